#include "porthole/calib/refractive.h"
#include "porthole/calib/rig.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <fmt/format.h>
#include <glog/logging.h>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <set>

#include "porthole/calib/bundle.h"
#include "porthole/calib/compare.h"
#include "porthole/calib/free_target.h"
#include "porthole/calib/housed_prior.h"
#include "porthole/calib/prior_cost.h"
#include "porthole/calib/scales.h"
#include "porthole/coded/ellipse.h"
#include "porthole/core/error.h"
#include "porthole/ports/describe.h"
#include "porthole/refraction/shell_json.h"
#include "porthole/simulate/simulate.h"

namespace porthole::calib {
namespace {

using refraction::kPortNumParams;
using refraction::kShellNumParams;
using refraction::PortKind;
using refraction::ShellArray;
using PortArray = std::array<double, kPortNumParams>;
using ShellFree = std::array<bool, kShellNumParams>;

// Raises glog's threshold to ERROR while alive: Ceres warns through glog of what porthole reports
// or handles itself (Covariance: "Jacobian matrix is rank deficient"; a step where some point
// cannot be projected: "Step failed to evaluate"), lines that would follow or precede porthole's
// one line on stderr.
class QuietGlog {
 public:
  QuietGlog() : saved_(FLAGS_minloglevel) { FLAGS_minloglevel = std::max(saved_, google::GLOG_ERROR); }
  ~QuietGlog() { FLAGS_minloglevel = saved_; }
  QuietGlog(const QuietGlog&) = delete;
  QuietGlog& operator=(const QuietGlog&) = delete;

 private:
  int saved_;
};

struct Obs {
  int image = 0, point = 0;
  double u_px = 0, v_px = 0;  // what the residual compares with: the measurement − centre offset
  bool active = true;
  // The detector's measurement; u_px, v_px are it minus the centre offset of a circular target
  // (RefractiveAdjustment::UpdateCentreOffsets), or it unchanged.
  double measured_u_px = 0, measured_v_px = 0;
};

// The in-air calibration as a Gaussian prior on the lens parameters `idx`: r = L⁻¹(p − μ) with
// Σ = L·Lᵀ over idx (whiten = L⁻¹).
struct Prior {
  std::vector<int> idx;
  Eigen::VectorXd mean;
  Eigen::MatrixXd whiten;
};

// The port file's σ as a prior on the shell values v (refraction::ShellParams): r = A·v − b, one
// row per stated σ (ShellPriorOf); `free` the values it adjusts.
struct ShellPrior {
  Eigen::MatrixXd a;
  Eigen::VectorXd b;
  ShellFree free{};
};

template <typename M>
class RefractiveAdjustment {
 public:
  static constexpr int N = M::kNumParams;
  // Rows of the joint covariance: [lens N, port, shell].
  static constexpr int kT = N + kPortNumParams + kShellNumParams;

  // Images [0, n_images − n_air) are in water, the last n_air in air through the same port.
  RefractiveAdjustment(const RefractiveOptions& o, const camera::Sensor& sensor,
                       const refraction::Shell& shell, std::vector<Obs> obs,
                       std::vector<Eigen::Vector3d> points, std::vector<Eigen::Vector3d> normals, int n_images,
                       int n_air = 0)
      : o_(o), sensor_(sensor), shell_(shell), air_shell_(AirShell(shell)), obs_(std::move(obs)),
        points_(std::move(points)), normals_(std::move(normals)), scale_(ModelScales<M>(sensor)),
        pose_(n_images), first_air_(n_images - n_air) {
    shell_values = refraction::ShellValues(shell);
  }

  // The shell seen from air: the same glass, air outside (indices are relative to air).
  static refraction::Shell AirShell(refraction::Shell s) {
    s.n_water = 1.0;
    return s;
  }
  bool InAir(int image) const { return image >= first_air_; }

  std::array<double, N> lens{};
  PortArray port{};
  ShellArray shell_values{};
  FreeMask lens_free;
  std::array<bool, kPortNumParams> port_free{};
  ShellFree shell_free{};
  double weight = 1;  // 1/σ of the image residuals (px⁻¹)
  std::optional<Prior> prior;
  std::optional<ShellPrior> shell_prior;
  // A calibration made in air through the port (housed_prior.h): a prior on the lens and the port.
  std::optional<HousedPrior> housed;
  // The air images' focal length(s) as a factor on the lens's (RefractiveOptions::air_refocused),
  // adjusted when air_focus_free.
  std::array<double, 1> air_focus{1.0};
  bool air_focus_free = false;
  // A free target (CalibrationOptions::target_free; free_target.h).
  std::optional<FreeTarget> free_target;
  // The target's points (target frame, mm), by id: adjusted in place with a free target.
  std::vector<Eigen::Vector3d>& points() { return points_; }

  // The shell's values as the air images see them (the water factor 1).
  ShellArray AirShellValues() const {
    ShellArray v = shell_values;
    v[0] = 1;
    return v;
  }
  // (Re-)linearises the housed prior at the current lens and port (housed_prior.h); the largest
  // move of its pixels since the last time.
  double LineariseHoused() {
    const ShellArray v = AirShellValues();
    return LineariseHousedPrior<M>(&*housed, sensor_, air_shell_, lens.data(), port.data(), v.data());
  }

  // cam_from_target of each image: angle-axis (rad) then translation (mm), one Ceres block (so
  // that the Schur solver eliminates every pose: bundle.h).
  void SetPose(int image, const Eigen::Vector3d& rotation_rad, const Eigen::Vector3d& translation_mm) {
    pose_[image] = {rotation_rad.x(), rotation_rad.y(), rotation_rad.z(),
                    translation_mm.x(), translation_mm.y(), translation_mm.z()};
  }
  Eigen::Vector3d Rotation(int image) const { return Eigen::Vector3d(pose_[image].data()); }
  Eigen::Vector3d Translation(int image) const { return Eigen::Vector3d(pose_[image].data() + 3); }
  // The target's points in the camera frame at the poses of images [0, n): a network of views
  // like the images' (the housed prior's, housed_prior.h).
  std::vector<std::vector<Eigen::Vector3d>> Views(int n) const {
    std::vector<std::vector<Eigen::Vector3d>> views(n);
    for (int i = 0; i < n; ++i) {
      Eigen::Matrix3d r;
      ceres::AngleAxisToRotationMatrix(pose_[i].data(), r.data());
      for (const auto& x : points_) views[i].push_back(r * x + Translation(i));
    }
    return views;
  }
  std::vector<Obs>& obs() { return obs_; }

  // Adjusts; returns the iterations and the final cost (½Σr², weighted; infinite when some
  // point cannot be projected at the start: nothing is adjusted then).
  int Solve(int max_iterations, double* cost = nullptr) {
    for (const auto& ob : obs_) {
      if (ob.active && !Residual(ob)) {
        if (cost) *cost = INFINITY;
        return 0;
      }
    }
    std::array<double, N> scaled;
    const std::unique_ptr<Bundle> bundle = MakeBundle(&scaled);
    BundleSolveOptions so;
    so.max_iterations = max_iterations;
    so.function_tolerance = 1e-9;
    so.parameter_tolerance = 1e-9;
    so.gradient_tolerance = 1e-12;
    so.num_threads = o_.lens.num_threads;
    const ceres::Solver::Summary summary = bundle->Solve(so);
    for (int i = 0; i < N; ++i) lens[i] = scaled[i] * scale_[i];
    if (cost) *cost = summary.IsSolutionUsable() ? summary.final_cost : INFINITY;
    return static_cast<int>(summary.iterations.size());
  }

  // The σ0²-free covariance (JᵀJ)⁻¹ of [lens (model order), port, shell] (kT × kT), marginal over
  // the poses, in the parameters' own units (0 for parameters not adjusted); false if singular.
  // With the air images' focal factor adjusted, *focus_variance (if given) gets its variance.
  // With a free target, *point_variance (if given) gets the diagonal of each adjusted point's block
  // (mm², likewise σ0²-free; 0 for held coordinates, NaN for points not adjusted).
  bool Covariance(Eigen::MatrixXd* cov, double* focus_variance = nullptr,
                  std::vector<Eigen::Vector3d>* point_variance = nullptr) {
    std::array<double, N> scaled;
    const std::unique_ptr<Bundle> bundle = MakeBundle(&scaled);
    ceres::Problem& problem = bundle->problem();
    ceres::Covariance::Options co;
    co.num_threads = o_.lens.num_threads;
    ceres::Covariance covariance(co);
    // The blocks and their offsets in the joint matrix; the shell only when in the problem.
    std::vector<std::pair<const double*, int>> blocks = {{scaled.data(), 0},
                                                         {port.data(), N}};
    if (UsesShell()) blocks.push_back({shell_values.data(), N + kPortNumParams});
    std::vector<std::pair<const double*, const double*>> pairs;
    for (std::size_t i = 0; i < blocks.size(); ++i) {
      for (std::size_t j = i; j < blocks.size(); ++j) pairs.push_back({blocks[i].first, blocks[j].first});
    }
    const bool with_focus = air_focus_free && problem.HasParameterBlock(air_focus.data());
    if (with_focus) pairs.push_back({air_focus.data(), air_focus.data()});
    const bool with_points = free_target && point_variance != nullptr;
    if (with_points) AddPointCovariancePairs(*free_target, problem, &points_, &pairs);
    if (!covariance.Compute(pairs, &problem)) return false;
    if (with_points && !PointVariances(*free_target, problem, covariance, &points_, point_variance)) return false;
    if (with_focus && focus_variance != nullptr &&
        !covariance.GetCovarianceBlock(air_focus.data(), air_focus.data(), focus_variance)) {
      return false;
    }
    const auto size = [&](const double* b) {
      return b == scaled.data() ? N : b == port.data() ? kPortNumParams : kShellNumParams;
    };
    cov->setZero(kT, kT);
    for (std::size_t i = 0; i < blocks.size(); ++i) {
      for (std::size_t j = i; j < blocks.size(); ++j) {
        const auto [bi, oi] = blocks[i];
        const auto [bj, oj] = blocks[j];
        Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> c(size(bi), size(bj));
        if (!covariance.GetCovarianceBlock(bi, bj, c.data())) return false;
        cov->block(oi, oj, c.rows(), c.cols()) = c;
        cov->block(oj, oi, c.cols(), c.rows()) = c.transpose();
      }
    }
    // The lens block was adjusted scaled: back to the parameters' units.
    Eigen::VectorXd sv = Eigen::VectorXd::Ones(kT);
    for (int i = 0; i < N; ++i) sv(i) = scale_[i];
    *cov = sv.asDiagonal() * *cov * sv.asDiagonal();
    return cov->allFinite();
  }

