#include "porthole/simulate/simulate.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "porthole/core/error.h"
#include "porthole/optics/batch.h"

namespace porthole::simulate {
namespace {

using camera::BrownParams;
using camera::kBrownNumParams;

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

// One observation: a measured image point and an object point on its traced ray.
struct Observation {
  int grid_index;
  Eigen::Vector2d image_mm;
  Vec3 point_in_housing_mm;
};

// The grid rays traced out through the port: the ray in the outer medium, or nullopt on failure.
struct TracedGrid {
  std::vector<Eigen::Vector2d> image_mm;
  std::vector<std::optional<optics::Ray>> rays;
  int num_failed = 0;
};

TracedGrid TraceGrid(const ports::PortSystem& sys, const CameraSetup& cam, int cols, int rows) {
  TracedGrid g;
  g.image_mm = ImageGrid(cam.sensor, cols, rows);
  optics::RayBatch batch;
  batch.resize(g.image_mm.size());
  for (std::size_t i = 0; i < g.image_mm.size(); ++i) {
    // Camera and housing axes are parallel (docs/conventions.md), so the cam-frame direction is
    // the housing-frame direction.
    const Vec3 dir = camera::Unproject(cam.lens, g.image_mm[i](0), g.image_mm[i](1));
    if (!(dir.z() > 0)) throw InvalidInput("lens", "an image point's ray points backwards");
    batch.Set(i, {cam.ep_in_housing_mm, dir});
  }
  optics::BatchOptions bo;
  bo.num_threads = 1;  // a few thousand rays: threads cost more than they save
  optics::TraceBatch(sys.Outward(), &batch, bo);
  g.rays.resize(batch.size());
  for (std::size_t i = 0; i < batch.size(); ++i) {
    const optics::Ray r = batch.Get(i);
    if (batch.status[i] == optics::RayStatus::kOk && r.dir.z() > 0) {
      g.rays[i] = r;
    } else {
      ++g.num_failed;
    }
  }
  return g;
}

// Object points where the traced rays cross the plane `distance_mm` ahead of the pupil (+Z).
// A ray that would cross it before leaving the port contributes nothing.
void AddObservations(const TracedGrid& g, double ep_z, double distance_mm,
                     std::vector<Observation>* obs) {
  const double z = ep_z + distance_mm;
  for (std::size_t i = 0; i < g.rays.size(); ++i) {
    if (!g.rays[i]) continue;
    const optics::Ray& r = *g.rays[i];
    const double t = (z - r.origin.z()) / r.dir.z();
    if (!(t >= 0)) continue;
    obs->push_back({static_cast<int>(i), g.image_mm[i], r.origin + t * r.dir});
  }
}

// The object point in the camera frame: R(rotation) · (p − centre).
template <typename T>
Eigen::Matrix<T, 3, 1> ToCam(const T* rotation, const T* centre, const Vec3& p) {
  const T d[3] = {T(p.x()) - centre[0], T(p.y()) - centre[1], T(p.z()) - centre[2]};
  T out[3];
  ceres::AngleAxisRotatePoint(rotation, d, out);
  return {out[0], out[1], out[2]};
}

// Stage 1 (mm): the collinearity misfit in correction space, (x̄ + Δx − c·X/Z, ȳ + Δy + c·Y/Z).
// Needs no iteration, so it converges from a poor start (a flat port's c is 1.34× the air one).
// Blocks: camera [10], rotation [3] (angle-axis, cam_from_housing), centre [3] (housing, mm).
struct CorrectionResidual {
  Observation o;
  template <typename T>
  bool operator()(const T* cam, const T* rotation, const T* centre, T* r) const {
    const auto pc = ToCam(rotation, centre, o.point_in_housing_mm);
    const camera::Vec2<T> ideal = camera::Undistort<T>(cam, T(o.image_mm(0)), T(o.image_mm(1)));
    r[0] = ideal(0) - cam[camera::kBrownX0] - cam[camera::kBrownC] * pc(0) / pc(2);
    r[1] = ideal(1) - cam[camera::kBrownY0] + cam[camera::kBrownC] * pc(1) / pc(2);
    return true;
  }
};

// Stage 2 (mm): projected minus measured image point, camera::BrownReprojectionResidual on the
// posed point. Same blocks.
struct ImageResidual {
  Observation o;
  template <typename T>
  bool operator()(const T* cam, const T* rotation, const T* centre, T* r) const {
    const auto pc = ToCam(rotation, centre, o.point_in_housing_mm);
    return camera::BrownReprojectionResidual(o.image_mm(0), o.image_mm(1))(cam, pc.data(), r);
  }
};

// What stage 2 minimises: ImageResidual, and where the correction polynomial has no inverse (the
// corners of a strongly distorted lens while the fit moves, e.g. OpenCV's left_intrinsics.yml, k3 =
// 0.24) stage 1's correction-space residual in its place, as camera::OpenCVToBrown does, so that
// Ceres never meets a failed evaluation (it stopped at once, printing an error line).
struct ImageOrCorrectionResidual {
  Observation o;
  template <typename T>
  bool operator()(const T* cam, const T* rotation, const T* centre, T* r) const {
    return ImageResidual{o}(cam, rotation, centre, r) || CorrectionResidual{o}(cam, rotation, centre, r);
  }
};

// The image-residual length (mm) of each observation under a fitted camera; +inf where Project
// fails.
std::vector<double> ResidualLengthsMm(const std::vector<Observation>& obs, const double* cam,
                                      const double* rotation, const double* centre) {
  std::vector<double> out;
  out.reserve(obs.size());
  for (const Observation& o : obs) {
    double r[2];
    const bool ok = ImageResidual{o}(cam, rotation, centre, r);
    out.push_back(ok ? std::hypot(r[0], r[1]) : std::numeric_limits<double>::infinity());
  }
  return out;
}

ceres::Solver::Options SolverOptions(int max_iterations) {
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = max_iterations;
  so.function_tolerance = 1e-10;  // relative cost change: c to ~1e-7 mm, far below any tolerance
  so.parameter_tolerance = 1e-10;
  so.gradient_tolerance = 1e-20;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  return so;
}

// The fitted pose and camera as arrays.
struct FitState {
  std::array<double, kBrownNumParams> cam;
  double rotation[3] = {0, 0, 0};
  double centre[3] = {0, 0, 0};
};

template <typename Residual>
bool RunStage(const std::vector<Observation>& obs, const FitOptions& options, FitState* s) {
  ceres::Problem problem;
  for (const Observation& o : obs) {
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<Residual, 2, kBrownNumParams, 3, 3>(new Residual{o}),
        nullptr, s->cam.data(), s->rotation, s->centre);
  }
  std::vector<int> held = {camera::kBrownB1, camera::kBrownB2};
  if (!options.fit_k3) held.push_back(camera::kBrownK3);
  problem.SetManifold(s->cam.data(), new ceres::SubsetManifold(kBrownNumParams, held));
  if (!options.free_rotation) problem.SetParameterBlockConstant(s->rotation);
  ceres::Solver::Summary summary;
  ceres::Solve(SolverOptions(options.max_iterations), &problem, &summary);
  return summary.IsSolutionUsable() && summary.termination_type == ceres::CONVERGENCE;
}

}  // namespace

