#include "porthole/ports/port.h"

#include <Eigen/Geometry>
#include <cmath>

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

// Where the line {p0 + s ẑ} meets a cylinder (axis across Z) on its +Z side.
std::optional<double> FrontZ(const CylinderPort& c, double radius, const Vec3& p0) {
  const Vec3 a = c.axis.normalized();
  const Vec3 across = a.cross(Vec3::UnitZ());  // unit, since a.z = 0
  const double off = (p0 - c.axis_point_mm).dot(across);
  const double h2 = radius * radius - off * off;
  if (h2 < 0) return std::nullopt;
  return c.axis_point_mm.z() + std::sqrt(h2);
}

}  // namespace

Vec3 CanonicalAxis(const Vec3& axis) {
  const Vec3 a = axis.normalized();
  return a.y() < 0 || (a.y() == 0 && a.x() < 0) ? Vec3(-a) : a;
}

std::string_view PortSpec::KindName() const {
  return IsDome() ? "dome" : IsCylinder() ? "cylinder" : "flat";
}

const std::string& PortSpec::material() const {
  return std::visit([](const auto& p) -> const std::string& { return p.material; }, shape);
}

void Validate(const PortSpec& spec, const std::string& where) {
  if (const auto* d = std::get_if<DomePort>(&spec.shape)) {
    RequireFiniteVec(where + ".outer.center_mm", d->outer.center_mm);
    RequireFiniteVec(where + ".inner.center_mm", d->inner.center_mm);
    RequirePositive(where + ".outer.radius_mm", d->outer.radius_mm);
    RequirePositive(where + ".inner.radius_mm", d->inner.radius_mm);
    if (d->inner.radius_mm >= d->outer.radius_mm) {
      throw InvalidInput(where + ".inner.radius_mm", "must be smaller than outer.radius_mm (" +
                                                         std::to_string(d->outer.radius_mm) + ")");
    }
    const double gap = d->outer.radius_mm - d->inner.radius_mm;
    if ((d->outer.center_mm - d->inner.center_mm).norm() >= gap) {
      throw InvalidInput(where + ".inner.center_mm",
                         "the inner sphere must lie inside the outer one (centre distance below "
                         "the radius difference)");
    }
    if (d->rim_z_mm) RequireFinite(where + ".rim_z_mm", *d->rim_z_mm);
  } else if (const auto* c = std::get_if<CylinderPort>(&spec.shape)) {
    RequireFiniteVec(where + ".axis_point_mm", c->axis_point_mm);
    RequireFiniteVec(where + ".axis", c->axis);
    if (std::abs(c->axis.norm() - 1) > 1e-6) throw InvalidInput(where + ".axis", "must be a unit vector");
    if (std::abs(c->axis.z()) > 1e-9) {
      throw InvalidInput(where + ".axis", "must lie across the optical axis (its z component 0)");
    }
    RequirePositive(where + ".inner_radius_mm", c->inner_radius_mm);
    RequirePositive(where + ".outer_radius_mm", c->outer_radius_mm);
    if (c->inner_radius_mm >= c->outer_radius_mm) {
      throw InvalidInput(where + ".inner_radius_mm", "must be smaller than outer_radius_mm (" +
                                                         std::to_string(c->outer_radius_mm) + ")");
    }
    if (c->rim_z_mm) RequireFinite(where + ".rim_z_mm", *c->rim_z_mm);
  } else {
    const auto& f = std::get<FlatPort>(spec.shape);
    RequireFiniteVec(where + ".inner_point_mm", f.inner_point_mm);
    RequireFiniteVec(where + ".normal", f.normal);
    if (std::abs(f.normal.norm() - 1) > 1e-6) throw InvalidInput(where + ".normal", "must be a unit vector");
    if (f.normal.z() <= 0) throw InvalidInput(where + ".normal", "must point toward the scene (+Z)");
    RequirePositive(where + ".thickness_mm", f.thickness_mm);
  }
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
    if (auto* d = std::get_if<DomePort>(&sys.spec.shape)) {
      d->outer.center_mm += ep;
      d->inner.center_mm += ep;
      if (d->rim_z_mm) *d->rim_z_mm += ep.z();
    } else if (auto* c = std::get_if<CylinderPort>(&sys.spec.shape)) {
      c->axis_point_mm += ep;
      if (c->rim_z_mm) *c->rim_z_mm += ep.z();
    } else {
      std::get<FlatPort>(sys.spec.shape).inner_point_mm += ep;
    }
  }
  if (const auto* d = std::get_if<DomePort>(&sys.spec.shape)) {
    if ((ep - d->inner.center_mm).norm() >= d->inner.radius_mm) {
      throw InvalidInput("entrance_pupil_mm", "the entrance pupil must lie inside the dome's inner sphere");
    }
  } else if (const auto* c = std::get_if<CylinderPort>(&sys.spec.shape)) {
    if (FromAxis(ep, c->axis_point_mm, c->axis.normalized()) >= c->inner_radius_mm) {
      throw InvalidInput("entrance_pupil_mm", "the entrance pupil must lie inside the cylinder's inner surface");
    }
  } else {
    const auto& f = std::get<FlatPort>(sys.spec.shape);
    if ((ep - f.inner_point_mm).dot(f.normal) >= 0) {
      throw InvalidInput("entrance_pupil_mm", "the entrance pupil must lie behind the flat port's inner plane");
    }
  }
  return sys;
}

