// Undistortion to a virtual pinhole (undistort.h, docs/undistort.md).
#include "porthole/undistort/undistort.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <thread>
#include <type_traits>

#include "porthole/core/error.h"
#include "porthole/measure/triangulate.h"

namespace porthole::undistort {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;
using Json = nlohmann::ordered_json;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Runs body(i) for i in [0, n) on `threads` threads (0: every core).
template <typename F>
void ParallelFor(int n, int threads, F body) {
  int t =
      threads > 0 ? threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  t = std::max(1, std::min(t, n));
  if (t == 1) {
    for (int i = 0; i < n; ++i) body(i);
    return;
  }
  std::atomic<int> next{0};
  std::vector<std::thread> pool;
  for (int k = 0; k < t; ++k) {
    pool.emplace_back([&] {
      for (int i = next++; i < n; i = next++) body(i);
    });
  }
  for (auto& th : pool) th.join();
}

// The z of the port's outer vertex: where the backward ray of the principal point leaves the port.
double VertexZ(const measure::RigCamera& c) {
  if (!c.shell) return 0;
  const auto r = measure::BackwardRay(c, c.camera.PrincipalPointPx());
  if (!r) throw InvalidInput("calibration", "the principal point's ray does not leave the port");
  return r->origin_mm.z();
}

// Depths (camera-frame z) from `near` to `far` working distance, n evenly in inverse depth.
std::vector<double> InverseSpaced(double near_z, double far_z, int n) {
  std::vector<double> z;
  for (int i = 0; i < n; ++i) {
    const double t = n == 1 ? 0.5 : static_cast<double>(i) / (n - 1);
    z.push_back(1.0 / ((1 - t) / near_z + t / far_z));
  }
  return z;
}

// Source pixels along the frame's four edges (every ~1 % of the side, corners included).
std::vector<Vector2d> EdgePixels(const camera::Sensor& s, std::vector<int>* side) {
  std::vector<Vector2d> px;
  const int n = 101;
  const double w = s.width_px - 1, h = s.height_px - 1;
  for (int i = 0; i < n; ++i) {
    const double a = static_cast<double>(i) / (n - 1);
    px.emplace_back(0, a * h), side->push_back(0);  // left
    px.emplace_back(w, a * h), side->push_back(1);  // right
    px.emplace_back(a * w, 0), side->push_back(2);  // top
    px.emplace_back(a * w, h), side->push_back(3);  // bottom
  }
  return px;
}

// The normalised pinhole coordinates of the scene a source pixel sees, averaged over `depths`
// (central: the lens's ray; rays beyond 80° off axis are taken at 80°, where a fisheye sees past
// what a pinhole can hold).
std::optional<Vector2d> Normalised(const measure::RigCamera& c, const Vector3d& centre,
                                   const std::vector<double>& depths, const Vector2d& s) {
  if (!c.shell) {
    auto d = c.camera.Unproject(s);
    if (!d) return std::nullopt;
    Vector3d v = d->normalized();
    const double min_z = std::cos(80.0 * M_PI / 180);
    if (v.z() < min_z) {
      const double xy = std::hypot(v.x(), v.y());
      if (!(xy > 0)) return std::nullopt;
      const double k = std::sin(80.0 * M_PI / 180) / xy;
      v = Vector3d(v.x() * k, v.y() * k, min_z);
    }
    return Vector2d(v.x() / v.z(), v.y() / v.z());
  }
  const auto r = measure::BackwardRay(c, s);
  if (!r || !(r->direction.z() > 0)) return std::nullopt;
  Vector2d sum(0, 0);
  for (double z : depths) {
    const Vector3d x = r->origin_mm + r->direction * ((z - r->origin_mm.z()) / r->direction.z());
    const Vector3d rel = x - centre;
    if (!(rel.z() > 0)) return std::nullopt;
    sum += Vector2d(rel.x() / rel.z(), rel.y() / rel.z());
  }
  return sum / static_cast<double>(depths.size());
}

// The centre of the pinhole that best fits the port's rays over `depths`: the point C minimising
// Σ |n_k − n̄|² over rays of a grid over the frame (n_k the normalised coordinates of the ray's
// point at depth k seen from C, n̄ their mean): the pinhole's parallax over the depths, to first
// order the residual / f. Coordinate-wise golden-section search, three rounds. Returns the RMS·f in
// px.
double FitCentre(const measure::RigCamera& c, const std::vector<double>& depths, Vector3d* centre,
                 double* at_pupil_px) {
  struct R {
    Vector3d o, d;
  };
  std::vector<R> rays;
  for (const Vector2d& s : camera::FramePixels(c.camera.sensor, 24, 16)) {
    const auto r = measure::BackwardRay(c, s);
    if (r && r->direction.z() > 0) rays.push_back({r->origin_mm, r->direction});
  }
  if (rays.size() < 4)
    throw InvalidInput("calibration", "too few pixels have a ray out through the port");
  const double f = c.camera.FocalLengthPx();
  const auto cost = [&](const Vector3d& ctr) {
    double sum = 0;
    int n = 0;
    for (const R& r : rays) {
      Vector2d mean(0, 0);
      std::vector<Vector2d> ns;
      for (double z : depths) {
        const Vector3d rel = r.o + r.d * ((z - r.o.z()) / r.d.z()) - ctr;
        if (!(rel.z() > 1e-6)) return std::numeric_limits<double>::infinity();
        ns.emplace_back(rel.x() / rel.z(), rel.y() / rel.z());
        mean += ns.back();
      }
      mean /= static_cast<double>(ns.size());
      for (const auto& v : ns) sum += (v - mean).squaredNorm(), ++n;
    }
    return sum / n;
  };
  Vector3d ctr = Vector3d::Zero();
  *at_pupil_px = f * std::sqrt(cost(ctr));
  const double near_z = *std::min_element(depths.begin(), depths.end());
  const double span[3] = {50, 50, std::min(200.0, 0.5 * near_z)};
  const double g = (std::sqrt(5.0) - 1) / 2;
  for (int round = 0; round < 3; ++round) {
    for (int axis = 0; axis < 3; ++axis) {
      const double w = span[axis] / (1 << round);
      double a = ctr[axis] - w, b = ctr[axis] + w;
      const auto at = [&](double v) {
        Vector3d p = ctr;
        p[axis] = v;
        return cost(p);
      };
      double x1 = b - g * (b - a), x2 = a + g * (b - a);
      double f1 = at(x1), f2 = at(x2);
      for (int it = 0; it < 60; ++it) {
        if (f1 < f2) {
          b = x2, x2 = x1, f2 = f1, x1 = b - g * (b - a), f1 = at(x1);
        } else {
          a = x1, x1 = x2, f1 = f2, x2 = a + g * (b - a), f2 = at(x2);
        }
      }
      const double best = 0.5 * (a + b);
      if (at(best) <= cost(ctr)) ctr[axis] = best;
    }
  }
  *centre = ctr;
  return f * std::sqrt(cost(ctr));
}

double Cubic(double p0, double p1, double p2, double p3, double t) {  // Catmull-Rom
  return p1 +
         0.5 * t * (p2 - p0 + t * (2 * p0 - 5 * p1 + 4 * p2 - p3 + t * (3 * (p1 - p2) + p3 - p0)));
}

}  // namespace

