#include "porthole/ports/environment.h"

#include "porthole/core/error.h"

namespace porthole::ports {

double Environment::WaterIndex() const {
  if (water_index) {
    if (!(std::isfinite(*water_index) && *water_index >= 1)) {
      throw InvalidInput("water_index", "must be a finite number >= 1");
    }
    return *water_index;
  }
  return materials::Index(water, conditions);
}

double Environment::GlassIndex(const std::string& material) const {
  if (glass_index) {
    if (!(std::isfinite(*glass_index) && *glass_index >= 1)) {
      throw InvalidInput("glass_index", "must be a finite number >= 1");
    }
    return *glass_index;
  }
  return materials::Index(material, conditions);
}

PortSystem MakeSystem(const PortSpec& spec, const Environment& env,
                      const std::optional<Vec3>& ep_in_housing_mm) {
  return Place(spec, ep_in_housing_mm.value_or(spec.default_ep_in_housing_mm),
               env.GlassIndex(spec.material()), env.WaterIndex());
}

}  // namespace porthole::ports