  // The pixel of `point_in_target_mm` seen in image `image` through the port by the current
  // estimate; nullopt where it cannot be projected.
  std::optional<Eigen::Vector2d> ProjectPoint(int image, const Eigen::Vector3d& point_in_target_mm) const {
    Eigen::Matrix3d r;
    ceres::AngleAxisToRotationMatrix(pose_[image].data(), r.data());
    const Eigen::Vector3d p = r * point_in_target_mm + Translation(image);
    if (InAir(image)) {
      const ShellArray v = AirShellValues();
      std::array<double, N> air_lens = lens;
      for (int k = 0; k < M::kNumFocal; ++k) air_lens[k] *= air_focus[0];
      return refraction::Project<M, double>(sensor_, air_lens.data(), air_shell_, port.data(), p, v.data());
    }
    return refraction::Project<M, double>(sensor_, lens.data(), shell_, port.data(), p, shell_values.data());
  }

  // The image residual of one observation (px, unweighted); nullopt where it cannot be projected.
  std::optional<Eigen::Vector2d> Residual(const Obs& ob) const {
    const auto uv = ProjectPoint(ob.image, points_[ob.point]);
    if (!uv) return std::nullopt;
    return Eigen::Vector2d(*uv - Eigen::Vector2d(ob.u_px, ob.v_px));
  }

  // Circular targets of radius dot_radius_mm > 0 (CalibrationOptions::centre_correction): sets
  // every observation to its measurement minus the centre offset at the current estimate — the
  // centre of the ellipse fitted to 32 points of the dot's rim (in the dot's plane, normal to its
  // TargetNormals) projected through the port and the lens (coded::ImagedCircleCentre), minus
  // the projection of the dot's centre; 0 where a rim point cannot be projected. Returns the
  // largest change of an observation (px); max_centre_offset_px gets the largest offset.
  double UpdateCentreOffsets(double dot_radius_mm) {
    if (!(dot_radius_mm > 0)) return 0;
    double change = 0, largest = 0;
    for (Obs& ob : obs_) {
      const Eigen::Vector3d& x = points_[ob.point];
      const auto project = [&](const Eigen::Vector3d& p) { return ProjectPoint(ob.image, p); };
      const auto projected = project(x);
      const auto [u, v] = coded::DotAxes(normals_[ob.point]);  // the dot's plane
      const auto centre = coded::ImagedCircleCentre(project, x, u, v, dot_radius_mm);
      const Eigen::Vector2d offset = projected && centre ? Eigen::Vector2d(*centre - *projected)
                                                         : Eigen::Vector2d::Zero();
      const Eigen::Vector2d uv = Eigen::Vector2d(ob.measured_u_px, ob.measured_v_px) - offset;
      change = std::max(change, std::hypot(uv.x() - ob.u_px, uv.y() - ob.v_px));
      largest = std::max(largest, offset.norm());
      ob.u_px = uv.x(), ob.v_px = uv.y();
    }
    max_centre_offset_px = largest;
    return change;
  }
  double max_centre_offset_px = 0;

  // Σ|r|² (px², unweighted) over the active observations, and their count.
  double SumSquares(int* n_active) const {
    double ss = 0;
    *n_active = 0;
    for (const auto& ob : obs_) {
      if (!ob.active) continue;
      const auto r = Residual(ob);
      ss += r ? r->squaredNorm() : 0;
      ++*n_active;
    }
    return ss;
  }

  // Σ of the priors' squared residuals at the current lens and shell.
  double PriorSumSquares() const {
    double ss = 0;
    if (prior) {
      Eigen::VectorXd d(prior->idx.size());
      for (std::size_t a = 0; a < prior->idx.size(); ++a) d(a) = lens[prior->idx[a]] - prior->mean(a);
      ss += (prior->whiten * d).squaredNorm();
    }
    if (housed) {
      std::array<double, N> scaled, r;
      for (int i = 0; i < N; ++i) scaled[i] = lens[i] / scale_[i];
      const HousedPriorCost<M> f{&*housed, sensor_, scale_, air_shell_};
      if (f.template Residual<double>(scaled.data(), port.data(), shell_values.data(), r.data())) {
        for (double x : r) ss += x * x;
      } else {
        ss = INFINITY;
      }
    }
    if (shell_prior) {
      ss += (shell_prior->a * Eigen::Map<const Eigen::VectorXd>(shell_values.data(), kShellNumParams) -
             shell_prior->b).squaredNorm();
    }
    return ss + ControlSumSquares();
  }

  // Σ of the control points' squared prior residuals (weight 1) at the current points.
  double ControlSumSquares() const { return free_target ? free_target->ControlSumSquares(points_) : 0.0; }

  bool UsesShell() const {
    return std::find(shell_free.begin(), shell_free.end(), true) != shell_free.end();
  }

 private:
  // The adjustment at the current estimate as a Bundle (bundle.h): the lens (scaled into
  // `scaled`, which must outlive it), the port, the shell's values when some are adjusted, one
  // pose per image, the images in water and in air through the port, the priors.
  std::unique_ptr<Bundle> MakeBundle(std::array<double, N>* scaled) {
    for (int i = 0; i < N; ++i) (*scaled)[i] = lens[i] / scale_[i];
    auto bundle = std::make_unique<Bundle>();
    BundleCamera c;
    c.model = M::kId;
    c.sensor = sensor_;
    c.scaled = scaled->data();
    c.scale.assign(scale_.begin(), scale_.end());
    c.free.assign(lens_free.begin(), lens_free.begin() + N);
    c.water_shell = &shell_;
    c.air_shell = &air_shell_;
    c.port = port.data();
    c.port_free = port_free;
    const bool with_shell = UsesShell();
    if (with_shell) {
      c.shell_values = shell_values.data();
      c.shell_free = shell_free;
    }
    bundle->AddCamera(c);
    for (const auto& ob : obs_) {
      if (!ob.active) continue;
      BundleObservation bo;
      bo.pose = pose_[ob.image].data();
      bo.point = points_[ob.point];
      if (free_target && free_target->Adjusted(ob.point)) bo.point_block = points_[ob.point].data();
      bo.u_px = ob.u_px, bo.v_px = ob.v_px;
      bo.weight = weight;
      bo.medium = InAir(ob.image) ? Medium::kAir : Medium::kWater;
      if (air_focus_free && InAir(ob.image)) bo.focal_scale = air_focus.data();
      bundle->AddObservation(bo);
    }
    if (prior) {
      // r = W(S·scaled − μ) over idx: A = W·E·S, b = W·μ.
      const int m = static_cast<int>(prior->idx.size());
      Eigen::MatrixXd e = Eigen::MatrixXd::Zero(m, N);
      for (int a = 0; a < m; ++a) e(a, prior->idx[a]) = scale_[prior->idx[a]];
      bundle->AddCost(new LinearPriorCost(prior->whiten * e, prior->whiten * prior->mean), {scaled->data()});
    }
    if (housed && with_shell) {
      bundle->AddCost(
          new ceres::AutoDiffCostFunction<HousedPriorShellCost<M>, N, N, kPortNumParams, kShellNumParams>(
              new HousedPriorShellCost<M>{{&*housed, sensor_, scale_, air_shell_}}),
          {scaled->data(), port.data(), shell_values.data()});
    } else if (housed) {
      bundle->AddCost(new ceres::AutoDiffCostFunction<HousedPriorCost<M>, N, N, kPortNumParams>(
                          new HousedPriorCost<M>{&*housed, sensor_, scale_, air_shell_}),
                      {scaled->data(), port.data()});
    }
    if (shell_prior && with_shell) {
      bundle->AddCost(new LinearPriorCost(shell_prior->a, shell_prior->b), {shell_values.data()});
    }
    if (free_target) free_target->AddTo(bundle.get(), &points_);
    return bundle;
  }

