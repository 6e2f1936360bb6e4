// `porthole undistort` as one library call (run.h, docs/undistort.md).
#include "porthole/undistort/run.h"

#include <fmt/format.h>
#include <stdlib.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <exception>
#include <mutex>
#include <thread>

#include "porthole/calib/detect.h"
#include "porthole/calib/frames.h"
#include <opencv2/videoio.hpp>
#include "porthole/core/error.h"
#include "porthole/core/gnuplot.h"
#include "porthole/core/input.h"
#include "porthole/core/output.h"
#include "porthole/interop/interop.h"

namespace porthole::undistort {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

double Seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Creates `dir` (and its parents) when missing; refuses a file in its place or a folder not
// writable.
void EnsureDirectory(const fs::path& dir, const std::string& field) {
  if (dir.empty()) throw InvalidInput(field, "give a directory");
  std::error_code ec;
  if (fs::exists(dir, ec)) {
    if (!fs::is_directory(dir, ec))
      throw InvalidInput(field, dir.string() + " exists and is not a directory");
  } else if (!fs::create_directories(dir, ec) && !fs::is_directory(dir)) {
    throw InvalidInput(field, fmt::format("cannot create {}: {}", dir.string(),
                                          ec ? ec.message() : "unknown error"));
  }
  if (access(dir.c_str(), W_OK | X_OK) != 0)
    throw InvalidInput(field, dir.string() + " is not writable");
}


std::string Dump(const Json& j) {
  return j.dump(2, ' ', false, Json::error_handler_t::replace) + "\n";
}

}  // namespace

measure::RigCamera LoadCalibration(const std::string& path, const std::string& field) {
  const std::string text = ReadInputFile(path, field);
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (j.is_object() && (j.contains("port") || j.contains("rig"))) {
    const measure::Rig rig = measure::LoadCamera(path, field);
    if (rig.cameras.size() != 1) {
      throw InvalidInput(field, fmt::format("a rig of {} cameras: give one camera's calibration",
                                            rig.cameras.size()));
    }
    return rig.cameras[0];
  }
  measure::RigCamera c;
  c.name = "camera";
  c.camera = interop::ReadCalibrationFile(path, 1.0, field).camera();
  return c;
}

std::vector<double> ParseWd(const std::string& text, const std::string& field) {
  std::vector<double> v;
  std::size_t start = 0;
  while (true) {
    const std::size_t colon = text.find(':', start);
    const std::string part =
        text.substr(start, colon == std::string::npos ? std::string::npos : colon - start);
    double x = NAN;
    try {
      std::size_t used = 0;
      x = std::stod(part, &used);
      if (used != part.size()) x = NAN;
    } catch (const std::exception&) {
    }
    if (!std::isfinite(x)) {
      throw InvalidInput(
          field,
          fmt::format("'{}': give a working distance in mm (1000) or a range NEAR:FAR (500:3000)",
                      text));
    }
    v.push_back(x);
    if (colon == std::string::npos) break;
    start = colon + 1;
  }
  return v;
}

