#include "porthole/ports/describe.h"

#include <fmt/format.h>

namespace porthole::ports {
namespace {

using Json = nlohmann::ordered_json;

Json Vec3Json(const Vec3& v) { return Json::array({v.x(), v.y(), v.z()}); }

}  // namespace

Json DomePort::GeometryJson() const {
  return {{"outer", {{"center_mm", Vec3Json(outer.center_mm)}, {"radius_mm", outer.radius_mm}}},
          {"inner", {{"center_mm", Vec3Json(inner.center_mm)}, {"radius_mm", inner.radius_mm}}}};
}

Json FlatPort::GeometryJson() const {
  return {{"inner_point_mm", Vec3Json(inner_point_mm)}, {"normal", Vec3Json(normal)}, {"thickness_mm", thickness_mm}};
}

Json CylinderPort::GeometryJson() const {
  return {{"axis_point_mm", Vec3Json(axis_point_mm)},
          {"axis", Vec3Json(axis)},
          {"inner_radius_mm", inner_radius_mm},
          {"outer_radius_mm", outer_radius_mm}};
}

Json PortJson(const PortSystem& sys) {
  Json port = {{"name", sys.spec.name}, {"type", sys.spec.KindName()},
               {"material", sys.spec.material()}, {"glass_index", sys.n_glass}};
  port.update(std::visit([](const auto& shape) { return shape.GeometryJson(); }, sys.spec.shape));
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
