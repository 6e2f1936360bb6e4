#include "porthole/catalogue/presets.h"

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <type_traits>
#include <variant>
#include <toml++/toml.h>

#include "porthole/core/error.h"
#include "porthole/core/nearest.h"
#include "porthole/core/input.h"
#include "porthole/materials/materials.h"

namespace porthole::catalogue {

// Defined in the generated presets_data.cc (CMake embeds presets/<kind>s/*.toml).
extern const std::vector<Preset> kBuiltinPresets;

const std::vector<Preset>& BuiltinPresets() { return kBuiltinPresets; }

std::string PresetDescription(const Preset& p) {
  try {
    const toml::table t = toml::parse(p.toml);
    return t["description"].value_or(std::string());
  } catch (const toml::parse_error&) {
    return "";
  }
}

namespace {

using ports::Vec3;

// Reads typed values from one TOML table, naming file, line and key in every error, and rejecting
// keys it was not asked about (a typo must not be silently ignored).
class Reader {
 public:
  Reader(const toml::table& t, std::string origin, std::string prefix)
      : t_(t), origin_(std::move(origin)), prefix_(std::move(prefix)) {}

  [[noreturn]] void Fail(const std::string& key, const std::string& rule, const toml::node* n = nullptr) const {
    // The key's own line when it is there (an enum with a bad value), else the table's.
    const toml::node* at = n ? n : t_.get(key);
    const auto& src = at ? at->source() : t_.source();
    throw InvalidInput(fmt::format("{}:{}: {}{}", origin_, src.begin.line, prefix_, key), rule);
  }
  const toml::node* Node(const std::string& key) {
    seen_.insert(key);
    return t_.get(key);
  }
  std::optional<double> OptDouble(const std::string& key) {
    const toml::node* n = Node(key);
    if (!n) return std::nullopt;
    const auto v = n->value<double>();
    if (!v || !std::isfinite(*v)) Fail(key, "must be a finite number", n);
    return v;
  }
  double Double(const std::string& key) {
    const auto v = OptDouble(key);
    if (!v) Missing(key);
    return *v;
  }
  // A required key is absent: when a key not yet read is a typo of it ("radus_mm"), that key is the
  // error, at its own line; else the table's line says what is required.
  [[noreturn]] void Missing(const std::string& key, const std::string& rule = "is required") const {
    for (const auto& [k, v] : t_) {
      const std::string name(k.str());
      if (!seen_.count(name) && EditDistance(name, key) <= TypoDistance(key)) {
        Fail(name, "unknown key (did you mean " + prefix_ + key + "?)", &v);
      }
    }
    Fail(key, rule);
  }
  // A whole number in [1, 1e6] (pixel counts): no silent truncation, no overflowing cast.
  int PositiveInt(const std::string& key) {
    const double v = Double(key);
    if (!(v >= 1 && v <= 1e6 && v == std::floor(v))) Fail(key, "must be a whole number from 1 to 1000000", Node(key));
    return static_cast<int>(v);
  }
  std::optional<std::string> OptString(const std::string& key) {
    const toml::node* n = Node(key);
    if (!n) return std::nullopt;
    const auto v = n->value<std::string>();
    if (!v) Fail(key, "must be a string", n);
    return v;
  }
  std::optional<Vec3> OptVec3(const std::string& key) {
    const toml::node* n = Node(key);
    if (!n) return std::nullopt;
    const toml::array* a = n->as_array();
    if (!a || a->size() != 3) Fail(key, "must be an array of three numbers [x, y, z]", n);
    Vec3 v;
    for (int i = 0; i < 3; ++i) {
      const auto x = (*a)[static_cast<std::size_t>(i)].value<double>();
      if (!x || !std::isfinite(*x)) Fail(key, "must be an array of three finite numbers", n);
      v[i] = *x;
    }
    return v;
  }
  Vec3 Vector3(const std::string& key) {
    const auto v = OptVec3(key);
    if (!v) Missing(key);
    return *v;
  }
  Reader Table(const std::string& key) {
    const toml::node* n = Node(key);
    if (!n) Missing(key, "is required: a table [" + prefix_ + key + "]");
    if (!n->is_table()) Fail(key, "is required: a table [" + prefix_ + key + "]", n);
    return Reader(*n->as_table(), origin_, prefix_ + key + ".");
  }
  // Every key of the table must have been read: the first that was not is named at its line, with
  // the nearest key this table knows when it looks like a typo of it.
  void RejectUnknown() const {
    const std::vector<std::string> known(seen_.begin(), seen_.end());
    for (const auto& [k, v] : t_) {
      const std::string name(k.str());
      if (seen_.count(name)) continue;
      const auto near = NearestNames(name, known, 1, TypoDistance(name));
      Fail(name, near.empty() ? "unknown key" : "unknown key (did you mean " + prefix_ + near[0] + "?)", &v);
    }
  }

