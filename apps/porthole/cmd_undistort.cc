// `porthole undistort --calibration CAL --images DIR --out DIR`: the images remapped to a virtual
// pinhole, its intrinsics for COLMAP, Metashape, OpenCV and nerfstudio, and behind a port the
// pinhole's residual against depth (undistort/undistort.h, docs/undistort.md). The CLI reads the
// options and files and prints; the library does the rest.
#include <fmt/format.h>

#include <cmath>
#include <filesystem>

#include "commands.h"
#include "common.h"
#include "porthole/core/error.h"
#include "porthole/core/field_names.h"
#include "porthole/undistort/run.h"

namespace porthole::cli {

void RegisterUndistort(CLI::App& app) {
  struct Options {
    std::string calibration, images, out, wd, interpolation = "linear", gnuplot = "gnuplot";
    std::optional<double> alpha;
    bool keep_focal = false, json = false, force = false;
    int threads = 0;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd =
      app.add_subcommand("undistort",
                         "Remap images to a virtual pinhole camera (central or behind a port), "
                         "with its intrinsics for COLMAP, Metashape, OpenCV and nerfstudio");
  cmd->add_option("--calibration", o->calibration,
                  "Calibration: any format porthole reads (porthole JSON of any model, OpenCV "
                  "YAML/XML, COLMAP, "
                  "mrcal, Metashape, calibmar), or porthole's refractive JSON (calibrate --port)")
      ->required();
  cmd->add_option("--images", o->images,
                  "Folder of images (png, jpg, tif; 8 or 16 bit, grey or colour)")
      ->required();
  cmd->add_option("--out", o->out,
                  "Output folder: images/ (same names and formats), cameras.txt (COLMAP PINHOLE), "
                  "camera.yml "
                  "(OpenCV), camera.xml (Metashape), transforms.json (nerfstudio), undistort.json; "
                  "behind a port "
                  "also residual.png/.dat/.gp")
      ->required();
  auto* alpha = cmd->add_option(
      "--alpha", o->alpha,
      "Field as cv2.getOptimalNewCameraMatrix: 0 only valid pixels (no black border), 1 every "
      "source pixel kept (default 0)");
  cmd->add_flag("--keep-focal", o->keep_focal, "Instead: the input's size and focal length")
      ->excludes(alpha);
  cmd->add_option(
      "--wd", o->wd,
      "Behind a port (required there): working distance in water, mm from the port's vertex, "
      "or a range NEAR:FAR (500:3000)");
  cmd->add_option("--interpolation", o->interpolation, "nearest, linear, cubic or lanczos")
      ->capture_default_str();
  cmd->add_option("--threads", o->threads, "Threads (0: every core)")->capture_default_str();
  cmd->add_option("--gnuplot", o->gnuplot, "gnuplot program for the residual figure")
      ->capture_default_str();
  cmd->add_flag("--json", o->json, "JSON summary on stdout");
  AddForceFlag(cmd, &o->force);
  cmd->footer(
      "The pinhole: central calibrations are undistorted exactly (each output pixel's ray "
      "projected by the\n"
      "lens model). Behind a port no pinhole is exact at every depth: the pinhole's centre is "
      "fitted to\n"
      "the port's rays over --wd, the map is exact at --wd (a range: the mean over five depths), "
      "and the\n"
      "residual against depth (0.5, 1, 2, 5 m) is written as residual.png and in undistort.json.\n"
      "nerfstudio's transforms.json holds the intrinsics and file paths, no poses "
      "(docs/undistort.md).\n"
      "Outputs are written whole; an existing one is replaced only with --force. See "
      "docs/undistort.md.");
  cmd->callback([o, cmd] {
    WithFieldNames(
        {{"alpha", "--alpha"},
         {"keep_focal", "--keep-focal"},
         {"wd_mm", "--wd"},
         {"threads", "--threads"},
         {"interpolation", "--interpolation"},
         {"calibration", "--calibration"},
         {"images", "--images"},
         {"out", "--out"},
         {"gnuplot", "--gnuplot"}},
        [&] {
          undistort::RunOptions ro;
          ro.calibration = o->calibration;
          ro.images = o->images;
          ro.out = o->out;
          ro.undistort.alpha = o->alpha;
          ro.undistort.keep_focal = o->keep_focal;
          ro.undistort.threads = o->threads;
          ro.undistort.interpolation =
              undistort::InterpolationFromName(o->interpolation, "interpolation");
          if (!o->wd.empty()) ro.undistort.wd_mm = undistort::ParseWd(o->wd);
          ro.force = o->force;
          ro.inputs = InputFiles(cmd, {"--out"});
          ro.gnuplot = o->gnuplot;
          ro.progress = [](const std::string& line) { fmt::print(stderr, "{}\n", line); };
          const Json summary = undistort::Run(ro);
          const bool refractive = summary["source"]["refractive"].get<bool>();
          const auto& p = summary["pinhole"];
          const auto num = [](const Json& v) { return v.is_number() ? v.get<double>() : NAN; };
          if (o->json) {
            fmt::print("{}\n", PrintableJson(summary));
            return;
          }
          std::string text = fmt::format(
              "{} images undistorted into {} ({:.1f} s)\n", summary["images"].size(),
              (std::filesystem::path(o->out) / "images").string(), num(summary["seconds"]));
          text += fmt::format(
              "pinhole {}x{} px: fx {:.3f} fy {:.3f} cx {:.3f} cy {:.3f} (pixel (0,0) = centre of "
              "the top-left pixel)\n",
              p["width_px"].get<int>(), p["height_px"].get<int>(), num(p["fx_px"]), num(p["fy_px"]),
              num(p["cx_px"]), num(p["cy_px"]));
          if (refractive) {
            const auto& c = p["centre_in_cam_mm"];
            text += fmt::format(
                "pinhole centre {:.2f}, {:.2f}, {:.2f} mm from the entrance pupil; residual "
                "(px):\n",
                num(c[0]), num(c[1]), num(c[2]));
            for (const auto& r : summary["residual"]) {
              text += fmt::format("  WD {:>6} mm: RMS {:.3f}, max {:.3f}\n", num(r["wd_mm"]),
                                  num(r["rms_px"]), num(r["max_px"]));
            }
          }
          text +=
              "intrinsics: cameras.txt (COLMAP), camera.yml (OpenCV), camera.xml (Metashape), "
              "transforms.json (nerfstudio)\n";
          fmt::print("{}", text);
        });
  });
}

}  // namespace porthole::cli
