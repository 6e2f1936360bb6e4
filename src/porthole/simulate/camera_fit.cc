// SimulateCameraFit (simulate.h): any model of the camera list fitted to rays traced through a
// port, by Ceres automatic differentiation through the model's own Project<T>.
#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "porthole/camera/profile.h"
#include "porthole/core/error.h"
#include "porthole/housing/housed.h"
#include "porthole/simulate/simulate.h"

namespace porthole::simulate {
namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

struct PixelObservation {
  int grid_index;
  Eigen::Vector2d uv;  // measured pixel
  Vec3 point_in_housing_mm;
};

// Projected minus measured pixel for model M; blocks camera [M::kNumParams], rotation [3]
// (angle-axis, cam_from_housing), centre [3] (housing, mm).
template <typename M>
struct PixelResidual {
  camera::Sensor sensor;
  PixelObservation o;
  template <typename T>
  bool operator()(const T* cam, const T* rotation, const T* centre, T* r) const {
    const T d[3] = {T(o.point_in_housing_mm.x()) - centre[0], T(o.point_in_housing_mm.y()) - centre[1],
                    T(o.point_in_housing_mm.z()) - centre[2]};
    T pc[3];
    ceres::AngleAxisRotatePoint(rotation, d, pc);
    const auto q = M::template Project<T>(sensor, cam, camera::Vec3<T>(pc[0], pc[1], pc[2]));
    if (!q) return false;
    r[0] = (*q)(0) - T(o.uv(0));
    r[1] = (*q)(1) - T(o.uv(1));
    return true;
  }
};

template <typename M>
bool Solve(const std::vector<PixelObservation>& obs, const camera::Sensor& sensor, const FitOptions& options,
           bool pose_free, double* cam, double* rotation, double* centre) {
  ceres::Problem problem;
  for (const PixelObservation& o : obs) {
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<PixelResidual<M>, 2, M::kNumParams, 3, 3>(
                                 new PixelResidual<M>{sensor, o}),
                             nullptr, cam, rotation, centre);
  }
  if (!pose_free || !options.free_rotation) problem.SetParameterBlockConstant(rotation);
  if (!pose_free) problem.SetParameterBlockConstant(centre);
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = options.max_iterations;
  so.function_tolerance = 1e-12;
  so.parameter_tolerance = 1e-12;
  so.gradient_tolerance = 1e-20;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  return summary.IsSolutionUsable() && summary.termination_type == ceres::CONVERGENCE;
}

}  // namespace

CameraFit SimulateCameraFit(const ports::PortSystem& sys, const lens::LensSpec& lens, const camera::Sensor& sensor,
                            double c_mm, camera::CameraModelId model, const FitOptions& options,
                            const camera::Camera* lens_camera) {
  Validate(options);
  camera::ValidateSensor(sensor);
  RequirePositive("c_mm", c_mm);
  if (lens_camera) camera::ValidateCamera(*lens_camera, "air_fisheye_calibration");
  const Vec3& ep = sys.ep_in_housing_mm;
  // Trace the grid's chief rays (the lens's projection at principal distance c, or the calibrated
  // lens's rays) out through the port.
  const auto grid = ImageGrid(sensor, options.grid_cols, options.grid_rows);
  CameraFit fit;
  std::vector<std::optional<optics::Ray>> rays(grid.size());
  for (std::size_t i = 0; i < grid.size(); ++i) {
    const auto dir = lens_camera ? lens_camera->Unproject(camera::ImageMmToPixel(sensor, grid[i](0), grid[i](1)))
                                 : housing::ChiefRay(lens, c_mm, grid[i](0), grid[i](1));
    optics::Ray out;
    if (dir && optics::TraceSequence<double>(sys.Outward(), {ep, *dir}, &out) == optics::RayStatus::kOk) {
      rays[i] = optics::Ray{out.origin, out.dir.normalized()};
    } else {
      ++fit.num_failed;
    }
  }
  if (2 * static_cast<std::size_t>(fit.num_failed) > grid.size()) {
    throw InvalidInput("port", std::to_string(fit.num_failed) + " of " + std::to_string(grid.size()) +
                                   " image rays do not get through the port");
  }
  // Object points on spheres about the pupil at the fit distances (a fisheye sees beyond 90°, where
  // planes across the axis would not be met).
  std::vector<PixelObservation> obs;
  for (double d : Distances(options)) {
    for (std::size_t i = 0; i < grid.size(); ++i) {
      if (!rays[i]) continue;
      const Vec3 o = rays[i]->origin - ep, u = rays[i]->dir;
      const double b = o.dot(u), disc = b * b - (o.squaredNorm() - d * d);
      if (!(disc >= 0)) continue;
      const double t = -b + std::sqrt(disc);
      if (!(t > 0)) continue;
      const Eigen::Vector2d uv = camera::ImageMmToPixel(sensor, grid[i](0), grid[i](1));
      obs.push_back({static_cast<int>(i), uv, rays[i]->origin + t * u});
    }
  }
  fit.camera = lens_camera && lens_camera->model == model ? *lens_camera
                                                         : camera::Camera::Ideal(model, sensor, c_mm / sensor.pixel_pitch_mm);
  fit.camera.sensor = sensor;
  double rotation[3] = {0, 0, 0}, centre[3] = {ep.x(), ep.y(), ep.z()};
  camera::VisitModel(model, [&](auto m) {
    using M = decltype(m);
    // The camera alone first (pose at the pupil), then camera and pose together.
    Solve<M>(obs, sensor, options, false, fit.camera.params.data(), rotation, centre);
    fit.converged = Solve<M>(obs, sensor, options, true, fit.camera.params.data(), rotation, centre);
    std::vector<double> sum2(grid.size(), 0.0);
    std::vector<int> count(grid.size(), 0);
    double total2 = 0;
    int used = 0;
    for (const PixelObservation& o : obs) {
      double r[2];
      if (!PixelResidual<M>{sensor, o}(fit.camera.params.data(), rotation, centre, r)) continue;
      const double px2 = r[0] * r[0] + r[1] * r[1];
      total2 += px2;
      fit.max_px = std::max(fit.max_px, std::sqrt(px2));
      sum2[o.grid_index] += px2;
      ++count[o.grid_index];
      ++used;
    }
    fit.num_points = used;
    fit.rms_px = used ? std::sqrt(total2 / used) : std::nan("");
    fit.residual_px.resize(grid.size());
    for (std::size_t i = 0; i < grid.size(); ++i) {
      fit.residual_px[i] = count[i] ? std::sqrt(sum2[i] / count[i]) : std::nan("");
    }
  });
  fit.center_in_housing_mm = Vec3(centre[0], centre[1], centre[2]);
  fit.rotation_deg = Vec3(rotation[0], rotation[1], rotation[2]) * kRadToDeg;
  return fit;
}

