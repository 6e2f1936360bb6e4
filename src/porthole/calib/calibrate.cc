#include "porthole/calib/calibrate.h"

#include <ceres/ceres.h>
#include <fmt/format.h>

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <set>

#include "porthole/calib/residual.h"
#include "porthole/calib/scales.h"
#include "porthole/coded/ellipse.h"
#include "porthole/core/error.h"

namespace porthole::calib {
namespace {

using camera::CameraModelId;

struct Observation {
  int image = 0;     // index into the used images
  int point = 0;     // target point id
  double u_px = 0, v_px = 0;  // the measurement
  double x_mm = 0, y_mm = 0;  // the same in image mm (the Brown model's analytic residual)
  bool active = true;
  // The detector's measurement; u_px, v_px (and x_mm, y_mm) are it minus the centre offset of a
  // circular target (CalibrationOptions::centre_correction), or it unchanged.
  double measured_u_px = 0, measured_v_px = 0;
};

template <int N>
struct State {
  std::array<double, N> camera{};
  std::vector<std::array<double, 3>> rotation, translation;  // cam_from_target per image
  std::vector<Eigen::Vector3d> points;                       // target frame, mm
};

// Normalised DLT homography mapping src to dst points (Hartley's normalisation of both sets), unit
// Frobenius norm. The right singular vector of the 2n×9 system is taken as the eigenvector of its
// 9×9 normal matrix (the same solution at a fraction of the cost). nullopt when the points do not
// determine a homography (4 of 5 on one line, say): the second-smallest singular value below 1e-3
// of the largest.
std::optional<Eigen::Matrix3d> FitHomography(const std::vector<Eigen::Vector2d>& src,
                                             const std::vector<Eigen::Vector2d>& dst) {
  if (src.size() < 4 || src.size() != dst.size()) return std::nullopt;
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
  const Eigen::Matrix<double, 9, 9> ata = a.transpose() * a;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> es(ata);
  const auto& ev = es.eigenvalues();  // σ², ascending
  if (!(ev(1) > 1e-6 * ev(8))) return std::nullopt;
  const Eigen::Matrix<double, 9, 1> h = es.eigenvectors().col(0);
  Eigen::Matrix3d hn;
  hn << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), h(8);
  const Eigen::Matrix3d hm = td.inverse() * hn * ts;
  return Eigen::Matrix3d(hm / hm.norm());
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

// cam_from_target pose from a homography (target plane → camera rays, scaled by c: principal
// point at 0) whose sign puts the target in front along the rays.
void PoseFromHomography(const Eigen::Matrix3d& h, double c, std::array<double, 3>* rotation,
                        std::array<double, 3>* translation) {
  const Eigen::Vector3d kinv(1 / c, 1 / c, 1);
  const Eigen::Vector3d m1 = kinv.cwiseProduct(h.col(0)), m2 = kinv.cwiseProduct(h.col(1)),
                        m3 = kinv.cwiseProduct(h.col(2));
  // h's sign is the caller's (RayHomography: the target points lie along +ray); the target origin
  // itself may be behind the camera (a fisheye seeing the board 85° off axis).
  const double lambda = 2.0 / (m1.norm() + m2.norm());
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

// The image residual of any model by automatic differentiation: Project(R·X + t) − observed, px.
// Blocks: scaled camera [N], rotation [3], translation [3] and, with a free target, the point [3].
template <typename M>
struct ModelResidual {
  double u_px, v_px;
  camera::Sensor sensor;
  std::array<double, M::kNumParams> scale;
  Eigen::Vector3d point;

  template <typename T>
  bool Evaluate(const T* scaled, const T* rotation, const T* translation, const T* x,
                T* r) const {
    T cam[M::kNumParams];
    for (int i = 0; i < M::kNumParams; ++i) cam[i] = scaled[i] * T(scale[i]);
    T p[3];
    ceres::AngleAxisRotatePoint(rotation, x, p);
    const auto uv = M::template Project<T>(
        sensor, cam, camera::Vec3<T>(p[0] + translation[0], p[1] + translation[1], p[2] + translation[2]));
    if (!uv) return false;
    r[0] = (*uv)(0) - T(u_px);
    r[1] = (*uv)(1) - T(v_px);
    return true;
  }
  template <typename T>
  bool operator()(const T* scaled, const T* rotation, const T* translation, T* r) const {
    const T x[3] = {T(point.x()), T(point.y()), T(point.z())};
    return Evaluate(scaled, rotation, translation, x, r);
  }
  template <typename T>
  bool operator()(const T* scaled, const T* rotation, const T* translation, const T* x,
                  T* r) const {
    return Evaluate(scaled, rotation, translation, x, r);
  }
};

// Residual (projected − observed) in px, or nullopt where the projection fails.
template <typename M>
std::optional<Eigen::Vector2d> Residual(const State<M::kNumParams>& s, const Observation& o,
                                        const camera::Sensor& sensor) {
  Eigen::Matrix3d r;
  ceres::AngleAxisToRotationMatrix(s.rotation[o.image].data(), r.data());
  const Eigen::Vector3d p =
      r * s.points[o.point] + Eigen::Vector3d(s.translation[o.image].data());
  const auto uv = M::template Project<double>(sensor, s.camera.data(), p);
  if (!uv) return std::nullopt;
  return Eigen::Vector2d(*uv - Eigen::Vector2d(o.u_px, o.v_px));
}

template <typename M>
class Adjustment {
 public:
  static constexpr int N = M::kNumParams;
  using CameraMatrix = Eigen::Matrix<double, N, N>;

  Adjustment(const CalibrationOptions& options, std::vector<Observation>* obs, State<N>* state,
             const camera::Sensor& sensor, const std::set<int>& used_points)
      : o_(options), obs_(obs), s_(state), sensor_(sensor), scale_(ModelScales<M>(sensor)),
        used_(used_points) {
    if (o_.target_free) datum_ = ChooseDatum(s_->points, used_);
  }

  // Least squares over the active observations with the free parameters `free` in the residual
  // form `form` (residual.h; only the Brown model has the correction form, every other model
  // always uses the image residual); updates the state and returns the Ceres iterations.
  int Solve(const FreeMask& free, Form form) {
    std::array<double, N> scaled;
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
    so.initial_trust_region_radius = M::kCaps.analytic_jacobian ? 1e8 : 1e4;
    // A step that carries a point beyond a model's valid field (a fisheye's fold) cannot be
    // evaluated; Ceres then shrinks the trust region. Its default gives up after 5 such steps in a
    // row, before the region is small enough.
    so.max_num_consecutive_invalid_steps = 50;
    // The correction-form stage is only the start of the image-residual stage, which converges
    // from anywhere near its optimum in 2–3 steps: 1e-6 is enough there. The image-residual
    // stage stops at 1e-8 relative changes, far below the statistics' precision.
    so.function_tolerance = form == Form::kProject ? 1e-8 : 1e-6;
    so.parameter_tolerance = form == Form::kProject ? 1e-8 : 1e-6;
    so.gradient_tolerance = 1e-12;
    so.num_threads = o_.num_threads;
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
    for (int i = 0; i < N; ++i) s_->camera[i] = scaled[i] * scale_[i];
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
    const Eigen::Map<const Eigen::Matrix<double, N, 1>> sv(scale_.data());
    *covariance = sv.asDiagonal() * (*covariance) * sv.asDiagonal();
    return ok;
  }

 private:
  ceres::CostFunction* NewModelCost(Form form, const Observation& ob, bool point_free) const {
    const Eigen::Vector3d& point = s_->points[ob.point];
    if constexpr (M::kCaps.analytic_jacobian) {
      const double pitch = sensor_.pixel_pitch_mm;
      return point_free ? NewCost<true>(form, ob, pitch, scale_, point)
                        : NewCost<false>(form, ob, pitch, scale_, point);
    } else {
      auto* f = new ModelResidual<M>{ob.u_px, ob.v_px, sensor_, scale_, point};
      if (point_free) return new ceres::AutoDiffCostFunction<ModelResidual<M>, 2, N, 3, 3, 3>(f);
      return new ceres::AutoDiffCostFunction<ModelResidual<M>, 2, N, 3, 3>(f);
    }
  }

  void Build(const FreeMask& free, Form form, std::array<double, N>* scaled,
             ceres::Problem* problem) {
    for (int i = 0; i < N; ++i) (*scaled)[i] = s_->camera[i] / scale_[i];
    for (const auto& ob : *obs_) {
      if (!ob.active) continue;
      ceres::LossFunction* loss = nullptr;
      if (o_.loss == LossKind::kHuber) loss = new ceres::HuberLoss(o_.loss_scale_px);
      if (o_.loss == LossKind::kCauchy) loss = new ceres::CauchyLoss(o_.loss_scale_px);
      Eigen::Vector3d* point = &s_->points[ob.point];
      double* rot = s_->rotation[ob.image].data();
      double* tr = s_->translation[ob.image].data();
      const bool point_free = o_.target_free && ob.point != datum_[0] && ob.point != datum_[1];
      ceres::CostFunction* cost = NewModelCost(form, ob, point_free);
      if (point_free) {
        problem->AddResidualBlock(cost, loss, scaled->data(), rot, tr, point->data());
      } else {
        problem->AddResidualBlock(cost, loss, scaled->data(), rot, tr);
      }
    }
    std::vector<int> fixed;
    for (int i = 0; i < N; ++i) {
      if (!free[i]) fixed.push_back(i);
    }
    if (static_cast<int>(fixed.size()) == N) {
      problem->SetParameterBlockConstant(scaled->data());
    } else if (!fixed.empty()) {
      problem->SetManifold(scaled->data(), new ceres::SubsetManifold(N, fixed));
    }
    if (o_.target_free && problem->HasParameterBlock(s_->points[datum_[2]].data())) {
      problem->SetManifold(s_->points[datum_[2]].data(), new ceres::SubsetManifold(3, {2}));
    }
  }

  // Ceres's marginal covariance over all unknowns (sparse QR): the general path (free target,
  // robust loss, automatic differentiation) and the reference of ReducedCameraCovariance.
  // Scaled units.
  bool CeresCovariance(const FreeMask& free, CameraMatrix* covariance) {
    std::array<double, N> scaled;
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

  // Fixed target, no robust loss: the camera block of (JᵀJ)⁻¹ is the inverse of the reduced
  // camera system S = U − Σ_i W_i V_i⁻¹ W_iᵀ (U = J_camᵀJ_cam, W_i = J_camᵀJ_pose_i,
  // V_i = J_pose_iᵀJ_pose_i per image), from each observation's cost Jacobian (analytic for Brown,
  // automatic for the others): an N×N problem instead of a sparse QR over all unknowns. Singular
  // (false) if an image's pose or the free camera block has a reciprocal condition number below
  // 1e-14 (Ceres's default for its covariance). Scaled units.
  bool ReducedCameraCovariance(const FreeMask& free, CameraMatrix* covariance) {
    const int n_images = static_cast<int>(s_->rotation.size());
    std::array<double, N> scaled;
    for (int i = 0; i < N; ++i) scaled[i] = s_->camera[i] / scale_[i];
    CameraMatrix u = CameraMatrix::Zero();
    std::vector<Eigen::Matrix<double, N, 6>> w(n_images, Eigen::Matrix<double, N, 6>::Zero());
    std::vector<Eigen::Matrix<double, 6, 6>> v(n_images, Eigen::Matrix<double, 6, 6>::Zero());
    Eigen::Matrix<double, 2, N, Eigen::RowMajor> jc;
    RowJacobian3 jr, jt;
    Eigen::Matrix<double, 2, 6> jp;
    double r[2];
    for (const auto& ob : *obs_) {
      if (!ob.active) continue;
      const std::unique_ptr<ceres::CostFunction> cost(NewModelCost(Form::kProject, ob, false));
      const double* params[] = {scaled.data(), s_->rotation[ob.image].data(),
                                s_->translation[ob.image].data()};
      double* jac[] = {jc.data(), jr.data(), jt.data()};
      if (!cost->Evaluate(params, r, jac)) return false;
      jp << jr, jt;
      u.noalias() += jc.transpose() * jc;
      w[ob.image].noalias() += jc.transpose() * jp;
      v[ob.image].noalias() += jp.transpose() * jp;
    }
    for (int i = 0; i < n_images; ++i) {
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> es(v[i]);
      const auto& ev = es.eigenvalues();
      if (!(ev(0) > 1e-14 * ev(5))) return false;
      const Eigen::Matrix<double, N, 6> wq = w[i] * es.eigenvectors();
      u.noalias() -= wq * ev.cwiseInverse().asDiagonal() * wq.transpose();
    }
    std::vector<int> idx;
    for (int i = 0; i < N; ++i) {
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
  State<N>* s_;
  camera::Sensor sensor_;
  std::array<double, N> scale_;
  std::set<int> used_;
  std::array<int, 3> datum_{-1, -1, -1};
};

// Homography from the target plane (X, Y, 1) to the camera's unit rays through the observed
// pixels of one image (H·X = λ·ray, λ > 0), by the normalised DLT in a frame turned so that the
// rays' mean direction is its axis: a board seen by a fisheye 85° off axis is as well conditioned
// as one seen straight on, and rays beyond 90° from the camera axis are no exception. nullopt with
// fewer than 4 rays, or when the points do not determine a homography (FitHomography).
std::optional<Eigen::Matrix3d> RayHomography(const camera::Camera& cam, const ImageDetections& d,
                                             const std::vector<Eigen::Vector3d>& nominal) {
  std::vector<Eigen::Vector2d> src;
  std::vector<Eigen::Vector3d> rays;
  Eigen::Vector3d mean_ray = Eigen::Vector3d::Zero();
  for (std::size_t k = 0; k < d.ids.size(); ++k) {
    const auto ray = cam.Unproject(d.points_px[k]);
    if (!ray) continue;
    src.push_back(nominal[d.ids[k]].head<2>());
    rays.push_back(*ray);
    mean_ray += *ray;
  }
  if (src.size() < 4 || !(mean_ray.norm() > 0)) return std::nullopt;
  const Eigen::Matrix3d turn =
      Eigen::Quaterniond::FromTwoVectors(mean_ray.normalized(), Eigen::Vector3d::UnitZ())
          .toRotationMatrix();
  std::vector<Eigen::Vector2d> dst;
  for (const auto& r : rays) {
    const Eigen::Vector3d q = turn * r;
    if (!(q.z() > 0.05)) return std::nullopt;  // the board spans more than ~170° of view
    dst.emplace_back(q.x() / q.z(), q.y() / q.z());
  }
  const auto h = FitHomography(src, dst);
  if (!h) return std::nullopt;
  Eigen::Matrix3d hm = turn.transpose() * *h;
  // The sign that puts the observed points in front along their rays (H·X = +λ·ray).
  double along = 0;
  for (std::size_t i = 0; i < src.size(); ++i) along += (hm * src[i].homogeneous()).dot(rays[i]);
  if (along < 0) hm = -hm;
  return hm / hm.norm();
}

// Refines one image's cam_from_target pose with the camera held fixed (a PnP refinement on the
// image residual), so that a fisheye start, whose homographies are only approximate, is good.
template <typename M>
void RefinePose(const camera::Camera& cam, const ImageDetections& d,
                const std::vector<Eigen::Vector3d>& nominal, std::array<double, 3>* rotation,
                std::array<double, 3>* translation) {
  std::array<double, M::kNumParams> params;
  std::copy(cam.params.begin(), cam.params.end(), params.begin());
  std::array<double, M::kNumParams> unit;
  unit.fill(1.0);
  ceres::Problem problem;
  for (std::size_t k = 0; k < d.ids.size(); ++k) {
    auto* f = new ModelResidual<M>{d.points_px[k].x(), d.points_px[k].y(), cam.sensor, unit,
                                   nominal[d.ids[k]]};
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<ModelResidual<M>, 2, M::kNumParams, 3, 3>(f),
                             new ceres::HuberLoss(0.02 * cam.sensor.width_px), params.data(),
                             rotation->data(), translation->data());
  }
  problem.SetParameterBlockConstant(params.data());
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = 50;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
}

// The start poses of every image for a start camera, and the RMS (px) of the observations
// reprojected through that camera from them. An image whose rays do not determine its pose
// (RayHomography), or with a point the camera cannot project from it (the adjustment could not
// take its first step), is marked false in *usable and left out of the RMS; nullopt when fewer
// than 3 images are usable. With `refine`, each pose is refined with the camera fixed
// (RefinePose).
template <typename M>
std::optional<double> StartPoses(const camera::Camera& cam,
                                 const std::vector<const ImageDetections*>& images,
                                 const std::vector<Eigen::Vector3d>& nominal,
                                 State<M::kNumParams>* s, bool refine, std::vector<bool>* usable) {
  const int n = static_cast<int>(images.size());
  s->rotation.assign(n, {});
  s->translation.assign(n, {});
  usable->assign(n, false);
  double ss = 0;
  int count = 0, n_usable = 0;
  for (int i = 0; i < n; ++i) {
    const auto h = RayHomography(cam, *images[i], nominal);
    if (!h) continue;
    PoseFromHomography(*h, 1.0, &s->rotation[i], &s->translation[i]);
    if (refine) RefinePose<M>(cam, *images[i], nominal, &s->rotation[i], &s->translation[i]);
    Eigen::Matrix3d r;
    ceres::AngleAxisToRotationMatrix(s->rotation[i].data(), r.data());
    double image_ss = 0;
    bool ok = true;
    for (std::size_t k = 0; k < images[i]->ids.size() && ok; ++k) {
      const Eigen::Vector3d p =
          r * nominal[images[i]->ids[k]] + Eigen::Vector3d(s->translation[i].data());
      const auto uv = cam.Project(p);
      ok = uv.has_value();
      if (ok) image_ss += (*uv - images[i]->points_px[k]).squaredNorm();
    }
    if (!ok) continue;
    (*usable)[i] = true;
    ++n_usable;
    ss += image_ss;
    count += static_cast<int>(images[i]->ids.size());
  }
  if (n_usable < 3) return std::nullopt;
  return std::sqrt(ss / count);
}

template <typename M>
CalibrationResult CalibrateModel(std::vector<const ImageDetections*> used_images,
                                 const std::vector<Eigen::Vector3d>& nominal,
                                 const CalibrationOptions& options, const FreeMask& free_start,
                                 CalibrationResult res) {
  constexpr int N = M::kNumParams;
  const auto t0 = std::chrono::steady_clock::now();
  const auto say = [&](const std::string& m) {
    if (options.progress) options.progress(m);
  };
  const camera::Sensor& sensor = res.camera.sensor;
  const CameraModelId id = M::kId;
  const camera::ModelInfo& info = camera::Info(id);

  // Start: the camera (initial, or ideal), its focal length, then the poses.
  State<N> s;
  s.points = nominal;
  camera::Camera start = camera::Camera::Ideal(id, sensor, 1.0);
  if (options.initial) {
    start.params = options.initial->params;
  }
  bool focal_free = false;
  for (int i = 0; i < info.num_focal; ++i) focal_free = focal_free || free_start[i];
  if (focal_free || !options.initial) {
    if (!M::kCaps.fisheye) {
      // Zhang on the homographies of the centred pixels (one focal length, no distortion).
      std::vector<Eigen::Matrix3d> hs;
      const Eigen::Vector2d mid(0.5 * (sensor.width_px - 1), 0.5 * (sensor.height_px - 1));
      for (const auto* d : used_images) {
        std::vector<Eigen::Vector2d> src, dst;
        for (std::size_t k = 0; k < d->ids.size(); ++k) {
          src.push_back(nominal[d->ids[k]].head<2>());
          dst.push_back(d->points_px[k] - mid);
        }
        if (const auto h = FitHomography(src, dst)) hs.push_back(*h);
      }
      const auto f = ZhangPrincipalDistance(hs);
      camera::SetFocalLengthPx(&start, f ? *f : std::max(sensor.width_px, sensor.height_px));
      say(f ? fmt::format("start: Zhang focal length {:.2f} px ({:.4f} mm)", *f,
                          *f * sensor.pixel_pitch_mm)
            : "start: homographies do not fix the focal length (views too parallel?); using the "
              "image width");
    } else {
      // Fisheye: the ideal projection (equidistant, equisolid, stereographic, orthographic) and
      // field (the frame corner 25°–125° off axis) whose camera best explains the views, that
      // projection approximated by the model (camera::FitToProjection).
      const double half_diag = 0.5 * std::hypot(sensor.width_px, sensor.height_px);
      double best_rms = INFINITY;
      std::string best_name;
      auto try_candidate = [&](camera::Projection p, double corner_deg) {
        const double corner = corner_deg * M_PI / 180;
        if (corner >= camera::MaxFieldAngleRad(p)) return;
        const double f = half_diag / camera::ProjectionRadius(p, corner);
        camera::Camera trial = camera::FitToProjection(
            id, sensor, p, f, std::min(1.1 * corner, camera::MaxFieldAngleRad(p)));
        State<N> trial_state;
        std::vector<bool> usable;
        const auto rms = StartPoses<M>(trial, used_images, nominal, &trial_state, false, &usable);
        if (rms && *rms < best_rms) {
          best_rms = *rms;
          best_name = fmt::format("{} {:.0f} deg to the corner", camera::ProjectionName(p),
                                  corner_deg);
          start.params = trial.params;
        }
      };
      // Every projection at 10° steps, then 5° either side of the best.
      camera::Projection best_p = camera::Projection::kEquidistant;
      double best_deg = 0;
      for (camera::Projection p : camera::kAllProjections) {
        if (!camera::IsFisheye(p)) continue;
        for (double corner_deg = 30; corner_deg <= 120; corner_deg += 10) {
          const double before = best_rms;
          try_candidate(p, corner_deg);
          if (best_rms < before) best_p = p, best_deg = corner_deg;
        }
      }
      if (best_deg > 0) {
        try_candidate(best_p, best_deg - 5);
        try_candidate(best_p, best_deg + 5);
      }
      say(fmt::format("start: fisheye focal length {:.2f} px ({}; ideal-projection RMS {:.2f} px)",
                      start.FocalLengthPx(), best_name, best_rms));
    }
  }
  std::vector<bool> usable;
  if (!StartPoses<M>(start, used_images, nominal, &s, M::kCaps.fisheye, &usable)) {
    throw InvalidInput("--images", "fewer than 3 images whose points fix their pose for the start "
                                   "camera (boards seen edge-on or along one line?)");
  }
  std::copy(start.params.begin(), start.params.end(), s.camera.begin());
  {
    std::vector<const ImageDetections*> kept;
    State<N> kept_state = s;
    kept_state.rotation.clear();
    kept_state.translation.clear();
    for (std::size_t i = 0; i < used_images.size(); ++i) {
      if (!usable[i]) {
        say(fmt::format("skipped {}: its {} points do not fix its pose", used_images[i]->image,
                        used_images[i]->ids.size()));
        continue;
      }
      kept.push_back(used_images[i]);
      kept_state.rotation.push_back(s.rotation[i]);
      kept_state.translation.push_back(s.translation[i]);
    }
    used_images = std::move(kept);
    s = std::move(kept_state);
  }

  // Observations.
  std::vector<Observation> obs;
  std::set<int> used_points;
  for (std::size_t i = 0; i < used_images.size(); ++i) {
    const auto& d = *used_images[i];
    for (std::size_t k = 0; k < d.ids.size(); ++k) {
      const Eigen::Vector2d& uv = d.points_px[k];
      const Eigen::Vector2d xy = camera::PixelToImageMm(sensor, uv.x(), uv.y());
      obs.push_back({static_cast<int>(i), d.ids[k], uv.x(), uv.y(), xy.x(), xy.y(), true, uv.x(), uv.y()});
      used_points.insert(d.ids[k]);
    }
  }
  const int n_images = static_cast<int>(used_images.size());
  const int n_point_unknowns = options.target_free ? 3 * static_cast<int>(used_points.size()) - 7 : 0;


  // The centre offsets of circular targets from the current estimate (see centre_correction);
  // returns the largest change of an offset, px.
  const double dot_r = res.dot_radius_mm;
  const auto update_offsets = [&]() {
    if (!(dot_r > 0)) return 0.0;
    camera::Camera cam = res.camera;
    cam.params.assign(s.camera.begin(), s.camera.end());
    double change = 0, largest = 0;
    for (auto& ob : obs) {
      Eigen::Matrix3d r;
      ceres::AngleAxisToRotationMatrix(s.rotation[ob.image].data(), r.data());
      const Eigen::Vector3d t(s.translation[ob.image].data());
      const auto project = [&](const Eigen::Vector3d& x) { return cam.Project(r * x + t); };
      const Eigen::Vector3d& x = s.points[ob.point];
      const auto projected = project(x);
      const auto centre = coded::ImagedCircleCentre(project, x, Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(), dot_r);
      const Eigen::Vector2d offset = projected && centre ? Eigen::Vector2d(*centre - *projected) : Eigen::Vector2d::Zero();
      const Eigen::Vector2d uv = Eigen::Vector2d(ob.measured_u_px, ob.measured_v_px) - offset;
      change = std::max(change, std::hypot(uv.x() - ob.u_px, uv.y() - ob.v_px));
      largest = std::max(largest, offset.norm());
      const Eigen::Vector2d xy = camera::PixelToImageMm(sensor, uv.x(), uv.y());
      ob.u_px = uv.x(), ob.v_px = uv.y(), ob.x_mm = xy.x(), ob.y_mm = xy.y();
    }
    res.max_centre_offset_px = largest;
    return change;
  };
  Adjustment<M> adj(options, &obs, &s, sensor, used_points);
  if constexpr (M::kCaps.analytic_jacobian) res.iterations += adj.Solve(free_start, Form::kCorrect);
  update_offsets();
  // One adjustment in the image residual, repeated while the centre offsets move (at most 10).
  const auto solve = [&](const FreeMask& f) {
    for (int k = 0; k < 10; ++k) {
      res.iterations += adj.Solve(f, Form::kProject);
      if (update_offsets() < 1e-5) break;
    }
  };
  say(fmt::format("{} images, {} points: adjusting {} ({})", n_images, obs.size(),
                  FreeParametersToString(id, free_start), M::kName));

  // Adjust, reject outliers, evaluate statistics; stepwise drop non-significant parameters.
  FreeMask free = free_start;
  typename Adjustment<M>::CameraMatrix cov;
  res.sigma.assign(N, NAN);
  res.covariance = Eigen::MatrixXd::Zero(N, N);
  while (true) {
    int n_free_now = 0;
    for (bool f : free) n_free_now += f ? 1 : 0;
    res.n_unknowns = n_free_now + 6 * n_images + n_point_unknowns;
    double ss = 0;
    int n_active = 0;
    for (int round = 0;; ++round) {
      solve(free);
      ss = 0;
      n_active = 0;
      for (const auto& ob : obs) {
        if (!ob.active) continue;
        const auto r = Residual<M>(s, ob, sensor);
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
        const auto r = Residual<M>(s, ob, sensor);
        if (!r || r->norm() > options.reject_k * sigma0) ob.active = false, ++rejected;
      }
      if (rejected == 0) break;
      say(fmt::format("rejected {} points beyond {:g} sigma0 ({:.3f} px); readjusting", rejected,
                      options.reject_k, sigma0));
    }
    res.sigma0_px = std::sqrt(ss / res.redundancy);
    res.rms_px = std::sqrt(ss / n_active);
    res.n_points = n_active;
    if (!options.statistics) break;
    res.covariance_ok = adj.Covariance(free, &cov);
    res.covariance = cov * (res.sigma0_px * res.sigma0_px);
    res.significance.clear();
    int weakest = -1;
    double weakest_t = options.significance_t;
    for (int i = 0; i < N; ++i) {
      res.sigma[i] = free[i] ? std::sqrt(res.covariance(i, i)) : NAN;
      if (i < info.first_distortion || !free[i]) continue;
      const double t = std::abs(s.camera[i]) / res.sigma[i];
      res.significance.push_back({i, t, t >= options.significance_t});
      if (t < weakest_t) weakest_t = t, weakest = i;
    }
    if (!options.drop_insignificant || weakest < 0 || !res.covariance_ok) break;
    res.dropped.push_back({weakest, s.camera[weakest], res.sigma[weakest], weakest_t});
    say(fmt::format("dropping {} = {:.4g} (|p|/sigma = {:.2f} < {:g}) and readjusting",
                    M::kParams[weakest].name, s.camera[weakest], weakest_t,
                    options.significance_t));
    free[weakest] = false;
    s.camera[weakest] = 0;
  }
  res.free = free;
  res.correlation = Eigen::MatrixXd::Constant(N, N, NAN);
  for (int i = 0; i < N; ++i) {
    for (int j = 0; j < N; ++j) {
      if (free[i] && free[j]) {
        res.correlation(i, j) = res.covariance(i, j) / (res.sigma[i] * res.sigma[j]);
      }
    }
  }
  res.camera.params.assign(s.camera.begin(), s.camera.end());
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
    const auto r = Residual<M>(s, ob, sensor);
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

}  // namespace

FreeMask DefaultFree(CameraModelId model) {
  const camera::ModelInfo& m = camera::Info(model);
  FreeMask free(m.num_params, true);
  if (model == CameraModelId::kBrown) {
    free[camera::kBrownK3] = free[camera::kBrownB1] = free[camera::kBrownB2] = false;
  } else if (model == CameraModelId::kOpenCV) {
    for (int i = camera::OpenCVModel::kK3; i <= camera::OpenCVModel::kK6; ++i) free[i] = false;
  }
  return free;
}

FreeMask ParseFreeParameters(CameraModelId model, const std::string& list,
                             const std::string& field) {
  const camera::ModelInfo& m = camera::Info(model);
  if (list == "all") return FreeMask(m.num_params, true);
  if (list == "default") return DefaultFree(model);
  FreeMask free(m.num_params, false);
  std::size_t start = 0;
  while (start <= list.size()) {
    std::size_t end = list.find(',', start);
    if (end == std::string::npos) end = list.size();
    const std::string name = list.substr(start, end - start);
    const auto i = camera::ParamIndex(model, name);
    if (!i) {
      std::string names;
      for (const auto& p : m.params) names += std::string(p.name) + ",";
      throw InvalidInput(field, fmt::format("unknown parameter '{}' of the {} model (use {} all "
                                            "or default)", name, m.name, names));
    }
    free[*i] = true;
    start = end + 1;
  }
  return free;
}

std::string FreeParametersToString(CameraModelId model, const FreeMask& free) {
  const camera::ModelInfo& m = camera::Info(model);
  std::string s;
  for (int i = 0; i < m.num_params && i < static_cast<int>(free.size()); ++i) {
    if (!free[i]) continue;
    if (!s.empty()) s += ",";
    s += m.params[i].name;
  }
  return s;
}

CalibrationResult Calibrate(const std::vector<ImageDetections>& detections,
                            const TargetSpec& target, const CalibrationOptions& options) {
  const auto say = [&](const std::string& m) {
    if (options.progress) options.progress(m);
  };
  if (options.centre_correction == CalibrationOptions::CentreCorrection::kOn && target.kind != TargetKind::kCoded) {
    throw InvalidInput("--centre-correction", "needs circular targets of known dot radius (coded:BITS:RADIUS_MM)");
  }
  RequirePositive("--pixel-pitch-mm", options.pixel_pitch_mm);
  RequireNonNegative("--reject-k", options.reject_k);
  RequirePositive("--loss-scale-px", options.loss_scale_px);
  RequirePositive("--significance-t", options.significance_t);
  if (options.drop_insignificant && !options.statistics) {
    throw InvalidInput("statistics", "stepwise dropping needs the statistics (σ of each parameter)");
  }
  const camera::ModelInfo& info = camera::Info(options.model);
  const FreeMask free = options.FreeOrDefault();
  if (static_cast<int>(free.size()) != info.num_params) {
    throw InvalidInput("--free", fmt::format("{} flags for the {} parameters of model {}",
                                             free.size(), info.num_params, info.name));
  }
  if (options.initial && options.initial->model != options.model) {
    throw InvalidInput("--initial", fmt::format("a {} camera cannot start a {} calibration",
                                                options.initial->model_name(), info.name));
  }
  for (int i = 0; i < info.first_distortion; ++i) {
    if (!free[i] && !options.initial) {
      throw InvalidInput("--free", fmt::format("{} may be fixed only with a start camera "
                                               "(--initial)", info.params[i].name));
    }
  }
  const std::vector<Eigen::Vector3d> nominal = TargetPoints(target);

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
    // Points (nearly) on one line of the target do not fix the image's pose: a board seen only
    // along its edge (a fisheye's frame corner) would start the adjustment from a wrong pose.
    {
      Eigen::Vector2d mean = Eigen::Vector2d::Zero();
      for (int id : d.ids) mean += nominal[id].head<2>();
      mean /= static_cast<double>(d.ids.size());
      Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
      for (int id : d.ids) {
        const Eigen::Vector2d q = nominal[id].head<2>() - mean;
        scatter += q * q.transpose();
      }
      const Eigen::Vector2d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(scatter).eigenvalues();
      if (!(ev(0) > 0.01 * ev(1))) {
        say(fmt::format("skipped {}: its {} points lie nearly on one line of the target",
                        d.image, d.ids.size()));
        continue;
      }
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
                                               FreeParametersToString(options.model, free)));
  }
  CalibrationResult res;
  using CC = CalibrationOptions::CentreCorrection;
  if (target.kind == TargetKind::kCoded && options.centre_correction != CC::kOff) res.dot_radius_mm = target.dot_radius_mm;
  res.camera.model = options.model;
  res.camera.sensor = {used_images[0]->width_px, used_images[0]->height_px,
                       options.pixel_pitch_mm};
  camera::ValidateSensor(res.camera.sensor);
  if (options.initial) {
    camera::Camera initial = *options.initial;
    initial.sensor = res.camera.sensor;
    camera::ValidateCamera(initial, "--initial");
  }
  return camera::VisitModel(options.model, [&](auto m) {
    return CalibrateModel<decltype(m)>(used_images, nominal, options, free, std::move(res));
  });
}

}  // namespace porthole::calib
