#include "porthole/refraction/shell_json.h"

#include <cmath>

#include "porthole/core/error.h"

namespace porthole::refraction {
namespace {

double Number(const nlohmann::json& j, const std::string& key, const std::string& field) {
  if (!j.contains(key) || !j[key].is_number()) throw InvalidInput(field + "." + key, "must be a number");
  const double v = j[key].get<double>();
  if (!std::isfinite(v)) throw InvalidInput(field + "." + key, "must be finite");
  return v;
}

Vec3 Vector3(const nlohmann::json& j, const std::string& key, const std::string& field) {
  if (!j.contains(key) || !j[key].is_array() || j[key].size() != 3) {
    throw InvalidInput(field + "." + key, "must be a list of 3 numbers");
  }
  Vec3 v;
  for (int i = 0; i < 3; ++i) {
    if (!j[key][i].is_number()) throw InvalidInput(field + "." + key, "must be a list of 3 numbers");
    v(i) = j[key][i].get<double>();
    if (!std::isfinite(v(i))) throw InvalidInput(field + "." + key, "must be finite");
  }
  return v;
}

}  // namespace

nlohmann::ordered_json ShellToJson(const Shell& s) {
  using Json = nlohmann::ordered_json;
  Json j = {{"frame", "cam (origin at the entrance pupil, axes of the housing)"},
            {"n_glass", s.n_glass},
            {"n_water", s.n_water}};
  switch (s.kind) {
    case PortKind::kDome:
      j["outer_radius_mm"] = s.outer_radius_mm;
      j["inner_radius_mm"] = s.inner_radius_mm;
      j["inner_from_outer_mm"] = {s.inner_from_outer_mm.x(), s.inner_from_outer_mm.y(), s.inner_from_outer_mm.z()};
      j["rim_from_outer_z_mm"] = s.rim_from_outer_z_mm;
      break;
    case PortKind::kCylinder:
      j["outer_radius_mm"] = s.outer_radius_mm;
      j["inner_radius_mm"] = s.inner_radius_mm;
      j["rim_from_axis_z_mm"] = s.rim_from_outer_z_mm;
      break;
    case PortKind::kFlat:
      j["thickness_mm"] = s.thickness_mm;
      break;
  }
  return j;
}

Shell ShellFromJson(const std::string& kind, const nlohmann::json& s, const std::string& f) {
  Shell sh;
  sh.n_glass = Number(s, "n_glass", f);
  sh.n_water = Number(s, "n_water", f);
  if (kind == "dome") {
    sh.kind = PortKind::kDome;
    sh.outer_radius_mm = Number(s, "outer_radius_mm", f);
    sh.inner_radius_mm = Number(s, "inner_radius_mm", f);
    sh.inner_from_outer_mm = Vector3(s, "inner_from_outer_mm", f);
    sh.rim_from_outer_z_mm = Number(s, "rim_from_outer_z_mm", f);
    if (!(sh.outer_radius_mm > 0 && sh.inner_radius_mm > 0 &&
          sh.inner_from_outer_mm.norm() < sh.outer_radius_mm - sh.inner_radius_mm)) {
      throw InvalidInput(f, "not a dome: the inner sphere must lie inside the outer one");
    }
  } else if (kind == "cylinder") {
    sh.kind = PortKind::kCylinder;
    sh.outer_radius_mm = Number(s, "outer_radius_mm", f);
    sh.inner_radius_mm = Number(s, "inner_radius_mm", f);
    sh.rim_from_outer_z_mm = Number(s, "rim_from_axis_z_mm", f);
    if (!(sh.inner_radius_mm > 0 && sh.inner_radius_mm < sh.outer_radius_mm)) {
      throw InvalidInput(f, "not a cylinder: the inner radius must be positive and below the outer one");
    }
  } else if (kind == "flat") {
    sh.kind = PortKind::kFlat;
    sh.thickness_mm = Number(s, "thickness_mm", f);
    if (!(sh.thickness_mm > 0)) throw InvalidInput(f + ".thickness_mm", "must be > 0");
  } else {
    throw InvalidInput(f, "no shell of a port kind '" + kind + "' (dome, flat, cylinder)");
  }
  if (!(sh.n_glass >= 1 && sh.n_water >= 1)) throw InvalidInput(f, "indices must be >= 1");
  return sh;
}

}  // namespace porthole::refraction