 private:
  const toml::table& t_;
  std::string origin_, prefix_;
  std::set<std::string> seen_;
};

// Limits checked before toml++ sees the text (docs/robustness.md): toml++ builds nested tables
// recursively, so a 100 kB `[a.a.a...]` header overflowed the stack.
constexpr int kMaxTomlKeyParts = 16;   // a.b.c: 3 parts, over a header or a dotted key
constexpr int kMaxTomlNesting = 16;    // arrays and inline tables inside each other
constexpr std::size_t kMaxTomlLine = 64 * 1024;

// One pass over the text as TOML's lexer sees it (strings, comments, brackets), without recursion:
// throws InvalidInput(origin:line) when a key has too many dotted parts, values nest too deeply or a
// line is too long.
void CheckTomlLimits(std::string_view text, const std::string& origin) {
  std::size_t line = 1, line_start = 0;
  std::vector<char> open;  // '[' (array or header) and '{' (inline table) currently open
  int key_parts = 1;
  bool in_key = true;      // reading a key: at the start of a line, after '{' or ',' in an inline table
  bool header = false;
  auto fail = [&](const std::string& rule) { throw InvalidInput(fmt::format("{}:{}", origin, line), rule); };
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == '\n') {
      ++line;
      line_start = i + 1;
      if (open.empty()) {
        in_key = true;
        key_parts = 1;
        header = false;
      }
      continue;
    }
    if (i - line_start > kMaxTomlLine) fail(fmt::format("line longer than {} characters", kMaxTomlLine));
    if (c == '#') {
      while (i + 1 < text.size() && text[i + 1] != '\n') ++i;
    } else if (c == '"' || c == '\'') {
      const bool triple = text.substr(i, 3) == std::string(3, c);
      const std::string_view close = triple ? text.substr(i, 3) : text.substr(i, 1);
      i += close.size();
      while (i < text.size() && text.substr(i, close.size()) != close) {
        if (text[i] == '\n') {
          if (!triple) fail("string not closed on its line");
          ++line;
          line_start = i + 1;
        }
        if (c == '"' && text[i] == '\\') ++i;
        ++i;
      }
      if (i >= text.size()) fail("string not closed");
      i += close.size() - 1;
    } else if (in_key || header) {
      if (c == '.' && ++key_parts > kMaxTomlKeyParts) fail(fmt::format("a key has more than {} dotted parts", kMaxTomlKeyParts));
      if (c == '=') {
        in_key = false;
        key_parts = 1;
      } else if (c == '[' && open.empty() && !header) {
        header = true;  // [table] or [[array of tables]]
      } else if (c == ']' && header) {
        header = false;
        in_key = false;
      }
    } else if (c == '[' || c == '{') {
      open.push_back(c);
      if (open.size() > static_cast<std::size_t>(kMaxTomlNesting)) fail(fmt::format("values nested deeper than {} levels", kMaxTomlNesting));
      if (c == '{') in_key = true, key_parts = 1;
    } else if (c == ']' || c == '}') {
      if (!open.empty()) open.pop_back();
    } else if (c == ',' && !open.empty() && open.back() == '{') {
      in_key = true;
      key_parts = 1;
    }
  }
}

