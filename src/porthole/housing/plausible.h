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

// Pixel pitch, focal length, the port's radii (dome) or thickness (flat).
inline std::vector<std::string> PlausibilityWarnings(const housing::HousedCamera& h) {
  std::vector<std::string> w;
  AddPlausibilityWarning(&w, "pixel_pitch_mm", h.camera.sensor.pixel_pitch_mm, kPixelPitchRange);
  AddPlausibilityWarning(&w, "focal_length_mm", h.lens.focal_length_mm, kFocalLengthRange);
  if (const auto* d = std::get_if<ports::DomePort>(&h.port.shape)) {
    AddPlausibilityWarning(&w, "port.outer.radius_mm", d->outer.radius_mm, kDomeRadiusRange);
    AddPlausibilityWarning(&w, "port.inner.radius_mm", d->inner.radius_mm, kDomeRadiusRange);
  } else if (const auto* f = std::get_if<ports::FlatPort>(&h.port.shape)) {
    AddPlausibilityWarning(&w, "port.thickness_mm", f->thickness_mm, kPortThicknessRange);
  }
  return w;
}

}  // namespace porthole::housing