Interpolation InterpolationFromName(std::string_view name, const std::string& field) {
  for (auto i : {Interpolation::kNearest, Interpolation::kLinear, Interpolation::kCubic,
                 Interpolation::kLanczos}) {
    if (InterpolationName(i) == name) return i;
  }
  throw InvalidInput(
      field,
      fmt::format("unknown interpolation '{}' (known: nearest, linear, cubic, lanczos)", name));
}

std::string_view InterpolationName(Interpolation i) {
  switch (i) {
    case Interpolation::kNearest:
      return "nearest";
    case Interpolation::kLinear:
      return "linear";
    case Interpolation::kCubic:
      return "cubic";
    case Interpolation::kLanczos:
      return "lanczos";
  }
  return "linear";
}

void Validate(const UndistortOptions& o, const measure::RigCamera& c) {
  if (o.alpha && (!std::isfinite(*o.alpha) || *o.alpha < 0 || *o.alpha > 1)) {
    throw InvalidInput(
        "alpha", fmt::format("{} is outside [0, 1] (0: only valid pixels, 1: every source pixel)",
                             *o.alpha));
  }
  if (o.alpha && o.keep_focal) throw InvalidInput("keep_focal", "excludes `alpha`: choose one");
  if (o.threads < 0) throw InvalidInput("threads", "must be >= 0 (0: every core)");
  if (!c.shell) {
    if (!o.wd_mm.empty()) {
      throw InvalidInput(
          "wd_mm",
          "is for a calibration behind a port: a central camera has one pinhole at every depth");
    }
    return;
  }
  if (o.wd_mm.empty()) {
    throw InvalidInput(
        "wd_mm",
        "required for a refractive calibration (behind a port): the working distance in "
        "water, mm, or a range NEAR:FAR");
  }
  if (o.wd_mm.size() > 2) throw InvalidInput("wd_mm", "give one distance or a range NEAR:FAR");
  for (double w : o.wd_mm) {
    if (!std::isfinite(w) || !(w > 0))
      throw InvalidInput("wd_mm", "must be finite and > 0 (mm from the port's vertex)");
  }
  if (o.wd_mm.size() == 2 && !(o.wd_mm[0] < o.wd_mm[1])) {
    throw InvalidInput("wd_mm",
                       fmt::format("range {}:{}: NEAR must be below FAR", o.wd_mm[0], o.wd_mm[1]));
  }
}