toml::table ParseToml(std::string_view text, const std::string& origin) {
  CheckTomlLimits(text, origin);
  try {
    return toml::parse(text, origin);
  } catch (const toml::parse_error& e) {
    throw InvalidInput(fmt::format("{}:{}", origin, e.source().begin.line), std::string(e.description()));
  }
}

// Runs a semantic check (ports::Validate, lens::Validate) whose errors name the field as
// "<origin>: <what>.<key path>", and names the TOML line of that key as the Reader does:
// "<origin>:<line>: <key path>". Errors about no single key pass through unchanged.
template <typename Check>
void CheckWithLine(const toml::table& t, const std::string& origin, const std::string& what, Check check) {
  try {
    check();
  } catch (const InvalidInput& e) {
    const std::string prefix = origin + ": " + what + ".";
    const std::string& field = e.field();
    if (field.rfind(prefix, 0) != 0) throw;
    const std::string key = field.substr(prefix.size());
    const toml::node* n = t.at_path(key).node();
    if (!n) throw;
    const std::string rule = std::string(e.what()).substr(field.size() + 2);
    throw InvalidInput(fmt::format("{}:{}: {}", origin, n->source().begin.line, key), rule);
  }
}

// The keys every preset file has: its name (default `default_name`), description and source.
template <typename T>
void ReadIdentity(Reader& r, const std::string& default_name, T* x) {
  x->name = r.OptString("name").value_or(default_name);
  x->description = r.OptString("description").value_or("");
  x->source = r.OptString("source").value_or("");
}

}  // namespace

