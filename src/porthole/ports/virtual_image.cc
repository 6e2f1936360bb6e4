#include "porthole/ports/virtual_image.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

#include "porthole/core/error.h"

namespace porthole::ports {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The port as seen by the paraxial trace. Coordinate w = −z grows in the direction light travels
// from the scene to the camera; radii are signed (positive: centre downstream of the vertex).
struct ParaxialSurface {
  double w_mm;
  double radius_mm;  // infinite for a plane
  double n_before, n_after;
};

// The port's x–z section (its Section): a circle's radius signed by where its centre lies, a plane's
// infinite. A cylinder's section across its axis is circles, as a dome's; along the axis its
// surfaces are straight, as a flat port's: the port is astigmatic (RealRayVirtualImage).
std::vector<ParaxialSurface> ParaxialModel(const PortSystem& p) {
  const double w_outer = -p.OuterVertexZ();
  const double w_inner = -p.InnerVertexZ();
  const PortSection sec = std::visit([](const auto& shape) { return shape.Section(); }, p.spec.shape);
  const auto radius = [](const SectionCurve& c, double w_vertex) {
    return c.IsCircle() ? std::copysign(c.radius_mm, -c.center_mm.z() - w_vertex) : kInf;
  };
  return {{w_outer, radius(sec.outer, w_outer), p.n_water, p.n_glass}, {w_inner, radius(sec.inner, w_inner), p.n_glass, 1.0}};
}

struct YNu {
  double y, nu;  // height and index × slope after the last surface
  double n;      // index after the last surface
};

// Traces (y at the first surface, n·u before it) through the surfaces.
YNu TraceYNu(const std::vector<ParaxialSurface>& s, double y, double nu) {
  double n = s.front().n_before;
  for (std::size_t k = 0; k < s.size(); ++k) {
    const double phi = std::isinf(s[k].radius_mm) ? 0.0 : (s[k].n_after - s[k].n_before) / s[k].radius_mm;
    nu -= y * phi;
    n = s[k].n_after;
    if (k + 1 < s.size()) y += (s[k + 1].w_mm - s[k].w_mm) * nu / n;
  }
  return {y, nu, n};
}

void CheckWd(double wd_mm) {
  if (std::isnan(wd_mm) || !(wd_mm > 0)) throw InvalidInput("wd_mm", "must be > 0 (or inf)");
}

}  // namespace

