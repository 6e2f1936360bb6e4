// Forward and backward projection through a port: the explicit refractive camera (a lens model of
// camera/models.h behind a dome or flat port), templated on the scalar so that the port's
// parameters, the point and the lens parameters can all be ceres::Jets in a bundle adjustment.
//
// Frames and units (docs/conventions.md, "Ports as parameters of a refractive camera"): everything
// here is in the cam frame (origin at the entrance pupil, axes of the housing frame: X right,
// Y down, Z toward the scene), mm. A port is split into
//  - its Shell: what a port file (scan, datasheet) fixes and the images do not estimate — a dome's
//    radii, the inner sphere's centre relative to the outer one, its rim; a flat port's glass
//    thickness; and the glass and water indices (relative to air);
//  - three PARAMETERS, what a calibration estimates (kPortNumParams, PortParamInfo):
//      dome: ep_in_dome_mm (x, y, z), the entrance pupil minus the outer sphere's centre;
//      flat: the inner face's unit normal n (toward the scene) as (n_x, n_y), n_z = sqrt(1 − n_x² −
//            n_y²) > 0, and distance_mm, the pupil-to-inner-face distance along n;
//      cylinder: the axis a = (sin φ, cos φ, 0) across the optical axis, φ = axis_angle_deg from +Y
//            toward +X, and the pupil minus the axis (ep_in_cylinder_x_mm along a × ẑ, which is +X
//            at φ = 0, and ep_in_cylinder_z_mm along Z); the pupil's place along the axis does not
//            matter (a cylinder is the same all along it).
//
// Forward projection (ForwardDirection): the direction from the pupil, in air, of the ray that
// the port bends through a given point in the water. The ray's path is traced exactly by the one
// surface step of optics/trace.h (optics::Step, on the port's surfaces in scalar T); the direction
// is found
//  - for an AXIAL system (a flat port; a dome whose pupil lies on the line through both centres),
//    by a safeguarded Newton iteration on one angle in the plane of refraction (the plane through
//    the axis and the point), the residual being the sine of the angle between the refracted ray
//    and the direction from its exit point to the point;
//  - otherwise (a non-concentric dome with the pupil off the line of centres: the paper's as-built
//    NI320; a cylinder), by a 2-D Newton iteration on the direction started from that in-plane
//    solution (a cylinder: from its far-field direction with the pupil on the axis), the residual
//    being the two components of (unit direction to the point − refracted ray direction) across
//    the ray.
// Jacobians of the iterations come from Jets through the trace (never finite differences). The
// iteration runs on values in double; when T is a Jet, one final Newton step in T carries the
// derivatives with respect to the port parameters and the point (implicit-function theorem), as
// camera::Distort does for the lens.
//
// Backward projection is the plain trace: a pixel's ray (the lens model's Unproject) traced out
// through the port (optics::TraceSequence on Interfaces(), or TraceOut here).
//
// Expected outcomes are std::nullopt, never exceptions: the point is not in the water beyond the
// port, the ray leaves the glass (beyond a dome's rim), or the iteration does not converge.
#pragma once

#include <ceres/jet.h>

#include <Eigen/Core>
#include <Eigen/LU>
#include <array>
#include <cmath>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "porthole/camera/scalar.h"
#include "porthole/camera/sensor.h"
#include "porthole/optics/trace.h"
#include "porthole/ports/port.h"

