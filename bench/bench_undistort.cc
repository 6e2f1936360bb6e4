// Undistortion (undistort/undistort.h, issue 28): a 24-megapixel image (6000 × 4000, an
// OpenCV-model camera with radial and tangential distortion, alpha 0) remapped to the pinhole on 2
// threads, grey and RGB, 8 bit, bilinear; against cv2.remap (python3-opencv, 2 threads) with the
// same map — porthole's, written to a raw file and read by bench_undistort_cv2.py — in the same
// run. Goal: ≤ 0.3 s on 2 cores. Counters: seconds per image (porthole: best of 5), map_s (building
// the map once, 2 threads), map_diff_px: cv2.initUndistortRectifyMap of the same camera against
// porthole's map (exact model).
#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>

#include "peer.h"
#include "porthole/undistort/undistort.h"

namespace {

using namespace porthole;

constexpr int kW = 6000, kH = 4000;

struct Fixture {
  undistort::Undistorter u;
  cv::Mat map;
  double map_s = 0;
};

const Fixture& Get() {
  static const Fixture f = [] {
    Fixture x;
    measure::RigCamera c;
    c.camera.model = camera::CameraModelId::kOpenCV;
    c.camera.sensor = {kW, kH, 0.0039};
    c.camera.params = {5000, 5004, 3003.2, 1996.4, -0.12, 0.05, 0.0006, -0.0004, 0, 0, 0, 0};
    undistort::UndistortOptions o;
    o.threads = 2;
    x.u = undistort::Prepare(c, o);
    const auto t0 = std::chrono::steady_clock::now();
    x.map = undistort::BuildMap(x.u);
    x.map_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return x;
  }();
  return f;
}

cv::Mat Image(int channels) {
  cv::Mat m(kH, kW, CV_8UC(channels));
  cv::randu(m, cv::Scalar::all(0), cv::Scalar::all(256));
  return m;
}

void BM_Undistort24MP(benchmark::State& state) {
  const int channels = static_cast<int>(state.range(0));
  const int threads = static_cast<int>(state.range(1));
  const Fixture& f = Get();
  const cv::Mat img = Image(channels);
  double best = 1e30;
  cv::Mat out;  // reused, as `porthole undistort` reuses it from image to image
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    undistort::Remap(img, f.map, undistort::Interpolation::kLinear, &out, threads);
    benchmark::DoNotOptimize(out.data);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    best = std::min(best, s);
    state.SetIterationTime(s);
  }
  state.counters["best_s"] = best;
  state.counters["map_s"] = f.map_s;
}
// OpenCV's cv::remap (what cv2.remap runs) in this process on the same map, 2 threads: the peer
// under the same load (the machine is shared), beside the Python run below.
void BM_Undistort24MP_cvremap(benchmark::State& state) {
  const int channels = static_cast<int>(state.range(0));
  const Fixture& f = Get();
  const cv::Mat img = Image(channels);
  const int before = cv::getNumThreads();
  cv::setNumThreads(2);
  double best = 1e30;
  cv::Mat out;  // reused likewise
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    cv::remap(img, out, f.map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_CONSTANT);
    benchmark::DoNotOptimize(out.data);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    best = std::min(best, s);
    state.SetIterationTime(s);
  }
  cv::setNumThreads(before);
  state.counters["best_s"] = best;
}
BENCHMARK(BM_Undistort24MP)
    ->Args({1, 2})
    ->Args({3, 2})
    ->Args({3, 1})
    ->ArgNames({"channels", "threads"})
    ->UseManualTime()
    ->Iterations(5)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Undistort24MP_cvremap)
    ->Arg(1)
    ->Arg(3)
    ->ArgName("channels")
    ->UseManualTime()
    ->Iterations(5)
    ->Unit(benchmark::kMillisecond);

void BM_Undistort24MP_cv2(benchmark::State& state) {
  const int channels = static_cast<int>(state.range(0));
  const Fixture& f = Get();
  const std::string map_path = "/tmp/porthole_bench_undistort_map.f32";
  const std::string spec_path = "/tmp/porthole_bench_undistort.json";
  {
    std::ofstream m(map_path, std::ios::binary);
    m.write(reinterpret_cast<const char*>(f.map.data),
            static_cast<std::streamsize>(f.map.total() * f.map.elemSize()));
    const auto& p = f.u.camera.camera.params;
    std::ofstream s(spec_path);
    char buf[1024];
    std::snprintf(buf, sizeof buf,
                  "{\"map\": \"%s\", \"width\": %d, \"height\": %d, \"channels\": %d, "
                  "\"K\": [%.17g, 0, %.17g, 0, %.17g, %.17g, 0, 0, 1], \"D\": [%.17g, %.17g, "
                  "%.17g, %.17g, 0], "
                  "\"newK\": [%.17g, 0, %.17g, 0, %.17g, %.17g, 0, 0, 1]}\n",
                  map_path.c_str(), kW, kH, channels, p[0], p[2], p[1], p[3], p[4], p[5], p[6],
                  p[7], f.u.pinhole.fx, f.u.pinhole.cx, f.u.pinhole.fy, f.u.pinhole.cy);
    s << buf;
  }
  const std::string cmd = "/usr/bin/python3 " PORTHOLE_BENCH_DIR "/bench_undistort_cv2.py " +
                          spec_path + " 2>/dev/null";
  double seconds = 0, diff = 0;
  for (auto _ : state) {
    const std::string text = porthole::bench::RunPeer(cmd);
    const auto at = text.find("\"seconds\": ");
    const auto dat = text.find("\"map_diff_px\": ");
    if (at == std::string::npos || dat == std::string::npos) {
      state.SkipWithError("cv2 peer failed (python3-opencv)");
      break;
    }
    seconds = std::stod(text.substr(at + 11));
    diff = std::stod(text.substr(dat + 15));
    state.SetIterationTime(seconds);
  }
  std::remove(map_path.c_str());
  std::remove(spec_path.c_str());
  state.counters["best_s"] = seconds;
  state.counters["map_diff_px"] = diff;
}
BENCHMARK(BM_Undistort24MP_cv2)
    ->Arg(1)
    ->Arg(3)
    ->ArgName("channels")
    ->UseManualTime()
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);

}  // namespace
