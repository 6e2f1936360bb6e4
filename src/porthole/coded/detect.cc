#include "porthole/coded/detect.h"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <optional>
#include <opencv2/imgproc.hpp>

#include "porthole/core/error.h"
#include "porthole/core/hartley.h"

namespace porthole::coded {
namespace {

constexpr double kTwoPi = 2 * std::numbers::pi;
constexpr int kSamplesPerBit = 12;

// The dot's image as an affine image of the unit circle: x = c + A (ρ cos t, ρ sin t).
struct Frame {
  Eigen::Vector2d c{0, 0};
  Eigen::Matrix2d a = Eigen::Matrix2d::Identity();
  Eigen::Vector2d At(double rho, double t) const { return c + a * Eigen::Vector2d(rho * std::cos(t), rho * std::sin(t)); }
  double Minor() const { return Eigen::JacobiSVD<Eigen::Matrix2d>(a).singularValues()(1); }
  double Major() const { return Eigen::JacobiSVD<Eigen::Matrix2d>(a).singularValues()(0); }
};

// cv::fitEllipseDirect, or nullopt when OpenCV refuses the points or returns no ellipse.
std::optional<cv::RotatedRect> FitEllipse(const cv::Mat& points) {
  try {
    const cv::RotatedRect r = cv::fitEllipseDirect(points);
    if (std::isfinite(r.center.x) && std::isfinite(r.center.y) && r.size.width > 0 && r.size.height > 0 &&
        std::isfinite(r.size.width) && std::isfinite(r.size.height) && std::isfinite(r.angle)) {
      return r;
    }
  } catch (const cv::Exception&) {
  }
  return std::nullopt;
}

Frame FromRect(const cv::RotatedRect& r, const Eigen::Vector2d& offset) {
  const double th = r.angle * std::numbers::pi / 180;
  Eigen::Matrix2d rot;
  rot << std::cos(th), -std::sin(th), std::sin(th), std::cos(th);
  Frame f;
  f.c = offset + Eigen::Vector2d(r.center.x, r.center.y);
  f.a = rot * Eigen::Vector2d(r.size.width / 2.0, r.size.height / 2.0).asDiagonal();
  return f;
}

// Bilinear sample of a CV_32F image; nullopt outside the pixel centres' hull.
std::optional<double> Sample(const cv::Mat& g, const Eigen::Vector2d& p) {
  if (!(p.x() >= 0 && p.y() >= 0 && p.x() <= g.cols - 1 && p.y() <= g.rows - 1)) return std::nullopt;
  const int x0 = std::min(static_cast<int>(p.x()), g.cols - 2), y0 = std::min(static_cast<int>(p.y()), g.rows - 2);
  const double fx = p.x() - x0, fy = p.y() - y0;
  const float* r0 = g.ptr<float>(y0);
  const float* r1 = g.ptr<float>(y0 + 1);
  return (1 - fy) * ((1 - fx) * r0[x0] + fx * r0[x0 + 1]) + fy * ((1 - fx) * r1[x0] + fx * r1[x0 + 1]);
}

struct Levels {
  double dot = 0, gap = 0;
};

enum class Outcome { kOk, kPartial, kNoRing, kUnclear, kImpossible, kRefineFailed, kNotElliptic };

// Mean level inside the dot (ρ ≤ 0.45) and median level of the gap between dot and ring.
std::optional<Levels> MeasureLevels(const cv::Mat& g, const Frame& f, double gap_lo, double gap_hi, bool* partial) {
  std::vector<double> in, gap;
  for (int k = 0; k < 48; ++k) {
    const double t = kTwoPi * k / 48;
    for (double rho : {0.0, 0.15, 0.3, 0.45}) {
      const auto v = Sample(g, f.At(rho, t));
      if (!v) return *partial = true, std::nullopt;
      in.push_back(*v);
    }
    for (int j = 0; j < 3; ++j) {
      const auto v = Sample(g, f.At(gap_lo + (gap_hi - gap_lo) * j / 2.0, t));
      if (!v) return *partial = true, std::nullopt;
      gap.push_back(*v);
    }
  }
  std::nth_element(in.begin(), in.begin() + in.size() / 2, in.end());
  std::nth_element(gap.begin(), gap.begin() + gap.size() / 2, gap.end());
  return Levels{in[in.size() / 2], gap[gap.size() / 2]};
}

// Edge points where rays of the frame cross the mean of the two levels; refits the ellipse.
Outcome Refine(const cv::Mat& g, Frame* f, Levels* lv, double gap_lo, double gap_hi, double min_contrast) {
  for (int iter = 0; iter < 3; ++iter) {
    bool partial = false;
    const auto levels = MeasureLevels(g, *f, gap_lo, gap_hi, &partial);
    if (!levels) return Outcome::kPartial;
    *lv = *levels;
    if (std::abs(lv->dot - lv->gap) < min_contrast) return Outcome::kNoRing;
    const int rays = std::clamp(static_cast<int>(std::lround(2 * kTwoPi * f->Major())), 48, 720);
    std::vector<cv::Point2f> edge;
    edge.reserve(rays);
    for (int k = 0; k < rays; ++k) {
      const double t = kTwoPi * (k + 0.5) / rays;
      const Eigen::Vector2d u(std::cos(t), std::sin(t));
      const double len = (f->a * u).norm();
      // The edge by the profile's integral: for a step blurred by any symmetric kernel (pixel
      // area, bilinear interpolation, defocus) the area under the normalised profile from ρ0 to
      // ρ1 is the step's distance from ρ0, whatever the blur and the pixel phase.
      const double r0 = 0.55, r1 = 1.45;
      const int n = std::max(8, static_cast<int>(std::ceil((r1 - r0) * len / 0.2)));
      double area = 0;
      for (int i = 0; i <= n; ++i) {
        const auto v = Sample(g, f->c + f->a * u * (r0 + (r1 - r0) * i / n));
        if (!v) return Outcome::kPartial;
        const double w = (i == 0 || i == n) ? 0.5 : 1.0;
        area += w * (*v - lv->gap) / (lv->dot - lv->gap);
      }
      const double re = r0 + area * (r1 - r0) / n;
      if (!(re > r0 + 0.05 && re < r1 - 0.05)) continue;  // no edge in the window
      const Eigen::Vector2d p = f->a * u * re;  // relative to the frame's centre
      edge.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
    }
    if (edge.size() < 0.8 * rays) return Outcome::kRefineFailed;
    const auto r = FitEllipse(cv::Mat(edge));
    if (!r) return Outcome::kRefineFailed;
    const Frame next = FromRect(*r, f->c);
    // A dot's edge is an ellipse: points off it by more than 5 % of the radius (a ring segment,
    // a blot, two touching dots) end the candidate.
    const Eigen::Matrix2d inv = next.a.inverse();
    double ss = 0;
    for (const auto& p : edge) {
      const double d = (inv * (Eigen::Vector2d(p.x, p.y) + f->c - next.c)).norm() - 1;
      ss += d * d;
    }
    if (std::sqrt(ss / edge.size()) > 0.05) return Outcome::kNotElliptic;
    if ((next.c - f->c).norm() > 0.5 * f->Minor() || next.Minor() < 0.5 * f->Minor()) return Outcome::kRefineFailed;
    *f = next;
  }
  return Outcome::kOk;
}

// Reads the ring; returns its raw code (first bit read = most significant) and the clarity, and
// whether the gap between dot and ring is inside the image and empty (`gap_clean`).
Outcome ReadRing(const cv::Mat& g, const Frame& f, const Levels& lv, const CodedDetectOptions& o, uint32_t* code,
                 double* clarity, bool* gap_clean) {
  const RingRadii ring = Ring(o.profile);
  const int m = o.bits * kSamplesPerBit;
  auto norm = [&](double v) { return (v - lv.gap) / (lv.dot - lv.gap); };  // 0 gap/background, 1 ink
  int dirty_gap = 0, dirty_out = 0;
  *gap_clean = false;
  for (int k = 0; k < m; ++k) {
    const auto gap = Sample(g, f.At(0.5 * (1 + ring.inner), kTwoPi * k / m));
    if (!gap) return Outcome::kPartial;
    dirty_gap += norm(*gap) > 0.25;
  }
  *gap_clean = dirty_gap == 0;
  std::vector<double> s(m, 0.0);
  for (int k = 0; k < m; ++k) {
    const double t = kTwoPi * k / m;
    for (double q : {0.3, 0.5, 0.7}) {
      const auto v = Sample(g, f.At(ring.inner + q * (ring.outer - ring.inner), t));
      if (!v) return Outcome::kPartial;
      s[k] += norm(*v) / 3;
    }
    const auto out = Sample(g, f.At(ring.outer + 0.35, t));
    if (!out) return Outcome::kPartial;
    dirty_out += norm(*out) > 0.25;
  }
  if (dirty_gap > 0 || dirty_out > m / 10) return Outcome::kNoRing;
  double best = -1;
  uint32_t best_code = 0;
  for (int phase = 0; phase < kSamplesPerBit; ++phase) {
    uint32_t c = 0;
    double worst = 1;
    for (int j = 0; j < o.bits; ++j) {
      double mean = 0;
      for (int q = 2; q < kSamplesPerBit - 2; ++q) mean += s[(phase + j * kSamplesPerBit + q) % m];
      mean /= kSamplesPerBit - 4;
      worst = std::min(worst, std::abs(mean - 0.5));
      if (mean > 0.5) c |= uint32_t{1} << (o.bits - 1 - j);
    }
    if (worst > best) {
      best = worst;
      best_code = c;
    }
  }
  *code = best_code;
  *clarity = best;
  if (best_code == 0) return Outcome::kNoRing;
  if (best < 0.5 - o.min_bit_clarity) return Outcome::kUnclear;
  return Outcome::kOk;
}

}  // namespace

std::string DetectionCounts::ToString() const {
  return fmt::format("{} candidates: {} decoded; skipped {} partial, {} without a ring, {} unclear, {} impossible "
                     "codes, {} duplicate IDs, {} not elliptic, {} refinement failures{}",
                     candidates, decoded, partial, no_ring, unclear, impossible, duplicate, not_elliptic, refine_failed,
                     over_limit > 0 ? fmt::format("; {} more beyond the limit of candidates per image, not tried", over_limit)
                                    : std::string());
}

CodedDetection DetectCodedTargets(const cv::Mat& gray_in, const CodedDetectOptions& o) {
  ValidateBits(o.bits, "bits");
  if (o.max_candidates < 0) throw InvalidInput("max_candidates", "must be >= 0");
  if (gray_in.empty() || gray_in.channels() != 1) throw InvalidInput("image", "expected a non-empty grey image");
  cv::Mat g;
  const int depth = gray_in.depth();
  const double full = depth == CV_8U ? 255.0 : depth == CV_16U ? 65535.0 : 1.0;
  gray_in.convertTo(g, CV_32F, 1.0 / full);
  CodedDetection out;
  if (g.cols < 8 || g.rows < 8) return out;

  // 1. Candidates: blobs darker / lighter than their neighbourhood.
  cv::Mat mean;
  const int block = std::clamp(std::min(g.cols, g.rows) / 6 | 1, 31, 401);
  cv::blur(g, mean, cv::Size(block, block), cv::Point(-1, -1), cv::BORDER_REPLICATE);
  const RingRadii ring = Ring(o.profile);
  const double gap_lo = 1.3, gap_hi = std::min(1.6, 0.5 * (1 + ring.inner) + 0.1);
  std::vector<Frame> candidates;
  for (int polarity = 0; polarity < 2; ++polarity) {
    cv::Mat mask = polarity == 0 ? (g < mean - o.min_contrast / 2) : (g > mean + o.min_contrast / 2);
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(mask, contours, cv::RETR_LIST, cv::CHAIN_APPROX_NONE);
    for (const auto& ct : contours) {
      if (ct.size() < 8) continue;
      const double area = cv::contourArea(ct);
      const double min_area = std::numbers::pi * std::pow(o.min_dot_diameter_px / 2, 2) / o.max_axis_ratio;
      if (area < 0.5 * min_area) continue;
      const auto fit = FitEllipse(cv::Mat(ct));
      if (!fit) continue;
      const cv::RotatedRect& r = *fit;
      const double a = std::max(r.size.width, r.size.height) / 2, b = std::min(r.size.width, r.size.height) / 2;
      if (!(b > 0) || 2 * a < o.min_dot_diameter_px || a / b > o.max_axis_ratio) continue;
      const double fill = area / (std::numbers::pi * a * b);
      if (fill < 0.7 || fill > 1.2) continue;
      if (static_cast<int>(candidates.size()) >= o.max_candidates) {  // checked first: the search below is linear
        ++out.counts.over_limit;
        continue;
      }
      const Frame f = FromRect(r, Eigen::Vector2d::Zero());
      bool seen = false;
      for (const auto& c : candidates) seen = seen || (c.c - f.c).norm() < 0.3 * b;
      if (!seen) candidates.push_back(f);
    }
  }
  out.counts.candidates = static_cast<int>(candidates.size());

  // 2–3. Refine and decode each candidate.
  auto ellipse = [](const Frame& f, const Levels& lv) {
    CodedTarget t;
    t.centre_px = f.c;
    Eigen::JacobiSVD<Eigen::Matrix2d> svd(f.a, Eigen::ComputeFullU);
    t.semi_major_px = svd.singularValues()(0);
    t.semi_minor_px = svd.singularValues()(1);
    t.angle_rad = std::atan2(svd.matrixU()(1, 0), svd.matrixU()(0, 0));
    t.dark_on_light = lv.dot < lv.gap;
    return t;
  };
  std::map<int, std::vector<CodedTarget>> by_id;
  for (Frame f : candidates) {
    Levels lv;
    Outcome r = Refine(g, &f, &lv, gap_lo, gap_hi, o.min_contrast);
    uint32_t code = 0;
    double clarity = 0;
    bool gap_clean = false;
    if (r == Outcome::kOk) r = ReadRing(g, f, lv, o, &code, &clarity, &gap_clean);
    int id = 0;
    if (r == Outcome::kOk) {
      id = IdOfRing(o.profile, o.bits, code);
      if (id == 0) r = Outcome::kImpossible;
    }
    if (o.uncoded_dots && gap_clean && r != Outcome::kOk) {
      // A dot with an empty gap that gave no ID (ReadRing set gap_clean, so the refinement held).
      const CodedTarget dot = ellipse(f, lv);
      const bool seen = std::any_of(out.dots.begin(), out.dots.end(), [&](const CodedTarget& d) {
        return (d.centre_px - dot.centre_px).norm() < 0.5 * d.semi_minor_px;
      });
      if (!seen) out.dots.push_back(dot);
    }
    switch (r) {
      case Outcome::kOk: break;
      case Outcome::kPartial: ++out.counts.partial; continue;
      case Outcome::kNoRing: ++out.counts.no_ring; continue;
      case Outcome::kUnclear: ++out.counts.unclear; continue;
      case Outcome::kImpossible: ++out.counts.impossible; continue;
      case Outcome::kRefineFailed: ++out.counts.refine_failed; continue;
      case Outcome::kNotElliptic: ++out.counts.not_elliptic; continue;
    }
    CodedTarget t = ellipse(f, lv);
    t.id = id;
    t.clarity = clarity;
    by_id[id].push_back(t);
  }
  for (auto& [id, list] : by_id) {
    // The same target found twice (two candidate blobs of one dot) is one; two places are none.
    const auto& first = list.front();
    const bool one_place = std::all_of(list.begin(), list.end(), [&](const CodedTarget& t) {
      return (t.centre_px - first.centre_px).norm() < 0.5 * first.semi_minor_px;
    });
    if (!one_place) {
      out.counts.duplicate += static_cast<int>(list.size());
      continue;
    }
    out.targets.push_back(first);
  }
  out.counts.decoded = static_cast<int>(out.targets.size());
  return out;
}

}  // namespace porthole::coded