void Validate(const FitOptions& o) {
  if (o.grid_cols < 3) throw InvalidInput("grid_cols", "must be >= 3");
  if (o.grid_rows < 3) throw InvalidInput("grid_rows", "must be >= 3");
  if (o.max_iterations < 1) throw InvalidInput("max_iterations", "must be >= 1");
  if (o.distances_mm.empty()) {
    RequirePositive("reference_distance_mm", o.reference_distance_mm);
    RequirePositive("near_factor", o.near_factor);
    RequirePositive("far_factor", o.far_factor);
    if (!(o.far_factor > o.near_factor)) throw InvalidInput("far_factor", "must exceed near_factor");
    if (o.num_distances < 2) throw InvalidInput("num_distances", "must be >= 2");
  } else {
    for (double d : o.distances_mm) RequirePositive("distances_mm", d);
    std::vector<double> sorted = o.distances_mm;
    std::sort(sorted.begin(), sorted.end());
    if (sorted.front() == sorted.back()) {
      throw InvalidInput("distances_mm", "needs at least two different distances");
    }
  }
}

std::vector<double> Distances(const FitOptions& o) {
  if (!o.distances_mm.empty()) return o.distances_mm;
  std::vector<double> d;
  for (int k = 0; k < o.num_distances; ++k) {
    const double f = o.near_factor + (o.far_factor - o.near_factor) * k / (o.num_distances - 1);
    d.push_back(f * o.reference_distance_mm);
  }
  return d;
}

std::vector<Eigen::Vector2d> ImageGrid(const camera::Sensor& s, int cols, int rows) {
  camera::ValidateSensor(s);
  std::vector<Eigen::Vector2d> g;
  g.reserve(static_cast<std::size_t>(cols) * rows);
  for (int j = 0; j < rows; ++j) {
    for (int i = 0; i < cols; ++i) {
      g.push_back(camera::PixelToImageMm(s, i * (s.width_px - 1.0) / (cols - 1),
                                         j * (s.height_px - 1.0) / (rows - 1)));
    }
  }
  return g;
}

