// Exact ray tracing through a sequence of refracting spheres and planes (vector Snell's law).
//
// Frames and units: every point and direction is in one frame chosen by the caller (porthole uses
// the housing frame, docs/conventions.md), lengths in mm, directions unit vectors. Indices are
// relative to air (air n = 1).
//
// The maths is written once, templated on the scalar (double, ceres::Jet), and is branch-light so
// the batched tracer (batch.h) runs the very same inline functions across arrays of rays.
// Expected outcomes — a ray that misses a surface, leaves its aperture, or is totally internally
// reflected — come back as a RayStatus, never dropped and never an exception.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string_view>
#include <type_traits>
#include <vector>

namespace porthole::optics {

template <typename T>
using Vec3T = Eigen::Matrix<T, 3, 1>;
using Vec3 = Vec3T<double>;

enum class RayStatus : std::uint8_t {
  kOk = 0,
  kMissed = 1,                    // no intersection ahead of the ray
  kOutsideAperture = 2,           // hit the surface where it has no glass (beyond a dome's rim)
  kTotalInternalReflection = 3,   // refraction impossible: sin θ' would exceed 1
};
std::string_view ToString(RayStatus s);

template <typename T>
struct RayT {
  Vec3T<T> origin;
  Vec3T<T> dir;  // unit
};
using Ray = RayT<double>;

// A refracting surface. A sphere (centre, radius) or a plane (point, unit normal); the aperture is
// the half-space dot(p - aperture_point, aperture_normal) >= 0 where the surface has glass
// (a dome's rim plane); aperture_normal = 0 means unbounded.
struct Surface {
  enum class Kind : std::uint8_t { kSphere, kPlane };
  Kind kind = Kind::kSphere;
  Vec3 center = Vec3::Zero();  // sphere centre, or a point on the plane
  double radius = 0;           // sphere only
  Vec3 normal = Vec3::Zero();  // plane only (unit)
  Vec3 aperture_point = Vec3::Zero();
  Vec3 aperture_normal = Vec3::Zero();

