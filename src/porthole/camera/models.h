// The closed list of camera models (docs/camera-model.md, "The camera models"; docs/architecture.md,
// "Add a camera model"). Each model is one struct with:
//   kId, kName, kDescription        its identity (kName is what files, JSON and --model use)
//   kNumParams, kParams             number, names, JSON keys (with units) and units of its parameters
//   kNumFocal, kFirstDistortion     the parameter layout every model shares: the focal length(s)
//                                   first, then the principal point, then distortion from
//                                   kFirstDistortion on
//   kCaps                           capabilities as data (fisheye, central, analytic Jacobian, …)
//   Project<T>(sensor, params, point_in_cam)  → pixel, std::nullopt outside the valid field
//   Unproject<T>(sensor, params, pixel)       → unit ray in the camera frame, std::nullopt outside
//   Ideal(f_px, sensor)             parameters of the undistorted camera of focal length f_px with
//                                   the principal point at the image centre (a calibration start)
//   FocalLengthPx, PrincipalPointPx read back from parameters (for starts and reports)
// and one entry in CameraModelList below. Everything above camera/ (calibration, simulation,
// interop, the report) is written against the list, never against one model.
//
// Conventions (docs/conventions.md): the camera frame has X right, Y down, Z forward (mm); pixels
// have (0, 0) at the centre of the top-left pixel, u right, v down. Project and Unproject are
// templates over the scalar so that double and ceres::Jet run through the same code; where a model
// must iterate (inverting a polynomial), the iteration runs on the values in double and one final
// Newton step in T carries the derivatives (implicit-function theorem), as camera::Distort does.
#pragma once

#include <ceres/jet.h>

#include <Eigen/Core>
#include <Eigen/LU>
#include <array>
#include <cmath>
#include <optional>
#include <string_view>
#include <tuple>
#include <vector>

#include "porthole/camera/brown.h"
#include "porthole/camera/projection.h"
#include "porthole/camera/scalar.h"
#include "porthole/camera/sensor.h"

namespace porthole::camera {

enum class CameraModelId : int {
  kBrown = 0,
  kOpenCV,
  kKannalaBrandt,
  kEquidistant,
  kEquisolid,
  kStereographic,
  kOrthographic,
};

// Capabilities as data (mrcal's lens-model metadata).
struct ModelCaps {
  bool fisheye = false;            // maps rays at or beyond 90° off axis (not rectilinear)
  bool central = true;             // every ray passes through one point (the entrance pupil)
  bool analytic_jacobian = false;  // calibration has hand-written Jacobians (calib/residual.h)
  bool image_mm = false;           // parameters in image mm (photogrammetric), else pixels
  bool correction_form = false;    // distortion corrects measured points (Brown), else distorts
                                   // ideal ones (forward, OpenCV/mrcal/COLMAP sense)
};

namespace detail {

// Ray in the camera frame for a point at distortion-free normalised radius direction: the unit
// vector at angle θ from +Z in the azimuth of (mx, my). (mx, my) need not be normalised; at the
// axis (|m| = 0) the ray is +Z.
template <typename T>
Vec3<T> RayAtAngle(const T& theta, const T& mx, const T& my) {
  using std::cos;
  using std::sin;
  using std::sqrt;
  const T m2 = mx * mx + my * my;
  if (!(ScalarValue(m2) > 1e-300)) return Vec3<T>(mx, my, T(1)).normalized();
  const T m = sqrt(m2);
  const T s = sin(theta) / m;
  return Vec3<T>(s * mx, s * my, cos(theta));
}

// Solves f(x) = target for x ≥ 0 by safeguarded Newton in double, starting at x0; f must be
// increasing on [0, x_max). Returns nullopt without convergence to |step| ≤ 1e-15·(1 + |x|).
template <typename F, typename DF>
std::optional<double> SolveIncreasing(F f, DF df, double target, double x0, double x_max) {
  double x = x0;
  for (int it = 0; it < 100; ++it) {
    const double d = df(x);
    if (!(d > 0)) return std::nullopt;
    double step = (f(x) - target) / d;
    double next = x - step;
    if (next < 0) next = 0.5 * x;
    if (next >= x_max) next = 0.5 * (x + x_max);
    step = x - next;
    x = next;
    if (std::abs(step) <= 1e-15 * (1 + std::abs(x))) return x;
  }
  return std::nullopt;
}

}  // namespace detail

// ---------------------------------------------------------------------------------------------
// Brown–Conrady, the photogrammetric correction form of camera/brown.h (the paper's model).
struct BrownModel {
  static constexpr CameraModelId kId = CameraModelId::kBrown;
  static constexpr std::string_view kName = "brown";
  static constexpr std::string_view kDescription =
      "Brown-Conrady, photogrammetric correction form (c, x0, y0 in image mm; K1-K3, P1, P2, B1, B2)";
  static constexpr int kNumParams = kBrownNumParams;
  static constexpr int kNumFocal = 1;          // c
  static constexpr int kFirstDistortion = 3;   // K1 (x0, y0 are the principal point)
  static constexpr const std::array<ParamInfo, kNumParams>& kParams = kBrownParamInfo;
  static constexpr ModelCaps kCaps{.fisheye = false, .central = true, .analytic_jacobian = true,
                                   .image_mm = true, .correction_form = true};

