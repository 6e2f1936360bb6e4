#include "porthole/coded/detect.h"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <optional>
#include <opencv2/imgproc.hpp>

#include "porthole/core/error.h"

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
                     "codes, {} duplicate IDs, {} not elliptic, {} refinement failures",
                     candidates, decoded, partial, no_ring, unclear, impossible, duplicate, not_elliptic, refine_failed);
}

CodedDetection DetectCodedTargets(const cv::Mat& gray_in, const CodedDetectOptions& o) {
  ValidateBits(o.bits, "bits");
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
