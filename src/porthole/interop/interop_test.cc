// Proves the format conversions of interop/interop.h:
//  - every exact pair (porthole model → format model → porthole) reprojects to ≤ 1e-9 px over the
//    whole image: each pixel of a grid through the frame's corners is unprojected by the original
//    camera and projected by the one read back;
//  - the COLMAP mapping against COLMAP's own equations written out here (the 0.5 px shift, the
//    parameter order of each model), independent of porthole's models;
//  - a Brown camera (the paper's Table 6, in air and under water) written to COLMAP and mrcal is a
//    dense refit whose RMS is reported and below 0.01 px;
//  - the Python-literal reader accepts what mrcal writes and refuses anything that is not a literal;
//  - Metashape's conventions on a hand-computed example (top-left pixel centre (0.5, 0.5), cx and
//    cy from the image centre, P1/P2 swapped against OpenCV's, PhotoScan's fx/fy/skew form), its
//    covariance carried to porthole's parameters by the hand-derived Jacobian, and a refit for
//    the terms OpenCV lacks (b2, k4, p3, p4);
//  - σ through a refit (Brown → OpenCV) agrees with a Monte Carlo of the refit;
//  - calibmar's calibration.yaml (its layout from calibmar's report.cpp) with σ and RMS from its
//    comments, and its DOMEPORT / FLATPORT housing as a porthole port: a ray traced by porthole
//    through the converted port leaves the glass where refractive COLMAP's equations (written out
//    here: ray–sphere / ray–plane, vector Snell, metres) put it;
//  - malformed files give InvalidInput naming the file and the field.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <fmt/format.h>

#include <cmath>
#include <random>
#include <string>

#include "porthole/core/error.h"
#include "porthole/interop/interop.h"
#include "porthole/interop/metashape.h"
#include "porthole/interop/pyliteral.h"
#include "porthole/interop/refractive.h"
#include "porthole/catalogue/presets.h"
#include "porthole/optics/trace.h"

