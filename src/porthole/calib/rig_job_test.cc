// Proves CalibrateRigJob (calib/rig_job.h) recovers a known two-camera rig from synthetic
// detections (calib/test_rig.h: 300 mm apart, turned 5°) within 3σ, gives what CalibrateRig gives
// on the same input, writes the OpenCV stereo pair asked for, checks the outputs only once the
// options hold together, and refuses what a rig cannot take naming the field, never a CLI flag.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "porthole/calib/rig_job.h"
#include "porthole/catalogue/presets.h"
#include "porthole/calib/test_fields.h"
#include "porthole/calib/test_rig.h"
#include "porthole/core/error.h"

namespace porthole::calib {
namespace {

using namespace fixtures;  // test_rig.h: TwoCameraRig, Frames; test_fields.h: RaisedBoard

constexpr const char* kTarget = "chessboard:16x12:50";

CalibrateRigJobOptions StereoJob() {
  CalibrateRigJobOptions o;
  o.given = Frames(TwoCameraRig(), ParseTarget(kTarget), 15, 5);
  o.target = kTarget;
  o.model = {"opencv"};
  return o;
}

TEST(CalibrateRigJob, RecoversATwoCameraRigAsCalibrateRigDoes) {
  const Truth truth = TwoCameraRig();
  int checks = 0;
  CalibrateRigJobOptions o = StereoJob();
  o.stereo_out = "pair.yaml";
  o.check_outputs = [&] { ++checks; };
  const CalibrateRigJobResult r = CalibrateRigJob(o);
  EXPECT_EQ(checks, 1);
  ASSERT_EQ(r.rig.cameras.size(), 2u);
  const RigCamera& c1 = r.rig.cameras[1];
  // The truth within 3σ: the translation, the 300 mm baseline, the 5° convergence.
  for (int i = 0; i < 3; ++i) {
    EXPECT_LE(std::abs(c1.translation_mm(i) - truth.cam_from_rig[1].translation()(i)), 3 * c1.pose_sigma(3 + i)) << i;
  }
  EXPECT_NEAR(c1.baseline_mm, 300, 3 * c1.baseline_sigma_mm);
  EXPECT_NEAR(c1.convergence_deg, 5, 3 * c1.pose_sigma(1) * 180 / M_PI);
  EXPECT_EQ(r.rig.cameras[0].name, "camera0");  // given detections without names
  // The same adjustment as CalibrateRig's with the same options (one opencv lens set for both), to
  // 1e-9 relative (the solver's threads sum in any order).
  RigOptions direct;
  CalibrationOptions lens;
  lens.model = camera::CameraModelId::kOpenCV;
  direct.cameras = {lens};
  const RigResult d = CalibrateRig(*StereoJob().given, ParseTarget(kTarget), direct);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(c1.translation_mm(i), d.cameras[1].translation_mm(i), 1e-9 * (1 + std::abs(c1.translation_mm(i)))) << i;
  }
  // The stereo pair as OpenCV's FileStorage YAML, with the pose between the two.
  EXPECT_EQ(r.stereo_text.rfind("%YAML", 0), 0u) << r.stereo_text.substr(0, 40);
  EXPECT_NE(r.stereo_text.find("\nT: !!opencv-matrix"), std::string::npos);
  const auto j = CalibrateRigJobJson(r);
  EXPECT_EQ(j["rig"]["cameras"].size(), 2u);
  EXPECT_TRUE(j["skipped"].is_array() && j["skipped"].empty());
}

// Each case: what is set, and the field the refusal must name; refused before the outputs are
// checked.
TEST(CalibrateRigJob, RefusesWhatARigCannotTakeNamingTheField) {
  int checks = 0;
  const auto field_of = [&](CalibrateRigJobOptions o) -> std::string {
    o.check_outputs = [&] { ++checks; };
    try {
      CalibrateRigJob(o);
    } catch (const InvalidInput& e) {
      EXPECT_EQ(std::string(e.what()).find("--"), std::string::npos) << e.what();
      return e.field();
    }
    return "(accepted)";
  };
  CalibrateRigJobOptions o = StereoJob();
  o.model = {"opencv", "opencv", "brown"};  // three models for two cameras
  EXPECT_EQ(field_of(o), "model");
  o = StereoJob();
  o.pixel_pitch_mm = {0.0055, 0.0055, 0.0055};
  EXPECT_EQ(field_of(o), "pixel_pitch_mm");
  o = StereoJob();
  o.air_calibration = {"left.json", "right.json"};  // without a port
  EXPECT_EQ(field_of(o), "air_calibration");
  o = StereoJob();
  o.port = {"nimar-ni320"};
  o.air_lens_bare = true;  // says what an air calibration holds: none given
  EXPECT_EQ(field_of(o), "air_lens_bare");
  o = StereoJob();
  o.air_given_detections = *o.given;  // air images without a port
  EXPECT_EQ(field_of(o), "air_detections");
  o = StereoJob();
  o.names = {"left"};  // one name for two cameras
  EXPECT_EQ(field_of(o), "names");
  o = StereoJob();
  o.field_out = true;  // a free target's field file: one camera's (a rig's free target is in its JSON)
  EXPECT_EQ(field_of(o), "field_out");
  o = StereoJob();
  o.datum = "minimal";  // a free target's datum, without a free target
  EXPECT_EQ(field_of(o), "datum");
  o = StereoJob();
  o.port = {"nimar-ni320"};
  o.free_port = true;  // a single camera's adjusted port parameters
  EXPECT_EQ(field_of(o), "free_port");
  o = StereoJob();
  o.port_out = true;  // estimated ports, without ports
  EXPECT_EQ(field_of(o), "port_out");
  o = StereoJob();
  o.ep_mm = Eigen::Vector3d(0, 0, 25);  // a pupil behind ports, without ports
  EXPECT_EQ(field_of(o), "ep");
  o = StereoJob();
  o.model = {"opencv", "brown"};
  o.stereo_out = "pair.yaml";  // camera 1 is not an opencv camera
  EXPECT_EQ(field_of(o), "stereo_out");
  EXPECT_EQ(checks, 0);
}

// Two cameras behind their own NI320s (the second pupil 0.7, 0.5, 2.4 mm off the first's), in
// water, through the preset `nimar-ni320` (the pupils' start where it puts them): with port_out each
// camera's estimated port comes back as a port TOML that the port reader takes, names the camera's
// port "-as-calibrated" and puts the estimated parameters back, within 1e-9 mm; with ep_mm every
// camera's port is predicted from that pupil. (Water images only,
// no air calibration: the estimates themselves are weak here; rig_test checks them against truth.)
TEST(CalibrateRigJob, WritesEachCamerasEstimatedPort) {
  const Truth truth = TwoDomeRig();
  CalibrateRigJobOptions o;
  o.given = Frames(truth, ParseTarget(kTarget), 15, 9);
  o.target = kTarget;
  o.pixel_pitch_mm = {truth.cams[0].sensor.pixel_pitch_mm};
  o.port = {"nimar-ni320"};
  o.water.water_index = 1.341;
  o.port_out = true;
  const CalibrateRigJobResult r = CalibrateRigJob(o);
  ASSERT_EQ(r.port_tomls.size(), 2u);
  for (int k = 0; k < 2; ++k) {
    const RigCamera& c = r.rig.cameras[k];
    ASSERT_TRUE(c.has_port);
    const ports::PortSpec spec = catalogue::ParsePortToml(r.port_tomls[k], "camera" + std::to_string(k));
    EXPECT_EQ(spec.name, "nimar-ni320-as-calibrated");
    EXPECT_NE(spec.description.find("camera" + std::to_string(k)), std::string::npos) << spec.description;
    const auto& dome = std::get<ports::DomePort>(spec.shape);
    const auto p = dome.PortParams(spec.default_ep_in_housing_mm);  // the pupil minus the outer centre
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(p[i], c.port[i], 1e-9) << k << " " << i;
    // The preset's glass and the water index as the rig took them.
    EXPECT_EQ(dome.material, "n-bk7");
  }
  // The two cameras' ports differ as their pupils do (the second 2.4 mm further back).
  EXPECT_NE(r.port_tomls[0], r.port_tomls[1]);
  // ep_mm: every camera's pupil predicted there, not where the preset puts it (26.9 mm; the
  // outer centre at z 21.5): ep_in_dome_z predicted 3.5 mm, not 5.4; the pupil in the TOML too.
  for (int k = 0; k < 2; ++k) EXPECT_NEAR(r.rig.cameras[k].port_predicted[2], 5.4, 1e-9) << k;
  o.ep_mm = Eigen::Vector3d(0, 0, 25);
  const CalibrateRigJobResult at = CalibrateRigJob(o);
  for (int k = 0; k < 2; ++k) {
    EXPECT_NEAR(at.rig.cameras[k].port_predicted[0], 0.4, 1e-9) << k;
    EXPECT_NEAR(at.rig.cameras[k].port_predicted[2], 3.5, 1e-9) << k;
    const ports::PortSpec spec = catalogue::ParsePortToml(at.port_tomls[k], "camera");
    EXPECT_NEAR(spec.default_ep_in_housing_mm.z(), 25, 1e-9) << k;
  }
}

// A rig's free target (lens.target_free, a 3-D coded field: the board with raised targets) with
// field_out: the adjusted field as one camera's target-field file, which the field reader reads back
// to the rig's adjusted points (within the file's 1e-6 mm), every observed point with its σ.
TEST(CalibrateRigJob, WritesTheFreeTargetsAdjustedField) {
  const Truth truth = TwoCameraRig();
  const TargetSpec board = RaisedBoard();
  const std::string field_file = ::testing::TempDir() + "rig_job_field.txt";
  {
    std::ofstream f(field_file);
    for (const auto& t : board.field) f << t.id << " " << t.xyz_mm.x() << " " << t.xyz_mm.y() << " " << t.xyz_mm.z() << "\n";
  }
  CalibrateRigJobOptions o;
  o.given = Frames(truth, board, 15, 5);
  DropIdZero(&*o.given);  // id 0 is no target of the field
  o.target = board.ToString();
  o.field = field_file;
  o.model = {"opencv"};
  o.centre_correction = "off";  // synthetic centres
  o.lens.target_free = true;
  o.field_out = true;
  const CalibrateRigJobResult r = CalibrateRigJob(o);
  ASSERT_FALSE(r.field_text.empty());
  EXPECT_NE(r.field_text.find("# datum: "), std::string::npos) << r.field_text.substr(0, 400);
  const std::string written = ::testing::TempDir() + "rig_job_field_out.txt";
  std::ofstream(written) << r.field_text;
  TargetSpec back = ParseTarget(o.target);
  LoadTargetField(written, &back);
  ASSERT_EQ(back.field.size(), board.field.size());
  int adjusted = 0;
  for (const auto& t : back.field) {
    if (!r.rig.target_sigma_mm[t.id].allFinite()) continue;
    ++adjusted;
    EXPECT_LE((t.xyz_mm - r.rig.target_points_mm[t.id]).cwiseAbs().maxCoeff(), 1e-6) << t.id;
  }
  EXPECT_EQ(adjusted, static_cast<int>(board.field.size()));  // every point seen
  std::size_t sigma_lines = 0;
  for (std::size_t at = 0; (at = r.field_text.find("# sigma", at)) != std::string::npos; ++at) ++sigma_lines;
  EXPECT_EQ(sigma_lines, board.field.size());
  std::printf("rig field_out: %d points adjusted, sigma0 %.4f px\n", adjusted, r.rig.sigma0_px);
}

}  // namespace
}  // namespace porthole::calib