  template <typename T>
  static std::optional<Vec2<T>> Project(const Sensor& s, const T* p, const Vec3<T>& point_in_cam) {
    const auto xy = camera::Project<T>(p, point_in_cam);
    if (!xy) return std::nullopt;
    return ImageMmToPixel<T>(s, (*xy)(0), (*xy)(1));
  }
  template <typename T>
  static std::optional<Vec3<T>> Unproject(const Sensor& s, const T* p, const Vec2<T>& uv) {
    const Vec2<T> xy = PixelToImageMm<T>(s, uv(0), uv(1));
    return camera::Unproject<T>(p, xy(0), xy(1));
  }
  static std::vector<double> Ideal(double f_px, const Sensor& s) {
    std::vector<double> p(kNumParams, 0.0);
    p[kBrownC] = f_px * s.pixel_pitch_mm;
    return p;
  }
  static double FocalLengthPx(const double* p, const Sensor& s) {
    return p[kBrownC] / s.pixel_pitch_mm;
  }
  static Eigen::Vector2d PrincipalPointPx(const double* p, const Sensor& s) {
    return ImageMmToPixel<double>(s, p[kBrownX0], p[kBrownY0]);
  }
};

// ---------------------------------------------------------------------------------------------
// OpenCV's pinhole with rational radial and tangential distortion (cv::projectPoints with
// k1 k2 p1 p2 k3 k4 k5 k6; COLMAP's FULL_OPENCV, and OPENCV with k3…k6 = 0). Forward, in pixels,
// on normalised coordinates x = X/Z, y = Y/Z, r² = x² + y²:
//   x_d = x·(1 + k1 r² + k2 r⁴ + k3 r⁶)/(1 + k4 r² + k5 r⁴ + k6 r⁶) + 2 p1 x y + p2 (r² + 2x²)
//   y_d = y·(…)/(…) + p1 (r² + 2y²) + 2 p2 x y,      u = fx x_d + cx,  v = fy y_d + cy.
struct OpenCVModel {
  static constexpr CameraModelId kId = CameraModelId::kOpenCV;
  static constexpr std::string_view kName = "opencv";
  static constexpr std::string_view kDescription =
      "OpenCV pinhole, rational radial k1-k6 and tangential p1, p2, in pixels (forward)";
  static constexpr int kNumParams = 12;
  static constexpr int kNumFocal = 2;          // fx, fy
  static constexpr int kFirstDistortion = 4;   // k1
  enum : int { kFx = 0, kFy, kCx, kCy, kK1, kK2, kP1, kP2, kK3, kK4, kK5, kK6 };
  static constexpr std::array<ParamInfo, kNumParams> kParams = {{
      {"fx", "fx_px", "px"}, {"fy", "fy_px", "px"}, {"cx", "cx_px", "px"}, {"cy", "cy_px", "px"},
      {"k1", "k1", "1"}, {"k2", "k2", "1"}, {"p1", "p1", "1"}, {"p2", "p2", "1"},
      {"k3", "k3", "1"}, {"k4", "k4", "1"}, {"k5", "k5", "1"}, {"k6", "k6", "1"},
  }};
  static constexpr ModelCaps kCaps{};

