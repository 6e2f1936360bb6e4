#include "porthole/calib/calibrate.h"
#include "porthole/calib/bundle.h"

#include <ceres/ceres.h>
#include <glog/logging.h>
#include <fmt/format.h>

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <set>

#include "porthole/calib/prior_cost.h"
#include "porthole/calib/residual.h"
#include "porthole/calib/scales.h"
#include "porthole/coded/ellipse.h"
#include "porthole/core/error.h"
#include "porthole/core/hartley.h"

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
  const Eigen::Matrix3d ts = HartleyNormaliser<2>(src), td = HartleyNormaliser<2>(dst);
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

using Matrix34d = Eigen::Matrix<double, 3, 4>;

// Normalised DLT camera matrix (Hartley: both sets normalised) mapping 3-D points to 2-D points,
// P·(X, 1) ∝ (x, 1), unit Frobenius norm; the right singular vector of the 2n×12 system taken
// as the eigenvector of its 12×12 normal matrix, as FitHomography. nullopt with fewer than 6
// points, or when they do not determine it (all on one plane or line): the second-smallest
// singular value below 1e-3 of the largest.
std::optional<Matrix34d> FitCameraMatrix(const std::vector<Eigen::Vector3d>& src,
                                         const std::vector<Eigen::Vector2d>& dst) {
  if (src.size() < 6 || src.size() != dst.size()) return std::nullopt;
  const Eigen::Matrix4d ts = HartleyNormaliser<3>(src);
  const Eigen::Matrix3d td = HartleyNormaliser<2>(dst);
  Eigen::MatrixXd a(2 * src.size(), 12);
  for (std::size_t i = 0; i < src.size(); ++i) {
    const Eigen::RowVector4d x = (ts * src[i].homogeneous()).transpose();
    const Eigen::Vector3d d = td * dst[i].homogeneous();
    a.row(2 * i) << x, Eigen::RowVector4d::Zero(), -d.x() * x;
    a.row(2 * i + 1) << Eigen::RowVector4d::Zero(), x, -d.y() * x;
  }
  const Eigen::Matrix<double, 12, 12> ata = a.transpose() * a;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 12, 12>> es(ata);
  const auto& ev = es.eigenvalues();  // σ², ascending
  if (!(ev(1) > 1e-6 * ev(11))) return std::nullopt;
  const Eigen::Matrix<double, 12, 1> p = es.eigenvectors().col(0);
  Matrix34d pn;
  pn << p.segment<4>(0).transpose(), p.segment<4>(4).transpose(), p.segment<4>(8).transpose();
  const Matrix34d pm = td.inverse() * pn * ts;
  return Matrix34d(pm / pm.norm());
}

// K of M = K·R (the RQ decomposition: K upper triangular with a positive diagonal, R a rotation
// up to sign), scaled to K(2, 2) = 1: the calibration matrix of a DLT camera matrix's left 3×3.
Eigen::Matrix3d RqCalibration(const Eigen::Matrix3d& m) {
  Eigen::Matrix3d flip;
  flip << 0, 0, 1, 0, 1, 0, 1, 0, 0;
  // (flip·M)ᵀ = Q·U  ⇒  M = (flip·Uᵀ·flip)·(flip·Qᵀ), flip·Uᵀ·flip upper triangular.
  const Eigen::HouseholderQR<Eigen::Matrix3d> qr((flip * m).transpose());
  const Eigen::Matrix3d u = qr.matrixQR().triangularView<Eigen::Upper>();
  Eigen::Matrix3d k = flip * u.transpose() * flip;
  for (int i = 0; i < 3; ++i) {
    if (k(i, i) < 0) k.col(i) *= -1;  // K·D, D·R with D = diag(±1)
  }
  return k / k(2, 2);
}

// A target field is planar when no point lies off its least-squares plane by more than this
// fraction of its extent (twice the largest distance of a point from its centroid): then every
// image's start is a homography of that plane; otherwise a DLT where an image sees the field off
// one plane.
constexpr double kPlanarFraction = 0.02;

// The least-squares plane of a point set: its centroid, its principal axes (columns: the largest
// spread, the second, and the plane's normal, a right-handed frame), the spread (RMS distance
// from the centroid) along each, the largest distance of a point from the plane and the extent.
struct PlaneFit {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();
  Eigen::Vector3d spread = Eigen::Vector3d::Zero();  // along axes' columns, mm
  double off_plane_mm = 0;
  double extent_mm = 0;
  bool Planar() const { return off_plane_mm <= kPlanarFraction * extent_mm; }
  // Points (nearly) on one line: the second spread below 10 % of the first.
  bool OnALine() const { return !(spread(1) > 0.1 * spread(0)); }
};

