// Proves the format conversions of interop/interop.h:
//  - every exact pair (porthole model → format model → porthole) reprojects to ≤ 1e-9 px over the
//    whole image: each pixel of a grid through the frame's corners is unprojected by the original
//    camera and projected by the one read back;
//  - the COLMAP mapping against COLMAP's own equations written out here (the 0.5 px shift, the
//    parameter order of each model), independent of porthole's models;
//  - a Brown camera (the paper's Table 6, in air and under water) written to COLMAP and mrcal is a
//    dense refit whose RMS is reported and below 0.01 px;
//  - the Python-literal reader accepts what mrcal writes and refuses anything that is not a literal;
//  - malformed files give InvalidInput naming the file and the field.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "porthole/core/error.h"
#include "porthole/interop/interop.h"
#include "porthole/interop/pyliteral.h"

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
    const ReadResult r = ReadCamera(w.content, c.format, kD300.pixel_pitch_mm, "in");
    EXPECT_EQ(r.camera.sensor.width_px, kD300.width_px);
    EXPECT_EQ(r.camera.sensor.height_px, kD300.height_px);
    const double px = MaxReprojectionPx(c.cam, r.camera);
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
      const ReadResult r = ReadCamera(w.content, f, kD300.pixel_pitch_mm, "in");
      EXPECT_LE(MaxReprojectionPx(brown, r.camera), w.fit.max_px * 1.01 + 1e-9);
      std::printf("Table 6 c=%.3f -> %s: refit RMS %.2e px, max %.2e px\n", p[0],
                  std::string(FormatName(f)).c_str(), w.fit.rms_px, w.fit.max_px);
    }
  }
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
  auto message = [](const std::string& content, Format f) {
    try {
      ReadCamera(content, f, 1.0, "IN 'x'");
    } catch (const InvalidInput& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  auto has = [](const std::string& msg, const std::string& part) {
    return msg.find("IN 'x'") != std::string::npos && msg.find(part) != std::string::npos;
  };
  EXPECT_TRUE(has(message("1 OPENCV 640 480 500 500 320 240", Format::kColmapText), "PARAMS"));
  EXPECT_TRUE(has(message("1 THIN_PRISM_FISHEYE 640 480 1 2 3", Format::kColmapText), "MODEL"));
  EXPECT_TRUE(has(message("1 PINHOLE 640 480 500 500 x 240", Format::kColmapText), "'x'"));
  EXPECT_TRUE(has(message("1 PINHOLE 640 480 500 500 320 240\n2 PINHOLE 640 480 500 500 320 240\n",
                          Format::kColmapText), "2 cameras"));
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
  EXPECT_THROW(WriteCamera(kb, Format::kOpenCVYaml, "OUT"), InvalidInput);
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
  EXPECT_EQ(OutputFormat("x.anything", std::string("mrcal"), "f"), Format::kMrcal);
  EXPECT_THROW(OutputFormat("x.anything", std::nullopt, "f"), InvalidInput);
}

}  // namespace
}  // namespace porthole::interop
