// `porthole target-sheet OUT.svg|OUT.pdf`: a printable sheet of circular coded targets (vector
// paths, a 100 mm scale bar, each target's ID) and the matching target field (ID → X, Y, Z mm),
// written next to it as OUT.field.txt unless --field names another file.
#include <fmt/format.h>

#include <algorithm>
#include <filesystem>

#include "commands.h"
#include "common.h"
#include "porthole/coded/sheet.h"
#include "porthole/core/atomic_file.h"
#include "porthole/core/error.h"

namespace porthole::cli {

void RegisterTargetSheet(CLI::App& app) {
  struct Options {
    std::string out, field, profile = "aicon";
    coded::SheetOptions sheet;
    bool json = false, force = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "target-sheet", "Write a printable sheet of coded circular targets (SVG or PDF) and its target field");
  cmd->add_option("out", o->out, "Sheet file: .svg or .pdf")->required();
  cmd->add_option("--field", o->field, "Target field file (ID X Y Z, mm); default: OUT with .field.txt");
  cmd->add_option("--bits", o->sheet.bits, "Code bits: 12 or 14")->capture_default_str();
  cmd->add_option("--profile", o->profile, "Numbering: aicon (ring 2r-3r) or metashape (ring 2.25r-3.5r)")
      ->capture_default_str();
  cmd->add_option("--radius-mm", o->sheet.radius_mm, "Radius of the central dot, mm")->capture_default_str();
  cmd->add_option("--paper", o->sheet.paper, "A5, A4, A3, A2, letter, legal or WxH in mm")->capture_default_str();
  cmd->add_flag("--landscape", o->sheet.landscape, "Turn the paper");
  cmd->add_flag("--white-on-black", o->sheet.white_on_black, "White targets on a black field");
  cmd->add_option("--first-id", o->sheet.first_id, "First target ID on the sheet")->capture_default_str();
  cmd->add_option("--count", o->sheet.count, "Number of targets (0: as many as fit)")->capture_default_str();
  cmd->add_option("--margin-mm", o->sheet.margin_mm, "Blank border, mm")->capture_default_str();
  cmd->add_flag("--json", o->json, "Print the summary as JSON");
  AddForceFlag(cmd, &o->force);
  cmd->callback([o] {
    namespace fs = std::filesystem;
    std::string ext = fs::path(o->out).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
    if (ext != ".svg" && ext != ".pdf") throw InvalidInput("out", "the sheet file must end in .svg or .pdf, got '" + o->out + "'");
    o->sheet.profile = coded::ParseProfile(o->profile);
    const coded::SheetLayout layout = coded::LayoutSheet(o->sheet);
    const std::string field_path =
        o->field.empty() ? fs::path(o->out).replace_extension(".field.txt").string() : o->field;
    if (fs::path(field_path) == fs::path(o->out)) throw InvalidInput("--field", "must differ from the sheet file");
    // Both texts are made before either file is written.
    const std::string sheet = ext == ".svg" ? coded::SheetSvg(layout) : coded::SheetPdf(layout);
    const std::string field = coded::FieldText(layout);
    const OutputRules rules{.force = o->force, .inputs = {}};
    CheckOutput(o->out, "out", rules);  // both checked before either is written
    CheckOutput(field_path, "--field", rules);
    WriteOutput(o->out, sheet, "out", rules);
    WriteOutput(field_path, field, "--field", rules);
    const auto& t = layout.targets;
    if (o->json) {
      const Json j = {{"sheet", o->out}, {"field", field_path}, {"profile", coded::ProfileName(o->sheet.profile)},
                      {"bits", o->sheet.bits}, {"radius_mm", o->sheet.radius_mm},
                      {"paper_mm", {layout.width_mm, layout.height_mm}}, {"pitch_mm", layout.pitch_mm},
                      {"targets", t.size()}, {"first_id", t.front().id}, {"last_id", t.back().id}};
      return fmt::print("{}\n", j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace));
    }
    fmt::print("wrote {} ({} {}-bit targets, IDs {}-{}, dot radius {} mm, pitch {} mm, {} x {} mm paper) and {}\n",
               o->out, coded::ProfileName(o->sheet.profile), o->sheet.bits, t.front().id, t.back().id,
               o->sheet.radius_mm, layout.pitch_mm, layout.width_mm, layout.height_mm, field_path);
    fmt::print("print at 100 % (no fit-to-page) and check the 100 mm scale bar with a ruler\n");
  });
}

}  // namespace porthole::cli
