// `porthole undistort --calibration CAL --images DIR --out DIR`: the images remapped to a virtual
// pinhole, its intrinsics for COLMAP, Metashape, OpenCV and nerfstudio, and behind a port the
// pinhole's residual against depth (undistort/undistort.h, docs/undistort.md). The CLI reads the
// options and files and prints; the library does the rest.
#include <fmt/format.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <mutex>
#include <thread>

#include "commands.h"
#include "common.h"
#include "porthole/calib/detect.h"
#include "porthole/core/error.h"
#include "porthole/core/field_names.h"
#include "porthole/core/input.h"
#include "porthole/core/output.h"
#include "porthole/interop/interop.h"
#include "porthole/measure/rig_model.h"
#include "porthole/undistort/undistort.h"

namespace porthole::cli {
namespace {

namespace fs = std::filesystem;

double Seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// "1000" or "500:3000" (mm).
std::vector<double> ParseWd(const std::string& text) {
  std::vector<double> v;
  std::size_t start = 0;
  while (true) {
    const std::size_t colon = text.find(':', start);
    const std::string part = text.substr(start, colon == std::string::npos ? std::string::npos : colon - start);
    double x = NAN;
    try {
      std::size_t used = 0;
      x = std::stod(part, &used);
      if (used != part.size()) x = NAN;
    } catch (const std::exception&) {
    }
    if (!std::isfinite(x)) {
      throw InvalidInput("--wd", fmt::format("'{}': give a working distance in mm (1000) or a range NEAR:FAR (500:3000)", text));
    }
    v.push_back(x);
    if (colon == std::string::npos) break;
    start = colon + 1;
  }
  return v;
}

// The calibration as one camera: porthole's refractive JSON (a lens behind its port, or a rig of one
// camera) through measure's loader, every other file (any format interop reads) as a central camera.
measure::RigCamera LoadCalibration(const std::string& path) {
  const std::string text = ReadInputFile(path, "--calibration");
  nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_object() && (j.contains("port") || j.contains("rig"))) {
    const measure::Rig rig = measure::LoadCamera(path, "--calibration");
    if (rig.cameras.size() != 1) {
      throw InvalidInput("--calibration", fmt::format("a rig of {} cameras: give one camera's calibration",
                                                      rig.cameras.size()));
    }
    return rig.cameras[0];
  }
  measure::RigCamera c;
  c.name = "camera";
  c.camera = interop::ReadCalibrationFile(path, 1.0, "--calibration").camera();
  return c;
}

}  // namespace

