#include "porthole/ports/port.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <utility>

#include "porthole/core/error.h"

namespace porthole::ports {
namespace {

void RequireFiniteVec(const std::string& field, const Vec3& v) {
  if (!v.allFinite()) throw InvalidInput(field, "must be three finite numbers");
}

// Where the line {p0 + s ẑ} meets a sphere on its +Z side; nullopt when it misses.
std::optional<double> FrontZ(const SphereSpec& s, const Vec3& p0) {
  const double rho2 = (p0.head<2>() - s.center_mm.head<2>()).squaredNorm();
  const double h2 = s.radius_mm * s.radius_mm - rho2;
  if (h2 < 0) return std::nullopt;
  return s.center_mm.z() + std::sqrt(h2);
}

// Distance from `p` to the line through `c` along unit `a`.
double FromAxis(const Vec3& p, const Vec3& c, const Vec3& a) {
  const Vec3 q = p - c;
  return (q - q.dot(a) * a).norm();
}

}  // namespace

// ---- Dome ----

void DomePort::Validate(const std::string& where) const {
  RequireFiniteVec(where + ".outer.center_mm", outer.center_mm);
  RequireFiniteVec(where + ".inner.center_mm", inner.center_mm);
  RequirePositive(where + ".outer.radius_mm", outer.radius_mm);
  RequirePositive(where + ".inner.radius_mm", inner.radius_mm);
  if (inner.radius_mm >= outer.radius_mm) {
    throw InvalidInput(where + ".inner.radius_mm", "must be smaller than outer.radius_mm (" +
                                                       std::to_string(outer.radius_mm) + ")");
  }
  const double gap = outer.radius_mm - inner.radius_mm;
  if ((outer.center_mm - inner.center_mm).norm() >= gap) {
    throw InvalidInput(where + ".inner.center_mm",
                       "the inner sphere must lie inside the outer one (centre distance below "
                       "the radius difference)");
  }
  if (rim_z_mm) RequireFinite(where + ".rim_z_mm", *rim_z_mm);
}

void DomePort::Translate(const Vec3& by) {
  outer.center_mm += by;
  inner.center_mm += by;
  if (rim_z_mm) *rim_z_mm += by.z();
}

void DomePort::RequirePupilInside(const Vec3& ep) const {
  if ((ep - inner.center_mm).norm() >= inner.radius_mm) {
    throw InvalidInput("entrance_pupil_mm", "the entrance pupil must lie inside the dome's inner sphere");
  }
}

TwoInterfaces<double> DomePort::Outward(double n_glass, double n_water) const {
  return Interfaces<double>(inner.center_mm, inner.radius_mm, outer.center_mm, outer.radius_mm,
                            rim_z_mm.value_or(outer.center_mm.z()), n_glass, n_water);
}

bool DomePort::InsideOuterSurface(const Vec3& p) const { return (p - outer.center_mm).norm() < outer.radius_mm; }

double DomePort::VertexZ(const Vec3& ep, bool of_outer) const {
  const auto z = FrontZ(of_outer ? outer : inner, ep);
  PORTHOLE_CHECK(z.has_value());  // Place() put the pupil inside the inner sphere
  return *z;
}

bool DomePort::CentralAt(const Vec3& ep, double tol_mm) const {
  return (outer.center_mm - ep).norm() <= tol_mm && (inner.center_mm - ep).norm() <= tol_mm;
}

PortSection DomePort::Section() const {
  return {{outer.center_mm, outer.radius_mm}, {inner.center_mm, inner.radius_mm}, rim_z_mm};
}

// Both centres on the axis through the pupil (parallel to housing +Z).
bool DomePort::RevolvesAbout(const Vec3& ep) const {
  constexpr double kTol = 1e-12;
  return (outer.center_mm - ep).head<2>().norm() <= kTol * outer.radius_mm &&
         (inner.center_mm - ep).head<2>().norm() <= kTol * inner.radius_mm;
}

CamShell DomePort::AsShell() const {
  CamShell s;
  s.outer_radius_mm = outer.radius_mm;
  s.inner_radius_mm = inner.radius_mm;
  s.inner_from_outer_mm = inner.center_mm - outer.center_mm;
  s.rim_from_outer_z_mm = rim_z_mm ? *rim_z_mm - outer.center_mm.z() : 0.0;
  return s;
}

std::array<double, 5> DomePort::ShellValues(const CamShell& s) {
  return {s.outer_radius_mm, s.inner_radius_mm, s.inner_from_outer_mm.x(), s.inner_from_outer_mm.y(),
          s.inner_from_outer_mm.z()};
}

void DomePort::SetShellValues(const double* v, CamShell* s) {
  s->outer_radius_mm = v[0];
  s->inner_radius_mm = v[1];
  s->inner_from_outer_mm = Vec3(v[2], v[3], v[4]);
}

DomePort DomePort::AtSurfaces(const CamSurfaces<double>& g) {
  DomePort d;
  d.outer = {g.outer_center, g.outer_radius};
  d.inner = {g.inner_center, g.inner_radius};
  d.rim_z_mm = g.rim_z;
  return d;
}

bool DomePort::InWater(const CamSurfaces<double>& g, const Vec3& x) {
  return (x - g.outer_center).norm() > g.outer_radius && x.z() > g.rim_z;
}

void DomePort::ValidateParams(const CamShell& s, const double* p, const std::string& field) {
  CamSurfaces<double> g;
  SurfacesAt<double>(s, p, nullptr, &g);
  if (g.inner_center.norm() >= g.inner_radius) {
    throw InvalidInput(field, fmt::format("the entrance pupil ({:.2f}, {:.2f}, {:.2f}) mm from "
                                          "the dome centre is not inside the inner sphere",
                                          p[0], p[1], p[2]));
  }
}

std::optional<Vec3> DomePort::AxisThroughPupil(const CamSurfaces<double>& g, bool* identity) {
  *identity = false;
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

Vec3 DomePort::ApproximateAxis(const CamSurfaces<double>& g) {
  const Vec3& co = g.outer_center;
  const Vec3 a = co.norm() > 1e-9 * g.outer_radius ? co.normalized() : g.inner_center.normalized();
  return a.z() < 0 ? Vec3(-a) : a;
}

std::array<double, 3> DomePort::PortParams(const Vec3& ep) const {
  const Vec3 p = ep - outer.center_mm;
  return {p.x(), p.y(), p.z()};
}

// v: outer radius, inner radius, inner centre minus outer (x, y, z).
void DomePort::ValidateShellValues(const double* v, const std::string& field) {
  const double off = Vec3(v[2], v[3], v[4]).norm();
  if (!(v[1] > 0) || !(off < v[0] - v[1])) {
    throw InvalidInput(field, fmt::format("the inner sphere (radius {:.4g} mm, {:.4g} mm from the "
                                          "outer centre) is not inside the outer one (radius {:.4g} mm)",
                                          v[1], off, v[0]));
  }
}

// ---- Flat ----

void FlatPort::Validate(const std::string& where) const {
  RequireFiniteVec(where + ".inner_point_mm", inner_point_mm);
  RequireFiniteVec(where + ".normal", normal);
  if (std::abs(normal.norm() - 1) > 1e-6) throw InvalidInput(where + ".normal", "must be a unit vector");
  if (normal.z() <= 0) throw InvalidInput(where + ".normal", "must point toward the scene (+Z)");
  RequirePositive(where + ".thickness_mm", thickness_mm);
}

void FlatPort::Translate(const Vec3& by) { inner_point_mm += by; }

void FlatPort::RequirePupilInside(const Vec3& ep) const {
  if ((ep - inner_point_mm).dot(normal) >= 0) {
    throw InvalidInput("entrance_pupil_mm", "the entrance pupil must lie behind the flat port's inner plane");
  }
}

TwoInterfaces<double> FlatPort::Outward(double n_glass, double n_water) const {
  return Interfaces<double>(inner_point_mm, normal, 0.0, thickness_mm, n_glass, n_water);
}

bool FlatPort::InsideOuterSurface(const Vec3& p) const { return (p - inner_point_mm).dot(normal) < thickness_mm; }

// Two planes (their tilt is not drawn: the section is square to the axis).
PortSection FlatPort::Section() const {
  PortSection sec;
  sec.inner.center_mm = inner_point_mm;
  sec.outer.center_mm = inner_point_mm + thickness_mm * normal;
  return sec;
}

// Square to the axis.
bool FlatPort::RevolvesAbout(const Vec3&) const { return normal.head<2>().norm() <= 1e-12; }

double FlatPort::VertexZ(const Vec3& ep, bool of_outer) const {
  const Vec3 p = of_outer ? Vec3(inner_point_mm + thickness_mm * normal) : inner_point_mm;
  return ep.z() + (p - ep).dot(normal) / normal.z();
}

std::array<double, 3> FlatPort::PortParams(const Vec3& ep) const {
  return {normal.x(), normal.y(), (inner_point_mm - ep).dot(normal)};
}

FlatPort FlatPort::AtSurfaces(const CamSurfaces<double>& g) {
  FlatPort f;
  f.normal = g.normal;
  f.inner_point_mm = g.distance * g.normal;
  f.thickness_mm = g.thickness;
  return f;
}

void FlatPort::ValidateParams(const CamShell&, const double* p, const std::string& field) {
  if (!(p[0] * p[0] + p[1] * p[1] < 1)) {
    throw InvalidInput(field, "the flat port's normal must point toward the scene (n_x² + n_y² < 1)");
  }
  if (!(p[2] > 0)) throw InvalidInput(field, "the flat port must lie ahead of the pupil (distance > 0)");
}

// v: thickness.
void FlatPort::ValidateShellValues(const double* v, const std::string& field) {
  if (!(v[0] > 0)) throw InvalidInput(field, fmt::format("the glass thickness {:.4g} mm is not positive", v[0]));
}

// ---- Cylinder ----

Vec3 CanonicalAxis(const Vec3& axis) {
  const Vec3 a = axis.normalized();
  return a.y() < 0 || (a.y() == 0 && a.x() < 0) ? Vec3(-a) : a;
}

void CylinderPort::Validate(const std::string& where) const {
  RequireFiniteVec(where + ".axis_point_mm", axis_point_mm);
  RequireFiniteVec(where + ".axis", axis);
  if (std::abs(axis.norm() - 1) > 1e-6) throw InvalidInput(where + ".axis", "must be a unit vector");
  if (std::abs(axis.z()) > 1e-9) {
    throw InvalidInput(where + ".axis", "must lie across the optical axis (its z component 0)");
  }
  RequirePositive(where + ".inner_radius_mm", inner_radius_mm);
  RequirePositive(where + ".outer_radius_mm", outer_radius_mm);
  if (inner_radius_mm >= outer_radius_mm) {
    throw InvalidInput(where + ".inner_radius_mm", "must be smaller than outer_radius_mm (" +
                                                       std::to_string(outer_radius_mm) + ")");
  }
  if (rim_z_mm) RequireFinite(where + ".rim_z_mm", *rim_z_mm);
}

void CylinderPort::Translate(const Vec3& by) {
  axis_point_mm += by;
  if (rim_z_mm) *rim_z_mm += by.z();
}

void CylinderPort::RequirePupilInside(const Vec3& ep) const {
  if (FromAxis(ep, axis_point_mm, axis.normalized()) >= inner_radius_mm) {
    throw InvalidInput("entrance_pupil_mm", "the entrance pupil must lie inside the cylinder's inner surface");
  }
}

TwoInterfaces<double> CylinderPort::Outward(double n_glass, double n_water) const {
  return Interfaces<double>(axis_point_mm, CanonicalAxis(axis), inner_radius_mm, outer_radius_mm,
                            rim_z_mm.value_or(axis_point_mm.z()), n_glass, n_water);
}

bool CylinderPort::InsideOuterSurface(const Vec3& p) const {
  return FromAxis(p, axis_point_mm, axis.normalized()) < outer_radius_mm;
}

// Across its axis: circles about the axis, as a dome's (centred at y = 0: the x–z plane cuts the
// tube across, whatever point of the axis the file names).
PortSection CylinderPort::Section() const {
  const Vec3 c(axis_point_mm.x(), 0, axis_point_mm.z());
  return {{c, outer_radius_mm}, {c, inner_radius_mm}, rim_z_mm};
}

// Curved across its axis, straight along it: never.
bool CylinderPort::RevolvesAbout(const Vec3&) const { return false; }

double CylinderPort::VertexZ(const Vec3& ep, bool of_outer) const {
  // Where {ep + s ẑ} meets the cylinder on its +Z side, in the plane across the axis.
  const double radius = of_outer ? outer_radius_mm : inner_radius_mm;
  const double off = (ep - axis_point_mm).dot(axis.normalized().cross(Vec3::UnitZ()));  // a.z = 0: unit
  const double h2 = radius * radius - off * off;
  PORTHOLE_CHECK(h2 >= 0);  // Place() put the pupil inside the inner cylinder
  return axis_point_mm.z() + std::sqrt(h2);
}

std::array<double, 3> CylinderPort::PortParams(const Vec3& ep) const {
  const Vec3 a = CanonicalAxis(axis);
  const Vec3 q = ep - axis_point_mm;
  return {q.dot(a.cross(Vec3::UnitZ())), q.z(), std::atan2(a.x(), a.y()) * 180 / M_PI};
}

CylinderPort CylinderPort::AtSurfaces(const CamSurfaces<double>& g) {
  CylinderPort c;
  c.axis = g.normal;
  c.axis_point_mm = g.axis_point;
  c.inner_radius_mm = g.inner_radius;
  c.outer_radius_mm = g.outer_radius;
  c.rim_z_mm = g.rim_z;
  return c;
}

bool CylinderPort::InWater(const CamSurfaces<double>& g, const Vec3& x) {
  const Vec3 q = x - g.axis_point;
  return (q - q.dot(g.normal) * g.normal).norm() > g.outer_radius && x.z() > g.rim_z;
}

void CylinderPort::ValidateParams(const CamShell& s, const double* p, const std::string& field) {
  if (std::hypot(p[0], p[1]) >= s.inner_radius_mm) {
    throw InvalidInput(field, fmt::format("the entrance pupil ({:.2f}, {:.2f}) mm from the cylinder's "
                                          "axis is not inside the inner cylinder (radius {:.4g} mm)",
                                          p[0], p[1], s.inner_radius_mm));
  }
}

// Far away with the pupil on the axis every ray meets both surfaces square across the axis, so
// only its slope along the axis bends, as through a flat port: sin(slope in air) = n_water
// sin(slope in water).
std::optional<Vec3> CylinderPort::StartDirection(const CamSurfaces<double>& g, const Vec3& x) {
  const Vec3& a = g.normal;
  const double along = x.dot(a);
  Vec3 across = x - along * a;
  const double rho = across.norm();
  if (rho <= 1e-14 * x.norm()) return x.normalized();
  across /= rho;
  const double slope = std::asin(std::clamp(g.n_water * along / x.norm(), -0.999, 0.999));
  return std::cos(slope) * across + std::sin(slope) * a;
}

// v: outer radius, inner radius.
void CylinderPort::ValidateShellValues(const double* v, const std::string& field) {
  if (!(v[1] > 0) || !(v[1] < v[0])) {
    throw InvalidInput(field, fmt::format("the inner cylinder (radius {:.4g} mm) is not inside the "
                                          "outer one (radius {:.4g} mm)", v[1], v[0]));
  }
}

// ---- The list ----

std::vector<std::string_view> ShapeNames() {
  return [&]<std::size_t... I>(std::index_sequence<I...>) {
    return std::vector<std::string_view>{std::variant_alternative_t<I, PortShape>::kName...};
  }(std::make_index_sequence<std::variant_size_v<PortShape>>());
}

std::optional<PortShape> ShapeNamed(std::string_view name) {
  std::optional<PortShape> out;
  [&]<std::size_t... I>(std::index_sequence<I...>) {
    ((std::variant_alternative_t<I, PortShape>::kName == name ? (void)out.emplace(std::in_place_index<I>) : void()),
     ...);
  }(std::make_index_sequence<std::variant_size_v<PortShape>>());
  return out;
}

std::string_view PortSpec::KindName() const {
  return std::visit([](const auto& p) { return std::decay_t<decltype(p)>::kName; }, shape);
}

bool PortSpec::IsCurved() const {
  return std::visit([](const auto& p) { return p.Section().outer.IsCircle(); }, shape);
}

const std::string& PortSpec::material() const {
  return std::visit([](const auto& p) -> const std::string& { return p.material; }, shape);
}

void Validate(const PortSpec& spec, const std::string& where) {
  std::visit([&](const auto& p) { p.Validate(where); }, spec.shape);
  RequireFiniteVec(where + ".entrance_pupil_mm", spec.default_ep_in_housing_mm);
  const ShellSigma& sg = spec.sigma;
  for (const auto& [key, v] : {std::pair{".sigma.outer_radius_mm", sg.outer_radius_mm},
                               std::pair{".sigma.inner_radius_mm", sg.inner_radius_mm},
                               std::pair{".sigma.thickness_mm", sg.thickness_mm}}) {
    if (v && !(std::isfinite(*v) && *v >= 0)) throw InvalidInput(where + key, "a sigma must be finite and >= 0");
  }
  if (sg.inner_offset_mm && !(sg.inner_offset_mm->allFinite() && sg.inner_offset_mm->minCoeff() >= 0)) {
    throw InvalidInput(where + ".sigma.inner_offset_mm", "a sigma must be finite and >= 0 on every axis");
  }
}

PortSystem Place(const PortSpec& spec_in, const Vec3& ep, double n_glass, double n_water) {
  Validate(spec_in);
  RequireFiniteVec("entrance_pupil_mm", ep);
  if (!(std::isfinite(n_glass) && n_glass >= 1)) throw InvalidInput("glass_index", "must be a finite number >= 1");
  if (!(std::isfinite(n_water) && n_water >= 1)) throw InvalidInput("water_index", "must be a finite number >= 1");
  PortSystem sys;
  sys.spec = spec_in;
  sys.ep_in_housing_mm = ep;
  sys.n_glass = n_glass;
  sys.n_water = n_water;
  // Move a cam-frame description to the housing frame: cam = housing - ep.
  if (spec_in.frame == PortFrame::kCam) {
    sys.spec.frame = PortFrame::kHousing;
    std::visit([&](auto& p) { p.Translate(ep); }, sys.spec.shape);
  }
  std::visit([&](const auto& p) { p.RequirePupilInside(ep); }, sys.spec.shape);
  return sys;
}

std::vector<optics::Interface> PortSystem::Outward() const {
  const TwoInterfaces<double> f =
      std::visit([&](const auto& p) { return p.Outward(n_glass, n_water); }, spec.shape);
  return {f.begin(), f.end()};
}

std::vector<optics::Interface> PortSystem::Inward() const { return optics::Reversed(Outward()); }

bool PortSystem::InsideOuterSurface(const Vec3& p) const {
  return std::visit([&](const auto& s) { return s.InsideOuterSurface(p); }, spec.shape);
}

bool PortSystem::IsCentral(double tol_mm) const {
  return IsDome() && dome().CentralAt(ep_in_housing_mm, tol_mm);
}

double PortSystem::OuterVertexZ() const {
  return std::visit([&](const auto& p) { return p.VertexZ(ep_in_housing_mm, true); }, spec.shape);
}

double PortSystem::InnerVertexZ() const {
  return std::visit([&](const auto& p) { return p.VertexZ(ep_in_housing_mm, false); }, spec.shape);
}

}  // namespace porthole::ports