  const RefractiveOptions& o_;
  camera::Sensor sensor_;
  refraction::Shell shell_, air_shell_;
  std::vector<Obs> obs_;
  std::vector<Eigen::Vector3d> points_;
  std::vector<Eigen::Vector3d> normals_;  // of each point's dot (TargetNormals)
  std::array<double, N> scale_;
  std::vector<std::array<double, 6>> pose_;
  int first_air_ = 0;  // the first image in air (n_images: none)
};

// The port file's σ (ports::ShellSigma) as a prior on the shell values of `shell` (refraction::
// ShellParams), and the values it adjusts (RefractiveOptions::free_shell); nullopt when the file
// states none. The water index factor has no prior.
std::optional<ShellPrior> ShellPriorOf(const ports::PortSpec& spec, const refraction::Shell& shell) {
  const ShellArray v0 = refraction::ShellValues(shell);
  std::vector<std::pair<Eigen::Matrix<double, 1, kShellNumParams>, double>> rows;  // (a, σ)
  ShellPrior prior;
  // The shape says which σ bears on which of its shell values (index 0 here: the water index
  // factor, which has none). A σ of 0 states the value exactly: it stays fixed.
  const auto row = [&](const std::optional<double>& sigma, std::initializer_list<std::pair<int, double>> terms,
                       int frees) {
    if (!sigma || !(*sigma > 0)) return;
    Eigen::Matrix<double, 1, kShellNumParams> a = Eigen::Matrix<double, 1, kShellNumParams>::Zero();
    for (const auto& [i, c] : terms) a(1 + i) = c;
    rows.push_back({a, *sigma});
    prior.free[1 + frees] = true;
  };
  refraction::VisitKind(shell.kind, [&](auto shape) { decltype(shape)::type::ShellPrior(spec.sigma, row); });
  if (rows.empty()) return std::nullopt;
  const Eigen::Map<const Eigen::Matrix<double, kShellNumParams, 1>> x0(v0.data());
  prior.a.resize(static_cast<int>(rows.size()), kShellNumParams);
  prior.b.resize(static_cast<int>(rows.size()));
  for (std::size_t r = 0; r < rows.size(); ++r) {
    const int k = static_cast<int>(r);
    prior.a.row(k) = rows[r].first / rows[r].second;
    prior.b(k) = prior.a.row(k).dot(x0);
  }
  return prior;
}

// The prior's covariance of the shell values it adjusts ((AᵀA)⁻¹ over them, 0 elsewhere):
// what the port file's σ say of its values.
Eigen::Matrix<double, kShellNumParams, kShellNumParams> ShellPriorCovariance(const ShellPrior& p) {
  std::vector<int> idx;
  for (int i = 0; i < kShellNumParams; ++i) {
    if (p.free[i]) idx.push_back(i);
  }
  Eigen::MatrixXd a(p.a.rows(), static_cast<int>(idx.size()));
  for (std::size_t k = 0; k < idx.size(); ++k) a.col(k) = p.a.col(idx[k]);
  const Eigen::MatrixXd c = (a.transpose() * a).inverse();
  Eigen::Matrix<double, kShellNumParams, kShellNumParams> out =
      Eigen::Matrix<double, kShellNumParams, kShellNumParams>::Zero();
  for (std::size_t i = 0; i < idx.size(); ++i) {
    for (std::size_t j = 0; j < idx.size(); ++j) out(idx[i], idx[j]) = c(i, j);
  }
  return out;
}

// The shell prior the options ask for (free_shell: the port file's σ); throws InvalidInput when
// the file states none.
std::optional<ShellPrior> ShellPriorFor(const RefractiveOptions& o, const refraction::Shell& shell) {
  if (!o.free_shell) return std::nullopt;
  auto prior = ShellPriorOf(o.port.spec, shell);
  if (!prior) {
    throw InvalidInput("free_shell",
                       fmt::format("the port file '{}' states no sigma of its shell (its [sigma] "
                                   "table: outer_radius_mm, inner_radius_mm, thickness_mm, "
                                   "inner_offset_mm; docs/presets.md)",
                                   o.port.spec.name));
  }
  return prior;
}

// The shell values adjusted: the water index factor when asked, the values the prior holds.
ShellFree ShellFreeOf(const RefractiveOptions& o, const std::optional<ShellPrior>& prior) {
  ShellFree f = prior ? prior->free : ShellFree{};
  f[0] = o.free_water_index;
  return f;
}

// c, x0, y0 of simulate's water fit (a central Brown model fitted to rays traced through the
// port) for the Brown lens `lens` behind `base`'s port with the parameters `p` and shell values `v`.
std::array<double, 3> EquivalentCentral(const ports::PortSystem& base, const PortArray& p,
                                        const ShellArray& v, const camera::Camera& lens,
                                        const simulate::FitOptions& fo) {
  const ports::PortSystem sys = ports::Place(refraction::SpecWithParams(base, p, v),
                                             base.ep_in_housing_mm, base.n_glass, base.n_water * v[0]);
  const simulate::CameraSetup setup{lens.sensor, camera::ToBrown(lens), base.ep_in_housing_mm};
  const simulate::BrownFit fit = simulate::SimulateFit(sys, setup, fo);
  return {fit.params.c_mm, fit.params.x0_mm, fit.params.y0_mm};
}

// CentralPrediction (refractive.h): `cov` is the σ0-scaled joint covariance [lens, port, shell] of
// the estimate, `prior` the in-air prior the adjustment used (kPrior), `shell_prior` the port
// file's (free_shell), `ranges` the images' target distances (mm). The shell values `shell` enter
// as the lens and port do: the prediction uses the port file's (factor 1) with the prior's
// covariance, the estimate's cross-covariance with them is its own over the values the prior
// adjusts (linear model: Cov(x̂, x₀) = Σ_post·AᵀΣ_m⁻¹A·(AᵀΣ_m⁻¹A)⁻¹ = Σ_post).
CentralPrediction CompareCentral(const RefractiveOptions& o, const CalibrationResult& central,
                                 const camera::Camera& lens, const PortArray& port,
                                 const ShellArray& shell, const PortArray& predicted_sigma,
                                 const Eigen::MatrixXd& cov, const std::optional<Prior>& prior,
                                 const std::optional<ShellPrior>& shell_prior,
                                 const std::vector<double>& ranges) {
  CentralPrediction cp;
  if (lens.model != camera::CameraModelId::kBrown) {
    cp.why_not = fmt::format("the simulate prediction fits Brown's c, x0, y0; a {} lens has none",
                             lens.model_name());
    return cp;
  }
  if (!o.air) {
    cp.why_not = "needs `air_calibration`, the in-air lens the prediction puts behind the port";
    return cp;
  }
  const int N = lens.info().num_params, S = N + kPortNumParams, T = S + kShellNumParams;
  const auto [lo, hi] = std::minmax_element(ranges.begin(), ranges.end());
  // Two planes at one range cannot separate c from the centre's Z (simulate.h): span ≥ 1.3×.
  const double far = std::max(*hi, 1.3 * *lo);
  simulate::FitOptions fo;
  fo.grid_cols = 13;
  fo.grid_rows = 9;
  fo.distances_mm = {*lo, 0.5 * (*lo + far), far};
  cp.distances_mm = fo.distances_mm;
  const PortArray predicted = refraction::ParamsOf(o.port);
  const ShellArray shell_predicted = refraction::ShellValues(refraction::ShellOf(o.port));
  const auto pred = EquivalentCentral(o.port, predicted, shell_predicted, o.air->camera, fo);
  const auto est = EquivalentCentral(o.port, port, shell, lens, fo);
  // Covariances, NaN (fixed) → 0.
  const auto clean = [](Eigen::MatrixXd m) { return m.unaryExpr([](double v) { return std::isfinite(v) ? v : 0.0; }).eval(); };
  const Eigen::MatrixXd post = clean(cov);
  Eigen::MatrixXd pred_cov = Eigen::MatrixXd::Zero(T, T);
  const bool air_cov = o.intrinsics != IntrinsicsMode::kFixed && o.air->has_covariance &&
                       o.air->covariance.rows() == N;
  if (air_cov) pred_cov.topLeftCorner(N, N) = clean(o.air->covariance);
  for (int i = 0; i < kPortNumParams; ++i) {
    if (o.port_free[i]) pred_cov(N + i, N + i) = predicted_sigma[i] * predicted_sigma[i];
  }
  Eigen::MatrixXd cross = Eigen::MatrixXd::Zero(T, T);  // Cov(estimate, in-air lens)
  if (prior && air_cov) {
    const int m = static_cast<int>(prior->idx.size());
    const Eigen::MatrixXd w = prior->whiten.transpose() * prior->whiten;  // Σ_air[idx]⁻¹
    Eigen::MatrixXd post_idx(T, m), air_idx(m, N);
    for (int a = 0; a < m; ++a) {
      post_idx.col(a) = post.col(prior->idx[a]);
      air_idx.row(a) = pred_cov.topLeftCorner(N, N).row(prior->idx[a]);
    }
    cross.leftCols(N) = post_idx * w * air_idx;
  }
  if (shell_prior) {
    pred_cov.bottomRightCorner(kShellNumParams, kShellNumParams) = ShellPriorCovariance(*shell_prior);
    for (int i = 0; i < kShellNumParams; ++i) {
      if (shell_prior->free[i]) cross.col(S + i) = post.col(S + i);
    }
  }
  // J by central differences, one σ steps, over the parameters that carry variance.
  Eigen::MatrixXd jac = Eigen::MatrixXd::Zero(3, T);
  for (int i = 0; i < T; ++i) {
    const double h = std::sqrt(std::max(post(i, i), pred_cov(i, i)));
    if (!(h > 0)) continue;
    camera::Camera lp = lens, lm = lens;
    PortArray pp = port, pm = port;
    ShellArray vp = shell, vm = shell;
    if (i < N) {
      lp.params[i] += h;
      lm.params[i] -= h;
    } else if (i < S) {
      pp[i - N] += h;
      pm[i - N] -= h;
    } else {
      vp[i - S] += h;
      vm[i - S] -= h;
    }
    try {
      const auto fp = EquivalentCentral(o.port, pp, vp, lp, fo);
      const auto fm = EquivalentCentral(o.port, pm, vm, lm, fo);
      for (int k = 0; k < 3; ++k) jac(k, i) = (fp[k] - fm[k]) / (2 * h);
    } catch (const InvalidInput& e) {  // the estimate ± 1σ is no port: nothing to propagate
      cp.why_not = fmt::format("{} ± 1 sigma is not a valid port ({}): the estimate is not "
                               "determined well enough to compare", JointParamName(lens.model,
                               refraction::ShellOf(o.port).kind, i, false), e.what());
      return cp;
    }
  }
  const Eigen::Matrix3d s_est = jac * post * jac.transpose();
  const Eigen::Matrix3d s_pred = jac * pred_cov * jac.transpose();
  const Eigen::Matrix3d s_d = jac * (post + pred_cov - cross - cross.transpose()) * jac.transpose();
  Eigen::Vector3d d;
  for (int k = 0; k < 3; ++k) {
    cp.predicted[k] = pred[k];
    cp.estimated[k] = est[k];
    cp.predicted_sigma[k] = std::sqrt(s_pred(k, k));
    cp.estimated_sigma[k] = std::sqrt(s_est(k, k));
    cp.central[k] = central.camera.params[k];
    cp.central_sigma[k] = k < static_cast<int>(central.sigma.size()) ? central.sigma[k] : NAN;
    d(k) = est[k] - pred[k];
  }
  cp.chi2 = d.dot(s_d.ldlt().solve(d));
  cp.p_value = UpperIncompleteGammaQ(0.5 * cp.dof, 0.5 * cp.chi2);
  cp.differs = cp.p_value < o.alpha;
  cp.available = std::isfinite(cp.chi2);
  if (!cp.available) cp.why_not = "the difference's covariance is singular";
  return cp;
}

// The lens the adjustment starts from: the in-air calibration, or the central calibration of the
// water images with its distortion zeroed and, behind a flat port, its focal length / n_water.
camera::Camera StartLens(const RefractiveOptions& o, const CalibrationResult& central,
                         const refraction::Shell& shell, const CalibrationResult* central_air = nullptr) {
  camera::Camera start = central.camera;
  if (o.air) {
    start.params = o.air->camera.params;
    return start;
  }
  if (central_air != nullptr) {  // the air images through the port: close to the lens itself
    start.params = central_air->camera.params;
    return start;
  }
  const camera::ModelInfo& info = start.info();
  for (int i = info.first_distortion; i < info.num_params; ++i) start.params[i] = 0;
  if (shell.kind == PortKind::kFlat) {
    camera::SetFocalLengthPx(&start, start.FocalLengthPx() / shell.n_water);
  }
  return start;
}

// The adjusted lens parameters of the intrinsics mode.
FreeMask LensFree(const RefractiveOptions& o) {
  const camera::ModelInfo& info = camera::Info(o.lens.model);
  if (o.intrinsics == IntrinsicsMode::kFree) return o.lens.FreeOrDefault();
  FreeMask free(info.num_params, false);
  if (o.intrinsics == IntrinsicsMode::kPrior) {
    free = o.air->free;
    for (int i = 0; i < info.num_focal; ++i) free[i] = true;
  }
  return free;
}

// An in-air calibration made through the port (the housing on) used as a prior: on the lens and
// the port together (housed_prior.h), every parameter it adjusted, the focal length(s) too (one
// focus for both sets, as with air images).
bool Housed(const RefractiveOptions& o) {
  return o.air && o.air_of == RefractiveOptions::AirCalibrationOf::kThroughPort &&
         o.intrinsics == IntrinsicsMode::kPrior;
}

// The in-air calibration of the lens alone as a prior (kPrior: every parameter it adjusted but the
// focal length(s)); nullopt in the other modes, for a housed calibration, or when it adjusted
// nothing else.
std::optional<Prior> MakePrior(const RefractiveOptions& o) {
  if (o.intrinsics != IntrinsicsMode::kPrior || Housed(o)) return std::nullopt;
  const camera::ModelInfo& info = camera::Info(o.lens.model);
  Prior prior;
  for (int i = info.num_focal; i < info.num_params; ++i) {
    if (o.air->free[i]) prior.idx.push_back(i);
  }
  if (prior.idx.empty()) return std::nullopt;
  const WhitenedPrior w = WhitenedPriorOf(*o.air, prior.idx, "air_calibration");
  prior.mean = w.mean;
  prior.whiten = w.whiten;
  return prior;
}

// "" or the warning that every target sits at one range (max < 1.3 × min of `ranges_mm`, the
// targets' distances from the pupil): a flat port's distance and a dome pupil's axial offset are
// then weakly observable.
std::string RangeWarning(const std::vector<double>& ranges_mm) {
  if (ranges_mm.empty()) return "";
  const auto [lo, hi] = std::minmax_element(ranges_mm.begin(), ranges_mm.end());
  if (*hi >= 1.3 * *lo) return "";
  return fmt::format("all targets at one range ({:.0f}-{:.0f} mm): the port's axial parameter "
                     "is weakly observable, add views at another range", *lo, *hi);
}

// The correlation matrix of `cov` over the free parameters (NaN elsewhere).
Eigen::MatrixXd Correlation(const Eigen::MatrixXd& cov, const std::vector<bool>& free) {
  const int t = static_cast<int>(cov.rows());
  Eigen::MatrixXd corr = Eigen::MatrixXd::Constant(t, t, NAN);
  for (int i = 0; i < t; ++i) {
    for (int j = 0; j < t; ++j) {
      if (free[i] && free[j]) corr(i, j) = cov(i, j) / std::sqrt(cov(i, i) * cov(j, j));
    }
  }
  return corr;
}

double Bic(double rss, int n, int k) {
  return n * std::log(rss / n) + k * std::log(static_cast<double>(n));
}

template <typename M>
RefractiveResult CalibrateRefractiveModel(const std::vector<ImageDetections>& detections,
                                          const TargetSpec& target, const RefractiveOptions& o,
                                          const CalibrationResult& central,
                                          const CalibrationResult* central_air) {
  constexpr int N = M::kNumParams;
  const auto t0 = std::chrono::steady_clock::now();
  const auto say = [&](const std::string& m) {
    if (o.lens.progress) o.lens.progress(m);
  };
  const camera::ModelInfo& info = camera::Info(M::kId);
  const camera::Sensor sensor = central.camera.sensor;
  const refraction::Shell shell = refraction::ShellOf(o.port);
  const PortArray predicted = refraction::ParamsOf(o.port);
  refraction::ValidateParams(shell, predicted.data(), "port");

  RefractiveResult res;
  res.intrinsics = o.intrinsics;
  res.kind = shell.kind;
  res.predicted = predicted;
  res.predicted_sigma = o.predicted_sigma ? *o.predicted_sigma : refraction::PredictedSigmaOf(shell.kind);
  res.port_free = o.port_free;
  res.shell_predicted = refraction::ShellValues(shell);
  const std::optional<ShellPrior> shell_prior = ShellPriorFor(o, shell);
  res.shell_free = ShellFreeOf(o, shell_prior);

  // The images the central calibrations used, with their poses: the water images, then the air
  // images (options.air_detections) as images [n_images, n_total).
  std::vector<Obs> obs;
  std::vector<const ImageResult*> start_pose;
  const auto add_set = [&](const std::vector<ImageDetections>& set, const CalibrationResult& c) {
    std::map<std::string, const ImageDetections*> by_name;
    for (const auto& d : set) by_name[d.image] = &d;
    for (const ImageResult& im : c.images) {
      const int i = static_cast<int>(start_pose.size());
      start_pose.push_back(&im);
      const ImageDetections* d = by_name.at(im.image);
      for (std::size_t k = 0; k < d->ids.size(); ++k) {
        const Eigen::Vector2d& uv = d->points_px[k];
        obs.push_back({i, d->ids[k], uv.x(), uv.y(), true, uv.x(), uv.y()});
      }
    }
  };
  add_set(detections, central);
  const int n_images = static_cast<int>(start_pose.size());  // in water
  if (central_air != nullptr) add_set(o.air_detections, *central_air);
  const int n_total = static_cast<int>(start_pose.size());
  const int n_air = n_total - n_images;
  RefractiveAdjustment<M> adj(o, sensor, shell, obs, TargetPoints(target), TargetNormals(target), n_total,
                              n_air);
  // A free target: the points from the central calibration of the water images (which adjusted
  // them too), its datum held (the minimal one at the nominal values, or the control points).
  int n_point_unknowns = 0, n_control_prior = 0;
  if (o.lens.target_free) {
    adj.points() = central.target_points_mm;
    std::set<int> observed;
    for (const Obs& ob : obs) observed.insert(ob.point);
    adj.free_target = FreeTargetOf(central, observed, target, &adj.points());
    n_point_unknowns = adj.free_target->n_unknowns;
    n_control_prior = adj.free_target->n_prior;
  }
  const auto set_poses = [&] {
    for (int i = 0; i < n_total; ++i) {
      const ImageResult& im = *start_pose[i];
      adj.SetPose(i, im.rotation_rad, im.translation_mm);
    }
  };

  // The lens's start and free set.
  const camera::Camera start = StartLens(o, central, shell, central_air);
  const FreeMask lens_free = LensFree(o);
  adj.lens_free = lens_free;
  adj.port_free = o.port_free;
  adj.air_focus_free = o.air_refocused && n_air > 0;

  // 1-D search of the axial port parameter (dome and cylinder ep_z, flat distance) around the
  // prediction.
  const int axial = refraction::AxialSearchOf(shell.kind).param;
  std::vector<double> candidates = refraction::AxialSearchOf(shell.kind).Candidates(predicted[axial]);
  if (!o.port_free[axial] || !o.search) candidates.resize(1);
  // Circular targets: the centre correction (CalibrationOptions::centre_correction) with the dot
  // radius the central calibration used (0: off). Its offsets are computed at the start (the
  // predicted port) for the search, then recomputed after every adjustment until they settle.
  const double dot_r = central.dot_radius_mm;
  std::copy(start.params.begin(), start.params.end(), adj.lens.begin());
  adj.port = predicted;
  set_poses();
  adj.UpdateCentreOffsets(dot_r);
  double best_cost = INFINITY, best_axial = predicted[axial];
  int iterations = 0;
  for (double c : candidates) {
    PortArray p = predicted;
    p[axial] = c;
    try {
      refraction::ValidateParams(shell, p.data(), "port");
    } catch (const InvalidInput&) {
      continue;
    }
    std::copy(start.params.begin(), start.params.end(), adj.lens.begin());
    adj.port = p;
    adj.air_focus = {1.0};
    set_poses();
    double cost = INFINITY;
    iterations += adj.Solve(candidates.size() > 1 ? 4 : 0, &cost);
    say(fmt::format("start: {} = {:.2f} {} -> RMS {:.3f} px", refraction::PortParams(shell.kind)[axial].name, c,
                    refraction::PortParams(shell.kind)[axial].unit,
                    std::sqrt(2 * cost / obs.size())));
    if (cost < best_cost) best_cost = cost, best_axial = c;
  }
  if (!std::isfinite(best_cost)) {
    throw InvalidInput("port", "no start of the port parameters projects the target points: "
                                 "check the port, the pupil and the water");
  }
  std::copy(start.params.begin(), start.params.end(), adj.lens.begin());
  adj.port = predicted;
  adj.port[axial] = best_axial;
  adj.air_focus = {1.0};
  set_poses();

  // Adjust with outlier rejection (as Calibrate), the water index factor free when asked but the
  // shell geometry fixed; then, with a prior (in-air lens, shell), weight the images by 1/σ0, add
  // the priors and free the shell values they hold.
  // One adjustment, repeated while the centre offsets move (as Calibrate: at most 10 rounds, until
  // no observation moves by 1e-5 px; the offsets' own derivatives are left out).
  const auto solve = [&] {
    for (int k = 0; k < 10; ++k) {
      iterations += adj.Solve(o.lens.max_iterations);
      if (adj.UpdateCentreOffsets(dot_r) < 1e-5) break;
    }
  };
  int n_port_free = 0, n_lens_free = 0, n_shell_free = 0;
  for (bool f : o.port_free) n_port_free += f;
  for (bool f : lens_free) n_lens_free += f;
  for (bool f : res.shell_free) n_shell_free += f;
  adj.shell_free[0] = res.shell_free[0];
  const int n_focus_free = adj.air_focus_free ? 1 : 0;
  const int n_unknowns_first =
      n_lens_free + n_port_free + adj.shell_free[0] + n_focus_free + 6 * n_total + n_point_unknowns;
  const int n_unknowns = n_lens_free + n_port_free + n_shell_free + n_focus_free + 6 * n_total + n_point_unknowns;
  double ss = 0;
  int n_active = 0;
  for (int round = 0;; ++round) {
    solve();
    ss = adj.SumSquares(&n_active);
    const int redundancy = 2 * n_active + n_control_prior - n_unknowns_first;
    if (redundancy <= 0) {
      throw InvalidInput("images", fmt::format("{} points in {} images give {} observations for "
                                                 "{} unknowns: add images", n_active, n_total,
                                                 2 * n_active, n_unknowns_first));
    }
    const double sigma0 = std::sqrt(ss / redundancy);
    if (o.lens.reject_k <= 0 || round >= o.lens.max_reject_rounds) break;
    int rejected = 0;
    for (auto& ob : adj.obs()) {
      if (!ob.active) continue;
      const auto r = adj.Residual(ob);
      if (!r || r->norm() > o.lens.reject_k * sigma0) ob.active = false, ++rejected;
    }
    if (rejected == 0) break;
    say(fmt::format("rejected {} points beyond {:g} sigma0 ({:.3f} px); readjusting", rejected,
                    o.lens.reject_k, sigma0));
  }
  int n_prior = n_control_prior;
  const std::optional<Prior> used_prior = MakePrior(o);
  if (Housed(o)) {
    adj.housed = MakeHousedPrior<M>(*o.air, adj.Views(n_images));
  }
  if (used_prior || shell_prior || adj.housed || n_control_prior > 0) {
    // The images weighted by 1/σ0 of the first pass (its control priors counted as σ0 = 1 px).
    adj.weight = 1 / std::sqrt((ss + adj.ControlSumSquares()) / (2 * n_active + n_control_prior - n_unknowns_first));
    if (used_prior) n_prior += static_cast<int>(used_prior->idx.size());
    if (shell_prior) n_prior += static_cast<int>(shell_prior->a.rows());
    if (adj.housed) n_prior += static_cast<int>(adj.housed->idx.size());
    adj.prior = used_prior;
    adj.shell_prior = shell_prior;
    adj.shell_free = res.shell_free;
    if (!adj.housed) {
      solve();
    } else {
      // The housed prior is linearised at the estimate: adjust, re-linearise at the new estimate,
      // until its pixels move by less than 1e-4 px (at most 8 rounds).
      adj.LineariseHoused();
      for (int round = 0; round < 8; ++round) {
        solve();
        const double moved = adj.LineariseHoused();
        say(fmt::format("in-air calibration through the port: central fit RMS {:.4f} px, its pixels moved "
                        "{:.2g} px", adj.housed->fit_rms_px, moved));
        if (moved < 1e-4) break;
      }
      res.housed_fit_rms_px = adj.housed->fit_rms_px;
    }
    ss = adj.SumSquares(&n_active);
  }

  // Statistics.
  CalibrationResult& lr = res.lens;
  lr.camera = central.camera;
  lr.camera.params.assign(adj.lens.begin(), adj.lens.end());
  lr.free = lens_free;
  lr.dot_radius_mm = dot_r;
  lr.max_centre_offset_px = adj.max_centre_offset_px;
  lr.n_images = n_total;
  lr.n_points = n_active;
  lr.n_unknowns = n_unknowns;
  lr.redundancy = 2 * n_active + n_prior - n_unknowns;
  lr.iterations = iterations;
  lr.rms_px = std::sqrt(ss / n_active);
  lr.sigma0_px = std::sqrt(ss / (2 * n_active - n_unknowns + n_prior));
  const double weighted_ss = ss * adj.weight * adj.weight + adj.PriorSumSquares();
  const double s0w2 = weighted_ss / lr.redundancy;  // σ0² of the weighted adjustment
  say(fmt::format("adjusted: RMS {:.4f} px, {} iterations; covariance", lr.rms_px, iterations));
  Eigen::MatrixXd cov;
  double focus_variance = NAN;
  std::vector<Eigen::Vector3d> point_variance;
  lr.covariance_ok = adj.Covariance(&cov, &focus_variance, o.lens.target_free ? &point_variance : nullptr);
  constexpr int S = N + kPortNumParams, T = S + kShellNumParams;
  if (!lr.covariance_ok) {
    throw InvalidInput("images", std::string("the port parameters and the lens are not determined "
                                               "by these images (singular covariance): add views at "
                                               "other ranges and angles, or fix parameters "
                                               "(`intrinsics` fixed, `free`") +
                                       (n_shell_free > 0 ? ", without `free_water_index`, `free_shell`)" : ")"));
  }
  cov *= s0w2;
  std::vector<bool> free_all(T);
  for (int i = 0; i < N; ++i) free_all[i] = lens_free[i];
  for (int i = 0; i < kPortNumParams; ++i) free_all[N + i] = o.port_free[i];
  for (int i = 0; i < kShellNumParams; ++i) free_all[S + i] = res.shell_free[i];
  res.covariance = cov;
  res.correlation = Correlation(cov, free_all);
  lr.covariance = cov.topLeftCorner(N, N);
  lr.sigma.assign(N, NAN);
  lr.correlation = res.correlation.topLeftCorner(N, N);
  for (int i = 0; i < N; ++i) {
    if (!lens_free[i]) continue;
    lr.sigma[i] = std::sqrt(cov(i, i));
    if (i >= info.first_distortion) {
      const double t = std::abs(adj.lens[i]) / lr.sigma[i];
      lr.significance.push_back({i, t, t >= o.lens.significance_t});
    }
  }
  res.port = adj.port;
  for (int i = 0; i < kPortNumParams; ++i) {
    res.port_sigma[i] = o.port_free[i] ? std::sqrt(cov(N + i, N + i)) : NAN;
  }
  res.shell = adj.shell_values;
  for (int i = 0; i < kShellNumParams; ++i) {
    res.shell_sigma[i] = res.shell_free[i] ? std::sqrt(cov(S + i, S + i)) : NAN;
  }
  res.n_water = o.port.n_water * res.shell[0];
  if (adj.air_focus_free) {
    res.air_focal_scale = adj.air_focus[0];
    res.air_focal_scale_sigma = std::sqrt(s0w2 * focus_variance);
  }
  // Per image; the water images' sum of squares alone for the model choice.
  std::vector<double> image_ss(n_total, 0);
  std::vector<ImageResult> all_images(n_total);
  double water_ss = 0;
  int n_water_active = 0;
  for (const auto& ob : adj.obs()) {
    auto& im = all_images[ob.image];
    if (!ob.active) {
      ++im.n_rejected;
      ++lr.n_rejected;
      continue;
    }
    const auto r = adj.Residual(ob);
    image_ss[ob.image] += r ? r->squaredNorm() : 0;
    if (ob.image < n_images) water_ss += r ? r->squaredNorm() : 0, ++n_water_active;
    ++im.n_points;
  }
  std::vector<double> ranges;  // of the water images: where the port's axial parameter shows
  for (int i = 0; i < n_total; ++i) {
    auto& im = all_images[i];
    im.image = start_pose[i]->image;
    im.rms_px = im.n_points > 0 ? std::sqrt(image_ss[i] / im.n_points) : NAN;
    im.rotation_rad = adj.Rotation(i);
    im.translation_mm = adj.Translation(i);
    if (i < n_images) ranges.push_back(im.translation_mm.norm());
  }
  lr.images.assign(all_images.begin(), all_images.begin() + n_images);
  res.air_images.assign(all_images.begin() + n_images, all_images.end());
  if (n_air > 0) {
    double air_ss = 0;
    int n_air_points = 0;
    for (int i = n_images; i < n_total; ++i) air_ss += image_ss[i], n_air_points += all_images[i].n_points;
    res.air_rms_px = std::sqrt(air_ss / n_air_points);
    res.water_rms_px = std::sqrt(water_ss / n_water_active);
  }
  lr.target_points_mm = adj.points();
  if (o.lens.target_free) {
    lr.datum = central.datum;
    lr.target_sigma_mm = adj.free_target->Sigma(point_variance, s0w2, adj.points().size());
  }

  // χ² of the estimate against the prediction.
  std::vector<int> pf;
  for (int i = 0; i < kPortNumParams; ++i) {
    if (o.port_free[i]) pf.push_back(i);
  }
  res.dof = static_cast<int>(pf.size());
  if (res.dof > 0) {
    Eigen::VectorXd d(res.dof);
    Eigen::MatrixXd s(res.dof, res.dof);
    for (int a = 0; a < res.dof; ++a) {
      d(a) = res.port[pf[a]] - predicted[pf[a]];
      for (int b = 0; b < res.dof; ++b) s(a, b) = cov(N + pf[a], N + pf[b]);
      s(a, a) += res.predicted_sigma[pf[a]] * res.predicted_sigma[pf[a]];
    }
    res.chi2 = d.dot(s.ldlt().solve(d));
    res.p_value = UpperIncompleteGammaQ(0.5 * res.dof, 0.5 * res.chi2);
    res.port_differs = res.p_value < o.alpha;
  }
  if (shell.kind == PortKind::kFlat) {
    const auto ge = refraction::MakeGeometry<double>(shell, res.port.data());
    const auto gp = refraction::MakeGeometry<double>(shell, predicted.data());
    res.normal_tilt_from_predicted_deg =
        std::atan2(ge.normal.cross(gp.normal).norm(), ge.normal.dot(gp.normal)) * 180 / M_PI;
  }

  // Model choice against the central calibration of the same images: with air images, against
  // the usual practice of two central calibrations (one of the air set, one of the water set).
  double central_rss = central.rms_px * central.rms_px * central.n_points;
  int central_n = central.n_points;
  res.central_k = central.n_unknowns;
  if (central_air != nullptr) {
    central_rss += central_air->rms_px * central_air->rms_px * central_air->n_points;
    central_n += central_air->n_points;
    res.central_k += central_air->n_unknowns;
  }
  res.central_rms_px = std::sqrt(central_rss / central_n);
  res.central_bic = Bic(central_rss, 2 * central_n, res.central_k);
  res.k = n_unknowns;
  res.bic = Bic(ss, 2 * n_active, n_unknowns);
  res.preferred = res.bic < res.central_bic ? "refractive" : "central";

  refraction::ValidateParams(shell, res.port.data(), "port");
  // An estimate that is no shell (a water index below 1: images not taken in water; an inner
  // sphere outside the outer one) is refused, naming the option that freed it.
  refraction::ValidateShellValues(shell, res.shell,
                                  n_shell_free > res.shell_free[0] ? "free_shell" : "free_water_index");
  res.estimated_port = refraction::SpecWithParams(o.port, res.port, res.shell);
  // The file's σ of a value adjusted here were its prior: the estimate's σ are in the JSON, and a
  // port file read again must not count that prior twice. σ of values not adjusted stay.
  ports::ShellSigma& sg = res.estimated_port.sigma;
  if (res.shell_free[1]) sg.outer_radius_mm.reset();
  if (res.shell_free[2] || (shell.kind == PortKind::kFlat && res.shell_free[1])) {
    sg.inner_radius_mm.reset();
    sg.thickness_mm.reset();
  }
  if (res.shell_free[3] || res.shell_free[4] || res.shell_free[5]) sg.inner_offset_mm.reset();
  res.estimated_port.description = fmt::format("{} as calibrated from images ({})",
                                               o.port.spec.name, o.port.spec.description);
  res.estimated_port.source = "porthole calibrate through the port: estimated from images";
  res.estimated_port.name = o.port.spec.name + "-as-calibrated";

  if (o.compare_central && n_air > 0) {
    res.central_prediction.why_not = "the lens was adjusted with the air images, not taken from an in-air calibration";
  } else if (o.compare_central && o.air && o.air_of == RefractiveOptions::AirCalibrationOf::kThroughPort) {
    res.central_prediction.why_not =
        "the in-air calibration was made through the port: the prediction needs the lens alone";
  } else if (o.compare_central) {
    say("comparing the simulate prediction of c, x0, y0");
    res.central_prediction = CompareCentral(o, central, lr.camera, res.port, res.shell,
                                            res.predicted_sigma, cov, used_prior, shell_prior, ranges);
  } else {
    res.central_prediction.why_not = "not asked for";
  }

  const std::string warning = RangeWarning(ranges);
  if (!warning.empty()) say("warning: " + warning);
  const std::string poor = PoorFitStatus(lr.rms_px);  // a port "consistent with the prediction" at RMS 1362 px is no result
  if (!poor.empty()) say("warning: " + poor);
  lr.message = !poor.empty() ? poor : warning.empty() ? "ok" : "ok; " + warning;
  res.message = lr.message;
  lr.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  say(fmt::format("done: sigma0 {:.4f} px, RMS {:.4f} px, {} iterations, {:.3f} s", lr.sigma0_px,
                  lr.rms_px, iterations, lr.seconds));
  return res;
}

template <typename M>
RefractivePlan PlanModel(const std::vector<ImageResult>& poses, const TargetSpec& target,
                         const camera::Camera& lens, const RefractiveOptions& o, double sigma0_px) {
  constexpr int N = M::kNumParams;
  const refraction::Shell shell = refraction::ShellOf(o.port);
  const PortArray port = refraction::ParamsOf(o.port);
  refraction::ValidateParams(shell, port.data(), "port");
  RefractivePlan plan;
  plan.model = M::kId;
  plan.kind = shell.kind;
  plan.sigma0_px = sigma0_px;
  plan.port_free = o.port_free;
  const std::optional<ShellPrior> shell_prior = ShellPriorFor(o, shell);
  plan.shell_free = ShellFreeOf(o, shell_prior);
  const std::vector<Eigen::Vector3d> points = TargetPoints(target);
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const auto& p : points) centre += p / static_cast<double>(points.size());
  const camera::Sensor& sensor = lens.sensor;
  std::vector<Obs> obs;
  std::vector<double> ranges;
  std::vector<const ImageResult*> used;
  for (const auto& pose : poses) {
    Eigen::Matrix3d r;
    ceres::AngleAxisToRotationMatrix(pose.rotation_rad.data(), r.data());
    std::vector<Obs> seen;
    for (std::size_t k = 0; k < points.size(); ++k) {
      const auto uv = refraction::Project<M, double>(sensor, lens.params.data(), shell, port.data(),
                                                     r * points[k] + pose.translation_mm);
      if (!uv || uv->x() < 0 || uv->y() < 0 || uv->x() > sensor.width_px - 1 ||
          uv->y() > sensor.height_px - 1) {
        continue;
      }
      seen.push_back({static_cast<int>(used.size()), static_cast<int>(k), uv->x(), uv->y(), true, uv->x(), uv->y()});
    }
    if (seen.size() < 4) continue;  // as Calibrate: an image needs 4 points
    obs.insert(obs.end(), seen.begin(), seen.end());
    ranges.push_back((r * centre + pose.translation_mm).norm());
    used.push_back(&pose);
  }
  plan.n_images = static_cast<int>(used.size());
  plan.n_points = static_cast<int>(obs.size());
  if (used.empty()) throw InvalidInput("images", "no pose sees 4 target points through the port");
  RefractiveAdjustment<M> adj(o, sensor, shell, obs, points, TargetNormals(target), plan.n_images);
  for (int i = 0; i < plan.n_images; ++i) {
    const auto& p = *used[i];
    adj.SetPose(i, p.rotation_rad, p.translation_mm);
  }
  std::copy(lens.params.begin(), lens.params.end(), adj.lens.begin());
  adj.port = port;
  adj.lens_free = LensFree(o);
  adj.port_free = o.port_free;
  adj.weight = 1 / sigma0_px;
  adj.prior = MakePrior(o);
  adj.shell_prior = shell_prior;
  adj.shell_free = plan.shell_free;
  if (Housed(o)) {  // linearised at the design (the housed calibration's lens behind the port)
    adj.housed = MakeHousedPrior<M>(*o.air, adj.Views(plan.n_images));
    adj.LineariseHoused();
  }
  const auto [lo, hi] = std::minmax_element(ranges.begin(), ranges.end());
  plan.min_range_mm = *lo;
  plan.max_range_mm = *hi;
  plan.warning = RangeWarning(ranges);
  Eigen::MatrixXd cov;
  plan.determined = adj.Covariance(&cov);
  plan.lens_sigma.assign(N, NAN);
  plan.port_sigma.fill(NAN);
  plan.shell_sigma.fill(NAN);
  if (!plan.determined) {
    plan.warning = "the port parameters and the lens are not determined by this network (singular "
                   "covariance): add views at other ranges and angles, or fix parameters" +
                   (plan.warning.empty() ? "" : "; " + plan.warning);
    return plan;
  }
  constexpr int S = N + kPortNumParams;
  std::vector<bool> free_all(S + kShellNumParams);
  for (int i = 0; i < N; ++i) free_all[i] = adj.lens_free[i];
  for (int i = 0; i < kPortNumParams; ++i) free_all[N + i] = o.port_free[i];
  for (int i = 0; i < kShellNumParams; ++i) free_all[S + i] = plan.shell_free[i];
  plan.covariance = cov;
  plan.correlation = Correlation(cov, free_all);
  for (int i = 0; i < N; ++i) {
    if (free_all[i]) plan.lens_sigma[i] = std::sqrt(cov(i, i));
  }
  for (int i = 0; i < kPortNumParams; ++i) {
    if (o.port_free[i]) plan.port_sigma[i] = std::sqrt(cov(N + i, N + i));
  }
  for (int i = 0; i < kShellNumParams; ++i) {
    if (plan.shell_free[i]) plan.shell_sigma[i] = std::sqrt(cov(S + i, S + i));
  }
  return plan;
}

// Checks shared by the refractive calibration and its plan.
void CheckOptions(const RefractiveOptions& o) {
  ShellPriorFor(o, refraction::ShellOf(o.port));  // --free-shell needs the port file's σ
  if (o.intrinsics != IntrinsicsMode::kFree && !o.air) {
    throw InvalidInput("intrinsics", ToString(o.intrinsics) + " needs `air_calibration`");
  }
  if (o.air_refocused && o.air_detections.empty()) {
    throw InvalidInput("air_refocused", "says the air images were taken at another focus: give `air_images` or "
                                        "`air_detections`");
  }
  if (o.air && !o.air_detections.empty()) {
    throw InvalidInput("air_calibration",
                       "not with `air_detections`: the lens comes from the air images adjusted with the water "
                       "ones; give one of them");
  }
  if (o.air && o.air_of == RefractiveOptions::AirCalibrationOf::kThroughPort &&
      o.intrinsics == IntrinsicsMode::kFixed) {
    throw InvalidInput("intrinsics",
                       "fixed holds the lens at the in-air calibration, and one made through the port (the "
                       "housing on) is not the lens: take it as a prior (`intrinsics` prior), or say it is the "
                       "lens alone (`air_lens_bare`)");
  }
  if (o.air) {
    if (o.air->camera.model != o.lens.model) {
      throw InvalidInput("air_calibration",
                         fmt::format("a {} calibration cannot start a {} one",
                                     o.air->camera.model_name(), camera::Info(o.lens.model).name));
    }
    // A prior needs the in-air covariance; a file without σ (OpenCV YAML, COLMAP, mrcal) is
    // refused rather than given an invented one.
    if (o.intrinsics == IntrinsicsMode::kPrior && !o.air->has_covariance) {
      throw InvalidInput(
          "air_calibration",
          fmt::format("a prior (`intrinsics` prior, the default with `air_calibration`) needs the "
                      "in-air covariance, and this calibration has none{}: give {}, or a calibration "
                      "with sigma (porthole JSON, Metashape XML, calibmar)",
                      o.air->covariance_note.empty() ? "" : " (" + o.air->covariance_note + ")",
                      o.air_of == RefractiveOptions::AirCalibrationOf::kLensBare
                          ? "`intrinsics` fixed"
                          : "`intrinsics` free (it is then only the start; made through the port it "
                            "cannot be held fixed)"));
    }
  }
}

// The central calibration of the same images (CalibrateRefractive's first step).
// With `free_target` (the water images of a free target) it adjusts the points too: their start
// and the datum.
CalibrationResult CentralOf(const std::vector<ImageDetections>& detections,
                            const TargetSpec& target, const RefractiveOptions& o,
                            const std::string& which = "", bool free_target = false) {
  CalibrationOptions co = o.lens;
  co.drop_insignificant = false;
  co.initial.reset();
  co.free.reset();
  co.target_free = free_target;
  if (!free_target) co.datum = CalibrationOptions::DatumKind::kAuto;
  co.progress = [&](const std::string& m) {
    if (o.lens.progress) o.lens.progress(which + "central: " + m);
  };
  const CalibrationResult central = Calibrate(detections, target, co);
  if (o.air) {
    const camera::Sensor& a = o.air->camera.sensor;
    const camera::Sensor& w = central.camera.sensor;
    if (a.width_px != w.width_px || a.height_px != w.height_px ||
        std::abs(a.pixel_pitch_mm - w.pixel_pitch_mm) > 1e-12) {
      throw InvalidInput("air_calibration",
                         fmt::format("its sensor ({}x{} px, pitch {:g} mm) is not the images' "
                                     "({}x{} px, pitch {:g} mm)", a.width_px, a.height_px,
                                     a.pixel_pitch_mm, w.width_px, w.height_px, w.pixel_pitch_mm));
    }
  }
  return central;
}

}  // namespace

