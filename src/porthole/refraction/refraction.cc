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
  VisitKind(s.kind, [&](auto shape) {
    const auto own = decltype(shape)::type::ShellValues(s);
    std::copy(own.begin(), own.end(), v.begin() + 1);
  });
  return v;
}

Shell WithShellValues(const Shell& s, const ShellArray& v) {
  Shell out = s;
  out.n_water = s.n_water * v[0];
  VisitKind(s.kind, [&](auto shape) { decltype(shape)::type::SetShellValues(v.data() + 1, &out); });
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
  VisitKind(s.kind, [&](auto shape) { decltype(shape)::type::ValidateShellValues(v.data() + 1, field); });
}

bool InWater(const Geometry<double>& g, const Vec3& x) {
  return VisitKind(g.kind, [&](auto shape) { return decltype(shape)::type::InWater(g, x); });
}

bool FillJacobian(const Geometry<double>& g, const Vec3& x, Solution* s) {
  Eigen::Vector2d r;
  return NewtonSystem(CastGeometry<J2>(g), x, s, &r);
}

std::optional<Solution> SolveDirection(const Geometry<double>& g, const Vec3& x) {
  if (!x.allFinite() || !InWater(g, x)) return std::nullopt;
  Solution s;
  // The shape's axis of symmetry through the pupil (an axial system), else its start: a direction
  // for the 2-D iteration (a cylinder), or an approximate axis for a first 1-D solve in the plane
  // through it (a non-axial dome). ports/port.h: AxisThroughPupil, StartDirection, ApproximateAxis,
  // InPlaneStart.
  bool identity = false;
  std::optional<Vec3> axis, start;
  Vec3 approximate_axis = Vec3::UnitZ();
  VisitKind(g.kind, [&](auto shape) {
    using S = typename decltype(shape)::type;
    axis = S::AxisThroughPupil(g, &identity);
    if (!axis && !identity) {
      start = S::StartDirection(g, x);
      if (!start) approximate_axis = S::ApproximateAxis(g);
    }
  });
  s.axial = axis.has_value();
  if (identity) {
    s.dir = x.normalized();
    return s;
  }
  if (start) {
    s.dir = *start;
    // A start whose ray misses the glass (beyond the rim, for a point seen close to it) is turned
    // toward +Z until its ray gets through; Newton's backtracking then walks to the solution.
    Vec3 o, v;
    for (int k = 0; k < 20 && TraceOut<double>(g, s.dir, &o, &v) != optics::RayStatus::kOk; ++k) {
      s.dir = (s.dir + 0.1 * Vec3::UnitZ()).normalized();
    }
  } else if (const Vec3 a = axis ? *axis : approximate_axis;
             (x - x.dot(a) * a).norm() <= 1e-14 * x.norm()) {
    // On the axis: an axial system sends the axial ray straight through it.
    s.dir = x.dot(a) >= 0 ? a : Vec3(-a);
    if (axis) return s;
  } else {
    Vec3 e = x - x.dot(a) * a;
    const double rho = e.norm();
    e /= rho;
    // Start: the direction to the point, as the shape would have it (a flat port steepens it by
    // the water index).
    const double th0 =
        VisitKind(g.kind, [&](auto shape) { return decltype(shape)::type::InPlaneStart(g, std::atan2(rho, x.dot(a))); });
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
  static_cast<ports::CamShell&>(s) = std::visit([](const auto& shape) { return shape.AsShell(); }, sys.spec.shape);
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
  const Geometry<double> g = MakeGeometry<double>(ShellOf(sys), p.data(), v.data());
  // The shape at the new surfaces, moved to the housing frame; its material kept, and a rim only
  // where it had one.
  std::visit([&](auto& shape) {
    using S = std::decay_t<decltype(shape)>;
    S moved = S::AtSurfaces(g);
    moved.material = shape.material;
    moved.Translate(sys.ep_in_housing_mm);
    if constexpr (requires { shape.rim_z_mm; }) {
      if (!shape.rim_z_mm) moved.rim_z_mm.reset();
    }
    shape = std::move(moved);
  }, spec.shape);
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
  VisitKind(shell.kind, [&](auto shape) {
    auto s = decltype(shape)::type::AtSurfaces(g);
    s.material = material;
    spec.shape = std::move(s);
  });
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
  VisitKind(shell.kind, [&](auto shape) { decltype(shape)::type::ValidateParams(shell, p, field); });
}

}  // namespace porthole::refraction