std::string_view FitView::model_name() const {
  return brown_ ? camera::Info(camera::CameraModelId::kBrown).name : model_->camera.model_name();
}

double FitView::c_mm() const {
  return brown_ ? brown_->params.c_mm : model_->camera.FocalLengthPx() * model_->camera.sensor.pixel_pitch_mm;
}

double FitView::rms_um() const {
  return brown_ ? brown_->rms_um : 1000 * model_->rms_px * model_->camera.sensor.pixel_pitch_mm;
}

double FitView::max_um() const {
  return brown_ ? brown_->max_um : 1000 * model_->max_px * model_->camera.sensor.pixel_pitch_mm;
}

Eigen::Vector2d FitView::CorrectionMm(double x_mm, double y_mm) const {
  if (brown_) return camera::Correction(brown_->params, x_mm, y_mm);
  const camera::Camera& cam = model_->camera;
  const camera::ModelInfo& info = cam.info();
  const double fx = cam.params[0], fy = cam.params[info.num_focal - 1];
  const double cx = cam.params[info.num_focal], cy = cam.params[info.num_focal + 1];
  const Eigen::Vector2d uv = camera::ImageMmToPixel(cam.sensor, x_mm, y_mm);
  const auto ray = cam.Unproject(uv);
  if (!ray) return Eigen::Vector2d::Constant(std::nan(""));
  // The ideal pixel: the lens's projection g(θ) at the fitted focal lengths, along the ray's azimuth.
  const double rho = std::hypot(ray->x(), ray->y());
  const double theta = std::atan2(rho, ray->z());
  const double g = camera::ProjectionRadius(projection_, theta);
  const Eigen::Vector2d ideal_uv =
      rho > 0 ? Eigen::Vector2d(cx + fx * g * ray->x() / rho, cy + fy * g * ray->y() / rho) : Eigen::Vector2d(cx, cy);
  return camera::PixelToImageMm(cam.sensor, ideal_uv(0), ideal_uv(1)) - Eigen::Vector2d(x_mm, y_mm);
}

double FitView::RadialProfileMm(double r_mm) const {
  if (brown_) return camera::RadialProfileMm(brown_->params, r_mm);
  const camera::Camera& cam = model_->camera;
  const int k = cam.info().num_focal;
  const Eigen::Vector2d pp = camera::PixelToImageMm(cam.sensor, cam.params[k], cam.params[k + 1]);
  return CorrectionMm(pp.x() + r_mm, pp.y()).x();
}

std::optional<double> FitView::DecentringProfileMm(double r_mm) const {
  if (brown_) return camera::DecentringProfileMm(brown_->params, r_mm);
  return std::nullopt;
}

double FitView::ResidualUm(std::size_t i) const {
  if (brown_) return i < brown_->residual_um.size() ? brown_->residual_um[i] : std::nan("");
  return i < model_->residual_px.size() ? 1000 * model_->residual_px[i] * model_->camera.sensor.pixel_pitch_mm
                                        : std::nan("");
}

}  // namespace porthole::simulate