Vector2d Pinhole::Project(const Vector3d& x) const {
  const Vector3d r = x - centre_mm;
  return {fx * r.x() / r.z() + cx, fy * r.y() / r.z() + cy};
}

Vector3d Pinhole::Ray(const Vector2d& q) const {
  return {(q.x() - cx) / fx, (q.y() - cy) / fy, 1.0};
}

std::vector<double> MapDepthsZ(const std::vector<double>& wd_mm, double vertex_z_mm) {
  if (wd_mm.size() == 1) return {wd_mm[0] + vertex_z_mm};
  return InverseSpaced(wd_mm[0] + vertex_z_mm, wd_mm[1] + vertex_z_mm, 5);
}

std::optional<Vector2d> Undistorter::SourcePixel(const Vector2d& q) const {
  const Vector3d d = pinhole.Ray(q);
  if (!refractive) return camera.camera.Project(d);
  Vector2d sum(0, 0);
  for (double z : depths_z_mm) {
    const auto s =
        measure::ProjectPoint(camera, pinhole.centre_mm + d * (z - pinhole.centre_mm.z()));
    if (!s) return std::nullopt;
    sum += *s;
  }
  return sum / static_cast<double>(depths_z_mm.size());
}

std::optional<Vector2d> Undistorter::OutputPixel(const Vector2d& s, const Vector2d& start) const {
  Vector2d q = start;
  const double h = 0.5;
  for (int it = 0; it < 30; ++it) {
    const auto m = SourcePixel(q);
    const auto mx0 = SourcePixel(q - Vector2d(h, 0)), mx1 = SourcePixel(q + Vector2d(h, 0));
    const auto my0 = SourcePixel(q - Vector2d(0, h)), my1 = SourcePixel(q + Vector2d(0, h));
    if (!m || !mx0 || !mx1 || !my0 || !my1) return std::nullopt;
    Eigen::Matrix2d j;
    j.col(0) = (*mx1 - *mx0) / (2 * h);
    j.col(1) = (*my1 - *my0) / (2 * h);
    const Vector2d step = j.inverse() * (*m - s);
    if (!step.allFinite()) return std::nullopt;
    q -= step;
    if (step.norm() < 1e-10) return q;
  }
  return std::nullopt;
}

std::optional<Vector2d> Undistorter::Residual(const Vector3d& x) const {
  const auto s = measure::ProjectPoint(camera, x);
  if (!s) return std::nullopt;
  const Vector2d q = pinhole.Project(x);
  const auto q2 = OutputPixel(*s, q);
  if (!q2) return std::nullopt;
  return *q2 - q;
}

