// Proves the frame sources and the automatic choice (calib/frames.h): the edge-blur measure gives the
// blur of a rendered edge, whatever its contrast and with sensor noise; the tilt of a board is
// read from its homography alone; the choice drops blurred frames and spreads the rest over the
// frame's cells and the tilts; a video written by OpenCV (FFmpeg backend) is read frame by frame
// with each frame's index and time.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <unistd.h>
#include <fmt/format.h>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "porthole/calib/frames.h"
#include "porthole/calib/render_board.h"
#include "porthole/core/error.h"

namespace porthole::calib {
namespace {

namespace fs = std::filesystem;

// A straight edge at angle a through the image centre, blurred by a Gaussian of sigma px, sampled
// at the pixel centres: 60 + contrast * Phi(distance / sigma).
cv::Mat BlurredEdge(double sigma, double contrast, double noise = 0, double a = 0.3) {
  cv::Mat img(200, 200, CV_8U);
  cv::RNG rng(7);
  for (int v = 0; v < img.rows; ++v) {
    for (int u = 0; u < img.cols; ++u) {
      const double d = (u - 100) * std::cos(a) + (v - 100) * std::sin(a);
      img.at<unsigned char>(v, u) = cv::saturate_cast<unsigned char>(60 + contrast * 0.5 * std::erfc(-d / (sigma * std::sqrt(2.0))) + rng.gaussian(noise));
    }
  }
  return img;
}

TEST(Frames, EdgeBlurIsTheBlurOfARenderedEdgeDespiteContrastAndNoise) {
  const std::vector<cv::Point2f> box = {{40, 40}, {160, 40}, {160, 160}, {40, 160}};
  for (double sigma : {1.0, 2.0, 3.0, 5.0}) {
    const double b = EdgeBlurPx(BlurredEdge(sigma, 150), box);
    const double low = EdgeBlurPx(BlurredEdge(sigma, 60), box), noisy = EdgeBlurPx(BlurredEdge(sigma, 150, 2), box);
    std::printf("edge blurred by sigma %.0f px: measured %.3f px (contrast 60: %.3f, sensor noise 2 levels: %.3f)\n",
                sigma, b, low, noisy);
    EXPECT_NEAR(b, sigma, 0.15) << sigma;
    EXPECT_NEAR(low, sigma, 0.15) << sigma;
    EXPECT_NEAR(noisy, sigma, 0.1 * sigma) << sigma;  // one edge in the box: noise counts more than on a board
  }
  EXPECT_TRUE(std::isnan(EdgeBlurPx(BlurredEdge(2, 150), {{1, 1}, {2, 2}})));
}

// A board of cols x rows inner corners (squares of `square` mm) seen by a pinhole of f px at
// distance z mm, tilted by `tilt_deg` about the image's y axis (toward +u: the right side nearer),
// its centre shifted to (cu, cv) px.
ImageDetections Seen(double tilt_deg, double cu, double cv_, double f = 1000, double z = 1500, int cols = 9,
                     int rows = 6, double square = 40) {
  ImageDetections d;
  d.image = "x";
  d.width_px = 1600, d.height_px = 1000;
  const double t = tilt_deg * M_PI / 180;
  const double x0 = (cu - 800) * z / f, y0 = (cv_ - 500) * z / f;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const double X = (c - (cols - 1) / 2.0) * square, Y = (r - (rows - 1) / 2.0) * square;
      // Rotation about y: the +X side moves toward the camera when tilt > 0.
      const double x = x0 + X * std::cos(t), y = y0 + Y, zz = z - X * std::sin(t);
      d.ids.push_back(r * cols + c);
      d.points_px.emplace_back(800 + f * x / zz, 500 + f * y / zz);
    }
  }
  return d;
}