  // (x, y) → (x_d, y_d), normalised; nullopt where the rational denominator is not positive.
  template <typename T>
  static std::optional<Vec2<T>> DistortNormalized(const T* p, const T& x, const T& y) {
    const T r2 = x * x + y * y;
    const T num = T(1) + r2 * (p[kK1] + r2 * (p[kK2] + r2 * p[kK3]));
    const T den = T(1) + r2 * (p[kK4] + r2 * (p[kK5] + r2 * p[kK6]));
    if (!(ScalarValue(den) > 0)) return std::nullopt;
    const T radial = num / den;
    const T xy = x * y;
    return Vec2<T>(x * radial + T(2) * p[kP1] * xy + p[kP2] * (r2 + T(2) * x * x),
                   y * radial + p[kP1] * (r2 + T(2) * y * y) + T(2) * p[kP2] * xy);
  }

  template <typename T>
  static std::optional<Vec2<T>> Project(const Sensor&, const T* p, const Vec3<T>& point_in_cam) {
    if (!(ScalarValue(point_in_cam(2)) > 0)) return std::nullopt;
    const auto d =
        DistortNormalized(p, point_in_cam(0) / point_in_cam(2), point_in_cam(1) / point_in_cam(2));
    if (!d) return std::nullopt;
    return Vec2<T>(p[kFx] * (*d)(0) + p[kCx], p[kFy] * (*d)(1) + p[kCy]);
  }

  // Newton on the 2×2 system DistortNormalized(x) = m in double (Jacobian by a Jet), then one step
  // in T. nullopt without convergence or where the map folds (det ≤ 0).
  template <typename T>
  static std::optional<Vec3<T>> Unproject(const Sensor&, const T* p, const Vec2<T>& uv) {
    const Vec2<T> m((uv(0) - p[kCx]) / p[kFx], (uv(1) - p[kCy]) / p[kFy]);
    using J = ceres::Jet<double, 2>;
    std::array<J, kNumParams> pj;
    for (int i = 0; i < kNumParams; ++i) pj[i] = J(ScalarValue(p[i]));
    const Eigen::Vector2d md(ScalarValue(m(0)), ScalarValue(m(1)));
    Eigen::Vector2d x = md;
    Eigen::Matrix2d jac;
    bool converged = false;
    for (int it = 0; it < 100 && !converged; ++it) {
      const auto d = DistortNormalized<J>(pj.data(), J(x(0), 0), J(x(1), 1));
      if (!d) return std::nullopt;
      jac << (*d)(0).v(0), (*d)(0).v(1), (*d)(1).v(0), (*d)(1).v(1);
      const double det = jac.determinant();
      if (!(det > 0)) return std::nullopt;
      const Eigen::Vector2d step = jac.inverse() * (Eigen::Vector2d((*d)(0).a, (*d)(1).a) - md);
      x -= step;
      if (!x.allFinite()) return std::nullopt;
      converged = step.norm() <= 1e-15 * (1 + x.norm());
    }
    if (!converged) return std::nullopt;
    // The last Newton step in T: value unchanged, derivatives by the implicit-function theorem.
    const auto dt = DistortNormalized<T>(p, T(x(0)), T(x(1)));
    if (!dt) return std::nullopt;
    const Eigen::Matrix2d ji = jac.inverse();
    const Vec2<T> f = *dt - m;
    const T xn = T(x(0)) - (T(ji(0, 0)) * f(0) + T(ji(0, 1)) * f(1));
    const T yn = T(x(1)) - (T(ji(1, 0)) * f(0) + T(ji(1, 1)) * f(1));
    return Vec3<T>(xn, yn, T(1)).normalized();
  }

