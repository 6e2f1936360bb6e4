// Triangulation (measure/triangulate.h, issue 27): points per second on 2 threads, with their σ,
// against OpenCV's cv::triangulatePoints (what cv2.triangulatePoints runs) on the same central
// problem in the same run.
//
// Problems: 100,000 points 1–4 m in front of a stereo rig (two 4288 × 2848 px cameras, 300 mm
// apart, 5° convergence), seen by both cameras, noise-free pixels:
//  - central: two opencv-model cameras in air. porthole: TriangulateMany (image σ; Arg 1: the
//    calibration σ too, over a joint covariance of both cameras' 8 intrinsics and camera 1's pose).
//    OpenCV: cv::undistortPoints (iterative, 20 iterations, ε 1e-12) of both images, then
//    cv::triangulatePoints (DLT), no σ, one thread (it has no threads);
//  - refractive: two D300 + 24 mm lenses (Brown) behind as-built NI320 domes with their own pupil
//    offsets (porthole only: OpenCV has no refraction), image σ (Arg 0) or image and calibration σ
//    (Arg 1).
// Counters: items_per_second (points), max_err_mm against the true points.
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>
#include <random>

#include "porthole/calib/test_rig.h"
#include "porthole/measure/triangulate.h"

namespace {

using namespace porthole;
using calib::fixtures::Truth;

constexpr int kPoints = 100000;

measure::Rig RigOf(const Truth& truth, bool with_covariance) {
  measure::Rig rig;
  int n = 0;
  for (std::size_t k = 0; k < truth.cams.size(); ++k) {
    measure::RigCamera c;
    c.name = "camera" + std::to_string(k);
    c.camera = truth.cams[k];
    if (!truth.ports.empty()) {
      c.shell = refraction::ShellOf(truth.ports[k]);
      c.port = refraction::ParamsOf(truth.ports[k]);
    }
    const Eigen::AngleAxisd aa(truth.cam_from_rig[k].linear());
    c.rotation_rad = aa.angle() * aa.axis();
    c.translation_mm = truth.cam_from_rig[k].translation();
    c.intrinsic_index.assign(c.camera.params.size(), -1);
    if (with_covariance) {
      for (int i = 0; i < 8; ++i) c.intrinsic_index[i] = n++;
      if (c.shell) {
        for (int i = 0; i < 3; ++i) c.port_index[i] = n++;
      }
      if (k > 0) {
        for (int i = 0; i < 6; ++i) c.pose_index[i] = n++;
      }
    }
    rig.cameras.push_back(c);
  }
  // Any positive definite matrix: the cost does not depend on its values.
  rig.covariance = 1e-8 * Eigen::MatrixXd::Identity(n, n);
  return rig;
}

struct Problem {
  std::vector<Eigen::Vector3d> truth;
  std::vector<std::vector<measure::Observation>> obs;
};

Problem Make(const Truth& t) {
  Problem p;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  while (static_cast<int>(p.truth.size()) < kPoints) {
    const double z = 1000 + 3000 * u(rng);
    const double x = 150 + (u(rng) - 0.5) * 0.6 * z, y = (u(rng) - 0.5) * 0.5 * z;
    const Eigen::Vector3d pt(x, y, z);
    std::vector<measure::Observation> o;
    for (int k = 0; k < 2; ++k) {
      const auto uv = t.Project(k, t.cam_from_rig[k] * pt);
      if (!uv || uv->x() < 0 || uv->y() < 0 || uv->x() > 4287 || uv->y() > 2847) break;
      o.push_back({k, *uv});
    }
    if (o.size() != 2) continue;
    p.truth.push_back(pt);
    p.obs.push_back(o);
  }
  return p;
}

void BM_TriangulatePorthole(benchmark::State& state, bool refractive) {
  const Truth truth = refractive ? calib::fixtures::TwoDomeRig() : calib::fixtures::TwoCameraRig();
  const bool with_cal = state.range(0) == 1;
  const measure::Rig rig = RigOf(truth, with_cal);
  const Problem p = Make(truth);
  measure::TriangulateOptions o;
  o.calibration_sigma = with_cal;
  double worst = 0;
  for (auto _ : state) {
    const auto pts = measure::TriangulateMany(rig, p.obs, o, 2);
    benchmark::DoNotOptimize(pts.data());
    worst = 0;
    for (int i = 0; i < kPoints; ++i) worst = std::max(worst, pts[i].ok ? (pts[i].x_mm - p.truth[i]).norm() : INFINITY);
  }
  state.SetItemsProcessed(state.iterations() * kPoints);
  state.counters["max_err_mm"] = worst;
  state.SetLabel(std::string(refractive ? "two as-built domes" : "central, opencv model") +
                 (with_cal ? ", image + calibration sigma" : ", image sigma") + ", 2 threads");
}
BENCHMARK_CAPTURE(BM_TriangulatePorthole, central, false)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_TriangulatePorthole, refractive, true)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_TriangulateOpenCV(benchmark::State& state) {
  const Truth truth = calib::fixtures::TwoCameraRig();
  const Problem p = Make(truth);
  std::vector<cv::Mat> k(2), d(2);
  for (int c = 0; c < 2; ++c) {
    const auto& q = truth.cams[c].params;  // fx fy cx cy k1 k2 p1 p2 k3 k4 k5 k6
    k[c] = (cv::Mat_<double>(3, 3) << q[0], 0, q[2], 0, q[1], q[3], 0, 0, 1);
    d[c] = (cv::Mat_<double>(1, 8) << q[4], q[5], q[6], q[7], q[8], q[9], q[10], q[11]);
  }
  cv::Mat p0 = cv::Mat::eye(3, 4, CV_64F), p1(3, 4, CV_64F);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) p1.at<double>(r, c) = truth.cam_from_rig[1].linear()(r, c);
    p1.at<double>(r, 3) = truth.cam_from_rig[1].translation()(r);
  }
  std::vector<cv::Point2d> uv0(kPoints), uv1(kPoints);
  for (int i = 0; i < kPoints; ++i) {
    uv0[i] = {p.obs[i][0].pixel_px.x(), p.obs[i][0].pixel_px.y()};
    uv1[i] = {p.obs[i][1].pixel_px.x(), p.obs[i][1].pixel_px.y()};
  }
  const cv::TermCriteria crit(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 20, 1e-12);
  double worst = 0;
  for (auto _ : state) {
    std::vector<cv::Point2d> n0, n1;
    cv::undistortPoints(uv0, n0, k[0], d[0], cv::noArray(), cv::noArray(), crit);
    cv::undistortPoints(uv1, n1, k[1], d[1], cv::noArray(), cv::noArray(), crit);
    cv::Mat h;
    cv::triangulatePoints(p0, p1, n0, n1, h);
    benchmark::DoNotOptimize(h.data);
    worst = 0;
    for (int i = 0; i < kPoints; ++i) {
      const double w = h.at<double>(3, i);
      const Eigen::Vector3d x(h.at<double>(0, i) / w, h.at<double>(1, i) / w, h.at<double>(2, i) / w);
      worst = std::max(worst, (x - p.truth[i]).norm());
    }
  }
  state.SetItemsProcessed(state.iterations() * kPoints);
  state.counters["max_err_mm"] = worst;
  state.SetLabel("cv::undistortPoints + cv::triangulatePoints, central, no sigma, 1 thread");
}
BENCHMARK(BM_TriangulateOpenCV)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