TEST(Frames, TheChoiceDropsBlurredFramesAndSpreadsTheRest) {
  const TargetSpec target = ParseTarget("chessboard:9x6:40");
  DetectionRun run;
  // 12 near copies facing the camera at the centre (a diver hovering), then frames in the corners
  // and tilted ones; 3 of the centre ones blurred.
  for (int k = 0; k < 12; ++k) run.detections.push_back(Seen(0, 800 + k, 500));
  for (auto [u, v] : {std::pair{300.0, 250.0}, {1300, 250}, {300, 750}, {1300, 750}}) {
    run.detections.push_back(Seen(0, u, v));
  }
  for (double tilt : {-30.0, 30.0}) run.detections.push_back(Seen(tilt, 800, 500));
  for (std::size_t k = 0; k < run.detections.size(); ++k) {
    run.detections[k].image = fmt::format("f{:06d}", k);
    run.detections[k].blur_px = (k == 2 || k == 5 || k == 7) ? 2.5 : 0.6 + 0.001 * k;
  }
  run.uncoded.resize(run.detections.size());
  run.coded.resize(run.detections.size());
  FrameOptions o;
  FrameChoice all;
  {
    DetectionRun copy = run;
    ChooseFrames(&copy, target, o, &all);  // no choice asked: every frame, the blurred ones too
    EXPECT_EQ(copy.detections.size(), 18u);
    EXPECT_EQ(all.tilt_classes, 3);
  }
  o.max_frames = 7;
  FrameChoice c;
  ChooseFrames(&run, target, o, &c);
  EXPECT_EQ(c.found, 18);
  EXPECT_EQ(c.blurred, 3);
  ASSERT_EQ(run.skipped.size(), 3u);
  EXPECT_NE(run.skipped[0].reason.find("blurred"), std::string::npos) << run.skipped[0].reason;
  ASSERT_EQ(run.detections.size(), 7u);
  ASSERT_EQ(run.uncoded.size(), 7u);
  // The four corners, both tilts and one centre frame: every cell any frame covers, 3 tilt classes.
  int centre = 0;
  for (const auto& d : run.detections) {
    EXPECT_TRUE(d.image != "f000002" && d.image != "f000005" && d.image != "f000007") << d.image;
    centre += d.image < "f000012";
  }
  EXPECT_EQ(centre, 1);
  EXPECT_EQ(c.tilt_classes, 3);
  EXPECT_EQ(c.cells_covered, all.cells_covered);  // every cell the 18 cover
  EXPECT_EQ(c.chosen, 7);
}

TEST(Frames, TiltIsReadFromTheHomographyAlone) {
  const TargetSpec target = ParseTarget("chessboard:9x6:40");
  // Facing the camera anywhere in the frame: class 0. Tilted 20 degrees: toward +u (class 1) or -u
  // (class 5), at focal lengths of 600 and 2000 px.
  for (double f : {600.0, 2000.0}) {
    DetectionRun run;
    for (double tilt : {0.0, 20.0, -20.0}) run.detections.push_back(Seen(tilt, 700, 450, f, 1500 * f / 1000));
    run.detections.push_back(Seen(0, 300, 250, f, 1500 * f / 1000));
    run.uncoded.resize(4), run.coded.resize(4);
    FrameOptions o;
    FrameChoice c;
    ChooseFrames(&run, target, o, &c);
    EXPECT_EQ(c.tilt_classes, 3) << f;
  }
}

// A clip of 12 rendered boards, frames 4 and 9 blurred by a Gaussian of 1.5 px, written by OpenCV
// (MJPG through FFmpeg) at 10 fps.
std::string WriteClip(const fs::path& dir) {
  fs::create_directories(dir);
  const std::string path = (dir / "clip.avi").string();
  cv::VideoWriter w(path, cv::CAP_FFMPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10, cv::Size(640, 480), false);
  if (!w.isOpened()) return "";
  for (int k = 0; k < 12; ++k) {
    Eigen::Matrix3d H;
    H << 36, 2 * (k % 3), 120 + 6 * k, -1.5 * (k % 4), 36, 120 + 3 * k, 0, 0, 1;
    cv::Mat img = RenderChessboard(640, 480, 9, 6, H, 4).gray;
    if (k == 4 || k == 9) cv::GaussianBlur(img, img, cv::Size(0, 0), 1.5);
    w.write(img);
  }
  return path;
}

