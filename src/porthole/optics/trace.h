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

// Forces inlining of the per-ray primitives so the batched loops vectorise (gcc's heuristics
// otherwise keep Step() as a call, which blocks vectorisation).
#define PORTHOLE_INLINE inline __attribute__((always_inline))

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

// A refracting surface: a sphere (centre, radius), a plane (point, unit normal) or a circular
// cylinder (a point on its axis, the axis's unit direction, radius). The aperture is the
// half-space dot(p - aperture_point, aperture_normal) >= 0 where the surface has glass (a dome's
// or a cylinder's rim plane); aperture_normal = 0 means unbounded. Templated on the scalar S of
// its shape (double for the tracers; ceres::Jet where a port's parameters are being estimated,
// refraction/refraction.h); the aperture is a value only.
template <typename S>
struct SurfaceT {
  enum class Kind : std::uint8_t { kSphere, kPlane, kCylinder };
  Kind kind = Kind::kSphere;
  Vec3T<S> center = Vec3T<S>::Zero();  // sphere centre, a point on the plane, a point on the axis
  S radius = S(0);                     // sphere and cylinder
  Vec3T<S> normal = Vec3T<S>::Zero();  // plane: unit normal; cylinder: unit axis direction
  Vec3 aperture_point = Vec3::Zero();
  Vec3 aperture_normal = Vec3::Zero();

  static SurfaceT MakeSphere(const Vec3T<S>& center, const S& radius) {
    SurfaceT s;
    s.kind = Kind::kSphere;
    s.center = center;
    s.radius = radius;
    return s;
  }
  static SurfaceT MakePlane(const Vec3T<S>& point, const Vec3T<S>& unit_normal) {
    SurfaceT s;
    s.kind = Kind::kPlane;
    s.center = point;
    s.normal = unit_normal;
    return s;
  }
  static SurfaceT MakeCylinder(const Vec3T<S>& axis_point, const Vec3T<S>& unit_axis, const S& radius) {
    SurfaceT s;
    s.kind = Kind::kCylinder;
    s.center = axis_point;
    s.normal = unit_axis;
    s.radius = radius;
    return s;
  }
};
using Surface = SurfaceT<double>;

// One refraction: the surface, and the indices before and after it along the ray's travel.
template <typename S>
struct InterfaceT {
  SurfaceT<S> surface;
  S n_before = S(1.0);
  S n_after = S(1.0);
};
using Interface = InterfaceT<double>;