std::vector<optics::Interface> PortSystem::Outward() const {
  using optics::Interface;
  using optics::Surface;
  if (IsDome()) {
    const DomePort& d = dome();
    Surface inner = Surface::MakeSphere(d.inner.center_mm, d.inner.radius_mm);
    Surface outer = Surface::MakeSphere(d.outer.center_mm, d.outer.radius_mm);
    const double rim = d.rim_z_mm.value_or(d.outer.center_mm.z());
    for (Surface* s : {&inner, &outer}) {
      s->aperture_point = Vec3(0, 0, rim);
      s->aperture_normal = Vec3(0, 0, 1);
    }
    return {Interface{inner, 1.0, n_glass}, Interface{outer, n_glass, n_water}};
  }
  if (IsCylinder()) {
    const CylinderPort& c = cylinder();
    const Vec3 a = CanonicalAxis(c.axis);
    Surface inner = Surface::MakeCylinder(c.axis_point_mm, a, c.inner_radius_mm);
    Surface outer = Surface::MakeCylinder(c.axis_point_mm, a, c.outer_radius_mm);
    const double rim = c.rim_z_mm.value_or(c.axis_point_mm.z());
    for (Surface* s : {&inner, &outer}) {
      s->aperture_point = Vec3(0, 0, rim);
      s->aperture_normal = Vec3(0, 0, 1);
    }
    return {Interface{inner, 1.0, n_glass}, Interface{outer, n_glass, n_water}};
  }
  const FlatPort& f = flat();
  return {Interface{Surface::MakePlane(f.inner_point_mm, f.normal), 1.0, n_glass},
          Interface{Surface::MakePlane(f.inner_point_mm + f.thickness_mm * f.normal, f.normal), n_glass,
                    n_water}};
}

std::vector<optics::Interface> PortSystem::Inward() const { return optics::Reversed(Outward()); }

bool PortSystem::InsideOuterSurface(const Vec3& p) const {
  if (IsDome()) return (p - dome().outer.center_mm).norm() < dome().outer.radius_mm;
  if (IsCylinder()) return FromAxis(p, cylinder().axis_point_mm, cylinder().axis.normalized()) < cylinder().outer_radius_mm;
  return (p - flat().inner_point_mm).dot(flat().normal) < flat().thickness_mm;
}

bool PortSystem::IsCentral(double tol_mm) const {
  if (!IsDome()) return false;
  return (dome().outer.center_mm - ep_in_housing_mm).norm() <= tol_mm &&
         (dome().inner.center_mm - ep_in_housing_mm).norm() <= tol_mm;
}

double PortSystem::OuterVertexZ() const {
  if (IsDome()) {
    const auto z = FrontZ(dome().outer, ep_in_housing_mm);
    PORTHOLE_CHECK(z.has_value());  // Place() put the pupil inside the inner sphere
    return *z;
  }
  if (IsCylinder()) {
    const auto z = FrontZ(cylinder(), cylinder().outer_radius_mm, ep_in_housing_mm);
    PORTHOLE_CHECK(z.has_value());  // Place() put the pupil inside the inner cylinder
    return *z;
  }
  const FlatPort& f = flat();
  const Vec3 p = f.inner_point_mm + f.thickness_mm * f.normal;
  return ep_in_housing_mm.z() + (p - ep_in_housing_mm).dot(f.normal) / f.normal.z();
}

double PortSystem::InnerVertexZ() const {
  if (IsDome()) {
    const auto z = FrontZ(dome().inner, ep_in_housing_mm);
    PORTHOLE_CHECK(z.has_value());
    return *z;
  }
  if (IsCylinder()) {
    const auto z = FrontZ(cylinder(), cylinder().inner_radius_mm, ep_in_housing_mm);
    PORTHOLE_CHECK(z.has_value());
    return *z;
  }
  const FlatPort& f = flat();
  return ep_in_housing_mm.z() + (f.inner_point_mm - ep_in_housing_mm).dot(f.normal) / f.normal.z();
}

}  // namespace porthole::ports