// OpenCV's findChessboardCornersSB draws from the thread's random state: the same frame was found
// or not depending on what the thread had searched before (detect.cc, DetectInImage).
TEST(Frames, DetectionDoesNotDependOnTheThreadsRandomState) {
  const fs::path dir = fs::temp_directory_path() / fmt::format("porthole_rng_{}", ::getpid());
  const std::string path = WriteClip(dir);
  ASSERT_FALSE(path.empty()) << "OpenCV cannot write MJPG through FFmpeg";
  cv::VideoCapture video(path, cv::CAP_FFMPEG);
  const TargetSpec target = ParseTarget("chessboard:9x6:40");
  cv::Mat frame, gray;
  int frames = 0;
  while (video.read(frame)) {
    cv::cvtColor(frame, gray, cv::COLOR_BGR2GRAY);
    std::vector<int> ids0;
    std::vector<cv::Point2f> pts0;
    cv::theRNG().state = 0;
    const bool found0 = DetectInImage(gray, target, &ids0, &pts0);
    for (std::uint64_t seed = 1; seed < 5; ++seed) {
      std::vector<int> ids;
      std::vector<cv::Point2f> pts;
      cv::theRNG().state = seed * 7919;
      ASSERT_EQ(DetectInImage(gray, target, &ids, &pts), found0) << "frame " << frames << ", seed " << seed;
      ASSERT_EQ(ids, ids0);
      for (std::size_t i = 0; i < pts.size(); ++i) ASSERT_EQ(pts[i], pts0[i]) << "frame " << frames;
    }
    ++frames;
  }
  EXPECT_EQ(frames, 12);
  fs::remove_all(dir);
}

TEST(Frames, AVideoIsReadFrameByFrameWithIndexAndTime) {
  const fs::path dir = fs::temp_directory_path() / fmt::format("porthole_frames_{}", ::getpid());
  const std::string path = WriteClip(dir);
  ASSERT_FALSE(path.empty()) << "OpenCV cannot write MJPG through FFmpeg";
  const double fps = 10;
  FrameOptions o;
  o.max_frames = 6;
  std::vector<std::string> lines;
  const SourceRun r = DetectSource(path, ParseTarget("chessboard:9x6:40"), o, [&](const std::string& s) { lines.push_back(s); });
  for (const auto& k : r.run.skipped) std::printf("skipped %s: %s\n", k.image.c_str(), k.reason.c_str());
  EXPECT_EQ(r.choice.kind, SourceKind::kVideo);
  EXPECT_EQ(r.choice.frames_in_source, 12);
  EXPECT_EQ(r.choice.searched, 12);
  // The detector may miss a blurred board; one it finds is left out as blurred.
  EXPECT_GE(r.choice.found, 9);
  EXPECT_GE(r.choice.blurred, 1);
  int blurred_or_missed = 0;
  for (const auto& k : r.run.skipped) blurred_or_missed += k.image.starts_with("f000004") || k.image.starts_with("f000009");
  EXPECT_EQ(blurred_or_missed, 2);
  ASSERT_EQ(r.run.detections.size(), 6u);
  for (const auto& d : r.run.detections) {
    EXPECT_NE(d.frame_index, 4);
    EXPECT_NE(d.frame_index, 9);
    EXPECT_EQ(d.image, fmt::format("f{:06d}", d.frame_index));
    EXPECT_NEAR(d.time_s, d.frame_index / fps, 1e-6) << d.image;
    EXPECT_EQ(d.width_px, 640);
    EXPECT_LT(d.blur_px, 0.8) << d.image;
  }
  ASSERT_FALSE(lines.empty());
  EXPECT_NE(lines.front().find("video, 12 frames at 10 fps"), std::string::npos) << lines.front();
  EXPECT_NE(lines.back().find("blurred, left out"), std::string::npos) << lines.back();
  EXPECT_NE(lines.back().find("6 kept"), std::string::npos) << lines.back();
  // Every other frame, no choice asked: all the even frames found, the blurred frame 4 too if found.
  o.every = 2;
  o.max_frames = 0;
  const SourceRun half = DetectSource(path, ParseTarget("chessboard:9x6:40"), o);
  EXPECT_EQ(half.choice.searched, 6);
  EXPECT_EQ(half.run.detections.size() + half.run.skipped.size(), 6u);
  EXPECT_EQ(half.choice.blurred, 0);
  for (const auto& d : half.run.detections) EXPECT_EQ(d.frame_index % 2, 0);
  // Not a video.
  std::ofstream(dir / "notes.txt") << "not a video\n";
  EXPECT_THROW(DetectSource((dir / "notes.txt").string(), ParseTarget("chessboard:9x6:40"), o), InvalidInput);
  EXPECT_THROW(DetectSource((dir / "missing.mp4").string(), ParseTarget("chessboard:9x6:40"), o), InvalidInput);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace porthole::calib
