// Proves `coded:BITS:RADIUS[:PROFILE]` works as a calibration target end to end: exact renders
// (coded/raster.h) of the default sheet seen by a known pinhole camera are detected through
// DetectInImage (ids = target IDs, positions from TargetPoints) and calibrated. Without the
// model-based centre correction c is many σ off (the centres' eccentricity, coded/ellipse.h: a
// bias: 13σ); with it (on by default for coded targets) c, x0 and y0 are the rendering camera's
// within 3σ (c 0.6σ, y0 2.0σ). Through the as-built NI320 in sea water the same correction inside
// the refractive calibration (calibrate --port) removes the bias of the port and the lens.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cstdio>
#include <cstdlib>
#include <opencv2/core.hpp>
#include <random>
#include <fmt/format.h>

#include "porthole/calib/calibrate.h"
#include "porthole/calib/detect.h"
#include "porthole/calib/refractive.h"
#include "porthole/calib/result_json.h"
#include "porthole/calib/test_refractive.h"
#include "porthole/coded/ellipse.h"
#include "porthole/coded/raster.h"
#include "porthole/coded/sheet.h"
#include "porthole/core/error.h"
#include "porthole/catalogue/presets.h"
#include "porthole/refraction/test_camera.h"
#include "porthole/render/dots.h"
#include "porthole/render/render.h"

