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
#include <map>
#include <random>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>

#include "peer.h"
#include "porthole/calib/calibrate.h"
#include "porthole/calib/detect.h"
#include "porthole/calib/rig.h"
#include "porthole/calib/synthetic.h"

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
// Runs bench_calib_mrcal.py on a detections file once per iteration, its own timing as the
// iteration time; false (the benchmark skipped with the reason) if the peer failed.
bool RunMrcalPeer(benchmark::State& state, const std::string& json_path, nlohmann::json* j) {
  const std::string cmd = "/usr/bin/python3 " PORTHOLE_BENCH_DIR "/bench_calib_mrcal.py " + json_path + " 2>/dev/null";
  for (auto _ : state) {
    const std::string out = porthole::bench::RunPeer(cmd);
    try {
      *j = nlohmann::json::parse(out);
    } catch (const nlohmann::json::exception&) {
      state.SkipWithError("mrcal peer failed (scripts/install-deps --bench: mrcal python3-mrcal)");
      return false;
    }
    state.SetIterationTime((*j)["seconds"].get<double>());
  }
  return true;
}

void BM_CalibMrcal(benchmark::State& state) {
  if (!HaveSamples(state)) return;
  nlohmann::json j;
  if (!RunMrcalPeer(state, GetSamples().json_path, &j)) return;
  state.counters["rms_px"] = j["rms_px"].get<double>();
  state.counters["fx_px"] = j["intrinsics"]["fx"].get<double>();
}
BENCHMARK(BM_CalibMrcal)->Unit(benchmark::kMillisecond)->UseManualTime()->Iterations(3);

// ---------------------------------------------------------------------------------------------
// Many views (issue 26: a calibration from video has thousands of frames): synthetic views of a
// 10 × 7 chessboard (70 points) by a D300 + 24 mm Brown camera at 0.3 px, 150 / 1,000 / 10,000
// views, porthole with its statistics (covariance included) against mrcal (LENSMODEL_OPENCV5,
// the same detections through bench_calib_mrcal.py) at 150 and 1,000. Acceptance: 1,000 views in
// ≤ 1 s and 10,000 in ≤ 10 s, the time per view flat (a solve linear in the views).
struct ManyViews {
  TargetSpec target = ParseTarget("chessboard:10x7:30");
  std::vector<ImageDetections> detections;
  std::string json_path;
};

const ManyViews& GetManyViews(int n) {
  static std::map<int, ManyViews> sets;
  auto it = sets.find(n);
  if (it != sets.end()) return it->second;
  ManyViews& out = sets[n];
  SyntheticOptions o;
  o.camera = {porthole::camera::CameraModelId::kBrown, {4288, 2848, 0.0055},
              {25.8, 0.05, -0.03, 1.8e-4, -3e-7, 0, 1e-5, -1e-5, 0, 0}};
  o.target = out.target;
  o.n_images = n;
  o.noise_seed = 3;
  out.detections = MakeSyntheticSet(o).detections;
  out.json_path = (fs::temp_directory_path() / ("porthole_bench_views_" + std::to_string(n) + ".json")).string();
  std::ofstream(out.json_path) << DetectionSetToJson(out.detections, {}, out.target).dump();
  return out;
}

void BM_CalibManyViewsPorthole(benchmark::State& state) {
  const ManyViews& s = GetManyViews(static_cast<int>(state.range(0)));
  CalibrationOptions o;
  o.pixel_pitch_mm = 0.0055;
  o.reject_k = 0;  // the same points as mrcal
  CalibrationResult r;
  for (auto _ : state) {
    r = Calibrate(s.detections, s.target, o);
    const double rms = r.rms_px;
    benchmark::DoNotOptimize(rms);
  }
  state.counters["views"] = static_cast<double>(r.n_images);
  state.counters["rms_px"] = r.rms_px;
  state.counters["sigma_c_mm"] = r.sigma[porthole::camera::kBrownC];
  state.counters["ms_per_view"] = 1e3 * r.seconds / r.n_images;
}
BENCHMARK(BM_CalibManyViewsPorthole)->Arg(150)->Arg(1000)->Arg(10000)->Unit(benchmark::kMillisecond)
    ->Iterations(1)->UseRealTime();

void BM_CalibManyViewsMrcal(benchmark::State& state) {
  const ManyViews& s = GetManyViews(static_cast<int>(state.range(0)));
  nlohmann::json j;
  if (!RunMrcalPeer(state, s.json_path, &j)) return;
  state.counters["views"] = static_cast<double>(s.detections.size());
  state.counters["rms_px"] = j["rms_px"].get<double>();
}
BENCHMARK(BM_CalibManyViewsMrcal)->Arg(150)->Arg(1000)->Unit(benchmark::kMillisecond)->UseManualTime()->Iterations(1);