  static Surface MakeSphere(const Vec3& center, double radius) {
    Surface s;
    s.kind = Kind::kSphere;
    s.center = center;
    s.radius = radius;
    return s;
  }
  static Surface MakePlane(const Vec3& point, const Vec3& unit_normal) {
    Surface s;
    s.kind = Kind::kPlane;
    s.center = point;
    s.normal = unit_normal;
    return s;
  }
};

// One refraction: the surface, and the indices before and after it along the ray's travel.
struct Interface {
  Surface surface;
  double n_before = 1.0;
  double n_after = 1.0;
};

// ---- Primitives (templated, inline, written with selects instead of early returns so that the
// batched tracer's loops vectorise; shared by the single-ray, Jet and batched tracers) ----

template <typename T>
inline Vec3T<T> Select(bool c, const Vec3T<T>& a, const Vec3T<T>& b) {
  return Vec3T<T>(c ? a.x() : b.x(), c ? a.y() : b.y(), c ? a.z() : b.z());
}

// Distance along a unit ray to a sphere: the smallest root greater than `eps`. *hit is false when
// there is none (the return value is then meaningless). Works from inside (the exit point) and
// from outside (the entry point).
template <typename T>
inline T IntersectSphere(const Vec3T<T>& o, const Vec3T<T>& d, const Vec3T<T>& c, T radius,
                         bool* hit, double eps = 1e-9) {
  const Vec3T<T> oc = o - c;
  const T b = oc.dot(d);
  // R² − (distance from the centre to the ray's line)², computed from the perpendicular vector
  // rather than as b² − (|oc|² − R²), which cancels catastrophically for far-away origins.
  const Vec3T<T> perp = oc - b * d;
  const T disc = radius * radius - perp.squaredNorm();
  const bool real = disc >= T(0);
  using std::sqrt;
  const T sq = sqrt(real ? disc : T(0));
  const T t1 = -b - sq;
  const T t = t1 > T(eps) ? t1 : -b + sq;
  *hit = real && t > T(eps);
  return t;
}

// Distance along a unit ray to a plane (point p, unit normal n); *hit is false when the plane is
// parallel to the ray or behind it.
template <typename T>
inline T IntersectPlane(const Vec3T<T>& o, const Vec3T<T>& d, const Vec3T<T>& p,
                        const Vec3T<T>& n, bool* hit, double eps = 1e-9) {
  const T denom = d.dot(n);
  const bool ok = denom > T(1e-15) || denom < T(-1e-15);
  const T t = (p - o).dot(n) / (ok ? denom : T(1));
  *hit = ok && t > T(eps);
  return t;
}

// Vector form of Snell's law: unit direction d meets a surface with unit normal n (either
// orientation) going from index n1 into n2. Returns false on total internal reflection, and then
// *out is meaningless. Otherwise *out is a unit vector with n1 sin θ1 = n2 sin θ2 to round-off.
template <typename T>
inline bool Refract(const Vec3T<T>& d, const Vec3T<T>& normal, T n1, T n2, Vec3T<T>* out) {
  const T dn = normal.dot(d);
  const T sign = dn > T(0) ? T(-1) : T(1);  // make the normal face the incoming ray
  const T cos_i = -sign * dn;
  const T eta = n1 / n2;
  const T k = T(1) - eta * eta * (T(1) - cos_i * cos_i);
  using std::sqrt;
  const T root = sqrt(k >= T(0) ? k : T(0));
  *out = eta * d + ((eta * cos_i - root) * sign) * normal;
  return k >= T(0);
}

// One interface: moves *o to the intersection with f.surface and refracts *d there. On a status
// other than kOk, *o is the intersection (kOutsideAperture, kTotalInternalReflection) or unchanged
// (kMissed), and *d is unchanged. This is the only implementation of a surface step: the
// single-ray, the templated (Jet) and the batched tracers all call it.
template <typename T>
inline RayStatus Step(const Interface& f, Vec3T<T>* o, Vec3T<T>* d) {
  const Surface& s = f.surface;
  const bool sphere = s.kind == Surface::Kind::kSphere;
  const Vec3T<T> c = s.center.template cast<T>();
  bool hit = false;
  const T t = sphere ? IntersectSphere<T>(*o, *d, c, T(s.radius), &hit)
                     : IntersectPlane<T>(*o, *d, c, s.normal.template cast<T>(), &hit);
  const Vec3T<T> p = *o + t * *d;
  const bool bounded = s.aperture_normal.squaredNorm() > 0;
  const bool inside_aperture =
      !bounded ||
      (p - s.aperture_point.template cast<T>()).dot(s.aperture_normal.template cast<T>()) >= T(0);
  const Vec3T<T> n =
      sphere ? Vec3T<T>((p - c) / T(s.radius)) : Vec3T<T>(s.normal.template cast<T>());
  Vec3T<T> d_new;
  const bool refracted = Refract<T>(*d, n, T(f.n_before), T(f.n_after), &d_new);
  const RayStatus status = !hit               ? RayStatus::kMissed
                           : !inside_aperture ? RayStatus::kOutsideAperture
                           : !refracted       ? RayStatus::kTotalInternalReflection
                                              : RayStatus::kOk;
  *o = Select<T>(hit, p, *o);
  *d = Select<T>(status == RayStatus::kOk, d_new, *d);
  return status;
}

// ---- Tracing one ray through a sequence ----

// Optional record of the points a ray visits, for diagrams: the start, then each intersection.
struct RayPath {
  std::vector<Vec3> points;
};

// Traces `ray` through `seq` in order. *out is the ray after the last surface (origin on it) on
// kOk; otherwise the ray as far as it got, with `failed_at` (if given) the interface index where it
// stopped (-1 on success). Templated for automatic differentiation; `path` must be null for Jets.
template <typename T>
RayStatus TraceSequence(const std::vector<Interface>& seq, const RayT<T>& ray, RayT<T>* out,
                        RayPath* path = nullptr, int* failed_at = nullptr) {
  out->origin = ray.origin;
  out->dir = ray.dir;
  if constexpr (std::is_same_v<T, double>) {
    if (path) path->points.assign(1, ray.origin);
  }
  for (int i = 0; i < static_cast<int>(seq.size()); ++i) {
    const Vec3T<T> before = out->origin;
    const RayStatus st = Step<T>(seq[i], &out->origin, &out->dir);
    if constexpr (std::is_same_v<T, double>) {
      if (path && out->origin != before) path->points.push_back(out->origin);
    }
    if (st != RayStatus::kOk) {
      if (failed_at) *failed_at = i;
      return st;
    }
  }
  if (failed_at) *failed_at = -1;
  return RayStatus::kOk;
}

// The reversed sequence: the same surfaces in opposite order with before/after indices swapped.
// Tracing a ray through `seq` and then its reverse (direction negated) returns it to its start.
std::vector<Interface> Reversed(const std::vector<Interface>& seq);

}  // namespace porthole::optics