namespace porthole::calib {
namespace {

TEST(CodedCalib, SpecPointsAreTheDefaultSheet) {
  const TargetSpec t = ParseTarget("coded:14:2.5");
  EXPECT_EQ(t.ToString(), "coded:14:2.5:aicon");
  EXPECT_EQ(ParseTarget(t.ToString()).ToString(), t.ToString());
  const auto sheet = coded::LayoutSheet({});
  const auto pts = TargetPoints(t);
  ASSERT_EQ(static_cast<int>(pts.size()), t.NumPoints());
  ASSERT_EQ(pts.size(), sheet.targets.size() + 1);
  for (const auto& p : sheet.targets) EXPECT_EQ(pts[p.id], p.xyz_mm);
  EXPECT_EQ(ParseTarget("coded:12:3:Metashape").ToString(), "coded:12:3:metashape");
}

// A --field file replaces the default sheet: ids index its points (3-D ones too), the ids it does
// not list are no points, and a bad file or a field for a non-coded target is one InvalidInput.
TEST(CodedCalib, FieldFileReplacesTheSheet) {
  const std::string path = testing::TempDir() + "/field_test.txt";
  {
    std::FILE* f = std::fopen(path.c_str(), "w");
    ASSERT_NE(f, nullptr);
    std::fputs("# a raised target\n3 10 20 0\n7, 30.5, 20, -15.25\n\n12 0 0 0\n", f);
    std::fclose(f);
  }
  TargetSpec t = ParseTarget("coded:12:2");
  LoadTargetField(path, &t);
  ASSERT_EQ(t.NumPoints(), 13);
  const auto pts = TargetPoints(t);
  ASSERT_EQ(pts.size(), 13u);
  EXPECT_EQ(pts[7], Eigen::Vector3d(30.5, 20, -15.25));
  EXPECT_EQ(pts[3], Eigen::Vector3d(10, 20, 0));
  for (int id : {3, 7, 12}) EXPECT_TRUE(t.HasPoint(id)) << id;
  for (int id : {-1, 0, 1, 6, 13, 600}) EXPECT_FALSE(t.HasPoint(id)) << id;
  EXPECT_TRUE(ParseTarget("coded:12:2").HasPoint(1));
  TargetSpec chess = ParseTarget("chessboard:9x6:25");
  EXPECT_THROW(LoadTargetField(path, &chess), InvalidInput);
  EXPECT_THROW(LoadTargetField(path + ".missing", &t), InvalidInput);
  {
    std::FILE* f = std::fopen(path.c_str(), "w");
    std::fputs("3 10 20 0\n3 1 2 3\n", f);  // duplicate id
    std::fclose(f);
  }
  try {
    LoadTargetField(path, &t);
    ADD_FAILURE() << "a duplicate id was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("line 2"), std::string::npos) << e.what();
  }
  std::remove(path.c_str());
}

TEST(CodedCalib, RecoversARenderedPinholeCamera) {
  const TargetSpec t = ParseTarget("coded:14:2.5");
  coded::RasterOptions ro;
  ro.radius_mm = t.dot_radius_mm;
  // 64 lines per pixel row (the rasteriser's default): with 16 its midpoint rule along v (u is
  // exact) moved y0 by 0.013 px (to 0.024 px, 3.7σ); at 64 and 256 y0 is 0.011 px (2σ) alike.
  ro.subrows = 64;
  const auto sheet = coded::LayoutSheet({});
  const auto points = TargetPoints(t);
  // `exact`: the same ids at the exact ellipse centres (coded/ellipse.h) of each view.
  std::vector<ImageDetections> dets, exact;
  Eigen::Vector2d error_sum = Eigen::Vector2d::Zero();
  int n_error = 0;
  const double tilts[][3] = {{0, 0, 0}, {25, 0, 10}, {25, 90, -15}, {35, 45, 30}, {35, 135, 60}, {30, 200, 90}, {20, 300, -60}, {40, 250, 5}};
  for (const auto& v : tilts) {
    const coded::SheetView view = coded::LookAtSheet(Eigen::Vector2d(105, 140), 560, v[0], v[1], v[2], 2400, 1200, 900);
    const auto cov = coded::RasterizeTargets(view.width, view.height, view.H(), sheet.targets, ro);
    cv::Mat img(view.height, view.width, CV_8U);
    for (int r = 0; r < view.height; ++r)
      for (int c = 0; c < view.width; ++c) img.at<uint8_t>(r, c) = cv::saturate_cast<uint8_t>(217 - 191 * cov[r * view.width + c]);
    ImageDetections d;
    d.image = "view" + std::to_string(dets.size());
    d.width_px = view.width;
    d.height_px = view.height;
    std::vector<cv::Point2f> pts;
    ASSERT_TRUE(DetectInImage(img, t, &d.ids, &pts)) << d.image;
    for (const auto& p : pts) d.points_px.emplace_back(p.x, p.y);
    ImageDetections e = d;
    for (std::size_t k = 0; k < d.ids.size(); ++k) {
      e.points_px[k] = coded::ConicCentreOfCircle<double>(view.H(), points[d.ids[k]].head<2>(), t.dot_radius_mm);
      error_sum += d.points_px[k] - e.points_px[k];
      ++n_error;
    }
    dets.push_back(d);
    exact.push_back(e);
  }
  // The detector has no bias along either axis (mean error against the exact centres).
  const Eigen::Vector2d mean_error = error_sum / n_error;
  std::printf("detector against the exact ellipse centres: mean error u %.5f, v %.5f px over %d\n", mean_error.x(),
              mean_error.y(), n_error);
  EXPECT_LT(mean_error.cwiseAbs().maxCoeff(), 0.001);
  // Brown, pitch 1: millimetres are pixels; default free set c, x0, y0, K1, K2, P1, P2.
  CalibrationOptions o;
  o.centre_correction = CalibrationOptions::CentreCorrection::kOff;
  const CalibrationResult off = Calibrate(dets, t, o);
  o.centre_correction = CalibrationOptions::CentreCorrection::kAuto;  // on: a coded target
  const CalibrationResult on = Calibrate(dets, t, o);
  for (const CalibrationResult* r : {&off, &on}) {
    std::printf("coded calibration, centre correction %s: %d images, %d points, rms %.4f px; c %.4f (truth 2400, sigma "
                "%.4f: %.1f sigma off), x0 %.4f, y0 %.4f (sigma %.4f, %.4f); largest offset %.3f px\n",
                r == &on ? "on " : "off", r->n_images, r->n_points, r->rms_px, r->camera.params[0], r->sigma[0],
                std::abs(r->camera.params[0] - 2400) / r->sigma[0], r->camera.params[1], r->camera.params[2], r->sigma[1],
                r->sigma[2], r->max_centre_offset_px);
    EXPECT_LT(r->rms_px, 0.03);
  }
  // Without the correction c is many σ off (the eccentricity of the centres, a bias); with it,
  // c and the principal point are the rendering camera's within 3σ.
  EXPECT_GT(std::abs(off.camera.params[0] - 2400), 5 * off.sigma[0]);
  EXPECT_EQ(off.dot_radius_mm, 0);
  EXPECT_EQ(on.dot_radius_mm, 2.5);
  EXPECT_GT(on.max_centre_offset_px, 0.02);
  EXPECT_LT(std::abs(on.camera.params[0] - 2400), 3 * on.sigma[0]);
  EXPECT_LT(std::abs(on.camera.params[1]), 3 * on.sigma[1]);
  EXPECT_LT(std::abs(on.camera.params[2]), 3 * on.sigma[2]);
  // The exact ellipse centres give the rendering camera back (the pixel convention, the sheet
  // layout and the correction are exact; what is left in x0, y0 above is the detector's error).
  const CalibrationResult ex = Calibrate(exact, t, o);
  std::printf("exact centres: c %.7f, x0 %.2g, y0 %.2g px\n", ex.camera.params[0], ex.camera.params[1], ex.camera.params[2]);
  EXPECT_NEAR(ex.camera.params[0], 2400, 1e-5);
  EXPECT_NEAR(ex.camera.params[1], 0, 1e-5);
  EXPECT_NEAR(ex.camera.params[2], 0, 1e-5);
  EXPECT_LT(on.rms_px, off.rms_px);
  // The result JSON states the correction, and its reader reads it back.
  for (const CalibrationResult* r : {&off, &on}) {
    const auto j = CalibrationToJson(*r, t, o);
    EXPECT_EQ(j["dot_radius_mm"], r->dot_radius_mm);
    EXPECT_EQ(j["max_centre_offset_px"], r->max_centre_offset_px);
    const CalibrationRecord rec = CalibrationFromJson(nlohmann::json::parse(j.dump()), "test");
    EXPECT_EQ(rec.dot_radius_mm, r->dot_radius_mm);
    EXPECT_EQ(rec.max_centre_offset_px, r->max_centre_offset_px);
  }
}


// Coded targets seen through the as-built NI320 in sea water (the paper's D300 + 24 mm, the pupil
// where its Table 4 puts it, 20 views at three ranges): every centre is the renderer's
// detector-equivalent truth — render::DotImageCentre, the dot's rim traced through the port by
// render's own forward projection and fitted with an ellipse, what `porthole render` writes as
// dot_centres — plus Gaussian noise of `noise_px`. `truth` receives the port (the band's indices).
std::vector<ImageDetections> CodedViewsThroughNi320(const camera::Camera& cam, const TargetSpec& target,
                                                    double noise_px, uint64_t seed, ports::PortSystem* truth) {
  render::Scene s;
  s.housed.camera = catalogue::LoadCamera("nikon-d300");
  s.housed.lens = catalogue::LoadLens("nikkor-24mm-f2.8d");
  s.housed.port = catalogue::LoadPort("nimar-ni320");
  s.camera = cam;
  s.target = target;
  s.bands_nm = {546.07};
  s.f_number = INFINITY;
  s.focus_distance_mm = 300;
  const render::Setup setup = render::Resolve(s);
  const render::Band& band = setup.bands[0];
  *truth = ports::Place(setup.system.spec, setup.ep_in_housing_mm, band.n_glass, band.n_water);
  std::vector<ImageResult> poses;
  auto views = fixtures::Views(cam, *truth, target, seed, &poses, {0.9, 0.4, 0.15}, 0.0);
  const auto pts = TargetPoints(target);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0, noise_px);
  for (std::size_t i = 0; i < views.size(); ++i) {
    render::Pose pose;
    const Eigen::Vector3d aa = poses[i].rotation_rad;
    pose.rotation = Eigen::AngleAxisd(aa.norm(), aa.normalized()).toRotationMatrix();
    pose.translation_mm = poses[i].translation_mm;
    ImageDetections& d = views[i];
    const std::vector<int> ids = d.ids;
    d.ids.clear();
    d.points_px.clear();
    for (int id : ids) {
      if (!target.HasPoint(id)) continue;
      const auto c = render::DotImageCentre(setup, band, pose, pts[id], target.dot_radius_mm);
      if (!c) continue;
      d.ids.push_back(id);
      d.points_px.push_back(*c + Eigen::Vector2d(noise(rng), noise(rng)));
    }
  }
  return views;
}

// How far an estimate is from the truth, in its σ: the port and every adjusted lens parameter.
struct Deviation {
  std::array<double, 3> port_sigmas{};  // (estimate − truth) / σ per port parameter
  double worst_sigmas = 0;              // largest |estimate − truth| / σ, port and lens
  double port_mm = 0;                   // largest |estimate − truth| of the port, mm
  double c_sigmas = 0;                  // (c − truth) / σ
};
Deviation DeviationFromTruth(const char* what, const RefractiveResult& r, const ports::PortSystem& truth,
                             const camera::Camera& cam) {
  Deviation d;
  const auto t = refraction::ParamsOf(truth);
  for (int i = 0; i < 3; ++i) {
    if (!r.port_free[i]) continue;
    d.port_sigmas[i] = (r.port[i] - t[i]) / r.port_sigma[i];
    d.worst_sigmas = std::max(d.worst_sigmas, std::abs(d.port_sigmas[i]));
    d.port_mm = std::max(d.port_mm, std::abs(r.port[i] - t[i]));
  }
  std::string lens;
  for (int i = 0; i < cam.info().num_params; ++i) {
    if (!r.lens.free[i]) continue;
    const double s = (r.lens.camera.params[i] - cam.params[i]) / r.lens.sigma[i];
    if (i == 0) d.c_sigmas = s;
    d.worst_sigmas = std::max(d.worst_sigmas, std::abs(s));
    lens += fmt::format(" {} {:.1f}", cam.info().params[i].name, s);
  }
  std::printf("%s: %d points, largest offset %.3f px; port %.4f %.4f %.4f mm (truth %.4f %.4f %.4f): %.1f %.1f %.1f "
              "sigma, largest error %.2g mm; lens (sigma):%s; worst %.1f sigma\n",
              what, r.lens.n_points, r.lens.max_centre_offset_px, r.port[0], r.port[1], r.port[2], t[0], t[1], t[2],
              d.port_sigmas[0], d.port_sigmas[1], d.port_sigmas[2], d.port_mm, lens.c_str(), d.worst_sigmas);
  return d;
}

// The centre correction inside the refractive calibration (calibrate --port): synthetic coded
// views through the as-built NI320 (above), dots of 2.5 mm (14 bits, the default sheet) and 5 mm
// (12 bits), centres with 0.02 px noise (the detector's precision on clean renders), the port
// predicted at its nominal (pupil at the outer centre):
//  - the in-air calibration (chessboard, 0.02 px) as a prior, the default with one: without the
//    correction the estimate is biased (c 4σ and 11σ off), with it the port and every lens
//    parameter are within 3σ;
//  - the in-air lens fixed (exact), the port alone: without the correction the pupil's axial
//    offset is 7σ and 11σ off (0.017 and 0.08 mm), with it within 3σ;
//  - noise-free centres, prior: with the correction the truth comes back to 1e-4 mm — the
//    correction's rim (32 points through refraction::Project) and the renderer's truth (64
//    points through render's own forward projection) agree.
// The residuals do not show the bias (σ0 is the noise either way): the poses absorb most of it.
TEST(CodedCalib, RefractiveCorrectionRecoversTheAsBuiltNi320) {
  using CC = CalibrationOptions::CentreCorrection;
  const camera::Camera cam = refraction::testing::D300Brown();
  for (const char* spec : {"coded:14:2.5", "coded:12:5"}) {
    const TargetSpec target = ParseTarget(spec);
    ports::PortSystem truth;
    const auto views = CodedViewsThroughNi320(cam, target, 0.02, 5, &truth);
    RefractiveOptions o = fixtures::Options(fixtures::Displaced(truth, {-0.4, -1.0, -5.4}), cam.sensor.pixel_pitch_mm);
    o.air = fixtures::AirCalibration(cam, ParseTarget("chessboard:12x9:30"), 0.02);
    o.air_of = RefractiveOptions::AirCalibrationOf::kLensBare;
    o.intrinsics = IntrinsicsMode::kPrior;
    o.compare_central = false;
    const std::string name(spec);
    o.lens.centre_correction = CC::kOff;
    const RefractiveResult off = CalibrateRefractive(views, target, o);
    const Deviation d_off = DeviationFromTruth((name + ", prior, correction off").c_str(), off, truth, cam);
    o.lens.centre_correction = CC::kAuto;  // on: coded targets
    const RefractiveResult on = CalibrateRefractive(views, target, o);
    const Deviation d_on = DeviationFromTruth((name + ", prior, correction on").c_str(), on, truth, cam);
    EXPECT_EQ(off.lens.dot_radius_mm, 0);
    EXPECT_EQ(on.lens.dot_radius_mm, target.dot_radius_mm);
    EXPECT_GT(on.lens.max_centre_offset_px, 0.3) << spec;  // a real bias to remove
    EXPECT_GT(std::abs(d_off.c_sigmas), 3.5) << spec;
    EXPECT_LT(d_on.worst_sigmas, 3) << spec;
    EXPECT_NEAR(on.lens.sigma0_px, 0.02, 0.002) << spec;
    const auto j = RefractiveToJson(on, target, o);  // the lens block of `calibrate --port --json`
    EXPECT_EQ(j["dot_radius_mm"], target.dot_radius_mm);
    EXPECT_EQ(j["max_centre_offset_px"], on.lens.max_centre_offset_px);

    // The lens fixed: the port alone.
    o.air = fixtures::ExactLens(cam);
    o.air_of = RefractiveOptions::AirCalibrationOf::kLensBare;
    o.intrinsics = IntrinsicsMode::kFixed;
    o.lens.centre_correction = CC::kOff;
    const Deviation f_off = DeviationFromTruth((name + ", lens fixed, correction off").c_str(),
                                               CalibrateRefractive(views, target, o), truth, cam);
    o.lens.centre_correction = CC::kAuto;
    const Deviation f_on = DeviationFromTruth((name + ", lens fixed, correction on").c_str(),
                                              CalibrateRefractive(views, target, o), truth, cam);
    EXPECT_GT(std::abs(f_off.port_sigmas[2]), 5) << spec;
    EXPECT_LT(f_on.worst_sigmas, 3) << spec;
  }
  // Noise-free: the correction gives the truth back.
  const TargetSpec target = ParseTarget("coded:14:2.5");
  ports::PortSystem truth;
  const auto views = CodedViewsThroughNi320(cam, target, 0.0, 5, &truth);
  RefractiveOptions o = fixtures::Options(fixtures::Displaced(truth, {-0.4, -1.0, -5.4}), cam.sensor.pixel_pitch_mm);
  o.air = fixtures::AirCalibration(cam, ParseTarget("chessboard:12x9:30"), 0.02);
  o.air_of = RefractiveOptions::AirCalibrationOf::kLensBare;
  o.intrinsics = IntrinsicsMode::kPrior;
  o.compare_central = false;
  o.lens.reject_k = 0;  // σ0 is ~0: nothing to reject
  const RefractiveResult r = CalibrateRefractive(views, target, o);
  const Deviation d = DeviationFromTruth("coded:14:2.5, noise-free, correction on", r, truth, cam);
  EXPECT_LT(d.port_mm, 1e-4);
  EXPECT_LT(std::abs(r.lens.camera.params[0] - cam.params[0]), 1e-5);
}

}  // namespace
}  // namespace porthole::calib
