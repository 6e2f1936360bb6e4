// Detection on rendered chessboards with known corners (render_board.h), a coded target field's
// uncoded dots found through a TargetSpec carrying the field, the image-header and size checks
// that keep hostile images from being decoded, PNG through libpng equal to imread, and the pixel
// budget of parallel detection (docs/robustness.md).
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <fmt/format.h>

#include "porthole/calib/detect.h"
#include "porthole/calib/render_board.h"
#include "porthole/coded/test_fields.h"

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
  EXPECT_EQ(bad.reason.rfind("not an image (", 0), 0u) << bad.reason;
}

// Issue 24: PNG is decoded through libpng itself (its warnings kept, not printed): the pixels are
// exactly cv::imread's for IMREAD_GRAYSCALE, for grey, colour, alpha and 16-bit files.
TEST(Detect, PngThroughLibpngEqualsImread) {
  cv::Mat bgr(37, 53, CV_8UC3), bgra(37, 53, CV_8UC4), grey16(37, 53, CV_16U), bgr16(37, 53, CV_16UC3);
  cv::RNG rng(3);
  for (cv::Mat* m : {&bgr, &bgra, &grey16, &bgr16}) rng.fill(*m, cv::RNG::UNIFORM, 0, m->depth() == CV_8U ? 256 : 65536);
  cv::Mat grey;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  int k = 0;
  for (const cv::Mat* m : {&grey, &bgr, &bgra, &grey16, &bgr16}) {
    const auto p = (std::filesystem::temp_directory_path() / fmt::format("porthole_png_{}.png", k++)).string();
    ASSERT_TRUE(cv::imwrite(p, *m));
    std::string warning, error;
    const cv::Mat mine = ReadPngGray(p, &warning, &error);
    const cv::Mat theirs = cv::imread(p, cv::IMREAD_GRAYSCALE);
    ASSERT_EQ(mine.type(), CV_8UC1) << k << error;
    ASSERT_EQ(mine.size(), theirs.size()) << k;
    EXPECT_EQ(cv::norm(mine, theirs, cv::NORM_INF), 0) << "image " << k << " (type " << m->type() << ")";
    EXPECT_EQ(warning, "");
  }
  // A size over libpng's limits set from the header check: refused by the decoder itself.
  const auto p = (std::filesystem::temp_directory_path() / "porthole_png_limit.png").string();
  ASSERT_TRUE(cv::imwrite(p, bgr));
  std::string error;
  EXPECT_TRUE(ReadPngGray(p, nullptr, &error, 50, 50).empty());
  EXPECT_NE(error, "");
}

// Images are decoded and searched at once only while their pixels fit the budget: a budget of one
// pixel still runs every image (one at a time), none is lost or refused.
TEST(Detect, PixelBudgetRunsImagesOneAtATime) {
  const auto board = RenderChessboard(900, 600, 9, 6, ObliqueBoardHomography(900, 600, 9, 6, 60));
  std::vector<std::string> paths;
  for (int i = 0; i < 4; ++i) {
    paths.push_back((std::filesystem::temp_directory_path() / fmt::format("porthole_budget_{}.png", i)).string());
    ASSERT_TRUE(cv::imwrite(paths.back(), board.gray));
  }
  DetectOptions o;
  o.max_pixels_in_flight = 1;
  o.threads = 4;
  const DetectionRun run = DetectAll(paths, ParseTarget("chessboard:9x6:25"), {}, o);
  EXPECT_EQ(run.detections.size(), 4u);
  EXPECT_TRUE(run.skipped.empty());
}

// A coded target whose field holds uncoded dots (IDs above the code count): detection through the
// TargetSpec (as `detect --field` and `calibrate` do) reports them with their field IDs, where
// they are in the image, read back from an 8-bit PNG with barrel distortion; without the field,
// only the coded targets.
TEST(Detect, CodedFieldReportsItsUncodedDotsByFieldId) {
  TargetSpec t = ParseTarget("coded:14:3");
  t.field = coded::testing::GridField(15, 11, 24, 0);
  ASSERT_TRUE(HasUncodedDots(t));
  coded::testing::FieldView fv;
  fv.cam = coded::LookAtSheet(Eigen::Vector2d(168, 120), 520, 35, 60, 10, 1400, 1200, 900);
  fv.k1 = -0.15;
  const auto cov = coded::testing::DrawField(t.field, 3, coded::Profile::kAicon, 14, fv, 8);
  cv::Mat img(fv.cam.height, fv.cam.width, CV_8U);
  for (int v = 0; v < img.rows; ++v) {
    for (int u = 0; u < img.cols; ++u) img.at<uint8_t>(v, u) = cv::saturate_cast<uint8_t>(220 - 190 * cov.ink[v * img.cols + u]);
  }
  const auto path = std::filesystem::temp_directory_path() / "porthole_uncoded_field.png";
  ASSERT_TRUE(cv::imwrite(path.string(), img));
  const DetectResult r = DetectTarget(path.string(), t);
  ASSERT_TRUE(r.detections && r.uncoded);
  int uncoded = 0;
  double worst = 0;
  for (std::size_t k = 0; k < r.detections->ids.size(); ++k) {
    const int id = r.detections->ids[k];
    ASSERT_TRUE(cov.truth.count(id)) << id;
    const double e = (r.detections->points_px[k] - cov.truth.at(id)).norm();
    EXPECT_LT(e, 0.1) << id;
    worst = std::max(worst, e);
    uncoded += coded::IsUncodedId(coded::Profile::kAicon, 14, id);
  }
  std::printf("%zu points, %d uncoded (%zu inside the image), worst %.4f px | %s\n", r.detections->ids.size(), uncoded,
              cov.eligible.size(), worst, r.uncoded->ToString().c_str());
  EXPECT_EQ(uncoded, r.uncoded->matched);
  EXPECT_GE(uncoded, static_cast<int>(cov.eligible.size()) - 2);
  TargetSpec sheet = ParseTarget("coded:14:3");  // no field: the default sheet's IDs, no uncoded dots
  const DetectResult plain = DetectTarget(path.string(), sheet);
  EXPECT_FALSE(plain.uncoded);
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace porthole::calib