RefractivePlan PlanRefractive(const std::vector<ImageResult>& poses, const TargetSpec& target,
                              const camera::Camera& lens, const RefractiveOptions& o,
                              double sigma0_px) {
  const QuietGlog quiet;
  RequirePositive("plan_sigma_px", sigma0_px);
  if (poses.empty()) throw InvalidInput("images", "no poses to plan with");
  if (lens.model != o.lens.model) {
    throw InvalidInput("model", fmt::format("the design lens is {}, the plan's model {}",
                                              lens.model_name(), camera::Info(o.lens.model).name));
  }
  CheckOptions(o);
  camera::ValidateCamera(lens, "lens");
  return camera::VisitModel(o.lens.model, [&](auto m) {
    return PlanModel<decltype(m)>(poses, target, lens, o, sigma0_px);
  });
}

RefractivePlan PlanRefractiveFromImages(const std::vector<ImageDetections>& detections,
                                        const TargetSpec& target, const RefractiveOptions& o,
                                        double sigma0_px) {
  const QuietGlog quiet;
  RequirePositive("plan_sigma_px", sigma0_px);
  CheckOptions(o);
  if (!o.air_detections.empty()) {
    throw InvalidInput("plan_only", "plans the water images alone: not with `air_detections`");
  }
  const CalibrationResult central = CentralOf(detections, target, o);
  const camera::Camera lens = StartLens(o, central, refraction::ShellOf(o.port));
  return PlanRefractive(central.images, target, lens, o, sigma0_px);
}