Undistorter Prepare(const measure::RigCamera& camera_in, const UndistortOptions& options) {
  // Everything here is in the camera's own frame: a rig camera's cam_from_rig is dropped.
  measure::RigCamera cam = camera_in;
  cam.rotation_rad.setZero();
  cam.translation_mm.setZero();
  Validate(options, cam);
  Undistorter u;
  u.camera = cam;
  u.options = options;
  u.refractive = cam.shell.has_value();
  const camera::Sensor& sensor = cam.camera.sensor;
  std::vector<double> depths{1.0};
  if (u.refractive) {
    u.vertex_z_mm = VertexZ(cam);
    u.depths_z_mm = MapDepthsZ(options.wd_mm, u.vertex_z_mm);
    const std::vector<double> fit = options.wd_mm.size() == 1
                                        ? InverseSpaced(0.5 * options.wd_mm[0] + u.vertex_z_mm,
                                                        2 * options.wd_mm[0] + u.vertex_z_mm, 5)
                                        : u.depths_z_mm;
    u.centre_fit_rms_px = FitCentre(cam, fit, &u.pinhole.centre_mm, &u.centre_at_pupil_rms_px);
    depths = u.depths_z_mm;
  }
  Pinhole& p = u.pinhole;
  p.width_px = sensor.width_px;
  p.height_px = sensor.height_px;
  const Vector3d& ctr = p.centre_mm;
  if (options.keep_focal) {
    const Vector2d pp = cam.camera.PrincipalPointPx();
    if (!u.refractive) {
      p.fx = p.fy = cam.camera.FocalLengthPx();
      p.cx = pp.x(), p.cy = pp.y();
    } else {
      const double h = 2;
      const auto n0 = Normalised(cam, ctr, depths, pp);
      const auto nx0 = Normalised(cam, ctr, depths, pp - Vector2d(h, 0)),
                 nx1 = Normalised(cam, ctr, depths, pp + Vector2d(h, 0));
      const auto ny0 = Normalised(cam, ctr, depths, pp - Vector2d(0, h)),
                 ny1 = Normalised(cam, ctr, depths, pp + Vector2d(0, h));
      if (!n0 || !nx0 || !nx1 || !ny0 || !ny1)
        throw InvalidInput("calibration", "no ray through the principal point");
      const double f = 0.5 * (2 * h / (*nx1 - *nx0).norm() + 2 * h / (*ny1 - *ny0).norm());
      p.fx = p.fy = f;
      p.cx = pp.x() - f * n0->x();
      p.cy = pp.y() - f * n0->y();
    }
    return u;
  }
  // cv2.getOptimalNewCameraMatrix: the inner and outer rectangles of the undistorted frame.
  std::vector<int> side;
  const std::vector<Vector2d> edge = EdgePixels(sensor, &side);
  double in_l = -1e300, in_r = 1e300, in_t = -1e300, in_b = 1e300;
  double out_l = 1e300, out_r = -1e300, out_t = 1e300, out_b = -1e300;
  int good = 0;
  for (std::size_t i = 0; i < edge.size(); ++i) {
    const auto n = Normalised(cam, ctr, depths, edge[i]);
    if (!n) continue;
    ++good;
    out_l = std::min(out_l, n->x()), out_r = std::max(out_r, n->x());
    out_t = std::min(out_t, n->y()), out_b = std::max(out_b, n->y());
    if (side[i] == 0) in_l = std::max(in_l, n->x());
    if (side[i] == 1) in_r = std::min(in_r, n->x());
    if (side[i] == 2) in_t = std::max(in_t, n->y());
    if (side[i] == 3) in_b = std::min(in_b, n->y());
  }
  if (good < 8 || !(in_r > in_l) || !(in_b > in_t)) {
    throw InvalidInput(
        "alpha",
        "the frame's edges have no pinhole image (a fisheye's whole field, a port's rim "
        "across the frame): use `keep_focal`");
  }
  const double a = options.alpha.value_or(0.0);
  const double w1 = p.width_px - 1, h1 = p.height_px - 1;
  const double fx0 = w1 / (in_r - in_l), fy0 = h1 / (in_b - in_t), cx0 = -fx0 * in_l,
               cy0 = -fy0 * in_t;
  const double fx1 = w1 / (out_r - out_l), fy1 = h1 / (out_b - out_t), cx1 = -fx1 * out_l,
               cy1 = -fy1 * out_t;
  p.fx = fx0 * (1 - a) + fx1 * a;
  p.fy = fy0 * (1 - a) + fy1 * a;
  p.cx = cx0 * (1 - a) + cx1 * a;
  p.cy = cy0 * (1 - a) + cy1 * a;
  return u;
}

cv::Mat BuildMap(const Undistorter& u, int grid_step_px) {
  const int w = u.pinhole.width_px, h = u.pinhole.height_px;
  cv::Mat map(h, w, CV_32FC2);
  const float bad = -100.0f;
  if (!u.refractive) {
    ParallelFor(h, u.options.threads, [&](int v) {
      auto* row = map.ptr<cv::Vec2f>(v);
      for (int c = 0; c < w; ++c) {
        const auto s = u.SourcePixel(Vector2d(c, v));
        row[c] = s ? cv::Vec2f(static_cast<float>(s->x()), static_cast<float>(s->y()))
                   : cv::Vec2f(bad, bad);
      }
    });
    return map;
  }
  // Refractive: exact on nodes (one extra ring around the frame), Catmull-Rom in between.
  const int g = std::max(1, grid_step_px);
  const int nx = (w - 1) / g + 4, ny = (h - 1) / g + 4;  // nodes at (i − 1)·g
  std::vector<Vector2d> node(static_cast<std::size_t>(nx) * ny);
  ParallelFor(ny, u.options.threads, [&](int j) {
    for (int i = 0; i < nx; ++i) {
      const auto s = u.SourcePixel(Vector2d((i - 1.0) * g, (j - 1.0) * g));
      node[static_cast<std::size_t>(j) * nx + i] = s ? *s : Vector2d(kNaN, kNaN);
    }
  });
  ParallelFor(h, u.options.threads, [&](int v) {
    auto* row = map.ptr<cv::Vec2f>(v);
    const int j = v / g + 1;
    const double ty = static_cast<double>(v - (j - 1) * g) / g;
    for (int c = 0; c < w; ++c) {
      const int i = c / g + 1;
      const double tx = static_cast<double>(c - (i - 1) * g) / g;
      Vector2d col[4];
      for (int k = 0; k < 4; ++k) {
        const Vector2d* r = &node[static_cast<std::size_t>(j - 1 + k) * nx + (i - 1)];
        col[k] = Vector2d(Cubic(r[0].x(), r[1].x(), r[2].x(), r[3].x(), tx),
                          Cubic(r[0].y(), r[1].y(), r[2].y(), r[3].y(), tx));
      }
      const Vector2d s(Cubic(col[0].x(), col[1].x(), col[2].x(), col[3].x(), ty),
                       Cubic(col[0].y(), col[1].y(), col[2].y(), col[3].y(), ty));
      row[c] = s.allFinite() ? cv::Vec2f(static_cast<float>(s.x()), static_cast<float>(s.y()))
                             : cv::Vec2f(bad, bad);
    }
  });
  return map;
}

