#include "porthole/calib/calibrate.h"

#include <ceres/ceres.h>
#include <fmt/format.h>

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <chrono>
#include <cmath>
#include <map>
#include <set>

#include "porthole/calib/residual.h"
#include "porthole/core/error.h"

namespace porthole::calib {
namespace {

using camera::kBrownNumParams;
constexpr int kNumAdditionalFirst = camera::kBrownK1;  // K1…B2 are the additional parameters

struct Observation {
  int image = 0;     // index into the used images
  int point = 0;     // target point id
  double x_mm = 0, y_mm = 0;
  bool active = true;
};

struct State {
  std::array<double, kBrownNumParams> camera{};
  std::vector<std::array<double, 3>> rotation, translation;  // cam_from_target per image
  std::vector<Eigen::Vector3d> points;                       // target frame, mm
};

// Normalised DLT homography mapping target (X, Y) to image (x, −y) mm; unit Frobenius norm.
Eigen::Matrix3d FitHomography(const std::vector<Eigen::Vector2d>& src,
                              const std::vector<Eigen::Vector2d>& dst) {
  auto normaliser = [](const std::vector<Eigen::Vector2d>& p) {
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const auto& q : p) mean += q;
    mean /= static_cast<double>(p.size());
    double d = 0;
    for (const auto& q : p) d += (q - mean).norm();
    d /= static_cast<double>(p.size());
    const double s = d > 0 ? std::sqrt(2.0) / d : 1.0;
    Eigen::Matrix3d t;
    t << s, 0, -s * mean.x(), 0, s, -s * mean.y(), 0, 0, 1;
    return t;
  };
  const Eigen::Matrix3d ts = normaliser(src), td = normaliser(dst);
  Eigen::MatrixXd a(2 * src.size(), 9);
  for (std::size_t i = 0; i < src.size(); ++i) {
    const Eigen::Vector3d s = ts * src[i].homogeneous();
    const Eigen::Vector3d d = td * dst[i].homogeneous();
    a.row(2 * i) << s.x(), s.y(), 1, 0, 0, 0, -d.x() * s.x(), -d.x() * s.y(), -d.x();
    a.row(2 * i + 1) << 0, 0, 0, s.x(), s.y(), 1, -d.y() * s.x(), -d.y() * s.y(), -d.y();
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeFullV);
  const Eigen::VectorXd h = svd.matrixV().col(8);
  Eigen::Matrix3d hn;
  hn << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), h(8);
  Eigen::Matrix3d hm = td.inverse() * hn * ts;
  return hm / hm.norm();
}

// Zhang's constraints with the principal point at the image-mm origin and one principal distance:
// h1ᵀωh2 = 0 and h1ᵀωh1 = h2ᵀωh2 with ω = diag(1/c², 1/c², 1), least squares in 1/c².
std::optional<double> ZhangPrincipalDistance(const std::vector<Eigen::Matrix3d>& hs) {
  double num = 0, den = 0;
  for (const auto& h : hs) {
    const double a1 = h(0, 0) * h(0, 1) + h(1, 0) * h(1, 1), b1 = h(2, 0) * h(2, 1);
    const double a2 = h(0, 0) * h(0, 0) + h(1, 0) * h(1, 0) - h(0, 1) * h(0, 1) - h(1, 1) * h(1, 1);
    const double b2 = h(2, 0) * h(2, 0) - h(2, 1) * h(2, 1);
    num -= a1 * b1 + a2 * b2;
    den += a1 * a1 + a2 * a2;
  }
  const double inv_c2 = num / den;
  if (!(inv_c2 > 0) || !std::isfinite(inv_c2)) return std::nullopt;
  return 1.0 / std::sqrt(inv_c2);
}