std::string JointParamName(camera::CameraModelId model, PortKind kind, int k, bool json) {
  const camera::ModelInfo& m = camera::Info(model);
  const auto pick = [&](const auto& info) { return std::string(json ? info.json_key : info.name); };
  if (k < m.num_params) return pick(m.params[k]);
  k -= m.num_params;
  if (k < kPortNumParams) return pick(refraction::PortParams(kind)[k]);
  return pick(refraction::ShellParams(kind)[k - kPortNumParams]);
}

nlohmann::ordered_json PlanToJson(const RefractivePlan& p) {
  using Json = nlohmann::ordered_json;
  const auto num = [](double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); };
  const auto& names = refraction::PortParams(p.kind);
  const camera::ModelInfo& m = camera::Info(p.model);
  Json port = Json::object(), lens = Json::object(), shell = Json::object();
  for (int i = 0; i < kPortNumParams; ++i) port[std::string(names[i].json_key)] = num(p.port_sigma[i]);
  for (int i = 0; i < kShellNumParams; ++i) {
    if (p.shell_free[i]) shell[std::string(refraction::ShellParams(p.kind)[i].json_key)] = num(p.shell_sigma[i]);
  }
  for (int i = 0; i < m.num_params; ++i) {
    lens[std::string(m.params[i].json_key)] = i < static_cast<int>(p.lens_sigma.size()) ? num(p.lens_sigma[i]) : Json(nullptr);
  }
  Json high = Json::array();
  const int t = static_cast<int>(p.correlation.rows());
  const auto name = [&](int k) { return JointParamName(p.model, p.kind, k, false); };
  for (int i = 0; i < t; ++i) {
    for (int j = i + 1; j < t; ++j) {
      if ((i >= m.num_params || j >= m.num_params) && std::isfinite(p.correlation(i, j)) &&
          std::abs(p.correlation(i, j)) > 0.9) {
        high.push_back({{"a", name(i)}, {"b", name(j)}, {"correlation", p.correlation(i, j)}});
      }
    }
  }
  return {{"plan",
           {{"kind", refraction::PortKindName(p.kind)},
            {"model", std::string(m.name)},
            {"sigma0_px", p.sigma0_px},
            {"n_images", p.n_images},
            {"n_points", p.n_points},
            {"determined", p.determined},
            {"port_sigma", port},
            {"shell_sigma", shell},
            {"lens_sigma", lens},
            {"port_correlations_beyond_0_9", high},
            {"min_range_mm", p.min_range_mm},
            {"max_range_mm", p.max_range_mm},
            {"warning", p.warning.empty() ? Json(nullptr) : Json(p.warning)}}}};  // null: none
}

