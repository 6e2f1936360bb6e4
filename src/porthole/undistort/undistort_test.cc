// Proves the undistortion map: central maps round-trip through the camera model within 1e-6 px
// (and the float table within 1e-3 px), alpha 0 keeps only valid pixels and alpha 1 every source
// pixel, keep-focal keeps f; the refractive map's grid interpolation stays within 2e-3 px of the
// exact map, the residual vanishes at the map's single depth (a rig camera's pose changes nothing),
// and bad options are refused by field.
#include "porthole/undistort/undistort.h"

#include <gtest/gtest.h>

#include <random>

#include "porthole/render/render.h"
#include "porthole/render/test_scenes.h"

namespace porthole::undistort {
namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

measure::RigCamera OpenCVCamera() {
  measure::RigCamera c;
  c.camera.model = camera::CameraModelId::kOpenCV;
  c.camera.sensor = {960, 640, 0.0055};
  c.camera.params = {800, 803, 482.3, 317.1, -0.21, 0.06, 0.0012, -0.0007, 0, 0, 0, 0};
  return c;
}

measure::RigCamera BrownCamera() {
  measure::RigCamera c;
  c.camera.model = camera::CameraModelId::kBrown;
  c.camera.sensor = {960, 640, 0.0246};
  // c, x0, y0, K1, K2, K3, P1, P2, B1, B2: a 24 mm lens on a reduced D300 frame, barrel.
  c.camera.params = {24.5, 0.05, -0.08, 1.8e-4, -3e-7, 0, 2e-5, -1e-5, 1e-4, 0};
  return c;
}

measure::RigCamera KannalaBrandtCamera() {
  measure::RigCamera c;
  c.camera.model = camera::CameraModelId::kKannalaBrandt;
  c.camera.sensor = {960, 640, 0.003};
  c.camera.params = {420, 421, 480.5, 318.7, 0.02, -0.01, 0.002, -0.0003};
  return c;
}

measure::RigCamera DomeCamera() {
  render::Scene s = render::testing::PaperScene("nimar-ni320", 960);
  s.focus_distance_mm = 1500;
  s.bands_nm = {546.07};
  s.target = calib::ParseTarget("chessboard:9x6:60");
  s.pose = render::PoseFacing(s.target, 1500);
  const render::Setup setup = render::Resolve(s);
  measure::RigCamera c;
  c.camera = setup.camera;
  c.shell = refraction::ShellOf(setup.system);
  c.port = refraction::ParamsOf(setup.system);
  return c;
}

void ExpectRoundTrip(const measure::RigCamera& cam, const UndistortOptions& o) {
  const Undistorter u = Prepare(cam, o);
  const cv::Mat map = BuildMap(u);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> du(0, u.pinhole.width_px - 1),
      dv(0, u.pinhole.height_px - 1);
  double worst = 0, worst_table = 0;
  int n = 0;
  for (int i = 0; i < 2000; ++i) {
    const Vector2d q(du(rng), dv(rng));
    const auto s = u.SourcePixel(q);
    if (!s) continue;
    const auto ray = cam.camera.Unproject(*s);
    ASSERT_TRUE(ray) << s->transpose();
    worst = std::max(worst, (u.pinhole.Project(*ray) - q).norm());
    const int c = static_cast<int>(std::lround(q.x())), r = static_cast<int>(std::lround(q.y()));
    const auto st = u.SourcePixel(Vector2d(c, r));
    const cv::Vec2f m = map.at<cv::Vec2f>(r, c);
    if (st) worst_table = std::max(worst_table, (Vector2d(m[0], m[1]) - *st).norm()), ++n;
  }
  EXPECT_GT(n, 1500);
  EXPECT_LT(worst, 1e-6) << cam.camera.model_name();
  EXPECT_LT(worst_table, 1e-3) << cam.camera.model_name();
}

TEST(Undistort, CentralMapRoundTripsThroughTheCameraModel) {
  for (const auto& cam : {OpenCVCamera(), BrownCamera(), KannalaBrandtCamera()}) {
    ExpectRoundTrip(cam, {});
    UndistortOptions one;
    one.alpha = 1;
    ExpectRoundTrip(cam, one);
  }
}

bool Inside(const Vector2d& p, int w, int h, double tol) {
  return p.x() >= -tol && p.y() >= -tol && p.x() <= w - 1 + tol && p.y() <= h - 1 + tol;
}

TEST(Undistort, AlphaZeroKeepsOnlyValidPixelsAndOneEverySourcePixel) {
  for (const auto& cam : {OpenCVCamera(), BrownCamera()}) {
    const auto& s = cam.camera.sensor;
    UndistortOptions zero, one;
    zero.alpha = 0;
    one.alpha = 1;
    const Undistorter u0 = Prepare(cam, zero), u1 = Prepare(cam, one);
    // alpha 0: every output pixel comes from inside the source frame.
    int outside = 0;
    for (const Vector2d& q :
         camera::FramePixels({u0.pinhole.width_px, u0.pinhole.height_px, 1}, 97, 65)) {
      const auto src = u0.SourcePixel(q);
      if (!src || !Inside(*src, s.width_px, s.height_px, 0.05)) ++outside;
    }
    EXPECT_EQ(outside, 0) << cam.camera.model_name();
    // alpha 1: every source pixel of the frame's edge lands inside the output, and the output's
    // edges touch it (the bounding box, not larger).
    double umin = 1e9, umax = -1e9, vmin = 1e9, vmax = -1e9;
    for (const Vector2d& p : camera::FramePixels(s, 97, 65)) {
      const auto ray = cam.camera.Unproject(p);
      ASSERT_TRUE(ray);
      const Vector2d q = u1.pinhole.Project(*ray);
      EXPECT_TRUE(Inside(q, u1.pinhole.width_px, u1.pinhole.height_px, 0.05)) << q.transpose();
      umin = std::min(umin, q.x()), umax = std::max(umax, q.x()), vmin = std::min(vmin, q.y()),
      vmax = std::max(vmax, q.y());
    }
    EXPECT_NEAR(umin, 0, 0.5);
    EXPECT_NEAR(umax, s.width_px - 1, 0.5);
    EXPECT_NEAR(vmin, 0, 0.5);
    EXPECT_NEAR(vmax, s.height_px - 1, 0.5);
    // Between them the focal length falls monotonically (more field, smaller scale).
    EXPECT_GT(u0.pinhole.fx, u1.pinhole.fx);
  }
}

TEST(Undistort, KeepFocalKeepsTheLensFocalLengthAndPrincipalPoint) {
  const auto cam = OpenCVCamera();
  UndistortOptions o;
  o.keep_focal = true;
  const Undistorter u = Prepare(cam, o);
  EXPECT_DOUBLE_EQ(u.pinhole.fx, cam.camera.FocalLengthPx());
  EXPECT_DOUBLE_EQ(u.pinhole.cx, 482.3);
  EXPECT_DOUBLE_EQ(u.pinhole.cy, 317.1);
  EXPECT_EQ(u.pinhole.width_px, 960);
}

TEST(Undistort, RefractiveGridMapFollowsTheExactMapAndResidualVanishesAtItsDepth) {
  const auto cam = DomeCamera();
  UndistortOptions o;
  o.wd_mm = {1000};
  o.alpha = 0;
  const Undistorter u = Prepare(cam, o);
  EXPECT_TRUE(u.refractive);
  EXPECT_GT(u.vertex_z_mm, 50);  // the NI320's vertex lies ≈ 78 mm ahead of the pupil
  EXPECT_LT(u.vertex_z_mm, 100);
  const cv::Mat map = BuildMap(u, 8);
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> du(0, 959), dv(0, 639);
  double worst = 0;
  for (int i = 0; i < 300; ++i) {
    const int c = du(rng), r = dv(rng);
    const auto s = u.SourcePixel(Vector2d(c, r));
    ASSERT_TRUE(s);
    const cv::Vec2f m = map.at<cv::Vec2f>(r, c);
    worst = std::max(worst, (Vector2d(m[0], m[1]) - *s).norm());
  }
  EXPECT_LT(worst, 2e-3);
  // At the map's depth the pinhole is exact; elsewhere it is not.
  double at_wd = 0, at_half = 0;
  for (const Vector2d& q : camera::FramePixels({960, 640, 1}, 9, 7)) {
    const Vector3d d = u.pinhole.Ray(q);
    const auto x = [&](double wd) {
      return Vector3d(u.pinhole.centre_mm + d * (wd + u.vertex_z_mm - u.pinhole.centre_mm.z()));
    };
    const auto r1 = u.Residual(x(1000));
    const auto r2 = u.Residual(x(300));
    ASSERT_TRUE(r1 && r2);
    at_wd = std::max(at_wd, r1->norm());
    at_half = std::max(at_half, r2->norm());
  }
  EXPECT_LT(at_wd, 1e-6);
  EXPECT_GT(at_half, 10 * at_wd);
  // A rig camera's pose in the rig (cam_from_rig) does not change its own undistortion.
  measure::RigCamera moved = cam;
  moved.rotation_rad = Vector3d(0.02, -0.1, 0.03);
  moved.translation_mm = Vector3d(-300, 5, 2);
  const Undistorter v = Prepare(moved, o);
  EXPECT_NEAR(v.pinhole.fx, u.pinhole.fx, 1e-9 * u.pinhole.fx);
  EXPECT_NEAR(v.vertex_z_mm, u.vertex_z_mm, 1e-9);
  const auto a = u.SourcePixel(Vector2d(100, 50)), b = v.SourcePixel(Vector2d(100, 50));
  ASSERT_TRUE(a && b);
  EXPECT_LT((*a - *b).norm(), 1e-9);
}

// The remap interpolates with the map's exact fractions: a ramp comes out as the ramp at the source
// pixel to float precision (cv::remap's 1/32-px fractions would leave up to 1.1 here), and the
// 8-bit fixed-point path (1/2048 px) rounds the float result within 1 level; 16-bit and colour
// alike.
TEST(Undistort, RemapReproducesARampAtTheSourcePixel) {
  const Undistorter u = Prepare(OpenCVCamera(), {});
  const cv::Mat map = BuildMap(u);
  cv::Mat ramp(640, 960, CV_32F);
  for (int v = 0; v < 640; ++v) {
    for (int c = 0; c < 960; ++c) ramp.at<float>(v, c) = 50.0f * c + 20.0f * v;
  }
  const cv::Mat out = Remap(ramp, map, Interpolation::kLinear);
  double worst = 0;
  for (int v = 0; v < 640; ++v) {
    for (int c = 0; c < 960; ++c) {
      const cv::Vec2f m = map.at<cv::Vec2f>(v, c);
      if (m[0] < 0 || m[1] < 0 || m[0] > 959 || m[1] > 639) continue;
      worst = std::max(worst, std::abs(out.at<float>(v, c) - (50.0 * m[0] + 20.0 * m[1])));
    }
  }
  EXPECT_LT(worst, 0.02);
  cv::Mat small, out8, outf;
  cv::Mat rgb(640, 960, CV_32FC3);
  cv::randu(rgb, cv::Scalar::all(0), cv::Scalar::all(255));
  rgb.convertTo(small, CV_8UC3);
  small.convertTo(rgb, CV_32FC3);
  out8 = Remap(small, map, Interpolation::kLinear);
  outf = Remap(rgb, map, Interpolation::kLinear);
  cv::Mat rounded;
  outf.convertTo(rounded, CV_8UC3);
  cv::Mat diff;
  cv::absdiff(out8, rounded, diff);
  double mx = 0;
  cv::minMaxLoc(diff.reshape(1), nullptr, &mx);
  EXPECT_LE(mx, 1.0);
  cv::Mat r16, o16;
  small.convertTo(r16, CV_16UC3, 257.0);
  o16 = Remap(r16, map, Interpolation::kNearest);
  EXPECT_EQ(o16.type(), CV_16UC3);
}

TEST(Undistort, BadOptionsAreRefusedNamingTheField) {
  const auto central = OpenCVCamera();
  const auto dome = DomeCamera();
  const auto field = [](const auto& f) -> std::string {
    try {
      f();
    } catch (const InvalidInput& e) {
      return e.field();
    }
    return "";
  };
  UndistortOptions o;
  o.alpha = 1.5;
  EXPECT_EQ(field([&] { Prepare(central, o); }), "alpha");
  o.alpha = -0.1;
  EXPECT_EQ(field([&] { Prepare(central, o); }), "alpha");
  o = {};
  o.wd_mm = {1000};
  EXPECT_EQ(field([&] { Prepare(central, o); }), "wd_mm");
  o = {};
  EXPECT_EQ(field([&] { Prepare(dome, o); }), "wd_mm");
  o.wd_mm = {2000, 1000};
  EXPECT_EQ(field([&] { Prepare(dome, o); }), "wd_mm");
  o.wd_mm = {-5};
  EXPECT_EQ(field([&] { Prepare(dome, o); }), "wd_mm");
  o = {};
  o.alpha = 0.5;
  o.keep_focal = true;
  EXPECT_EQ(field([&] { Prepare(central, o); }), "keep_focal");
  EXPECT_EQ(field([&] { InterpolationFromName("bicubic", "interpolation"); }), "interpolation");
}

}  // namespace
}  // namespace porthole::undistort