ports::PortSpec ParsePortToml(std::string_view text, const std::string& origin) {
  const toml::table t = ParseToml(text, origin);
  Reader r(t, origin, "");
  ports::PortSpec p;
  ReadIdentity(r, std::filesystem::path(origin).stem().string(), &p);
  const std::string frame = r.OptString("frame").value_or("housing");
  if (frame == "housing") {
    p.frame = ports::PortFrame::kHousing;
  } else if (frame == "cam") {
    p.frame = ports::PortFrame::kCam;
  } else {
    r.Fail("frame", "must be \"housing\" (flange origin) or \"cam\" (entrance-pupil origin)");
  }
  if (const auto ep = r.OptVec3("entrance_pupil_mm")) p.default_ep_in_housing_mm = *ep;
  const auto type = r.OptString("type");
  const auto material = r.OptString("material");
  if (material) {
    try {
      materials::ModelOf(*material);  // an unknown glass is named at its line, not when first traced
    } catch (const InvalidInput& e) {
      r.Fail("material", std::string(e.what()).substr(e.field().size() + 2));
    }
  }
  // The shape named by `type`, its keys read in the order its Fields lists them (a key
  // "table.key" from [table], each table checked for unknown keys when its keys are read).
  std::optional<ports::PortShape> shape = type ? ports::ShapeNamed(*type) : std::nullopt;
  if (!shape) {
    const std::vector<std::string_view> names = ports::ShapeNames();
    std::string list;
    for (std::size_t i = 0; i < names.size(); ++i) {
      list += fmt::format("{}\"{}\"", i == 0 ? "" : i + 1 == names.size() ? " or " : ", ", names[i]);
    }
    if (!type) r.Missing("type", "is required: " + list);
    r.Fail("type", "must be " + list);
  }
  std::visit([&](auto& s) {
    if (material) s.material = *material;
    std::string table;
    std::optional<Reader> in;  // the table being read
    s.Fields(s, [&](std::string_view dotted, auto& value, ports::FieldUse use) {
      const std::size_t dot = dotted.find('.');
      const std::string at(dot == std::string_view::npos ? "" : dotted.substr(0, dot));
      const std::string key(dot == std::string_view::npos ? dotted : dotted.substr(dot + 1));
      if (at != table) {
        if (in) in->RejectUnknown();
        table = at;
        if (at.empty()) in.reset(); else in.emplace(r.Table(at));
      }
      Reader& rr = in ? *in : r;
      using V = std::decay_t<decltype(value)>;
      if constexpr (std::is_same_v<V, std::optional<double>>) {
        value = rr.OptDouble(key);
      } else if constexpr (std::is_same_v<V, double>) {
        if (use == ports::FieldUse::kRequired) {
          value = rr.Double(key);
        } else if (const auto v = rr.OptDouble(key)) {
          value = *v;
        }
      } else {
        static_assert(std::is_same_v<V, Vec3>);
        if (use == ports::FieldUse::kRequired) {
          value = rr.Vector3(key);
        } else if (const auto v = rr.OptVec3(key)) {
          value = *v;
        }
      }
    });
    if (in) in->RejectUnknown();
  }, *shape);
  p.shape = std::move(*shape);
  // [sigma]: the port's 1σ (interop::HousingSigmaToml writes calibmar's; docs/presets.md), in this
  // file's units, checked (finite, >= 0). The shell's (outer_radius_mm, inner_radius_mm,
  // thickness_mm, inner_offset_mm) are kept (ports::ShellSigma: calibrate --port --free-shell's
  // priors); the placement's and the indices' are not used by the optics.
  if (t.contains("sigma")) {
    Reader sigma = r.Table("sigma");
    for (const char* key : {"outer_radius_mm", "inner_radius_mm", "distance_mm", "thickness_mm", "n_glass", "n_water"}) {
      if (const auto v = sigma.OptDouble(key); v && *v < 0) sigma.Fail(key, "a sigma must be >= 0");
    }
    for (const char* key : {"center_mm", "normal", "inner_offset_mm"}) {
      if (const auto v = sigma.OptVec3(key); v && v->minCoeff() < 0) sigma.Fail(key, "a sigma must be >= 0");
    }
    p.sigma.outer_radius_mm = sigma.OptDouble("outer_radius_mm");
    p.sigma.inner_radius_mm = sigma.OptDouble("inner_radius_mm");
    p.sigma.thickness_mm = sigma.OptDouble("thickness_mm");
    p.sigma.inner_offset_mm = sigma.OptVec3("inner_offset_mm");
    sigma.RejectUnknown();
  }
  r.RejectUnknown();
  CheckWithLine(t, origin, "port", [&] { ports::Validate(p, origin + ": port"); });
  return p;
}

namespace {

// The TOML text of a built-in preset of `kind`, or of a file; `flag` names the option in errors.
std::pair<std::string, std::string> PresetOrFileText(const std::string& kind, const std::string& name_or_path,
                                                     const std::string& flag) {
  const bool is_path = name_or_path.find('/') != std::string::npos ||
                       (name_or_path.size() > 5 && name_or_path.ends_with(".toml"));
  if (!is_path) {
    std::string names;
    for (const Preset& p : BuiltinPresets()) {
      if (p.kind != kind) continue;
      if (p.name == name_or_path) return {std::string(p.toml), std::string(p.name)};
      names += (names.empty() ? "" : ", ") + std::string(p.name);
    }
    throw InvalidInput(flag, "unknown preset '" + name_or_path + "' (built-in: " + names +
                                 "; or give a path to a .toml file)");
  }
  return {ReadInputFile(name_or_path, flag, kMaxTextFileBytes), name_or_path};
}


}  // namespace

ports::PortSpec LoadPort(const std::string& name_or_path) {
  const auto [text, origin] = PresetOrFileText("port", name_or_path, "port");
  return ParsePortToml(text, origin);
}

lens::CameraBody LoadCamera(const std::string& name_or_path) {
  const auto [text, origin] = PresetOrFileText("camera", name_or_path, "camera");
  return ParseCameraToml(text, origin);
}

lens::LensSpec LoadLens(const std::string& name_or_path) {
  const auto [text, origin] = PresetOrFileText("lens", name_or_path, "lens");
  return ParseLensToml(text, origin);
}