Json Run(const RunOptions& o) {
  const auto say = [&](const std::string& line) {
    if (o.progress) o.progress(line);
  };
  const auto t0 = std::chrono::steady_clock::now();
  const UndistortOptions& uo = o.undistort;
  const measure::RigCamera cam =
      o.camera ? *o.camera : LoadCalibration(o.calibration, "calibration");
  Validate(uo, cam);
  if (o.every < 1) throw InvalidInput("every", "a whole number >= 1");
  // A folder, one image, or a video (calib/frames.h): a video's frames are written as
  // images/f<index, 6 digits>.png, each with its index and time in undistort.json.
  const calib::SourceKind kind = calib::ClassifySource(o.images, "images");
  std::vector<std::string> images;
  if (kind == calib::SourceKind::kDirectory) images = calib::ListImages(o.images, "images");
  if (kind == calib::SourceKind::kImage) images = {o.images};
  if (kind == calib::SourceKind::kImage && o.every != 1) throw InvalidInput("every", "for a folder or a video");
  if (kind == calib::SourceKind::kDirectory && o.every > 1) {
    std::vector<std::string> some;
    for (std::size_t k = 0; k < images.size(); k += o.every) some.push_back(images[k]);
    images = std::move(some);
  }
  cv::VideoCapture video;
  long video_frames = 0;
  double fps = 0;
  const auto& sensor = cam.camera.sensor;
  if (kind == calib::SourceKind::kVideo) {
    try {
      video.open(o.images, cv::CAP_FFMPEG);
    } catch (const cv::Exception&) {
    }
    if (!video.isOpened()) {
      throw InvalidInput("images", o.images + ": not a directory, an image (png, jpg, tif) or a video OpenCV's "
                                              "FFmpeg backend can open");
    }
    const long w = std::lround(video.get(cv::CAP_PROP_FRAME_WIDTH)), h = std::lround(video.get(cv::CAP_PROP_FRAME_HEIGHT));
    if (w != sensor.width_px || h != sensor.height_px) {
      throw InvalidInput("images", fmt::format("{}: frames of {}x{} px, the calibration's images {}x{}", o.images, w, h,
                                               sensor.width_px, sensor.height_px));
    }
    video_frames = std::max<long>(0, std::lround(video.get(cv::CAP_PROP_FRAME_COUNT)));
    fps = video.get(cv::CAP_PROP_FPS);
    if (!(fps > 0 && std::isfinite(fps))) fps = 0;
  }
  // Every image the calibration's size, from its header, before anything is written.
  for (const auto& im : images) {
    const auto size = calib::ReadImageSize(im);
    if (!size)
      throw InvalidInput("images",
                         fmt::format("{}: not an image porthole reads (png, jpg, tif)", im));
    if (size->first != sensor.width_px || size->second != sensor.height_px) {
      throw InvalidInput(
          "images", fmt::format("{} is {}x{} px, the calibration's images {}x{}", im, size->first,
                                size->second, sensor.width_px, sensor.height_px));
    }
  }

  // Outputs: checked before any work (never an input, never an existing file without --force).
  std::vector<fs::path> inputs = o.inputs;
  if (!o.calibration.empty()) inputs.emplace_back(o.calibration);
  for (const auto& im : images) inputs.emplace_back(im);
  const OutputRules rules{.force = o.force, .inputs = inputs};
  EnsureDirectory(o.out, "out");
  const fs::path out(o.out), image_dir = out / "images";
  EnsureDirectory(image_dir, "out");
  std::vector<fs::path> image_out;
  for (const auto& im : images) {
    image_out.push_back(image_dir / fs::path(im).filename());
    CheckOutput(image_out.back(), "out", rules);
  }
  const auto frame_file = [&](long index) { return image_dir / fmt::format("f{:06d}.png", index); };
  for (long k = 0; k < video_frames; k += o.every) CheckOutput(frame_file(k), "out", rules);
  const bool refractive = cam.shell.has_value();
  std::vector<std::string> files = {"cameras.txt", "camera.yml", "camera.xml", "transforms.json",
                                    "undistort.json"};
  if (refractive) files.insert(files.end(), {"residual.png", "residual.dat", "residual.gp"});
  for (const auto& f : files) CheckOutput(out / f, "out", rules);
  if (refractive && !Executable(o.gnuplot)) {
    throw InvalidInput(
        "gnuplot",
        fmt::format("'{}' not found: the residual figure needs gnuplot (Debian's gnuplot-nox)",
                    o.gnuplot));
  }

  const Undistorter u = Prepare(cam, uo);
  if (o.check_only) return SummaryJson(u);
  const auto tm = std::chrono::steady_clock::now();
  const cv::Mat map = BuildMap(u);
  const double map_s = Seconds(tm);
  say(fmt::format(
      "undistort: pinhole {}x{} fx {:.2f} fy {:.2f} cx {:.2f} cy {:.2f}; map built in {:.2f} s",
      u.pinhole.width_px, u.pinhole.height_px, u.pinhole.fx, u.pinhole.fy, u.pinhole.cx,
      u.pinhole.cy, map_s));

  // The images, in parallel; the first error stops the others after their current image.
  std::mutex mu;
  std::exception_ptr error;
  std::atomic<int> next{0}, done{0};
  const int n = static_cast<int>(images.size());
  const int workers = std::max(
      1, std::min(n, uo.threads > 0
                         ? uo.threads
                         : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()))));
  const int cores = uo.threads > 0
                        ? uo.threads
                        : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const int remap_threads = std::max(1, cores / workers);
  const auto work = [&] {
    cv::Mat res;  // reused from image to image (no fresh pages per image)
    for (int i = next++; i < n; i = next++) {
      {
        std::lock_guard<std::mutex> lock(mu);
        if (error) return;
      }
      try {
        const auto ti = std::chrono::steady_clock::now();
        const cv::Mat im = ReadImage(images[i], "images");
        const auto& s = cam.camera.sensor;
        if (im.cols != s.width_px || im.rows != s.height_px) {
          throw InvalidInput(
              "images", fmt::format("{} is {}x{} px, the calibration's images {}x{}", images[i],
                                    im.cols, im.rows, s.width_px, s.height_px));
        }
        Remap(im, map, uo.interpolation, &res, remap_threads);
        WriteOutput(image_out[i], EncodeLike(res, image_out[i].string(), "out"), "out", rules);
        const int k = ++done;
        std::lock_guard<std::mutex> lock(mu);
        if (o.progress)
          o.progress(fmt::format("undistort: [{}/{}] {} ({:.2f} s)", k, n,
                                 fs::path(images[i]).filename().string(), Seconds(ti)));
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
  // A video: decoded in order, each kept frame remapped on every core.
  Json frames = Json::array();
  if (kind == calib::SourceKind::kVideo) {
    cv::Mat frame, res;
    const long expected = (video_frames + o.every - 1) / o.every;
    for (long index = 0; video.grab(); ++index) {
      if (index % o.every != 0) continue;
      const auto ti = std::chrono::steady_clock::now();
      if (!video.retrieve(frame) || frame.empty()) break;
      if (frame.cols != sensor.width_px || frame.rows != sensor.height_px) {
        throw InvalidInput("images", fmt::format("{}: frame {} is {}x{} px, the calibration's images {}x{}", o.images,
                                                 index, frame.cols, frame.rows, sensor.width_px, sensor.height_px));
      }
      const double ms = video.get(cv::CAP_PROP_POS_MSEC);
      const double t = std::isfinite(ms) && ms > 0 ? ms / 1e3 : (fps > 0 ? index / fps : 0.0);
      const fs::path file = frame_file(index);
      if (index >= video_frames) CheckOutput(file, "out", rules);  // past the frame count the header gave
      Remap(frame, map, uo.interpolation, &res, cores);
      WriteOutput(file, EncodeLike(res, file.string(), "out"), "out", rules);
      image_out.push_back(file);
      frames.push_back({{"image", "images/" + file.filename().string()}, {"frame_index", index}, {"time_s", t}});
      if (o.progress) {
        o.progress(fmt::format("undistort: [{}/{}] {} ({:.3f} s in the video; {:.2f} s)", frames.size(), expected,
                               file.filename().string(), t, Seconds(ti)));
      }
    }
    if (frames.empty()) throw InvalidInput("images", o.images + ": no frame could be decoded");
  }

  // The pinhole for the tools.
  const camera::Camera pin = PinholeCamera(u);
  WriteOutput(out / "cameras.txt", ColmapCamerasText(u), "out", rules);
  WriteOutput(out / "camera.yml",
              interop::WriteCamera(pin, interop::Format::kOpenCVYaml, "out").content, "out", rules);
  WriteOutput(out / "camera.xml",
              interop::WriteCamera(pin, interop::Format::kMetashape, "out").content, "out", rules);
  std::vector<std::string> rel;
  for (const auto& p : image_out) rel.push_back("images/" + p.filename().string());
  WriteOutput(out / "transforms.json", Dump(NerfstudioTransforms(u, rel)), "out", rules);
  Json summary = SummaryJson(u);
  summary["map_seconds"] = map_s;
  summary["images"] = rel;
  if (kind == calib::SourceKind::kVideo) {
    summary["video"] = {{"source", o.images}, {"frames_in_source", video_frames}, {"fps", fps}, {"every", o.every},
                        {"frames", frames}};
  }
  if (refractive) {
    const auto maps = ResidualMaps(u);
    summary["residual"] = ResidualJson(maps);
    const std::string data = ResidualData(maps);
    const std::string script = ResidualScript(maps, "residual.dat", "residual.png");
    // gnuplot draws in a private folder; the PNG is then written like every output.
    std::string tmpl = (out / ".undistort-gnuplot.XXXXXX").string();
    if (mkdtemp(tmpl.data()) == nullptr)
      throw InvalidInput("out", fmt::format("{}: cannot create a folder", o.out));
    const fs::path tmp(tmpl);
    try {
      WriteFileAtomically(tmp / "residual.dat", data, "out");
      WriteFileAtomically(tmp / "residual.gp", script, "out");
      RunGnuplot(o.gnuplot, tmp.string(), "residual.gp");
      WriteOutput(out / "residual.png", ReadInputFile(tmp / "residual.png", "out"), "out", rules);
    } catch (...) {
      std::error_code ec;
      fs::remove_all(tmp, ec);
      throw;
    }
    std::error_code ec;
    fs::remove_all(tmp, ec);
    WriteOutput(out / "residual.dat", data, "out", rules);
    WriteOutput(out / "residual.gp", script, "out", rules);
  }
  summary["seconds"] = Seconds(t0);
  WriteOutput(out / "undistort.json", Dump(summary), "out", rules);
  return summary;
}

}  // namespace porthole::undistort
