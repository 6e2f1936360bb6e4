// `porthole presets`: the built-in presets, or the TOML text of one (to copy and edit).
#include <fmt/format.h>

#include "commands.h"
#include "common.h"
#include "porthole/core/error.h"
#include "porthole/catalogue/presets.h"

namespace porthole::cli {

void RegisterPresets(CLI::App& app) {
  struct Options {
    std::string name;
    bool json = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("presets", "List the built-in presets, or print one as TOML to copy and edit");
  cmd->add_option("name", o->name, "A preset to print in full");
  cmd->add_flag("--json", o->json, "JSON output for scripts");
  cmd->callback([o] {
    const auto& all = catalogue::BuiltinPresets();
    if (!o->name.empty()) {
      for (const catalogue::Preset& p : all) {
        if (p.name == o->name) {
          fmt::print("{}", p.toml);
          return;
        }
      }
      throw InvalidInput("name", "no preset called '" + o->name + "' (see 'porthole presets')");
    }
    if (o->json) {
      Json list = Json::array();
      for (const catalogue::Preset& p : all) {
        list.push_back({{"kind", p.kind}, {"name", p.name}, {"description", catalogue::PresetDescription(p)}});
      }
      fmt::print("{}\n", Json{{"presets", list}}.dump(2));
      return;
    }
    std::string text = fmt::format("{:<8} {:<24} {}\n", "kind", "name", "description");
    for (const catalogue::Preset& p : all) text += fmt::format("{:<8} {:<24} {}\n", p.kind, p.name, catalogue::PresetDescription(p));
    text += "\n'porthole presets NAME' prints one as TOML; edit it and pass the file with --port my-port.toml.\n";
    fmt::print("{}", text);
  });
}

}  // namespace porthole::cli