namespace {

// The ray in the water that reaches the pupil point `pupil_point` (housing frame, on the pupil
// plane z = ep.z) after refraction into the housing, from `object` (a point, or parallel rays from
// infinity). Unknown: where the water ray, aimed straight, would cross the pupil plane; Newton on
// the 2D miss with a finite-difference Jacobian. Returns the air-side ray, or nullopt when a ray
// fails or Newton does not converge.
std::optional<optics::Ray> RayThroughPupilPoint(const std::vector<optics::Interface>& inward,
                                                const ObjectPoint& object, const Vec3& pupil_point,
                                                const Vec3& normal = Vec3(0, 0, 1)) {
  // The pupil plane through pupil_point with unit `normal` (the axis: z = const), spanned by e1, e2.
  const Vec3 n = normal.normalized();
  const Vec3 pick = std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  const Vec3 e1 = (pick - pick.dot(n) * n).normalized();  // x for the axis
  const Vec3 e2 = n.cross(e1);                            // y for the axis
  constexpr double kFar = 1e6;  // launch distance of rays from infinity, mm
  auto miss = [&](const Eigen::Vector2d& aim, optics::Ray* air) -> std::optional<Eigen::Vector2d> {
    const Vec3 a = pupil_point + aim.x() * e1 + aim.y() * e2;
    const optics::Ray water = object.at_infinity ? optics::Ray{a + kFar * object.v, -object.v}
                                                 : optics::Ray{object.v, (a - object.v).normalized()};
    optics::Ray out;
    if (optics::TraceSequence<double>(inward, water, &out) != optics::RayStatus::kOk) return std::nullopt;
    const double towards = out.dir.dot(n);  // < 0: travelling back toward the pupil
    if (!(towards < 0)) return std::nullopt;
    const Vec3 hit = out.origin + ((pupil_point - out.origin).dot(n) / towards) * out.dir;
    if (air) *air = out;
    return Eigen::Vector2d((hit - pupil_point).dot(e1), (hit - pupil_point).dot(e2));
  };
  Eigen::Vector2d aim = Eigen::Vector2d::Zero();
  optics::Ray air;
  for (int it = 0; it < 30; ++it) {
    const auto m = miss(aim, &air);
    if (!m) return std::nullopt;
    if (m->norm() < 1e-12) return air;
    Eigen::Matrix2d jac;
    const double h = 1e-6;
    for (int k = 0; k < 2; ++k) {
      Eigen::Vector2d step = aim;
      step[k] += h;
      const auto mk = miss(step, nullptr);
      if (!mk) return std::nullopt;
      jac.col(k) = (*mk - *m) / h;
    }
    aim -= jac.fullPivLu().solve(*m);
  }
  return std::nullopt;
}

// The y-nu trace along the axis through the pupil: exact to first order when the port is
// rotationally symmetric about that axis.
VirtualImage AxialParaxialImage(const PortSystem& port, double wd_mm) {
  const auto s = ParaxialModel(port);
  const double w_ep = -port.ep_in_housing_mm.z();
  const double w_outer = s.front().w_mm;
  // A ray from the axial object point: unit object-side height at infinity, else slope u0.
  const double n0 = s.front().n_before;
  const double u0 = std::isinf(wd_mm) ? 0.0 : 1e-3;
  const double y0 = std::isinf(wd_mm) ? 1.0 : u0 * wd_mm;
  const YNu out = TraceYNu(s, y0, n0 * u0);
  VirtualImage vi;
  vi.wd_mm = wd_mm;
  const double u = out.nu / out.n;
  if (u == 0) {  // afocal: the image of infinity is at infinity
    vi.d_s2ep_mm = vi.vwd_mm = kInf;
    vi.magnification = 1;
    return vi;
  }
  const double w_img = s.back().w_mm - out.y / u;
  vi.d_s2ep_mm = w_ep - w_img;
  vi.vwd_mm = w_outer - w_img;
  vi.focal_line_near_d_s2ep_mm = vi.focal_line_far_d_s2ep_mm = vi.d_s2ep_mm;
  // Lagrange invariant: n u h = n' u' h'  =>  m = (n0 u0) / (n' u').
  vi.magnification = std::isinf(wd_mm) ? 0.0 : (n0 * u0) / (out.n * u);
  return vi;
}

// True when the port is a surface of revolution about the axis through the pupil (parallel to
// housing +Z): dome centres on that axis, or a flat port square to it. The chief ray of an axial
// object is then the axis itself and the y-nu trace is the limit of real rays.
bool SymmetricAboutAxis(const PortSystem& p) {
  return std::visit([&](const auto& shape) { return shape.RevolvesAbout(p.ep_in_housing_mm); }, p.spec.shape);
}

// The object point on the axis through the pupil at wd_mm from the outer vertex (or at infinity).
ObjectPoint AxialObject(const PortSystem& port, double wd_mm) {
  const Vec3& ep = port.ep_in_housing_mm;
  return std::isinf(wd_mm) ? ObjectPoint::Toward(Vec3(0, 0, 1))
                           : ObjectPoint::At(Vec3(ep.x(), ep.y(), port.OuterVertexZ() + wd_mm));
}

// The first-order image about the chief ray (the parabasal image): the limit, as the pupil circle
// shrinks, of the least-squares meeting point of RealRayVirtualPoint's eight rays. With the air
// rays through pupil points ep + h a (a in the pupil plane) having unit directions d(a) ≈ d0 + h G a
// (G a ⊥ d0), the squared distances from a point ep + s d0 sum, to first order in h, to
// 4 h² ‖(P0 + s G) A‖²_F (A = [x̂ ŷ], P0 = I − d0 d0ᵀ), minimised at s = −⟨P0 A, G A⟩ / ‖G A‖².
// G comes from central differences of traced rays. nullopt when a ray fails.
std::optional<VirtualImage> ChiefRayParaxialImage(const PortSystem& port, double wd_mm) {
  const auto inward = port.Inward();
  const ObjectPoint object = AxialObject(port, wd_mm);
  const Vec3& ep = port.ep_in_housing_mm;
  const auto chief = RayThroughPupilPoint(inward, object, ep);
  if (!chief) return std::nullopt;
  const Vec3 d0 = chief->dir.normalized();
  const Eigen::Matrix3d p0 = Eigen::Matrix3d::Identity() - d0 * d0.transpose();
  constexpr double kStep = 1e-3;  // mm in the pupil plane: truncation O(step²/d²), rounding ~1e-12/step
  Eigen::Matrix<double, 3, 2> ga, p0a;
  for (int k = 0; k < 2; ++k) {
    const Vec3 e = k == 0 ? Vec3(1, 0, 0) : Vec3(0, 1, 0);
    const auto plus = RayThroughPupilPoint(inward, object, ep + kStep * e);
    const auto minus = RayThroughPupilPoint(inward, object, ep - kStep * e);
    if (!plus || !minus) return std::nullopt;
    ga.col(k) = p0 * (plus->dir.normalized() - minus->dir.normalized()) / (2 * kStep);
    p0a.col(k) = p0 * e;
  }
  VirtualImage vi;
  vi.wd_mm = wd_mm;
  const double g2 = ga.squaredNorm();
  if (!(g2 > 1e-24)) {  // parallel air rays: the image is at infinity
    vi.d_s2ep_mm = vi.vwd_mm = kInf;
    vi.focal_line_near_d_s2ep_mm = vi.focal_line_far_d_s2ep_mm = kInf;
    return vi;
  }
  const Vec3 x = ep - (p0a.cwiseProduct(ga).sum() / g2) * d0;
  vi.d_s2ep_mm = x.z() - ep.z();
  vi.vwd_mm = x.z() - port.OuterVertexZ();
  vi.lateral_offset_mm = (x - ep).head<2>().norm();
  // The focal lines: the distances s along the chief ray where the rays of one direction a of the
  // pupil meet, (P0 A + s G A) a = 0 across the ray: det(B + s M) = 0 with B, M those matrices
  // in a basis across d0, i.e. s = −1/λ for the eigenvalues λ of B⁻¹M (λ = 0: a line at infinity).
  Vec3 e1 = d0.cross(std::abs(d0.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY()).normalized();
  const Vec3 e2 = d0.cross(e1);
  Eigen::Matrix<double, 2, 3> across;
  across.row(0) = e1.transpose();
  across.row(1) = e2.transpose();
  const Eigen::Matrix2d bm = across * p0a, mm = across * ga;
  const Eigen::Vector2cd lambda = (bm.inverse() * mm).eigenvalues();
  double line[2];
  for (int k = 0; k < 2; ++k) {
    const double l = lambda(k).real();
    line[k] = std::abs(l) > 1e-15 ? (-1 / l) * d0.z() : kInf;
  }
  vi.focal_line_near_d_s2ep_mm = std::min(line[0], line[1]);
  vi.focal_line_far_d_s2ep_mm = std::max(line[0], line[1]);
  return vi;
}

}  // namespace

VirtualImage ParaxialVirtualImage(const PortSystem& port, double wd_mm) {
  CheckWd(wd_mm);
  VirtualImage axial = AxialParaxialImage(port, wd_mm);
  if (SymmetricAboutAxis(port)) return axial;
  const auto chief = ChiefRayParaxialImage(port, wd_mm);
  if (!chief) return axial;  // a chief ray that cannot pass: keep the axial first-order model
  // The y-nu magnification is kept: first order in the decentring (the image positions are exact).
  VirtualImage vi = *chief;
  vi.magnification = axial.magnification;
  return vi;
}

std::optional<VirtualPoint> RealRayVirtualPoint(const PortSystem& port, const ObjectPoint& object,
                                                double aperture_height_mm, const Vec3& pupil_normal) {
  RequirePositive("aperture_height_mm", aperture_height_mm);
  PORTHOLE_CHECK(object.v.allFinite());
  const auto inward = port.Inward();
  const Vec3& ep = port.ep_in_housing_mm;
  // The pupil's circle: in the plane normal to the axis (x, y), or turned to face pupil_normal.
  const Vec3 nz = pupil_normal.normalized();
  Vec3 u1 = Vec3::UnitX(), u2 = Vec3::UnitY();
  if ((nz - Vec3::UnitZ()).norm() > 1e-15) {
    u1 = (std::abs(nz.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY());
    u1 = (u1 - u1.dot(nz) * nz).normalized();
    u2 = nz.cross(u1);
  }
  // Rays through 8 points of the pupil rim; their least-squares meeting point is the virtual image
  // (for an astigmatic bundle this is its centre of least spread).
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  Vec3 b = Vec3::Zero();
  double min_cos = 1;
  std::vector<optics::Ray> rays;
  for (int k = 0; k < 8; ++k) {
    const double phi = k * M_PI / 4;
    const Vec3 p = ep + aperture_height_mm * (std::cos(phi) * u1 + std::sin(phi) * u2);
    auto air = RayThroughPupilPoint(inward, object, p, pupil_normal);
    if (!air) return std::nullopt;
    air->dir.normalize();
    const Eigen::Matrix3d proj = Eigen::Matrix3d::Identity() - air->dir * air->dir.transpose();
    a += proj;
    b += proj * air->origin;
    if (!rays.empty()) min_cos = std::min(min_cos, rays.front().dir.dot(air->dir));
    rays.push_back(*air);
  }
  VirtualPoint vp;
  if (1 - min_cos < 1e-18) {  // parallel air rays (a flat port at infinity): image at infinity
    vp.at_infinity = true;
    return vp;
  }
  vp.position_mm = a.ldlt().solve(b);
  double sum2 = 0;
  for (const optics::Ray& r : rays) {
    const Vec3 d = vp.position_mm - r.origin;
    sum2 += (d - d.dot(r.dir) * r.dir).squaredNorm();
  }
  vp.rms_spread_mm = std::sqrt(sum2 / rays.size());
  return vp;
}

std::optional<VirtualImage> RealRayVirtualImage(const PortSystem& port, double wd_mm,
                                                double aperture_height_mm) {
  CheckWd(wd_mm);
  const Vec3& ep = port.ep_in_housing_mm;
  const double z_outer = port.OuterVertexZ();
  const auto vp = RealRayVirtualPoint(port, AxialObject(port, wd_mm), aperture_height_mm);
  if (!vp) return std::nullopt;
  VirtualImage vi;
  vi.wd_mm = wd_mm;
  if (vp->at_infinity) {
    vi.d_s2ep_mm = vi.vwd_mm = kInf;
    vi.focal_line_near_d_s2ep_mm = vi.focal_line_far_d_s2ep_mm = kInf;
    return vi;
  }
  const Vec3& v = vp->position_mm;
  vi.d_s2ep_mm = v.z() - ep.z();
  vi.vwd_mm = v.z() - z_outer;
  vi.lateral_offset_mm = (v - ep).head<2>().norm();
  return vi;
}

FocalProperties ParaxialFocal(const PortSystem& port) {
  const auto s = ParaxialModel(port);
  const double n0 = s.front().n_before;
  // A ray parallel to the axis at unit height.
  const YNu par = TraceYNu(s, 1.0, 0.0);
  FocalProperties f;
  f.power_per_mm = -par.nu;  // Φ = −n'u'/y1
  if (f.power_per_mm == 0) {
    f.efl_mm = f.efl_water_mm = f.back_focal_mm = f.front_focal_mm = kInf;
    return f;
  }
  f.efl_mm = 1.0 / f.power_per_mm;
  f.efl_water_mm = n0 / f.power_per_mm;
  // Back focal point: where the parallel ray crosses the axis after the last surface (+ downstream).
  f.back_focal_mm = -par.y / (par.nu / par.n);
  // Front focal point: trace the reversed system (air → water) with a parallel ray.
  std::vector<ParaxialSurface> rev;
  for (auto it = s.rbegin(); it != s.rend(); ++it) {
    rev.push_back({-it->w_mm, -it->radius_mm, it->n_after, it->n_before});
  }
  const YNu back = TraceYNu(rev, 1.0, 0.0);
  f.front_focal_mm = -back.y / (back.nu / back.n);
  return f;
}

}  // namespace porthole::ports