namespace {

// The lens keys (docs/presets.md), from a lens file or a fixed-lens camera's [lens] table.
lens::LensSpec ReadLens(Reader& r, const std::string& default_name, bool fixed) {
  lens::LensSpec l;
  ReadIdentity(r, default_name, &l);
  if (fixed) {
    l.mount = "fixed";
  } else if (const toml::node* m = r.Node("mount"); m && m->is_array()) {
    // A lens made for several mounts: the pupil samples are for the first.
    for (const toml::node& e : *m->as_array()) {
      const auto v = e.value<std::string>();
      if (!v) r.Fail("mount", "must be a mount name or an array of them", &e);
      (l.mount.empty() ? l.mount : l.other_mounts.emplace_back()) = *v;
    }
    if (l.mount.empty()) r.Fail("mount", "must not be an empty array", m);
  } else {
    l.mount = r.OptString("mount").value_or("");
  }
  l.focal_length_mm = r.Double("focal_length_mm");
  l.f_number_min = r.Double("f_number_min");
  l.f_number_max = r.Double("f_number_max");
  l.min_focus_mm = r.Double("min_focus_mm");
  if (const toml::node* n = r.Node("min_focus_assumed")) l.min_focus_assumed = n->value_or(false);
  if (const toml::node* n = r.Node("pupil_estimated")) l.pupil_estimated = n->value_or(false);
  if (const auto proj = r.OptString("projection")) {
    const auto p = camera::ProjectionFromName(*proj);
    if (!p) {
      r.Fail("projection", "must be \"rectilinear\", \"equidistant\", \"equisolid\", \"stereographic\" or "
                           "\"orthographic\"", r.Node("projection"));
    }
    l.projection = *p;
  }
  if (const toml::node* n = r.Node("projection_estimated")) l.projection_estimated = n->value_or(false);
  if (const toml::node* n = r.Node("fixed_focus")) l.fixed_focus = n->value_or(false);
  // pupil_mm: the entrance pupil ahead of the sensor at infinity focus (as --pupil-mm), instead of
  // the table against the flange.
  const toml::node* pupil = r.Node("pupil");
  if (const auto ep = r.OptDouble("pupil_mm")) {
    if (pupil) r.Fail("pupil_mm", "give either pupil_mm or the pupil table, not both");
    if (!(*ep > 0)) r.Fail("pupil_mm", "must be > 0 (mm ahead of the sensor)");
    double ffd = 0;
    for (const lens::Mount& m : lens::KnownMounts()) {
      if (m.name == l.mount) ffd = m.flange_focal_distance_mm;
    }
    l.pupil.push_back({std::numeric_limits<double>::infinity(), *ep - ffd});
    r.RejectUnknown();
    return l;
  }
  if (!pupil) r.Missing("pupil", "is required: an array of {focus_mm, d_ep2f_mm} (or pupil_mm)");
  if (!pupil->is_array()) r.Fail("pupil", "is required: an array of {focus_mm, d_ep2f_mm} (or pupil_mm)", pupil);
  for (const toml::node& e : *pupil->as_array()) {
    const toml::table* et = e.as_table();
    if (!et) r.Fail("pupil", "entries must be tables {focus_mm = ..., d_ep2f_mm = ...}", &e);
    // focus_mm may be the TOML float inf; Reader's finite check does not apply to it.
    const auto fd = et->get("focus_mm") ? et->get("focus_mm")->value<double>() : std::nullopt;
    const auto d = et->get("d_ep2f_mm") ? et->get("d_ep2f_mm")->value<double>() : std::nullopt;
    if (!fd || !d) r.Fail("pupil", "each entry needs focus_mm and d_ep2f_mm numbers", &e);
    l.pupil.push_back({*fd, *d});
  }
  r.RejectUnknown();
  return l;
}

}  // namespace