namespace {

template <typename T>
T Saturate(float v) {
  if constexpr (std::is_floating_point_v<T>) {
    return static_cast<T>(v);
  } else {
    const float hi = static_cast<float>(std::numeric_limits<T>::max());
    return static_cast<T>(v <= 0 ? 0 : v >= hi ? hi : v + 0.5f);
  }
}

// Bilinear (or nearest) remap with the map's exact fractions (cv::remap quantises them to 1/32 px):
// taps outside the image count as 0, as cv::remap's BORDER_CONSTANT.
template <typename T, int C, bool kNearest>
void RemapRows(const cv::Mat& src_mat, const cv::Mat& map, cv::Mat& dst, int r0, int r1) {
  // Locals only inside the loop: a store through T* (uint8_t may alias anything) must not make the
  // compiler reload the cv::Mat's fields after every pixel.
  const int w = src_mat.cols, h = src_mat.rows, cols = dst.cols;
  const std::uint8_t* const base = src_mat.data;
  const std::size_t step = src_mat.step[0];
  const auto row = [base, step](int y) {
    return reinterpret_cast<const T*>(base + step * static_cast<std::size_t>(y));
  };
  for (int v = r0; v < r1; ++v) {
    const float* __restrict m = map.ptr<float>(v);
    T* __restrict out = dst.ptr<T>(v);
    for (int c = 0; c < cols; ++c, out += C) {
      const float x = m[2 * c], y = m[2 * c + 1];
      if constexpr (kNearest) {
        int xi = static_cast<int>(x + 0.5f), yi = static_cast<int>(y + 0.5f);
        xi -= x + 0.5f < static_cast<float>(xi);
        yi -= y + 0.5f < static_cast<float>(yi);
        const bool in = xi >= 0 && yi >= 0 && xi < w && yi < h;
        const T* p = in ? row(yi) + static_cast<std::size_t>(xi) * C : nullptr;
        for (int k = 0; k < C; ++k) out[k] = in ? p[k] : T(0);
        continue;
      }
      // floor without a libm call (the x86-64 baseline has no rounding instruction); the map's
      // values lie far inside int's range (−100 marks "no source").
      int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
      x0 -= x < static_cast<float>(x0);
      y0 -= y < static_cast<float>(y0);
      const float ax = x - static_cast<float>(x0), ay = y - static_cast<float>(y0);
      if (x0 >= 0 && y0 >= 0 && x0 + 1 < w && y0 + 1 < h) {
        const T* p0 = row(y0) + static_cast<std::size_t>(x0) * C;
        const T* p1 = row(y0 + 1) + static_cast<std::size_t>(x0) * C;
        if constexpr (std::is_same_v<T, std::uint8_t>) {
          // 8 bit: fixed point, the fractions to 1/2048 px (cv::remap: 1/32), exact integer sums.
          const int bx = static_cast<int>(ax * 2048.0f + 0.5f),
                    by = static_cast<int>(ay * 2048.0f + 0.5f);
          for (int k = 0; k < C; ++k) {
            const int top = (p0[k] << 11) + (p0[k + C] - p0[k]) * bx;
            const int bot = (p1[k] << 11) + (p1[k + C] - p1[k]) * bx;
            out[k] = static_cast<T>(((top << 11) + (bot - top) * by + (1 << 21)) >> 22);
          }
          continue;
        }
        for (int k = 0; k < C; ++k) {
          const float top = p0[k] + ax * (static_cast<float>(p0[k + C]) - p0[k]);
          const float bot = p1[k] + ax * (static_cast<float>(p1[k + C]) - p1[k]);
          out[k] = Saturate<T>(top + ay * (bot - top));
        }
        continue;
      }
      if (x0 < -1 || y0 < -1 || x0 >= w || y0 >= h) {
        for (int k = 0; k < C; ++k) out[k] = T(0);
        continue;
      }
      float acc[C] = {};
      for (int dy = 0; dy < 2; ++dy) {
        for (int dx = 0; dx < 2; ++dx) {
          const int xx = x0 + dx, yy = y0 + dy;
          if (xx < 0 || yy < 0 || xx >= w || yy >= h) continue;
          const float wgt = (dx ? ax : 1 - ax) * (dy ? ay : 1 - ay);
          const T* p = row(yy) + static_cast<std::size_t>(xx) * C;
          for (int k = 0; k < C; ++k) acc[k] += wgt * p[k];
        }
      }
      for (int k = 0; k < C; ++k) out[k] = Saturate<T>(acc[k]);
    }
  }
}

template <typename T, int C>
void RemapOwn(const cv::Mat& src, const cv::Mat& map, cv::Mat& dst, bool nearest, int threads) {
  const int blocks = std::max(1, dst.rows / 16);
  ParallelFor(blocks, threads, [&](int b) {
    const int r0 = static_cast<int>(static_cast<long>(dst.rows) * b / blocks);
    const int r1 = static_cast<int>(static_cast<long>(dst.rows) * (b + 1) / blocks);
    if (nearest) {
      RemapRows<T, C, true>(src, map, dst, r0, r1);
    } else {
      RemapRows<T, C, false>(src, map, dst, r0, r1);
    }
  });
}

template <typename T>
void RemapChannels(const cv::Mat& src, const cv::Mat& map, cv::Mat& dst, bool nearest,
                   int threads) {
  switch (src.channels()) {
    case 1:
      RemapOwn<T, 1>(src, map, dst, nearest, threads);
      break;
    case 2:
      RemapOwn<T, 2>(src, map, dst, nearest, threads);
      break;
    case 3:
      RemapOwn<T, 3>(src, map, dst, nearest, threads);
      break;
    case 4:
      RemapOwn<T, 4>(src, map, dst, nearest, threads);
      break;
    default:
      throw InvalidInput("image", fmt::format("{} channels: 1 to 4 only", src.channels()));
  }
}

}  // namespace

