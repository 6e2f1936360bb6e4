// Coded target fields rendered by `porthole render` (docs/render.md, "Target fields"): a field
// file's targets at their X, Y, Z, raised ones (Z < 0: toward the camera) on plates that hide what
// lies behind them; partial views, where only the targets imaged whole are in the truth. Checked
// against closed forms of the pinhole camera (no port: a dome concentric with the pupil in air),
// against the physics of that dome in water, and against the coded detector reading the images.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <vector>
#include <opencv2/core.hpp>

#include "porthole/coded/codes.h"
#include "porthole/coded/detect.h"
#include "porthole/coded/ellipse.h"
#include "porthole/core/error.h"
#include "porthole/render/dots.h"
#include "porthole/render/render.h"
#include "porthole/render/test_scenes.h"

namespace porthole::render {
namespace {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;

// The D300 + 24 mm on a `width` px frame, one band, a pinhole, `target` with `field`.
Scene FieldScene(const std::string& target, const std::vector<coded::PlacedTarget>& field, int width, Medium medium,
                 const std::string& port = "nimar-ni320") {
  Scene s = testing::PaperScene(port, width);
  s.target = calib::ParseTarget(target);
  s.target.field = field;
  s.medium = medium;
  s.bands_nm = {546.07};
  s.f_number = INFINITY;
  return s;
}

cv::Mat Gray16(const Image& im) {
  cv::Mat g(im.height, im.width, CV_16U);
  for (int v = 0; v < im.height; ++v) {
    for (int u = 0; u < im.width; ++u) g.at<uint16_t>(v, u) = static_cast<uint16_t>(std::lround(65535.0 * im.at(u, v)));
  }
  return g;
}

coded::CodedDetection Detect(const Scene& s, const Image& im) {
  coded::CodedDetectOptions o;
  o.bits = s.target.code_bits;
  o.profile = coded::ParseProfile(s.target.code_profile);
  return coded::DetectCodedTargets(Gray16(im), o);
}

std::set<int> Ids(const std::vector<TruthPoint>& truth) {
  std::set<int> ids;
  for (const TruthPoint& t : truth) ids.insert(t.id);
  return ids;
}

// A 5 × 4 grid of AICON 14-bit targets (3 mm dots, 40 mm apart, ids 1-20) with three raised ones
// and an uncoded dot (id 600: the profile has 516 codes) between the rows.
std::vector<coded::PlacedTarget> RaisedField() {
  std::vector<coded::PlacedTarget> f;
  for (int j = 0; j < 4; ++j) {
    for (int i = 0; i < 5; ++i) f.push_back({j * 5 + i + 1, Vec3(40.0 * i, 40.0 * j, 0)});
  }
  f[6].xyz_mm.z() = -25;  // id 7
  f[8].xyz_mm.z() = -40;  // id 9
  f[13].xyz_mm.z() = -25;  // id 14
  f.push_back({600, Vec3(60, 20, 0)});
  return f;
}

TEST(FieldRender, RaisedTargetsImageAtTheirPinholeProjection) {
  // The camera alone (a dome concentric with the pupil, in air): a point's image is the pinhole
  // projection of the 3-D point, a dot's image centre the closed-form centre of its conic
  // (coded/ellipse.h: EccentricityPx), for raised targets as for those on the board.
  Scene s = FieldScene("coded:14:3", RaisedField(), 960, Medium::kAir);  // dots of 9 px
  s.housed.port = testing::ConcentricDome();
  s.pose = PoseFacing(s.target, 650, {10, -5}, 15, -10, 5);
  RenderOptions ro;
  ro.samples_per_pixel = 16;
  const Rendered r = Render(s, ro);
  const camera::Camera& cam = r.setup.camera;
  const double f = cam.FocalLengthPx();
  const Vec2 pp = cam.PrincipalPointPx();
  ASSERT_EQ(r.truth.size(), 21u) << "partial " << r.left_out.partial.size() << ", occluded " << r.left_out.occluded.size();
  double worst_point = 0, worst_dot = 0;
  const std::vector<DotTruth> dots = DotImageCentres(s, r.setup, r.truth);
  ASSERT_EQ(dots.size(), r.truth.size());
  std::map<int, Vec2> dot_at;
  for (std::size_t k = 0; k < r.truth.size(); ++k) {
    const TruthPoint& t = r.truth[k];
    const Vec3 c = s.pose.Apply(t.point_in_target_mm);
    const Vec2 pinhole = pp + f * c.head<2>() / c.z();
    worst_point = std::max(worst_point, (t.pixel_per_band[0] - pinhole).norm());
    const Vec2 conic = pinhole + coded::EccentricityPx(f, s.pose.rotation, c, s.target.dot_radius_mm);
    worst_dot = std::max(worst_dot, (dots[k].centre_px_per_band[0] - conic).norm());
    dot_at[t.id] = dots[k].centre_px_per_band[0];
  }
  std::printf("21 points (3 raised): truth against the pinhole projection %.1e px, dot centres against the conic's "
              "%.1e px\n", worst_point, worst_dot);
  EXPECT_LT(worst_point, 1e-6);
  EXPECT_LT(worst_dot, 1e-6);
  // The image: every coded target, raised or not, read with its ID at its dot's centre; the uncoded
  // dot is no coded target.
  const coded::CodedDetection det = Detect(s, r.image);
  double worst_found = 0;
  std::set<int> found;
  for (const auto& t : det.targets) {
    ASSERT_TRUE(dot_at.count(t.id)) << "wrong id " << t.id;
    worst_found = std::max(worst_found, (t.centre_px - dot_at[t.id]).norm());
    found.insert(t.id);
  }
  std::printf("decoded %zu of 20 coded targets, centres within %.4f px of the truth (%s)\n", found.size(), worst_found,
              det.counts.ToString().c_str());
  EXPECT_EQ(found.size(), 20u);
  EXPECT_FALSE(found.count(600));
  for (int raised : {7, 9, 14}) EXPECT_TRUE(found.count(raised)) << raised;
  EXPECT_LT(worst_found, 0.05);
}

TEST(FieldRender, PlatesHideWhatLiesBehindThem) {
  // Face on, a plate 40 mm in front of the board over target 1 casts, from the pupil, a shadow on
  // the board of its radius × z_board / z_plate around the plate centre's ray: a board target is
  // hidden when the disc of its ring (SeenRadiusMm) meets that shadow. Closed form against the
  // truth's occluded list; and the image: the hidden target is not read, the plate's is.
  std::vector<coded::PlacedTarget> field = {{1, Vec3(0, 0, 0)},   {2, Vec3(0, 0, -40)}, {3, Vec3(16, 0, 0)},
                                            {4, Vec3(36, 0, 0)},  {5, Vec3(0, 28, 0)},  {6, Vec3(-60, -30, 0)},
                                            {7, Vec3(60, 30, 0)}, {8, Vec3(-20, 45, 0)}};
  Scene s = FieldScene("coded:14:3", field, 720, Medium::kAir);
  s.housed.port = testing::ConcentricDome();
  s.pose = PoseFacing(s.target, 500, {0, 0});
  const render::Setup setup = Resolve(s);
  LeftOut left;
  const std::vector<TruthPoint> truth = GroundTruth(s, setup, &left);
  const double plate = PlateRadiusMm(s.target);
  const Vec3 plate_c = s.pose.Apply(field[1].xyz_mm);
  std::set<int> expect_hidden;
  for (const auto& t : field) {
    if (t.xyz_mm.z() != 0) continue;
    const Vec3 c = s.pose.Apply(t.xyz_mm);
    const double scale = c.z() / plate_c.z();  // the board is parallel to the image: one depth
    const double gap = (c.head<2>() - scale * plate_c.head<2>()).norm() - scale * plate - SeenRadiusMm(s.target, t.id);
    ASSERT_GT(std::abs(gap), 0.5) << "target " << t.id << " is too near the shadow's edge for the test";
    if (gap < 0) expect_hidden.insert(t.id);
  }
  std::printf("hidden: %zu (closed form %zu), partial %zu, in the truth %zu\n", left.occluded.size(), expect_hidden.size(),
              left.partial.size(), truth.size());
  EXPECT_EQ(std::set<int>(left.occluded.begin(), left.occluded.end()), expect_hidden);
  EXPECT_TRUE(expect_hidden.count(1) && expect_hidden.count(3));  // the test covers a hidden neighbour
  EXPECT_TRUE(left.partial.empty());
  EXPECT_EQ(truth.size() + expect_hidden.size(), field.size());
  RenderOptions ro;
  ro.samples_per_pixel = 16;
  const Rendered r = Render(s, ro);
  std::set<int> found;
  for (const auto& t : Detect(s, r.image).targets) found.insert(t.id);
  EXPECT_TRUE(found.count(2));
  EXPECT_FALSE(found.count(1));
  for (int id : found) EXPECT_TRUE(Ids(r.truth).count(id)) << "id " << id << " read but not in the truth";
}

TEST(FieldRender, ConcentricDomeInWaterRendersWhatAirRendersWithRaisedTargets) {
  // A dome concentric with the pupil bends no ray from its centre: seen through a pinhole there, the
  // raised field images in water where it does in air (truth and dot centres), plates and all.
  Scene s = FieldScene("coded:14:3", RaisedField(), 480, Medium::kWater);
  s.housed.port = testing::ConcentricDome();
  s.pose = PoseFacing(s.target, 700, {0, 0}, -20, 15, 0);
  s.focus_distance_mm = 1000;  // one camera in both media
  Scene a = s;
  a.medium = Medium::kAir;
  RenderOptions ro;
  ro.samples_per_pixel = 9;
  const Rendered w = Render(s, ro), r = Render(a, ro);
  ASSERT_EQ(w.truth.size(), r.truth.size());
  ASSERT_EQ(w.truth.size(), 21u);
  double worst = 0;
  const auto dw = DotImageCentres(s, w.setup, w.truth), da = DotImageCentres(a, r.setup, r.truth);
  for (std::size_t k = 0; k < w.truth.size(); ++k) {
    worst = std::max(worst, (w.truth[k].pixel_per_band[0] - r.truth[k].pixel_per_band[0]).norm());
    worst = std::max(worst, (dw[k].centre_px_per_band[0] - da[k].centre_px_per_band[0]).norm());
  }
  double sq = 0;
  for (std::size_t i = 0; i < w.image.data.size(); ++i) sq += std::pow(w.image.data[i] - r.image.data[i], 2);
  const double rms = std::sqrt(sq / w.image.data.size());
  std::printf("water against air: points and dot centres %.1e px apart, images %.1e rms\n", worst, rms);
  EXPECT_LT(worst, 1e-6);
  EXPECT_LT(rms, 0.01);
}

TEST(FieldRender, APartialViewKeepsTheTargetsImagedWholeAndTheDetectorReadsThose) {
  // The default A4 sheet of AICON 14-bit targets (3 mm dots), face on at 450 mm and shifted so the
  // frame cuts it. Pinhole, no port: a target's whole-radius circle images as a circle of radius
  // f·R/Z about its projection, so a target is whole in the frame when that circle is, a closed
  // form the truth must follow; and the coded detector reads exactly the targets of the truth.
  Scene s = FieldScene("coded:14:3", {}, 720, Medium::kAir);
  s.housed.port = testing::ConcentricDome();
  s.pose = PoseFacing(s.target, 450, {110, 75});
  RenderOptions ro;
  ro.samples_per_pixel = 16;
  const Rendered r = Render(s, ro);
  const camera::Camera& cam = r.setup.camera;
  const double f = cam.FocalLengthPx();
  const Vec2 pp = cam.PrincipalPointPx();
  const double w = cam.sensor.width_px - 1, h = cam.sensor.height_px - 1;
  std::set<int> expect;
  int borderline = 0;
  for (const auto& t : calib::CodedSheet(s.target).targets) {
    const Vec3 c = s.pose.Apply(t.xyz_mm);
    const Vec2 uv = pp + f * c.head<2>() / c.z();
    const double rad = f * FrameRadiusMm(s.target, t.id) / c.z();
    const double room = std::min({uv.x() - rad, uv.y() - rad, w - uv.x() - rad, h - uv.y() - rad});
    if (std::abs(room) < 0.05) ++borderline;  // 32 rim points may miss the last 0.05 px: not tested
    if (room > 0) expect.insert(t.id);
  }
  const std::set<int> kept = Ids(r.truth);
  std::printf("partial view: %zu targets whole in the frame (closed form %zu, %d borderline), %zu left out\n", kept.size(),
              expect.size(), borderline, r.left_out.partial.size());
  ASSERT_EQ(borderline, 0);
  EXPECT_EQ(kept, expect);
  EXPECT_GT(r.left_out.partial.size(), 10u);
  EXPECT_TRUE(r.left_out.occluded.empty());
  const coded::CodedDetection det = Detect(s, r.image);
  std::set<int> found;
  for (const auto& t : det.targets) found.insert(t.id);
  std::printf("read %zu targets: %s\n", found.size(), det.counts.ToString().c_str());
  EXPECT_EQ(found, kept);
}

TEST(FieldRender, SetsOfPartialViewsAreForCodedTargets) {
  Scene s = FieldScene("coded:14:3", {}, 480, Medium::kWater);
  s.focus_distance_mm = 1000;
  SetOptions so;
  so.count = 2;
  so.min_whole_fraction = 0.5;
  so.near_mm = 400;
  so.far_mm = 500;
  const std::vector<Pose> poses = SetPoses(s, so);
  ASSERT_EQ(poses.size(), 2u);
  for (const Pose& p : poses) {
    s.pose = p;
    const std::size_t kept = GroundTruth(s, Resolve(s)).size();
    EXPECT_GE(2 * kept, calib::CodedSheet(s.target).targets.size());
  }
  Scene board = s;
  board.target = calib::ParseTarget("chessboard:9x6:40");
  try {
    SetPoses(board, so);
    ADD_FAILURE() << "a chessboard set of partial views was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "min_whole_fraction");
  }
}

}  // namespace
}  // namespace porthole::render