lens::CameraBody ParseCameraToml(std::string_view text, const std::string& origin) {
  const toml::table t = ParseToml(text, origin);
  Reader r(t, origin, "");
  lens::CameraBody b;
  ReadIdentity(r, std::filesystem::path(origin).stem().string(), &b);
  b.mount = r.OptString("mount").value_or("");
  b.sensor.width_px = r.PositiveInt("width_px");
  b.sensor.height_px = r.PositiveInt("height_px");
  b.sensor.pixel_pitch_mm = r.Double("pixel_pitch_mm");
  if (b.mount == "fixed") {
    Reader lr = r.Table("lens");
    b.fixed_lens = ReadLens(lr, b.name, true);
  }
  r.RejectUnknown();
  CheckWithLine(t, origin, "camera", [&] { lens::Validate(b, origin + ": camera"); });
  return b;
}

lens::LensSpec ParseLensToml(std::string_view text, const std::string& origin) {
  const toml::table t = ParseToml(text, origin);
  Reader r(t, origin, "");
  lens::LensSpec l = ReadLens(r, std::filesystem::path(origin).stem().string(), false);
  CheckWithLine(t, origin, "lens", [&] { lens::Validate(l, origin + ": lens"); });
  return l;
}

// Numbers as the shortest text that reads back to the same double (a port converted from another
// tool's file round-trips exactly).
std::string PortToToml(const ports::PortSpec& p) {
  auto vec = [](const Vec3& v) { return fmt::format("[{}, {}, {}]", v.x(), v.y(), v.z()); };
  auto str = [](const std::string& s) {
    std::string out = "\"";
    for (char c : s) out += (c == '"' || c == '\\') ? std::string("\\") + c : std::string(1, c);
    return out + "\"";
  };
  std::string s;
  s += fmt::format("name = {}\ndescription = {}\nsource = {}\n", str(p.name), str(p.description), str(p.source));
  s += fmt::format("type = \"{}\"\nframe = \"{}\"\nmaterial = {}\n", p.KindName(),
                   p.frame == ports::PortFrame::kCam ? "cam" : "housing", str(p.material()));
  s += fmt::format("entrance_pupil_mm = {}\n", vec(p.default_ep_in_housing_mm));
  // The shape's keys (its Fields): the top-level ones, then each [table]'s; a std::optional only
  // when set.
  std::visit([&](const auto& shape) {
    std::vector<std::string> tables;
    std::string body;
    const auto write = [&](std::string_view dotted, const auto& value, ports::FieldUse) {
      const std::size_t dot = dotted.find('.');
      const std::string at(dot == std::string_view::npos ? "" : dotted.substr(0, dot));
      const std::string key(dot == std::string_view::npos ? dotted : dotted.substr(dot + 1));
      std::string* out = &s;
      if (!at.empty()) {
        if (tables.empty() || tables.back() != at) {
          tables.push_back(at);
          body += "\n[" + at + "]\n";
        }
        out = &body;
      }
      using V = std::decay_t<decltype(value)>;
      if constexpr (std::is_same_v<V, std::optional<double>>) {
        if (value) *out += fmt::format("{} = {}\n", key, *value);
      } else if constexpr (std::is_same_v<V, double>) {
        *out += fmt::format("{} = {}\n", key, value);
      } else {
        *out += fmt::format("{} = {}\n", key, vec(value));
      }
    };
    std::decay_t<decltype(shape)>::Fields(shape, write);
    s += body;
  }, p.shape);
  // The shell's σ (ports::ShellSigma) as the [sigma] table, when the port has any.
  const ports::ShellSigma& sg = p.sigma;
  if (!sg.Empty()) {
    s += "\n[sigma]\n";
    for (const auto& [key, v] : {std::pair{"outer_radius_mm", sg.outer_radius_mm},
                                 std::pair{"inner_radius_mm", sg.inner_radius_mm},
                                 std::pair{"thickness_mm", sg.thickness_mm}}) {
      if (v) s += fmt::format("{} = {}\n", key, *v);
    }
    if (sg.inner_offset_mm) s += fmt::format("inner_offset_mm = {}\n", vec(*sg.inner_offset_mm));
  }
  return s;
}

}  // namespace porthole::catalogue
