#include "porthole/refraction/shell_json.h"

#include <algorithm>
#include <cmath>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

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

// The Shell's field a `shell` JSON key names (ports::…Port::kShellJsonKeys): a number, or the
// inner centre's offset as three. The rim's key says what it is measured from (the outer centre,
// the axis).
double* NumberField(Shell& s, std::string_view key) {
  if (key == "outer_radius_mm") return &s.outer_radius_mm;
  if (key == "inner_radius_mm") return &s.inner_radius_mm;
  if (key == "rim_from_outer_z_mm" || key == "rim_from_axis_z_mm") return &s.rim_from_outer_z_mm;
  if (key == "thickness_mm") return &s.thickness_mm;
  return nullptr;
}
Vec3* VectorField(Shell& s, std::string_view key) {
  return key == "inner_from_outer_mm" ? &s.inner_from_outer_mm : nullptr;
}

// f(key) for the `shell` keys of the shape of `kind`.
template <typename F>
void ForEachKey(PortKind kind, F&& f) {
  using Shapes = ports::PortShape;
  [&]<std::size_t... I>(std::index_sequence<I...>) {
    ((static_cast<std::size_t>(kind) == I
          ? [&] { for (std::string_view k : std::variant_alternative_t<I, Shapes>::kShellJsonKeys) f(k); }()
          : void()),
     ...);
  }(std::make_index_sequence<std::variant_size_v<Shapes>>());
}

}  // namespace

nlohmann::ordered_json ShellToJson(const Shell& s) {
  using Json = nlohmann::ordered_json;
  Json j = {{"frame", "cam (origin at the entrance pupil, axes of the housing)"},
            {"n_glass", s.n_glass},
            {"n_water", s.n_water}};
  Shell& m = const_cast<Shell&>(s);  // read only
  ForEachKey(s.kind, [&](std::string_view key) {
    const std::string k(key);
    if (const double* v = NumberField(m, key)) {
      j[k] = *v;
    } else if (const Vec3* v = VectorField(m, key)) {
      j[k] = {v->x(), v->y(), v->z()};
    } else {
      throw InternalError("no Shell field for the shell key '" + k + "'");
    }
  });
  return j;
}

Shell ShellFromJson(const std::string& kind, const nlohmann::json& s, const std::string& f) {
  Shell sh;
  sh.n_glass = Number(s, "n_glass", f);
  sh.n_water = Number(s, "n_water", f);
  const std::vector<std::string_view> names = ports::ShapeNames();
  const auto it = std::find(names.begin(), names.end(), kind);
  if (it == names.end()) {
    std::string list;
    for (std::string_view n : names) list += (list.empty() ? "" : ", ") + std::string(n);
    throw InvalidInput(f, "no shell of a port kind '" + kind + "' (" + list + ")");
  }
  sh.kind = static_cast<PortKind>(it - names.begin());
  ForEachKey(sh.kind, [&](std::string_view key) {
    const std::string k(key);
    if (double* v = NumberField(sh, key)) {
      *v = Number(s, k, f);
    } else if (Vec3* v = VectorField(sh, key)) {
      *v = Vector3(s, k, f);
    } else {
      throw InternalError("no Shell field for the shell key '" + k + "'");
    }
  });
  if (!(sh.n_glass >= 1 && sh.n_water >= 1)) throw InvalidInput(f, "indices must be >= 1");
  // The shape's own rule (the inner surface inside the outer one, a positive thickness).
  ValidateShellValues(sh, ShellValues(sh), f);
  return sh;
}

}  // namespace porthole::refraction