ports::PortSystem WithAirOutside(const ports::PortSystem& sys) {
  ports::PortSystem air = sys;
  air.n_water = 1.0;
  return air;
}

BrownFit SimulateFit(const ports::PortSystem& sys, const CameraSetup& cam,
                     const FitOptions& options) {
  Validate(options);
  camera::ValidateBrownParams(cam.lens);
  if ((sys.ep_in_housing_mm - cam.ep_in_housing_mm).norm() > 1e-9) {
    throw InvalidInput("entrance_pupil_mm", "the port was placed for another pupil position");
  }
  const TracedGrid g = TraceGrid(sys, cam, options.grid_cols, options.grid_rows);
  std::vector<Observation> obs;
  for (double d : Distances(options)) AddObservations(g, cam.ep_in_housing_mm.z(), d, &obs);
  const std::size_t n_grid = g.image_mm.size();
  if (2 * static_cast<std::size_t>(g.num_failed) > n_grid) {
    throw InvalidInput("port", std::to_string(g.num_failed) + " of " + std::to_string(n_grid) +
                                   " image rays do not get through the port");
  }

  FitState s;
  s.cam = cam.lens.ToArray();
  s.cam[camera::kBrownB1] = s.cam[camera::kBrownB2] = 0;
  for (int k = 0; k < 3; ++k) s.centre[k] = cam.ep_in_housing_mm(k);
  // Stage 1 only finds the basin: a subsample of about 1000 observations spread over the grid and
  // the distances is enough, and keeps large grids fast.
  std::vector<Observation> coarse;
  const std::size_t stride = std::max<std::size_t>(1, obs.size() / 1000);
  for (std::size_t k = 0; k < obs.size(); k += stride) coarse.push_back(obs[k]);
  RunStage<CorrectionResidual>(coarse, options, &s);
  const bool converged = RunStage<ImageOrCorrectionResidual>(obs, options, &s);

  BrownFit fit;
  fit.params = BrownParams::FromArray(s.cam.data());
  fit.center_in_housing_mm = Vec3(s.centre[0], s.centre[1], s.centre[2]);
  fit.rotation_deg = Vec3(s.rotation[0], s.rotation[1], s.rotation[2]) * kRadToDeg;
  fit.num_points = static_cast<int>(obs.size());
  fit.num_failed = g.num_failed;
  fit.converged = converged;
  const std::vector<double> len = ResidualLengthsMm(obs, s.cam.data(), s.rotation, s.centre);
  std::vector<double> sum2(n_grid, 0.0);
  std::vector<int> count(n_grid, 0);
  double total2 = 0;
  for (std::size_t k = 0; k < obs.size(); ++k) {
    const double um = 1000 * len[k];
    total2 += um * um;
    fit.max_um = std::max(fit.max_um, um);
    sum2[obs[k].grid_index] += um * um;
    ++count[obs[k].grid_index];
  }
  fit.rms_um = obs.empty() ? 0 : std::sqrt(total2 / obs.size());
  fit.residual_um.resize(n_grid);
  for (std::size_t i = 0; i < n_grid; ++i) {
    fit.residual_um[i] = count[i] ? std::sqrt(sum2[i] / count[i]) : std::nan("");
  }
  return fit;
}

std::vector<DistanceError> DistanceErrors(const ports::PortSystem& sys, const CameraSetup& cam,
                                          const BrownFit& fit,
                                          const std::vector<double>& distances_mm,
                                          const FitOptions& options) {
  Validate(options);
  const TracedGrid g = TraceGrid(sys, cam, options.grid_cols, options.grid_rows);
  const auto p = fit.params.ToArray();
  const Vec3 rotation = fit.rotation_deg / kRadToDeg;
  std::vector<DistanceError> out;
  for (double d : distances_mm) {
    RequirePositive("distance_mm", d);
    std::vector<Observation> obs;
    AddObservations(g, cam.ep_in_housing_mm.z(), d, &obs);
    DistanceError e;
    e.distance_mm = d;
    e.num_points = static_cast<int>(obs.size());
    double sum2 = 0;
    for (double len : ResidualLengthsMm(obs, p.data(), rotation.data(),
                                        fit.center_in_housing_mm.data())) {
      sum2 += 1e6 * len * len;
      e.max_um = std::max(e.max_um, 1000 * len);
    }
    e.rms_um = obs.empty() ? std::nan("") : std::sqrt(sum2 / obs.size());
    out.push_back(e);
  }
  return out;
}

}  // namespace porthole::simulate
