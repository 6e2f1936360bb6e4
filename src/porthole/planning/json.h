// JSON of a plan and of a flat-port analysis: the one serialisation, shared by `porthole plan`,
// `porthole flat` and the Python module. Field names carry units (docs/conventions.md); infinite
// lengths are the string "inf", unavailable ones null.
#pragma once

#include <nlohmann/json.hpp>

#include "porthole/planning/flat.h"
#include "porthole/planning/plan.h"

namespace porthole::planning {

using Json = nlohmann::ordered_json;

Json SetupToJson(const Setup& setup, const ports::PortSystem& sys);
Json PlanToJson(const Setup& setup, const Plan& plan);
Json FlatToJson(const Setup& setup, const FlatAnalysis& flat);

}  // namespace porthole::planning
