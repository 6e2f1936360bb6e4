// Proves detection and calibration on real images: OpenCV's sample chessboards (Debian opencv-doc,
// left01–14.jpg, 9×6 inner corners) give an RMS within 1 % of cv::calibrateCamera with the same
// model and a principal distance within 0.5 % of its fx; bad images are skipped, not fatal.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/aruco/charuco.hpp>
#include <opencv2/imgproc.hpp>

#include "porthole/calib/calibrate.h"
#include "porthole/calib/detect.h"

namespace porthole::calib {
namespace {
namespace fs = std::filesystem;

// The samples as Debian installs them (plain or gzipped), copied into a temporary directory.
fs::path SampleDir() {
  static const fs::path dir = [] {
    const fs::path out = fs::temp_directory_path() / "porthole_calib_samples";
    fs::create_directories(out);
    for (const char* src : {"/usr/share/doc/opencv-doc/examples/data",
                            "/usr/share/opencv4/samples/data"}) {
      if (!fs::is_directory(src)) continue;
      for (const auto& e : fs::directory_iterator(src)) {
        const std::string name = e.path().filename().string();
        if (name.rfind("left", 0) != 0 || name.size() < 10) continue;  // left01.jpg[.gz]
        if (e.path().extension() == ".jpg") {
          fs::copy_file(e.path(), out / name, fs::copy_options::overwrite_existing);
        } else if (e.path().extension() == ".gz") {
          const std::string cmd = "gzip -dc '" + e.path().string() + "' > '" +
                                  (out / e.path().stem()).string() + "'";
          if (std::system(cmd.c_str()) != 0) continue;
        }
      }
      break;
    }
    return out;
  }();
  return dir;
}

struct OpenCVRun {
  double rms_px = 0, fx = 0;
};

OpenCVRun CalibrateWithOpenCV(const std::vector<ImageDetections>& dets, const TargetSpec& target,
                              int flags) {
  std::vector<std::vector<cv::Point3f>> object;
  std::vector<std::vector<cv::Point2f>> image;
  ToOpenCVCorrespondences(dets, target, &object, &image);
  cv::Mat k = cv::Mat::eye(3, 3, CV_64F), dist;
  std::vector<cv::Mat> rv, tv;
  OpenCVRun r;
  r.rms_px = cv::calibrateCamera(object, image, cv::Size(dets[0].width_px, dets[0].height_px), k,
                                 dist, rv, tv, flags);
  r.fx = k.at<double>(0, 0);
  return r;
}

class CalibRealTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const auto paths = ListImages(SampleDir().string());
    target_ = new TargetSpec(ParseTarget("chessboard:9x6:25"));
    run_ = new DetectionRun(DetectAll(paths, *target_));
  }
  static void TearDownTestSuite() {
    delete run_;
    delete target_;
  }
  static TargetSpec* target_;
  static DetectionRun* run_;
};
TargetSpec* CalibRealTest::target_ = nullptr;
DetectionRun* CalibRealTest::run_ = nullptr;

TEST_F(CalibRealTest, DetectsTheSampleChessboards) {
  // Debian ships 13 of the 14 (left10.jpg is missing); each must give all 54 corners.
  ASSERT_GE(run_->detections.size(), 13u) << "install opencv-doc (scripts/install-deps)";
  for (const auto& d : run_->detections) {
    EXPECT_EQ(d.ids.size(), 54u) << d.image;
    EXPECT_EQ(d.width_px, 640);
    EXPECT_EQ(d.height_px, 480);
  }
}