void Remap(const cv::Mat& image, const cv::Mat& map, Interpolation interpolation, cv::Mat* out,
           int threads) {
  PORTHOLE_CHECK(map.type() == CV_32FC2 && out != nullptr && out->data != image.data);
  if (interpolation == Interpolation::kLinear || interpolation == Interpolation::kNearest) {
    out->create(map.rows, map.cols, image.type());
    const bool nearest = interpolation == Interpolation::kNearest;
    switch (image.depth()) {
      case CV_8U:
        RemapChannels<std::uint8_t>(image, map, *out, nearest, threads);
        return;
      case CV_16U:
        RemapChannels<std::uint16_t>(image, map, *out, nearest, threads);
        return;
      case CV_32F:
        RemapChannels<float>(image, map, *out, nearest, threads);
        return;
      default:
        throw InvalidInput("image", "8-bit, 16-bit or float images only");
    }
  }
  const int flag = interpolation == Interpolation::kCubic ? cv::INTER_CUBIC : cv::INTER_LANCZOS4;
  cv::remap(image, *out, map, cv::noArray(), flag, cv::BORDER_CONSTANT, cv::Scalar::all(0));
}

cv::Mat Remap(const cv::Mat& image, const cv::Mat& map, Interpolation interpolation, int threads) {
  cv::Mat out;
  Remap(image, map, interpolation, &out, threads);
  return out;
}

std::vector<ResidualMap> ResidualMaps(const Undistorter& u, const std::vector<double>& wd_mm,
                                      int cols, int rows) {
  std::vector<ResidualMap> maps;
  camera::Sensor out{u.pinhole.width_px, u.pinhole.height_px, 1.0};
  const std::vector<Vector2d> grid = camera::FramePixels(out, cols, rows);
  for (double wd : wd_mm) {
    ResidualMap m;
    m.wd_mm = wd;
    m.cols = cols, m.rows = rows;
    m.q_px = grid;
    m.error_px.assign(grid.size(), kNaN);
    const double z = wd + u.vertex_z_mm;
    ParallelFor(static_cast<int>(grid.size()), u.options.threads, [&](int i) {
      const Vector3d x =
          u.pinhole.centre_mm + u.pinhole.Ray(grid[i]) * (z - u.pinhole.centre_mm.z());
      const auto r = u.Residual(x);
      if (r) m.error_px[i] = r->norm();
    });
    std::vector<double> ok;
    for (double e : m.error_px) {
      if (std::isfinite(e)) ok.push_back(e);
    }
    if (!ok.empty()) {
      double s2 = 0;
      for (double e : ok) s2 += e * e;
      m.rms_px = std::sqrt(s2 / ok.size());
      m.max_px = *std::max_element(ok.begin(), ok.end());
      std::nth_element(ok.begin(), ok.begin() + ok.size() / 2, ok.end());
      m.median_px = ok[ok.size() / 2];
    } else {
      m.rms_px = m.max_px = m.median_px = kNaN;
    }
    maps.push_back(std::move(m));
  }
  return maps;
}

