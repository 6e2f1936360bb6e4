// Calibration on OpenCV's sample chessboards (opencv-doc left01–14.jpg, 13 images × 54 corners),
// all three tools on the SAME detections (porthole's chessboard detector, run once): porthole
// (Ceres bundle adjustment + covariance statistics), OpenCV 4.6 cv::calibrateCamera and mrcal 2.2
// (LENSMODEL_OPENCV5, through bench_calib_mrcal.py). The models have 8 parameters each except
// mrcal (fx ≠ fy: 9): porthole c,x0,y0,K1,K2,K3,P1,P2; OpenCV CALIB_FIX_ASPECT_RATIO with
// k1,k2,p1,p2,k3. Counters: rms_px (2-D, sqrt(Σ|r|²/n)), c_px or fx_px. Target: porthole ≥ 5×
// faster than OpenCV at equal RMS.
//
// What is timed: detections in, calibration out. BM_CalibPorthole includes porthole's statistics
// (σ0²-scaled covariance, σ, correlation, significance, per-image RMS); BM_CalibOpenCV computes no
// standard deviations. Both variants of each are timed as well: porthole with statistics off
// (CalibrationOptions::statistics) and OpenCV with stdDeviationsIntrinsics/Extrinsics and
// perViewErrors (its diagonal σ).
#include <benchmark/benchmark.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>

#include "porthole/calib/calibrate.h"
#include "porthole/calib/detect.h"

namespace {
namespace fs = std::filesystem;
using namespace porthole::calib;

struct Samples {
  TargetSpec target = ParseTarget("chessboard:9x6:25");
  std::vector<ImageDetections> detections;
  std::string json_path;  // the same detections for the mrcal script
};

const Samples& GetSamples() {
  static const Samples s = [] {
    Samples out;
    const char* dir = "/usr/share/doc/opencv-doc/examples/data";
    std::vector<std::string> paths;
    if (fs::is_directory(dir)) {
      for (const auto& e : fs::directory_iterator(dir)) {
        const auto name = e.path().filename().string();
        if (name.size() == 10 && name.rfind("left", 0) == 0 && e.path().extension() == ".jpg") {
          paths.push_back(e.path().string());
        }
      }
    }
    std::sort(paths.begin(), paths.end());
    if (!paths.empty()) out.detections = DetectAll(paths, out.target).detections;
    out.json_path = (fs::temp_directory_path() / "porthole_bench_calib_detections.json").string();
    std::ofstream(out.json_path) << DetectionSetToJson(out.detections, {}, out.target).dump();
    return out;
  }();
  return s;
}

bool HaveSamples(benchmark::State& state) {
  if (GetSamples().detections.size() >= 3) return true;
  state.SkipWithError("opencv-doc sample chessboards not found (scripts/install-deps)");
  return false;
}

// porthole with or without its statistics (covariance, σ, correlation, significance).
void RunPorthole(benchmark::State& state, bool statistics) {
  if (!HaveSamples(state)) return;
  const auto& s = GetSamples();
  CalibrationOptions o;
  o.reject_k = 0;  // the same points as the peers
  o.free = ParseFreeParameters(porthole::camera::CameraModelId::kBrown, "c,x0,y0,K1,K2,K3,P1,P2");
  o.statistics = statistics;
  CalibrationResult r;
  for (auto _ : state) {
    r = Calibrate(s.detections, s.target, o);
    const double rms = r.rms_px;
    benchmark::DoNotOptimize(rms);
  }
  state.counters["rms_px"] = r.rms_px;
  state.counters["c_px"] = r.camera.params[porthole::camera::kBrownC];
  if (statistics) state.counters["sigma_c_px"] = r.sigma[porthole::camera::kBrownC];
  state.counters["iterations"] = r.iterations;
}
void BM_CalibPorthole(benchmark::State& state) { RunPorthole(state, true); }
BENCHMARK(BM_CalibPorthole)->Unit(benchmark::kMillisecond);
void BM_CalibPortholeNoStatistics(benchmark::State& state) { RunPorthole(state, false); }
BENCHMARK(BM_CalibPortholeNoStatistics)->Unit(benchmark::kMillisecond);

// OpenCV with or without its standard deviations (stdDeviationsIntrinsics/Extrinsics and
// perViewErrors).
void RunOpenCV(benchmark::State& state, bool std_deviations) {
  if (!HaveSamples(state)) return;
  const auto& s = GetSamples();
  std::vector<std::vector<cv::Point3f>> object;
  std::vector<std::vector<cv::Point2f>> image;
  ToOpenCVCorrespondences(s.detections, s.target, &object, &image);
  const cv::Size size(s.detections[0].width_px, s.detections[0].height_px);
  double rms = 0;
  cv::Mat k, dist, sd_intrinsics;
  for (auto _ : state) {
    k = cv::Mat::eye(3, 3, CV_64F);
    dist.release();
    std::vector<cv::Mat> rv, tv;
    if (std_deviations) {
      cv::Mat sd_extrinsics, per_view;
      rms = cv::calibrateCamera(object, image, size, k, dist, rv, tv, sd_intrinsics,
                                sd_extrinsics, per_view, cv::CALIB_FIX_ASPECT_RATIO);
    } else {
      rms = cv::calibrateCamera(object, image, size, k, dist, rv, tv, cv::CALIB_FIX_ASPECT_RATIO);
    }
    benchmark::DoNotOptimize(rms);
  }
  state.counters["rms_px"] = rms;
  state.counters["fx_px"] = k.at<double>(0, 0);
  // With CALIB_FIX_ASPECT_RATIO OpenCV adjusts fy (fx = aspect·fy): its σ is the second entry.
  if (std_deviations) state.counters["sigma_fy_px"] = sd_intrinsics.at<double>(1);
}
void BM_CalibOpenCV(benchmark::State& state) { RunOpenCV(state, false); }
BENCHMARK(BM_CalibOpenCV)->Unit(benchmark::kMillisecond);
void BM_CalibOpenCVWithStdDev(benchmark::State& state) { RunOpenCV(state, true); }
BENCHMARK(BM_CalibOpenCVWithStdDev)->Unit(benchmark::kMillisecond);

// mrcal through its Python API: the script times itself (seed + optimisation, without the
// interpreter start-up), reported as the manual iteration time.
void BM_CalibMrcal(benchmark::State& state) {
  if (!HaveSamples(state)) return;
  const std::string cmd = "/usr/bin/python3 " PORTHOLE_BENCH_DIR "/bench_calib_mrcal.py " +
                          GetSamples().json_path + " 2>/dev/null";
  nlohmann::json j;
  for (auto _ : state) {
    std::string out;
    if (FILE* p = popen(cmd.c_str(), "r")) {
      char buf[4096];
      while (fgets(buf, sizeof buf, p) != nullptr) out += buf;
      if (pclose(p) != 0) out.clear();
    }
    try {
      j = nlohmann::json::parse(out);
    } catch (const nlohmann::json::exception&) {
      state.SkipWithError("mrcal peer failed (scripts/install-deps --bench: mrcal python3-mrcal)");
      return;
    }
    state.SetIterationTime(j["seconds"].get<double>());
  }
  state.counters["rms_px"] = j["rms_px"].get<double>();
  state.counters["fx_px"] = j["intrinsics"]["fx"].get<double>();
}
BENCHMARK(BM_CalibMrcal)->Unit(benchmark::kMillisecond)->UseManualTime()->Iterations(3);

}  // namespace