  static std::vector<double> Ideal(double f_px, const Sensor& s) {
    std::vector<double> p(kNumParams, 0.0);
    p[kFx] = p[kFy] = f_px;
    p[kCx] = 0.5 * (s.width_px - 1);
    p[kCy] = 0.5 * (s.height_px - 1);
    return p;
  }
  static double FocalLengthPx(const double* p, const Sensor&) { return 0.5 * (p[kFx] + p[kFy]); }
  static Eigen::Vector2d PrincipalPointPx(const double* p, const Sensor&) {
    return {p[kCx], p[kCy]};
  }
};

// ---------------------------------------------------------------------------------------------
// Kannala–Brandt, as OpenCV's fisheye module (cv::fisheye) and COLMAP's OPENCV_FISHEYE: the
// equidistant angle θ = atan2(√(X² + Y²), Z) distorted as θd = θ(1 + k1θ² + k2θ⁴ + k3θ⁶ + k4θ⁸),
// (x_d, y_d) = θd·(X, Y)/√(X² + Y²), u = fx x_d + cx, v = fy y_d + cy. Valid while θd increases
// with θ and θ < 180°.
struct KannalaBrandtModel {
  static constexpr CameraModelId kId = CameraModelId::kKannalaBrandt;
  static constexpr std::string_view kName = "kannala-brandt";
  static constexpr std::string_view kDescription =
      "Kannala-Brandt fisheye (OpenCV fisheye, COLMAP OPENCV_FISHEYE): k1-k4 on the equidistant "
      "angle, in pixels";
  static constexpr int kNumParams = 8;
  static constexpr int kNumFocal = 2;          // fx, fy
  static constexpr int kFirstDistortion = 4;   // k1
  enum : int { kFx = 0, kFy, kCx, kCy, kK1, kK2, kK3, kK4 };
  static constexpr std::array<ParamInfo, kNumParams> kParams = {{
      {"fx", "fx_px", "px"}, {"fy", "fy_px", "px"}, {"cx", "cx_px", "px"}, {"cy", "cy_px", "px"},
      {"k1", "k1", "1"}, {"k2", "k2", "1"}, {"k3", "k3", "1"}, {"k4", "k4", "1"},
  }};
  static constexpr ModelCaps kCaps{.fisheye = true};

  template <typename T>
  static T ThetaD(const T* p, const T& th) {
    const T t2 = th * th;
    return th * (T(1) + t2 * (p[kK1] + t2 * (p[kK2] + t2 * (p[kK3] + t2 * p[kK4]))));
  }
  template <typename T>
  static T ThetaDDerivative(const T* p, const T& th) {
    const T t2 = th * th;
    return T(1) + t2 * (T(3) * p[kK1] + t2 * (T(5) * p[kK2] + t2 * (T(7) * p[kK3] + T(9) * t2 * p[kK4])));
  }

  template <typename T>
  static std::optional<Vec2<T>> Project(const Sensor&, const T* p, const Vec3<T>& point_in_cam) {
    using std::atan2;
    using std::sqrt;
    const T& X = point_in_cam(0);
    const T& Y = point_in_cam(1);
    const T& Z = point_in_cam(2);
    const T r2 = X * X + Y * Y;
    T scale;  // θd / r
    if (ScalarValue(r2) > 1e-18 * ScalarValue(Z * Z)) {
      const T r = sqrt(r2);
      const T th = atan2(r, Z);
      if (!(ScalarValue(ThetaDDerivative(p, th)) > 0)) return std::nullopt;
      scale = ThetaD(p, th) / r;
    } else {
      if (!(ScalarValue(Z) > 0)) return std::nullopt;
      scale = T(1) / Z;  // the limit of θd/r on the axis
    }
    return Vec2<T>(p[kFx] * scale * X + p[kCx], p[kFy] * scale * Y + p[kCy]);
  }

  template <typename T>
  static std::optional<Vec3<T>> Unproject(const Sensor&, const T* p, const Vec2<T>& uv) {
    using std::sqrt;
    const T mx = (uv(0) - p[kCx]) / p[kFx];
    const T my = (uv(1) - p[kCy]) / p[kFy];
    const T m2 = mx * mx + my * my;
    if (!(ScalarValue(m2) > 1e-300)) return Vec3<T>(mx, my, T(1)).normalized();
    const T thd = sqrt(m2);
    std::array<double, kNumParams> pd;
    for (int i = 0; i < kNumParams; ++i) pd[i] = ScalarValue(p[i]);
    const auto th = detail::SolveIncreasing([&](double t) { return ThetaD(pd.data(), t); },
                                            [&](double t) { return ThetaDDerivative(pd.data(), t); },
                                            ScalarValue(thd), ScalarValue(thd), M_PI);
    if (!th) return std::nullopt;
    const T tht = T(*th) - (ThetaD(p, T(*th)) - thd) / T(ThetaDDerivative(pd.data(), *th));
    return detail::RayAtAngle(tht, mx, my);
  }

