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
#include "porthole/measure/rig_model.h"
#include "porthole/undistort/run.h"

namespace porthole::cli {

namespace {

// The text summary of one camera's run.
std::string Describe(const Json& summary, const std::string& images_dir) {
  const auto num = [](const Json& v) { return v.is_number() ? v.get<double>() : NAN; };
  const auto& p = summary["pinhole"];
  std::string text = fmt::format("{} images undistorted into {} ({:.1f} s)\n",
                                 summary["images"].size(), images_dir, num(summary["seconds"]));
  text += fmt::format(
      "pinhole {}x{} px: fx {:.3f} fy {:.3f} cx {:.3f} cy {:.3f} "
      "(pixel (0,0) = centre of the top-left pixel)\n",
      p["width_px"].get<int>(), p["height_px"].get<int>(), num(p["fx_px"]), num(p["fy_px"]),
      num(p["cx_px"]), num(p["cy_px"]));
  if (summary["source"]["refractive"].get<bool>()) {
    const auto& c = p["centre_in_cam_mm"];
    text += fmt::format(
        "pinhole centre {:.2f}, {:.2f}, {:.2f} mm from the entrance pupil; "
        "residual (px):\n",
        num(c[0]), num(c[1]), num(c[2]));
    for (const auto& r : summary["residual"]) {
      text += fmt::format("  WD {:>6} mm: RMS {:.3f}, max {:.3f}\n", num(r["wd_mm"]),
                          num(r["rms_px"]), num(r["max_px"]));
    }
  }
  return text;
}

// A rig camera's folder name: its name (without a ".json" its detections file gave it) when that
// is a plain file name, else camera<k>.
std::string FolderOf(std::string name, std::size_t k) {
  if (name.size() > 5 && name.compare(name.size() - 5, 5, ".json") == 0)
    name.resize(name.size() - 5);
  const bool plain =
      !name.empty() && name.find_first_of("/\\") == std::string::npos && name[0] != '.';
  return plain ? name : fmt::format("camera{}", k);
}

}  // namespace

void RegisterUndistort(CLI::App& app) {
  struct Options {
    std::string calibration, rig, out, wd, interpolation = "linear", gnuplot = "gnuplot";
    std::vector<std::string> images;
    std::optional<double> alpha;
    bool keep_focal = false, json = false, force = false;
    int threads = 0;
    int every = 1;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd =
      app.add_subcommand("undistort",
                         "Remap images to a virtual pinhole camera (central or behind a port), "
                         "with its intrinsics for COLMAP, Metashape, OpenCV and nerfstudio");
  auto* cal = cmd->add_option(
      "--calibration", o->calibration,
      "Calibration: any format porthole reads (porthole JSON of any model, OpenCV YAML/XML, "
      "COLMAP, mrcal, Metashape, calibmar), or porthole's refractive JSON (calibrate --port)");
  cmd->add_option("--rig", o->rig,
                  "Or a rig calibration (calibrate with one --images per camera): each camera's "
                  "images into OUT/<camera>/, one --images per camera in the rig's order")
      ->excludes(cal);
  cmd->add_option("--images", o->images,
                  "Folder of images (png, jpg, tif; 8 or 16 bit, grey or colour), one image, or a video "
                  "(its frames written as images/f<index>.png, index and time in undistort.json); with "
                  "--rig one per camera")
      ->required();
  cmd->add_option("--every", o->every, "Every N-th image or video frame")->check(CLI::Range(1, 1000000));
  cmd->add_option("--out", o->out,
                  "Output folder: images/ (same names and formats), cameras.txt (COLMAP PINHOLE), "
                  "camera.yml (OpenCV), camera.xml (Metashape), transforms.json (nerfstudio), "
                  "undistort.json; behind a port also residual.png/.dat/.gp")
      ->required();
  auto* alpha = cmd->add_option(
      "--alpha", o->alpha,
      "Field as cv2.getOptimalNewCameraMatrix: 0 only valid pixels (no black border), 1 every "
      "source pixel kept (default 0)");
  cmd->add_flag("--keep-focal", o->keep_focal, "Instead: the input's size and focal length")
      ->excludes(alpha);
  cmd->add_option("--wd", o->wd,
                  "Behind a port (required there): working distance in water, mm from the port's "
                  "vertex, or a range NEAR:FAR (500:3000)");
  cmd->add_option("--interpolation", o->interpolation, "nearest, linear, cubic or lanczos")
      ->capture_default_str();
  cmd->add_option("--threads", o->threads, "Threads (0: every core)")->capture_default_str();
  cmd->add_option("--gnuplot", o->gnuplot, "gnuplot program for the residual figure")
      ->capture_default_str();
  cmd->add_flag("--json", o->json, "JSON summary on stdout");
  AddForceFlag(cmd, &o->force);
  cmd->footer(
      "The pinhole: central calibrations are undistorted exactly (each output pixel's ray\n"
      "projected by the lens model). Behind a port no pinhole is exact at every depth: the\n"
      "pinhole's centre is fitted to the port's rays over --wd, the map is exact at --wd (a "
      "range:\n"
      "the mean over five depths), and the residual against depth (0.5, 1, 2, 5 m) is written as\n"
      "residual.png and in undistort.json. nerfstudio's transforms.json holds the intrinsics and\n"
      "file paths, no poses. Outputs are written whole; an existing one is replaced only with\n"
      "--force. See docs/undistort.md.");
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
         {"gnuplot", "--gnuplot"},
         {"every", "--every"}},
        [&] {
          undistort::RunOptions ro;
          ro.undistort.alpha = o->alpha;
          ro.undistort.keep_focal = o->keep_focal;
          ro.undistort.threads = o->threads;
          ro.undistort.interpolation =
              undistort::InterpolationFromName(o->interpolation, "interpolation");
          if (!o->wd.empty()) ro.undistort.wd_mm = undistort::ParseWd(o->wd);
          ro.force = o->force;
          ro.inputs = InputFiles(cmd, {"--out"});
          ro.gnuplot = o->gnuplot;
          ro.every = o->every;
          ro.progress = [](const std::string& line) { fmt::print(stderr, "{}\n", line); };
          namespace fs = std::filesystem;
          if (o->rig.empty()) {
            if (o->calibration.empty())
              throw InvalidInput("--calibration", "give a calibration (or --rig)");
            if (o->images.size() != 1) {
              throw InvalidInput("--images",
                                 "one folder with --calibration (one per camera goes with --rig)");
            }
            ro.calibration = o->calibration;
            ro.images = o->images[0];
            ro.out = o->out;
            const Json summary = undistort::Run(ro);
            if (o->json) {
              fmt::print("{}\n", PrintableJson(summary));
              return;
            }
            fmt::print(
                "{}intrinsics: cameras.txt (COLMAP), camera.yml (OpenCV), camera.xml "
                "(Metashape), transforms.json (nerfstudio)\n",
                Describe(summary, (fs::path(o->out) / "images").string()));
            return;
          }
          // A rig: each camera on its own, in its own frame, into OUT/<camera>/.
          const measure::Rig rig = measure::LoadRig(o->rig, "--rig");
          if (o->images.size() != rig.cameras.size()) {
            std::string names;
            for (const auto& c : rig.cameras) names += (names.empty() ? "" : ", ") + c.name;
            throw InvalidInput("--images",
                               fmt::format("{} folders for the rig's {} cameras ({}): one "
                                           "per camera, in that order",
                                           o->images.size(), rig.cameras.size(), names));
          }
          // Every camera's calibration, images and outputs checked before the first one runs.
          const auto options_of = [&](std::size_t k) {
            undistort::RunOptions rk = ro;
            rk.camera = rig.cameras[k];
            rk.calibration = o->rig;
            rk.images = o->images[k];
            rk.out = (fs::path(o->out) / FolderOf(rig.cameras[k].name, k)).string();
            return rk;
          };
          for (std::size_t k = 0; k < rig.cameras.size(); ++k) {
            undistort::RunOptions check = options_of(k);
            check.check_only = true;
            check.progress = nullptr;
            undistort::Run(check);
          }
          Json all;
          all["rig"] = o->rig;
          all["cameras"] = Json::array();
          std::string text;
          for (std::size_t k = 0; k < rig.cameras.size(); ++k) {
            const undistort::RunOptions rk = options_of(k);
            Json summary = undistort::Run(rk);
            summary["camera"] = rig.cameras[k].name;
            summary["out"] = rk.out;
            text += fmt::format("camera {}:\n{}", rig.cameras[k].name,
                                Describe(summary, (fs::path(rk.out) / "images").string()));
            all["cameras"].push_back(summary);
          }
          if (o->json) {
            fmt::print("{}\n", PrintableJson(all));
            return;
          }
          fmt::print(
              "{}intrinsics per camera: cameras.txt (COLMAP), camera.yml (OpenCV), camera.xml "
              "(Metashape), transforms.json (nerfstudio)\n",
              text);
        });
  });
}

}  // namespace porthole::cli
