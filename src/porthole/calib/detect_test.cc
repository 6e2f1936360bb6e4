// Detection on rendered chessboards with known corners (render_board.h), and the image-header and
// size checks that keep hostile images from being decoded (docs/robustness.md).
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

#include "porthole/calib/detect.h"
#include "porthole/calib/render_board.h"

namespace porthole::calib {
namespace {

// Largest distance between detected and true corners, px, in whichever of the two orders a
// chessboard allows (OpenCV may start from either end of a board symmetric under 180 degrees).
double MaxError(const std::vector<cv::Point2f>& found, const std::vector<cv::Point2d>& truth) {
  double worst[2] = {0, 0};
  const std::size_t n = truth.size();
  for (std::size_t i = 0; i < n; ++i) {
    worst[0] = std::max(worst[0], std::hypot(found[i].x - truth[i].x, found[i].y - truth[i].y));
    worst[1] = std::max(worst[1], std::hypot(found[i].x - truth[n - 1 - i].x, found[i].y - truth[n - 1 - i].y));
  }
  return std::min(worst[0], worst[1]);
}

TEST(Detect, ReducedCopyRefinedAtFullResolutionFindsTheTrueCorners) {
  // 12 MP like the paper's D300 (4288 x 2848); 9 x 6 inner corners, squares of ~300 px.
  const int w = 4288, h = 2848, cols = 9, rows = 6;
  const auto board = RenderChessboard(w, h, cols, rows, ObliqueBoardHomography(w, h, cols, rows, 300));
  const TargetSpec t = ParseTarget("chessboard:9x6:25");
  std::vector<int> ids;
  std::vector<cv::Point2f> pts;
  ASSERT_TRUE(DetectInImage(board.gray, t, &ids, &pts));
  ASSERT_EQ(pts.size(), board.corners_px.size());
  // Rendering is exact to the 16 x 16 supersampling of edge pixels and 8-bit quantisation.
  EXPECT_LT(MaxError(pts, board.corners_px), 0.02);
}

TEST(Detect, SmallImagesAreSearchedAtFullResolution) {
  const int w = 900, h = 600, cols = 9, rows = 6;
  const auto board = RenderChessboard(w, h, cols, rows, ObliqueBoardHomography(w, h, cols, rows, 60));
  std::vector<int> ids;
  std::vector<cv::Point2f> pts;
  ASSERT_TRUE(DetectInImage(board.gray, ParseTarget("chessboard:9x6:25"), &ids, &pts));
  EXPECT_LT(MaxError(pts, board.corners_px), 0.02);
}

std::string Write(const std::string& name, const std::string& bytes) {
  const auto p = std::filesystem::temp_directory_path() / name;
  std::ofstream(p, std::ios::binary) << bytes;
  return p.string();
}

TEST(Detect, ImageSizeFromHeadersWithoutDecoding) {
  const auto board = RenderChessboard(320, 200, 4, 3, ObliqueBoardHomography(320, 200, 4, 3, 40));
  for (const char* ext : {".png", ".jpg", ".bmp", ".pgm", ".tif"}) {
    const auto p = (std::filesystem::temp_directory_path() / (std::string("porthole_size") + ext)).string();
    ASSERT_TRUE(cv::imwrite(p, board.gray)) << ext;
    const auto size = ReadImageSize(p);
    ASSERT_TRUE(size.has_value()) << ext;
    EXPECT_EQ(size->first, 320) << ext;
    EXPECT_EQ(size->second, 200) << ext;
  }
  EXPECT_FALSE(ReadImageSize(Write("porthole_size.xyz", "not an image")).has_value());
}

TEST(Detect, OversizeImagesAreSkippedBeforeDecoding) {
  // A PGM header claiming 99999 x 99999 px (10 gigapixels) over 100 bytes: skipped at once.
  const auto p = Write("porthole_huge.pgm", "P5\n99999 99999\n255\n" + std::string(100, '\0'));
  const auto t0 = std::chrono::steady_clock::now();
  const DetectResult r = DetectTarget(p, ParseTarget("chessboard:9x6:25"));
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 5.0);
  EXPECT_FALSE(r.detections.has_value());
  EXPECT_NE(r.reason.find("too large: 99999 x 99999"), std::string::npos) << r.reason;
  const DetectResult bad = DetectTarget(Write("porthole_bad.png", "\x89PNG\r\n\x1a\n garbage"), ParseTarget("chessboard:9x6:25"));
  EXPECT_FALSE(bad.detections.has_value());
  EXPECT_NE(bad.reason.find("unreadable"), std::string::npos) << bad.reason;
}

}  // namespace
}  // namespace porthole::calib
