#include "porthole/camera/opencv_model.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "porthole/core/error.h"

namespace porthole::camera {
namespace {

void ValidateOptions(const CameraConversionOptions& o) {
  if (o.grid_cols < 3) throw InvalidInput("grid_cols", "must be >= 3");
  if (o.grid_rows < 3) throw InvalidInput("grid_rows", "must be >= 3");
  if (o.max_iterations < 1) throw InvalidInput("max_iterations", "must be >= 1");
}

void ValidateOpenCVParams(const OpenCVParams& p) {
  static constexpr const char* kNames[kOpenCVNumParams] = {"fx", "fy", "cx", "cy", "k1",
                                                           "k2", "p1", "p2", "k3"};
  const auto a = p.ToArray();
  for (int i = 0; i < kOpenCVNumParams; ++i) RequireFinite(kNames[i], a[i]);
  RequirePositive("fx", p.fx);
  RequirePositive("fy", p.fy);
}

// A grid pixel (u, v) and the ray (normalised X/Z, Y/Z; Y down) the source model assigns to it.
struct GridRay {
  double u, v;
  double xn, yn;
};

// Grid pixels spanning the full frame, pixel centres 0 … W−1 and 0 … H−1 inclusive.
std::vector<Eigen::Vector2d> GridPixels(const Sensor& s, const CameraConversionOptions& o) {
  std::vector<Eigen::Vector2d> px;
  px.reserve(static_cast<size_t>(o.grid_cols) * o.grid_rows);
  for (int j = 0; j < o.grid_rows; ++j) {
    for (int i = 0; i < o.grid_cols; ++i) {
      px.emplace_back(i * (s.width_px - 1.0) / (o.grid_cols - 1),
                      j * (s.height_px - 1.0) / (o.grid_rows - 1));
    }
  }
  return px;
}

ceres::Solver::Options SolverOptions(const CameraConversionOptions& o) {
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = o.max_iterations;
  so.function_tolerance = 1e-16;
  so.parameter_tolerance = 1e-16;
  so.gradient_tolerance = 1e-20;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  return so;
}

// Fit statistics from per-point 2-D pixel distances (an infinite distance marks a point the model
// could not project: counted, not averaged).
ConversionFit Stats(const std::vector<double>& dist_px) {
  ConversionFit f;
  f.num_points = static_cast<int>(dist_px.size());
  double sum2 = 0;
  int used = 0;
  for (double d : dist_px) {
    if (!std::isfinite(d)) {
      ++f.num_not_projected;
      continue;
    }
    sum2 += d * d;
    ++used;
    f.max_px = std::max(f.max_px, d);
  }
  f.rms_px = used == 0 ? std::numeric_limits<double>::infinity() : std::sqrt(sum2 / used);
  return f;
}

// Residual (px): OpenCV projection of the ray minus the grid pixel. Block: OpenCV params [9].
struct OpenCVPixelResidual {
  GridRay g;
  template <typename T>
  bool operator()(const T* p, T* r) const {
    const Vec2<T> d = OpenCVDistortNormalized(p, T(g.xn), T(g.yn));
    r[0] = p[kCvFx] * d(0) + p[kCvCx] - T(g.u);
    r[1] = p[kCvFy] * d(1) + p[kCvCy] - T(g.v);
    return true;
  }
};

// Residual (px): (x̄ + Δx − c·X/Z, ȳ + Δy + c·Y/Z) / pitch at the grid pixel's image-mm point, i.e.
// the collinearity misfit in correction space. Block: Brown params [10].
struct BrownCorrectionResidual {
  GridRay g;
  Sensor s;
  template <typename T>
  bool operator()(const T* p, T* r) const {
    const Vec2<double> xy = PixelToImageMm(s, g.u, g.v);
    const Vec2<T> ideal = Undistort<T>(p, T(xy(0)), T(xy(1)));
    r[0] = (ideal(0) - p[kBrownX0] - p[kBrownC] * T(g.xn)) / T(s.pixel_pitch_mm);
    r[1] = (ideal(1) - p[kBrownY0] + p[kBrownC] * T(g.yn)) / T(s.pixel_pitch_mm);
    return true;
  }
};

// Residual (px): Brown projection of the ray, in pixels, minus the grid pixel. Block: Brown [10].
struct BrownPixelResidual {
  GridRay g;
  Sensor s;
  template <typename T>
  bool operator()(const T* p, T* r) const {
    const auto xy = Project<T>(p, Vec3<T>(T(g.xn), T(g.yn), T(1)));
    // Where the correction polynomial has no inverse (possible in the corners of a strongly
    // distorted lens while the fit moves), the correction-space residual stands in: the same units
    // and equal to first order, so the problem stays defined and is pulled back to invertibility.
    if (!xy) return BrownCorrectionResidual{g, s}(p, r);
    const Vec2<T> uv = ImageMmToPixel(s, (*xy)(0), (*xy)(1));
    r[0] = uv(0) - T(g.u);
    r[1] = uv(1) - T(g.v);
    return true;
  }
};

void HoldConstant(ceres::Problem* problem, double* block, int size, const std::vector<int>& held) {
  if (held.empty()) return;
  problem->SetManifold(block, new ceres::SubsetManifold(size, held));
}

}  // namespace

std::optional<Eigen::Vector2d> OpenCVUnprojectNormalized(const OpenCVParams& p, double u,
                                                         double v) {
  using J = ceres::Jet<double, 2>;
  const auto pd = p.ToArray();
  std::array<J, kOpenCVNumParams> pj;
  for (int i = 0; i < kOpenCVNumParams; ++i) pj[i] = J(pd[i]);
  const Eigen::Vector2d target((u - p.cx) / p.fx, (v - p.cy) / p.fy);
  Eigen::Vector2d x = target;  // start at the distorted point
  for (int it = 0; it < 50; ++it) {
    const Vec2<J> d = OpenCVDistortNormalized<J>(pj.data(), J(x(0), 0), J(x(1), 1));
    const Eigen::Vector2d f(d(0).a - target(0), d(1).a - target(1));
    Eigen::Matrix2d jac;
    jac << d(0).v(0), d(0).v(1), d(1).v(0), d(1).v(1);
    const double det = jac.determinant();
    if (!(det > 0)) return std::nullopt;
    const Eigen::Vector2d step = jac.inverse() * f;
    x -= step;
    if (!x.allFinite()) return std::nullopt;
    if (step.norm() < 1e-14) return x;
  }
  return std::nullopt;
}

OpenCVParams BrownToOpenCVClosedForm(const BrownParams& b, const Sensor& s) {
  const double c = b.c_mm, pitch = s.pixel_pitch_mm;
  OpenCVParams o;
  o.fx = c / (pitch * (1.0 + b.B1));
  o.fy = c / pitch;
  o.cx = 0.5 * (s.width_px - 1) + b.x0_mm / pitch;
  o.cy = 0.5 * (s.height_px - 1) - b.y0_mm / pitch;
  o.k1 = -b.K1 * c * c;
  o.k2 = -b.K2 * std::pow(c, 4);
  o.k3 = -b.K3 * std::pow(c, 6);
  o.p1 = b.P2 * c;
  o.p2 = -b.P1 * c;
  return o;
}

BrownParams OpenCVToBrownClosedForm(const OpenCVParams& o, const Sensor& s) {
  const double pitch = s.pixel_pitch_mm;
  BrownParams b;
  b.c_mm = o.fy * pitch;
  b.B1 = o.fy / o.fx - 1.0;
  b.x0_mm = (o.cx - 0.5 * (s.width_px - 1)) * pitch;
  b.y0_mm = -(o.cy - 0.5 * (s.height_px - 1)) * pitch;
  const double c = b.c_mm;
  b.K1 = -o.k1 / (c * c);
  b.K2 = -o.k2 / std::pow(c, 4);
  b.K3 = -o.k3 / std::pow(c, 6);
  b.P1 = -o.p2 / c;
  b.P2 = o.p1 / c;
  return b;
}

BrownToOpenCVResult BrownToOpenCV(const BrownParams& brown, const Sensor& sensor,
                                  const CameraConversionOptions& options) {
  ValidateBrownParams(brown);
  ValidateSensor(sensor);
  ValidateOptions(options);

  std::vector<GridRay> rays;
  for (const Eigen::Vector2d& uv : GridPixels(sensor, options)) {
    const Vec2<double> xy = PixelToImageMm(sensor, uv(0), uv(1));
    const Vec3<double> dir = Unproject(brown, xy(0), xy(1));
    if (!(dir(2) > 0)) throw InvalidInput("brown", "a grid pixel's ray points backwards");
    rays.push_back({uv(0), uv(1), dir(0) / dir(2), dir(1) / dir(2)});
  }

  BrownToOpenCVResult result;
  result.initial = BrownToOpenCVClosedForm(brown, sensor);
  if (!options.fit_k3) result.initial.k3 = 0;
  auto p = result.initial.ToArray();

  ceres::Problem problem;
  for (const GridRay& g : rays) {
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<OpenCVPixelResidual, 2, kOpenCVNumParams>(
            new OpenCVPixelResidual{g}),
        nullptr, p.data());
  }
  if (!options.fit_k3) HoldConstant(&problem, p.data(), kOpenCVNumParams, {kCvK3});
  ceres::Solver::Summary summary;
  ceres::Solve(SolverOptions(options), &problem, &summary);
  result.opencv = OpenCVParams::FromArray(p.data());

