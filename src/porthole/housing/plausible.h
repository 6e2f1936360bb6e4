// The plausibility warnings of a housed camera (core/plausible.h): the values a plan, a flat-port
// analysis or a simulation rests on that lie outside what physical cameras, lenses and ports have.
// Each names the library field (pixel_pitch_mm, focal_length_mm, port.outer.radius_mm, …); the
// results carry them in `warnings` (plan, flat, simulate), so the CLI and Python say the same.
#pragma once

#include <string>
#include <variant>
#include <vector>

#include "porthole/core/plausible.h"
#include "porthole/housing/housed.h"

namespace porthole::housing {

inline void AddPlausibilityWarning(std::vector<std::string>* warnings, std::string_view field, double value,
                                   const PlausibleRange& range) {
  if (auto w = PlausibilityWarning(field, value, range)) warnings->push_back(std::move(*w));
}

// The port's values that have a plausible range (its shape's PlausibleValues: a dome's radii, a
// cylinder's radii and wall, a flat port's thickness), fields named `where`.<key> (the port file's
// keys).
inline std::vector<std::string> PortPlausibilityWarnings(const ports::PortSpec& port, const std::string& where = "port") {
  std::vector<std::string> w;
  std::visit([&](const auto& shape) {
    for (const ports::PlausibleValue& v : shape.PlausibleValues()) {
      AddPlausibilityWarning(&w, where + "." + std::string(v.key), v.value, v.range);
    }
  }, port.shape);
  return w;
}

// Pixel pitch, focal length, and the port's (PortPlausibilityWarnings).
inline std::vector<std::string> PlausibilityWarnings(const housing::HousedCamera& h) {
  std::vector<std::string> w;
  AddPlausibilityWarning(&w, "pixel_pitch_mm", h.camera.sensor.pixel_pitch_mm, kPixelPitchRange);
  AddPlausibilityWarning(&w, "focal_length_mm", h.lens.focal_length_mm, kFocalLengthRange);
  for (std::string& p : PortPlausibilityWarnings(h.port)) w.push_back(std::move(p));
  return w;
}

}  // namespace porthole::housing