// ---- Uncoded dots of a known field ----

namespace porthole::coded {
namespace {

// Nearest-point queries on a uniform grid of cells (the points are image positions).
class PointGrid {
 public:
  explicit PointGrid(std::vector<Eigen::Vector2d> pts) : pts_(std::move(pts)) {
    if (pts_.empty()) return;
    lo_ = pts_[0];
    Eigen::Vector2d hi = pts_[0];
    for (const auto& p : pts_) {
      lo_ = lo_.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    const Eigen::Vector2d ext = hi - lo_;
    const double n = static_cast<double>(pts_.size());
    cell_ = std::max({std::sqrt(ext.x() * ext.y() / n), ext.maxCoeff() / (4 * n), 1e-6});
    nx_ = static_cast<int>(ext.x() / cell_) + 1;
    ny_ = static_cast<int>(ext.y() / cell_) + 1;
    cells_.resize(static_cast<std::size_t>(nx_) * ny_);
    for (int i = 0; i < static_cast<int>(pts_.size()); ++i) {
      const auto [cx, cy] = Cell(pts_[i]);
      cells_[static_cast<std::size_t>(cy) * nx_ + cx].push_back(i);
    }
  }

  // Up to k points nearest to q within max_dist (distance, index), nearest first; `skip` and
  // `skip2` excluded.
  std::vector<std::pair<double, int>> Nearest(const Eigen::Vector2d& q, int k, double max_dist, int skip = -1,
                                              int skip2 = -1) const {
    std::vector<std::pair<double, int>> best;
    if (pts_.empty() || k <= 0) return best;
    const double fx = std::floor((q.x() - lo_.x()) / cell_), fy = std::floor((q.y() - lo_.y()) / cell_);
    if (!(std::abs(fx) < 1e8 && std::abs(fy) < 1e8)) return best;  // far outside (or not finite)
    const int cx = static_cast<int>(fx), cy = static_cast<int>(fy);
    auto visit = [&](int x, int y) {
      if (x < 0 || y < 0 || x >= nx_ || y >= ny_) return;
      for (int i : cells_[static_cast<std::size_t>(y) * nx_ + x]) {
        const double d = (pts_[i] - q).norm();
        if (i == skip || i == skip2 || d > max_dist) continue;
        if (static_cast<int>(best.size()) == k && d >= best.back().first) continue;
        best.insert(std::upper_bound(best.begin(), best.end(), std::make_pair(d, i)), {d, i});
        if (static_cast<int>(best.size()) > k) best.pop_back();
      }
    };
    // Ring r holds the cells at Chebyshev distance r from q's cell: none of its points is nearer
    // than (r − 1) cells.
    const int rings = std::max({cx + 1, nx_ - cx, cy + 1, ny_ - cy});
    for (int r = 0; r <= rings; ++r) {
      const double near = (r - 1) * cell_;
      if (near > max_dist || (static_cast<int>(best.size()) == k && near > best.back().first)) break;
      if (r == 0) {
        visit(cx, cy);
        continue;
      }
      for (int x = std::max(cx - r, 0); x <= std::min(cx + r, nx_ - 1); ++x) {
        visit(x, cy - r);
        visit(x, cy + r);
      }
      for (int y = std::max(cy - r + 1, 0); y <= std::min(cy + r - 1, ny_ - 1); ++y) {
        visit(cx - r, y);
        visit(cx + r, y);
      }
    }
    return best;
  }

 private:
  std::pair<int, int> Cell(const Eigen::Vector2d& p) const {
    return {std::clamp(static_cast<int>((p.x() - lo_.x()) / cell_), 0, nx_ - 1),
            std::clamp(static_cast<int>((p.y() - lo_.y()) / cell_), 0, ny_ - 1)};
  }
  std::vector<Eigen::Vector2d> pts_;
  Eigen::Vector2d lo_{0, 0};
  double cell_ = 1;
  int nx_ = 0, ny_ = 0;
  std::vector<std::vector<int>> cells_;
};

// The linear (DLT) fit of x_image ~ M x_field, M of shape 3 × (D + 1), both sides normalised.
template <int D>
std::optional<Eigen::Matrix<double, 3, D + 1>> FitProjective(const std::vector<Eigen::Matrix<double, D, 1>>& xs,
                                                             const std::vector<Eigen::Vector2d>& uvs) {
  constexpr int kN = 3 * (D + 1);
  const auto tx = HartleyNormaliser<D>(xs);
  const auto tu = HartleyNormaliser<2>(uvs);
  Eigen::Matrix<double, kN, kN> ata = Eigen::Matrix<double, kN, kN>::Zero();
  for (std::size_t i = 0; i < xs.size(); ++i) {
    const Eigen::Matrix<double, D + 1, 1> x = tx * xs[i].homogeneous();
    const Eigen::Vector3d u = tu * uvs[i].homogeneous();
    Eigen::Matrix<double, 2, kN> rows = Eigen::Matrix<double, 2, kN>::Zero();
    rows.template block<1, D + 1>(0, 0) = -x.transpose();
    rows.template block<1, D + 1>(0, 2 * (D + 1)) = u.x() * x.transpose();
    rows.template block<1, D + 1>(1, D + 1) = -x.transpose();
    rows.template block<1, D + 1>(1, 2 * (D + 1)) = u.y() * x.transpose();
    ata += rows.transpose() * rows;
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, kN, kN>> es(ata);
  if (es.info() != Eigen::Success) return std::nullopt;
  const Eigen::Matrix<double, kN, 1> h = es.eigenvectors().col(0);
  Eigen::Matrix<double, 3, D + 1> m;
  for (int r = 0; r < 3; ++r) m.row(r) = h.template segment<D + 1>(r * (D + 1)).transpose();
  Eigen::Matrix<double, 3, D + 1> out = tu.inverse() * m * tx;
  if (!out.allFinite() || !(out.norm() > 0)) return std::nullopt;
  return Eigen::Matrix<double, 3, D + 1>(out / out.norm());
}

// The field mapped into the image: pixels ~ p (X, 1). From a homography when the known points are
// coplanar (p = H · plane coordinates; only points on that plane are predicted), else a DLT.
struct FieldMap {
  Eigen::Matrix<double, 3, 4> p = Eigen::Matrix<double, 3, 4>::Zero();
  double sign = 1;                   // of the third coordinate in front of the camera
  bool planar = false;
  Eigen::Vector3d plane_point{0, 0, 0}, plane_normal{0, 0, 1};
  double plane_tolerance_mm = 0;

  std::optional<Eigen::Vector2d> ProjectAny(const Eigen::Vector3d& x) const {
    const Eigen::Vector3d h = p * x.homogeneous();
    if (!(h.z() * sign > 0)) return std::nullopt;
    return Eigen::Vector2d(h.head<2>() / h.z());
  }
  std::optional<Eigen::Vector2d> Project(const Eigen::Vector3d& x) const {
    if (planar && std::abs(plane_normal.dot(x - plane_point)) > plane_tolerance_mm) return std::nullopt;
    return ProjectAny(x);
  }
  // The image size (√ of the semi-axes' product, px) of a dot of radius r at x, parallel to the
  // field's XY plane: r √|det ∂(u, v)/∂(X, Y)|.
  std::optional<double> DotSize(const Eigen::Vector3d& x, double r) const {
    const auto xp = ProjectAny(x + Eigen::Vector3d(r, 0, 0)), xm = ProjectAny(x - Eigen::Vector3d(r, 0, 0));
    const auto yp = ProjectAny(x + Eigen::Vector3d(0, r, 0)), ym = ProjectAny(x - Eigen::Vector3d(0, r, 0));
    if (!xp || !xm || !yp || !ym) return std::nullopt;
    Eigen::Matrix2d j;
    j << (*xp - *xm) / 2, (*yp - *ym) / 2;  // per r
    const double s = std::sqrt(std::abs(j.determinant()));
    return s > 0 ? std::optional<double>(s) : std::nullopt;
  }
};

std::optional<FieldMap> FitFieldMap(const std::vector<Eigen::Vector3d>& xs, const std::vector<Eigen::Vector2d>& uvs) {
  const std::size_t n = xs.size();
  if (n < 4) return std::nullopt;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& x : xs) c += x;
  c /= static_cast<double>(n);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  double extent = 0;
  for (const auto& x : xs) {
    cov += (x - c) * (x - c).transpose();
    extent = std::max(extent, (x - c).norm());
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov / static_cast<double>(n));
  const Eigen::Vector3d normal = es.eigenvectors().col(0);
  if (!(extent > 0) || !(es.eigenvalues()(1) > 1e-6 * extent * extent)) return std::nullopt;  // collinear
  double thickness = 0;
  for (const auto& x : xs) thickness = std::max(thickness, std::abs(normal.dot(x - c)));
  FieldMap m;
  if (thickness <= 2e-3 * extent || n < 6) {
    m.planar = true;
    m.plane_point = c;
    m.plane_normal = normal;
    m.plane_tolerance_mm = std::max(2e-3 * extent, 0.01);
    const Eigen::Vector3d e1 = es.eigenvectors().col(2), e2 = es.eigenvectors().col(1);
    std::vector<Eigen::Vector2d> ab;
    std::vector<Eigen::Vector2d> uv_in;
    for (std::size_t i = 0; i < n; ++i) {
      if (std::abs(normal.dot(xs[i] - c)) > m.plane_tolerance_mm) continue;
      ab.emplace_back(e1.dot(xs[i] - c), e2.dot(xs[i] - c));
      uv_in.push_back(uvs[i]);
    }
    if (ab.size() < 4) return std::nullopt;
    const auto h = FitProjective<2>(ab, uv_in);
    if (!h) return std::nullopt;
    Eigen::Matrix<double, 3, 4> to_plane = Eigen::Matrix<double, 3, 4>::Zero();
    to_plane.block<1, 3>(0, 0) = e1.transpose();
    to_plane(0, 3) = -e1.dot(c);
    to_plane.block<1, 3>(1, 0) = e2.transpose();
    to_plane(1, 3) = -e2.dot(c);
    to_plane(2, 3) = 1;
    m.p = *h * to_plane;
  } else {
    const auto p = FitProjective<3>(xs, uvs);
    if (!p) return std::nullopt;
    m.p = *p;
  }
  int front = 0;
  for (const auto& x : xs) front += (m.p * x.homogeneous()).z() > 0 ? 1 : -1;
  m.sign = front >= 0 ? 1 : -1;
  return m;
}

// The map's local correction at the raw prediction q from known points nearby (raw projection
// m, residual e = observed − m, size ratio rho = measured / mapped size), weighted by
// 1 / (d² + (s/2)²): an affine fit of the residuals when the neighbours span two directions
// (their weighted scatter's smaller axis ≥ s/4), else their weighted mean.
struct Correction {
  Eigen::Vector2d shift{0, 0};
  double size_ratio = 1;
};

Correction LocalCorrection(const Eigen::Vector2d& q, double s, const std::vector<std::pair<double, int>>& near,
                           const std::vector<Eigen::Vector2d>& raw, const std::vector<Eigen::Vector2d>& residual,
                           const std::vector<double>& rho) {
  Correction c;
  double wsum = 0, rsum = 0;
  Eigen::Vector2d zmean = Eigen::Vector2d::Zero(), emean = Eigen::Vector2d::Zero();
  std::vector<double> w(near.size());
  for (std::size_t k = 0; k < near.size(); ++k) {
    const int i = near[k].second;
    w[k] = 1 / (near[k].first * near[k].first + 0.25 * s * s);
    wsum += w[k];
    zmean += w[k] * (raw[i] - q);
    emean += w[k] * residual[i];
    rsum += w[k] * rho[i];
  }
  zmean /= wsum;
  c.shift = emean / wsum;
  c.size_ratio = rsum / wsum;
  if (near.size() < 4) return c;
  Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
  Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
  Eigen::Matrix<double, 3, 2> atb = Eigen::Matrix<double, 3, 2>::Zero();
  for (std::size_t k = 0; k < near.size(); ++k) {
    const int i = near[k].second;
    const Eigen::Vector2d z = raw[i] - q;
    scatter += w[k] * (z - zmean) * (z - zmean).transpose();
    const Eigen::Vector3d a(1, z.x(), z.y());
    ata += w[k] * a * a.transpose();
    atb += w[k] * a * residual[i].transpose();
  }
  scatter /= wsum;
  if (Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(scatter).eigenvalues()(0) < 0.0625 * s * s) return c;
  const Eigen::Matrix<double, 3, 2> coef = ata.ldlt().solve(atb);
  if (coef.allFinite()) c.shift = coef.row(0).transpose();
  return c;
}

// A point of the field whose image is known: a decoded target or a matched dot.
struct Known {
  int field_index;
  Eigen::Vector2d uv;   // measured centre, px
  double size_px;       // √(semi-axes product) of its image
};

// The field mapped from the known points, with what the local predictions need: the raw
// projection of every field point (for the local spacing) and, at each known point, the map's
// residual and its size ratio (measured / mapped).
struct Mapping {
  FieldMap map;
  std::vector<Eigen::Vector2d> field_uv;  // raw projections of the projectable field points
  std::vector<int> field_at;              // per field point: index in field_uv, or −1
  std::vector<Eigen::Vector2d> raw, residual;
  std::vector<double> rho;
  std::vector<int> raw_of_known;          // per known point: index in raw, or −1
  PointGrid spacing{{}}, near_known{{}};
};

std::optional<Mapping> MapField(const std::vector<Known>& known, const std::vector<PlacedTarget>& field, double r) {
  std::vector<Eigen::Vector3d> xs;
  std::vector<Eigen::Vector2d> uvs;
  for (const auto& k : known) {
    xs.push_back(field[k.field_index].xyz_mm);
    uvs.push_back(k.uv);
  }
  const auto map = FitFieldMap(xs, uvs);
  if (!map) return std::nullopt;
  Mapping m;
  m.map = *map;
  m.field_at.assign(field.size(), -1);
  for (std::size_t i = 0; i < field.size(); ++i) {
    if (const auto uv = m.map.Project(field[i].xyz_mm)) {
      m.field_at[i] = static_cast<int>(m.field_uv.size());
      m.field_uv.push_back(*uv);
    }
  }
  for (const auto& k : known) {
    const auto uv = m.map.ProjectAny(field[k.field_index].xyz_mm);
    const auto size = m.map.DotSize(field[k.field_index].xyz_mm, r);
    m.raw_of_known.push_back(uv && size ? static_cast<int>(m.raw.size()) : -1);
    if (!uv || !size) continue;
    m.raw.push_back(*uv);
    m.residual.push_back(k.uv - *uv);
    m.rho.push_back(k.size_px / *size);
  }
  m.spacing = PointGrid(m.field_uv);
  m.near_known = PointGrid(m.raw);
  return m;
}

// Where field point i should image, from the map and its known neighbours (`skip`, `skip2`: raw
// indices left out, for the leave-one-out check).
struct Prediction {
  Eigen::Vector2d uv{0, 0};
  double spacing_px = 0;       // to the nearest other projected field point
  double support_px = 0;       // to the nearest known point used
  double size_ratio = 1;       // measured / mapped size, from the neighbours
  std::vector<std::pair<double, int>> near;  // the known points used (distance, raw index)
};

std::optional<Prediction> Predict(const Mapping& m, int i, int neighbours, int skip = -1, int skip2 = -1) {
  if (m.field_at[i] < 0) return std::nullopt;
  const Eigen::Vector2d q = m.field_uv[m.field_at[i]];
  const auto next = m.spacing.Nearest(q, 1, std::numeric_limits<double>::infinity(), m.field_at[i]);
  if (next.empty() || !(next[0].first > 0)) return std::nullopt;
  Prediction p;
  p.spacing_px = next[0].first;
  p.near = m.near_known.Nearest(q, neighbours, std::numeric_limits<double>::infinity(), skip, skip2);
  if (p.near.empty()) return std::nullopt;
  p.support_px = p.near[0].first;
  const Correction c = LocalCorrection(q, p.spacing_px, p.near, m.raw, m.residual, m.rho);
  p.uv = q + c.shift;
  p.size_ratio = c.size_ratio;
  return p;
}

}  // namespace

bool IsUncodedId(Profile profile, int bits, int id) {
  return id > static_cast<int>(Codes(profile, bits).size());
}

std::string UncodedCounts::ToString() const {
  return fmt::format("{} uncoded dots in view (from {} coded targets): {} matched; {} not found, {} ambiguous, "
                     "{} of the wrong size or polarity, {} off their neighbours' pattern",
                     in_view, coded, matched, not_found, ambiguous, rejected, inconsistent);
}

UncodedMatch MatchUncodedDots(const CodedDetection& detection, const std::vector<PlacedTarget>& field,
                              double dot_radius_mm, const CodedDetectOptions& detect, int width_px, int height_px,
                              const UncodedMatchOptions& o) {
  ValidateBits(detect.bits, "bits");
  if (!(dot_radius_mm > 0)) throw InvalidInput("dot radius", "must be > 0 mm");
  if (!(o.tolerance > 0 && o.tolerance <= 0.5)) throw InvalidInput("tolerance", "must be in (0, 0.5] of the spacing");
  if (!(o.ambiguity_ratio >= 1)) throw InvalidInput("ambiguity_ratio", "must be >= 1");
  if (!(o.size_tolerance > 0)) throw InvalidInput("size_tolerance", "must be > 0");
  if (o.neighbours < 1) throw InvalidInput("neighbours", "must be >= 1");
  if (!(o.reach > 0 && o.max_reach >= o.reach)) throw InvalidInput("reach", "must be > 0 and <= max_reach");
  if (!(o.verify_floor >= 0 && o.verify_factor > 0)) throw InvalidInput("verify", "floor >= 0 and factor > 0");
  UncodedMatch out;
  std::vector<int> uncoded;
  std::map<int, int> index;  // field ID → position in `field`
  for (int i = 0; i < static_cast<int>(field.size()); ++i) {
    index[field[i].id] = i;
    if (IsUncodedId(detect.profile, detect.bits, field[i].id)) uncoded.push_back(i);
  }
  std::vector<Known> known;
  int dark = 0;
  for (const auto& t : detection.targets) {
    const auto it = index.find(t.id);
    if (it == index.end() || IsUncodedId(detect.profile, detect.bits, t.id)) continue;
    known.push_back({it->second, t.centre_px, std::sqrt(t.semi_major_px * t.semi_minor_px)});
    dark += t.dark_on_light ? 1 : -1;
  }
  out.counts.coded = static_cast<int>(known.size());
  if (uncoded.empty() || known.size() < 4) return out;
  const bool dark_on_light = dark >= 0;
  const int n_coded = static_cast<int>(known.size());

  // Every detected dot, decoded targets first: a prediction is judged against all of them.
  const int n_targets = static_cast<int>(detection.targets.size());
  std::vector<Eigen::Vector2d> dot_uv;
  for (const auto& t : detection.targets) dot_uv.push_back(t.centre_px);
  for (const auto& d : detection.dots) dot_uv.push_back(d.centre_px);
  const PointGrid dots(dot_uv);
  std::vector<int> owner(detection.dots.size(), -1);  // field index a candidate was matched to

  enum class Status { kUnseen, kNotFound, kAmbiguous, kRejected, kMatched, kInconsistent };
  std::vector<Status> status(field.size(), Status::kUnseen);
  // Rounds: the tolerance starts at a third of its limit and the reach at its first value; a round
  // that adds nothing widens the tolerance, then the reach (the tolerance back to a third); a
  // round that adds dots starts again from the tightest.
  const double tight = o.tolerance / 3;
  double reach = o.reach, tolerance = tight;
  // (64 rounds at most in the tests; the cap bounds the work on any input.)
  for (int round = 0; round < 1000; ++round) {
    const auto m = MapField(known, field, dot_radius_mm);
    if (!m) break;
    struct Claim {
      int field_index, dot;
    };
    std::vector<Claim> claims;
    std::vector<int> claimed(detection.dots.size(), 0);
    for (int i : uncoded) {
      if (status[i] == Status::kMatched) continue;
      status[i] = Status::kUnseen;
      if (m->field_at[i] < 0) continue;
      const Eigen::Vector2d q = m->field_uv[m->field_at[i]];
      if (!(q.x() >= 0 && q.y() >= 0 && q.x() <= width_px - 1 && q.y() <= height_px - 1)) continue;
      status[i] = Status::kNotFound;
      const auto p = Predict(*m, i, o.neighbours);
      if (!p || p->support_px > reach * p->spacing_px) continue;  // out of reach this round
      const double limit = o.tolerance * p->spacing_px;
      const auto nd = dots.Nearest(p->uv, 2, o.ambiguity_ratio * limit);
      if (nd.empty() || nd[0].first > limit) continue;
      if (nd[0].second < n_targets || (nd.size() > 1 && nd[1].first <= std::max(o.ambiguity_ratio * nd[0].first, limit))) {
        status[i] = Status::kAmbiguous;  // a decoded target where a plain dot should be, or two dots
        continue;
      }
      const int cand = nd[0].second - n_targets;
      const CodedTarget& d = detection.dots[cand];
      const auto size = m->map.DotSize(field[i].xyz_mm, dot_radius_mm);
      if (!size || d.dark_on_light != dark_on_light ||
          std::abs(std::sqrt(d.semi_major_px * d.semi_minor_px) / (p->size_ratio * *size) - 1) > o.size_tolerance) {
        status[i] = Status::kRejected;
        continue;
      }
      if (owner[cand] >= 0) {
        status[i] = Status::kAmbiguous;  // already another ID's dot
        continue;
      }
      if (nd[0].first > tolerance * p->spacing_px) continue;  // not yet: wait for closer support
      claims.push_back({i, cand});
      ++claimed[cand];
    }
    int accepted = 0;
    for (const auto& c : claims) {
      if (claimed[c.dot] > 1) {  // one dot, two IDs: neither
        status[c.field_index] = Status::kAmbiguous;
        continue;
      }
      const CodedTarget& d = detection.dots[c.dot];
      status[c.field_index] = Status::kMatched;
      owner[c.dot] = c.field_index;
      known.push_back({c.field_index, d.centre_px, std::sqrt(d.semi_major_px * d.semi_minor_px)});
      ++accepted;
    }
    if (accepted > 0) {
      reach = o.reach;
      tolerance = tight;
    } else if (tolerance < o.tolerance) {
      tolerance = std::min(o.tolerance, 1.5 * tolerance);
    } else if (reach < o.max_reach) {
      reach = std::min(o.max_reach, 1.5 * reach);
      tolerance = tight;
    } else {
      break;
    }
  }

  // Leave-one-out check: each matched dot predicted from its neighbours without itself; it is
  // dropped when that misses it by more than verify_factor × the median miss of its neighbours,
  // each predicted without itself and without the dot (so a wrong dot does not excuse itself by
  // spoiling its neighbours' predictions), and by more than verify_floor of the spacing. Repeated
  // (up to 5 passes) while it drops dots: wrong dots side by side spoil each other's neighbours.
  for (int pass = 0; pass < 5 && known.size() > static_cast<std::size_t>(n_coded); ++pass) {
    const auto m = MapField(known, field, dot_radius_mm);
    if (!m) break;
    std::vector<int> known_of_raw(m->raw.size(), -1);
    for (std::size_t k = 0; k < known.size(); ++k) {
      if (m->raw_of_known[k] >= 0) known_of_raw[m->raw_of_known[k]] = static_cast<int>(k);
    }
    auto miss = [&](int k, int skip2) -> std::optional<std::pair<double, Prediction>> {
      const auto p = Predict(*m, known[k].field_index, o.neighbours, m->raw_of_known[k], skip2);
      if (!p) return std::nullopt;
      return std::make_pair((p->uv - known[k].uv).norm() / p->spacing_px, *p);
    };
    std::vector<bool> drop(known.size(), false);
    for (std::size_t k = n_coded; k < known.size(); ++k) {
      const int ri = m->raw_of_known[k];
      const auto own = ri >= 0 ? miss(static_cast<int>(k), -1) : std::nullopt;
      std::vector<double> around;
      if (own) {
        for (const auto& [dist, j] : own->second.near) {
          if (const auto e = miss(known_of_raw[j], ri)) around.push_back(e->first);
        }
      }
      bool keep = own && !around.empty();
      if (keep) {
        std::nth_element(around.begin(), around.begin() + around.size() / 2, around.end());
        keep = own->first <= std::max(o.verify_floor, o.verify_factor * around[around.size() / 2]);
      }
      drop[k] = !keep;
    }
    std::vector<Known> kept;
    for (std::size_t k = 0; k < known.size(); ++k) {
      if (!drop[k]) {
        kept.push_back(known[k]);
        continue;
      }
      const int i = known[k].field_index;
      status[i] = Status::kInconsistent;
      for (int& w : owner) {
        if (w == i) w = -1;
      }
    }
    if (kept.size() == known.size()) break;
    known = std::move(kept);
  }

  for (int i : uncoded) {
    switch (status[i]) {
      case Status::kUnseen: continue;
      case Status::kNotFound: ++out.counts.not_found; break;
      case Status::kAmbiguous: ++out.counts.ambiguous; break;
      case Status::kRejected: ++out.counts.rejected; break;
      case Status::kMatched: ++out.counts.matched; break;
      case Status::kInconsistent: ++out.counts.inconsistent; break;
    }
    ++out.counts.in_view;
  }
  for (std::size_t c = 0; c < owner.size(); ++c) {
    if (owner[c] < 0) continue;
    CodedTarget d = detection.dots[c];
    d.id = field[owner[c]].id;
    out.dots.push_back(d);
  }
  std::sort(out.dots.begin(), out.dots.end(), [](const CodedTarget& a, const CodedTarget& b) { return a.id < b.id; });
  return out;
}

}  // namespace porthole::coded