PlaneFit FitPlane(const std::vector<Eigen::Vector3d>& pts) {
  PlaneFit f;
  if (pts.empty()) return f;
  for (const auto& p : pts) f.centroid += p;
  f.centroid /= static_cast<double>(pts.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const auto& p : pts) {
    scatter += (p - f.centroid) * (p - f.centroid).transpose();
    f.extent_mm = std::max(f.extent_mm, 2 * (p - f.centroid).norm());
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(scatter / static_cast<double>(pts.size()));
  f.axes.col(0) = es.eigenvectors().col(2);
  f.axes.col(1) = es.eigenvectors().col(1);
  f.axes.col(2) = f.axes.col(0).cross(f.axes.col(1));
  f.spread = es.eigenvalues().reverse().cwiseMax(0).cwiseSqrt();
  for (const auto& p : pts) f.off_plane_mm = std::max(f.off_plane_mm, std::abs(f.axes.col(2).dot(p - f.centroid)));
  return f;
}

// Coordinates of coplanar points in a frame of their plane, target = axes·(x, y, 0) + origin:
// X, Y themselves (axes I, origin 0) when every Z is 0, as on every printed board; nullopt when
// the points are not planar (PlaneFit::Planar).
struct PlaneFrame {
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector2d> xy;
};

std::optional<PlaneFrame> OnPlane(const std::vector<Eigen::Vector3d>& pts) {
  PlaneFrame f;
  if (std::all_of(pts.begin(), pts.end(), [](const Eigen::Vector3d& p) { return p.z() == 0; })) {
    for (const auto& p : pts) f.xy.push_back(p.head<2>());
    return f;
  }
  const PlaneFit fit = FitPlane(pts);
  if (!fit.Planar()) return std::nullopt;
  f.axes = fit.axes;
  f.origin = fit.centroid;
  for (const auto& p : pts) f.xy.push_back((fit.axes.transpose() * (p - fit.centroid)).head<2>());
  return f;
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
  // h's sign is the caller's (PoseFromRays: the target points lie along +ray); the target origin
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

// The datum of a free target: 7 fixed coordinates, the minimum that fixes its similarity gauge
// (translation, rotation, scale): all three of point a, all three of point b (the direction and
// the nominal length a–b), and coordinate `axis` of point c, which fixes the rotation about the
// line a–b — c moves by ω·d × (c − a) under it (d the line's direction), so c and the axis are
// the observed point and coordinate where that motion is largest. On a planar field (Z = 0) that
// is the Z of the point farthest from the line. a is the lowest observed id, b the observed point
// farthest from it. On a 3-D field the three are taken among the points of its dominant plane
// (DominantPlane: the board of raised targets), so that the raised points, whose heights a
// self-calibration is there to measure, are all free.
using Datum = CalibrationResult::Datum;

// The observed points of the field's dominant plane: every point when the field is planar; else
// those within 2 % of the extent of the plane fitted, twice, to the half of the points nearest
// the previous fit (a trimmed fit: raised targets leave it), when at least 3 off one line lie
// there; else every point.
std::vector<int> DominantPlane(const std::vector<Eigen::Vector3d>& pts, const std::set<int>& used) {
  std::vector<int> all(used.begin(), used.end());
  std::vector<Eigen::Vector3d> xyz;
  for (int id : all) xyz.push_back(pts[id]);
  const PlaneFit whole = FitPlane(xyz);
  if (whole.Planar()) return all;
  PlaneFit fit = whole;
  for (int round = 0; round < 2; ++round) {
    std::vector<std::pair<double, int>> by_distance;
    for (int id : all) by_distance.push_back({std::abs(fit.axes.col(2).dot(pts[id] - fit.centroid)), id});
    std::sort(by_distance.begin(), by_distance.end());
    std::vector<Eigen::Vector3d> nearest;
    for (std::size_t k = 0; k < std::max<std::size_t>(3, by_distance.size() / 2); ++k) nearest.push_back(pts[by_distance[k].second]);
    fit = FitPlane(nearest);
  }
  std::vector<int> on;
  std::vector<Eigen::Vector3d> on_xyz;
  for (int id : all) {
    if (std::abs(fit.axes.col(2).dot(pts[id] - fit.centroid)) <= kPlanarFraction * whole.extent_mm) {
      on.push_back(id);
      on_xyz.push_back(pts[id]);
    }
  }
  if (on.size() < 3 || FitPlane(on_xyz).OnALine()) return all;
  return on;
}

Datum ChooseDatum(const std::vector<Eigen::Vector3d>& pts, const std::set<int>& used) {
  const std::vector<int> candidates = DominantPlane(pts, used);
  Datum d;
  d.a = d.b = d.c = candidates.front();
  double best = -1;
  for (int id : candidates) {
    const double dist = (pts[id] - pts[d.a]).norm();
    if (dist > best) best = dist, d.b = id;
  }
  best = -1;
  const Eigen::Vector3d dir = (pts[d.b] - pts[d.a]).normalized();
  for (int id : candidates) {
    const Eigen::Vector3d motion = dir.cross(pts[id] - pts[d.a]);
    for (int k = 0; k < 3; ++k) {
      if (std::abs(motion(k)) > best) best = std::abs(motion(k)), d.c = id, d.axis = k;
    }
  }
  return d;
}

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

  // `control`: the observed control points (id → σ per coordinate, mm) when the datum is theirs;
  // empty: the minimal datum.
  Adjustment(const CalibrationOptions& options, std::vector<Observation>* obs, State<N>* state,
             const camera::Sensor& sensor, const std::set<int>& used_points,
             std::map<int, Eigen::Vector3d> control = {})
      : o_(options), obs_(obs), s_(state), sensor_(sensor), scale_(ModelScales<M>(sensor)),
        used_(used_points), control_(std::move(control)) {
    if (!o_.target_free) return;
    if (control_.empty()) {
      datum_ = ChooseDatum(s_->points, used_);
    } else {
      for (const auto& [id, sigma] : control_) {
        datum_.control.push_back(id);
        given_[id] = s_->points[id];
      }
    }
  }

  // The weight of the control points' priors: σ0 (px) of the images (1 until known).
  void SetPriorWeight(double sigma0_px) { prior_weight_ = sigma0_px > 0 && std::isfinite(sigma0_px) ? sigma0_px : 1.0; }
  // The priors' squared residuals at the current points (counted in σ0 with the images').
  double PriorSumSquares() const {
    double ss = 0;
    for (const auto& [id, sigma] : control_) {
      for (int k = 0; k < 3; ++k) {
        if (sigma(k) > 0) ss += std::pow(prior_weight_ * (s_->points[id](k) - given_.at(id)(k)) / sigma(k), 2);
      }
    }
    return ss;
  }

  // Least squares over the active observations with the free parameters `free` in the residual
  // form `form` (residual.h; only the Brown model has the correction form, every other model
  // always uses the image residual); updates the state and returns the Ceres iterations.
  int Solve(const FreeMask& free, Form form) {
    std::array<double, N> scaled;
    const std::unique_ptr<Bundle> bundle = MakeBundle(free, form, &scaled);
    BundleSolveOptions so;
    // Schur elimination of the poses (and free target points): the reduced camera system is
    // small, so the dense variant is the fastest; large free targets use the sparse one.
    so.sparse = o_.target_free && used_.size() > 200;
    so.max_iterations = o_.max_iterations;
    // The scaled parameters (ParameterScales) and the homography start make the Gauss–Newton step
    // good from the first iteration: a large initial trust region lets Levenberg–Marquardt take
    // it (the radius still shrinks after a failed step). Ceres's default 1e4 damps the first
    // steps and cost 3–4 extra iterations per stage on the samples.
    so.initial_trust_region_radius = M::kCaps.analytic_jacobian ? 1e8 : 1e4;
    // The correction-form stage is only the start of the image-residual stage, which converges
    // from anywhere near its optimum in 2–3 steps: 1e-6 is enough there. The image-residual
    // stage stops at 1e-8 relative changes, far below the statistics' precision.
    so.function_tolerance = form == Form::kProject ? 1e-8 : 1e-6;
    so.parameter_tolerance = form == Form::kProject ? 1e-8 : 1e-6;
    so.gradient_tolerance = 1e-12;
    so.num_threads = o_.num_threads;
    const ceres::Solver::Summary summary = bundle->Solve(so);
    for (int i = 0; i < N; ++i) s_->camera[i] = scaled[i] * scale_[i];
    for (std::size_t i = 0; i < pose_.size(); ++i) {
      std::copy(pose_[i].begin(), pose_[i].begin() + 3, s_->rotation[i].begin());
      std::copy(pose_[i].begin() + 3, pose_[i].end(), s_->translation[i].begin());
    }
    return static_cast<int>(summary.iterations.size());
  }

  // The unscaled marginal covariance of the camera parameters, (JᵀJ)⁻¹ of the image residual
  // (px, not yet multiplied by σ0²), rows and columns of fixed parameters 0. False if singular.
  // With a free target, *point_variance (if given) receives the diagonal of each point's block
  // (mm², unscaled likewise; 0 for the datum's fixed coordinates, NaN for unobserved ids).
  bool Covariance(const FreeMask& free, CameraMatrix* covariance,
                  std::vector<Eigen::Vector3d>* point_variance = nullptr) {
    covariance->setZero();
    bool ok = (o_.target_free || o_.loss != LossKind::kNone || o_.ceres_covariance)
                  ? CeresCovariance(free, covariance, point_variance)
                  : ReducedCameraCovariance(free, covariance);
    // Back to the parameters' own units: Σ = S Σ_scaled S.
    const Eigen::Map<const Eigen::Matrix<double, N, 1>> sv(scale_.data());
    *covariance = sv.asDiagonal() * (*covariance) * sv.asDiagonal();
    return ok;
  }

  const Datum& datum() const { return datum_; }

 private:
  // The camera as the Bundle (bundle.h) sees it; `scaled` its block.
  BundleCamera CameraOf(const FreeMask& free, double* scaled) const {
    BundleCamera c;
    c.model = M::kId;
    c.sensor = sensor_;
    c.scaled = scaled;
    c.scale.assign(scale_.begin(), scale_.end());
    c.free.assign(free.begin(), free.begin() + N);
    return c;
  }

  // The adjustment as a Bundle (bundle.h) in the residual form `form`: the camera (scaled into
  // `scaled`, which must outlive it), one pose block [rotation, translation] per image (copied
  // back after Solve), the free target's points with the datum held, the control points' priors.
  std::unique_ptr<Bundle> MakeBundle(const FreeMask& free, Form form, std::array<double, N>* scaled) {
    for (int i = 0; i < N; ++i) (*scaled)[i] = s_->camera[i] / scale_[i];
    pose_.resize(s_->rotation.size());
    for (std::size_t i = 0; i < pose_.size(); ++i) {
      std::copy(s_->rotation[i].begin(), s_->rotation[i].end(), pose_[i].begin());
      std::copy(s_->translation[i].begin(), s_->translation[i].end(), pose_[i].begin() + 3);
    }
    auto bundle = std::make_unique<Bundle>(o_.loss, o_.loss_scale_px, form);
    bundle->AddCamera(CameraOf(free, scaled->data()));
    for (const auto& ob : *obs_) {
      if (!ob.active) continue;
      BundleObservation b;
      b.pose = pose_[ob.image].data();
      b.point = s_->points[ob.point];
      if (PointFree(ob.point)) b.point_block = s_->points[ob.point].data();
      b.u_px = ob.u_px, b.v_px = ob.v_px;
      bundle->AddObservation(b);
    }
    if (o_.target_free && control_.empty()) bundle->HoldPoint(s_->points[datum_.c].data(), {datum_.axis});
    // The control points: coordinates of σ 0 held, the others a prior.
    for (const auto& [id, sigma] : control_) {
      double* point = s_->points[id].data();
      if (!bundle->HasBlock(point)) continue;  // every coordinate held
      std::vector<int> held;
      for (int k = 0; k < 3; ++k) {
        if (!(sigma(k) > 0)) held.push_back(k);
      }
      if (!held.empty()) bundle->HoldPoint(point, held);
      bundle->AddCost(new ControlPrior(given_.at(id), sigma, prior_weight_), {point});
    }
    return bundle;
  }

  // Whether point `id` is a parameter block: a free target's point, unless the datum holds it whole.
  bool PointFree(int id) const {
    if (!o_.target_free) return false;
    if (control_.empty()) return id != datum_.a && id != datum_.b;
    const auto c = control_.find(id);
    return c == control_.end() || (c->second.array() > 0).any();
  }

  // Ceres's marginal covariance over all unknowns (sparse QR): the general path (free target,
  // robust loss, automatic differentiation) and the reference of ReducedCameraCovariance.
  // Scaled units.
  bool CeresCovariance(const FreeMask& free, CameraMatrix* covariance,
                       std::vector<Eigen::Vector3d>* point_variance) {
    std::array<double, N> scaled;
    const std::unique_ptr<Bundle> bundle = MakeBundle(free, Form::kProject, &scaled);
    ceres::Problem& problem = bundle->problem();
    ceres::Covariance::Options co;
    co.num_threads = o_.num_threads;
    ceres::Covariance cov(co);
    const double* cam = scaled.data();
    std::vector<std::pair<const double*, const double*>> blocks = {{cam, cam}};
    std::vector<int> free_points;
    if (point_variance != nullptr && o_.target_free) {
      for (int id : used_) {
        if (problem.HasParameterBlock(s_->points[id].data())) {
          free_points.push_back(id);
          blocks.push_back({s_->points[id].data(), s_->points[id].data()});
        }
      }
    }
    // Ceres writes row-major; the matrix is symmetric, so the storage order does not matter.
    if (!cov.Compute(blocks, &problem) || !cov.GetCovarianceBlock(cam, cam, covariance->data())) return false;
    if (point_variance != nullptr) {
      point_variance->assign(s_->points.size(), Eigen::Vector3d::Constant(NAN));
      if (o_.target_free && control_.empty()) {
        (*point_variance)[datum_.a] = (*point_variance)[datum_.b] = Eigen::Vector3d::Zero();
      }
      for (const auto& [id, sigma] : control_) {
        if (!PointFree(id)) (*point_variance)[id] = Eigen::Vector3d::Zero();
      }
      for (int id : free_points) {
        Eigen::Matrix3d c;  // ambient: the datum's fixed coordinate has variance 0
        if (!cov.GetCovarianceBlock(s_->points[id].data(), s_->points[id].data(), c.data())) return false;
        (*point_variance)[id] = c.diagonal();
      }
    }
    return true;
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
    Eigen::Matrix<double, 2, 6, Eigen::RowMajor> jp;
    double r[2];
    const BundleCamera camera = CameraOf(free, scaled.data());
    std::array<double, 6> pose;
    for (const auto& ob : *obs_) {
      if (!ob.active) continue;
      std::copy(s_->rotation[ob.image].begin(), s_->rotation[ob.image].end(), pose.begin());
      std::copy(s_->translation[ob.image].begin(), s_->translation[ob.image].end(), pose.begin() + 3);
      BundleObservation b;
      b.pose = pose.data();
      b.point = s_->points[ob.point];
      b.u_px = ob.u_px, b.v_px = ob.v_px;
      const std::unique_ptr<ceres::CostFunction> cost(NewObservationCost(camera, b));
      const double* params[] = {scaled.data(), pose.data()};
      double* jac[] = {jc.data(), jp.data()};
      if (!cost->Evaluate(params, r, jac)) return false;
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
  std::map<int, Eigen::Vector3d> control_;  // the control datum's points: id → σ, mm
  std::map<int, Eigen::Vector3d> given_;    // their given positions
  double prior_weight_ = 1.0;
  Datum datum_;
  std::vector<std::array<double, 6>> pose_;  // the problem's pose blocks (Build)
};

// The cam_from_target pose of one image from the camera's unit rays through its observed points
// and their target coordinates (mm): a PnP for a known camera. Solved in a frame turned so that
// the rays' mean direction is its axis: a board seen by a fisheye 85° off axis is as well
// conditioned as one seen straight on, and rays beyond 90° from the camera axis are no exception.
// Coplanar points (OnPlane): the normalised DLT homography of their plane onto the rays
// (FitHomography), the pose from it (PoseFromHomography). Points off one plane: the normalised
// DLT camera matrix of the rays (FitCameraMatrix), which for a calibrated camera is λ·[R | t]:
// R its left 3×3 over λ = det^(1/3), orthonormalised by SVD. Either with the sign that puts the
// points in front along their rays. False with fewer than 4 rays (6 off a plane), rays spanning
// more than ~170°, or points that do not fix the pose.
bool PoseFromRays(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& rays,
                  std::array<double, 3>* rotation, std::array<double, 3>* translation) {
  if (points.size() < 4 || points.size() != rays.size()) return false;
  Eigen::Vector3d mean_ray = Eigen::Vector3d::Zero();
  for (const auto& r : rays) mean_ray += r;
  if (!(mean_ray.norm() > 0)) return false;
  const Eigen::Matrix3d turn =
      Eigen::Quaterniond::FromTwoVectors(mean_ray.normalized(), Eigen::Vector3d::UnitZ())
          .toRotationMatrix();
  std::vector<Eigen::Vector2d> dst;
  for (const auto& r : rays) {
    const Eigen::Vector3d q = turn * r;
    if (!(q.z() > 0.05)) return false;  // the points span more than ~170° of view
    dst.emplace_back(q.x() / q.z(), q.y() / q.z());
  }
  if (const auto plane = OnPlane(points)) {
    const auto h = FitHomography(plane->xy, dst);
    if (!h) return false;
    Eigen::Matrix3d hm = turn.transpose() * *h;
    double along = 0;  // H·X = +λ·ray
    for (std::size_t i = 0; i < rays.size(); ++i) along += (hm * plane->xy[i].homogeneous()).dot(rays[i]);
    if (along < 0) hm = -hm;
    PoseFromHomography(hm / hm.norm(), 1.0, rotation, translation);
    if (plane->axes.isIdentity(0) && plane->origin.isZero(0)) return true;
    // cam = R_p·(x, y, 0) + t_p with (x, y, 0) = axesᵀ·(X − origin).
    const Eigen::Vector3d v(rotation->data());
    const Eigen::Matrix3d r_plane = Eigen::AngleAxisd(v.norm(), v.norm() > 0 ? v.normalized() : Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const Eigen::Matrix3d r = r_plane * plane->axes.transpose();
    const Eigen::Vector3d t = Eigen::Vector3d(translation->data()) - r * plane->origin;
    const Eigen::AngleAxisd aa(r);
    const Eigen::Vector3d w = aa.angle() * aa.axis();
    *rotation = {w.x(), w.y(), w.z()};
    *translation = {t.x(), t.y(), t.z()};
    return true;
  }
  const auto p = FitCameraMatrix(points, dst);
  if (!p) return false;
  Matrix34d pm = turn.transpose() * *p;
  double along = 0;
  for (std::size_t i = 0; i < rays.size(); ++i) along += (pm * points[i].homogeneous()).dot(rays[i]);
  if (along < 0) pm = -pm;
  const Eigen::Matrix3d m = pm.leftCols<3>();
  const double det = m.determinant();
  if (!(det > 0)) return false;  // a mirror image: not a camera
  const double lambda = std::cbrt(det);
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(m / lambda, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d r = svd.matrixU() * svd.matrixV().transpose();
  const Eigen::AngleAxisd aa(r);
  const Eigen::Vector3d w = aa.angle() * aa.axis();
  const Eigen::Vector3d t = pm.col(3) / lambda;
  *rotation = {w.x(), w.y(), w.z()};
  *translation = {t.x(), t.y(), t.z()};
  return true;
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
  // A pose from which a point cannot be projected (behind the camera: a PnP of too few points)
  // is left as it is, for StartPoses to find unusable, not handed to Ceres.
  {
    Eigen::Matrix3d r;
    ceres::AngleAxisToRotationMatrix(rotation->data(), r.data());
    for (int id : d.ids) {
      if (!cam.Project(r * nominal[id] + Eigen::Vector3d(translation->data()))) return;
    }
  }
  BundleCamera c;  // held: its parameters unscaled
  c.model = M::kId;
  c.sensor = cam.sensor;
  c.scaled = params.data();
  c.scale.assign(unit.begin(), unit.end());
  c.free.assign(M::kNumParams, false);
  std::array<double, 6> pose;
  std::copy(rotation->begin(), rotation->end(), pose.begin());
  std::copy(translation->begin(), translation->end(), pose.begin() + 3);
  ceres::Problem problem;
  for (std::size_t k = 0; k < d.ids.size(); ++k) {
    BundleObservation b;
    b.pose = pose.data();
    b.point = nominal[d.ids[k]];
    b.u_px = d.points_px[k].x(), b.v_px = d.points_px[k].y();
    problem.AddResidualBlock(NewObservationCost(c, b), new ceres::HuberLoss(0.02 * cam.sensor.width_px),
                             params.data(), pose.data());
  }
  problem.SetParameterBlockConstant(params.data());
  ceres::Solver::Options so;
  so.logging_type = ceres::SILENT;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = 50;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  std::copy(pose.begin(), pose.begin() + 3, rotation->begin());
  std::copy(pose.begin() + 3, pose.end(), translation->begin());
}

// The start poses of every image for a start camera, and the RMS (px) of the observations
// reprojected through that camera from them. An image whose rays do not determine its pose
// (PoseFromRays), or with a point the camera cannot project from it (the adjustment could not
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
    std::vector<Eigen::Vector3d> points, rays;
    for (std::size_t k = 0; k < images[i]->ids.size(); ++k) {
      const auto ray = cam.Unproject(images[i]->points_px[k]);
      if (!ray) continue;
      points.push_back(nominal[images[i]->ids[k]]);
      rays.push_back(*ray);
    }
    if (!PoseFromRays(points, rays, &s->rotation[i], &s->translation[i])) continue;
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

// Adjustments that re-weight the control points' priors with σ0 until the weight settles, at most
// (per round of outlier rejection): a few suffice, the weight's fixed point moves little.
constexpr int kMaxPriorWeightRounds = 10;

template <typename M>
CalibrationResult CalibrateModel(std::vector<const ImageDetections*> used_images,
                                 const std::vector<Eigen::Vector3d>& nominal,
                                 const std::vector<Eigen::Vector3d>& normals,
                                 const std::map<int, Eigen::Vector3d>& field_control,
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
  // The observed points' shape: a planar field starts from homographies, a 3-D one from DLTs.
  const PlaneFit field = [&] {
    std::set<int> seen;
    for (const auto* d : used_images) seen.insert(d->ids.begin(), d->ids.end());
    std::vector<Eigen::Vector3d> pts;
    for (int id : seen) pts.push_back(nominal[id]);
    return FitPlane(pts);
  }();
  const bool planar_start = field.Planar() || options.planar_start;
  if (!field.Planar()) {
    say(fmt::format("a 3-D target field: points up to {:.1f} mm off their best plane ({:.1f} % of its extent){}",
                    field.off_plane_mm, 100 * field.off_plane_mm / field.extent_mm,
                    options.planar_start ? "; started as a planar one (Z ignored)" : ""));
  }
  // The points the start sees: Z ignored when a 3-D field is started as a planar one.
  std::vector<Eigen::Vector3d> start_points = nominal;
  if (options.planar_start) {
    for (auto& p : start_points) p.z() = 0;
  }
  camera::Camera start = camera::Camera::Ideal(id, sensor, 1.0);
  if (options.initial) {
    start.params = options.initial->params;
  }
  bool focal_free = false;
  for (int i = 0; i < info.num_focal; ++i) focal_free = focal_free || free_start[i];
  if (focal_free || !options.initial) {
    if (!M::kCaps.fisheye) {
      // Images whose points lie on one plane: Zhang on their homographies of the centred pixels
      // (one focal length, no distortion). Images that see a 3-D field off one plane: the DLT
      // camera matrix of the centred pixels, K from its RQ decomposition, f = sqrt(fx·fy); the
      // median over those images, which then decide alone.
      std::vector<Eigen::Matrix3d> hs;
      std::vector<double> dlt_f;
      const Eigen::Vector2d mid(0.5 * (sensor.width_px - 1), 0.5 * (sensor.height_px - 1));
      for (const auto* d : used_images) {
        std::vector<Eigen::Vector3d> src;
        std::vector<Eigen::Vector2d> dst;
        for (std::size_t k = 0; k < d->ids.size(); ++k) {
          src.push_back(start_points[d->ids[k]]);
          dst.push_back(d->points_px[k] - mid);
        }
        if (const auto plane = OnPlane(src)) {
          if (const auto h = FitHomography(plane->xy, dst)) hs.push_back(*h);
        } else if (const auto p = FitCameraMatrix(src, dst)) {
          const Eigen::Matrix3d k = RqCalibration(p->leftCols<3>());
          const double f = std::sqrt(k(0, 0) * k(1, 1));
          if (std::isfinite(f) && f > 0) dlt_f.push_back(f);
        }
      }
      if (!dlt_f.empty()) {
        std::nth_element(dlt_f.begin(), dlt_f.begin() + dlt_f.size() / 2, dlt_f.end());
        const double f = dlt_f[dlt_f.size() / 2];
        camera::SetFocalLengthPx(&start, f);
        say(fmt::format("start: DLT focal length {:.2f} px ({:.4f} mm; median of {} images of the 3-D field)",
                        f, f * sensor.pixel_pitch_mm, dlt_f.size()));
      } else {
        if (!planar_start && hs.empty()) {
          throw InvalidInput("images", "no image sees 6 points of the 3-D target field off one plane (nor 4 "
                                         "on one plane): the start cannot fix the focal length");
        }
        const auto f = ZhangPrincipalDistance(hs);
        camera::SetFocalLengthPx(&start, f ? *f : std::max(sensor.width_px, sensor.height_px));
        say(f ? fmt::format("start: Zhang focal length {:.2f} px ({:.4f} mm)", *f,
                            *f * sensor.pixel_pitch_mm)
              : "start: homographies do not fix the focal length (views too parallel?); using the "
                "image width");
      }
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
        const auto rms = StartPoses<M>(trial, used_images, start_points, &trial_state, false, &usable);
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
  // Poses by PnP of the start camera, refined with it fixed for a fisheye (approximate start
  // camera) and for a 3-D field (the DLT pose is not the least-squares one).
  const auto start_rms = StartPoses<M>(start, used_images, start_points, &s, M::kCaps.fisheye || !planar_start, &usable);
  if (!start_rms) {
    throw InvalidInput("images", "fewer than 3 images whose points fix their pose for the start "
                                   "camera (boards seen edge-on or along one line, or fewer than 6 "
                                   "points of a 3-D field?)");
  }
  res.start_focal_px = start.FocalLengthPx();
  res.start_rms_px = *start_rms;
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
  // The datum of a free target: the observed control points, or the minimal 7 coordinates.
  std::map<int, Eigen::Vector3d> control;
  for (const auto& [pid, sigma] : field_control) {
    if (used_points.count(pid)) control[pid] = sigma;
  }
  using DatumKind = CalibrationOptions::DatumKind;
  const bool control_datum = [&] {
    if (!options.target_free || options.datum == DatumKind::kMinimal) return false;
    std::vector<Eigen::Vector3d> at;
    for (const auto& [pid, sigma] : control) at.push_back(nominal[pid]);
    const bool enough = at.size() >= 3 && !FitPlane(at).OnALine();
    if (options.datum == DatumKind::kControl && !enough) {
      throw InvalidInput("datum", fmt::format("the control points' datum needs 3 or more observed control points "
                                              "off one line: {} observed", at.size()));
    }
    return enough;
  }();
  if (!control_datum) control.clear();
  int n_point_unknowns = 0, n_prior = 0;
  if (options.target_free) {
    n_point_unknowns = 3 * static_cast<int>(used_points.size()) - (control_datum ? 0 : 7);
    for (const auto& [pid, sigma] : control) {
      for (int k = 0; k < 3; ++k) {
        if (sigma(k) > 0) {
          ++n_prior;  // a prior: one more observation
        } else {
          --n_point_unknowns;  // held
        }
      }
    }
  }


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
      const auto [u, v] = coded::DotAxes(normals[ob.point]);  // the dot's plane
      const auto centre = coded::ImagedCircleCentre(project, x, u, v, dot_r);
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
  Adjustment<M> adj(options, &obs, &s, sensor, used_points, control);
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
  double prior_weight = 1.0;  // the weight the control points' priors were given (σ0, px)
  typename Adjustment<M>::CameraMatrix cov;
  res.sigma.assign(N, NAN);
  res.covariance = Eigen::MatrixXd::Zero(N, N);
  while (true) {
    int n_free_now = 0;
    for (bool f : free) n_free_now += f ? 1 : 0;
    res.n_unknowns = n_free_now + 6 * n_images + n_point_unknowns;
    double ss = 0, ss_priors = 0;
    int n_active = 0;
    // One adjustment of the active observations; returns σ0 (px). A control point's prior is
    // weighted as an image observation of σ0, which the adjustment changes: it is re-weighted with
    // the new σ0 and readjusted until the weight settles (within 0.1 %, at most
    // kMaxPriorWeightRounds adjustments). These rounds are apart from the outlier rejection's.
    const auto adjust = [&]() {
      double sigma0 = 0;
      for (int weighting = 1;; ++weighting) {
        solve(free);
        ss = 0;
        n_active = 0;
        for (const auto& ob : obs) {
          if (!ob.active) continue;
          const auto r = Residual<M>(s, ob, sensor);
          if (r) ss += r->squaredNorm();
          ++n_active;
        }
        // A control coordinate with a σ is one more observation, its prior residual one more square.
        ss_priors = adj.PriorSumSquares();
        res.redundancy = 2 * n_active + n_prior - res.n_unknowns;
        if (res.redundancy <= 0) {
          throw InvalidInput("images", fmt::format("{} points in {} images give {} observations "
                                                     "for {} unknowns: add images or fix "
                                                     "parameters (`free`)", n_active, n_images,
                                                     2 * n_active, res.n_unknowns));
        }
        sigma0 = std::sqrt((ss + ss_priors) / res.redundancy);
        if (n_prior == 0 || std::abs(sigma0 - prior_weight) <= 1e-3 * sigma0) break;
        if (weighting >= kMaxPriorWeightRounds) {
          say(fmt::format("the control points' prior weight did not settle in {} adjustments "
                          "(sigma0 {:.4f} px, weighted with {:.4f} px)", kMaxPriorWeightRounds,
                          sigma0, prior_weight));
          break;
        }
        adj.SetPriorWeight(prior_weight = sigma0);  // weighted with another σ0: again with this one
      }
      return sigma0;
    };
    // Outlier rejection: its own max_reject_rounds, each after a (re-weighted) adjustment.
    for (int reject_round = 0;; ++reject_round) {
      const double sigma0 = adjust();
      if (options.reject_k <= 0 || reject_round >= options.max_reject_rounds) break;
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
    res.sigma0_px = std::sqrt((ss + ss_priors) / res.redundancy);
    res.rms_px = std::sqrt(ss / n_active);
    res.n_points = n_active;
    if (!options.statistics) break;
    std::vector<Eigen::Vector3d> point_variance;
    res.covariance_ok = adj.Covariance(free, &cov, &point_variance);
    res.covariance = cov * (res.sigma0_px * res.sigma0_px);
    res.target_sigma_mm.clear();
    for (const auto& v : point_variance) res.target_sigma_mm.push_back(res.sigma0_px * v.cwiseSqrt());
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
  if (options.target_free) res.datum = adj.datum();
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
  const std::string poor = PoorFitStatus(res.rms_px, options.max_ok_rms_px);
  res.message = !poor.empty()          ? poor
                : !options.statistics ? "ok (statistics not computed)"
                : res.covariance_ok   ? "ok"
                                      : "the covariance is singular: some free parameters are not "
                                        "determined by these images (fix them with `free`)";
  if (!poor.empty()) say("warning: " + poor);
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  say(fmt::format("done: sigma0 {:.4f} px, RMS {:.4f} px, {} iterations, {:.3f} s", res.sigma0_px,
                  res.rms_px, res.iterations, res.seconds));
  return res;
}

}  // namespace

std::string PoorFitStatus(double rms_px, double max_ok_rms_px) {
  if (rms_px <= max_ok_rms_px) return "";
  return fmt::format("poor: RMS {:.3g} px is above {:g} px ({:g} times the detectors' noise of about {:g} px): the "
                     "model does not fit these detections (another target or camera, mixed sets, wrong or repeated "
                     "ids); its values and sigma are not to be trusted",
                     rms_px, max_ok_rms_px, max_ok_rms_px / kDetectorNoisePx, kDetectorNoisePx);
}

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

int KeepTargetPoints(const TargetSpec& target, std::vector<ImageDetections>* detections,
                     const std::function<void(const std::string&)>& progress) {
  if (target.kind != TargetKind::kCoded) return 0;
  const std::vector<bool> is_point = TargetPointMask(target);
  int dropped = 0;
  for (auto& d : *detections) {
    if (d.ids.size() != d.points_px.size()) continue;  // Calibrate refuses it
    std::size_t kept = 0;
    for (std::size_t k = 0; k < d.ids.size(); ++k) {
      const int id = d.ids[k];
      if (id < 0 || id >= static_cast<int>(is_point.size()) || !is_point[id]) continue;
      d.ids[kept] = d.ids[k];
      d.points_px[kept] = d.points_px[k];
      ++kept;
    }
    dropped += static_cast<int>(d.ids.size() - kept);
    d.ids.resize(kept);
    d.points_px.resize(kept);
  }
  if (dropped > 0 && progress) {
    progress(fmt::format("ignored {} detection(s) of IDs that are not in the {}", dropped,
                         target.field.empty() ? "target's sheet" : "field " + target.field_file));
  }
  return dropped;
}

void QuietCeresLogs() {
  // Ceres logs through glog on stderr (296 lines in one calibration: invalid steps, rank-deficient
  // covariances). Each solve is SILENT, and glog keeps only FATAL: what matters reaches the user
  // through porthole's own status and progress lines.
  static const bool once = [] {
    FLAGS_minloglevel = google::GLOG_FATAL;
    return true;
  }();
  (void)once;
}

CalibrationOptions::DatumKind ParseDatumKind(const std::string& text, const std::string& field) {
  using K = CalibrationOptions::DatumKind;
  if (text == "auto") return K::kAuto;
  if (text == "minimal") return K::kMinimal;
  if (text == "control") return K::kControl;
  throw InvalidInput(field, "'" + text.substr(0, 40) + "' is not one of auto, minimal, control");
}

CalibrationResult Calibrate(const std::vector<ImageDetections>& detections,
                            const TargetSpec& target, const CalibrationOptions& options) {
  QuietCeresLogs();
  const auto say = [&](const std::string& m) {
    if (options.progress) options.progress(m);
  };
  if (options.centre_correction == CalibrationOptions::CentreCorrection::kOn && target.kind != TargetKind::kCoded) {
    throw InvalidInput("centre_correction", "needs circular targets of known dot radius (coded:BITS:RADIUS_MM)");
  }
  RequirePositive("pixel_pitch_mm", options.pixel_pitch_mm);
  RequireNonNegative("reject_k", options.reject_k);
  RequirePositive("loss_scale_px", options.loss_scale_px);
  RequirePositive("significance_t", options.significance_t);
  if (options.drop_insignificant && !options.statistics) {
    throw InvalidInput("statistics", "stepwise dropping needs the statistics (σ of each parameter)");
  }
  const camera::ModelInfo& info = camera::Info(options.model);
  const FreeMask free = options.FreeOrDefault();
  if (static_cast<int>(free.size()) != info.num_params) {
    throw InvalidInput("free", fmt::format("{} flags for the {} parameters of model {}",
                                             free.size(), info.num_params, info.name));
  }
  if (options.initial && options.initial->model != options.model) {
    throw InvalidInput("initial", fmt::format("a {} camera cannot start a {} calibration",
                                                options.initial->model_name(), info.name));
  }
  for (int i = 0; i < info.first_distortion; ++i) {
    if (!free[i] && !options.initial) {
      throw InvalidInput("free", fmt::format("{} may be fixed only with a start camera "
                                               "(`initial`)", info.params[i].name));
    }
  }
  const std::vector<Eigen::Vector3d> nominal = TargetPoints(target);
  // The field's control points (id → σ, mm): the datum of a free target (CalibrationOptions::datum).
  const std::map<int, Eigen::Vector3d> control = FieldControl(target);
  if (options.datum == CalibrationOptions::DatumKind::kControl && !options.target_free) {
    throw InvalidInput("datum", "the control points are a datum of a free target (`target_free`)");
  }
  // Coded targets: IDs the sheet or field does not carry are no points (ignored, counted).
  std::vector<ImageDetections> kept_detections;
  const std::vector<ImageDetections>* dets = &detections;
  if (target.kind == TargetKind::kCoded) {
    kept_detections = detections;
    KeepTargetPoints(target, &kept_detections, options.progress);
    dets = &kept_detections;
  }

  // Images with at least 4 valid points; all of one size.
  std::vector<const ImageDetections*> used_images;
  for (const auto& d : *dets) {
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
      std::vector<Eigen::Vector3d> pts;
      for (int id : d.ids) pts.push_back(nominal[id]);
      if (FitPlane(pts).OnALine()) {
        say(fmt::format("skipped {}: its {} points lie nearly on one line of the target",
                        d.image, d.ids.size()));
        continue;
      }
    }
    if (!used_images.empty() && (d.width_px != used_images[0]->width_px ||
                                 d.height_px != used_images[0]->height_px)) {
      throw InvalidInput("images", fmt::format("{} is {}x{} px, {} is {}x{}: one camera, one "
                                                 "image size", d.image, d.width_px, d.height_px,
                                                 used_images[0]->image, used_images[0]->width_px,
                                                 used_images[0]->height_px));
    }
    used_images.push_back(&d);
  }
  if (used_images.size() < 3) {
    throw InvalidInput("images", fmt::format("{} image(s) with the target; at least 3 are needed "
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
    camera::ValidateCamera(initial, "initial");
  }
  return camera::VisitModel(options.model, [&](auto m) {
    return CalibrateModel<decltype(m)>(used_images, nominal, TargetNormals(target), control, options, free,
                                       std::move(res));
  });
}

}  // namespace porthole::calib
