// Built-in presets (TOML files under presets/, compiled into the library) and the TOML schema of
// a user's own port file. The schema is documented in docs/presets.md.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "porthole/lens/lens.h"
#include "porthole/ports/port.h"

namespace porthole::catalogue {

struct Preset {
  std::string_view kind;  // "port", later "camera", "lens"
  std::string_view name;
  std::string_view toml;  // the file's text, comments included
};
const std::vector<Preset>& BuiltinPresets();

// The one-line description of a preset (its `description` key).
std::string PresetDescription(const Preset& p);

// A port from a built-in preset name or a path to a TOML file (anything containing '/' or ending in
// ".toml" is a path). Throws InvalidInput("port", ...) for an unknown name or unreadable file,
// and InvalidInput("<file>:<line>: <key>", ...) for a malformed or invalid file.
ports::PortSpec LoadPort(const std::string& name_or_path);

// Parses and validates a port TOML text; `origin` names it in error messages.
ports::PortSpec ParsePortToml(std::string_view text, const std::string& origin);

// A camera body or a lens from a built-in preset name or a TOML file, as LoadPort (field names
// "camera" and "lens" in errors). Schemas in docs/presets.md.
lens::CameraBody LoadCamera(const std::string& name_or_path);
lens::LensSpec LoadLens(const std::string& name_or_path);
lens::CameraBody ParseCameraToml(std::string_view text, const std::string& origin);
lens::LensSpec ParseLensToml(std::string_view text, const std::string& origin);

// The TOML text of a port (housing or cam frame as given); ParsePortToml(PortToToml(p)) == p.
std::string PortToToml(const ports::PortSpec& p);

}  // namespace porthole::catalogue