namespace {
Json Num(double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); }
}  // namespace

Json ResidualJson(const std::vector<ResidualMap>& maps) {
  Json out = Json::array();
  for (const ResidualMap& m : maps) {
    Json j;
    j["wd_mm"] = m.wd_mm;
    j["rms_px"] = Num(m.rms_px);
    j["median_px"] = Num(m.median_px);
    j["max_px"] = Num(m.max_px);
    j["grid"] = {{"cols", m.cols}, {"rows", m.rows}};
    Json u = Json::array(), v = Json::array(), e = Json::array();
    for (std::size_t i = 0; i < m.q_px.size(); ++i) {
      if (static_cast<int>(i) < m.cols) u.push_back(m.q_px[i].x());
      if (static_cast<int>(i) % m.cols == 0) v.push_back(m.q_px[i].y());
      e.push_back(Num(m.error_px[i]));
    }
    j["u_px"] = u;
    j["v_px"] = v;
    j["error_px"] = e;  // row by row
    out.push_back(j);
  }
  return out;
}

std::string ResidualData(const std::vector<ResidualMap>& maps) {
  std::string s =
      "# porthole undistort: residual |q' - q| (px, output image) over the frame.\n"
      "# One block per working distance (gnuplot index); columns: u_px v_px error_px\n";
  for (std::size_t k = 0; k < maps.size(); ++k) {
    const ResidualMap& m = maps[k];
    s += fmt::format("# wd_mm {}\n", m.wd_mm);
    for (int r = 0; r < m.rows; ++r) {
      for (int c = 0; c < m.cols; ++c) {
        const std::size_t i = static_cast<std::size_t>(r) * m.cols + c;
        const double e = m.error_px[i];
        s += fmt::format("{:.3f} {:.3f} {}\n", m.q_px[i].x(), m.q_px[i].y(),
                         std::isfinite(e) ? fmt::format("{:.6g}", e) : "NaN");
      }
      s += "\n";
    }
    s += "\n\n";
  }
  return s;
}

std::string ResidualScript(const std::vector<ResidualMap>& maps, const std::string& data_file,
                           const std::string& png_file) {
  double top = 0;
  for (const auto& m : maps) {
    if (std::isfinite(m.max_px)) top = std::max(top, m.max_px);
  }
  if (!(top > 0)) top = 1;
  const int n = static_cast<int>(maps.size());
  const int cols = n <= 1 ? 1 : 2, rows = (n + cols - 1) / cols;
  std::string s = fmt::format(
      "# porthole undistort: the pinhole's residual against depth. Run `gnuplot {0}.gp`.\n"
      "set terminal pngcairo size {1},{2} font 'sans,10'\n"
      "set output '{3}'\n"
      "set view map\nset size ratio -1\nset xrange [0:{7:.6g}]\nset yrange [{8:.6g}:0]\nset xlabel "
      "'u (px)'\nset ylabel 'v (px)'\n"
      "set cblabel 'residual (px)'\nset cbrange [0:{4:.6g}]\nset palette rgbformulae 33,13,10\n"
      "set multiplot layout {5},{6} title \"Undistorted image: where a point at depth lands minus "
      "where the pinhole "
      "puts it\"\n",
      "residual", 560 * cols, 420 * rows, png_file, top, rows, cols,
      maps.empty() ? 1.0 : maps[0].q_px.back().x(), maps.empty() ? 1.0 : maps[0].q_px.back().y());
  for (int k = 0; k < n; ++k) {
    s += fmt::format("set title 'WD {:g} m: RMS {:.3f} px, max {:.3f} px'\n", maps[k].wd_mm / 1000,
                     maps[k].rms_px, maps[k].max_px);
    s += fmt::format("splot '{}' index {} using 1:2:3 with pm3d notitle\n", data_file, k);
  }
  s += "unset multiplot\n";
  return s;
}

camera::Camera PinholeCamera(const Undistorter& u) {
  camera::Camera c;
  c.model = camera::CameraModelId::kOpenCV;
  c.sensor = {u.pinhole.width_px, u.pinhole.height_px, u.camera.camera.sensor.pixel_pitch_mm};
  c.params.assign(camera::Info(c.model).num_params, 0.0);
  c.params[0] = u.pinhole.fx;
  c.params[1] = u.pinhole.fy;
  c.params[2] = u.pinhole.cx;
  c.params[3] = u.pinhole.cy;
  return c;
}

