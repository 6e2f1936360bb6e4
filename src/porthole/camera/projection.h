// The ideal radial projections of a lens (docs/conventions.md, "Fisheye lenses"): the image radius
// r of a ray at angle θ from the optical axis, r = f·g(θ), and the inverse. One implementation,
// templated on the scalar, serves planning (field of view from a focal length in mm) and the
// fisheye camera models (camera/models.h, in pixels).
//
//   rectilinear   g(θ) = tan θ            valid 0 ≤ θ < 90°
//   equidistant   g(θ) = θ                valid 0 ≤ θ < 180°
//   equisolid     g(θ) = 2 sin(θ/2)       valid 0 ≤ θ < 180°
//   stereographic g(θ) = 2 tan(θ/2)       valid 0 ≤ θ < 180°
//   orthographic  g(θ) = sin θ            valid 0 ≤ θ < 90°  (g' = cos θ → 0 at the limit)
//
// lensfun's <type> names the same projections ("fisheye" there is equidistant).
#pragma once

#include <cmath>
#include <numbers>
#include <optional>
#include <string>
#include <string_view>

#include "porthole/camera/scalar.h"

namespace porthole::camera {

enum class Projection { kRectilinear, kEquidistant, kEquisolid, kStereographic, kOrthographic };

inline constexpr Projection kAllProjections[] = {Projection::kRectilinear, Projection::kEquidistant,
                                                 Projection::kEquisolid, Projection::kStereographic,
                                                 Projection::kOrthographic};

// "rectilinear", "equidistant", "equisolid", "stereographic", "orthographic" (the lens TOML
// `projection` values).
std::string_view ProjectionName(Projection p);
// The inverse of ProjectionName; nullopt for any other text.
std::optional<Projection> ProjectionFromName(std::string_view name);
// "rectilinear" is the ordinary lens; every other projection is a fisheye.
inline bool IsFisheye(Projection p) { return p != Projection::kRectilinear; }

// The largest angle from the axis (rad) the projection maps to a finite, increasing radius.
inline double MaxFieldAngleRad(Projection p) {
  switch (p) {
    case Projection::kRectilinear:
    case Projection::kOrthographic:
      return 0.5 * std::numbers::pi;
    default:
      return std::numbers::pi;
  }
}

// g(θ): the image radius per unit focal length (dimensionless). θ in rad, 0 ≤ θ < MaxFieldAngle.
template <typename T>
T ProjectionRadius(Projection p, const T& theta) {
  using std::sin;
  using std::tan;
  switch (p) {
    case Projection::kRectilinear: return tan(theta);
    case Projection::kEquidistant: return theta;
    case Projection::kEquisolid: return T(2) * sin(theta / T(2));
    case Projection::kStereographic: return T(2) * tan(theta / T(2));
    case Projection::kOrthographic: return sin(theta);
  }
  return theta;
}

// dg/dθ (> 0 inside the valid field).
template <typename T>
T ProjectionRadiusDerivative(Projection p, const T& theta) {
  using std::cos;
  switch (p) {
    case Projection::kRectilinear: {
      const T c = cos(theta);
      return T(1) / (c * c);
    }
    case Projection::kEquidistant: return T(1);
    case Projection::kEquisolid: return cos(theta / T(2));
    case Projection::kStereographic: {
      const T c = cos(theta / T(2));
      return T(1) / (c * c);
    }
    case Projection::kOrthographic: return cos(theta);
  }
  return T(1);
}

// θ = g⁻¹(ρ) for a radius per unit focal length ρ ≥ 0; nullopt beyond the projection's reach
// (orthographic ρ > 1, equisolid ρ > 2).
template <typename T>
std::optional<T> ProjectionAngle(Projection p, const T& rho) {
  using std::asin;
  using std::atan;
  const double v = ScalarValue(rho);
  switch (p) {
    case Projection::kRectilinear: return atan(rho);
    case Projection::kEquidistant: return rho;
    case Projection::kEquisolid:
      if (!(v < 2)) return std::nullopt;
      return T(2) * asin(rho / T(2));
    case Projection::kStereographic: return T(2) * atan(rho / T(2));
    case Projection::kOrthographic:
      if (!(v < 1)) return std::nullopt;
      return asin(rho);
  }
  return std::nullopt;
}

}  // namespace porthole::camera
