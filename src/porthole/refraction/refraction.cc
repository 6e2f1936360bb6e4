#include "porthole/refraction/refraction.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <utility>
#include <variant>

#include "porthole/core/error.h"

namespace porthole::refraction {
namespace {

using J1 = ceres::Jet<double, 1>;
using J2 = ceres::Jet<double, 2>;

// The Newton step (rad) below which an iteration is converged once the step is taken: Newton's
// error after it is of order C·step² (C ~ 100 for a fisheye behind a flat port: < 1e-14 rad).
constexpr double kFinalStep = 1e-8;

// A unit vector perpendicular to unit v, and the third completing a right-handed frame.
void Perpendiculars(const Vec3& v, Vec3* a, Vec3* b) {
  const Vec3 helper = std::abs(v.x()) < 0.6 ? Vec3::UnitX() : Vec3::UnitY();
  *a = v.cross(helper).normalized();
  *b = v.cross(*a);
}

template <typename S>
Geometry<S> CastGeometry(const Geometry<double>& g) {
  Geometry<S> c;
  c.kind = g.kind;
  c.outer_center = g.outer_center.cast<S>();
  c.inner_center = g.inner_center.cast<S>();
  c.outer_radius = S(g.outer_radius);
  c.inner_radius = S(g.inner_radius);
  c.rim_z = g.rim_z;
  c.normal = g.normal.cast<S>();
  c.axis_point = g.axis_point.cast<S>();
  c.distance = S(g.distance);
  c.thickness = S(g.thickness);
  c.n_glass = S(g.n_glass);
  c.n_water = S(g.n_water);
  return c;
}

// The axis of an axial system (unit, z ≥ 0), or nullopt when the system is not axial. *identity is
// set when the pupil sits at the common centre of a concentric dome (no ray is bent).
std::optional<Vec3> Axis(const Geometry<double>& g, bool* identity) {
  *identity = false;
  if (g.kind == PortKind::kFlat) return g.normal;
  const Vec3& co = g.outer_center;
  const Vec3& ci = g.inner_center;
  const double tol = 1e-12 * g.outer_radius;
  const double no = co.norm(), ni = ci.norm();
  if (no <= tol && ni <= tol) {
    *identity = true;
    return Vec3::UnitZ();
  }
  const Vec3 a = (no >= ni ? co / no : ci / ni);
  // Both centres on the line through the pupil along a.
  if ((co - co.dot(a) * a).norm() > tol || (ci - ci.dot(a) * a).norm() > tol) return std::nullopt;
  return a.z() < 0 ? Vec3(-a) : a;
}

// A cylinder's start: the direction whose ray would reach `x` far away with the pupil on the
// axis. There every ray meets both surfaces square across the axis, so only its slope along the
// axis bends, as through a flat port: sin(slope in air) = n_water sin(slope in water).
Vec3 CylinderStart(const Geometry<double>& g, const Vec3& x) {
  const Vec3& a = g.normal;
  const double along = x.dot(a);
  Vec3 across = x - along * a;
  const double rho = across.norm();
  if (rho <= 1e-14 * x.norm()) return x.normalized();
  across /= rho;
  const double slope = std::asin(std::clamp(g.n_water * along / x.norm(), -0.999, 0.999));
  return std::cos(slope) * across + std::sin(slope) * a;
}

// The approximate axis of a non-axial dome: from the pupil through the outer centre (or the
// inner one when the pupil sits at the outer centre), z ≥ 0.
Vec3 ApproximateAxis(const Geometry<double>& g) {
  const Vec3& co = g.outer_center;
  const Vec3 a = co.norm() > 1e-9 * g.outer_radius ? co.normalized() : g.inner_center.normalized();
  return a.z() < 0 ? Vec3(-a) : a;
}

// 1-D safeguarded Newton (Numerical Recipes' rtsafe idea): the angle θ ∈ (0, π) of the direction
// cos θ·a + sin θ·e in the plane through the axis a and the point, e the unit in-plane
// perpendicular toward the point. Residual F(θ) = ((u × v)·m), m = a × e: the sine of the angle
// from u (exit point → point) to v (ray in the water), increasing in θ, negative at θ = 0 (the ray
// along the axis leaves the point on its e side). Derivative by a Jet<1> through the trace.
// Returns θ, or nullopt without convergence; `tol` is the final Newton step (rad).
std::optional<double> SolveInPlane(const Geometry<J1>& g, const Vec3& x, const Vec3& a,
                                   const Vec3& e, double theta0, double tol, int* iterations) {
  const Vec3 m = a.cross(e);
  const Vec3T<J1> xj = x.cast<J1>();
  double lo = 0, hi = M_PI;  // F(lo) < 0; F(hi) > 0 or the trace fails there
  double th = std::clamp(theta0, 1e-9, M_PI - 1e-9);
  for (int it = 0; it < 100; ++it) {
    ++*iterations;
    const J1 t(th, 0);
    using std::cos;
    using std::sin;
    const Vec3T<J1> dir = a.cast<J1>() * cos(t) + e.cast<J1>() * sin(t);
    Vec3T<J1> o, v;
    double next;
    bool newton = false;
    if (TraceOut<J1>(g, dir, &o, &v) != optics::RayStatus::kOk) {
      hi = th;
      next = 0.5 * (lo + hi);
    } else {
      const Vec3T<J1> w = xj - o;
      const Vec3T<J1> u = w / w.norm();
      const J1 f = u.cross(v).dot(m.cast<J1>());
      if (f.a == 0) return th;
      (f.a < 0 ? lo : hi) = th;
      next = th - f.a / f.v(0);
      newton = f.v(0) > 0 && next > lo && next < hi;
      if (!newton) next = 0.5 * (lo + hi);
    }
    const double step = std::abs(next - th);
    th = next;
    if (newton && step <= tol) return th;
    if (hi - lo <= 1e-15) return th;
  }
  return std::nullopt;
}

// One Newton iteration's system at direction s->dir: residual and Jacobian by a Jet<2> trace.
bool NewtonSystem(const Geometry<J2>& g, const Vec3& x, Solution* s, Eigen::Vector2d* r) {
  Perpendiculars(s->dir, &s->e1, &s->e2);
  const Vec3T<J2> dir =
      s->dir.cast<J2>() + s->e1.cast<J2>() * J2(0, 0) + s->e2.cast<J2>() * J2(0, 1);
  // The residual frame follows the ray in the water: trace once for its value.
  Vec3T<J2> o, v;
  if (TraceOut<J2>(g, dir, &o, &v) != optics::RayStatus::kOk) return false;
  const Vec3 vv(v(0).a, v(1).a, v(2).a);
  Perpendiculars(vv, &s->f1, &s->f2);
  const Vec3T<J2> w = x.cast<J2>() - o;
  const Vec3T<J2> diff = w / w.norm() - v;
  const J2 r0 = diff.dot(s->f1.cast<J2>()), r1 = diff.dot(s->f2.cast<J2>());
  *r = Eigen::Vector2d(r0.a, r1.a);
  s->jac << r0.v(0), r0.v(1), r1.v(0), r1.v(1);
  s->has_jacobian = true;
  return true;
}

// A kind is the index of its shape in ports::PortSpec::shape.
using Shapes = decltype(ports::PortSpec::shape);
template <PortKind K>
using ShapeOf = std::variant_alternative_t<static_cast<std::size_t>(K), Shapes>;
static_assert(std::is_same_v<ShapeOf<PortKind::kDome>, ports::DomePort> &&
              std::is_same_v<ShapeOf<PortKind::kFlat>, ports::FlatPort> &&
              std::is_same_v<ShapeOf<PortKind::kCylinder>, ports::CylinderPort> &&
              std::variant_size_v<Shapes> == 3);

// {f(type_identity<Shape>)...} over the list, in its order: a table indexed by PortKind.
template <typename F>
constexpr auto PerShape(F f) {
  return [&]<std::size_t... I>(std::index_sequence<I...>) {
    return std::array{f(std::type_identity<std::variant_alternative_t<I, Shapes>>{})...};
  }(std::make_index_sequence<std::variant_size_v<Shapes>>());
}

// f(type_identity<Shape>) for the shape of `kind`.
template <typename F>
void WithShape(PortKind kind, F&& f) {
  [&]<std::size_t... I>(std::index_sequence<I...>) {
    ((static_cast<std::size_t>(kind) == I ? f(std::type_identity<std::variant_alternative_t<I, Shapes>>{}) : void()),
     ...);
  }(std::make_index_sequence<std::variant_size_v<Shapes>>());
}

// The Shell's field a shell value's key names (ports::…Port::kShellParams): the Shell's own
// vocabulary, which every shape's values map onto.
double& ShellField(Shell& s, std::string_view key) {
  if (key == "outer_radius_mm") return s.outer_radius_mm;
  if (key == "inner_radius_mm") return s.inner_radius_mm;
  if (key == "inner_from_outer_x_mm") return s.inner_from_outer_mm.x();
  if (key == "inner_from_outer_y_mm") return s.inner_from_outer_mm.y();
  if (key == "inner_from_outer_z_mm") return s.inner_from_outer_mm.z();
  if (key == "thickness_mm") return s.thickness_mm;
  throw InternalError(fmt::format("no Shell field for the shell value '{}'", key));
}

}  // namespace

std::string_view PortKindName(PortKind kind) {
  static constexpr auto kNames = []<std::size_t... I>(std::index_sequence<I...>) {
    return std::array<std::string_view, sizeof...(I)>{std::variant_alternative_t<I, Shapes>::kName...};
  }(std::make_index_sequence<std::variant_size_v<Shapes>>());
  const auto i = static_cast<std::size_t>(kind);
  return i < kNames.size() ? kNames[i] : "unknown";
}

PortKind KindOf(const ports::PortSpec& spec) { return static_cast<PortKind>(spec.shape.index()); }

const std::array<PortParamInfo, kPortNumParams>& PortParams(PortKind kind) {
  static constexpr auto kAll = PerShape([](auto s) { return decltype(s)::type::kPortParams; });
  return kAll[static_cast<std::size_t>(kind)];
}

std::string_view PortParamsMeaning(PortKind kind) {
  static constexpr auto kAll = PerShape([](auto s) { return decltype(s)::type::kPortParamsMeaning; });
  return kAll[static_cast<std::size_t>(kind)];
}

const std::array<double, kPortNumParams>& PredictedSigmaOf(PortKind kind) {
  static constexpr auto kAll = PerShape([](auto s) { return decltype(s)::type::kDefaultPredictedSigma; });
  return kAll[static_cast<std::size_t>(kind)];
}

const ports::AxialSearch& AxialSearchOf(PortKind kind) {
  static constexpr auto kAll = PerShape([](auto s) { return decltype(s)::type::kAxialSearch; });
  return kAll[static_cast<std::size_t>(kind)];
}

const std::array<PortParamInfo, kShellNumParams>& ShellParams(PortKind kind) {
  // The water index factor, then the shape's own values, then unused ("").
  static constexpr auto kAll = PerShape([](auto s) {
    using S = typename decltype(s)::type;
    static_assert(S::kShellParams.size() < kShellNumParams);
    std::array<PortParamInfo, kShellNumParams> a{};
    a[0] = {"n_water", "water_index_factor", "1"};
    for (std::size_t i = 0; i < S::kShellParams.size(); ++i) a[i + 1] = S::kShellParams[i];
    return a;
  });
  return kAll[static_cast<std::size_t>(kind)];
}

ShellArray ShellValues(const Shell& s) {
  ShellArray v{1.0, 0, 0, 0, 0, 0};
  Shell& m = const_cast<Shell&>(s);  // read only
  const auto& info = ShellParams(s.kind);
  for (int i = 1; i < kShellNumParams && !info[i].json_key.empty(); ++i) v[i] = ShellField(m, info[i].json_key);
  return v;
}

Shell WithShellValues(const Shell& s, const ShellArray& v) {
  Shell out = s;
  out.n_water = s.n_water * v[0];
  const auto& info = ShellParams(s.kind);
  for (int i = 1; i < kShellNumParams && !info[i].json_key.empty(); ++i) ShellField(out, info[i].json_key) = v[i];
  return out;
}

void ValidateShellValues(const Shell& s, const ShellArray& v, const std::string& field) {
  for (double x : v) {
    if (!std::isfinite(x)) throw InvalidInput(field, "shell values must be finite numbers");
  }
  if (!(v[0] > 0) || !(s.n_water * v[0] >= 1)) {
    throw InvalidInput(field, fmt::format("the water index factor {:.6g} gives a water index {:.6g} "
                                          "below 1", v[0], s.n_water * v[0]));
  }
  WithShape(s.kind, [&](auto shape) { decltype(shape)::type::ValidateShellValues(v.data() + 1, field); });
}

bool InWater(const Geometry<double>& g, const Vec3& x) {
  if (g.kind == PortKind::kDome) {
    return (x - g.outer_center).norm() > g.outer_radius && x.z() > g.rim_z;
  }
  if (g.kind == PortKind::kCylinder) {
    const Vec3 q = x - g.axis_point;
    return (q - q.dot(g.normal) * g.normal).norm() > g.outer_radius && x.z() > g.rim_z;
  }
  return x.dot(g.normal) > g.distance + g.thickness;
}

bool FillJacobian(const Geometry<double>& g, const Vec3& x, Solution* s) {
  Eigen::Vector2d r;
  return NewtonSystem(CastGeometry<J2>(g), x, s, &r);
}

std::optional<Solution> SolveDirection(const Geometry<double>& g, const Vec3& x) {
  if (!x.allFinite() || !InWater(g, x)) return std::nullopt;
  Solution s;
  bool identity = false;
  // A cylinder has no axis of symmetry through the pupil: the 2-D iteration from its start.
  const std::optional<Vec3> axis =
      g.kind == PortKind::kCylinder ? std::nullopt : Axis(g, &identity);
  s.axial = axis.has_value();
  if (identity) {
    s.dir = x.normalized();
    return s;
  }
  if (g.kind == PortKind::kCylinder) {
    s.dir = CylinderStart(g, x);
    // A start whose ray misses the glass (beyond the rim, for a point seen close to it) is turned
    // toward +Z until its ray gets through; Newton's backtracking then walks to the solution.
    Vec3 o, v;
    for (int k = 0; k < 20 && TraceOut<double>(g, s.dir, &o, &v) != optics::RayStatus::kOk; ++k) {
      s.dir = (s.dir + 0.1 * Vec3::UnitZ()).normalized();
    }
  } else if (const Vec3 a = axis ? *axis : ApproximateAxis(g);
             (x - x.dot(a) * a).norm() <= 1e-14 * x.norm()) {
    // On the axis: an axial system sends the axial ray straight through it.
    s.dir = x.dot(a) >= 0 ? a : Vec3(-a);
    if (axis) return s;
  } else {
    Vec3 e = x - x.dot(a) * a;
    const double rho = e.norm();
    e /= rho;
    // Start: the direction to the point, steepened by the water index for a flat port (its far
    // field: sin θ_air = n_w sin θ_water).
    double th0 = std::atan2(rho, x.dot(a));
    if (g.kind == PortKind::kFlat) th0 = std::asin(std::min(0.999, g.n_water * std::sin(th0)));
    const auto th = SolveInPlane(CastGeometry<J1>(g), x, a, e, th0, axis ? kFinalStep : 1e-3,
                                 &s.iterations);
    if (!th) return std::nullopt;
    s.dir = std::cos(*th) * a + std::sin(*th) * e;
    if (axis) return s;
  }
  // 2-D Newton from the in-plane solution (a cylinder: its start), backtracking where a step
  // leaves the port.
  const Geometry<J2> gj = CastGeometry<J2>(g);
  Eigen::Vector2d r;
  if (!NewtonSystem(gj, x, &s, &r)) return std::nullopt;
  for (int it = 0; it < 50; ++it) {
    ++s.iterations;
    const Eigen::Vector2d step = -s.jac.partialPivLu().solve(r);
    if (!step.allFinite()) return std::nullopt;
    if (step.norm() <= kFinalStep) {
      // Quadratic convergence: after this step the error is of order C·|step|². The
      // Jacobian at the final direction is left to FillJacobian (Jets only).
      s.dir = (s.dir + step(0) * s.e1 + step(1) * s.e2).normalized();
      s.has_jacobian = false;
      return s;
    }
    Solution next = s;
    double scale = 1;
    bool ok = false;
    for (int k = 0; k < 30; ++k) {
      next.dir = (s.dir + scale * (step(0) * s.e1 + step(1) * s.e2)).normalized();
      ok = NewtonSystem(gj, x, &next, &r);
      if (ok) break;
      scale *= 0.5;
    }
    if (!ok) return std::nullopt;
    s = next;
  }
  return std::nullopt;
}

Shell ShellOf(const ports::PortSystem& sys) {
  Shell s;
  s.n_glass = sys.n_glass;
  s.n_water = sys.n_water;
  s.kind = KindOf(sys.spec);
  std::visit([&](const auto& shape) {
    using S = std::decay_t<decltype(shape)>;
    const auto values = shape.ShellValues();
    for (std::size_t i = 0; i < values.size(); ++i) ShellField(s, S::kShellParams[i].json_key) = values[i];
    s.rim_from_outer_z_mm = shape.RimAboveReference();
  }, sys.spec.shape);
  return s;
}

std::array<double, kPortNumParams> ParamsOf(const ports::PortSystem& sys) {
  return std::visit([&](const auto& shape) { return shape.PortParams(sys.ep_in_housing_mm); }, sys.spec.shape);
}

ports::PortSpec SpecWithParams(const ports::PortSystem& sys,
                               const std::array<double, kPortNumParams>& p) {
  return SpecWithParams(sys, p, ShellValues(ShellOf(sys)));
}

ports::PortSpec SpecWithParams(const ports::PortSystem& sys,
                               const std::array<double, kPortNumParams>& p, const ShellArray& v) {
  ports::PortSpec spec = sys.spec;
  spec.frame = ports::PortFrame::kHousing;
  spec.default_ep_in_housing_mm = sys.ep_in_housing_mm;
  const Shell shell = ShellOf(sys);
  const Geometry<double> g = MakeGeometry<double>(shell, p.data(), v.data());
  const Vec3& ep = sys.ep_in_housing_mm;
  if (auto* d = std::get_if<ports::DomePort>(&spec.shape)) {
    d->outer.center_mm = ep + g.outer_center;
    d->inner.center_mm = ep + g.inner_center;
    d->outer.radius_mm = g.outer_radius;
    d->inner.radius_mm = g.inner_radius;
    if (d->rim_z_mm) *d->rim_z_mm = ep.z() + g.rim_z;
  } else if (auto* c = std::get_if<ports::CylinderPort>(&spec.shape)) {
    c->axis = g.normal;
    c->axis_point_mm = ep + g.axis_point;
    c->outer_radius_mm = g.outer_radius;
    c->inner_radius_mm = g.inner_radius;
    if (c->rim_z_mm) *c->rim_z_mm = ep.z() + g.rim_z;
  } else {
    auto& f = std::get<ports::FlatPort>(spec.shape);
    f.normal = g.normal;
    f.inner_point_mm = ep + g.distance * g.normal;
    f.thickness_mm = g.thickness;
  }
  ports::Validate(spec);
  return spec;
}

ports::PortSpec PortSpecOf(const Shell& shell, const std::array<double, kPortNumParams>& p, const std::string& material,
                           const std::string& name) {
  const Geometry<double> g = MakeGeometry<double>(shell, p.data());
  ports::PortSpec spec;
  spec.name = name;
  spec.description = "a calibrated port (shell and parameters), relative to the pupil";
  spec.frame = ports::PortFrame::kCam;
  if (shell.kind == PortKind::kDome) {
    ports::DomePort d;
    d.outer = {g.outer_center, g.outer_radius};
    d.inner = {g.inner_center, g.inner_radius};
    d.material = material;
    d.rim_z_mm = g.rim_z;
    spec.shape = d;
  } else if (shell.kind == PortKind::kCylinder) {
    ports::CylinderPort c;
    c.axis = g.normal;
    c.axis_point_mm = g.axis_point;
    c.inner_radius_mm = g.inner_radius;
    c.outer_radius_mm = g.outer_radius;
    c.material = material;
    c.rim_z_mm = g.rim_z;
    spec.shape = c;
  } else {
    ports::FlatPort f;
    f.normal = g.normal;
    f.inner_point_mm = g.distance * g.normal;
    f.thickness_mm = g.thickness;
    f.material = material;
    spec.shape = f;
  }
  ports::Validate(spec, "port");
  return spec;
}

std::vector<optics::Interface> Interfaces(const Shell& shell, const double* port) {
  const auto f = InterfacesOf<double>(MakeGeometry<double>(shell, port));
  return {f.begin(), f.end()};
}

void ValidateParams(const Shell& shell, const double* p, const std::string& field) {
  for (int i = 0; i < kPortNumParams; ++i) {
    if (!std::isfinite(p[i])) throw InvalidInput(field, "port parameters must be finite numbers");
  }
  if (shell.kind == PortKind::kDome) {
    const Geometry<double> g = MakeGeometry<double>(shell, p);
    if (g.inner_center.norm() >= g.inner_radius) {
      throw InvalidInput(field, fmt::format("the entrance pupil ({:.2f}, {:.2f}, {:.2f}) mm from "
                                            "the dome centre is not inside the inner sphere",
                                            p[0], p[1], p[2]));
    }
  } else if (shell.kind == PortKind::kCylinder) {
    if (std::hypot(p[0], p[1]) >= shell.inner_radius_mm) {
      throw InvalidInput(field, fmt::format("the entrance pupil ({:.2f}, {:.2f}) mm from the cylinder's "
                                            "axis is not inside the inner cylinder (radius {:.4g} mm)",
                                            p[0], p[1], shell.inner_radius_mm));
    }
  } else {
    if (!(p[0] * p[0] + p[1] * p[1] < 1)) {
      throw InvalidInput(field, "the flat port's normal must point toward the scene (n_x² + n_y² < 1)");
    }
    if (!(p[2] > 0)) throw InvalidInput(field, "the flat port must lie ahead of the pupil (distance > 0)");
  }
}

}  // namespace porthole::refraction
