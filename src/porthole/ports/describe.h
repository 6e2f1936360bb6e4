// The one JSON (and one text line) of a port and of a placed port system: what `porthole trace`,
// `virtual-image` and `simulate` print with --json, Python's PortSystem.describe() returns, and the
// refractive calibration's estimated port (calib/refractive.cc, `geometry`) holds. A shape's fields
// are its port-file fields (its Fields in port.h): a new shape needs nothing here.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "porthole/ports/environment.h"
#include "porthole/ports/port.h"

namespace porthole::ports {

// The shape's fields as its port file states them (Fields: "outer.radius_mm" as {"outer":
// {"radius_mm": …}}, an unset optional left out), mm, in the shape's frame.
nlohmann::ordered_json GeometryJson(const PortShape& shape);
// {name, type, material, glass_index, the shape's fields (mm, in the spec's frame),
// outer_vertex_z_mm}: the port of a placed system (housing frame).
nlohmann::ordered_json PortJson(const PortSystem& sys);
// {"port": PortJson, "water": {model, index, lambda_nm, temperature_c, salinity_psu,
// pressure_dbar}, "ep_in_housing_mm", "is_central"}.
nlohmann::ordered_json DescribeSystem(const PortSystem& sys, const Environment& env);
// "port NAME (TYPE, MATERIAL n = …); WATER n = … (… degC, … PSU, … dbar); … nm; entrance pupil (…) mm".
std::string DescribeSystemLine(const PortSystem& sys, const Environment& env);

}  // namespace porthole::ports