// cam_from_target pose from a homography and the principal distance (principal point at 0).
void PoseFromHomography(const Eigen::Matrix3d& h, double c, std::array<double, 3>* rotation,
                        std::array<double, 3>* translation) {
  const Eigen::Vector3d kinv(1 / c, 1 / c, 1);
  const Eigen::Vector3d m1 = kinv.cwiseProduct(h.col(0)), m2 = kinv.cwiseProduct(h.col(1)),
                        m3 = kinv.cwiseProduct(h.col(2));
  double lambda = 2.0 / (m1.norm() + m2.norm());
  if (lambda * m3.z() < 0) lambda = -lambda;  // the target is in front of the camera
  Eigen::Matrix3d r;
  r.col(0) = lambda * m1;
  r.col(1) = lambda * m2;
  r.col(2) = r.col(0).cross(r.col(1));
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(r, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d rot = svd.matrixU() * svd.matrixV().transpose();
  if (rot.determinant() < 0) {
    Eigen::Matrix3d u = svd.matrixU();
    u.col(2) *= -1;
    rot = u * svd.matrixV().transpose();
  }
  const Eigen::AngleAxisd aa(rot);
  const Eigen::Vector3d v = aa.angle() * aa.axis();
  const Eigen::Vector3d t = lambda * m3;
  *rotation = {v.x(), v.y(), v.z()};
  *translation = {t.x(), t.y(), t.z()};
}

// Residual (projected − observed) in px, or nullopt where the projection fails.
std::optional<Eigen::Vector2d> Residual(const State& s, const Observation& o, double pitch) {
  const camera::BrownBundleResidual f(o.x_mm, o.y_mm, pitch);
  Eigen::Vector2d r;
  if (!f(s.camera.data(), s.rotation[o.image].data(), s.translation[o.image].data(),
         s.points[o.point].data(), r.data())) {
    return std::nullopt;
  }
  return r;
}

// The datum of a free target: three observed points (ids) spanning it.
std::array<int, 3> ChooseDatum(const std::vector<Eigen::Vector3d>& pts, const std::set<int>& used) {
  const int a = *used.begin();
  int b = a, c = a;
  double best = -1;
  for (int id : used) {
    const double d = (pts[id] - pts[a]).norm();
    if (d > best) best = d, b = id;
  }
  best = -1;
  const Eigen::Vector3d dir = (pts[b] - pts[a]).normalized();
  for (int id : used) {
    const Eigen::Vector3d v = pts[id] - pts[a];
    const double d = (v - v.dot(dir) * dir).norm();
    if (d > best) best = d, c = id;
  }
  return {a, b, c};
}

// Scales of the camera parameters in the adjustment (camera[i] = scale[i]·scaled[i], residual.h):
// every parameter gets a comparable effect at the image corner (K_n by R^-2n, P by R^-1, for R
// the half-diagonal in mm). Without them the Jacobian columns of c and K2 differ by ~R⁵ and the
// covariance is numerically singular in pixel units.
std::array<double, kBrownNumParams> ParameterScales(const camera::Sensor& s) {
  const double r = 0.5 * std::hypot(s.width_px, s.height_px) * s.pixel_pitch_mm;
  return {r, r, r, std::pow(r, -2), std::pow(r, -4), std::pow(r, -6), 1 / r, 1 / r, 1, 1};
}

using CameraMatrix = Eigen::Matrix<double, kBrownNumParams, kBrownNumParams>;

// The analytic cost of one observation in the residual form `form`.
template <bool kPointFree>
ceres::CostFunction* NewCost(Form form, const Observation& ob, double pitch_mm,
                             const CameraScales& scale, const Eigen::Vector3d& point) {
  if (form == Form::kProject) {
    return new AnalyticResidual<Form::kProject, kPointFree>(ob.x_mm, ob.y_mm, pitch_mm, scale,
                                                            point);
  }
  return new AnalyticResidual<Form::kCorrect, kPointFree>(ob.x_mm, ob.y_mm, pitch_mm, scale,
                                                          point);
}

class Adjustment {
 public:
  Adjustment(const CalibrationOptions& options, std::vector<Observation>* obs, State* state,
             const camera::Sensor& sensor, const std::set<int>& used_points)
      : o_(options), obs_(obs), s_(state), scale_(ParameterScales(sensor)), used_(used_points) {
    if (o_.target_free) datum_ = ChooseDatum(s_->points, used_);
  }

  // Least squares over the active observations with the free parameters `free` in the residual
  // form `form` (residual.h); updates the state and returns the Ceres iterations.
  int Solve(const FreeMask& free, Form form) {
    std::array<double, kBrownNumParams> scaled;
    ceres::Problem problem;
    Build(free, form, &scaled, &problem);
    ceres::Solver::Options so;
    // Schur elimination of the poses (and free target points): the reduced camera system is
    // small, so the dense variant is the fastest; large free targets use the sparse one.
    so.linear_solver_type = (o_.target_free && used_.size() > 200) ? ceres::SPARSE_SCHUR
                                                                    : ceres::DENSE_SCHUR;
    so.max_num_iterations = o_.max_iterations;
    // The scaled parameters (ParameterScales) and the homography start make the Gauss–Newton step
    // good from the first iteration: a large initial trust region lets Levenberg–Marquardt take
    // it (the radius still shrinks after a failed step). Ceres's default 1e4 damps the first
    // steps and cost 3–4 extra iterations per stage on the samples.
    so.initial_trust_region_radius = 1e8;
    // The correction-form stage is only the start of the image-residual stage, which converges
    // from anywhere near its optimum in 2–3 steps: 1e-6 is enough there. The image-residual
    // stage stops at 1e-8 relative changes, far below the statistics' precision.
    so.function_tolerance = form == Form::kProject ? 1e-8 : 1e-6;
    so.parameter_tolerance = form == Form::kProject ? 1e-8 : 1e-6;
    so.gradient_tolerance = 1e-12;
    so.num_threads = o_.num_threads;
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
    for (int i = 0; i < kBrownNumParams; ++i) s_->camera[i] = scaled[i] * scale_[i];
    return static_cast<int>(summary.iterations.size());
  }

  // The unscaled marginal covariance of the camera parameters, (JᵀJ)⁻¹ of the image residual
  // (px, not yet multiplied by σ0²), rows and columns of fixed parameters 0. False if singular.
  bool Covariance(const FreeMask& free, CameraMatrix* covariance) {
    covariance->setZero();
    bool ok = (o_.target_free || o_.loss != LossKind::kNone || o_.ceres_covariance)
                  ? CeresCovariance(free, covariance)
                  : ReducedCameraCovariance(free, covariance);
    // Back to the parameters' own units: Σ = S Σ_scaled S.
    const Eigen::Map<const Eigen::Matrix<double, kBrownNumParams, 1>> sv(scale_.data());
    *covariance = sv.asDiagonal() * (*covariance) * sv.asDiagonal();
    return ok;
  }

 private:
  void Build(const FreeMask& free, Form form, std::array<double, kBrownNumParams>* scaled,
             ceres::Problem* problem) {
    for (int i = 0; i < kBrownNumParams; ++i) (*scaled)[i] = s_->camera[i] / scale_[i];
    for (const auto& ob : *obs_) {
      if (!ob.active) continue;
      ceres::LossFunction* loss = nullptr;
      if (o_.loss == LossKind::kHuber) loss = new ceres::HuberLoss(o_.loss_scale_px);
      if (o_.loss == LossKind::kCauchy) loss = new ceres::CauchyLoss(o_.loss_scale_px);
      Eigen::Vector3d* point = &s_->points[ob.point];
      double* rot = s_->rotation[ob.image].data();
      double* tr = s_->translation[ob.image].data();
      const bool point_free = o_.target_free && ob.point != datum_[0] && ob.point != datum_[1];
      const double pitch = o_.pixel_pitch_mm;
      ceres::CostFunction* cost = point_free ? NewCost<true>(form, ob, pitch, scale_, *point)
                                             : NewCost<false>(form, ob, pitch, scale_, *point);
      if (point_free) {
        problem->AddResidualBlock(cost, loss, scaled->data(), rot, tr, point->data());
      } else {
        problem->AddResidualBlock(cost, loss, scaled->data(), rot, tr);
      }
    }
    std::vector<int> fixed;
    for (int i = 0; i < kBrownNumParams; ++i) {
      if (!free[i]) fixed.push_back(i);
    }
    if (static_cast<int>(fixed.size()) == kBrownNumParams) {
      problem->SetParameterBlockConstant(scaled->data());
    } else if (!fixed.empty()) {
      problem->SetManifold(scaled->data(), new ceres::SubsetManifold(kBrownNumParams, fixed));
    }
    if (o_.target_free && problem->HasParameterBlock(s_->points[datum_[2]].data())) {
      problem->SetManifold(s_->points[datum_[2]].data(), new ceres::SubsetManifold(3, {2}));
    }
  }

  // Ceres's marginal covariance over all unknowns (sparse QR): the general path (free target,
  // robust loss) and the reference of ReducedCameraCovariance. Scaled units.
  bool CeresCovariance(const FreeMask& free, CameraMatrix* covariance) {
    std::array<double, kBrownNumParams> scaled;
    ceres::Problem problem;
    Build(free, Form::kProject, &scaled, &problem);
    ceres::Covariance::Options co;
    co.num_threads = o_.num_threads;
    ceres::Covariance cov(co);
    const double* cam = scaled.data();
    const std::vector<std::pair<const double*, const double*>> blocks = {{cam, cam}};
    // Ceres writes row-major; the matrix is symmetric, so the storage order does not matter.
    return cov.Compute(blocks, &problem) && cov.GetCovarianceBlock(cam, cam, covariance->data());
  }

  // Fixed target, no robust loss: the camera block of (JᵀJ)⁻¹ is the inverse of the reduced camera
  // system S = U − Σ_i W_i V_i⁻¹ W_iᵀ (U = J_camᵀJ_cam, W_i = J_camᵀJ_pose_i, V_i = J_pose_iᵀJ_pose_i
  // per image), built from the analytic Jacobians: a 10×10 problem instead of a sparse QR over all
  // unknowns. Singular (false) if an image's pose or the free camera block has a reciprocal
  // condition number below 1e-14 (Ceres's default for its covariance). Scaled units.
  bool ReducedCameraCovariance(const FreeMask& free, CameraMatrix* covariance) {
    const int n_images = static_cast<int>(s_->rotation.size());
    std::array<double, kBrownNumParams> scaled;
    for (int i = 0; i < kBrownNumParams; ++i) scaled[i] = s_->camera[i] / scale_[i];
    CameraMatrix u = CameraMatrix::Zero();
    std::vector<Eigen::Matrix<double, kBrownNumParams, 6>> w(
        n_images, Eigen::Matrix<double, kBrownNumParams, 6>::Zero());
    std::vector<Eigen::Matrix<double, 6, 6>> v(n_images, Eigen::Matrix<double, 6, 6>::Zero());
    RowJacobianCamera jc;
    RowJacobian3 jr, jt;
    Eigen::Matrix<double, 2, 6> jp;
    double r[2];
    for (const auto& ob : *obs_) {
      if (!ob.active) continue;
      if (!EvaluateResidual<Form::kProject>(scaled.data(), scale_, s_->rotation[ob.image].data(),
                                            s_->translation[ob.image].data(),
                                            s_->points[ob.point].data(), ob.x_mm, ob.y_mm,
                                            o_.pixel_pitch_mm, r, &jc, &jr, &jt, nullptr)) {
        return false;
      }
      jp << jr, jt;
      u.noalias() += jc.transpose() * jc;
      w[ob.image].noalias() += jc.transpose() * jp;
      v[ob.image].noalias() += jp.transpose() * jp;
    }
    for (int i = 0; i < n_images; ++i) {
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> es(v[i]);
      const auto& ev = es.eigenvalues();
      if (!(ev(0) > 1e-14 * ev(5))) return false;
      const Eigen::Matrix<double, kBrownNumParams, 6> wq = w[i] * es.eigenvectors();
      u.noalias() -= wq * ev.cwiseInverse().asDiagonal() * wq.transpose();
    }
    std::vector<int> idx;
    for (int i = 0; i < kBrownNumParams; ++i) {
      if (free[i]) idx.push_back(i);
    }
    const int nf = static_cast<int>(idx.size());
    if (nf == 0) return true;
    Eigen::MatrixXd sf(nf, nf);
    for (int a = 0; a < nf; ++a) {
      for (int b = 0; b < nf; ++b) sf(a, b) = u(idx[a], idx[b]);
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(sf);
    const Eigen::VectorXd& ev = es.eigenvalues();
    if (!(ev(0) > 1e-14 * ev(nf - 1))) return false;
    const Eigen::MatrixXd inv =
        es.eigenvectors() * ev.cwiseInverse().asDiagonal() * es.eigenvectors().transpose();
    for (int a = 0; a < nf; ++a) {
      for (int b = 0; b < nf; ++b) (*covariance)(idx[a], idx[b]) = inv(a, b);
    }
    return true;
  }

  const CalibrationOptions& o_;
  std::vector<Observation>* obs_;
  State* s_;
  CameraScales scale_;
  std::set<int> used_;
  std::array<int, 3> datum_{-1, -1, -1};
};
}  // namespace

FreeMask ParseFreeParameters(const std::string& list, const std::string& field) {
  FreeMask free{};
  if (list == "all") {
    free.fill(true);
    return free;
  }
  std::size_t start = 0;
  while (start <= list.size()) {
    std::size_t end = list.find(',', start);
    if (end == std::string::npos) end = list.size();
    const std::string name = list.substr(start, end - start);
    bool found = false;
    for (int i = 0; i < kBrownNumParams; ++i) {
      if (camera::kBrownParamInfo[i].name == name) free[i] = found = true;
    }
    if (!found) {
      throw InvalidInput(field, fmt::format("unknown parameter '{}' (use c,x0,y0,K1,K2,K3,P1,P2,"
                                            "B1,B2 or all)", name));
    }
    start = end + 1;
  }
  return free;
}

std::string FreeParametersToString(const FreeMask& free) {
  std::string s;
  for (int i = 0; i < kBrownNumParams; ++i) {
    if (!free[i]) continue;
    if (!s.empty()) s += ",";
    s += camera::kBrownParamInfo[i].name;
  }
  return s;
}

CalibrationResult Calibrate(const std::vector<ImageDetections>& detections,
                            const TargetSpec& target, const CalibrationOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  const auto say = [&](const std::string& m) {
    if (options.progress) options.progress(m);
  };
  RequirePositive("--pixel-pitch-mm", options.pixel_pitch_mm);
  RequireNonNegative("--reject-k", options.reject_k);
  RequirePositive("--loss-scale-px", options.loss_scale_px);
  RequirePositive("--significance-t", options.significance_t);
  if (options.drop_insignificant && !options.statistics) {
    throw InvalidInput("statistics", "stepwise dropping needs the statistics (σ of each parameter)");
  }
  if (!options.free[camera::kBrownC] && !options.initial) {
    throw InvalidInput("--free", "c may be fixed only with a start camera (--initial)");
  }
  const std::vector<Eigen::Vector3d> nominal = TargetPoints(target);

  CalibrationResult res;
  res.free = options.free;
  // Images with at least 4 valid points; all of one size.
  std::vector<const ImageDetections*> used_images;
  for (const auto& d : detections) {
    if (d.ids.size() != d.points_px.size()) {
      throw InvalidInput("detections", d.image + ": ids and points differ in number");
    }
    for (int id : d.ids) {
      if (id < 0 || id >= static_cast<int>(nominal.size())) {
        throw InvalidInput("detections", fmt::format("{}: point id {} is not on target {}",
                                                     d.image, id, target.ToString()));
      }
    }
    if (d.points_px.size() < 4) {
      say(fmt::format("skipped {}: {} points (need 4)", d.image, d.points_px.size()));
      continue;
    }
    if (!used_images.empty() && (d.width_px != used_images[0]->width_px ||
                                 d.height_px != used_images[0]->height_px)) {
      throw InvalidInput("--images", fmt::format("{} is {}x{} px, {} is {}x{}: one camera, one "
                                                 "image size", d.image, d.width_px, d.height_px,
                                                 used_images[0]->image, used_images[0]->width_px,
                                                 used_images[0]->height_px));
    }
    used_images.push_back(&d);
  }
  if (used_images.size() < 3) {
    throw InvalidInput("--images", fmt::format("{} image(s) with the target; at least 3 are needed "
                                               "to solve for {}", used_images.size(),
                                               FreeParametersToString(options.free)));
  }
  res.sensor = {used_images[0]->width_px, used_images[0]->height_px, options.pixel_pitch_mm};
  camera::ValidateSensor(res.sensor);

  // Observations in image mm.
  std::vector<Observation> obs;
  std::set<int> used_points;
  for (std::size_t i = 0; i < used_images.size(); ++i) {
    const auto& d = *used_images[i];
    for (std::size_t k = 0; k < d.ids.size(); ++k) {
      const Eigen::Vector2d xy =
          camera::PixelToImageMm(res.sensor, d.points_px[k].x(), d.points_px[k].y());
      obs.push_back({static_cast<int>(i), d.ids[k], xy.x(), xy.y(), true});
      used_points.insert(d.ids[k]);
    }
  }
  const int n_images = static_cast<int>(used_images.size());
  const int n_point_unknowns = options.target_free ? 3 * static_cast<int>(used_points.size()) - 7 : 0;

  // Start: Zhang.
  State s;
  s.points = nominal;
  std::vector<Eigen::Matrix3d> hs;
  for (const auto* d : used_images) {
    std::vector<Eigen::Vector2d> src, dst;
    for (std::size_t k = 0; k < d->ids.size(); ++k) {
      src.push_back(nominal[d->ids[k]].head<2>());
      const Eigen::Vector2d xy =
          camera::PixelToImageMm(res.sensor, d->points_px[k].x(), d->points_px[k].y());
      dst.emplace_back(xy.x(), -xy.y());
    }
    hs.push_back(FitHomography(src, dst));
  }
  if (options.initial) {
    camera::ValidateBrownParams(*options.initial);
    s.camera = options.initial->ToArray();
  }
  if (options.free[camera::kBrownC] || !options.initial) {
    const auto c = ZhangPrincipalDistance(hs);
    s.camera[camera::kBrownC] =
        c ? *c : std::max(res.sensor.width_px, res.sensor.height_px) * options.pixel_pitch_mm;
    say(c ? fmt::format("start: Zhang principal distance {:.4f} mm", *c)
          : "start: homographies do not fix c (views too parallel?); using the image width");
  }
  // The start poses assume the principal point at the origin and no distortion.
  s.rotation.resize(n_images);
  s.translation.resize(n_images);
  for (int i = 0; i < n_images; ++i) {
    PoseFromHomography(hs[i], s.camera[camera::kBrownC], &s.rotation[i], &s.translation[i]);
  }

  Adjustment adj(options, &obs, &s, res.sensor, used_points);
  res.iterations += adj.Solve(options.free, Form::kCorrect);
  say(fmt::format("{} images, {} points: adjusting {}", n_images, obs.size(),
                  FreeParametersToString(options.free)));

  // Adjust, reject outliers, evaluate statistics; stepwise drop non-significant parameters.
  FreeMask free = options.free;
  CameraMatrix cov = CameraMatrix::Zero();
  while (true) {
    int n_free_now = 0;
    for (bool f : free) n_free_now += f ? 1 : 0;
    res.n_unknowns = n_free_now + 6 * n_images + n_point_unknowns;
    double ss = 0;
    int n_active = 0;
    for (int round = 0;; ++round) {
      res.iterations += adj.Solve(free, Form::kProject);
      ss = 0;
      n_active = 0;
      for (const auto& ob : obs) {
        if (!ob.active) continue;
        const auto r = Residual(s, ob, options.pixel_pitch_mm);
        if (r) ss += r->squaredNorm();
        ++n_active;
      }
      res.redundancy = 2 * n_active - res.n_unknowns;
      if (res.redundancy <= 0) {
        throw InvalidInput("--images", fmt::format("{} points in {} images give {} observations "
                                                   "for {} unknowns: add images or fix "
                                                   "parameters (--free)", n_active, n_images,
                                                   2 * n_active, res.n_unknowns));
      }
      const double sigma0 = std::sqrt(ss / res.redundancy);
      if (options.reject_k <= 0 || round >= options.max_reject_rounds) break;
      int rejected = 0;
      for (auto& ob : obs) {
        if (!ob.active) continue;
        const auto r = Residual(s, ob, options.pixel_pitch_mm);
        if (!r || r->norm() > options.reject_k * sigma0) ob.active = false, ++rejected;
      }
      if (rejected == 0) break;
      say(fmt::format("rejected {} points beyond {:g} sigma0 ({:.3f} px); readjusting", rejected,
                      options.reject_k, sigma0));
    }
    res.sigma0_px = std::sqrt(ss / res.redundancy);
    res.rms_px = std::sqrt(ss / n_active);
    res.n_points = n_active;
    if (!options.statistics) {
      res.sigma.fill(NAN);
      break;
    }
    res.covariance_ok = adj.Covariance(free, &cov);
    res.covariance = cov * (res.sigma0_px * res.sigma0_px);
    res.significance.clear();
    int weakest = -1;
    double weakest_t = options.significance_t;
    for (int i = 0; i < kBrownNumParams; ++i) {
      res.sigma[i] = free[i] ? std::sqrt(res.covariance(i, i)) : NAN;
      if (i < kNumAdditionalFirst || !free[i]) continue;
      const double t = std::abs(s.camera[i]) / res.sigma[i];
      res.significance.push_back({i, t, t >= options.significance_t});
      if (t < weakest_t) weakest_t = t, weakest = i;
    }
    if (!options.drop_insignificant || weakest < 0 || !res.covariance_ok) break;
    res.dropped.push_back({weakest, s.camera[weakest], res.sigma[weakest], weakest_t});
    say(fmt::format("dropping {} = {:.4g} (|p|/sigma = {:.2f} < {:g}) and readjusting",
                    camera::kBrownParamInfo[weakest].name, s.camera[weakest], weakest_t,
                    options.significance_t));
    free[weakest] = false;
    s.camera[weakest] = 0;
  }
  res.free = free;
  for (int i = 0; i < kBrownNumParams; ++i) {
    for (int j = 0; j < kBrownNumParams; ++j) {
      res.correlation(i, j) = (free[i] && free[j])
                                  ? res.covariance(i, j) / (res.sigma[i] * res.sigma[j])
                                  : NAN;
    }
  }
  res.camera = camera::BrownParams::FromArray(s.camera.data());
  res.n_images = n_images;
  res.target_points_mm = s.points;
  std::vector<double> image_ss(n_images, 0);
  res.images.resize(n_images);
  for (const auto& ob : obs) {
    auto& im = res.images[ob.image];
    if (!ob.active) {
      ++im.n_rejected;
      ++res.n_rejected;
      continue;
    }
    const auto r = Residual(s, ob, options.pixel_pitch_mm);
    image_ss[ob.image] += r ? r->squaredNorm() : 0;
    ++im.n_points;
  }
  for (int i = 0; i < n_images; ++i) {
    auto& im = res.images[i];
    im.image = used_images[i]->image;
    im.rms_px = im.n_points > 0 ? std::sqrt(image_ss[i] / im.n_points) : NAN;
    im.rotation_rad = Eigen::Vector3d(s.rotation[i].data());
    im.translation_mm = Eigen::Vector3d(s.translation[i].data());
  }
  res.message = !options.statistics ? "ok (statistics not computed)"
                : res.covariance_ok   ? "ok"
                                      : "the covariance is singular: some free parameters are not "
                                        "determined by these images (fix them with --free)";
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  say(fmt::format("done: sigma0 {:.4f} px, RMS {:.4f} px, {} iterations, {:.3f} s", res.sigma0_px,
                  res.rms_px, res.iterations, res.seconds));
  return res;
}

}  // namespace porthole::calib