std::string ColmapCamerasText(const Undistorter& u) {
  // interop::ToColmap would write SIMPLE_PINHOLE when fx = fy: the line is PINHOLE always, with
  // camera::PixelToColmap's shift.
  const Vector2d c = camera::PixelToColmap(Vector2d(u.pinhole.cx, u.pinhole.cy));
  return fmt::format(
      "# Camera list with one line of data per camera:\n"
      "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
      "# Number of cameras: 1\n"
      "1 PINHOLE {} {} {:.17g} {:.17g} {:.17g} {:.17g}\n",
      u.pinhole.width_px, u.pinhole.height_px, u.pinhole.fx, u.pinhole.fy, c.x(), c.y());
}

Json NerfstudioTransforms(const Undistorter& u, const std::vector<std::string>& file_paths) {
  const Vector2d c = camera::PixelToColmap(Vector2d(u.pinhole.cx, u.pinhole.cy));
  Json j;
  j["camera_model"] = "OPENCV";
  j["fl_x"] = u.pinhole.fx;
  j["fl_y"] = u.pinhole.fy;
  j["cx"] = c.x();
  j["cy"] = c.y();
  j["w"] = u.pinhole.width_px;
  j["h"] = u.pinhole.height_px;
  j["k1"] = 0.0;
  j["k2"] = 0.0;
  j["p1"] = 0.0;
  j["p2"] = 0.0;
  Json frames = Json::array();
  for (const auto& f : file_paths) frames.push_back({{"file_path", f}});
  j["frames"] = frames;
  return j;
}

Json SummaryJson(const Undistorter& u) {
  Json j;
  j["kind"] = "porthole undistort";
  j["source"] = {{"model", std::string(u.camera.camera.model_name())},
                 {"width_px", u.camera.camera.sensor.width_px},
                 {"height_px", u.camera.camera.sensor.height_px},
                 {"refractive", u.refractive}};
  j["pinhole"] = {{"width_px", u.pinhole.width_px},
                  {"height_px", u.pinhole.height_px},
                  {"fx_px", u.pinhole.fx},
                  {"fy_px", u.pinhole.fy},
                  {"cx_px", u.pinhole.cx},
                  {"cy_px", u.pinhole.cy},
                  {"centre_in_cam_mm",
                   {u.pinhole.centre_mm.x(), u.pinhole.centre_mm.y(), u.pinhole.centre_mm.z()}},
                  {"pixel_convention", "porthole: (0, 0) is the centre of the top-left pixel"}};
  Json o;
  if (u.options.keep_focal) {
    o["field"] = "keep_focal";
  } else {
    o["field"] = "alpha";
    o["alpha"] = u.options.alpha.value_or(0.0);
  }
  o["interpolation"] = std::string(InterpolationName(u.options.interpolation));
  if (u.refractive) {
    o["wd_mm"] = u.options.wd_mm;
    o["vertex_z_mm"] = u.vertex_z_mm;
    o["map_depths_z_mm"] = u.depths_z_mm;
    o["centre_fit_rms_px"] = u.centre_fit_rms_px;
    o["centre_at_pupil_rms_px"] = u.centre_at_pupil_rms_px;
  }
  j["options"] = o;
  return j;
}

std::string EncodeLike(const cv::Mat& image, const std::string& path, const std::string& field) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (auto& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  std::vector<int> params;
  if (ext == ".jpg" || ext == ".jpeg") {
    if (image.depth() != CV_8U)
      throw InvalidInput(field, fmt::format("{}: JPEG holds 8 bit only", path));
    params = {cv::IMWRITE_JPEG_QUALITY, 95};
  } else if (ext != ".png" && ext != ".tif" && ext != ".tiff" && ext != ".bmp" && ext != ".pgm" &&
             ext != ".ppm") {
    throw InvalidInput(field, fmt::format("{}: writes PNG, JPEG, TIFF, BMP, PGM or PPM", path));
  } else if (ext == ".bmp" && image.depth() != CV_8U) {
    throw InvalidInput(field, fmt::format("{}: BMP holds 8 bit only", path));
  }
  std::vector<uchar> buf;
  if (!cv::imencode(ext, image, buf, params))
    throw InvalidInput(field, fmt::format("{}: could not encode", path));
  return std::string(buf.begin(), buf.end());
}

cv::Mat ReadImage(const std::string& path, const std::string& field) {
  cv::Mat m = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (m.empty()) throw InvalidInput(field, fmt::format("{}: not an image OpenCV reads", path));
  if (m.depth() != CV_8U && m.depth() != CV_16U) {
    throw InvalidInput(field, fmt::format("{}: 8- or 16-bit images only", path));
  }
  return m;
}

}  // namespace porthole::undistort