  std::vector<double> dist;
  for (const GridRay& g : rays) {
    const auto uv = OpenCVProject(p.data(), Vec3<double>(g.xn, g.yn, 1.0));
    dist.push_back(uv ? std::hypot((*uv)(0) - g.u, (*uv)(1) - g.v)
                      : std::numeric_limits<double>::infinity());
  }
  result.fit = Stats(dist);
  return result;
}

OpenCVToBrownResult OpenCVToBrown(const OpenCVParams& opencv, const Sensor& sensor,
                                  const CameraConversionOptions& options) {
  ValidateOpenCVParams(opencv);
  ValidateSensor(sensor);
  ValidateOptions(options);

  std::vector<GridRay> rays;
  for (const Eigen::Vector2d& uv : GridPixels(sensor, options)) {
    const auto n = OpenCVUnprojectNormalized(opencv, uv(0), uv(1));
    if (!n) {
      throw InvalidInput("opencv", "the distortion cannot be inverted at pixel (" +
                                       std::to_string(uv(0)) + ", " + std::to_string(uv(1)) + ")");
    }
    rays.push_back({uv(0), uv(1), (*n)(0), (*n)(1)});
  }

  OpenCVToBrownResult result;
  result.initial = OpenCVToBrownClosedForm(opencv, sensor);
  if (!options.fit_k3) result.initial.K3 = 0;
  if (!options.fit_affinity) result.initial.B1 = result.initial.B2 = 0;
  auto p = result.initial.ToArray();
  std::vector<int> held;
  if (!options.fit_k3) held.push_back(kBrownK3);
  if (!options.fit_affinity) held.insert(held.end(), {kBrownB1, kBrownB2});

  // Stage 1: correction-space residual (no iteration inside, robust from the closed form).
  {
    ceres::Problem problem;
    for (const GridRay& g : rays) {
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<BrownCorrectionResidual, 2, kBrownNumParams>(
              new BrownCorrectionResidual{g, sensor}),
          nullptr, p.data());
    }
    HoldConstant(&problem, p.data(), kBrownNumParams, held);
    ceres::Solver::Summary summary;
    ceres::Solve(SolverOptions(options), &problem, &summary);
  }
  // Stage 2: the pixel residual itself (Newton inside Project, exact Jet derivatives).
  {
    ceres::Problem problem;
    for (const GridRay& g : rays) {
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<BrownPixelResidual, 2, kBrownNumParams>(
              new BrownPixelResidual{g, sensor}),
          nullptr, p.data());
    }
    HoldConstant(&problem, p.data(), kBrownNumParams, held);
    ceres::Solver::Summary summary;
    ceres::Solve(SolverOptions(options), &problem, &summary);
  }
  result.brown = BrownParams::FromArray(p.data());

  std::vector<double> dist;
  for (const GridRay& g : rays) {
    const auto xy = Project(result.brown, Vec3<double>(g.xn, g.yn, 1.0));
    if (!xy) {
      dist.push_back(std::numeric_limits<double>::infinity());
      continue;
    }
    const Vec2<double> uv = ImageMmToPixel(sensor, (*xy)(0), (*xy)(1));
    dist.push_back(std::hypot(uv(0) - g.u, uv(1) - g.v));
  }
  result.fit = Stats(dist);
  return result;
}

}  // namespace porthole::camera
