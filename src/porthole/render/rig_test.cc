// Proves the rig renderer's geometry against the projections it must agree with: a target point
// seen by two cameras of a rig (one bare with OpenCV distortion, one behind an as-built NI320 dome
// with its own pupil offset) lands, in each camera, where that camera's own projection of the point
// (camera::Camera::Project, refraction::Project through the calibrated port) puts it, within 1e-9 px;
// the described rig is as `porthole plan --baseline --convergence` describes it; a rig set's poses
// are seen whole by every camera in water and in air; bad rigs are refused.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <unistd.h>

#include "porthole/camera/models.h"
#include "porthole/catalogue/presets.h"
#include "porthole/render/rig.h"
#include "porthole/render/test_scenes.h"

namespace porthole::render {
namespace {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;

camera::Camera OpenCVCamera(const camera::Sensor& sensor, double k1) {
  camera::Camera c;
  c.model = camera::CameraModelId::kOpenCV;
  c.sensor = sensor;
  const double f = 24.6 / sensor.pixel_pitch_mm;
  c.params = {f, f * 1.0003, 0.5 * (sensor.width_px - 1) + 3.2, 0.5 * (sensor.height_px - 1) - 2.1, k1, 0.03,
              4e-4, -2e-4, 0, 0, 0, 0};
  return c;
}

// The as-built NI320 (its inner sphere off the outer one) as a calibrated port: its shell, and the
// pupil at `p` from the outer centre.
refraction::Shell NI320Shell() {
  const ports::PortSpec spec = catalogue::LoadPort("nimar-ni320");
  return refraction::ShellOf(ports::Place(spec, spec.default_ep_in_housing_mm, 1.5, 1.34));
}

struct TwoCameras {
  Scene base;
  std::vector<RigCamera> rig;
  refraction::Shell shell = NI320Shell();
  std::array<double, 3> p = {0.4, 1.0, 5.4};
};

TwoCameras MakeRig() {
  TwoCameras t;
  t.base = testing::PaperScene("nimar-ni320", 720);
  t.base.target = calib::ParseTarget("chessboard:9x6:40");
  t.base.bands_nm = {546.07};
  t.base.f_number = std::numeric_limits<double>::infinity();
  t.rig = DescribedRig(2, 300, 5);
  t.rig[0].camera = OpenCVCamera(t.base.housed.camera.sensor, -0.11);
  t.rig[0].port_use = RigCamera::PortUse::kNone;
  t.rig[1].camera = OpenCVCamera(t.base.housed.camera.sensor, -0.09);
  t.rig[1].port_use = RigCamera::PortUse::kOwn;
  t.rig[1].port = refraction::PortSpecOf(t.shell, t.p, "pmma", "ni320-calibrated");
  return t;
}

TEST(RigRender, APointSeenByBothCamerasLandsWhereEachCamerasProjectionPutsIt) {
  const TwoCameras t = MakeRig();
  const Pose rig_from_target = PoseFacing(t.base.target, 1300, {150, 20}, 12, -8, 4);
  double worst[2] = {0, 0};
  for (int k = 0; k < 2; ++k) {
    const Scene scene = CameraScene(t.base, t.rig[k], rig_from_target);
    const render::Setup setup = Resolve(scene);
    ASSERT_EQ(setup.bands.size(), 1u);
    const Band& band = setup.bands[0];
    refraction::Shell shell = t.shell;  // the render's indices at its band
    shell.n_glass = band.n_glass;
    shell.n_water = band.n_water;
    if (k == 1) {
      EXPECT_GT(band.n_water, 1.3);
      EXPECT_NE(band.n_glass, 1.0);
    }
    const auto truth = GroundTruth(scene, setup);
    ASSERT_EQ(truth.size(), 54u);
    for (const TruthPoint& tp : truth) {
      // The point in camera k's frame, by hand: cam_from_rig · (rig_from_target · X).
      const Vec3 in_rig = rig_from_target.rotation * tp.point_in_target_mm + rig_from_target.translation_mm;
      const Vec3 in_cam = t.rig[k].cam_from_rig.rotation * in_rig + t.rig[k].cam_from_rig.translation_mm;
      EXPECT_LT((tp.point_in_cam_mm - in_cam).norm(), 1e-9);
      std::optional<Vec2> expected;
      if (k == 0) {
        expected = t.rig[0].camera->Project(in_cam);
      } else {
        const auto uv = refraction::Project<camera::OpenCVModel, double>(
            t.rig[1].camera->sensor, t.rig[1].camera->params.data(), shell, t.p.data(), in_cam);
        if (uv) expected = Vec2(*uv);
      }
      ASSERT_TRUE(expected.has_value());
      worst[k] = std::max(worst[k], (tp.pixel_per_band[0] - *expected).norm());
    }
  }
  std::printf("rig truth against each camera's projection: bare %.2e px, behind its dome %.2e px\n", worst[0],
              worst[1]);
  EXPECT_LT(worst[0], 1e-9);
  EXPECT_LT(worst[1], 1e-9);
}

TEST(RigRender, ThePortOfAShellTracesAsItsInterfaces) {
  const TwoCameras t = MakeRig();
  const auto cam_frame = refraction::Interfaces(t.shell, t.p.data());
  const Vec3 ep(1, -2, 40);
  const ports::PortSystem sys = ports::Place(t.rig[1].port, ep, t.shell.n_glass, t.shell.n_water);
  const auto housing_frame = sys.Outward();
  double worst = 0;
  for (double x = -0.8; x <= 0.8; x += 0.2) {
    for (double y = -0.6; y <= 0.6; y += 0.2) {
      const Vec3 d = Vec3(x, y, 1).normalized();
      optics::Ray a, b;
      ASSERT_EQ(optics::TraceSequence<double>(cam_frame, optics::Ray{Vec3::Zero(), d}, &a), optics::RayStatus::kOk);
      ASSERT_EQ(optics::TraceSequence<double>(housing_frame, optics::Ray{ep, d}, &b), optics::RayStatus::kOk);
      worst = std::max({worst, (a.origin + ep - b.origin).norm(), (a.dir - b.dir).norm()});
    }
  }
  EXPECT_LT(worst, 1e-9);
}

TEST(RigRender, TheDescribedRigIsPlansBaselineAndConvergence) {
  const auto rig = DescribedRig(3, 300, 5);
  ASSERT_EQ(rig.size(), 3u);
  EXPECT_EQ(rig[0].name, "cam0");
  EXPECT_EQ(rig[2].name, "cam2");
  EXPECT_TRUE(rig[0].cam_from_rig.rotation.isIdentity());
  for (int k = 1; k < 3; ++k) {
    const Pose& p = rig[k].cam_from_rig;
    const Vec3 centre_in_rig = -p.rotation.transpose() * p.translation_mm;  // the pupil
    EXPECT_LT((centre_in_rig - Vec3(300.0 * k, 0, 0)).norm(), 1e-12);
    const Vec3 axis_in_rig = p.rotation.transpose() * Vec3::UnitZ();
    EXPECT_LT(axis_in_rig.x(), 0);  // turned towards the first camera: the axes cross in front
    const double cross_z = 300.0 * k * axis_in_rig.z() / -axis_in_rig.x();  // where it meets camera 0's axis
    EXPECT_NEAR(cross_z, 300.0 * k / std::tan(5 * std::numbers::pi / 180), 1e-6);
    EXPECT_NEAR(std::acos(axis_in_rig.z()) * 180 / std::numbers::pi, 5, 1e-9);
  }
  EXPECT_THROW(DescribedRig(1, 300, 5), InvalidInput);
  EXPECT_THROW(DescribedRig(2, 0, 5), InvalidInput);
  EXPECT_THROW(DescribedRig(2, 300, 45), InvalidInput);
}

TEST(RigRender, EverySetPoseIsSeenWholeByEveryCameraInWaterAndInAir) {
  TwoCameras t = MakeRig();
  t.base.focus_distance_mm = 1500;
  std::vector<SetView> views;
  for (const RigCamera& c : t.rig) views.push_back({CameraScene(t.base, c, Pose{}), c.cam_from_rig});
  SetOptions so;
  so.count = 6;
  so.seed = 3;
  so.near_mm = 900;
  so.far_mm = 1800;
  const auto poses = SetPosesSeenBy(views, so);
  ASSERT_EQ(poses.size(), 6u);
  for (const Pose& pose : poses) {
    for (std::size_t k = 0; k < views.size(); ++k) {
      for (const Medium m : {Medium::kWater, Medium::kAir}) {
        Scene sc = views[k].scene;
        sc.medium = m;
        sc.pose = Compose(t.rig[k].cam_from_rig, pose);
        const render::Setup st = Resolve(sc);
        std::vector<TruthPoint> truth;
        ASSERT_NO_THROW(truth = GroundTruth(sc, st));
        EXPECT_EQ(truth.size(), 54u);
      }
    }
  }
  // A lone camera of the rig is not bound by the other's field: its first pose differs.
  const auto alone = SetPosesSeenBy({views[0]}, so);
  EXPECT_EQ(alone.size(), 6u);
}

TEST(RigRender, BadRigsAreRefusedBeforeAnyFile) {
  TwoCameras t = MakeRig();
  RigRenderOptions o;
  o.out = std::filesystem::temp_directory_path() / "porthole_rig_test_never";
  std::filesystem::remove_all(o.out);
  t.base.pose = PoseFacing(t.base.target, 1300, {150, 0});
  auto rig = t.rig;
  rig[1].name = "../up";
  EXPECT_THROW(RenderRig(t.base, rig, o), InvalidInput);
  rig[1].name = "cam0";
  EXPECT_THROW(RenderRig(t.base, rig, o), InvalidInput);
  rig = t.rig;
  t.base.pose = PoseFacing(t.base.target, 1300, {-900, 0});  // outside the second camera's frame
  try {
    RenderRig(t.base, rig, o);
    ADD_FAILURE() << "rendered a target outside a camera's frame";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(std::string(e.field()), "pose");
  }
  EXPECT_FALSE(std::filesystem::exists(o.out));
}

TEST(RigRender, ASetWritesEveryCamerasImageOfAFrameUnderOneName) {
  TwoCameras t = MakeRig();
  t.base = testing::PaperScene("nimar-ni320", 360);  // small frames: the layout is what is tested
  t.base.target = calib::ParseTarget("chessboard:9x6:40");
  t.base.f_number = std::numeric_limits<double>::infinity();
  t.rig = DescribedRig(2, 300, 5);
  t.rig[0].port_use = t.rig[1].port_use = RigCamera::PortUse::kNone;  // bare: the air set only
  RigRenderOptions o;
  o.render.samples_per_pixel = 1;
  o.set_count = 2;
  o.out = std::filesystem::temp_directory_path() / ("porthole_rig_test_" + std::to_string(::getpid()));
  std::filesystem::remove_all(o.out);
  int prepared = 0;
  o.prepare = [&] { ++prepared; };
  const auto summary = RenderRig(t.base, t.rig, o);
  EXPECT_EQ(prepared, 1);
  EXPECT_EQ(summary["frames"], 2);
  EXPECT_FALSE(std::filesystem::exists(o.out / "water"));
  for (const char* frame : {"pose_000", "pose_001"}) {
    nlohmann::json truth[2];
    for (int k = 0; k < 2; ++k) {
      const auto dir = o.out / "air" / t.rig[k].name;
      ASSERT_TRUE(std::filesystem::exists(dir / (std::string(frame) + ".png")));
      std::ifstream in(dir / (std::string(frame) + ".json"));
      truth[k] = nlohmann::json::parse(in);
      EXPECT_EQ(truth[k]["rig"]["camera"], t.rig[k].name);
    }
    EXPECT_EQ(truth[0]["rig"]["rig_from_target"], truth[1]["rig"]["rig_from_target"]);
    // Camera 1's pose of the target is cam_from_rig ∘ rig_from_target (camera 0's is the rig's).
    Pose rig_from_target;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) rig_from_target.rotation(i, j) = truth[0]["pose"]["rotation"][i][j];
      rig_from_target.translation_mm[i] = truth[0]["pose"]["translation_mm"][i];
    }
    const Pose expect = Compose(t.rig[1].cam_from_rig, rig_from_target);
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR(truth[1]["pose"]["translation_mm"][i].get<double>(), expect.translation_mm[i], 1e-9);
      for (int j = 0; j < 3; ++j) EXPECT_NEAR(truth[1]["pose"]["rotation"][i][j].get<double>(), expect.rotation(i, j), 1e-12);
    }
  }
  std::filesystem::remove_all(o.out);
}

}  // namespace
}  // namespace porthole::render