// ---- Primitives (templated, inline, written with selects instead of early returns so that the
// batched tracer's loops vectorise; shared by the single-ray, Jet and batched tracers) ----
//
// They live in an inline namespace named by PORTHOLE_OPTICS_ISA_NS. The batched tracer compiles
// them once more per instruction set (batch_avx2.cc, batch_avx512.cc, with -mavx2 / -mavx512*),
// each defining its own namespace name before including this header, so an out-of-line copy made
// in a wide-vector file has a name of its own and the linker can never substitute it for the
// baseline one (which would crash on a processor without AVX). Everything else in the program
// sees the default name; callers never spell it.
#ifndef PORTHOLE_OPTICS_ISA_NS
#define PORTHOLE_OPTICS_ISA_NS isa_baseline
#endif
inline namespace PORTHOLE_OPTICS_ISA_NS {

// A plain 3-vector for the per-ray maths. Eigen's explicit SIMD on 3-vectors keeps gcc from
// vectorising *across* rays, which is what the batched tracer needs; this type converts to and
// from Eigen at the API boundary and works for any scalar (double, ceres::Jet).
template <typename T>
struct P3 {
  T x, y, z;
  static PORTHOLE_INLINE P3 From(const Vec3T<T>& v) { return {v.x(), v.y(), v.z()}; }
  template <typename S>
  static PORTHOLE_INLINE P3 Cast(const Vec3T<S>& v) { return {T(v.x()), T(v.y()), T(v.z())}; }
  PORTHOLE_INLINE Vec3T<T> ToEigen() const { return Vec3T<T>(x, y, z); }
  PORTHOLE_INLINE P3 operator+(const P3& o) const { return {x + o.x, y + o.y, z + o.z}; }
  PORTHOLE_INLINE P3 operator-(const P3& o) const { return {x - o.x, y - o.y, z - o.z}; }
  PORTHOLE_INLINE P3 operator*(const T& k) const { return {x * k, y * k, z * k}; }
  PORTHOLE_INLINE T dot(const P3& o) const { return x * o.x + y * o.y + z * o.z; }
  PORTHOLE_INLINE T squaredNorm() const { return dot(*this); }
};
template <typename T>
PORTHOLE_INLINE P3<T> operator*(const T& k, const P3<T>& v) { return v * k; }

template <typename T>
PORTHOLE_INLINE P3<T> Select(bool c, const P3<T>& a, const P3<T>& b) {
  return {c ? a.x : b.x, c ? a.y : b.y, c ? a.z : b.z};
}

// The nearer of the two roots −b ∓ √disc of a ray's quadratic that lies ahead of it (beyond
// `eps`); *hit is false when there is none (disc < 0, or both behind).
template <typename T>
PORTHOLE_INLINE T NearestRootAhead(const T& b, const T& disc, bool* hit, double eps) {
  const bool real = disc >= T(0);
  using std::sqrt;
  const T sq = sqrt(real ? disc : T(0));
  const T t1 = -b - sq;
  const T t = t1 > T(eps) ? t1 : -b + sq;
  *hit = real & (t > T(eps));
  return t;
}

// Distance along a unit ray to a sphere: the smallest root greater than `eps`. *hit is false when
// there is none (the return value is then meaningless). Works from inside (the exit point) and
// from outside (the entry point).
template <typename T>
PORTHOLE_INLINE T IntersectSphere(const P3<T>& o, const P3<T>& d, const P3<T>& c, T radius, bool* hit,
                                  double eps = 1e-9) {
  const P3<T> oc = o - c;
  const T b = oc.dot(d);
  // R² − (distance from the centre to the ray's line)², computed from the perpendicular vector
  // rather than as b² − (|oc|² − R²), which cancels catastrophically for far-away origins.
  const P3<T> perp = oc - b * d;
  return NearestRootAhead<T>(b, radius * radius - perp.squaredNorm(), hit, eps);
}

// Distance along a unit ray to a plane (point p, unit normal n); *hit is false when the plane is
// parallel to the ray or behind it.
template <typename T>
PORTHOLE_INLINE T IntersectPlane(const P3<T>& o, const P3<T>& d, const P3<T>& p, const P3<T>& n,
                                 bool* hit, double eps = 1e-9) {
  const T denom = d.dot(n);
  const bool ok = (denom > T(1e-15)) | (denom < T(-1e-15));
  const T t = (p - o).dot(n) / (ok ? denom : T(1));
  *hit = ok & (t > T(eps));
  return t;
}

// Distance along a unit ray to a circular cylinder (a point c on its axis, unit axis a, radius):
// the smallest root greater than `eps`, as IntersectSphere, in the plane across the axis. *hit is
// false when there is none or the ray runs along the axis.
template <typename T>
PORTHOLE_INLINE T IntersectCylinder(const P3<T>& o, const P3<T>& d, const P3<T>& c, const P3<T>& a,
                                    T radius, bool* hit, double eps = 1e-9) {
  const P3<T> oc = o - c;
  const P3<T> oc_across = oc - oc.dot(a) * a;  // the parts across the axis
  const P3<T> d_across = d - d.dot(a) * a;
  const T aa = d_across.squaredNorm();
  const bool slanted = aa > T(1e-24);
  const T inv_aa = T(1) / (slanted ? aa : T(1));
  const T b = oc_across.dot(d_across) * inv_aa;  // the closest approach, in units of the ray
  const P3<T> perp = oc_across - b * d_across;
  bool ahead = false;
  const T t = NearestRootAhead<T>(b, (radius * radius - perp.squaredNorm()) * inv_aa, &ahead, eps);
  *hit = slanted & ahead;
  return t;
}

// The unit outward normal of that cylinder at a point p on it.
template <typename T>
PORTHOLE_INLINE P3<T> CylinderNormal(const P3<T>& p, const P3<T>& c, const P3<T>& a, T radius) {
  const P3<T> pc = p - c;
  return (pc - pc.dot(a) * a) * (T(1) / radius);
}

// Vector form of Snell's law: unit direction d meets a surface with unit normal n (either
// orientation) going from index n1 into n2. Returns false on total internal reflection, and then
// *out is meaningless. Otherwise *out is a unit vector with n1 sin θ1 = n2 sin θ2 to round-off.
template <typename T>
PORTHOLE_INLINE bool Refract(const P3<T>& d, const P3<T>& normal, T n1, T n2, P3<T>* out) {
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
template <typename T>
bool Refract(const Vec3T<T>& d, const Vec3T<T>& normal, T n1, T n2, Vec3T<T>* out) {
  P3<T> r;
  const bool ok = Refract<T>(P3<T>::From(d), P3<T>::From(normal), n1, n2, &r);
  *out = r.ToEigen();
  return ok;
}

// `Kind` lets a caller that knows the surface kind at compile time (the batched tracer, which
// dispatches once per surface) remove the choice of kind from its vectorised loop.
enum class KindHint { kRuntime, kSphere, kPlane, kCylinder };

// One interface: moves *o to the intersection with f.surface and refracts *d there. On a status
// other than kOk, *o is the intersection (kOutsideAperture, kTotalInternalReflection) or unchanged
// (kMissed), and *d is unchanged. The one surface step of porthole: the single-ray, the templated
// (Jet), the batched tracers and the refractive projection (refraction::TraceOut) all call it.
// The surface's scalar S is double, or T itself (a port whose shape carries derivatives).
template <typename T, KindHint Kind = KindHint::kRuntime, typename S>
PORTHOLE_INLINE RayStatus Step(const InterfaceT<S>& f, P3<T>* o, P3<T>* d) {
  using Kinds = typename SurfaceT<S>::Kind;
  const SurfaceT<S>& s = f.surface;
  const bool sphere = Kind == KindHint::kRuntime ? s.kind == Kinds::kSphere : Kind == KindHint::kSphere;
  const bool cylinder = Kind == KindHint::kRuntime ? s.kind == Kinds::kCylinder : Kind == KindHint::kCylinder;
  const P3<T> c = P3<T>::Cast(s.center);
  const P3<T> axis_or_normal = P3<T>::Cast(s.normal);
  const T radius = T(s.radius);
  bool hit = false;
  const T t = sphere     ? IntersectSphere<T>(*o, *d, c, radius, &hit)
              : cylinder ? IntersectCylinder<T>(*o, *d, c, axis_or_normal, radius, &hit)
                         : IntersectPlane<T>(*o, *d, c, axis_or_normal, &hit);
  const P3<T> p = *o + t * *d;
  const bool bounded = P3<double>::Cast(s.aperture_normal).squaredNorm() > 0;
  const bool inside_aperture =
      !bounded | ((p - P3<T>::Cast(s.aperture_point)).dot(P3<T>::Cast(s.aperture_normal)) >= T(0));
  const P3<T> n = sphere     ? (p - c) * (T(1) / radius)
                  : cylinder ? CylinderNormal<T>(p, c, axis_or_normal, radius)
                             : axis_or_normal;
  P3<T> d_new;
  const bool refracted = Refract<T>(*d, n, T(f.n_before), T(f.n_after), &d_new);
  const RayStatus status = !hit               ? RayStatus::kMissed
                           : !inside_aperture ? RayStatus::kOutsideAperture
                           : !refracted       ? RayStatus::kTotalInternalReflection
                                              : RayStatus::kOk;
  *o = Select<T>(hit, p, *o);
  *d = Select<T>(status == RayStatus::kOk, d_new, *d);
  return status;
}

}  // inline namespace PORTHOLE_OPTICS_ISA_NS

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
  P3<T> o = P3<T>::From(ray.origin), d = P3<T>::From(ray.dir);
  if constexpr (std::is_same_v<T, double>) {
    if (path) path->points.assign(1, ray.origin);
  }
  RayStatus st = RayStatus::kOk;
  int at = -1;
  for (int i = 0; i < static_cast<int>(seq.size()) && st == RayStatus::kOk; ++i) {
    const P3<T> before = o;
    st = Step<T>(seq[i], &o, &d);
    if constexpr (std::is_same_v<T, double>) {
      const bool moved = o.x != before.x || o.y != before.y || o.z != before.z;
      if (path && moved) path->points.push_back(o.ToEigen());
    }
    if (st != RayStatus::kOk) at = i;
  }
  out->origin = o.ToEigen();
  out->dir = d.ToEigen();
  if (failed_at) *failed_at = at;
  return st;
}

// The reversed sequence: the same surfaces in opposite order with before/after indices swapped.
// Tracing a ray through `seq` and then its reverse (direction negated) returns it to its start.
std::vector<Interface> Reversed(const std::vector<Interface>& seq);

}  // namespace porthole::optics