void RegisterUndistort(CLI::App& app) {
  struct Options {
    std::string calibration, images, out, wd, interpolation = "linear", gnuplot = "gnuplot";
    std::optional<double> alpha;
    bool keep_focal = false, json = false, force = false;
    int threads = 0;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("undistort", "Remap images to a virtual pinhole camera (central or behind a port), "
                                                  "with its intrinsics for COLMAP, Metashape, OpenCV and nerfstudio");
  cmd->add_option("--calibration", o->calibration,
                  "Calibration: any format porthole reads (porthole JSON of any model, OpenCV YAML/XML, COLMAP, "
                  "mrcal, Metashape, calibmar), or porthole's refractive JSON (calibrate --port)")
      ->required();
  cmd->add_option("--images", o->images, "Folder of images (png, jpg, tif; 8 or 16 bit, grey or colour)")->required();
  cmd->add_option("--out", o->out,
                  "Output folder: images/ (same names and formats), cameras.txt (COLMAP PINHOLE), camera.yml "
                  "(OpenCV), camera.xml (Metashape), transforms.json (nerfstudio), undistort.json; behind a port "
                  "also residual.png/.dat/.gp")
      ->required();
  auto* alpha = cmd->add_option("--alpha", o->alpha,
                                "Field as cv2.getOptimalNewCameraMatrix: 0 only valid pixels (no black border), 1 every "
                                "source pixel kept (default 0)");
  cmd->add_flag("--keep-focal", o->keep_focal, "Instead: the input's size and focal length")->excludes(alpha);
  cmd->add_option("--wd", o->wd,
                  "Behind a port (required there): working distance in water, mm from the port's vertex, "
                  "or a range NEAR:FAR (500:3000)");
  cmd->add_option("--interpolation", o->interpolation, "nearest, linear, cubic or lanczos")->capture_default_str();
  cmd->add_option("--threads", o->threads, "Threads (0: every core)")->capture_default_str();
  cmd->add_option("--gnuplot", o->gnuplot, "gnuplot program for the residual figure")->capture_default_str();
  cmd->add_flag("--json", o->json, "JSON summary on stdout");
  AddForceFlag(cmd, &o->force);
  cmd->footer(
      "The pinhole: central calibrations are undistorted exactly (each output pixel's ray projected by the\n"
      "lens model). Behind a port no pinhole is exact at every depth: the pinhole's centre is fitted to\n"
      "the port's rays over --wd, the map is exact at --wd (a range: the mean over five depths), and the\n"
      "residual against depth (0.5, 1, 2, 5 m) is written as residual.png and in undistort.json.\n"
      "nerfstudio's transforms.json holds the intrinsics and file paths, no poses (docs/undistort.md).\n"
      "Outputs are written whole; an existing one is replaced only with --force. See docs/undistort.md.");
  cmd->callback([o, cmd] {
    WithFieldNames({{"alpha", "--alpha"}, {"keep_focal", "--keep-focal"}, {"wd_mm", "--wd"}, {"threads", "--threads"},
                    {"interpolation", "--interpolation"}, {"calibration", "--calibration"}},
                   [&] {
      const auto t0 = std::chrono::steady_clock::now();
      undistort::UndistortOptions uo;
      uo.alpha = o->alpha;
      uo.keep_focal = o->keep_focal;
      uo.threads = o->threads;
      uo.interpolation = undistort::InterpolationFromName(o->interpolation, "interpolation");
      if (!o->wd.empty()) uo.wd_mm = ParseWd(o->wd);
      const measure::RigCamera cam = LoadCalibration(o->calibration);
      undistort::Validate(uo, cam);
      const std::vector<std::string> images = calib::ListImages(o->images, "--images");
      // Every image the calibration's size, from its header, before anything is written.
      const auto& sensor = cam.camera.sensor;
      for (const auto& im : images) {
        const auto size = calib::ReadImageSize(im);
        if (!size) throw InvalidInput("--images", fmt::format("{}: not an image porthole reads (png, jpg, tif)", im));
        if (size->first != sensor.width_px || size->second != sensor.height_px) {
          throw InvalidInput("--images", fmt::format("{} is {}x{} px, the calibration's images {}x{}", im, size->first,
                                                     size->second, sensor.width_px, sensor.height_px));
        }
      }

      // Outputs: checked before any work (never an input, never an existing file without --force).
      std::vector<fs::path> inputs = InputFiles(cmd, {"--out"});
      for (const auto& im : images) inputs.emplace_back(im);
      const OutputRules rules{.force = o->force, .inputs = inputs};
      EnsureOutputDirectory(o->out, "--out");
      const fs::path out(o->out), image_dir = out / "images";
      EnsureOutputDirectory(image_dir.string(), "--out");
      std::vector<fs::path> image_out;
      for (const auto& im : images) {
        image_out.push_back(image_dir / fs::path(im).filename());
        CheckOutput(image_out.back(), "--out", rules);
      }
      const bool refractive = cam.shell.has_value();
      std::vector<std::string> files = {"cameras.txt", "camera.yml", "camera.xml", "transforms.json", "undistort.json"};
      if (refractive) files.insert(files.end(), {"residual.png", "residual.dat", "residual.gp"});
      for (const auto& f : files) CheckOutput(out / f, "--out", rules);

      const undistort::Undistorter u = undistort::Prepare(cam, uo);
      const auto tm = std::chrono::steady_clock::now();
      const cv::Mat map = undistort::BuildMap(u);
      const double map_s = Seconds(tm);
      fmt::print(stderr, "undistort: pinhole {}x{} fx {:.2f} fy {:.2f} cx {:.2f} cy {:.2f}; map built in {:.2f} s\n",
                 u.pinhole.width_px, u.pinhole.height_px, u.pinhole.fx, u.pinhole.fy, u.pinhole.cx, u.pinhole.cy, map_s);

      // The images, in parallel; the first error stops the others after their current image.
      std::mutex mu;
      std::exception_ptr error;
      std::atomic<int> next{0}, done{0};
      const int n = static_cast<int>(images.size());
      const int workers = std::max(1, std::min(n, o->threads > 0 ? o->threads
                                                               : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()))));
      const int cores = o->threads > 0 ? o->threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
      const int remap_threads = std::max(1, cores / workers);
      const auto work = [&] {
        for (int i = next++; i < n; i = next++) {
          {
            std::lock_guard<std::mutex> lock(mu);
            if (error) return;
          }
          try {
            const auto ti = std::chrono::steady_clock::now();
            const cv::Mat im = undistort::ReadImage(images[i], "--images");
            const auto& s = cam.camera.sensor;
            if (im.cols != s.width_px || im.rows != s.height_px) {
              throw InvalidInput("--images", fmt::format("{} is {}x{} px, the calibration's images {}x{}", images[i], im.cols,
                                                         im.rows, s.width_px, s.height_px));
            }
            const cv::Mat res = undistort::Remap(im, map, uo.interpolation, remap_threads);
            WriteOutput(image_out[i], undistort::EncodeLike(res, image_out[i].string(), "--out"), "--out", rules);
            const int k = ++done;
            std::lock_guard<std::mutex> lock(mu);
            fmt::print(stderr, "undistort: [{}/{}] {} ({:.2f} s)\n", k, n, fs::path(images[i]).filename().string(), Seconds(ti));
          } catch (...) {
            std::lock_guard<std::mutex> lock(mu);
            if (!error) error = std::current_exception();
            return;
          }
        }
      };
      std::vector<std::thread> pool;
      for (int k = 0; k < workers; ++k) pool.emplace_back(work);
      for (auto& t : pool) t.join();
      if (error) std::rethrow_exception(error);

      // The pinhole for the tools.
      const camera::Camera pin = undistort::PinholeCamera(u);
      WriteOutput(out / "cameras.txt", undistort::ColmapCamerasText(u), "--out", rules);
      WriteOutput(out / "camera.yml", interop::WriteCamera(pin, interop::Format::kOpenCVYaml, "--out").content, "--out", rules);
      WriteOutput(out / "camera.xml", interop::WriteCamera(pin, interop::Format::kMetashape, "--out").content, "--out", rules);
      std::vector<std::string> rel;
      for (const auto& p : image_out) rel.push_back("images/" + p.filename().string());
      WriteOutput(out / "transforms.json", PrintableJson(undistort::NerfstudioTransforms(u, rel)) + "\n", "--out", rules);
      Json summary = undistort::SummaryJson(u);
      summary["map_seconds"] = map_s;
      summary["images"] = rel;
      if (refractive) {
        const auto maps = undistort::ResidualMaps(u);
        summary["residual"] = undistort::ResidualJson(maps);
        const std::string data = undistort::ResidualData(maps);
        const std::string script = undistort::ResidualScript(maps, "residual.dat", "residual.png");
        // gnuplot draws in a private folder; the PNG is then written like every output.
        std::string tmpl = (out / ".undistort-gnuplot.XXXXXX").string();
        if (mkdtemp(tmpl.data()) == nullptr) throw InvalidInput("--out", fmt::format("{}: cannot create a folder", o->out));
        const fs::path tmp(tmpl);
        try {
          WriteFileAtomically(tmp / "residual.dat", data, "--out");
          WriteFileAtomically(tmp / "residual.gp", script, "--out");
          undistort::RunGnuplot(o->gnuplot, tmp.string(), "residual.gp");
          WriteOutput(out / "residual.png", ReadInputFile(tmp / "residual.png", "--out"), "--out", rules);
        } catch (...) {
          std::error_code ec;
          fs::remove_all(tmp, ec);
          throw;
        }
        std::error_code ec;
        fs::remove_all(tmp, ec);
        WriteOutput(out / "residual.dat", data, "--out", rules);
        WriteOutput(out / "residual.gp", script, "--out", rules);
      }
      summary["seconds"] = Seconds(t0);
      WriteOutput(out / "undistort.json", PrintableJson(summary) + "\n", "--out", rules);

      if (o->json) {
        fmt::print("{}\n", PrintableJson(summary));
        return;
      }
      std::string text = fmt::format("{} images undistorted into {} ({:.1f} s)\n", n, (out / "images").string(), Seconds(t0));
      text += fmt::format("pinhole {}x{} px: fx {:.3f} fy {:.3f} cx {:.3f} cy {:.3f} (pixel (0,0) = centre of the top-left pixel)\n",
                          u.pinhole.width_px, u.pinhole.height_px, u.pinhole.fx, u.pinhole.fy, u.pinhole.cx, u.pinhole.cy);
      if (refractive) {
        text += fmt::format("pinhole centre {:.2f}, {:.2f}, {:.2f} mm from the entrance pupil; residual (px):\n",
                            u.pinhole.centre_mm.x(), u.pinhole.centre_mm.y(), u.pinhole.centre_mm.z());
        for (const auto& r : summary["residual"]) {
          text += fmt::format("  WD {:>6} mm: RMS {:.3f}, max {:.3f}\n", r["wd_mm"].get<double>(),
                              r["rms_px"].is_number() ? r["rms_px"].get<double>() : NAN,
                              r["max_px"].is_number() ? r["max_px"].get<double>() : NAN);
        }
      }
      text += "intrinsics: cameras.txt (COLMAP), camera.yml (OpenCV), camera.xml (Metashape), transforms.json (nerfstudio)\n";
      fmt::print("{}", text);
    });
  });
}

}  // namespace porthole::cli