// ---------------------------------------------------------------------------------------------
// A stereo rig (issue 26): porthole's rig calibration (calib/rig.h: both cameras alone, then one
// adjustment of both intrinsics, cam_from_rig and the frames, covariance included) against OpenCV's
// cv::calibrateCamera of each camera followed by cv::stereoCalibrate (CALIB_USE_INTRINSIC_GUESS |
// CALIB_FIX_K3, 200 iterations, ε 1e-12: the whole pipeline a user runs), on the same points: two
// opencv-model cameras 300 mm apart with 5° convergence, 15 frames of a 16 × 12 chessboard, every
// point seen by both (stereoCalibrate needs that), 0.3 px. Counters: rms_px, baseline_mm.
struct StereoSet {
  TargetSpec target = ParseTarget("chessboard:16x12:50");
  std::vector<std::vector<ImageDetections>> cameras{2};
};

const StereoSet& GetStereoSet() {
  static const StereoSet s = [] {
    StereoSet out;
    const porthole::camera::Sensor sensor{4288, 2848, 0.0055};
    const porthole::camera::Camera cams[2] = {
        {porthole::camera::CameraModelId::kOpenCV, sensor, {2000, 2002, 2150, 1420, -0.08, 0.05, 2e-4, -1e-4, 0, 0, 0, 0}},
        {porthole::camera::CameraModelId::kOpenCV, sensor, {1990, 1991, 2130, 1430, -0.07, 0.04, -1e-4, 2e-4, 0, 0, 0, 0}}};
    const Eigen::Matrix3d r1 = Eigen::AngleAxisd(5 * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
    const Eigen::Vector3d t1 = -r1 * Eigen::Vector3d(300, 0, 0);
    const auto points = TargetPoints(out.target);
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (const auto& p : points) centre += p / static_cast<double>(points.size());
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> u(-1, 1);
    std::normal_distribution<double> g(0, 0.3);
    for (int f = 0; f < 15; ++f) {
      const Eigen::Matrix3d r = (Eigen::AngleAxisd(0.6 * u(rng), Eigen::Vector3d::UnitX()) *
                                 Eigen::AngleAxisd(0.6 * u(rng), Eigen::Vector3d::UnitY()) *
                                 Eigen::AngleAxisd(0.3 * u(rng), Eigen::Vector3d::UnitZ()))
                                    .toRotationMatrix();
      const Eigen::Vector3d aim(150 + 250 * u(rng), 200 * u(rng), 800 + 500 * (1 + u(rng)));
      const Eigen::Vector3d t = aim - r * centre;
      ImageDetections d[2];
      for (int k = 0; k < 2; ++k) {
        d[k].image = "f" + std::to_string(100 + f) + ".png";
        d[k].width_px = sensor.width_px, d[k].height_px = sensor.height_px;
      }
      for (std::size_t id = 0; id < points.size(); ++id) {
        const Eigen::Vector3d p0 = r * points[id] + t;
        const auto a = cams[0].Project(p0), b = cams[1].Project(r1 * p0 + t1);
        const auto in = [&](const std::optional<Eigen::Vector2d>& q) {
          return q && q->x() > 0 && q->y() > 0 && q->x() < sensor.width_px - 1 && q->y() < sensor.height_px - 1;
        };
        if (!in(a) || !in(b)) continue;
        d[0].ids.push_back(static_cast<int>(id)), d[1].ids.push_back(static_cast<int>(id));
        d[0].points_px.push_back(*a + Eigen::Vector2d(g(rng), g(rng)));
        d[1].points_px.push_back(*b + Eigen::Vector2d(g(rng), g(rng)));
      }
      if (d[0].ids.size() < 20) continue;
      out.cameras[0].push_back(d[0]), out.cameras[1].push_back(d[1]);
    }
    return out;
  }();
  return s;
}

void BM_CalibStereoPorthole(benchmark::State& state) {
  const StereoSet& s = GetStereoSet();
  RigOptions o;
  CalibrationOptions c;
  c.model = porthole::camera::CameraModelId::kOpenCV;
  c.reject_k = 0;  // the same points as OpenCV
  o.cameras = {c};
  RigResult r;
  for (auto _ : state) {
    r = CalibrateRig(s.cameras, s.target, o);
    const double rms = r.rms_px;
    benchmark::DoNotOptimize(rms);
  }
  state.counters["rms_px"] = r.rms_px;
  state.counters["baseline_mm"] = r.cameras[1].baseline_mm;
}
BENCHMARK(BM_CalibStereoPorthole)->Unit(benchmark::kMillisecond);

void BM_CalibStereoOpenCV(benchmark::State& state) {
  const StereoSet& s = GetStereoSet();
  std::vector<std::vector<cv::Point3f>> object;
  std::vector<std::vector<cv::Point2f>> image[2];
  ToOpenCVCorrespondences(s.cameras[0], s.target, &object, &image[0]);
  ToOpenCVCorrespondences(s.cameras[1], s.target, &object, &image[1]);
  const cv::Size size(4288, 2848);
  const cv::TermCriteria crit(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 200, 1e-12);
  double rms = 0;
  cv::Mat r, t;
  for (auto _ : state) {
    cv::Mat k[2], d[2];
    for (int c = 0; c < 2; ++c) {
      std::vector<cv::Mat> rv, tv;
      cv::calibrateCamera(object, image[c], size, k[c], d[c], rv, tv, cv::CALIB_FIX_K3, crit);
    }
    cv::Mat e, f;
    rms = cv::stereoCalibrate(object, image[0], image[1], k[0], d[0], k[1], d[1], size, r, t, e, f,
                              cv::CALIB_USE_INTRINSIC_GUESS | cv::CALIB_FIX_K3, crit);
    benchmark::DoNotOptimize(rms);
  }
  state.counters["rms_px"] = rms;
  state.counters["baseline_mm"] = cv::norm(t);
}
BENCHMARK(BM_CalibStereoOpenCV)->Unit(benchmark::kMillisecond);

// ---------------------------------------------------------------------------------------------
// A fisheye: porthole's Kannala–Brandt calibration (automatic differentiation, with statistics)
// against OpenCV's cv::fisheye::calibrate on the same synthetic points: a lens close to the Nikkor
// 10.5 mm DX on a D300, 20 views reaching 80° off axis, 0.3 px noise (calib_test's set). OpenCV is
// given an intrinsic guess (f = 1900 px at the image centre; its own start, f = W/π, fails on
// views this far off axis) and a fixed skew, on exactly the images porthole uses (porthole skips
// boards whose points do not fix a pose). Counters: rms_px, fx_px.
struct FisheyeSet {
  TargetSpec target = ParseTarget("chessboard:13x9:40");
  std::vector<ImageDetections> detections;  // the images porthole uses
};

const FisheyeSet& GetFisheyeSet() {
  static const FisheyeSet s = [] {
    FisheyeSet out;
    SyntheticOptions o;
    o.camera = {porthole::camera::CameraModelId::kKannalaBrandt, {4288, 2848, 0.0055},
                {1909, 1911, 2150, 1418, -0.0405, 0.0006, -0.0001, 0.00002}};
    o.target = out.target;
    o.n_images = 20;
    o.fill = 0.35;
    o.max_tilt_deg = 50;
    o.max_off_axis_deg = 85;
    o.noise_seed = 7;
    const auto all = MakeSyntheticSet(o).detections;
    CalibrationOptions c;
    c.model = o.camera.model;
    c.reject_k = 0;
    const auto r = Calibrate(all, out.target, c);
    for (const auto& d : all) {
      for (const auto& im : r.images) {
        if (im.image == d.image) out.detections.push_back(d);
      }
    }
    return out;
  }();
  return s;
}

void BM_CalibFisheyePorthole(benchmark::State& state) {
  const auto& s = GetFisheyeSet();
  CalibrationOptions o;
  o.model = porthole::camera::CameraModelId::kKannalaBrandt;
  o.reject_k = 0;
  CalibrationResult r;
  for (auto _ : state) {
    r = Calibrate(s.detections, s.target, o);
    const double rms = r.rms_px;
    benchmark::DoNotOptimize(rms);
  }
  state.counters["rms_px"] = r.rms_px;
  state.counters["fx_px"] = r.camera.params[0];
  state.counters["images"] = r.n_images;
}
BENCHMARK(BM_CalibFisheyePorthole)->Unit(benchmark::kMillisecond);

void BM_CalibFisheyeOpenCV(benchmark::State& state) {
  const auto& s = GetFisheyeSet();
  std::vector<std::vector<cv::Point3d>> object;
  std::vector<std::vector<cv::Point2d>> image;
  const auto nominal = TargetPoints(s.target);
  for (const auto& d : s.detections) {
    object.emplace_back();
    image.emplace_back();
    for (std::size_t k = 0; k < d.ids.size(); ++k) {
      const auto& p = nominal[d.ids[k]];
      object.back().emplace_back(p.x(), p.y(), p.z());
      image.back().emplace_back(d.points_px[k].x(), d.points_px[k].y());
    }
  }
  double rms = 0;
  cv::Matx33d k;
  for (auto _ : state) {
    k = cv::Matx33d(1900, 0, 2143.5, 0, 1900, 1423.5, 0, 0, 1);
    cv::Vec4d d(0, 0, 0, 0);
    std::vector<cv::Vec3d> rv, tv;
    rms = cv::fisheye::calibrate(
        object, image, cv::Size(4288, 2848), k, d, rv, tv,
        cv::fisheye::CALIB_RECOMPUTE_EXTRINSIC | cv::fisheye::CALIB_FIX_SKEW |
            cv::fisheye::CALIB_USE_INTRINSIC_GUESS,
        cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 200, 1e-12));
    benchmark::DoNotOptimize(rms);
  }
  state.counters["rms_px"] = rms;
  state.counters["fx_px"] = k(0, 0);
  state.counters["images"] = static_cast<double>(object.size());
}
BENCHMARK(BM_CalibFisheyeOpenCV)->Unit(benchmark::kMillisecond);

}  // namespace
