// Triangulation through the rig's ports with first-order σ (triangulate.h).
#include "porthole/measure/triangulate.h"

#include <ceres/jet.h>
#include <ceres/rotation.h>
#include <fmt/format.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <cmath>
#include <exception>
#include <thread>

#include "porthole/calib/compare.h"
#include "porthole/camera/models.h"
#include "porthole/core/error.h"

namespace porthole::measure {
namespace {

template <typename T>
using V3 = Eigen::Matrix<T, 3, 1>;

// The ray of pixel uv of a camera with parameters cam (model M), behind `shell` with parameters
// `port` (shell null: none), cam_from_rig `pose` (angle-axis, translation): origin and unit direction
// in the rig frame. false where it cannot be traced.
template <typename M, typename T>
bool RayT(const camera::Sensor& sensor, const T* cam, const refraction::Shell* shell, const T* port, const T* pose,
          const Eigen::Matrix<T, 2, 1>& uv, V3<T>* origin, V3<T>* dir) {
  const auto ray = M::template Unproject<T>(sensor, cam, uv);
  if (!ray) return false;
  V3<T> o = V3<T>::Zero(), d = *ray;
  if (shell != nullptr) {
    const refraction::Geometry<T> g = refraction::MakeGeometry<T>(*shell, port);
    V3<T> oo, dd;
    if (refraction::TraceOut<T>(g, d, &oo, &dd) != optics::RayStatus::kOk) return false;
    o = oo, d = dd;
  }
  // x_rig = Rᵀ·(x_cam − t): the rotation by −ω.
  const T w[3] = {-pose[0], -pose[1], -pose[2]};
  const T a[3] = {o(0) - pose[3], o(1) - pose[4], o(2) - pose[5]};
  const T b[3] = {d(0), d(1), d(2)};
  T ao[3], bo[3];
  ceres::AngleAxisRotatePoint(w, a, ao);
  ceres::AngleAxisRotatePoint(w, b, bo);
  *origin = V3<T>(ao[0], ao[1], ao[2]);
  *dir = V3<T>(bo[0], bo[1], bo[2]);
  return true;
}

// Value, and ∂/∂(u, v), of the ray of a pixel.
struct RayWithPixelJacobian {
  Eigen::Vector3d o, d;
  Eigen::Matrix<double, 3, 2> do_duv, dd_duv;
};

std::optional<RayWithPixelJacobian> PixelRay(const RigCamera& c, const Eigen::Vector2d& px) {
  return camera::VisitModel(c.camera.model, [&](auto m) -> std::optional<RayWithPixelJacobian> {
    using M = decltype(m);
    using J = ceres::Jet<double, 2>;
    constexpr int N = M::kNumParams;
    std::array<J, N> cam;
    for (int i = 0; i < N; ++i) cam[i] = J(c.camera.params[i]);
    std::array<J, refraction::kPortNumParams> port;
    for (int i = 0; i < refraction::kPortNumParams; ++i) port[i] = J(c.port[i]);
    const J pose[6] = {J(c.rotation_rad.x()),    J(c.rotation_rad.y()),    J(c.rotation_rad.z()),
                       J(c.translation_mm.x()), J(c.translation_mm.y()), J(c.translation_mm.z())};
    const Eigen::Matrix<J, 2, 1> uv(J(px.x(), 0), J(px.y(), 1));
    V3<J> o, d;
    if (!RayT<M, J>(c.camera.sensor, cam.data(), c.shell ? &*c.shell : nullptr, port.data(), pose, uv, &o, &d)) {
      return std::nullopt;
    }
    RayWithPixelJacobian r;
    for (int i = 0; i < 3; ++i) {
      r.o(i) = o(i).a, r.d(i) = d(i).a;
      r.do_duv.row(i) = o(i).v.transpose();
      r.dd_duv.row(i) = d(i).v.transpose();
    }
    return r;
  });
}

// ∂P/∂θ at range s of the ray of a pixel, θ the camera's parameters in the rig's joint order:
// a 3 × (rig parameters) matrix, columns of parameters the rig did not adjust zero.
void AddParamJacobian(const RigCamera& c, const Eigen::Vector2d& px, double s, const Eigen::Matrix3d& w,
                      Eigen::MatrixXd* g) {
  camera::VisitModel(c.camera.model, [&](auto m) {
    using M = decltype(m);
    constexpr int N = M::kNumParams;
    constexpr int P = refraction::kPortNumParams;
    constexpr int D = N + P + 6;
    using J = ceres::Jet<double, D>;
    std::array<J, N> cam;
    for (int i = 0; i < N; ++i) cam[i] = J(c.camera.params[i], i);
    std::array<J, P> port;
    for (int i = 0; i < P; ++i) port[i] = J(c.port[i], N + i);
    J pose[6];
    for (int i = 0; i < 3; ++i) pose[i] = J(c.rotation_rad(i), N + P + i), pose[3 + i] = J(c.translation_mm(i), N + P + 3 + i);
    const Eigen::Matrix<J, 2, 1> uv(J(px.x()), J(px.y()));
    V3<J> o, d;
    if (!RayT<M, J>(c.camera.sensor, cam.data(), c.shell ? &*c.shell : nullptr, port.data(), pose, uv, &o, &d)) {
      return;  // traced already in double: cannot happen
    }
    const auto column = [&](int j) {
      const Eigen::Vector3d dp(o(0).v(j) + s * d(0).v(j), o(1).v(j) + s * d(1).v(j), o(2).v(j) + s * d(2).v(j));
      return Eigen::Vector3d(w * dp);
    };
    for (int i = 0; i < N; ++i) {
      if (c.intrinsic_index[i] >= 0) g->col(c.intrinsic_index[i]) += column(i);
    }
    for (int i = 0; i < P; ++i) {
      if (c.port_index[i] >= 0) g->col(c.port_index[i]) += column(N + i);
    }
    for (int i = 0; i < 6; ++i) {
      if (c.pose_index[i] >= 0) g->col(c.pose_index[i]) += column(N + P + i);
    }
  });
}

}  // namespace

std::optional<Ray> BackwardRay(const RigCamera& c, const Eigen::Vector2d& pixel_px) {
  return camera::VisitModel(c.camera.model, [&](auto m) -> std::optional<Ray> {
    using M = decltype(m);
    const double pose[6] = {c.rotation_rad.x(),    c.rotation_rad.y(),    c.rotation_rad.z(),
                            c.translation_mm.x(), c.translation_mm.y(), c.translation_mm.z()};
    Ray r;
    if (!RayT<M, double>(c.camera.sensor, c.camera.params.data(), c.shell ? &*c.shell : nullptr, c.port.data(), pose,
                         pixel_px, &r.origin_mm, &r.direction)) {
      return std::nullopt;
    }
    return r;
  });
}

std::optional<Eigen::Vector2d> ProjectPoint(const RigCamera& c, const Eigen::Vector3d& x_rig_mm) {
  const Eigen::Vector3d p = c.CamFromRigRotation() * x_rig_mm + c.translation_mm;
  return camera::VisitModel(c.camera.model, [&](auto m) -> std::optional<Eigen::Vector2d> {
    using M = decltype(m);
    if (c.shell) {
      return refraction::Project<M, double>(c.camera.sensor, c.camera.params.data(), *c.shell, c.port.data(), p);
    }
    return M::template Project<double>(c.camera.sensor, c.camera.params.data(), p);
  });
}

bool InImage(const RigCamera& c, const Eigen::Vector2d& px) {
  const camera::Sensor& s = c.camera.sensor;
  return px.x() >= 0 && px.y() >= 0 && px.x() <= s.width_px - 1 && px.y() <= s.height_px - 1;
}

Point Triangulate(const Rig& rig, const std::vector<Observation>& obs, const TriangulateOptions& options) {
  if (!(options.sigma_px > 0) || !std::isfinite(options.sigma_px)) {
    throw InvalidInput("sigma_px", "must be a positive number of pixels");
  }
  Point p;
  const int n = static_cast<int>(obs.size());
  if (n < 2) {
    p.why = n == 1 ? fmt::format("seen by one camera only ({})", rig.cameras.at(obs[0].camera).name)
                   : "seen by no camera";
    return p;
  }
  std::vector<RayWithPixelJacobian> rays;
  for (const Observation& ob : obs) {
    if (ob.camera < 0 || ob.camera >= static_cast<int>(rig.cameras.size())) {
      throw InvalidInput("camera", fmt::format("{} is not a camera of the rig (0 … {})", ob.camera,
                                               rig.cameras.size() - 1));
    }
    const RigCamera& c = rig.cameras[ob.camera];
    const auto r = PixelRay(c, ob.pixel_px);
    if (!r) {
      p.why = fmt::format("{}: no ray through the lens and port at ({:.2f}, {:.2f}) px", c.name, ob.pixel_px.x(),
                          ob.pixel_px.y());
      return p;
    }
    rays.push_back(*r);
  }
  // Start: the point nearest all rays (unweighted).
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (const auto& r : rays) {
    const Eigen::Matrix3d q = Eigen::Matrix3d::Identity() - r.d * r.d.transpose();
    h += q;
    b += q * r.o;
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(h);
  if (!(es.eigenvalues()(0) > 1e-10 * es.eigenvalues()(2))) {
    p.why = "the rays are parallel: no intersection";
    return p;
  }
  Eigen::Vector3d x = h.ldlt().solve(b);
  std::vector<Eigen::Matrix<double, 2, 3>> jac(n);
  std::vector<double> s(n);
  Eigen::Matrix3d hinv;
  for (int iter = 0; iter < 3; ++iter) {
    h.setZero();
    b.setZero();
    for (int i = 0; i < n; ++i) {
      const auto& r = rays[i];
      s[i] = (x - r.o).dot(r.d);
      if (!(s[i] > 0)) {
        p.why = fmt::format("the rays meet behind {}", rig.cameras[obs[i].camera].name);
        return p;
      }
      Eigen::Matrix3d mm;
      mm.col(0) = r.do_duv.col(0) + s[i] * r.dd_duv.col(0);
      mm.col(1) = r.do_duv.col(1) + s[i] * r.dd_duv.col(1);
      mm.col(2) = r.d;
      jac[i] = mm.inverse().topRows<2>();
      const Eigen::Matrix3d jtj = jac[i].transpose() * jac[i];
      h += jtj;
      b += jtj * r.o;
    }
    hinv = h.inverse();
    x = hinv * b;
  }
  p.ok = true;
  p.x_mm = x;
  const double s2 = options.sigma_px * options.sigma_px;
  p.covariance_image_mm2 = s2 * hinv;
  p.covariance_mm2 = p.covariance_image_mm2;
  for (int i = 0; i < n; ++i) {
    const auto& r = rays[i];
    const Eigen::Vector2d res = jac[i] * (x - r.o);
    p.residual_px.push_back(res.norm());
    p.range_mm.push_back((x - r.o).dot(r.d));
    p.chi2 += res.squaredNorm() / s2;
    p.miss_mm = std::max(p.miss_mm, ((x - r.o) - (x - r.o).dot(r.d) * r.d).norm());
  }
  p.dof = 2 * n - 3;
  p.p_value = calib::UpperIncompleteGammaQ(0.5 * p.dof, 0.5 * p.chi2);
  p.mismatched = p.p_value < options.mismatch_p;
  if (options.calibration_sigma && rig.covariance.rows() > 0) {
    p.d_x_d_theta = Eigen::MatrixXd::Zero(3, rig.covariance.rows());
    for (int i = 0; i < n; ++i) {
      const Eigen::Matrix3d w = hinv * jac[i].transpose() * jac[i];
      AddParamJacobian(rig.cameras[obs[i].camera], obs[i].pixel_px, s[i], w, &p.d_x_d_theta);
    }
    p.covariance_mm2 += p.d_x_d_theta * rig.covariance * p.d_x_d_theta.transpose();
  }
  return p;
}

Point IntersectPlane(const Rig& rig, const Observation& obs, const Plane& plane, const TriangulateOptions& options) {
  if (!(options.sigma_px > 0) || !std::isfinite(options.sigma_px)) {
    throw InvalidInput("sigma_px", "must be a positive number of pixels");
  }
  if (std::abs(plane.normal.norm() - 1) > 1e-6 || !std::isfinite(plane.distance_mm) || !(plane.sigma_mm >= 0)) {
    throw InvalidInput("plane", "needs a unit normal, a finite distance and a sigma >= 0");
  }
  if (obs.camera < 0 || obs.camera >= static_cast<int>(rig.cameras.size())) {
    throw InvalidInput("camera", fmt::format("{} is not a camera of the rig", obs.camera));
  }
  const RigCamera& c = rig.cameras[obs.camera];
  Point p;
  const auto r = PixelRay(c, obs.pixel_px);
  if (!r) {
    p.why = fmt::format("{}: no ray through the lens and port at ({:.2f}, {:.2f}) px", c.name, obs.pixel_px.x(),
                        obs.pixel_px.y());
    return p;
  }
  // The plane in the rig frame: x_cam = R x_rig + t, so n·(R x + t) = d ⇔ (Rᵀn)·x = d − n·t.
  const Eigen::Matrix3d rot = c.CamFromRigRotation();
  const Eigen::Vector3d n = rot.transpose() * plane.normal;
  const double dist = plane.distance_mm - plane.normal.dot(c.translation_mm);
  const double nd = n.dot(r->d);
  if (std::abs(nd) < 1e-9) {
    p.why = fmt::format("{}: the ray runs along the plane", c.name);
    return p;
  }
  const double t = (dist - n.dot(r->o)) / nd;
  if (!(t > 0)) {
    p.why = fmt::format("{}: the plane is behind the ray (its exit from the port)", c.name);
    return p;
  }
  p.ok = true;
  p.x_mm = r->o + t * r->d;
  // dX = (I − d nᵀ/(n·d)) (do + t dd) for a change of the ray at fixed t; a change of the plane's
  // distance moves X along the ray by d/(n·d).
  const Eigen::Matrix3d proj = Eigen::Matrix3d::Identity() - r->d * n.transpose() / nd;
  const Eigen::Matrix<double, 3, 2> j = proj * (r->do_duv + t * r->dd_duv);
  p.covariance_image_mm2 = options.sigma_px * options.sigma_px * j * j.transpose();
  p.covariance_mm2 = p.covariance_image_mm2;
  p.residual_px = {0.0};
  p.range_mm = {t};
  p.dof = 0;
  const bool with_plane = plane.covariance_index >= 0 && plane.covariance_index < rig.covariance.rows();
  if ((options.calibration_sigma || with_plane) && rig.covariance.rows() > 0) {
    p.d_x_d_theta = Eigen::MatrixXd::Zero(3, rig.covariance.rows());
    if (options.calibration_sigma) AddParamJacobian(c, obs.pixel_px, t, proj, &p.d_x_d_theta);
    // A change of the plane's distance (its frame) moves X along the ray by d/(n·d).
    if (with_plane) p.d_x_d_theta.col(plane.covariance_index) += r->d / nd;
    p.covariance_mm2 += p.d_x_d_theta * rig.covariance * p.d_x_d_theta.transpose();
  }
  return p;
}

std::optional<LaserRange> RangeFromLaserPair(const RigCamera& c, const Eigen::Vector2d& dot_a_px,
                                             const Eigen::Vector2d& dot_b_px, double separation_mm, double sigma_px) {
  if (!(separation_mm > 0) || !std::isfinite(separation_mm)) {
    throw InvalidInput("laser_pair", "the separation must be > 0 mm");
  }
  return camera::VisitModel(c.camera.model, [&](auto m) -> std::optional<LaserRange> {
    using M = decltype(m);
    using J = ceres::Jet<double, 4>;  // d/d(u_a, v_a, u_b, v_b)
    constexpr int N = M::kNumParams;
    std::array<J, N> cam;
    for (int i = 0; i < N; ++i) cam[i] = J(c.camera.params[i]);
    std::array<J, refraction::kPortNumParams> port;
    for (int i = 0; i < refraction::kPortNumParams; ++i) port[i] = J(c.port[i]);
    const J pose[6] = {J(0), J(0), J(0), J(0), J(0), J(0)};  // the camera's own frame
    V3<J> oa, da, ob, db;
    const Eigen::Matrix<J, 2, 1> ua(J(dot_a_px.x(), 0), J(dot_a_px.y(), 1)), ub(J(dot_b_px.x(), 2), J(dot_b_px.y(), 3));
    const refraction::Shell* shell = c.shell ? &*c.shell : nullptr;
    if (!RayT<M, J>(c.camera.sensor, cam.data(), shell, port.data(), pose, ua, &oa, &da) ||
        !RayT<M, J>(c.camera.sensor, cam.data(), shell, port.data(), pose, ub, &ob, &db)) {
      return std::nullopt;
    }
    if (!(da(2).a > 0 && db(2).a > 0)) return std::nullopt;
    // X(Z) = o + ((Z − o_z)/d_z)·d: the dots' difference is a + Z·b.
    const V3<J> a = (ob - db * (ob(2) / db(2))) - (oa - da * (oa(2) / da(2)));
    const V3<J> b = db / db(2) - da / da(2);
    const J qa = b.dot(b), qb = J(2) * a.dot(b), qc = a.dot(a) - J(separation_mm * separation_mm);
    const J disc = qb * qb - J(4) * qa * qc;
    if (!(qa.a > 0) || !(disc.a >= 0)) return std::nullopt;
    using std::sqrt;
    const J z = (-qb + sqrt(disc)) / (J(2) * qa);
    if (!(z.a > 0) || !std::isfinite(z.a)) return std::nullopt;
    return LaserRange{z.a, sigma_px * z.v.norm()};
  });
}

std::vector<Point> TriangulateMany(const Rig& rig, const std::vector<std::vector<Observation>>& points,
                                   const TriangulateOptions& options, int num_threads) {
  const int n = static_cast<int>(points.size());
  std::vector<Point> out(n);
  int threads = num_threads > 0 ? num_threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  threads = std::min(threads, std::max(1, n / 256));  // small batches: one thread
  std::vector<std::exception_ptr> errors(threads);
  const auto work = [&](int t) {
    try {
      for (int i = t; i < n; i += threads) out[i] = Triangulate(rig, points[i], options);
    } catch (...) {
      errors[t] = std::current_exception();
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(work, t);
  work(0);
  for (auto& th : pool) th.join();
  for (const auto& e : errors) {
    if (e) std::rethrow_exception(e);
  }
  return out;
}

Length MeasureLength(const Rig& rig, const Point& a, const Point& b) {
  Length l;
  const Eigen::Vector3d v = b.x_mm - a.x_mm;
  l.length_mm = v.norm();
  if (!(l.length_mm > 0)) throw InvalidInput("points", "the two points coincide: no length direction");
  const Eigen::Vector3d e = v / l.length_mm;
  l.sigma_image_mm = std::sqrt(e.dot((a.covariance_image_mm2 + b.covariance_image_mm2) * e));
  double var_cal = 0;
  if (a.d_x_d_theta.size() > 0 && b.d_x_d_theta.size() > 0) {
    const Eigen::RowVectorXd g = e.transpose() * (b.d_x_d_theta - a.d_x_d_theta);
    var_cal = g * rig.covariance * g.transpose();
  }
  l.sigma_calibration_mm = std::sqrt(std::max(0.0, var_cal));
  l.sigma_mm = std::hypot(l.sigma_image_mm, l.sigma_calibration_mm);
  return l;
}

}  // namespace porthole::measure