  static std::vector<double> Ideal(double f_px, const Sensor& s) {
    std::vector<double> p(kNumParams, 0.0);
    p[kFx] = p[kFy] = f_px;
    p[kCx] = 0.5 * (s.width_px - 1);
    p[kCy] = 0.5 * (s.height_px - 1);
    return p;
  }
  static double FocalLengthPx(const double* p, const Sensor&) { return 0.5 * (p[kFx] + p[kFy]); }
  static Eigen::Vector2d PrincipalPointPx(const double* p, const Sensor&) {
    return {p[kCx], p[kCy]};
  }
};

// ---------------------------------------------------------------------------------------------
// The ideal fisheye projections of camera/projection.h with a radial correction polynomial, one
// focal length f (square pixels), in pixels: with ρ = g(θ) the projection's radius per unit focal
// length, ρd = ρ(1 + k1ρ² + k2ρ⁴), (u, v) = f·ρd·(X, Y)/√(X² + Y²) + (cx, cy). Valid while ρd
// increases with θ and θ is inside the projection's field (projection.h). For planning these are
// the lens types lensfun records; with k1 = k2 = 0 they are the textbook projections.
template <Projection kProjection>
struct IdealFisheyeModel {
  static constexpr int kNumParams = 5;
  static constexpr int kNumFocal = 1;          // f
  static constexpr int kFirstDistortion = 3;   // k1
  enum : int { kF = 0, kCx, kCy, kK1, kK2 };
  static constexpr std::array<ParamInfo, kNumParams> kParams = {{
      {"f", "f_px", "px"}, {"cx", "cx_px", "px"}, {"cy", "cy_px", "px"},
      {"k1", "k1", "1"}, {"k2", "k2", "1"},
  }};
  static constexpr ModelCaps kCaps{.fisheye = true};

  template <typename T>
  static T RhoD(const T* p, const T& rho) {
    const T r2 = rho * rho;
    return rho * (T(1) + r2 * (p[kK1] + r2 * p[kK2]));
  }
  template <typename T>
  static T RhoDDerivative(const T* p, const T& rho) {
    const T r2 = rho * rho;
    return T(1) + r2 * (T(3) * p[kK1] + T(5) * r2 * p[kK2]);
  }

  template <typename T>
  static std::optional<Vec2<T>> Project(const Sensor&, const T* p, const Vec3<T>& point_in_cam) {
    using std::atan2;
    using std::sqrt;
    const T& X = point_in_cam(0);
    const T& Y = point_in_cam(1);
    const T& Z = point_in_cam(2);
    const T r2 = X * X + Y * Y;
    T scale;  // f·ρd / r
    if (ScalarValue(r2) > 1e-18 * ScalarValue(Z * Z)) {
      const T r = sqrt(r2);
      const T th = atan2(r, Z);
      if (!(ScalarValue(th) < MaxFieldAngleRad(kProjection))) return std::nullopt;
      const T rho = ProjectionRadius(kProjection, th);
      if (!(ScalarValue(RhoDDerivative(p, rho)) > 0)) return std::nullopt;
      scale = p[kF] * RhoD(p, rho) / r;
    } else {
      if (!(ScalarValue(Z) > 0)) return std::nullopt;
      scale = p[kF] / Z;  // g(θ) ≈ θ ≈ r/Z on the axis for every projection
    }
    return Vec2<T>(scale * X + p[kCx], scale * Y + p[kCy]);
  }

  template <typename T>
  static std::optional<Vec3<T>> Unproject(const Sensor&, const T* p, const Vec2<T>& uv) {
    using std::sqrt;
    const T mx = (uv(0) - p[kCx]) / p[kF];
    const T my = (uv(1) - p[kCy]) / p[kF];
    const T m2 = mx * mx + my * my;
    if (!(ScalarValue(m2) > 1e-300)) return Vec3<T>(mx, my, T(1)).normalized();
    const T rhod = sqrt(m2);
    std::array<double, kNumParams> pd;
    for (int i = 0; i < kNumParams; ++i) pd[i] = ScalarValue(p[i]);
    const double rho_max = ProjectionRadius(kProjection, MaxFieldAngleRad(kProjection) * (1 - 1e-12));
    const auto rho = detail::SolveIncreasing([&](double r) { return RhoD(pd.data(), r); },
                                             [&](double r) { return RhoDDerivative(pd.data(), r); },
                                             ScalarValue(rhod), std::min(ScalarValue(rhod), rho_max),
                                             rho_max);
    if (!rho) return std::nullopt;
    const T rhot = T(*rho) - (RhoD(p, T(*rho)) - rhod) / T(RhoDDerivative(pd.data(), *rho));
    const auto th = ProjectionAngle(kProjection, rhot);
    if (!th) return std::nullopt;
    return detail::RayAtAngle(*th, mx, my);
  }

