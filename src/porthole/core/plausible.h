// Plausibility of an input: the range of values physical cameras, lenses and ports have, for one
// quantity. A value outside it is valid (nothing refuses it) but most likely typed in the wrong unit
// (µm for mm, metres or inches for mm). The one definition of the ranges and of the warning text,
// for the library's results (plan, flat: `warnings`) and the CLI's stderr notices alike; the hint
// is computed from the value given ("5.5 um is 0.0055 mm" only for 5.5).
#pragma once

#include <fmt/format.h>

#include <cmath>
#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

namespace porthole {

struct PlausibleRange {
  double lo, hi;     // in mm
  const char* unit;  // as printed after the numbers: "mm"
  const char* what;  // the quantity, for the hint: "a pixel pitch"
};
inline constexpr PlausibleRange kPixelPitchRange{0.0005, 0.03, "mm", "a pixel pitch"};
inline constexpr PlausibleRange kCocRange{0.001, 0.25, "mm", "a circle of confusion"};
inline constexpr PlausibleRange kDomeRadiusRange{15, 500, "mm", "a radius"};
inline constexpr PlausibleRange kPortThicknessRange{0.5, 60, "mm", "a thickness"};
inline constexpr PlausibleRange kFocalLengthRange{1, 2000, "mm", "a focal length"};

// The phrase every plausibility warning holds (front ends may pick them out of a result's warnings).
inline constexpr std::string_view kImplausiblePhrase = "is outside the range of any physical camera or port";

// The likely mistake behind `value` (in mm) for `range`: the first of µm, cm, inches and metres in
// which the same number would be plausible, worked out ("5.5 um is 0.0055 mm"); else that no other
// unit makes it plausible.
inline std::string PlausibilityHint(double value, const PlausibleRange& range) {
  for (const auto& [unit, to_mm] : std::initializer_list<std::pair<const char*, double>>{
           {"um", 1e-3}, {"cm", 10}, {"in", 25.4}, {"m", 1e3}}) {
    const double mm = value * to_mm;
    if (mm >= range.lo && mm <= range.hi) {
      return fmt::format("{} in {}? {:g} {} is {:g} mm", range.what, unit, value, unit, mm);
    }
  }
  return fmt::format("{} in another unit? no unit of length makes {:g} plausible", range.what, value);
}

// `field: <value> mm is outside the range of any physical camera or port (<lo>..<hi> mm): <hint>`
// when `value` is finite, > 0 and outside `range` (invalid values are the validity checks' business);
// nullopt otherwise. `field` names the library field (the CLI renames it to its flag).
inline std::optional<std::string> PlausibilityWarning(std::string_view field, double value,
                                                      const PlausibleRange& range) {
  if (!std::isfinite(value) || !(value > 0) || (value >= range.lo && value <= range.hi)) return std::nullopt;
  return fmt::format("{}: {:g} {} {} ({:g}..{:g} {}): {}", field, value, range.unit, kImplausiblePhrase, range.lo,
                     range.hi, range.unit, PlausibilityHint(value, range));
}

}  // namespace porthole
