// Chessboard detection on a 12-megapixel image (the paper's D300, 4288 x 2848) rendered with known
// corners (calib/render_board.h): porthole's detector (search on a reduced copy, corners refined at
// full resolution) against the same detector run at full resolution and against OpenCV's
// findChessboardCornersSB alone at full resolution (the peer; what porthole did before issue 10).
// Counters: max_err_px = largest distance to the true corners; max_vs_full_px = largest distance to
// the full-resolution detection's corners (acceptance: <= 0.02 px); the time per image.
// Peak memory is measured apart (docs/robustness.md: /usr/bin/time -v porthole detect).
#include <benchmark/benchmark.h>

#include <opencv2/calib3d.hpp>

#include "porthole/calib/detect.h"
#include "porthole/calib/render_board.h"

namespace {
using namespace porthole::calib;

constexpr int kW = 4288, kH = 2848, kCols = 9, kRows = 6;

const RenderedBoard& Board() {
  static const RenderedBoard b = RenderChessboard(kW, kH, kCols, kRows, ObliqueBoardHomography(kW, kH, kCols, kRows, 300));
  return b;
}

// Largest distance between two corner lists, in either order of a 180-degree-symmetric board.
template <typename P, typename Q>
double MaxDistance(const std::vector<P>& a, const std::vector<Q>& b) {
  double worst[2] = {0, 0};
  const std::size_t n = b.size();
  if (a.size() != n) return NAN;
  for (std::size_t i = 0; i < n; ++i) {
    worst[0] = std::max(worst[0], std::hypot(double(a[i].x) - b[i].x, double(a[i].y) - b[i].y));
    worst[1] = std::max(worst[1], std::hypot(double(a[i].x) - b[n - 1 - i].x, double(a[i].y) - b[n - 1 - i].y));
  }
  return std::min(worst[0], worst[1]);
}

std::vector<cv::Point2f> Detect(bool reduce) {
  std::vector<int> ids;
  std::vector<cv::Point2f> pts;
  DetectInImage(Board().gray, ParseTarget("chessboard:9x6:25"), &ids, &pts, {}, reduce);
  return pts;
}

void BM_Detect12MP_Porthole(benchmark::State& state) {
  std::vector<cv::Point2f> pts;
  for (auto _ : state) pts = Detect(true);
  state.counters["max_err_px"] = MaxDistance(pts, Board().corners_px);
  state.counters["max_vs_full_px"] = MaxDistance(pts, Detect(false));
}
BENCHMARK(BM_Detect12MP_Porthole)->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_Detect12MP_PortholeFullResolution(benchmark::State& state) {
  std::vector<cv::Point2f> pts;
  for (auto _ : state) pts = Detect(false);
  state.counters["max_err_px"] = MaxDistance(pts, Board().corners_px);
}
BENCHMARK(BM_Detect12MP_PortholeFullResolution)->Unit(benchmark::kMillisecond)->Iterations(1);

void BM_Detect12MP_OpenCVSBFullResolution(benchmark::State& state) {
  std::vector<cv::Point2f> pts;
  for (auto _ : state) {
    cv::findChessboardCornersSB(Board().gray, cv::Size(kCols, kRows), pts,
                                cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_EXHAUSTIVE | cv::CALIB_CB_ACCURACY);
  }
  state.counters["max_err_px"] = MaxDistance(pts, Board().corners_px);
}
BENCHMARK(BM_Detect12MP_OpenCVSBFullResolution)->Unit(benchmark::kMillisecond)->Iterations(1);

}  // namespace