namespace porthole::interop {
namespace {

using camera::Camera;
using camera::CameraModelId;

const camera::Sensor kD300{4288, 2848, 0.0055};

// The largest |B.Project(A.Unproject(uv)) − uv| over a 41 × 31 grid through the frame's corners, px.
double MaxReprojectionPx(const Camera& a, const Camera& b) {
  double worst = 0;
  for (int i = 0; i <= 40; ++i) {
    for (int j = 0; j <= 30; ++j) {
      const Eigen::Vector2d uv((a.sensor.width_px - 1) * i / 40.0, (a.sensor.height_px - 1) * j / 30.0);
      const auto ray = a.Unproject(uv);
      if (!ray) return INFINITY;
      const auto back = b.Project(*ray);
      if (!back) return INFINITY;
      worst = std::max(worst, (*back - uv).norm());
    }
  }
  return worst;
}

// The message of reading `content` as `f` from a file named "IN 'x'" ("no error" if it reads).
std::string message(const std::string& content, Format f) {
  try {
    ReadCalibration(content, f, 1.0, "IN 'x'");
  } catch (const InvalidInput& e) {
    return std::string(e.what());
  }
  return std::string("no error");
}

struct ExactCase {
  const char* name;
  Camera cam;
  Format format;
  const char* format_model;  // the model the file must hold
};

Camera OpenCV(std::vector<double> p) {
  p.resize(camera::OpenCVModel::kNumParams, 0.0);
  return {CameraModelId::kOpenCV, kD300, p};
}

std::vector<ExactCase> ExactCases() {
  const Camera full = OpenCV({4690, 4692, 2150, 1420, -0.1, 0.05, 1e-4, -2e-4, -0.01, 0.02, 0.005, 0.001});
  const Camera cv5 = OpenCV({4690, 4692, 2150, 1420, -0.1, 0.05, 1e-4, -2e-4, -0.01});
  const Camera cv4 = OpenCV({4690, 4692, 2150, 1420, -0.1, 0.05, 1e-4, -2e-4});
  const Camera radial = OpenCV({4690, 4690, 2150, 1420, -0.1, 0.05});
  const Camera simple_radial = OpenCV({4690, 4690, 2150, 1420, -0.1});
  const Camera pinhole = OpenCV({4690, 4692, 2150.25, 1420.75});
  const Camera simple_pinhole = OpenCV({4690, 4690, 2143.5, 1423.5});
  const Camera kb{CameraModelId::kKannalaBrandt, kD300, {1909, 1910, 2144, 1424, 0.02, -0.005, 0.001, -0.0002}};
  const Camera equidistant{CameraModelId::kEquidistant, kD300, {1700, 2140, 1426, 0.01, -0.001}};
  const Camera brown{CameraModelId::kBrown, kD300,
                     {25.801, -0.026, -0.144, 1.842e-4, -3.030e-7, 2e-10, 6.582e-6, 1.620e-5, 1e-4, -5e-5}};
  std::vector<ExactCase> cases = {
      {"opencv rational -> FULL_OPENCV", full, Format::kColmapText, "FULL_OPENCV"},
      {"opencv rational -> cameras.bin", full, Format::kColmapBinary, "FULL_OPENCV"},
      {"opencv k3 -> FULL_OPENCV", cv5, Format::kColmapText, "FULL_OPENCV"},
      {"opencv -> OPENCV", cv4, Format::kColmapText, "OPENCV"},
      {"opencv fx=fy k1 k2 -> RADIAL", radial, Format::kColmapText, "RADIAL"},
      {"opencv fx=fy k1 -> SIMPLE_RADIAL", simple_radial, Format::kColmapText, "SIMPLE_RADIAL"},
      {"opencv no distortion -> PINHOLE", pinhole, Format::kColmapText, "PINHOLE"},
      {"opencv fx=fy no distortion -> SIMPLE_PINHOLE", simple_pinhole, Format::kColmapBinary, "SIMPLE_PINHOLE"},
      {"kannala-brandt -> OPENCV_FISHEYE", kb, Format::kColmapText, "OPENCV_FISHEYE"},
      {"kannala-brandt -> OPENCV_FISHEYE bin", kb, Format::kColmapBinary, "OPENCV_FISHEYE"},
      {"equidistant -> OPENCV_FISHEYE", equidistant, Format::kColmapText, "OPENCV_FISHEYE"},
      {"opencv rational -> LENSMODEL_OPENCV8", full, Format::kMrcal, "LENSMODEL_OPENCV8"},
      {"opencv k3 -> LENSMODEL_OPENCV5", cv5, Format::kMrcal, "LENSMODEL_OPENCV5"},
      {"opencv -> LENSMODEL_OPENCV4", cv4, Format::kMrcal, "LENSMODEL_OPENCV4"},
      {"opencv no distortion -> LENSMODEL_PINHOLE", pinhole, Format::kMrcal, "LENSMODEL_PINHOLE"},
      {"opencv rational -> OpenCV YAML", full, Format::kOpenCVYaml, "8 coefficients"},
      {"opencv k3 -> OpenCV XML", cv5, Format::kOpenCVXml, "5 coefficients"},
      {"opencv -> OpenCV YAML", cv4, Format::kOpenCVYaml, "4 coefficients"},
      {"kannala-brandt -> cv::fisheye YAML", kb, Format::kOpenCVYaml, "fisheye, 4 coefficients"},
      {"kannala-brandt -> cv::fisheye XML", kb, Format::kOpenCVXml, "fisheye, 4 coefficients"},
      {"equidistant -> cv::fisheye XML", equidistant, Format::kOpenCVXml, "fisheye, 4 coefficients"},
      {"opencv k3 -> Metashape frame", cv5, Format::kMetashape, "frame"},
      {"opencv fx=fy -> Metashape frame", radial, Format::kMetashape, "frame"},
      {"kannala-brandt -> Metashape fisheye", kb, Format::kMetashape, "fisheye"},
      {"equidistant -> Metashape fisheye", equidistant, Format::kMetashape, "fisheye"},
  };
  // Every model of the list through porthole's own JSON.
  for (const Camera& c : {full, kb, equidistant, brown}) {
    cases.push_back({"json", c, Format::kJson, nullptr});
  }
  camera::ForEachModel([&](auto m) {
    using M = decltype(m);
    if constexpr (M::kId != CameraModelId::kBrown && M::kId != CameraModelId::kOpenCV &&
                  M::kId != CameraModelId::kKannalaBrandt && M::kId != CameraModelId::kEquidistant) {
      Camera c = Camera::Ideal(M::kId, kD300, 3000);  // covers the frame, orthographic too
      c.params[M::kK1] = 0.002;
      cases.push_back({"json (ideal fisheye)", c, Format::kJson, nullptr});
    }
  });
  return cases;
}

TEST(Interop, EveryExactPairRoundTripsTo1e9PxOverTheWholeImage) {
  double worst = 0;
  for (const auto& c : ExactCases()) {
    SCOPED_TRACE(std::string(c.name) + " " + std::string(FormatName(c.format)));
    const WriteResult w = WriteCamera(c.cam, c.format, "out");
    EXPECT_TRUE(w.exact);
    EXPECT_EQ(w.fit.rms_px, 0);
    if (c.format_model != nullptr) {
      EXPECT_EQ(w.format_model, c.format_model);
    }
    const ReadResult r = ReadCalibration(w.content, c.format, kD300.pixel_pitch_mm, "in");
    EXPECT_EQ(r.camera().sensor.width_px, kD300.width_px);
    EXPECT_EQ(r.camera().sensor.height_px, kD300.height_px);
    const double px = MaxReprojectionPx(c.cam, r.camera());
    EXPECT_LE(px, 1e-9);
    worst = std::max(worst, px);
  }
  std::printf("worst exact round trip over every pair: %.3g px\n", worst);
}

// COLMAP's equations written out (colmap/src/base/camera_models.h, OpenCVCameraModel and
// FullOpenCVCameraModel: u = fx·(x + du) + cx with COLMAP's pixel convention; docs/interop.md):
// a point projected by them lands 0.5 px from porthole's projection of the camera read back.
TEST(Interop, ColmapEquationsAndTheHalfPixelShift) {
  ColmapCamera c{1, "OPENCV", 4288, 2848, {4690, 4692, 2150.5, 1420.5, -0.1, 0.05, 1e-4, -2e-4}};
  const Camera cam = FromColmap(c, 0.0055, "in");
  const auto& q = c.params;
  for (const Eigen::Vector3d& X : {Eigen::Vector3d(100, -50, 1000), Eigen::Vector3d(-300, 200, 900)}) {
    const double x = X(0) / X(2), y = X(1) / X(2), r2 = x * x + y * y;
    const double radial = q[4] * r2 + q[5] * r2 * r2;
    const double du = x * radial + 2 * q[6] * x * y + q[7] * (r2 + 2 * x * x);
    const double dv = y * radial + 2 * q[7] * x * y + q[6] * (r2 + 2 * y * y);
    const Eigen::Vector2d colmap(q[0] * (x + du) + q[2], q[1] * (y + dv) + q[3]);
    const auto ours = cam.Project(X);
    ASSERT_TRUE(ours);
    EXPECT_NEAR((*ours - camera::ColmapToPixel(colmap)).norm(), 0, 1e-9);
  }
  // SIMPLE_RADIAL f cx cy k: one focal length, k = k1.
  const Camera sr = FromColmap({1, "SIMPLE_RADIAL", 100, 80, {500, 50, 40, -0.2}}, 1, "in");
  EXPECT_EQ(sr.params, (std::vector<double>{500, 500, 49.5, 39.5, -0.2, 0, 0, 0, 0, 0, 0, 0}));
}

TEST(Interop, BrownToPixelFormatsIsARefitBelow1e2PxForThePapersTable6) {
  // Menna et al. 2016, Table 6 (tests/data/menna2016_table6.csv): in air and under water.
  const std::vector<std::vector<double>> table6 = {
      {25.801, -0.026, -0.144, 1.842e-4, -3.030e-7, 0, 0, 0, 0, 0},
      {26.208, -0.058, -0.207, 1.663e-4, -2.582e-7, 0, 6.582e-6, 1.620e-5, 0, 0}};
  for (const auto& p : table6) {
    const Camera brown{CameraModelId::kBrown, kD300, p};
    for (Format f : {Format::kColmapText, Format::kMrcal, Format::kOpenCVYaml}) {
      SCOPED_TRACE(std::string(FormatName(f)));
      const WriteResult w = WriteCamera(brown, f, "out");
      EXPECT_FALSE(w.exact);
      EXPECT_GT(w.fit.num_points, 100);
      EXPECT_LT(w.fit.rms_px, 0.01);
      // What is read back reprojects the Brown camera to within the refit's max.
      const ReadResult r = ReadCalibration(w.content, f, kD300.pixel_pitch_mm, "in");
      EXPECT_LE(MaxReprojectionPx(brown, r.camera()), w.fit.max_px * 1.01 + 1e-9);
      std::printf("Table 6 c=%.3f -> %s: refit RMS %.2e px, max %.2e px\n", p[0],
                  std::string(FormatName(f)).c_str(), w.fit.rms_px, w.fit.max_px);
    }
  }
}

// A COLMAP file with several cameras: one chosen by id; mrcal's extrinsics carried to mrcal.
TEST(Interop, CameraIdAndMrcalExtrinsics) {
  const std::string two = "1 PINHOLE 640 480 500 501 320.5 240.5\n7 SIMPLE_PINHOLE 800 600 700 400.5 300.5\n";
  const ReadResult r = ReadCalibration(two, Format::kColmapText, 1, "IN", 7);
  EXPECT_EQ(r.camera().sensor.width_px, 800);
  EXPECT_EQ(r.camera().params[camera::OpenCVModel::kCx], 400);
  EXPECT_THROW(ReadCalibration(two, Format::kColmapText, 1, "IN", 3), InvalidInput);
  const std::string model =
      "{ 'lensmodel': 'LENSMODEL_OPENCV4', 'intrinsics': [500, 501, 320, 240, -0.1, 0.01, 0, 0],\n"
      "  'extrinsics': [0.1, -0.2, 0.3, 10, 20, -30], 'imagersize': [640, 480] }\n";
  const ReadResult m = ReadCalibration(model, Format::kMrcal, 1, "IN");
  ASSERT_TRUE(m.rt_fromref);
  EXPECT_EQ((*m.rt_fromref)[5], -30);
  const auto back = ParsePythonLiteral(WriteCalibration(m.calibration, Format::kMrcal, "OUT", {std::nullopt, m.rt_fromref}).content, "back");
  for (int k = 0; k < 6; ++k) EXPECT_EQ(back["extrinsics"][k].get<double>(), (*m.rt_fromref)[k]);
}

// Several cameras in one cameras.txt / cameras.bin, each with its CAMERA_ID, and refractive COLMAP's
// housing after a camera's parameters (COLMAP-Underwater's "… PARAMS[] DOMEPORT p1 … p8", and the later
// "… REFRAC DOMEPORT …"): each camera read back by id reprojects as written to 1e-9 px, the housing
// exactly.
TEST(Interop, SeveralCamerasAndRefractiveColmapCamerasTxt) {
  const Camera cv4 = OpenCV({4690, 4692, 2150, 1420, -0.1, 0.05, 1e-4, -2e-4});
  const Camera kb{CameraModelId::kKannalaBrandt, kD300, {1909, 1910, 2144, 1424, 0.02, -0.005, 0.001, -0.0002}};
  RefractiveHousing dome;
  dome.model = "DOMEPORT";
  dome.params = {0.002, -0.001, 0.003, 0.1, 0.008, 1, 1.5, 1.334};
  const std::vector<ColmapEntry> entries = {{WithoutSigma(cv4, ""), 3, std::nullopt}, {WithoutSigma(kb, ""), 7, dome}};
  const WriteResult w = WriteColmapCameras(entries, Format::kColmapText, "OUT");
  EXPECT_TRUE(w.exact);
  EXPECT_EQ(w.format_model, "OPENCV, OPENCV_FISHEYE + DOMEPORT");
  EXPECT_NE(w.content.find("# Number of cameras: 2"), std::string::npos);
  EXPECT_NE(w.content.find("\n7 OPENCV_FISHEYE 4288 2848 1909 1910 2144.5 1424.5 0.02 "), std::string::npos) << w.content;
  EXPECT_NE(w.content.find(" DOMEPORT 0.002 -0.001 0.003"), std::string::npos) << w.content;
  const ReadResult a = ReadCalibration(w.content, Format::kColmapText, kD300.pixel_pitch_mm, "IN", 3);
  EXPECT_LE(MaxReprojectionPx(cv4, a.camera()), 1e-9);
  EXPECT_FALSE(a.housing);
  std::string refrac = w.content;
  refrac.replace(refrac.find(" DOMEPORT "), 10, " REFRAC DOMEPORT ");
  for (const std::string& text : {w.content, refrac}) {
    const ReadResult b = ReadCalibration(text, Format::kColmapText, kD300.pixel_pitch_mm, "IN", 7);
    EXPECT_LE(MaxReprojectionPx(kb, b.camera()), 1e-9);
    ASSERT_TRUE(b.housing);
    EXPECT_EQ(b.housing->model, "DOMEPORT");
    EXPECT_EQ(b.housing->params, dome.params);
    EXPECT_EQ(b.format_model, "OPENCV_FISHEYE + DOMEPORT");
  }
  const WriteResult bin = WriteColmapCameras({entries[0], {WithoutSigma(kb, ""), 7, std::nullopt}},
                                             Format::kColmapBinary, "OUT");
  EXPECT_LE(MaxReprojectionPx(kb, ReadCalibration(bin.content, Format::kColmapBinary, kD300.pixel_pitch_mm, "IN", 7)
                                      .camera()),
            1e-9);
  // What cannot be written says so.
  EXPECT_THROW(WriteColmapCameras(entries, Format::kColmapBinary, "OUT"), InvalidInput);  // housing: text only
  EXPECT_THROW(WriteColmapCameras({entries[0], entries[0]}, Format::kColmapText, "OUT"), InvalidInput);
  EXPECT_THROW(WriteColmapCameras(entries, Format::kMrcal, "OUT"), InvalidInput);
  for (const char* bad : {"1 PINHOLE 640 480 500 500 320 240 DOMEPORT 0 0 0 0.1 0.01 1 1.5\n",
                          "1 PINHOLE 640 480 500 500 320 240 REFRAC\n",
                          "1 PINHOLE 640 480 500 500 320 240 DOMEPORT 0 0 0 0.1 0.01 1 1.5 x\n"}) {
    EXPECT_THROW(ReadCalibration(bad, Format::kColmapText, 1, "IN"), InvalidInput) << bad;
  }
  // A housing porthole cannot use is named where it stands.
  EXPECT_NE(message("1 PINHOLE 640 480 500 500 320 240 FLATPORT 0 0 0 0.02 0.01 1 1.5 1.33\n", Format::kColmapText)
                .find("IN 'x': line 1: FLATPORT: Nx: the normal Nx, Ny, Nz must be a unit vector"),
            std::string::npos);
  EXPECT_NE(message("1 PINHOLE 640 480 500 500 320 240 DOMEPORT 0 0 0 0.1 0.01 1 0.5 1.33\n", Format::kColmapText)
                .find("IN 'x': line 1: DOMEPORT: ng: a refractive index must be in [1, 5)"),
            std::string::npos);
}

// The housing's σ (calibmar's # non_svp_est_std_dev, metres) as the port TOML's [sigma] table in mm,
// which catalogue::ParsePortToml accepts with the port; a negative σ is refused naming the key.
TEST(Interop, HousingSigmaGoesIntoThePortToml) {
  RefractiveHousing flat;
  flat.model = "FLATPORT";
  flat.params = {0, 0, 1, 0.025, 0.012, 1, 1.49, 1.341};
  flat.sigma = {0.001, 0.002, 0.0005, 0.0001, NAN, NAN, NAN, NAN};
  double nw = 0;
  const std::string sigma = HousingSigmaToml(flat);
  EXPECT_NE(sigma.find("[sigma]\nnormal = [0.001, 0.002, 0.0005]\ndistance_mm = 0.1\n"), std::string::npos) << sigma;
  EXPECT_EQ(sigma.find("thickness_mm"), std::string::npos);  // unknown: not written
  const std::string toml = catalogue::PortToToml(PortFromRefractive(flat, "IN", &nw)) + sigma;
  EXPECT_NO_THROW(catalogue::ParsePortToml(toml, "port.toml"));
  std::string bad = toml;
  bad.replace(bad.find("distance_mm = 0.1"), 17, "distance_mm = -0.1");
  try {
    catalogue::ParsePortToml(bad, "port.toml");
    ADD_FAILURE() << "a negative sigma was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("sigma.distance_mm"), std::string::npos) << e.what();
  }
  EXPECT_EQ(HousingSigmaToml(RefractiveHousing{}), "");
}

TEST(Interop, PythonLiteralReaderTakesWhatMrcalWritesAndNothingElse) {
  const auto j = ParsePythonLiteral(
      "# comment\n{\n  'lensmodel': 'LENSMODEL_OPENCV4', # trailing\n"
      "  'intrinsics': [ 1.5e3, -2, +3.25, 4., ],\n  'imagersize': (640, 480),\n"
      "  \"x\": {'a': True, 'b': None, 'c': False, 'd': b'ab\\'c'},\n}\n", "f");
  EXPECT_EQ(j["lensmodel"], "LENSMODEL_OPENCV4");
  EXPECT_EQ(j["intrinsics"][0].get<double>(), 1500);
  EXPECT_EQ(j["intrinsics"][1].get<int>(), -2);
  EXPECT_EQ(j["intrinsics"][2].get<double>(), 3.25);
  EXPECT_EQ(j["imagersize"][1].get<int>(), 480);
  EXPECT_EQ(j["x"]["a"], true);
  EXPECT_TRUE(j["x"]["b"].is_null());
  EXPECT_EQ(j["x"]["d"], "ab'c");
  for (const char* bad : {"{'a': __import__('os')}", "{'a': 1 + 2}", "{'a': [1, 2}", "{1: 2}",
                          "{'a': 'unterminated}", "{'a': 1} junk"}) {
    EXPECT_THROW(ParsePythonLiteral(bad, "f"), InvalidInput) << bad;
  }
  std::string deep(100, '[');
  EXPECT_THROW(ParsePythonLiteral(deep, "f"), InvalidInput);
}

// Each malformed file: InvalidInput whose message names the file (the field given) and the key.
TEST(Interop, MalformedFilesNameTheFileAndTheField) {
  auto has = [](const std::string& msg, const std::string& part) {
    return msg.find("IN 'x'") != std::string::npos && msg.find(part) != std::string::npos;
  };
  EXPECT_TRUE(has(message("1 OPENCV 640 480 500 500 320 240", Format::kColmapText), "PARAMS"));
  EXPECT_TRUE(has(message("1 THIN_PRISM_FISHEYE 640 480 1 2 3", Format::kColmapText), "MODEL"));
  EXPECT_TRUE(has(message("1 PINHOLE 640 480 500 500 x 240", Format::kColmapText), "'x'"));
  EXPECT_TRUE(has(message("1 PINHOLE 640 480 500 500 320 240\n2 PINHOLE 640 480 500 500 320 240\n",
                          Format::kColmapText), "2 cameras (ids 1, 2)"));
  EXPECT_TRUE(has(message(std::string("\x01\0\0\0\0\0\0\0", 8), Format::kColmapBinary), "camera"));
  EXPECT_TRUE(has(message("{'lensmodel': 'LENSMODEL_CAHVOR', 'intrinsics': [1,2,3,4], 'imagersize': [1, 1]}",
                          Format::kMrcal), "lensmodel"));
  EXPECT_TRUE(has(message("{'lensmodel': 'LENSMODEL_OPENCV4', 'intrinsics': [1,2,3,4], 'imagersize': [1, 1]}",
                          Format::kMrcal), "intrinsics"));
  EXPECT_TRUE(has(message("{'lensmodel': 'LENSMODEL_PINHOLE', 'intrinsics': [1,1,3,4]}", Format::kMrcal),
                  "imagersize"));
  EXPECT_TRUE(has(message("%YAML:1.0\n---\nimage_width: 10\nimage_height: 10\n", Format::kOpenCVYaml),
                  "camera_matrix"));
  EXPECT_TRUE(has(message("%YAML:1.0\n---\nimage_width: 10\nimage_height: 10\ncamera_matrix: !!opencv-matrix\n"
                          "   rows: 3\n   cols: 3\n   dt: d\n   data: [ 5, 0, 5, 0, 5, 5, 0, 0, 1 ]\n"
                          "distortion_coefficients: !!opencv-matrix\n   data: [ 0, 0, 0 ]\n",
                          Format::kOpenCVYaml), "distortion_coefficients"));
  EXPECT_TRUE(has(message("{\"camera\": {\"fx_px\": 1}, \"model\": \"opencv\"}", Format::kJson), "sensor"));
  // A model without an equivalent in the format says so.
  const Camera kb{CameraModelId::kKannalaBrandt, kD300, {1909, 1910, 2144, 1424, 0.02, -0.005, 0.001, -0.0002}};
  EXPECT_THROW(WriteCamera(kb, Format::kMrcal, "OUT"), InvalidInput);
  const Camera equisolid = Camera::Ideal(CameraModelId::kEquisolid, kD300, 3000);
  EXPECT_THROW(WriteCamera(equisolid, Format::kOpenCVXml, "OUT"), InvalidInput);
}

// OpenCV FileStorage as OpenCV writes it (the XML below is what cv2.FileStorage wrote for these
// values, OpenCV 4.6; the YAML the layout of cv::FileStorage's "<<" of a cv::Size and a Mat), both key
// spellings, and the rules that tell cv::fisheye's K, D from the pinhole model
// (interop/opencv_storage.h).
TEST(OpenCVStorage, ReadsBothSpellingsInYamlAndXmlAndTellsFisheyeFromPinhole) {
  const std::string xml =
      "<?xml version=\"1.0\"?>\n<opencv_storage>\n<image_width>640</image_width>\n"
      "<image_height>480</image_height>\n<camera_matrix type_id=\"opencv-matrix\">\n  <rows>3</rows>\n"
      "  <cols>3</cols>\n  <dt>d</dt>\n  <data>\n    5.0025000000000000e+02 0. 3.2050000000000000e+02 0. 501. 240. "
      "0. 0.\n    1.</data></camera_matrix>\n<distortion_coefficients type_id=\"opencv-matrix\">\n  <rows>1</rows>\n"
      "  <cols>5</cols>\n  <dt>d</dt>\n  <data>\n    -1.0000000000000001e-01 1.0000000000000000e-02\n"
      "    1.0000000000000000e-04 -2.0000000000000001e-04\n    1.0000000000000000e-03</data></distortion_coefficients>\n"
      "</opencv_storage>\n";
  const ReadResult a = ReadCalibration(xml, Format::kOpenCVXml, 0.005, "IN");
  EXPECT_EQ(a.camera().model, CameraModelId::kOpenCV);
  EXPECT_EQ(a.camera().params, (std::vector<double>{500.25, 501, 320.5, 240, -0.1, 0.01, 1e-4, -2e-4, 1e-3, 0, 0, 0}));
  EXPECT_EQ(a.camera().sensor.width_px, 640);
  EXPECT_EQ(a.format_model, "5 coefficients");
  // cameraMatrix / distCoeffs / imageSize (cv::Size), YAML and XML.
  const std::string yaml_camel =
      "%YAML:1.0\n---\nimageSize: [ 640, 480 ]\ncameraMatrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
      "   data: [ 500.25, 0., 320.5, 0., 501., 240., 0., 0., 1. ]\ndistCoeffs: !!opencv-matrix\n   rows: 5\n"
      "   cols: 1\n   dt: d\n   data: [ -0.1, 0.01, 1.0000000000000000e-04,\n       -2.0000000000000001e-04, 1.0e-03 ]\n";
  EXPECT_EQ(ReadCalibration(yaml_camel, Format::kOpenCVYaml, 0.005, "IN").camera().params, a.camera().params);
  const std::string xml_camel =
      "<?xml version=\"1.0\"?>\n<opencv_storage>\n<imageSize>640 480</imageSize>\n<cameraMatrix type_id=\"opencv-matrix\">"
      "<rows>3</rows><cols>3</cols><dt>d</dt><data>500.25 0 320.5 0 501 240 0 0 1</data></cameraMatrix>\n"
      "<distCoeffs type_id=\"opencv-matrix\"><rows>5</rows><cols>1</cols><dt>d</dt>"
      "<data>-0.1 0.01 1e-4 -2e-4 1e-3</data></distCoeffs>\n</opencv_storage>\n";
  EXPECT_EQ(ReadCalibration(xml_camel, Format::kOpenCVXml, 0.005, "IN").camera().params, a.camera().params);

  // cv::fisheye: K and D with 4 coefficients, or any spelling with OpenCV's sample's fisheye_model: 1,
  // or ROS's distortion_model: equidistant. K = [fx 0 cx; 0 fy cy; 0 0 1], D = k1..k4.
  const std::string kd =
      "%YAML:1.0\n---\nimage_width: 1920\nimage_height: 1080\nK: !!opencv-matrix\n   rows: 3\n   cols: 3\n"
      "   dt: d\n   data: [ 700, 0, 960, 0, 701, 540, 0, 0, 1 ]\nD: !!opencv-matrix\n   rows: 4\n   cols: 1\n"
      "   dt: d\n   data: [ 0.02, -0.005, 0.001, -0.0002 ]\n";
  const ReadResult f = ReadCalibration(kd, Format::kOpenCVYaml, 0.003, "IN");
  EXPECT_EQ(f.camera().model, CameraModelId::kKannalaBrandt);
  EXPECT_EQ(f.camera().params, (std::vector<double>{700, 701, 960, 540, 0.02, -0.005, 0.001, -0.0002}));
  auto with = [&](const std::string& marker) {
    return ReadCalibration(kd + marker, Format::kOpenCVYaml, 0.003, "IN").camera().model;
  };
  EXPECT_EQ(with("fisheye_model: 0\n"), CameraModelId::kOpenCV);  // k1 k2 p1 p2
  EXPECT_EQ(with("distortion_model: plumb_bob\n"), CameraModelId::kOpenCV);
  EXPECT_EQ(with("distortion_model: \"equidistant\"\n"), CameraModelId::kKannalaBrandt);
  std::string named = kd;
  named.replace(named.find("K:"), 2, "camera_matrix:");
  EXPECT_EQ(ReadCalibration(named, Format::kOpenCVYaml, 1, "IN").camera().model, CameraModelId::kOpenCV);
  EXPECT_EQ(ReadCalibration(named + "fisheye_model: 1\n", Format::kOpenCVYaml, 1, "IN").camera().model,
            CameraModelId::kKannalaBrandt);

  // ROS camera_info YAML (camera_calibration_parsers' layout: no %YAML header, nested rows/cols/data,
  // distortion_model): plumb_bob is the pinhole model, equidistant cv::fisheye's.
  const std::string ros =
      "image_width: 640\nimage_height: 480\ncamera_name: left\ncamera_matrix:\n  rows: 3\n  cols: 3\n"
      "  data: [500.25, 0, 320.5, 0, 501, 240, 0, 0, 1]\ndistortion_model: plumb_bob\ndistortion_coefficients:\n"
      "  rows: 1\n  cols: 5\n  data: [-0.1, 0.01, 0.0001, -0.0002, 0.001]\nrectification_matrix:\n  rows: 3\n"
      "  cols: 3\n  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n";
  EXPECT_EQ(ReadCalibration(ros, Format::kOpenCVYaml, 0.005, "IN").camera().params, a.camera().params);
  std::string ros_fisheye = ros;
  ros_fisheye.replace(ros_fisheye.find("plumb_bob"), 9, "equidistant");
  ros_fisheye.replace(ros_fisheye.find("cols: 5\n  data: [-0.1, 0.01, 0.0001, -0.0002, 0.001]"), 52,
                      "cols: 4\n  data: [-0.1, 0.01, 0.0001, -0.0002]");
  const ReadResult rf = ReadCalibration(ros_fisheye, Format::kOpenCVYaml, 0.005, "IN");
  EXPECT_EQ(rf.camera().model, CameraModelId::kKannalaBrandt);
  EXPECT_EQ(rf.camera().params, (std::vector<double>{500.25, 501, 320.5, 240, -0.1, 0.01, 1e-4, -2e-4}));

  // Malformed: one message naming the file and the key.
  auto replaced = [](std::string s, const std::string& from, const std::string& to) {
    s.replace(s.find(from), from.size(), to);
    return s;
  };
  const std::vector<std::pair<std::string, std::string>> bad = {
      {replaced(xml, "<cols>5</cols>", "<cols>6</cols>"), "IN 'x': distortion_coefficients: rows x cols = 1 x 6"},
      {replaced(xml, "501.", "501.x"), "IN 'x': camera_matrix: '501.x' is not a finite number"},
      {replaced(xml, "<image_width>640", "<image_width>-640"), "IN 'x': image_width: must be a whole number"},
      {replaced(xml, "opencv_storage>\n<image", "calibration>\n<image"), "IN 'x': line"},
      {replaced(replaced(xml, "<opencv_storage>", "<storage>"), "</opencv_storage>", "</storage>"),
       "IN 'x': not an OpenCV FileStorage XML"},
      {replaced(xml, "0. 501.", "7. 501."), "IN 'x': camera_matrix: must be 3x3"},
      {"<!DOCTYPE a [<!ENTITY x \"y\">]><opencv_storage/>", "IN 'x': line 1: a DOCTYPE is not accepted"},
  };
  for (const auto& [content, expected] : bad) {
    EXPECT_NE(message(content, Format::kOpenCVXml).find(expected), std::string::npos)
        << message(content, Format::kOpenCVXml);
  }
  EXPECT_NE(message(kd + "fisheye_model: 1\ndistortion_model: plumb_bob\n", Format::kOpenCVYaml)
                .find("IN 'x': distortion_model: contradicts fisheye_model"),
            std::string::npos);
  EXPECT_NE(message(replaced(kd, "0.02, ", ""), Format::kOpenCVYaml).find("IN 'x': D: rows x cols = 4 x 1"),
            std::string::npos);
  EXPECT_NE(message(replaced(replaced(kd, "0.02, ", ""), "rows: 4", "rows: 3") + "fisheye_model: 1\n", Format::kOpenCVYaml)
                .find("IN 'x': D: has 3 entries; cv::fisheye has 4"),
            std::string::npos);
  EXPECT_NE(message(kd + "distortion_model: kb8\n", Format::kOpenCVYaml).find("IN 'x': distortion_model"),
            std::string::npos);
}

// Metashape Professional 1.5 manual, Appendix C (docs/interop.md): u = w/2 + cx + x'(f + B1) + y'B2,
// v = h/2 + cy + y'f in coordinates whose top-left pixel centre is (0.5, 0.5), with
// x' = x + P1(r² + 2x²) + 2P2xy. By hand, for f = 3000, cx = 10, cy = −20, P1 = 1e-3 and the point
// (0.2, 0.1, 1): r² = 0.05, x' = 0.2 + 1e-3·0.13 = 0.20013, y' = 0.1 + 2e-3·0.02 = 0.10004, so
// Metashape's pixel is (2000 + 10 + 600.39, 1500 − 20 + 300.12) = (2610.39, 1780.12) and porthole's
// (0.5 less) (2609.89, 1779.62). OpenCV's term p2(r² + 2x²) is the same one: p2 = P1, p1 = P2 = 0.
TEST(Metashape, HandCheckedHalfPixelAndP1P2Conventions) {
  const std::string xml =
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<calibration>\n  <projection>frame</projection>\n"
      "  <width>4000</width>\n  <height>3000</height>\n  <f>3000</f>\n  <cx>10</cx>\n  <cy>-20</cy>\n"
      "  <k1>0</k1>\n  <k2>0</k2>\n  <p1>0.001</p1>\n  <p2>0</p2>\n  <date>2024-01-01T00:00:00Z</date>\n"
      "</calibration>\n";
  const ReadResult r = ReadCalibration(xml, Format::kMetashape, 0.004, "IN");
  EXPECT_TRUE(r.exact);
  EXPECT_EQ(r.format_model, "frame");
  const Camera& c = r.camera();
  ASSERT_EQ(c.model, CameraModelId::kOpenCV);
  using M = camera::OpenCVModel;
  EXPECT_EQ(c.params[M::kCx], 2009.5);
  EXPECT_EQ(c.params[M::kCy], 1479.5);
  EXPECT_EQ(c.params[M::kP1], 0);
  EXPECT_EQ(c.params[M::kP2], 0.001);
  const auto uv = c.Project({0.2, 0.1, 1});
  ASSERT_TRUE(uv);
  EXPECT_NEAR((*uv)(0), 2609.89, 1e-9);
  EXPECT_NEAR((*uv)(1), 1779.62, 1e-9);
  // Written back: the same numbers in Metashape's form.
  const auto back = ParseMetashapeXml(WriteCamera(c, Format::kMetashape, "OUT").content, "back");
  EXPECT_NEAR(back.params[kMsCx], 10, 1e-12);
  EXPECT_NEAR(back.params[kMsCy], -20, 1e-12);
  EXPECT_EQ(back.params[kMsP1], 0.001);
  EXPECT_EQ(back.params[kMsP2], 0);
  EXPECT_EQ(back.params[kMsB1], 0);

  // Old PhotoScan form (fx, fy, principal point from the corner): u = cx + x'fx, v = cy + y'fy.
  // fx = 3001, fy = 3000, cx = 2010, cy = 1480 → porthole fx = 3001, cx = 2009.5.
  const ReadResult ps = ReadCalibration(
      "<calibration><projection>frame</projection><width>4000</width><height>3000</height>"
      "<fx>3001</fx><fy>3000</fy><cx>2010</cx><cy>1480</cy><skew>0</skew><k1>-0.1</k1>"
      "<p1>0.001</p1></calibration>",
      Format::kMetashape, 0.004, "IN");
  EXPECT_TRUE(ps.exact);
  EXPECT_EQ(ps.camera().params[M::kFx], 3001);
  EXPECT_EQ(ps.camera().params[M::kFy], 3000);
  EXPECT_EQ(ps.camera().params[M::kCx], 2009.5);
  EXPECT_EQ(ps.camera().params[M::kCy], 1479.5);
  EXPECT_EQ(ps.camera().params[M::kK1], -0.1);
  EXPECT_EQ(ps.camera().params[M::kP2], 0.001);
}

// Metashape's fisheye: x = x0·atan(r0)/r0 is the equidistant angle, so k1–k4 on it are
// Kannala–Brandt's: a point 30° off axis along +X lands at cx + f·θ(1 + k1θ²) by hand.
TEST(Metashape, FisheyeIsKannalaBrandt) {
  const ReadResult r = ReadCalibration(
      "<calibration><projection>fisheye</projection><width>4000</width><height>3000</height>"
      "<f>1500</f><cx>0</cx><cy>0</cy><k1>0.02</k1></calibration>",
      Format::kMetashape, 0.004, "IN");
  EXPECT_TRUE(r.exact);
  ASSERT_EQ(r.camera().model, CameraModelId::kKannalaBrandt);
  const double th = M_PI / 6;
  const auto uv = r.camera().Project({std::sin(th), 0, std::cos(th)});
  ASSERT_TRUE(uv);
  EXPECT_NEAR((*uv)(0), 1999.5 + 1500 * th * (1 + 0.02 * th * th), 1e-9);
  EXPECT_NEAR((*uv)(1), 1499.5, 1e-9);
}

// The covariance block: Metashape's <params>/<coeffs> in porthole's order, by the Jacobian of the
// exact mapping (fx = f + b1: σ²fx = σ²f + σ²b1 + 2cov; cx, k1 unchanged; OpenCV p1 = P2, p2 = P1),
// and back to Metashape unchanged.
TEST(Metashape, CovarianceIsCarriedByTheMappingsJacobian) {
  // params f cx cy b1 k1 k2 k3 p1 p2; a symmetric positive matrix with correlations.
  const std::vector<std::string> names = {"f", "cx", "cy", "b1", "k1", "k2", "k3", "p1", "p2"};
  const std::vector<double> sd = {1.5, 0.8, 0.9, 0.05, 1e-4, 4e-4, 9e-4, 2e-6, 3e-6};
  const int n = static_cast<int>(names.size());
  Eigen::MatrixXd cov(n, n);
  for (int a = 0; a < n; ++a) {
    for (int b = 0; b < n; ++b) cov(a, b) = sd[a] * sd[b] * (a == b ? 1.0 : 0.3 * std::cos(a + 2.0 * b) * std::cos(b + 2.0 * a));
  }
  cov = 0.5 * (cov + cov.transpose()).eval();
  cov.diagonal() = Eigen::Map<const Eigen::VectorXd>(sd.data(), n).array().square();
  std::string params, coeffs;
  for (int a = 0; a < n; ++a) {
    params += (a ? " " : "") + names[a];
    for (int b = 0; b < n; ++b) coeffs += fmt::format(" {:.17g}", cov(a, b));
  }
  const std::string xml =
      "<calibration><projection>frame</projection><width>6000</width><height>4000</height>"
      "<f>4500</f><cx>12</cx><cy>-8</cy><b1>0.7</b1><k1>-0.08</k1><k2>0.1</k2><k3>-0.02</k3>"
      "<p1>1e-4</p1><p2>-2e-4</p2><covariance><params>" + params + "</params><coeffs>" + coeffs +
      "</coeffs></covariance></calibration>";
  const ReadResult r = ReadCalibration(xml, Format::kMetashape, 0.004, "IN");
  ASSERT_TRUE(r.calibration.has_covariance);
  using M = camera::OpenCVModel;
  const Eigen::MatrixXd& s = r.calibration.covariance;
  const auto rel = [](double a, double b) { return std::abs(a - b) / std::abs(b); };
  EXPECT_LT(rel(s(M::kFx, M::kFx), cov(0, 0) + cov(3, 3) + 2 * cov(0, 3)), 1e-6);
  EXPECT_LT(rel(s(M::kFy, M::kFy), cov(0, 0)), 1e-6);
  EXPECT_LT(rel(s(M::kFx, M::kFy), cov(0, 0) + cov(0, 3)), 1e-6);
  EXPECT_LT(rel(s(M::kCx, M::kCx), cov(1, 1)), 1e-6);
  EXPECT_LT(rel(s(M::kK3, M::kK3), cov(6, 6)), 1e-6);
  EXPECT_LT(rel(s(M::kP1, M::kP1), cov(8, 8)), 1e-6);  // OpenCV p1 = Metashape P2
  EXPECT_LT(rel(s(M::kP2, M::kP2), cov(7, 7)), 1e-6);
  EXPECT_LT(rel(s(M::kP1, M::kK1), cov(8, 4)), 1e-6);
  for (int i : {M::kK4, M::kK5, M::kK6}) EXPECT_FALSE(r.calibration.free[i]);
  // Back to Metashape: the same covariance.
  const WriteResult w = WriteCalibration(r.calibration, Format::kMetashape, "OUT");
  EXPECT_TRUE(w.exact);
  EXPECT_TRUE(w.sigma_written);
  const MetashapeCalibration back = ParseMetashapeXml(w.content, "back");
  const int idx[] = {kMsF, kMsCx, kMsCy, kMsB1, kMsK1, kMsK2, kMsK3, kMsP1, kMsP2};
  for (int a = 0; a < n; ++a) {
    for (int b = 0; b < n; ++b) {
      EXPECT_NEAR(back.covariance(idx[a], idx[b]), cov(a, b), 1e-6 * sd[a] * sd[b]) << names[a] << " " << names[b];
    }
  }
  // Without <covariance>, σ is unknown (NaN), not 0.
  const ReadResult none = ReadCalibration(
      "<calibration><width>6000</width><height>4000</height><f>4500</f><cx>0</cx><cy>0</cy>"
      "<k1>-0.08</k1></calibration>", Format::kMetashape, 0.004, "IN");
  EXPECT_FALSE(none.calibration.has_covariance);
  EXPECT_TRUE(none.calibration.free[M::kK1]);
  EXPECT_TRUE(std::isnan(none.calibration.covariance(M::kK1, M::kK1)));
}

// Terms OpenCV has not (b2 skew, k4, p3, p4): a refit over the image, reported; what is read
// reprojects Metashape's own equations (written out in MetashapeProjector) to the refit's max.
TEST(Metashape, TermsOpenCVLacksAreRefitWithTheirRms) {
  MetashapeCalibration m;
  m.width_px = 6000;
  m.height_px = 4000;
  m.params = {4500, 12, -8, 0.7, 0, -0.08, 0.1, -0.02, 0.004, 1e-4, -2e-4, 0, 0};
  m.present.fill(true);
  const ReadResult r = ReadCalibration(MetashapeXml(m), Format::kMetashape, 0.004, "IN");
  EXPECT_FALSE(r.exact);
  EXPECT_GT(r.fit.num_points, 1000);
  EXPECT_LT(r.fit.rms_px, 0.05);
  const MetashapeProjector proj{false, 6000, 4000};
  double worst = 0;
  for (const Eigen::Vector2d& uv : camera::FramePixels(r.camera().sensor, 21, 15)) {
    const auto ray = r.camera().Unproject(uv);
    ASSERT_TRUE(ray);
    worst = std::max(worst, ((*proj(m.params.data(), camera::Vec3<double>(*ray))) - uv).norm());
  }
  EXPECT_LE(worst, r.fit.max_px * 1.05 + 1e-6);
  std::printf("Metashape k4 = 0.004 read as opencv: refit RMS %.2e px, max %.2e px\n", r.fit.rms_px, r.fit.max_px);
}

// σ through a refit: the paper's in-air Table 6 calibration with its σ (Brown) written as OpenCV;
// the propagated σ of each OpenCV parameter against the spread of 60 refits of Brown cameras drawn
// from N(p, Σ) (Monte Carlo, independent of the Jacobian). Agreement within 30% (the sampling
// error of a σ from 60 draws is ~9%).
TEST(Interop, SigmaThroughARefitMatchesMonteCarlo) {
  const std::vector<double> p = {25.801, -0.026, -0.144, 1.842e-4, -3.030e-7, 0, 0, 0, 0, 0};
  const std::vector<double> sd = {0.004, 0.003, 0.003, 1.5e-6, 8e-9, 0, 0, 0, 0, 0};
  calib::CalibrationRecord rec;
  rec.camera = {CameraModelId::kBrown, kD300, p};
  rec.free = {true, true, true, true, true, false, false, false, false, false};
  rec.covariance = Eigen::MatrixXd::Zero(10, 10);
  for (int i = 0; i < 5; ++i) rec.covariance(i, i) = sd[i] * sd[i];
  rec.has_covariance = true;
  const auto conv = ConvertCalibration(rec, CameraModelId::kOpenCV, "A");
  ASSERT_TRUE(conv.has_covariance);
  std::mt19937 rng(7);
  std::normal_distribution<double> g;
  const int n = 60;
  Eigen::MatrixXd samples(n, 9);
  for (int k = 0; k < n; ++k) {
    calib::CalibrationRecord s = rec;
    for (int i = 0; i < 5; ++i) s.camera.params[i] += sd[i] * g(rng);
    const auto c = ConvertCalibration(s, CameraModelId::kOpenCV, "A");
    for (int i = 0; i < 9; ++i) samples(k, i) = c.camera.params[i];
  }
  const Eigen::RowVectorXd mean = samples.colwise().mean();
  for (int i : {0, 1, 2, 3, 4, 5}) {  // fx fy cx cy k1 k2
    const double mc = std::sqrt((samples.col(i).array() - mean(i)).square().sum() / (n - 1));
    const double prop = std::sqrt(conv.covariance(i, i));
    EXPECT_NEAR(prop / mc, 1.0, 0.3) << camera::OpenCVModel::kParams[i].name;
    std::printf("%s: propagated σ %.3g, Monte Carlo %.3g\n", std::string(camera::OpenCVModel::kParams[i].name).c_str(), prop, mc);
  }
}

TEST(Metashape, MalformedFilesNameTheElement) {
  auto message = [](const std::string& content) {
    try {
      ReadCalibration(content, Format::kMetashape, 1.0, "IN 'x'");
    } catch (const InvalidInput& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string head = "<calibration><width>100</width><height>80</height>";
  auto has = [&](const std::string& content, const std::string& part) {
    const std::string m = message(content);
    EXPECT_NE(m.find("IN 'x'"), std::string::npos) << m;
    EXPECT_NE(m.find(part), std::string::npos) << m;
  };
  has(head + "<cx>0</cx></calibration>", "<f>");
  has(head + "<f>abc</f></calibration>", "<f>");
  has(head + "<f>100</f><k1>1</k1><k1>2</k1></calibration>", "given twice");
  has("<calibration><f>100</f></calibration>", "<width>");
  has(head + "<f>100</f><projection>spherical</projection></calibration>", "projection");
  has(head + "<f>100</f><fx>100</fx><fy>100</fy></calibration>", "either f");
  has(head + "<f>100</f><covariance><params>f q</params><coeffs>1 0 0 1</coeffs></covariance></calibration>", "'q'");
  has(head + "<f>100</f><covariance><params>f cx</params><coeffs>1 0 0</coeffs></covariance></calibration>", "<coeffs>");
  has(head + "<f>100</f>", "not XML");
  has("<!DOCTYPE x [<!ENTITY a \"aaaa\">]><calibration/>", "DOCTYPE");
  has(std::string(40, '<').replace(0, 40, [] { std::string d; for (int i = 0; i < 40; ++i) d += "<a>"; return d; }()), "deeper");
  has("<other/>", "<calibration>");
}

// calibmar writes (src/calibmar/core/report.cpp, GenerateCalibrationYaml) model, parameters, σ in
// "# params_est_std_dev", non_svp_model and parameters, width, height, "# overall_rms".
const char* kCalibmarDome =
    "model: OPENCV\n"
    "# fx, fy, cx, cy, k1, k2, p1, p2\n"
    "parameters: [1500.5, 1501.25, 960.5, 540.5, -0.1, 0.05, 0.0001, -0.0002]\n"
    "# params_est_std_dev: 0.8, 0.7, 0.5, 0.4, 0.001, 0.002, 1e-05, 2e-05\n"
    "non_svp_model: DOMEPORT\n"
    "# Cx, Cy, Cz, int_radius, int_thick, na, ng, nw\n"
    "non_svp_parameters: [0.002, -0.001, 0.003, 0.1, 0.008, 1, 1.5, 1.334]\n"
    "# non_svp_est_std_dev: 0.0001, 0.0001, 0.0002\n"
    "width: 1920\n"
    "height: 1080\n"
    "# overall_rms: 0.21\n"
    "# target: chessboard, 10, 7, 0.04\n";

TEST(Calibmar, CalibrationYamlWithSigmaRmsAndHousing) {
  const ReadResult r = ReadCalibration(kCalibmarDome, Format::kCalibmar, 0.003, "IN");
  using M = camera::OpenCVModel;
  const Camera& c = r.camera();
  EXPECT_EQ(c.params[M::kCx], 960.0);  // COLMAP's convention: 0.5 less
  EXPECT_EQ(c.params[M::kFy], 1501.25);
  EXPECT_EQ(r.file_rms_px, 0.21);
  ASSERT_TRUE(r.calibration.has_covariance);
  EXPECT_NEAR(std::sqrt(r.calibration.covariance(M::kCx, M::kCx)), 0.5, 1e-15);
  EXPECT_NEAR(std::sqrt(r.calibration.covariance(M::kP2, M::kP2)), 2e-5, 1e-20);
  ASSERT_TRUE(r.housing);
  EXPECT_EQ(r.housing->model, "DOMEPORT");
  EXPECT_EQ(r.housing->sigma[2], 0.0002);
  EXPECT_TRUE(std::isnan(r.housing->sigma[3]));
  // Written back: the same file content (numbers in shortest round-trip form).
  const WriteResult w = WriteCalibration(r.calibration, Format::kCalibmar, "OUT", {r.housing, std::nullopt});
  const CalibmarFile back = ParseCalibmarYaml(w.content, "back");
  const CalibmarFile orig = ParseCalibmarYaml(kCalibmarDome, "orig");
  EXPECT_EQ(back.camera.model, "OPENCV");
  EXPECT_EQ(back.camera.params, orig.camera.params);
  for (std::size_t i = 0; i < orig.camera_sigma.size(); ++i) EXPECT_NEAR(back.camera_sigma[i], orig.camera_sigma[i], 1e-15);
  EXPECT_EQ(back.housing->params, orig.housing->params);
  // A SIMPLE_RADIAL's f is both fx and fy: fully correlated.
  const ReadResult sr = ReadCalibration("model: SIMPLE_RADIAL\nparameters: [1000, 320, 240, -0.1]\n"
                                        "# params_est_std_dev: 2, 1, 1, 0.01\nnon_svp_model: NONE\n"
                                        "non_svp_parameters: []\nwidth: 640\nheight: 480\n",
                                        Format::kCalibmar, 1, "IN");
  EXPECT_EQ(sr.calibration.covariance(M::kFx, M::kFy), 4.0);
  EXPECT_FALSE(sr.housing);
}

// Refractive COLMAP's DomePort::CamFromImg and FlatPort::CamFromImg (models_refrac.h) written out:
// the ray from the projection centre meets the inner interface, refracts na → ng, meets the outer
// one, refracts ng → nw (vector Snell). Returns the point on the outer surface (m) and direction.
Eigen::Vector3d Refract(const Eigen::Vector3d& d, Eigen::Vector3d n, double n1, double n2) {
  n.normalize();
  if (n.dot(d) < 0) n = -n;  // the normal along the ray
  const double r = n1 / n2, c = n.dot(d);
  const double k = 1 - r * r * (1 - c * c);
  return (r * d + (std::sqrt(k) - r * c) * n).normalized();
}
std::pair<Eigen::Vector3d, Eigen::Vector3d> ColmapRefractive(const RefractiveHousing& h, Eigen::Vector3d dir) {
  const auto& p = h.params;
  const Eigen::Vector3d v(p[0], p[1], p[2]);
  Eigen::Vector3d o = Eigen::Vector3d::Zero();
  dir.normalize();
  auto sphere = [&](double radius) {  // far intersection of o + t·dir with |x − v| = radius
    const Eigen::Vector3d oc = o - v;
    const double b = oc.dot(dir), c = oc.squaredNorm() - radius * radius;
    return -b + std::sqrt(b * b - c);
  };
  if (h.model == "DOMEPORT") {
    o += sphere(p[3]) * dir;
    dir = Refract(dir, o - v, p[5], p[6]);
    o += sphere(p[3] + p[4]) * dir;
    dir = Refract(dir, o - v, p[6], p[7]);
  } else {
    o += (p[3] - v.dot(o)) / v.dot(dir) * dir;
    dir = Refract(dir, v, p[5], p[6]);
    o += (p[3] + p[4] - v.dot(o)) / v.dot(dir) * dir;
    dir = Refract(dir, v, p[6], p[7]);
  }
  return {o, dir};
}

TEST(Calibmar, HousingAsAPortTracesAsRefractiveColmap) {
  RefractiveHousing dome;
  dome.model = "DOMEPORT";
  dome.params = {0.002, -0.001, 0.003, 0.1, 0.008, 1.0, 1.5, 1.334};
  RefractiveHousing flat;
  flat.model = "FLATPORT";
  const Eigen::Vector3d n = Eigen::Vector3d(0.05, -0.03, 1).normalized();
  flat.params = {n.x(), n.y(), n.z(), 0.025, 0.012, 1.0, 1.49, 1.341};
  for (const RefractiveHousing& h : {dome, flat}) {
    SCOPED_TRACE(h.model);
    double n_water = 0;
    const ports::PortSpec port = PortFromRefractive(h, "IN", &n_water);
    EXPECT_EQ(n_water, h.params[7]);
    // Through the port TOML and back: exact.
    const ports::PortSpec read = catalogue::ParsePortToml(catalogue::PortToToml(port), "port.toml");
    const RefractiveHousing back = RefractiveFromPort(read, std::stod(read.material()), n_water, "port");
    EXPECT_EQ(back.model, h.model);
    for (int i = 0; i < 8; ++i) EXPECT_NEAR(back.params[i], h.params[i], 1e-15) << i;
    // porthole's tracer through the port (cam frame: the pupil at the origin) against the
    // equations above, over a fan of rays up to 40° off axis.
    const ports::PortSystem sys = ports::Place(read, Eigen::Vector3d::Zero(), std::stod(read.material()), n_water);
    double worst_mm = 0, worst_dir = 0;
    for (double ax : {-0.8, -0.3, 0.0, 0.4, 0.8}) {
      for (double ay : {-0.6, 0.0, 0.5}) {
        const Eigen::Vector3d d = Eigen::Vector3d(ax, ay, 1).normalized();
        optics::Ray out;
        ASSERT_EQ(optics::TraceSequence(sys.Outward(), optics::Ray{Eigen::Vector3d::Zero(), d}, &out),
                  optics::RayStatus::kOk);
        const auto [o, dir] = ColmapRefractive(h, d);
        worst_mm = std::max(worst_mm, (out.origin - 1000.0 * o).norm());
        const double dd = (out.dir - dir).norm();
        worst_dir = std::isnan(dd) ? INFINITY : std::max(worst_dir, dd);
      }
    }
    EXPECT_LT(worst_mm, 1e-9);
    EXPECT_LT(worst_dir, 1e-12);
    std::printf("%s: porthole vs refractive COLMAP equations: %.2g mm, %.2g in direction\n", h.model.c_str(),
                worst_mm, worst_dir);
  }
  // A dome that is not concentric has no DOMEPORT.
  EXPECT_THROW(RefractiveFromPort(catalogue::LoadPort("nimar-ni320"), 1.5, 1.34, "port"), InvalidInput);
}

TEST(Calibmar, MalformedFilesNameTheKey) {
  auto message = [](const std::string& content) {
    try {
      ReadCalibration(content, Format::kCalibmar, 1.0, "IN 'x'");
    } catch (const InvalidInput& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string ok = kCalibmarDome;
  auto replace = [&](const std::string& a, const std::string& b) {
    std::string s = ok;
    s.replace(s.find(a), a.size(), b);
    return s;
  };
  EXPECT_NE(message(replace("model: OPENCV", "")).find("model"), std::string::npos);
  EXPECT_NE(message(replace("[1500.5", "[abc")).find("parameters"), std::string::npos);
  EXPECT_NE(message(replace("0.8, 0.7, ", "")).find("params_est_std_dev"), std::string::npos);
  EXPECT_NE(message(replace("DOMEPORT", "SPHEREPORT")).find("non_svp_model"), std::string::npos);
  EXPECT_NE(message(replace(", 1.334]", "]")).find("non_svp_parameters"), std::string::npos);
  EXPECT_NE(message(replace("width: 1920", "width: 1e12")).find("width"), std::string::npos);
  double nw = 0;
  RefractiveHousing bad;
  bad.model = "DOMEPORT";
  bad.params = {0, 0, 0, 0.1, 0.008, 1, 0.5, 1.33};
  EXPECT_THROW(PortFromRefractive(bad, "IN", &nw), InvalidInput);
}

// OpenCV's own sample calibration with a strong k3 (opencv-doc's left_intrinsics.yml, 640 × 480:
// k1 = −0.266, k3 = 0.238), read as Brown (what simulate and the report need): the refit is finite
// and projects every grid point (it used to report RMS inf), and its RMS is no worse than the best a
// purely radial 3-term correction polynomial does on the same lens (a least-squares fit of
// r = r_d(1 + a r_d² + b r_d⁴ + c r_d⁶) to OpenCV's inverse, computed here): what remains is the
// two models' difference, not a failed fit.
TEST(Interop, StrongK3OpenCVYamlRefitsToBrownAsWellAsTheModelAllows) {
  const std::string yaml =
      "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\ncamera_matrix: !!opencv-matrix\n   rows: 3\n"
      "   cols: 3\n   dt: d\n   data: [ 5.3591573396163199e+02, 0., 3.4228315473308373e+02, 0.,\n"
      "       5.3591573396163199e+02, 2.3557082909788173e+02, 0., 0., 1. ]\n"
      "distortion_coefficients: !!opencv-matrix\n   rows: 5\n   cols: 1\n   dt: d\n"
      "   data: [ -2.6637260909660682e-01, -3.8588898922304653e-02,\n       1.7831947042852964e-03, "
      "-2.8122100441115472e-04,\n       2.3839153080878486e-01 ]\n";
  const ReadResult r = ConvertRead(ReadCalibration(yaml, Format::kOpenCVYaml, 0.006, "IN"), CameraModelId::kBrown, "IN");
  EXPECT_FALSE(r.exact);
  // The refit's correction polynomial turns over just inside the frame's extreme corners: those few
  // grid points have no Brown projection (counted, not averaged; camera::ConversionFit).
  EXPECT_LT(r.fit.num_not_projected, r.fit.num_points / 100);
  ASSERT_TRUE(std::isfinite(r.fit.rms_px));
  // The radial-only bound over the same 40 × 30 grid.
  const double f = 5.3591573396163199e+02, cx = 3.4228315473308373e+02, cy = 2.3557082909788173e+02;
  const double k1 = -2.6637260909660682e-01, k2 = -3.8588898922304653e-02, k3 = 2.3839153080878486e-01;
  Eigen::MatrixXd a(40 * 30, 3);
  Eigen::VectorXd b(40 * 30);
  for (int j = 0; j < 30; ++j) {
    for (int i = 0; i < 40; ++i) {
      const double rd = std::hypot(i * 639.0 / 39 - cx, j * 479.0 / 29 - cy) / f;
      double ru = rd;
      for (int it = 0; it < 100; ++it) {
        const double r2 = ru * ru;
        ru -= (ru * (1 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2) - rd) /
              (1 + 3 * k1 * r2 + 5 * k2 * r2 * r2 + 7 * k3 * r2 * r2 * r2);
      }
      a.row(j * 40 + i) << std::pow(rd, 3), std::pow(rd, 5), std::pow(rd, 7);
      b(j * 40 + i) = ru - rd;
    }
  }
  const Eigen::VectorXd coef = a.colPivHouseholderQr().solve(b);
  const double radial_rms_px = f * std::sqrt((a * coef - b).squaredNorm() / b.size());
  std::printf("left_intrinsics.yml as Brown: refit RMS %.4f px (max %.3f px, %d of %d grid points not projected); "
              "radial-only 3-term inverse: RMS %.4f px\n",
              r.fit.rms_px, r.fit.max_px, r.fit.num_not_projected, r.fit.num_points, radial_rms_px);
  EXPECT_LE(r.fit.rms_px, radial_rms_px);
}

TEST(Interop, FormatDetection) {
  EXPECT_EQ(DetectInputFormat("a/cameras.txt", "", "f"), Format::kColmapText);
  EXPECT_EQ(DetectInputFormat("a/cameras.bin", "", "f"), Format::kColmapBinary);
  EXPECT_EQ(DetectInputFormat("m.cameramodel", "", "f"), Format::kMrcal);
  EXPECT_EQ(DetectInputFormat("c.yml", "", "f"), Format::kOpenCVYaml);
  EXPECT_EQ(DetectInputFormat("c", "%YAML:1.0\n", "f"), Format::kOpenCVYaml);
  EXPECT_EQ(DetectInputFormat("c", "# x\n{ 'lensmodel': 'A' }", "f"), Format::kMrcal);
  EXPECT_EQ(DetectInputFormat("c", "{\"camera\": {}}", "f"), Format::kJson);
  EXPECT_EQ(DetectInputFormat("c", "# cams\n1 PINHOLE 640 480 1 1 1 1\n", "f"), Format::kColmapText);
  EXPECT_THROW(DetectInputFormat("c", "hello", "f"), InvalidInput);
  EXPECT_EQ(DetectInputFormat("cal.xml", "", "f"), Format::kMetashape);
  EXPECT_EQ(DetectInputFormat("c", "<?xml version=\"1.0\"?>\n<calibration>", "f"), Format::kMetashape);
  EXPECT_EQ(DetectInputFormat("c.xml", "<?xml version=\"1.0\"?>\n<opencv_storage>", "f"), Format::kOpenCVXml);
  EXPECT_EQ(DetectInputFormat("c", "<opencv_storage>", "f"), Format::kOpenCVXml);
  EXPECT_EQ(OutputFormat("c.xml", std::string("opencv-xml"), "f"), Format::kOpenCVXml);
  EXPECT_EQ(DetectInputFormat("calibration.yaml", kCalibmarDome, "f"), Format::kCalibmar);
  EXPECT_EQ(OutputFormat("x.anything", std::string("mrcal"), "f"), Format::kMrcal);
  EXPECT_THROW(OutputFormat("x.anything", std::nullopt, "f"), InvalidInput);
}

}  // namespace
}  // namespace porthole::interop
