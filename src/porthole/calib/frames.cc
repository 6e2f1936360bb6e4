#include "porthole/calib/frames.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <mutex>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <thread>

#include "porthole/core/error.h"
#include "porthole/core/input.h"

namespace porthole::calib {
namespace fs = std::filesystem;

namespace {

bool IsImageFile(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  for (const char* e : {".jpg", ".jpeg", ".png", ".tif", ".tiff", ".bmp", ".pgm", ".ppm"}) {
    if (ext == e) return true;
  }
  return false;
}

std::string Ordinal(int n) {
  if (n % 100 >= 11 && n % 100 <= 13) return fmt::format("{}th", n);
  switch (n % 10) {
    case 1: return fmt::format("{}st", n);
    case 2: return fmt::format("{}nd", n);
    case 3: return fmt::format("{}rd", n);
    default: return fmt::format("{}th", n);
  }
}

// The target's tilt class (0: facing the camera, 1-8: tilted toward one of 8 directions), from the
// gradient over the frame of the log of the homography's local scale. Non-planar targets: 0.
int TiltClass(const ImageDetections& d, const TargetSpec& target, double threshold) {
  if (d.ids.size() < 6) return 0;
  const auto pts = TargetPoints(target);
  std::vector<cv::Point2f> from, to;
  for (std::size_t k = 0; k < d.ids.size(); ++k) {
    const auto& p = pts.at(d.ids[k]);
    if (std::abs(p.z()) > 1e-9) return 0;  // a 3-D field: no one homography
    from.emplace_back(float(p.x()), float(p.y()));
    to.emplace_back(float(d.points_px[k].x()), float(d.points_px[k].y()));
  }
  const cv::Mat H = cv::findHomography(from, to, 0);
  if (H.empty()) return 0;
  // log |det J| of the homography at each point, fitted as a + b u + c v (least squares).
  const auto h = [&](int r, int c) { return H.at<double>(r, c); };
  cv::Mat A(int(from.size()), 3, CV_64F), y(int(from.size()), 1, CV_64F);
  for (int k = 0; k < int(from.size()); ++k) {
    const double X = from[k].x, Y = from[k].y;
    const double w = h(2, 0) * X + h(2, 1) * Y + h(2, 2);
    // det of the Jacobian of (x/w, y/w) = det(H) / w^3.
    const double det = cv::determinant(H) / (w * w * w);
    A.at<double>(k, 0) = 1, A.at<double>(k, 1) = to[k].x, A.at<double>(k, 2) = to[k].y;
    y.at<double>(k) = 0.5 * std::log(std::abs(det) + 1e-300);  // log of the linear scale
  }
  cv::Mat sol;
  if (!cv::solve(A, y, sol, cv::DECOMP_SVD)) return 0;
  const double diag = std::hypot(d.width_px, d.height_px);
  const double gx = sol.at<double>(1) * diag, gy = sol.at<double>(2) * diag;
  if (!std::isfinite(gx) || !std::isfinite(gy) || std::hypot(gx, gy) < threshold) return 0;
  const double a = std::atan2(gy, gx);  // toward the target's near (larger) side
  return 1 + (int(std::lround(a / (M_PI / 4))) % 8 + 8) % 8;
}

std::vector<int> CellsOf(const ImageDetections& d, int cols, int rows) {
  std::vector<int> cells;
  for (const auto& p : d.points_px) {
    const int c = std::clamp(int((p.x() + 0.5) / d.width_px * cols), 0, cols - 1);
    const int r = std::clamp(int((p.y() + 0.5) / d.height_px * rows), 0, rows - 1);
    cells.push_back(r * cols + c);
  }
  std::sort(cells.begin(), cells.end());
  cells.erase(std::unique(cells.begin(), cells.end()), cells.end());
  return cells;
}

// The lower quartile (the value a quarter of the way up the sorted list, interpolated).
double Quartile(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const double at = 0.25 * double(v.size() - 1);
  const std::size_t i = std::size_t(at);
  return i + 1 < v.size() ? v[i] + (at - double(i)) * (v[i + 1] - v[i]) : v[i];
}

// Removes entries of a run (detections and their parallel vectors) where keep[k] is false.
void KeepOnly(DetectionRun* run, const std::vector<bool>& keep) {
  DetectionRun out;
  out.skipped = std::move(run->skipped);
  for (std::size_t k = 0; k < run->detections.size(); ++k) {
    if (!keep[k]) continue;
    out.detections.push_back(std::move(run->detections[k]));
    out.uncoded.push_back(k < run->uncoded.size() ? run->uncoded[k] : std::nullopt);
    out.coded.push_back(k < run->coded.size() ? run->coded[k] : std::nullopt);
  }
  *run = std::move(out);
}

std::string FrameLabel(long index) { return fmt::format("f{:06d}", index); }

// Decodes the video on this thread, every `every`-th frame searched by `threads` workers; at most
// 2 x threads frames wait in memory.
DetectionRun DetectVideo(cv::VideoCapture& video, const std::string& path, const std::string& field,
                         const TargetSpec& target, int every,
                         long expected, const std::function<void(const std::string&)>& progress,
                         const DetectOptions& options, long* searched) {
  struct Frame {
    long index;
    double time_s;
    cv::Mat gray;
  };
  struct Result {
    long index;
    double time_s;
    std::optional<ImageDetections> d;
    std::optional<coded::UncodedCounts> uncoded;
    std::optional<CodedCounts> coded;
    std::string reason;
  };
  const unsigned hw = std::max(1u, std::thread::hardware_concurrency());
  const int n_threads = options.threads > 0 ? options.threads : int(hw);
  std::mutex mutex;
  std::condition_variable cv_ready, cv_space;
  std::deque<Frame> queue;
  bool done_reading = false;
  std::vector<Result> results;
  std::exception_ptr error;
  long finished = 0;
  const long to_search = expected > 0 ? (expected + every - 1) / every : 0;
  auto worker = [&] {
    for (;;) {
      Frame f;
      {
        std::unique_lock lock(mutex);
        cv_ready.wait(lock, [&] { return !queue.empty() || done_reading || error; });
        if (error || (queue.empty() && done_reading)) return;
        f = std::move(queue.front());
        queue.pop_front();
      }
      cv_space.notify_one();
      Result r{f.index, f.time_s, std::nullopt, std::nullopt, std::nullopt, ""};
      try {
        std::vector<int> ids;
        std::vector<cv::Point2f> pts;
        coded::UncodedCounts uncoded;
        CodedCounts coded;
        if (DetectInImage(f.gray, target, &ids, &pts, options, true, &uncoded, &coded)) {
          ImageDetections d;
          d.image = FrameLabel(f.index);
          d.frame_index = int(f.index);
          d.time_s = f.time_s;
          d.width_px = f.gray.cols;
          d.height_px = f.gray.rows;
          d.ids = ids;
          for (const auto& p : pts) d.points_px.emplace_back(p.x, p.y);
          d.blur_px = EdgeBlurPx(f.gray, pts);
          r.d = std::move(d);
        } else {
          r.reason = "no target found";
        }
        if (HasUncodedDots(target)) r.uncoded = uncoded;
        if (target.kind == TargetKind::kCoded) r.coded = coded;
      } catch (const cv::Exception& e) {
        r.reason = "OpenCV error (" + (e.err.empty() ? std::string("unknown") : e.err) + ")";
      } catch (...) {
        std::lock_guard lock(mutex);
        if (!error) error = std::current_exception();
        cv_space.notify_all();
        cv_ready.notify_all();
        return;
      }
      std::lock_guard lock(mutex);
      ++finished;
      if (progress) {
        const std::string of = to_search > 0 ? fmt::format("/{}", to_search) : "";
        const std::string name = fmt::format("{} ({:.3f} s)", FrameLabel(r.index), r.time_s);
        progress(r.d ? fmt::format("[{}{}] {}: {} points, edge blur {:.2f} px", finished, of, name, r.d->ids.size(),
                                   r.d->blur_px)
                     : fmt::format("[{}{}] {}: skipped ({})", finished, of, name, r.reason));
      }
      results.push_back(std::move(r));
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < n_threads; ++t) pool.emplace_back(worker);
  long index = 0;
  *searched = 0;
  cv::Mat frame;
  try {
    for (;; ++index) {
      {
        std::lock_guard lock(mutex);
        if (error) break;
      }
      const bool take = index % every == 0;
      if (!video.grab()) break;
      if (!take) continue;
      if (!video.retrieve(frame) || frame.empty()) break;
      if (double(frame.cols) * frame.rows > options.max_pixels) {
        throw InvalidInput(field, fmt::format("{}: frames of {} x {} px, above the limit of {:g} megapixels", path,
                                                 frame.cols, frame.rows, options.max_pixels / 1e6));
      }
      const double ms = video.get(cv::CAP_PROP_POS_MSEC);
      const double fps = video.get(cv::CAP_PROP_FPS);
      // The decoder's time stamp (variable frame rates too); OpenCV's FFmpeg backend gives 0 for the
      // last frame of a file, so 0 past the first frame falls back on index / fps.
      const double t = std::isfinite(ms) && ms > 0 ? ms / 1e3 : (fps > 0 ? index / fps : 0.0);
      cv::Mat gray;
      if (frame.channels() == 3) {
        cv::cvtColor(frame, gray, cv::COLOR_BGR2GRAY);
      } else if (frame.channels() == 4) {
        cv::cvtColor(frame, gray, cv::COLOR_BGRA2GRAY);
      } else {
        gray = frame.clone();
      }
      if (gray.depth() != CV_8U) gray.convertTo(gray, CV_8U, gray.depth() == CV_16U ? 1.0 / 257 : 1.0);
      ++*searched;
      if (std::size_t(*searched) > kMaxImagesPerSet) {
        throw InvalidInput(field, fmt::format("{}: more than the limit of {} frames searched per set; search fewer "
                                              "(`every`)", path, kMaxImagesPerSet));
      }
      std::unique_lock lock(mutex);
      cv_space.wait(lock, [&] { return queue.size() < std::size_t(2 * n_threads) || error; });
      if (error) break;
      queue.push_back({index, t, std::move(gray)});
      cv_ready.notify_one();
    }
  } catch (...) {
    std::lock_guard lock(mutex);
    if (!error) error = std::current_exception();
  }
  {
    std::lock_guard lock(mutex);
    done_reading = true;
  }
  cv_ready.notify_all();
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
  std::sort(results.begin(), results.end(), [](const Result& a, const Result& b) { return a.index < b.index; });
  DetectionRun run;
  for (auto& r : results) {
    if (r.d) {
      run.detections.push_back(std::move(*r.d));
      run.uncoded.push_back(r.uncoded);
      run.coded.push_back(r.coded);
    } else {
      run.skipped.push_back({fmt::format("{} ({:.3f} s)", FrameLabel(r.index), r.time_s), r.reason});
    }
  }
  return run;
}

}  // namespace

SourceKind ClassifySource(const std::string& path, const std::string& field) {
  std::error_code ec;
  const auto st = fs::status(path, ec);
  if (ec || !fs::exists(st)) throw InvalidInput(field, path + ": no such file or directory");
  if (fs::is_directory(st)) return SourceKind::kDirectory;
  return IsImageFile(path) ? SourceKind::kImage : SourceKind::kVideo;
}

void ChooseFrames(DetectionRun* run, const TargetSpec& target, const FrameOptions& frames, FrameChoice* choice) {
  const std::size_t n = run->detections.size();
  choice->found = long(n);
  std::vector<double> blur;
  for (const auto& d : run->detections) {
    if (!std::isnan(d.blur_px)) blur.push_back(d.blur_px);
  }
  // The reference: the lower quartile, the sharp end of the frames found (a median would sit among
  // the blurred frames when half of them are: every 3rd frame of a clip blurred every 6th).
  const double median = Quartile(blur);
  choice->reference_blur_px = median;
  // 1. Blurred frames out (only when there is a choice to make: a directory of stills keeps all
  //    unless max_frames asks for the choice).
  std::vector<bool> keep(n, true);
  choice->blurred = 0;
  if (frames.max_frames > 0 && std::isfinite(median)) {
    std::vector<SkippedImage> blurred;
    for (std::size_t k = 0; k < n; ++k) {
      const double b = run->detections[k].blur_px;
      if (!std::isnan(b) && b > frames.max_blur_ratio * median && b > median + frames.min_blur_excess_px) {
        keep[k] = false;
        ++choice->blurred;
        const auto& d = run->detections[k];
        const std::string name =
            d.frame_index >= 0 ? fmt::format("{} ({:.3f} s)", d.image, d.time_s) : d.image;
        run->skipped.push_back(
            {name, fmt::format("blurred: the target's edges blurred by {:.2f} px, above the {:.2f} px left in (the "
                               "frames' lower quartile {:.2f} px: {:g} x it and {:g} px over it)",
                               b, std::max(frames.max_blur_ratio * median, median + frames.min_blur_excess_px),
                               median, frames.max_blur_ratio, frames.min_blur_excess_px)});
      }
    }
    KeepOnly(run, keep);
  }
  // 2. The greedy choice of K over the grid cells and tilt classes.
  const int cols = std::max(1, frames.grid_cols), rows = std::max(1, frames.grid_rows);
  const std::size_t m = run->detections.size();
  std::vector<std::vector<int>> cells(m);
  std::vector<int> tilt(m);
  for (std::size_t k = 0; k < m; ++k) {
    cells[k] = CellsOf(run->detections[k], cols, rows);
    tilt[k] = TiltClass(run->detections[k], target, frames.tilt_threshold);
  }
  std::vector<bool> chosen(m, frames.max_frames <= 0 || std::size_t(frames.max_frames) >= m);
  if (!chosen.empty() && !chosen[0]) {
    std::vector<int> cell_count(cols * rows, 0), tilt_count(9, 0);
    for (int pick = 0; pick < frames.max_frames; ++pick) {
      double best = -1;
      std::size_t best_k = m;
      for (std::size_t k = 0; k < m; ++k) {
        if (chosen[k]) continue;
        double score = 0;
        for (int c : cells[k]) score += 1.0 / (1 + cell_count[c]);
        score /= cols * rows;
        score += 1.0 / (1 + tilt_count[tilt[k]]);
        const double b = run->detections[k].blur_px;
        score += 1e-3 / (1 + (std::isnan(b) ? 1.0 : std::min(b, 10.0)));  // ties: the sharper
        if (score > best) best = score, best_k = k;
      }
      if (best_k == m) break;
      chosen[best_k] = true;
      for (int c : cells[best_k]) ++cell_count[c];
      ++tilt_count[tilt[best_k]];
    }
  }
  std::vector<bool> cell_seen(cols * rows, false), tilt_seen(9, false);
  choice->chosen = 0;
  for (std::size_t k = 0; k < m; ++k) {
    if (!chosen[k]) continue;
    ++choice->chosen;
    for (int c : cells[k]) cell_seen[c] = true;
    tilt_seen[tilt[k]] = true;
  }
  choice->cells = cols * rows;
  choice->cells_covered = int(std::count(cell_seen.begin(), cell_seen.end(), true));
  choice->tilt_classes = int(std::count(tilt_seen.begin(), tilt_seen.end(), true));
  KeepOnly(run, chosen);
}

SourceRun DetectSource(const std::string& path, const TargetSpec& target, const FrameOptions& frames,
                       const std::function<void(const std::string&)>& progress, const DetectOptions& options,
                       const std::string& field) {
  if (frames.every < 0) throw InvalidInput("every", "a whole number >= 1 (0: automatic)");
  if (frames.max_frames < 0) throw InvalidInput("max_frames", "a whole number >= 1 (0: every frame found)");
  if (!(frames.max_blur_ratio > 1 && frames.max_blur_ratio < 1e6)) throw InvalidInput("max_blur_ratio", "above 1");
  if (!(frames.min_blur_excess_px >= 0 && frames.min_blur_excess_px < 1e6)) {
    throw InvalidInput("min_blur_excess_px", "a number of px >= 0");
  }
  SourceRun out;
  FrameChoice& c = out.choice;
  c.source = path;
  c.kind = ClassifySource(path, field);
  if (c.kind == SourceKind::kVideo) {
    cv::VideoCapture video;
    try {
      video.open(path, cv::CAP_FFMPEG);
    } catch (const cv::Exception&) {
    }
    if (!video.isOpened()) {
      throw InvalidInput(field, path + ": not a directory, an image (jpg, png, tif, bmp, pgm) or a video OpenCV's "
                                       "FFmpeg backend can open");
    }
    c.frames_in_source = std::max<long>(0, std::lround(video.get(cv::CAP_PROP_FRAME_COUNT)));
    c.fps = video.get(cv::CAP_PROP_FPS);
    if (!(c.fps > 0 && std::isfinite(c.fps))) c.fps = 0;
    c.every = frames.every > 0 ? frames.every
                               : std::max<int>(1, int((c.frames_in_source + frames.max_searched - 1) /
                                                      std::max(1, frames.max_searched)));
    if (progress) {
      progress(fmt::format("{}: video, {} frames at {:g} fps; searching {}", path, c.frames_in_source, c.fps,
                           c.every == 1 ? std::string("every frame") : "every " + Ordinal(c.every) + " frame"));
    }
    out.run = DetectVideo(video, path, field, target, c.every, c.frames_in_source, progress, options, &c.searched);
    if (c.searched == 0) throw InvalidInput(field, path + ": no frame could be decoded");
  } else {
    std::vector<std::string> paths;
    if (c.kind == SourceKind::kImage) {
      paths = {path};
    } else {
      paths = ListImages(path, field);
    }
    c.frames_in_source = long(paths.size());
    c.every = std::max(1, frames.every);
    if (c.every > 1) {
      std::vector<std::string> some;
      for (std::size_t k = 0; k < paths.size(); k += c.every) some.push_back(paths[k]);
      paths = std::move(some);
    }
    c.searched = long(paths.size());
    out.run = DetectAll(paths, target, progress, options);
  }
  FrameOptions choose = frames;
  if (choose.max_frames == 0 && choose.for_calibration && c.kind == SourceKind::kVideo) {
    choose.max_frames = kCalibrationFrames;
  }
  ChooseFrames(&out.run, target, choose, &c);
  if (progress && (choose.max_frames > 0 || c.kind == SourceKind::kVideo)) progress(Describe(c));
  return out;
}

nlohmann::ordered_json FrameChoiceToJson(const FrameChoice& c, const std::vector<ImageDetections>& kept) {
  nlohmann::ordered_json frames = nlohmann::ordered_json::array();
  for (const auto& d : kept) {
    nlohmann::ordered_json f = {{"image", d.image}};
    if (d.frame_index >= 0) f["frame_index"] = d.frame_index, f["time_s"] = d.time_s;
    if (std::isfinite(d.blur_px)) f["blur_px"] = d.blur_px;
    frames.push_back(f);
  }
  const char* kind = c.kind == SourceKind::kVideo ? "video" : c.kind == SourceKind::kImage ? "image" : "directory";
  return {{"source", c.source},
          {"kind", kind},
          {"frames_in_source", c.frames_in_source},
          {"fps", c.fps},
          {"every", c.every},
          {"searched", c.searched},
          {"found", c.found},
          {"blurred", c.blurred},
          {"kept", c.chosen},
          {"reference_blur_px", std::isfinite(c.reference_blur_px) ? nlohmann::ordered_json(c.reference_blur_px) : nullptr},
          {"cells_covered", c.cells_covered},
          {"cells", c.cells},
          {"tilt_classes", c.tilt_classes},
          {"frames", frames}};
}

std::string Describe(const FrameChoice& c) {
  std::string t = c.source + ": ";
  switch (c.kind) {
    case SourceKind::kVideo:
      t += fmt::format("video, {} frames at {:g} fps; {} searched", c.frames_in_source, c.fps, c.searched);
      if (c.every > 1) t += fmt::format(" (every {})", Ordinal(c.every));
      break;
    case SourceKind::kImage: t += "one image"; break;
    case SourceKind::kDirectory:
      t += fmt::format("{} images; {} searched", c.frames_in_source, c.searched);
      if (c.every > 1) t += fmt::format(" (every {})", Ordinal(c.every));
      break;
  }
  t += fmt::format(", the target in {}", c.found);
  if (c.blurred > 0) {
    t += fmt::format("; {} blurred, left out (the frames' lower quartile of edge blur {:.2f} px)", c.blurred,
                     c.reference_blur_px);
  }
  t += fmt::format("; {} kept, covering {} of {} grid cells and {} of 9 tilt classes", c.chosen, c.cells_covered,
                   c.cells, c.tilt_classes);
  return t;
}

}  // namespace porthole::calib