IntrinsicsMode ParseIntrinsicsMode(const std::string& s, const std::string& field) {
  if (s == "free") return IntrinsicsMode::kFree;
  if (s == "fixed") return IntrinsicsMode::kFixed;
  if (s == "prior") return IntrinsicsMode::kPrior;
  throw InvalidInput(field, "'" + s + "' is not one of free, fixed, prior");
}

std::string ToString(IntrinsicsMode m) {
  return m == IntrinsicsMode::kFree ? "free" : m == IntrinsicsMode::kFixed ? "fixed" : "prior";
}

std::array<bool, kPortNumParams> ParsePortFree(PortKind kind, const std::string& list,
                                               const std::string& field) {
  if (list == "all") return {true, true, true};
  if (list == "none") return {false, false, false};
  std::array<bool, kPortNumParams> free{false, false, false};
  const auto& names = refraction::PortParams(kind);
  std::size_t start = 0;
  while (start <= list.size()) {
    std::size_t end = list.find(',', start);
    if (end == std::string::npos) end = list.size();
    const std::string name = list.substr(start, end - start);
    bool found = false;
    for (int i = 0; i < kPortNumParams; ++i) {
      if (names[i].name == name) free[i] = found = true;
    }
    if (!found) {
      throw InvalidInput(field, fmt::format("unknown {} port parameter '{}' (use {},{},{}, all or none)",
                                            refraction::PortKindName(kind), name,
                                            names[0].name, names[1].name, names[2].name));
    }
    start = end + 1;
  }
  return free;
}

