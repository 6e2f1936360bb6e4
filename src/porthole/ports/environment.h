// The water and wavelength a port works in, resolved to the indices the tracer needs.
#pragma once

#include <optional>
#include <string>

#include "porthole/materials/materials.h"
#include "porthole/ports/port.h"

namespace porthole::ports {

struct Environment {
  std::string water = "seawater";          // a medium name for materials::Index()
  materials::Conditions conditions;        // λ, T, S, pressure (defaults: 546.07 nm, 20 °C, 35 ‰, 0)
  std::optional<double> water_index;       // forces a constant water index (e.g. the paper's 1.341)
  std::optional<double> glass_index;       // forces a constant port index (e.g. the paper's 1.5168)

  double WaterIndex() const;
  double GlassIndex(const std::string& material) const;
};

// The port placed at `ep_in_housing_mm` (default: the port's own default pupil) with its indices
// resolved from `env`. Throws InvalidInput for bad geometry, media or conditions.
PortSystem MakeSystem(const PortSpec& spec, const Environment& env,
                      const std::optional<Vec3>& ep_in_housing_mm = std::nullopt);

}  // namespace porthole::ports