// OpenCV with fx = fy, k3 fixed = porthole's c, x0, y0, K1, K2, P1, P2 (7 parameters each); and
// with k3 / K3 free (8 each).
TEST_F(CalibRealTest, MatchesOpenCVCalibrateCamera) {
  ASSERT_GE(run_->detections.size(), 13u);
  for (const bool k3 : {false, true}) {
    const int flags = cv::CALIB_FIX_ASPECT_RATIO | (k3 ? 0 : cv::CALIB_FIX_K3);
    const auto cv_run = CalibrateWithOpenCV(run_->detections, *target_, flags);
    CalibrationOptions o;
    o.reject_k = 0;  // the same points as OpenCV
    o.free = ParseFreeParameters(camera::CameraModelId::kBrown,
                                 k3 ? "c,x0,y0,K1,K2,K3,P1,P2" : "c,x0,y0,K1,K2,P1,P2");
    const auto r = Calibrate(run_->detections, *target_, o);
    ASSERT_TRUE(r.covariance_ok) << r.message;
    EXPECT_NEAR(r.rms_px, cv_run.rms_px, 0.01 * cv_run.rms_px) << "k3 " << k3;
    EXPECT_NEAR(r.camera.params[camera::kBrownC], cv_run.fx, 0.005 * cv_run.fx) << "k3 " << k3;
    EXPECT_GT(r.camera.params[camera::kBrownK1], 0);  // barrel in the correction convention (OpenCV k1 < 0)
    std::printf("k3 %d: porthole RMS %.5f px, c %.3f px; OpenCV RMS %.5f px, fx %.3f px\n", k3,
                r.rms_px, r.camera.params[camera::kBrownC], cv_run.rms_px, cv_run.fx);
  }
}

TEST_F(CalibRealTest, BadImagesAreSkipped) {
  const fs::path dir = fs::temp_directory_path() / "porthole_calib_bad";
  fs::create_directories(dir);
  std::ofstream(dir / "broken.jpg") << "not a JPEG";
  cv::imwrite((dir / "blank.png").string(), cv::Mat(480, 640, CV_8U, cv::Scalar(128)));
  fs::copy_file(SampleDir() / "left01.jpg", dir / "left01.jpg",
                fs::copy_options::overwrite_existing);
  const auto run = DetectAll(ListImages(dir.string()), *target_);
  ASSERT_EQ(run.detections.size(), 1u);
  ASSERT_EQ(run.skipped.size(), 2u);
  EXPECT_EQ(run.skipped[0].image, "blank.png");
  EXPECT_EQ(run.skipped[0].reason, "no target found");
  EXPECT_EQ(run.skipped[1].reason.rfind("not an image (", 0), 0u) << run.skipped[1].reason;  // says why (issue 24)
  EXPECT_THROW(Calibrate(run.detections, *target_), InvalidInput);  // one image is too few
}

TEST(CalibDetectTest, CharucoAndCircleGrids) {
  // A rendered ChArUco board: every inner corner found with its id.
  const auto t = ParseTarget("charuco:5x7:30:22");
  const auto board = cv::aruco::CharucoBoard::create(
      5, 7, 30, 22, cv::aruco::getPredefinedDictionary(cv::aruco::DICT_4X4_50));
  cv::Mat img;
  board->draw(cv::Size(500, 700), img, 40);
  const fs::path p = fs::temp_directory_path() / "porthole_charuco.png";
  cv::imwrite(p.string(), img);
  const auto r = DetectTarget(p.string(), t);
  ASSERT_TRUE(r.detections) << r.reason;
  EXPECT_EQ(r.detections->ids.size(), 24u);
  // A drawn 4×3 symmetric circle grid, spacing 60 px, first centre at (60, 60).
  cv::Mat grid(300, 360, CV_8U, cv::Scalar(255));
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 4; ++j) cv::circle(grid, {60 + 60 * j, 60 + 60 * i}, 15, 0, -1);
  const fs::path q = fs::temp_directory_path() / "porthole_circles.png";
  cv::imwrite(q.string(), grid);
  const auto c = DetectTarget(q.string(), ParseTarget("circles:4x3:20"));
  ASSERT_TRUE(c.detections) << c.reason;
  ASSERT_EQ(c.detections->ids.size(), 12u);
  // A symmetric grid has no preferred corner: each centre must lie on a drawn one.
  for (const auto& q : c.detections->points_px) {
    const double u = std::round(q.x() / 60) * 60, v = std::round(q.y() / 60) * 60;
    EXPECT_NEAR(q.x(), u, 0.5);
    EXPECT_NEAR(q.y(), v, 0.5);
    EXPECT_TRUE(u >= 60 && u <= 240 && v >= 60 && v <= 180) << u << "," << v;
  }
}

}  // namespace
}  // namespace porthole::calib