RefractiveResult CalibrateRefractive(const std::vector<ImageDetections>& detections,
                                     const TargetSpec& target, const RefractiveOptions& o) {
  const QuietGlog quiet;
  const auto t0 = std::chrono::steady_clock::now();
  CheckOptions(o);
  if (o.predicted_sigma) {
    for (double s : *o.predicted_sigma) RequirePositive("port_sigma", s);
  }
  // The central calibration of the same images: the poses, the start, and the model choice; the
  // same of the air images.
  const CalibrationResult central = CentralOf(detections, target, o, "", o.lens.target_free);
  std::optional<CalibrationResult> central_air;
  if (!o.air_detections.empty()) {
    central_air = CentralOf(o.air_detections, target, o, "air: ");
    const camera::Sensor& a = central_air->camera.sensor;
    const camera::Sensor& w = central.camera.sensor;
    if (a.width_px != w.width_px || a.height_px != w.height_px) {
      throw InvalidInput("air_detections",
                         fmt::format("the air images are {}x{} px, the water images {}x{} px: one "
                                     "camera takes both", a.width_px, a.height_px, w.width_px, w.height_px));
    }
  }
  RefractiveResult r = camera::VisitModel(o.lens.model, [&](auto m) {
    return CalibrateRefractiveModel<decltype(m)>(detections, target, o, central,
                                                 central_air ? &*central_air : nullptr);
  });
  r.lens.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

namespace {

// {key: correlation} of row k of the joint correlation with every other adjusted parameter.
nlohmann::ordered_json CorrelationRow(const RefractiveResult& r, int k) {
  nlohmann::ordered_json row = nlohmann::ordered_json::object();
  for (int j = 0; j < r.correlation.cols(); ++j) {
    const double c = r.correlation(k, j);
    if (j == k || !std::isfinite(c)) continue;
    row[JointParamName(r.lens.camera.model, r.kind, j, true)] = c;
  }
  return row;
}

}  // namespace

nlohmann::ordered_json RefractiveToJson(const RefractiveResult& r, const TargetSpec& target,
                                        const RefractiveOptions& options) {
  using Json = nlohmann::ordered_json;
  const auto num = [](double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); };
  Json j = CalibrationToJson(r.lens, target, options.lens);
  const auto& names = refraction::PortParams(r.kind);
  const camera::ModelInfo& m = r.lens.camera.info();
  const int n = m.num_params;
  Json params = Json::object(), sigma = Json::object(), pred = Json::object(),
       pred_sigma = Json::object(), units = Json::object(), corr = Json::object();
  for (int i = 0; i < kPortNumParams; ++i) {
    const std::string key(names[i].json_key);
    params[key] = r.port[i];
    sigma[key] = r.port_free[i] ? num(r.port_sigma[i]) : Json(nullptr);
    pred[key] = r.predicted[i];
    pred_sigma[key] = r.predicted_sigma[i];
    units[key] = std::string(names[i].unit);
    if (!r.port_free[i]) continue;
    corr[key] = CorrelationRow(r, n + i);
  }
  // The shell values (refraction::ShellParams) adjusted, with the port file's.
  const auto& shell_names = refraction::ShellParams(r.kind);
  Json shell = {{"free", Json::array()}, {"parameters", Json::object()}, {"sigma", Json::object()},
                {"from_port_file", Json::object()}, {"correlation", Json::object()}};
  for (int i = 0; i < kShellNumParams; ++i) {
    if (!r.shell_free[i]) continue;
    const std::string key(shell_names[i].json_key);
    shell["free"].push_back(key);
    shell["parameters"][key] = r.shell[i];
    shell["sigma"][key] = num(r.shell_sigma[i]);
    shell["from_port_file"][key] = r.shell_predicted[i];
    shell["correlation"][key] = CorrelationRow(r, n + kPortNumParams + i);
  }
  shell["n_water"] = num(r.n_water);
  // The shell as estimated, in the cam frame (what measure/ reads back to trace through the port).
  const Json estimated_shell = refraction::ShellToJson(refraction::WithShellValues(refraction::ShellOf(options.port), r.shell));
  for (const auto& [key, value] : estimated_shell.items()) shell[key] = value;
  // The estimated port in the housing frame: the one port JSON's shape fields (ports/describe.h).
  Json geometry = {{"frame", "housing"}};
  geometry.update(ports::GeometryJson(r.estimated_port.shape));
  const Eigen::Vector3d& ep = r.estimated_port.default_ep_in_housing_mm;
  geometry["entrance_pupil_mm"] = {ep.x(), ep.y(), ep.z()};
  if (r.estimated_port.IsFlat()) geometry["normal_from_predicted_deg"] = num(r.normal_tilt_from_predicted_deg);
  const CentralPrediction& cp = r.central_prediction;
  Json central = {{"available", cp.available}};
  if (cp.available) {
    const auto trio = [&](const std::array<double, 3>& v) {
      return Json{{"c_mm", num(v[0])}, {"x0_mm", num(v[1])}, {"y0_mm", num(v[2])}};
    };
    central["compared"] = "simulate's water fit (central Brown) through the predicted port with "
                          "the in-air lens vs through the estimated port with the estimated lens";
    central["distances_mm"] = cp.distances_mm;
    central["predicted"] = trio(cp.predicted);
    central["predicted_sigma"] = trio(cp.predicted_sigma);
    central["estimated"] = trio(cp.estimated);
    central["estimated_sigma"] = trio(cp.estimated_sigma);
    central["central_calibration"] = trio(cp.central);
    central["central_calibration_sigma"] = trio(cp.central_sigma);
    central["chi2"] = num(cp.chi2);
    central["dof"] = cp.dof;
    central["p_value"] = num(cp.p_value);
    central["differs_from_predicted"] = cp.differs;
  } else {
    central["why_not"] = cp.why_not;
  }
  j["port"] = {{"name", options.port.spec.name},
               {"kind", refraction::PortKindName(r.kind)},
               {"intrinsics", ToString(r.intrinsics)},
               {"n_water", options.port.n_water},
               {"n_glass", options.port.n_glass},
               {"parameters", params},
               {"sigma", sigma},
               {"units", units},
               {"predicted", pred},
               {"predicted_sigma", pred_sigma},
               {"correlation", corr},
               {"chi2", num(r.chi2)},
               {"dof", r.dof},
               {"p_value", num(r.p_value)},
               {"differs_from_predicted", r.port_differs},
               {"geometry", geometry},
               {"shell", shell},
               {"central_prediction", central},
               {"model_choice",
                {{"criterion", "BIC = n ln(RSS/n) + k ln(n), n image coordinates"},
                 {"central_model", std::string(m.name)},
                 {"central_rms_px", num(r.central_rms_px)},
                 {"central_k", r.central_k},
                 {"central_bic", num(r.central_bic)},
                 {"refractive_k", r.k},
                 {"refractive_bic", num(r.bic)},
                 {"preferred", r.preferred}}}};
  // What the lens was measured with (issue 26): the water images alone, with air images through
  // the same port, or with an in-air calibration of the lens alone.
  const bool housed = options.air && options.air_of == RefractiveOptions::AirCalibrationOf::kThroughPort;
  Json air = {{"lens_from", !r.air_images.empty() ? "air and water images through the port, adjusted together"
                            : !options.air        ? "the water images alone"
                            : !housed ? "an in-air calibration of the lens without the housing (the bare lens)"
                            : r.intrinsics == IntrinsicsMode::kPrior
                                ? "an in-air calibration made through the port (the housing on), modelled as the "
                                  "lens behind the port in air, adjusted with the water images"
                                : "the water images alone, started from an in-air calibration made through the port"}};
  if (options.air) air["air_calibration_taken_as"] = housed ? "through_port" : "lens_bare";
  if (std::isfinite(r.housed_fit_rms_px)) air["housed_central_fit_rms_px"] = r.housed_fit_rms_px;
  if (!r.air_images.empty()) {
    air["n_images"] = r.air_images.size();
    air["rms_px"] = num(r.air_rms_px);
    air["water_rms_px"] = num(r.water_rms_px);
    air["refocused"] = options.air_refocused;
    if (options.air_refocused) {
      air["focal_scale"] = num(r.air_focal_scale);  // the air images' focal length(s) / the water images'
      air["focal_scale_sigma"] = num(r.air_focal_scale_sigma);
    }
    air["images"] = ImagesJson(r.air_images);
  }
  j["port"]["air"] = air;
  return j;
}

}  // namespace porthole::calib