  static std::vector<double> Ideal(double f_px, const Sensor& s) {
    std::vector<double> p(kNumParams, 0.0);
    p[kF] = f_px;
    p[kCx] = 0.5 * (s.width_px - 1);
    p[kCy] = 0.5 * (s.height_px - 1);
    return p;
  }
  static double FocalLengthPx(const double* p, const Sensor&) { return p[kF]; }
  static Eigen::Vector2d PrincipalPointPx(const double* p, const Sensor&) {
    return {p[kCx], p[kCy]};
  }
};

struct EquidistantModel : IdealFisheyeModel<Projection::kEquidistant> {
  static constexpr CameraModelId kId = CameraModelId::kEquidistant;
  static constexpr std::string_view kName = "equidistant";
  static constexpr std::string_view kDescription =
      "ideal equidistant fisheye r = f theta, radial k1, k2 on r/f, in pixels";
};
struct EquisolidModel : IdealFisheyeModel<Projection::kEquisolid> {
  static constexpr CameraModelId kId = CameraModelId::kEquisolid;
  static constexpr std::string_view kName = "equisolid";
  static constexpr std::string_view kDescription =
      "ideal equisolid-angle fisheye r = 2f sin(theta/2), radial k1, k2, in pixels";
};
struct StereographicModel : IdealFisheyeModel<Projection::kStereographic> {
  static constexpr CameraModelId kId = CameraModelId::kStereographic;
  static constexpr std::string_view kName = "stereographic";
  static constexpr std::string_view kDescription =
      "ideal stereographic fisheye r = 2f tan(theta/2), radial k1, k2, in pixels";
};
struct OrthographicModel : IdealFisheyeModel<Projection::kOrthographic> {
  static constexpr CameraModelId kId = CameraModelId::kOrthographic;
  static constexpr std::string_view kName = "orthographic";
  static constexpr std::string_view kDescription =
      "ideal orthographic fisheye r = f sin(theta), radial k1, k2, in pixels (field < 180 deg)";
};

// ---------------------------------------------------------------------------------------------
// THE list. Adding a model: its struct above, one entry here, one line in camera/models_test.cc.
using CameraModelList = std::tuple<BrownModel, OpenCVModel, KannalaBrandtModel, EquidistantModel,
                                   EquisolidModel, StereographicModel, OrthographicModel>;

inline constexpr int kMaxModelParams = 12;  // the largest kNumParams in the list (checked below)

namespace detail {
template <typename F, typename... M>
auto VisitIn(CameraModelId id, F&& f, std::tuple<M...>*) {
  using R = decltype(f(std::tuple_element_t<0, std::tuple<M...>>{}));
  if constexpr (std::is_void_v<R>) {
    const bool found = ((id == M::kId ? (f(M{}), true) : false) || ...);
    if (!found) throw InternalError("camera model id " + std::to_string(int(id)) + " not in the list");
  } else {
    std::optional<R> out;
    const bool found = ((id == M::kId ? (out.emplace(f(M{})), true) : false) || ...);
    if (!found) throw InternalError("camera model id " + std::to_string(int(id)) + " not in the list");
    return R(std::move(*out));
  }
}
template <typename... M>
constexpr int MaxParams(std::tuple<M...>*) {
  return std::max({M::kNumParams...});
}
}  // namespace detail

static_assert(detail::MaxParams(static_cast<CameraModelList*>(nullptr)) == kMaxModelParams);

// Calls f(Model{}) for the model with this id (f is a generic lambda; Model::… gives the statics).
template <typename F>
auto VisitModel(CameraModelId id, F&& f) {
  return detail::VisitIn(id, std::forward<F>(f), static_cast<CameraModelList*>(nullptr));
}

// Calls f(Model{}) for every model in list order.
template <typename F>
void ForEachModel(F&& f) {
  std::apply([&](auto... m) { (f(m), ...); }, CameraModelList{});
}

}  // namespace porthole::camera
