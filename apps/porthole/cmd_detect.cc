// `porthole detect --images DIR --target SPEC`: find a calibration target in every image (OpenCV),
// report per image, optionally write one detections JSON per image (--out-dir) or print them all
// (--json). Unreadable images and images without the target are reported and skipped.
#include <fmt/format.h>

#include <filesystem>

#include "commands.h"
#include "common.h"
#include "porthole/calib/detect.h"
#include "porthole/core/atomic_file.h"
#include "porthole/core/error.h"

namespace porthole::cli {

void RegisterDetect(CLI::App& app) {
  struct Options {
    std::string images, target, out_dir;
    bool json = false, quiet = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "detect", "Detect a calibration target (chessboard, ChArUco, circle grid, coded targets) in images");
  cmd->add_option("--images", o->images, "Directory of images (jpg, png, tif, bmp, pgm)")
      ->required();
  cmd->add_option("--target", o->target,
                  "chessboard:COLSxROWS:SQUARE_MM (inner corners) | charuco:SQXxSQY:SQUARE_MM:"
                  "MARKER_MM[:DICT] | circles:COLSxROWS:MM | acircles:COLSxROWS:MM | "
                  "coded:BITS:DOT_RADIUS_MM[:aicon|metashape]")
      ->required();
  cmd->add_option("--out-dir", o->out_dir, "Write <image>.json detections into this directory (created if missing)");
  cmd->add_flag("--json", o->json, "Print all detections as one JSON set");
  cmd->add_flag("--quiet", o->quiet, "No progress on stderr");
  cmd->callback([o] {
    const auto target = calib::ParseTarget(o->target);
    if (!o->out_dir.empty()) EnsureOutputDirectory(o->out_dir, "--out-dir");
    const auto paths = calib::ListImages(o->images);
    const auto run = calib::DetectAll(paths, target, [&](const std::string& m) {
      if (!o->quiet) fmt::print(stderr, "detect: {}\n", m);
    });
    // File names need not be UTF-8 (a Latin-1 "é" from an old camera or card reader): JSON text
    // replaces invalid bytes with U+FFFD. Everything is serialised before the first file is written.
    constexpr auto kReplace = nlohmann::json::error_handler_t::replace;
    if (!o->out_dir.empty()) {
      std::vector<std::pair<std::filesystem::path, std::string>> files;
      for (const auto& d : run.detections) {
        files.emplace_back(std::filesystem::path(o->out_dir) / (std::filesystem::path(d.image).stem().string() + ".json"),
                           calib::DetectionsToJson(d, target).dump(1, ' ', false, kReplace) + "\n");
      }
      for (const auto& [file, text] : files) WriteFileAtomically(file, text, "--out-dir");
    }
    if (o->json) {
      return fmt::print("{}\n", calib::DetectionSetToJson(run.detections, run.skipped, target).dump(1, ' ', false, kReplace));
    }
    // Coded targets: ids are target IDs 1…N (id 0 is no point).
    const bool coded = target.kind == calib::TargetKind::kCoded;
    std::string text = fmt::format("target {} ({} {})\n{:<28} {:>7}  {}\n", target.ToString(),
                                   coded ? target.NumPoints() - 1 : target.NumPoints(), coded ? "targets" : "points",
                                   "image", "points", "status");
    for (const auto& d : run.detections) {
      text += fmt::format("{:<28} {:>7}  ok\n", d.image, d.ids.size());
    }
    for (const auto& s : run.skipped) text += fmt::format("{:<28} {:>7}  {}\n", s.image, "-", s.reason);
    text += fmt::format("{} of {} images hold the target\n", run.detections.size(), paths.size());
    fmt::print("{}", text);
  });
}

}  // namespace porthole::cli
