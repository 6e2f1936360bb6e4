#include "porthole/ports/describe.h"

#include <fmt/format.h>

namespace porthole::ports {
namespace {

using Json = nlohmann::ordered_json;

Json Vec3Json(const Vec3& v) { return Json::array({v.x(), v.y(), v.z()}); }

}  // namespace

// The shape's port-file fields (its Fields, in their order; "table.key" nested as in the file; an
// unset optional left out), mm.
Json GeometryJson(const PortShape& shape) {
  Json out = Json::object();
  std::visit(
      [&](const auto& p) {
        p.Fields(p, [&](std::string_view dotted, const auto& value, FieldUse) {
          using V = std::decay_t<decltype(value)>;
          const auto dot = dotted.find('.');
          Json& at = dot == std::string_view::npos ? out : out[std::string(dotted.substr(0, dot))];
          const std::string key(dot == std::string_view::npos ? dotted : dotted.substr(dot + 1));
          if constexpr (std::is_same_v<V, std::optional<double>>) {
            if (value) at[key] = *value;
          } else if constexpr (std::is_same_v<V, double>) {
            at[key] = value;
          } else {
            static_assert(std::is_same_v<V, Vec3>);
            at[key] = Vec3Json(value);
          }
        });
      },
      shape);
  return out;
}

Json PortJson(const PortSystem& sys) {
  Json port = {{"name", sys.spec.name}, {"type", sys.spec.KindName()},
               {"material", sys.spec.material()}, {"glass_index", sys.n_glass}};
  port.update(GeometryJson(sys.spec.shape));
  port["outer_vertex_z_mm"] = sys.OuterVertexZ();
  return port;
}

Json DescribeSystem(const PortSystem& sys, const Environment& env) {
  Json water = {{"model", env.water_index ? "constant" : env.water},
                {"index", sys.n_water},
                {"lambda_nm", env.conditions.lambda_nm},
                {"temperature_c", env.conditions.temperature_c},
                {"salinity_psu", env.conditions.salinity_psu},
                {"pressure_dbar", env.conditions.pressure_dbar}};
  return Json{{"port", PortJson(sys)}, {"water", water}, {"ep_in_housing_mm", Vec3Json(sys.ep_in_housing_mm)},
              {"is_central", sys.IsCentral()}};
}

std::string DescribeSystemLine(const PortSystem& sys, const Environment& env) {
  const auto& ep = sys.ep_in_housing_mm;
  const std::string water = env.water_index ? fmt::format("water n = {:.5f} (fixed)", sys.n_water)
                                            : fmt::format("{} n = {:.5f} ({:g} degC, {:g} PSU, {:g} dbar)",
                                                          env.water, sys.n_water, env.conditions.temperature_c,
                                                          env.conditions.salinity_psu, env.conditions.pressure_dbar);
  return fmt::format("port {} ({}, {} n = {:.5f}); {}; {:g} nm; entrance pupil ({:g}, {:g}, {:g}) mm",
                     sys.spec.name, sys.spec.KindName(), sys.spec.material(), sys.n_glass, water,
                     env.conditions.lambda_nm, ep.x(), ep.y(), ep.z());
}

}  // namespace porthole::ports
