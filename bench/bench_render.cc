// `porthole render` speed (issue 13: a 4288 × 2848 frame at 16 samples per pixel and 3 bands in
// <= 20 s on the 2-core machine): the paper's D300 + 24 mm behind the as-built NI320 in sea water,
// f/8 focused on a 9 × 6 chessboard at 1 m, tilted; both cores. The peer, measured in the same
// run: TraceBatch alone on the same number of rays (the port's two spheres, 3 bands) — the
// counter `render_over_trace` is what generating the rays, meeting the target and shading cost on
// top of the tracer.
//
// Counters: `seconds` (wall clock, one frame), `cpu_seconds` (summed over threads: on a machine
// shared with other jobs the wall clock includes their share), `samples_per_s`, `trace_seconds`
// (the peer), `render_over_trace`, and accuracy beside speed: `corner_rms_px` (OpenCV's corners in
// the frame against the ground truth).
#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>
#include <ctime>
#include <opencv2/core.hpp>

#include "porthole/calib/detect.h"
#include "porthole/catalogue/presets.h"
#include "porthole/optics/batch.h"
#include "porthole/render/render.h"

namespace {

using namespace porthole;

double CpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

render::Scene PaperFrame() {
  render::Scene s;
  s.housed.camera = catalogue::LoadCamera("nikon-d300");
  s.housed.lens = catalogue::LoadLens("nikkor-24mm-f2.8d");
  s.housed.port = catalogue::LoadPort("nimar-ni320");
  s.target = calib::ParseTarget("chessboard:9x6:60");
  s.pose = render::PoseFacing(s.target, 1200, {40, -30}, 20, -15, 8);
  return s;
}

void BM_RenderFullFrame(benchmark::State& state) {
  const render::Scene scene = PaperFrame();
  render::RenderOptions o;
  o.samples_per_pixel = 16;
  render::Rendered r;
  double wall = 0, cpu = 0;
  for (auto _ : state) {
    const double c0 = CpuSeconds();
    const auto t0 = std::chrono::steady_clock::now();
    r = render::Render(scene, o);
    wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    cpu = CpuSeconds() - c0;
  }
  const double samples = static_cast<double>(r.image.width) * r.image.height * o.samples_per_pixel;
  // The peer: the same number of rays through the same port in the same 3 bands, tracer alone.
  const std::size_t chunk = 1 << 20;
  optics::RayBatch in, out;
  in.resize(chunk);
  for (std::size_t i = 0; i < chunk; ++i) {
    const double a = 0.6 * std::sqrt((i + 0.5) / chunk), phi = 2.399963 * i;
    in.Set(i, optics::Ray{r.setup.ep_in_housing_mm,
                          Eigen::Vector3d(std::sin(a) * std::cos(phi), std::sin(a) * std::sin(phi), std::cos(a))});
  }
  const auto t0 = std::chrono::steady_clock::now();
  for (double done = 0; done < samples; done += chunk) {
    for (const auto& band : r.setup.bands) optics::TraceBatch(band.outward, in, &out);
  }
  const double trace = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  // Accuracy beside speed.
  cv::Mat gray(r.image.height, r.image.width, CV_8U);
  for (int v = 0; v < r.image.height; ++v) {
    for (int u = 0; u < r.image.width; ++u) gray.at<unsigned char>(v, u) = static_cast<unsigned char>(std::lround(255 * r.image.at(u, v)));
  }
  std::vector<int> ids;
  std::vector<cv::Point2f> pts;
  double rms = NAN;
  if (calib::DetectInImage(gray, scene.target, &ids, &pts) && pts.size() == r.truth.size()) {
    const bool reversed = std::hypot(pts[0].x - r.truth.back().pixel_per_band[1].x(), pts[0].y - r.truth.back().pixel_per_band[1].y()) <
                          std::hypot(pts[0].x - r.truth.front().pixel_per_band[1].x(), pts[0].y - r.truth.front().pixel_per_band[1].y());
    double s2 = 0;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const auto& t = r.truth[reversed ? pts.size() - 1 - i : i].pixel_per_band[1];
      s2 += std::pow(pts[i].x - t.x(), 2) + std::pow(pts[i].y - t.y(), 2);
    }
    rms = std::sqrt(s2 / pts.size());
  }
  state.counters["seconds"] = wall;
  state.counters["cpu_seconds"] = cpu;
  state.counters["samples_per_s"] = samples / wall;
  state.counters["trace_seconds"] = trace;
  state.counters["render_over_trace"] = wall / trace;
  state.counters["corner_rms_px"] = rms;
  state.counters["width_px"] = r.image.width;
  state.counters["height_px"] = r.image.height;
}
BENCHMARK(BM_RenderFullFrame)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();

}  // namespace
