// `porthole detect --images DIR --target SPEC [--field FILE]`: find a calibration target in every
// image (OpenCV; a coded target field's uncoded dots matched from its decoded targets),
// report per image, optionally write one detections JSON per image (--out-dir) or print them all
// (--json). Unreadable images and images without the target are reported and skipped.
#include <fmt/format.h>

#include <filesystem>
#include <map>

#include "commands.h"
#include "common.h"
#include "frame_options.h"
#include "porthole/calib/detect.h"
#include "porthole/calib/frames.h"
#include "porthole/core/atomic_file.h"
#include "porthole/core/error.h"

namespace porthole::cli {

void RegisterDetect(CLI::App& app) {
  struct Options {
    std::string images, target, field, out_dir;
    bool json = false, quiet = false, force = false;
    calib::FrameOptions frames;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "detect", "Detect a calibration target (chessboard, ChArUco, circle grid, coded targets) in images");
  cmd->add_option("--images", o->images,
                  "A directory of images (jpg, png, tif, bmp, pgm), one image, or a video (any format of Debian's "
                  "FFmpeg: mp4, mov, mkv, avi; frames named f<index>, with their time in the JSON)")
      ->required();
  AddFrameOptions(cmd, &o->frames, /*for_calibration=*/false);
  cmd->add_option("--target", o->target,
                  "chessboard:COLSxROWS:SQUARE_MM (inner corners) | charuco:SQXxSQY:SQUARE_MM:"
                  "MARKER_MM[:DICT] | circles:COLSxROWS:MM | acircles:COLSxROWS:MM | "
                  "coded:BITS:DOT_RADIUS_MM[:aicon|metashape]")
      ->required();
  cmd->add_option("--field", o->field,
                  "Target field file (coded targets): 'id x_mm y_mm z_mm' lines, e.g. from target-sheet; IDs above "
                  "the profile's code count are uncoded dots, matched once the decoded targets give the view");
  cmd->add_option("--out-dir", o->out_dir, "Write <image>.json detections into this directory (created if missing)");
  cmd->add_flag("--json", o->json, "Print all detections as one JSON set");
  cmd->add_flag("--quiet", o->quiet, "No progress on stderr");
  AddForceFlag(cmd, &o->force);
  cmd->footer("Outputs: --out-dir writes <image>.json per image; an existing one is replaced only with --force, and "
              "never a file another command wrote (a render's ground truth pose_NNN.json, a calibration): give "
              "render's folder as --images and another folder as --out-dir.");
  cmd->callback([o, cmd] {
    auto target = calib::ParseTarget(o->target);
    if (!o->field.empty()) calib::LoadTargetField(o->field, &target, "--field");
    if (!o->out_dir.empty()) EnsureOutputDirectory(o->out_dir, "--out-dir");
    const calib::SourceKind kind = calib::ClassifySource(o->images, "--images");
    std::vector<std::string> paths;
    if (kind == calib::SourceKind::kDirectory) paths = calib::ListImages(o->images);
    if (kind == calib::SourceKind::kImage) paths = {o->images};
    OutputRules rules{.force = o->force, .inputs = InputFiles(cmd, {"--out-dir"})};
    rules.inputs.insert(rules.inputs.end(), paths.begin(), paths.end());
    if (kind == calib::SourceKind::kVideo) rules.inputs.push_back(o->images);
    const auto out_file = [&](const std::string& image) {
      return std::filesystem::path(o->out_dir) / (std::filesystem::path(image).stem().string() + ".json");
    };
    if (!o->out_dir.empty()) {  // before the long work: every file an image may write (a video's: below)
      std::map<std::filesystem::path, std::string> by_name;  // two images of one stem (a.png, a.jpg) would share a.json
      for (const auto& image : paths) {
        const auto file = out_file(image);
        if (const auto [it, fresh] = by_name.emplace(file, image); !fresh) {
          throw InvalidInput("--out-dir", "images " + it->second + " and " + image + " would both write " +
                                              file.string() + ": rename one");
        }
        CheckOutput(file, "--out-dir", rules, FileKind::kDetections);
      }
    }
    const calib::SourceRun source = calib::DetectSource(o->images, target, o->frames, [&](const std::string& m) {
      if (!o->quiet) fmt::print(stderr, "detect: {}\n", m);
    }, {}, "--images");
    const calib::DetectionRun& run = source.run;
    // File names need not be UTF-8 (a Latin-1 "é" from an old camera or card reader): JSON text
    // replaces invalid bytes with U+FFFD. Everything is serialised before the first file is written.
    constexpr auto kReplace = nlohmann::json::error_handler_t::replace;
    if (!o->out_dir.empty()) {
      std::vector<std::pair<std::filesystem::path, std::string>> files;
      for (std::size_t k = 0; k < run.detections.size(); ++k) {
        files.emplace_back(out_file(run.detections[k].image),
                           calib::DetectionRunImageJson(run, k, target).dump(1, ' ', false, kReplace) + "\n");
      }
      // Every file checked before the first is written: all or none.
      for (const auto& [file, text] : files) CheckOutput(file, "--out-dir", rules, KindOfText(text));
      for (const auto& [file, text] : files) WriteOutput(file, text, "--out-dir", rules);
    }
    if (o->json) {
      nlohmann::ordered_json j = calib::DetectionRunToJson(run, target);
      j["source"] = calib::FrameChoiceToJson(source.choice, run.detections);
      return fmt::print("{}\n", j.dump(1, ' ', false, kReplace));
    }
    // Coded targets: ids are target IDs 1…N (id 0 is no point); a field's uncoded dots are
    // counted apart (matched / in view).
    const bool coded = target.kind == calib::TargetKind::kCoded;
    const bool dots = calib::HasUncodedDots(target);
    const int n_targets = !target.field.empty() ? static_cast<int>(target.field.size())
                                                : coded ? target.NumPoints() - 1 : target.NumPoints();
    std::string text = fmt::format("target {}{} ({} {})\n{:<28} {:>7}  {}{}\n", target.ToString(),
                                   o->field.empty() ? "" : ", field " + o->field, n_targets,
                                   coded ? "targets" : "points", "image", "points", dots ? "uncoded  " : "", "status");
    coded::UncodedCounts sum;
    calib::CodedCounts coded_sum;
    for (std::size_t k = 0; k < run.detections.size(); ++k) {
      const auto& d = run.detections[k];
      if (run.coded[k]) {
        const coded::DetectionCounts& c = run.coded[k]->detector;
        coded::DetectionCounts& t = coded_sum.detector;
        t.partial += c.partial;
        t.no_ring += c.no_ring;
        t.unclear += c.unclear;
        t.impossible += c.impossible;
        t.duplicate += c.duplicate;
        t.over_limit += c.over_limit;
        coded_sum.not_in_target += run.coded[k]->not_in_target;
      }
      std::string col;
      if (dots) {
        const coded::UncodedCounts c = run.uncoded[k].value_or(coded::UncodedCounts{});
        col = fmt::format("{:>7}  ", fmt::format("{}/{}", c.matched, c.in_view));
        sum.in_view += c.in_view;
        sum.matched += c.matched;
        sum.not_found += c.not_found;
        sum.ambiguous += c.ambiguous;
        sum.rejected += c.rejected;
        sum.inconsistent += c.inconsistent;
      }
      const std::string name = d.frame_index >= 0 ? fmt::format("{} ({:.3f} s)", d.image, d.time_s) : d.image;
      text += fmt::format("{:<28} {:>7}  {}ok\n", name, d.ids.size(), col);
    }
    for (const auto& s : run.skipped) text += fmt::format("{:<28} {:>7}  {}{}\n", s.image, "-", dots ? "         " : "", s.reason);
    const bool video = source.choice.kind == calib::SourceKind::kVideo;
    if (video || o->frames.max_frames > 0) {
      text += calib::Describe(source.choice) + "\n";
    } else {
      text += fmt::format("{} of {} images hold the target\n", run.detections.size(), source.choice.searched);
    }
    if (coded) {  // what the coded detector skipped in those images, never given an ID
      const coded::DetectionCounts& c = coded_sum.detector;
      text += fmt::format("coded candidates skipped: {} cut by the frame, {} without a ring (plain dots, look-alikes), {} "
                          "unclear, {} impossible codes, {} duplicate IDs; {} decoded IDs not in the {}\n",
                          c.partial, c.no_ring, c.unclear, c.impossible, c.duplicate, coded_sum.not_in_target,
                          o->field.empty() ? "sheet" : "field");
      if (c.over_limit > 0) {
        text += fmt::format("coded candidates not tried: {} beyond the limit of candidates per image (noise or texture "
                            "that looks like dots; see coded_counts.over_limit)\n", c.over_limit);
      }
    }
    if (dots) {
      text += fmt::format("uncoded dots: {} matched of {} in view; {} not found, {} ambiguous, {} of the wrong size or "
                          "polarity, {} off their neighbours' pattern\n",
                          sum.matched, sum.in_view, sum.not_found, sum.ambiguous, sum.rejected, sum.inconsistent);
    }
    fmt::print("{}", text);
  });
}

}  // namespace porthole::cli