namespace porthole::refraction {

using optics::Vec3;
template <typename T>
using Vec3T = Eigen::Matrix<T, 3, 1>;
template <typename T>
using Vec2T = Eigen::Matrix<T, 2, 1>;

// The port shapes, one closed list: the alternatives of ports::PortSpec::shape (ports/port.h), a
// kind being its index there (refraction.cc asserts the order).
enum class PortKind { kDome, kFlat, kCylinder };
// "dome", "flat", "cylinder": the name the files and the tables use (the shape's kName).
std::string_view PortKindName(PortKind kind);
// The kind of a port spec's shape (its index in the list).
PortKind KindOf(const ports::PortSpec& spec);

// Calls f(std::type_identity<Shape>{}) for the shape of `kind` (its alternative of
// ports::PortShape) and returns what it returns: how the refractive camera reads a shape's own
// members (ports/port.h) without switching on the kind.
template <std::size_t I = 0, typename F>
decltype(auto) VisitKind(PortKind kind, F&& f) {
  using Shape = std::variant_alternative_t<I, ports::PortShape>;
  if constexpr (I + 1 == std::variant_size_v<ports::PortShape>) {
    return f(std::type_identity<Shape>{});
  } else {
    if (static_cast<std::size_t>(kind) == I) return f(std::type_identity<Shape>{});
    return VisitKind<I + 1>(kind, std::forward<F>(f));
  }
}

// The fixed part of a port (see the file comment), cam-frame axes, mm: the shape's shell values
// (ports::CamShell: dome and cylinder radii, a dome's inner centre from the outer one, the rim; a
// flat port's thickness) and the indices.
struct Shell : ports::CamShell {
  PortKind kind = PortKind::kDome;
  // Indices relative to air (inside the housing n = 1).
  double n_glass = 1.5168, n_water = 1.341;
};

inline constexpr int kPortNumParams = 3;

// Name (as --free-port and the tables say it), JSON key with its unit, unit.
using PortParamInfo = ports::ParamInfo;
// The three parameters' names of a port kind, in order (its shape's kPortParams).
const std::array<PortParamInfo, kPortNumParams>& PortParams(PortKind kind);
// What the three are, in words ("dome: entrance pupil minus outer centre"; kPortParamsMeaning).
std::string_view PortParamsMeaning(PortKind kind);
// A calibration's default σ of the predicted parameters (kDefaultPredictedSigma), and the search
// of its start along the optical axis (kAxialSearch).
const std::array<double, kPortNumParams>& PredictedSigmaOf(PortKind kind);
const ports::AxialSearch& AxialSearchOf(PortKind kind);

// ---- The shell's values as parameters ----
// What a calibration may adjust beside the three port parameters (kShellNumParams values, in this
// order; ShellParams(kind) names them), each fixed at the Shell's value unless adjusted:
//   0     water_index_factor: the water index is factor × Shell::n_water (1: the materials model);
//   1…    the shape's kShellParams (ports/port.h), each the Shell field its key names; the rest
//         unused (0): dome 1 outer_radius_mm, 2 inner_radius_mm, 3–5 inner_from_outer_{x,y,z}_mm
//         (cam axes); flat 1 thickness_mm; cylinder 1 outer_radius_mm, 2 inner_radius_mm.
inline constexpr int kShellNumParams = 6;
using ShellArray = std::array<double, kShellNumParams>;
const std::array<PortParamInfo, kShellNumParams>& ShellParams(PortKind kind);
// The Shell's own values (factor 1).
ShellArray ShellValues(const Shell& s);
// The Shell with the values `v` in place of its own (n_water scaled by v[0]).
Shell WithShellValues(const Shell& s, const ShellArray& v);
// Throws InvalidInput(field) unless `v` describes a shell: a positive water index factor; a dome's
// inner sphere inside the outer one (positive radii, |offset| < outer − inner radius); a flat
// port's positive thickness.
void ValidateShellValues(const Shell& s, const ShellArray& v, const std::string& field);

// A port's surfaces in the cam frame for parameters p (see the file comment), in scalar T
// (ports::CamSurfaces: each shape uses its own fields), with the kind of its shape.
template <typename T>
struct Geometry : ports::CamSurfaces<T> {
  PortKind kind = PortKind::kDome;
};

// The surfaces of shell `s` with parameters p: the shape's SurfacesAt<T> (ports/port.h), its shell
// values from `shell_values` (kShellNumParams, see above; the shape's after the water index
// factor) when given, else from `s`.
template <typename T>
Geometry<T> MakeGeometry(const Shell& s, const T* p, const T* shell_values = nullptr) {
  const T* v = shell_values;
  Geometry<T> g;
  g.kind = s.kind;
  g.n_glass = T(s.n_glass);
  g.n_water = v ? T(s.n_water) * v[0] : T(s.n_water);
  VisitKind(s.kind, [&](auto shape) {
    decltype(shape)::type::template SurfacesAt<T>(s, p, v ? v + 1 : nullptr, &g);
  });
  return g;
}

// The port's two surfaces in the cam frame, as the tracer takes them (inner then outer, air →
// glass → water), in scalar T: each shape's own ports::<Shape>Port::Interfaces<T> (ports/port.h,
// the one statement of a shape's surfaces, which ports::PortSystem::Outward also calls, in double
// in the housing frame) at the geometry's values (the shape's InterfacesAt<T>). The refractive
// projection and the backward trace (Interfaces below) trace them.
template <typename T>
ports::TwoInterfaces<T> InterfacesOf(const Geometry<T>& g) {
  return VisitKind(g.kind, [&](auto shape) { return decltype(shape)::type::template InterfacesAt<T>(g); });
}

// Traces the ray leaving the pupil (the cam-frame origin) along `dir` (any length) out through
// the port: on kOk, *origin is its exit point on the outer surface and *out_dir its unit
// direction in the water. optics::Step on InterfacesOf(g): the tracer of optics/trace.h.
template <typename T>
optics::RayStatus TraceOut(const Geometry<T>& g, const Vec3T<T>& dir, Vec3T<T>* origin,
                           Vec3T<T>* out_dir) {
  using optics::P3;
  P3<T> o{T(0), T(0), T(0)};
  P3<T> d = P3<T>::From(Vec3T<T>(dir.normalized()));
  for (const optics::InterfaceT<T>& f : InterfacesOf<T>(g)) {
    const optics::RayStatus st = optics::Step<T>(f, &o, &d);
    if (st != optics::RayStatus::kOk) return st;
  }
  *origin = o.ToEigen();
  *out_dir = d.ToEigen();
  return optics::RayStatus::kOk;
}

// True where `point_in_cam` lies in the water beyond the port's outer surface (values only).
bool InWater(const Geometry<double>& g, const Vec3& point_in_cam);

// How ForwardDirection solves: what the double-valued iteration found.
struct Solution {
  Vec3 dir = Vec3::UnitZ();  // unit direction from the pupil, cam frame
  // The Newton system at dir: the residual r(a, b) = (f1·(u − v), f2·(u − v)) for the direction
  // normalize(dir + a·e1 + b·e2), u the unit vector from the exit point to the point, v the ray in
  // the water; jac = ∂r/∂(a, b). has_jacobian is false when the 1-D iteration alone solved it.
  Vec3 e1 = Vec3::UnitX(), e2 = Vec3::UnitY(), f1 = Vec3::UnitX(), f2 = Vec3::UnitY();
  Eigen::Matrix2d jac = Eigen::Matrix2d::Identity();
  bool has_jacobian = false;
  bool axial = false;
  int iterations = 0;
};

// Solves for the direction in double (see the file comment); nullopt when the point is not in the
// water or the iteration fails. Exposed for the tests and the benchmark.
std::optional<Solution> SolveDirection(const Geometry<double>& g, const Vec3& point_in_cam);

// The residual r of Solution at dir + a·e1 + b·e2 (a = b = 0 when the caller wants it at dir), in
// scalar S; false when the ray does not get through the port.
template <typename S>
bool DirectionResidual(const Geometry<S>& g, const Vec3T<S>& point, const Vec3T<S>& dir,
                       const Vec3& f1, const Vec3& f2, Vec2T<S>* r, Vec3* v_value = nullptr) {
  Vec3T<S> o, v;
  if (TraceOut<S>(g, dir, &o, &v) != optics::RayStatus::kOk) return false;
  const Vec3T<S> w = point - o;
  const Vec3T<S> u = w / w.norm();
  const Vec3T<S> diff = u - v;
  (*r)(0) = diff.dot(f1.cast<S>());
  (*r)(1) = diff.dot(f2.cast<S>());
  if (v_value) *v_value = Vec3(camera::ScalarValue(v(0)), camera::ScalarValue(v(1)), camera::ScalarValue(v(2)));
  return true;
}

// The Newton system of Solution at s->dir (fills e1, e2, f1, f2, jac): one trace in Jet<2>.
bool FillJacobian(const Geometry<double>& g, const Vec3& point_in_cam, Solution* s);

// The unit direction (cam frame) from the pupil whose ray the port bends through `point_in_cam`
// (mm), for the port `shell` with parameters `port` (kPortNumParams values) and, when given, the
// shell's values `shell_values` (kShellNumParams, see ShellParams). With T a Jet the derivatives
// with respect to the port parameters, the shell values and the point are exact (the
// implicit-function step above). nullopt: see the file comment.
template <typename T>
std::optional<Vec3T<T>> ForwardDirection(const Shell& shell, const T* port,
                                         const Vec3T<T>& point_in_cam,
                                         const T* shell_values = nullptr) {
  using camera::ScalarValue;
  double pd[kPortNumParams], vd[kShellNumParams];
  for (int i = 0; i < kPortNumParams; ++i) pd[i] = ScalarValue(port[i]);
  if (shell_values) {
    for (int i = 0; i < kShellNumParams; ++i) vd[i] = ScalarValue(shell_values[i]);
  }
  const Geometry<double> gd = MakeGeometry<double>(shell, pd, shell_values ? vd : nullptr);
  const Vec3 xd(ScalarValue(point_in_cam(0)), ScalarValue(point_in_cam(1)),
                ScalarValue(point_in_cam(2)));
  auto sol = SolveDirection(gd, xd);
  if (!sol) return std::nullopt;
  if constexpr (std::is_same_v<T, double>) {
    return sol->dir;
  } else {
    if (!sol->has_jacobian && !FillJacobian(gd, xd, &*sol)) return std::nullopt;
    const Geometry<T> g = MakeGeometry<T>(shell, port, shell_values);
    Vec2T<T> r;
    if (!DirectionResidual<T>(g, point_in_cam, sol->dir.cast<T>(), sol->f1, sol->f2, &r)) {
      return std::nullopt;
    }
    const Eigen::Matrix2d ji = sol->jac.inverse();
    const T da = -(T(ji(0, 0)) * r(0) + T(ji(0, 1)) * r(1));
    const T db = -(T(ji(1, 0)) * r(0) + T(ji(1, 1)) * r(1));
    const Vec3T<T> d = sol->dir.cast<T>() + sol->e1.cast<T>() * da + sol->e2.cast<T>() * db;
    return Vec3T<T>(d / d.norm());
  }
}

// The pixel of `point_in_cam` (mm, in the water) seen by the camera model M (camera/models.h) with
// parameters `cam` behind the port (shell values as ForwardDirection): M::Project of the forward
// direction. nullopt where either fails.
template <typename M, typename T>
std::optional<Vec2T<T>> Project(const camera::Sensor& sensor, const T* cam, const Shell& shell,
                                const T* port, const Vec3T<T>& point_in_cam,
                                const T* shell_values = nullptr) {
  const auto d = ForwardDirection<T>(shell, port, point_in_cam, shell_values);
  if (!d) return std::nullopt;
  return M::template Project<T>(sensor, cam, *d);
}

// ---- A placed port (ports::PortSystem) as shell + parameters, and back ----

// The shell of a placed port (housing frame → cam-frame axes; the dome's rim default is its outer
// centre's plane, as ports::PortSystem::Outward).
Shell ShellOf(const ports::PortSystem& sys);
// Its parameters (ep − outer centre; n_x, n_y and the pupil-to-inner-face distance; a cylinder's
// pupil from the axis and the axis angle).
std::array<double, kPortNumParams> ParamsOf(const ports::PortSystem& sys);
// The port spec (housing frame, pupil at sys.ep_in_housing_mm) with the parameters `p` in place of
// the system's own: a dome's two spheres moved together so the pupil sits at `p` from the outer
// centre; a flat port's inner face with normal and distance `p`. Name, material, thickness and
// radii are kept. Throws InvalidInput when the result is not a valid port (ports::Validate).
ports::PortSpec SpecWithParams(const ports::PortSystem& sys,
                               const std::array<double, kPortNumParams>& p);
// The same with the shell's geometry values `v` (ShellParams: radii and inner-centre offset, or
// thickness) in place of the system's; the water index factor v[0] is not part of a port.
ports::PortSpec SpecWithParams(const ports::PortSystem& sys,
                               const std::array<double, kPortNumParams>& p, const ShellArray& v);
// The port of a refractive camera (its shell and three parameters) as a port spec in the cam
// frame, made of `material` (the glass whose dispersion a render's bands use): a dome's spheres at
// −p and −p + inner_from_outer with its rim plane; a flat port's inner face at distance p[2] along
// its normal; a cylinder's axis as MakeGeometry puts it. Traced from the pupil it is
// Interfaces(shell, p) (the shell's indices aside). Throws InvalidInput when it is no valid port.
ports::PortSpec PortSpecOf(const Shell& shell, const std::array<double, kPortNumParams>& p,
                           const std::string& material, const std::string& name);
// The interfaces met by a ray leaving the pupil, in the CAM frame (the optics tracer's input):
// the backward projection through optics::TraceSequence.
std::vector<optics::Interface> Interfaces(const Shell& shell, const double* port);

// Throws InvalidInput(field) unless the parameters describe a port the pupil sits in: a dome's
// pupil inside the inner sphere; a flat normal with n_x² + n_y² < 1
// and a positive distance; a cylinder's pupil inside the inner cylinder.
void ValidateParams(const Shell& shell, const double* port, const std::string& field);

}  // namespace porthole::refraction
