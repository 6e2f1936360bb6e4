// Proves the rig files of interop/rig_files.h: a rig of opencv cameras written to each format and
// read back is the same rig (parameters and cam_from_rig to 1e-12 relative), with each format's
// conventions checked against hand-written files of the published schemas (Kalibr's camchain as
// PyYAML writes it, kalibr_common/ConfigReader.py at ethz-asl/kalibr 0b8b9e8e; ROS camera_info as
// camera_calibration_parsers' parse_yml.cpp writes it; numpy's .npy header, numpy/lib/format.py);
// units are converted at the boundary (Kalibr and ROS in metres) and an unstated unit is refused;
// other models are refit with their RMS; refractive cameras, wrong pairs and bad files are
// refused in one line naming the key.
#include "porthole/interop/rig_files.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <string>

#include "porthole/core/error.h"
#include "porthole/interop/interop.h"

namespace porthole::interop {
namespace {

using camera::Camera;
using camera::CameraModelId;

Camera OpenCVCam(double fx, double fy, double cx, double cy, std::vector<double> d) {
  Camera c{CameraModelId::kOpenCV, {1280, 960, 0.00345}, std::vector<double>(12, 0.0)};
  c.params[0] = fx, c.params[1] = fy, c.params[2] = cx, c.params[3] = cy;
  for (std::size_t i = 0; i < d.size(); ++i) c.params[4 + i] = d[i];
  return c;
}

RigFile TestRig(std::vector<double> d0, std::vector<double> d1) {
  RigFile rig;
  RigFileCamera a, b;
  a.name = "left";
  a.calibration = WithoutSigma(OpenCVCam(1402.5, 1401.25, 641.3, 479.8, std::move(d0)), "");
  b.name = "right";
  b.calibration = WithoutSigma(OpenCVCam(1398.75, 1399.5, 633.9, 486.1, std::move(d1)), "");
  b.rotation = Eigen::AngleAxisd(0.0873, Eigen::Vector3d(0.1, -0.98, 0.05).normalized()).toRotationMatrix();
  b.translation_mm = Eigen::Vector3d(-299.1, 2.37, 13.05);
  rig.cameras = {a, b};
  return rig;
}

double Rel(double a, double b) { return std::abs(a - b) / std::max(1.0, std::max(std::abs(a), std::abs(b))); }

void ExpectSameRig(const RigFile& a, const RigFile& b, double tol) {
  ASSERT_EQ(a.cameras.size(), b.cameras.size());
  for (std::size_t k = 0; k < a.cameras.size(); ++k) {
    const auto& pa = a.cameras[k].calibration.camera.params;
    const auto& pb = b.cameras[k].calibration.camera.params;
    ASSERT_EQ(a.cameras[k].calibration.camera.model, b.cameras[k].calibration.camera.model);
    EXPECT_EQ(a.cameras[k].calibration.camera.sensor.width_px, b.cameras[k].calibration.camera.sensor.width_px);
    EXPECT_EQ(a.cameras[k].calibration.camera.sensor.height_px, b.cameras[k].calibration.camera.sensor.height_px);
    for (std::size_t i = 0; i < pa.size(); ++i) EXPECT_LE(Rel(pa[i], pb[i]), tol) << "camera " << k << " param " << i;
    EXPECT_LE((a.cameras[k].rotation - b.cameras[k].rotation).norm(), tol) << "camera " << k;
    EXPECT_LE((a.cameras[k].translation_mm - b.cameras[k].translation_mm).norm(),
              tol * std::max(1.0, a.cameras[k].translation_mm.norm()))
        << "camera " << k;
  }
}

RigFile Back(const RigWriteResult& w, RigFormat format, RigReadOptions o = {}) {
  o.pixel_pitch_mm = 0.00345;
  o.format = format;
  std::vector<std::string> contents, names;
  for (const auto& [name, content] : w.files) {
    contents.push_back(content);
    names.push_back(name.empty() ? "out" : name);
  }
  return ParseRigFiles(contents, names, o, "IN");
}

TEST(RigFiles, OpenCVPairRoundTripsThroughEveryPairFormat) {
  const RigFile rig = TestRig({-0.12, 0.08, 1e-4, -2e-4, 0.01}, {-0.11, 0.07, 2e-4, 1e-4, 0.0, 0.002, 0.001, -0.003});
  for (RigFormat f : {RigFormat::kOpenCVStereoYaml, RigFormat::kOpenCVStereoXml, RigFormat::kViameNpz,
                      RigFormat::kRosCameraInfo, RigFormat::kJson}) {
    SCOPED_TRACE(std::string(RigFormatName(f)));
    const RigWriteResult w = WriteRigFile(rig, f, "OUT");
    EXPECT_TRUE(w.exact());
    ExpectSameRig(rig, Back(w, f), 1e-12);
  }
}

TEST(RigFiles, KalibrRoundTripsRadtanAndEquiCameras) {
  RigFile rig = TestRig({-0.12, 0.08, 1e-4, -2e-4}, {-0.11, 0.07, 2e-4, 1e-4});
  RigFileCamera third;
  third.name = "fish";
  third.calibration = WithoutSigma(
      Camera{CameraModelId::kKannalaBrandt, {1280, 960, 0.00345}, {610.5, 611.25, 640.1, 480.3, 0.02, -0.01, 0.003, -0.0004}}, "");
  third.rotation = Eigen::AngleAxisd(-0.3, Eigen::Vector3d::UnitY()).toRotationMatrix();
  third.translation_mm = Eigen::Vector3d(150.5, -20.25, 4.125);
  rig.cameras.push_back(third);
  const RigWriteResult w = WriteRigFile(rig, RigFormat::kKalibr, "OUT");
  EXPECT_TRUE(w.exact());
  EXPECT_EQ(w.cameras[0].format_model, "pinhole-radtan");
  EXPECT_EQ(w.cameras[2].format_model, "pinhole-equidistant");
  const std::string& text = w.files[0].second;
  // Kalibr's reader wants floats for the intrinsics (PyYAML: a point in every number) and metres.
  EXPECT_NE(text.find("intrinsics: [1402.5, 1401.25, 641.29999999999995, 479.80000000000001]"), std::string::npos) << text;
  const auto row0 = text.find("]", text.find("T_cn_cnm1:"));
  const auto comma = text.rfind(", ", row0);
  EXPECT_NEAR(std::stod(text.substr(comma + 2, row0 - comma - 2)), -0.2991, 1e-15) << text;  // -299.1 mm as metres
  const RigFile back = Back(w, RigFormat::kKalibr);
  ExpectSameRig(rig, back, 1e-12);
  EXPECT_EQ(back.cameras[2].name, "fish");
}

TEST(RigFiles, ReadsKalibrCamchainAsPyYamlWritesIt) {
  // The layout of Kalibr's camchain.yaml (yaml.dump of CameraChainParameters: T_cn_cnm1 as rows of
  // 4, metres; block lists written both ways PyYAML does).
  const std::string flow =
      "cam0:\n  cam_overlaps: [1]\n  camera_model: pinhole\n  distortion_coeffs: [-0.28, 0.07, 0.0002, 1.7e-05]\n"
      "  distortion_model: radtan\n  intrinsics: [458.6, 457.2, 367.2, 248.3]\n  resolution: [752, 480]\n"
      "  rostopic: /cam0/image_raw\ncam1:\n  T_cn_cnm1:\n  - [1.0, 0.0, 0.0, -0.11]\n  - [0.0, 1.0, 0.0, 0.0004]\n"
      "  - [0.0, 0.0, 1.0, 0.0]\n  - [0.0, 0.0, 0.0, 1.0]\n  cam_overlaps: [0]\n  camera_model: pinhole\n"
      "  distortion_coeffs: [-0.28, 0.07, 0.0002, 1.7e-05]\n  distortion_model: radtan\n"
      "  intrinsics: [458.6, 457.2, 367.2, 248.3]\n  resolution: [752, 480]\n  rostopic: /cam1/image_raw\n";
  const std::string block =
      "cam0:\n  camera_model: pinhole\n  distortion_coeffs:\n  - -0.28\n  - 0.07\n  - 0.0002\n  - 1.7e-05\n"
      "  distortion_model: radtan\n  intrinsics:\n  - 458.6\n  - 457.2\n  - 367.2\n  - 248.3\n  resolution:\n  - 752\n"
      "  - 480\n  rostopic: /cam0/image_raw\ncam1:\n  T_cn_cnm1:\n  - - 1.0\n    - 0.0\n    - 0.0\n    - -0.11\n"
      "  - - 0.0\n    - 1.0\n    - 0.0\n    - 0.0004\n  - - 0.0\n    - 0.0\n    - 1.0\n    - 0.0\n"
      "  - - 0.0\n    - 0.0\n    - 0.0\n    - 1.0\n  camera_model: pinhole\n  distortion_coeffs: [-0.28, 0.07, 0.0002, 1.7e-05]\n"
      "  distortion_model: radtan\n  intrinsics: [458.6, 457.2, 367.2, 248.3]\n  resolution: [752, 480]\n"
      "  rostopic: /cam1/image_raw\n";
  for (const std::string& text : {flow, block}) {
    const RigFile rig = ParseRigFiles({text}, {"camchain.yaml"}, {}, "IN");
    ASSERT_EQ(rig.cameras.size(), 2u);
    EXPECT_EQ(rig.cameras[0].name, "cam0");
    const auto& p = rig.cameras[1].calibration.camera.params;
    EXPECT_EQ(p[0], 458.6);
    EXPECT_EQ(p[3], 248.3);
    EXPECT_EQ(p[7], 1.7e-05);  // r2 = OpenCV's p2
    EXPECT_NEAR(rig.cameras[1].translation_mm.x(), -110.0, 1e-12);
    EXPECT_NEAR(rig.cameras[1].translation_mm.y(), 0.4, 1e-12);
  }
}

TEST(RigFiles, RosRectificationIsAPureBaseline) {
  const RigFile rig = TestRig({-0.12, 0.08, 1e-4, -2e-4, 0.01}, {-0.11, 0.07, 2e-4, 1e-4, 0.02});
  const RigWriteResult w = WriteRigFile(rig, RigFormat::kRosCameraInfo, "OUT");
  ASSERT_EQ(w.files.size(), 2u);
  EXPECT_EQ(w.files[0].first, "left.yaml");
  EXPECT_NE(w.files[0].second.find("distortion_model: plumb_bob"), std::string::npos);
  EXPECT_NE(w.files[1].second.find("camera_name: right"), std::string::npos);
  // P2's Tx = -f'·B: B the baseline in metres (|t| = 0.29938… m, nearly all along x).
  const std::string& p = w.files[1].second;
  const auto at = p.find("projection_matrix:");
  ASSERT_NE(at, std::string::npos);
  const auto data = p.find("data: [", at) + 7;
  std::vector<double> v;
  for (std::size_t s = data; v.size() < 12;) {
    std::size_t e = p.find_first_of(",]", s);
    v.push_back(std::stod(p.substr(s, e - s)));
    s = e + 1;
  }
  EXPECT_NEAR(-v[3] / v[0], rig.cameras[1].translation_mm.norm() / 1000, 1e-12);
  EXPECT_NEAR(v[7], 0.0, 1e-12);
  // File names come from the camera names but are never paths.
  RigFile evil = rig;
  evil.cameras[0].name = "../../etc/passwd";
  evil.cameras[1].name = "a\nb: c";
  const RigWriteResult we = WriteRigFile(evil, RigFormat::kRosCameraInfo, "OUT");
  EXPECT_EQ(we.files[0].first, "camera_.._.._etc_passwd.yaml");
  EXPECT_EQ(we.files[1].first, "a_b__c.yaml");
  EXPECT_NE(we.files[1].second.find("camera_name: \"a_b: c\"\n"), std::string::npos) << we.files[1].second;
  const RigFile back = Back(we, RigFormat::kRosCameraInfo);
  EXPECT_EQ(back.cameras[1].name, "a_b: c");
}

TEST(RigFiles, NpyHeaderIsNumpysVersion1) {
  NpyArray a;
  a.shape = {3, 1};
  a.data = {1.5, -2.25, 1e-300};
  const std::string b = NpyBytes(a);
  EXPECT_EQ(b.substr(0, 8), std::string("\x93NUMPY\x01\x00", 8));
  const std::size_t hlen = static_cast<unsigned char>(b[8]) | (static_cast<unsigned char>(b[9]) << 8);
  EXPECT_EQ((10 + hlen) % 64, 0u);
  EXPECT_EQ(b.substr(10, 59), "{'descr': '<f8', 'fortran_order': False, 'shape': (3, 1), }");
  EXPECT_EQ(b.size(), 10 + hlen + 24);
  const NpyArray back = ParseNpy(b, "x");
  EXPECT_EQ(back.shape, a.shape);
  EXPECT_EQ(back.data, a.data);
  NpyArray t;
  t.is_text = true;
  t.text = "mm";
  EXPECT_EQ(ParseNpy(NpyBytes(t), "x").text, "mm");
  // A Fortran-ordered 2 × 2 comes back row-major.
  std::string f = b;
  const std::string fo = "{'descr': '<f8', 'fortran_order': True, 'shape': (2, 2), }";
  std::string header = fo;
  while ((10 + header.size() + 1) % 64 != 0) header += ' ';
  header += '\n';
  std::string data(32, '\0');
  const double col[4] = {1, 3, 2, 4};  // [[1, 2], [3, 4]] column by column
  std::memcpy(data.data(), col, 32);
  f = std::string("\x93NUMPY\x01\x00", 8) + std::string{static_cast<char>(header.size()), 0} + header + data;
  EXPECT_EQ(ParseNpy(f, "x").data, (std::vector<double>{1, 2, 3, 4}));
}

TEST(RigFiles, UnstatedUnitIsRefusedAndGivenUnitConverts) {
  const RigFile rig = TestRig({-0.12, 0.08, 1e-4, -2e-4}, {-0.11, 0.07, 2e-4, 1e-4});
  const RigWriteResult w = WriteRigFile(rig, RigFormat::kOpenCVStereoYaml, "OUT");
  std::string text = w.files[0].second;
  const auto u = text.find("T_unit");
  ASSERT_NE(u, std::string::npos);
  text.resize(u);  // a file as OpenCV's own samples write it: no unit
  try {
    ParseRigFiles({text}, {"stereo.yml"}, {}, "IN");
    FAIL() << "an unstated unit was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("choices: mm, cm, m"), std::string::npos) << e.what();
    EXPECT_NE(e.field().find("T"), std::string::npos);
  }
  RigReadOptions o;
  o.length_unit = LengthUnit::kM;
  const RigFile m = ParseRigFiles({text}, {"stereo.yml"}, o, "IN");
  EXPECT_NEAR(m.cameras[1].translation_mm.x(), rig.cameras[1].translation_mm.x() * 1000, 1e-9);
  // A stated unit that contradicts the given one is refused.
  EXPECT_THROW(ParseRigFiles({w.files[0].second}, {"stereo.yml"}, o, "IN"), InvalidInput);
}

TEST(RigFiles, OtherModelsAreRefitWithTheirRms) {
  RigFile rig = TestRig({}, {});
  // A Kannala–Brandt camera (moderate field) into the pinhole formats: refit, RMS stated.
  rig.cameras[1].calibration = WithoutSigma(
      Camera{CameraModelId::kKannalaBrandt, {1280, 960, 0.00345}, {1398.75, 1399.5, 633.9, 486.1, -0.05, 0.01, 0, 0}}, "");
  const RigWriteResult w = WriteRigFile(rig, RigFormat::kViameNpz, "OUT");
  EXPECT_TRUE(w.cameras[0].exact);
  EXPECT_FALSE(w.cameras[1].exact);
  EXPECT_GT(w.cameras[1].fit.rms_px, 0.0);
  EXPECT_LT(w.cameras[1].fit.rms_px, 0.05);
  // An opencv camera with k3 into Kalibr's radtan (k1 k2 p1 p2): refit.
  const RigFile k3 = TestRig({-0.12, 0.08, 1e-4, -2e-4, 0.01}, {-0.11, 0.07, 2e-4, 1e-4});
  const RigWriteResult wk = WriteRigFile(k3, RigFormat::kKalibr, "OUT");
  EXPECT_FALSE(wk.cameras[0].exact);
  EXPECT_TRUE(wk.cameras[1].exact);
  EXPECT_GT(wk.cameras[0].fit.rms_px, 0.0);
}

TEST(RigFiles, RefusesPortsPairsAndBadFiles) {
  RigFile rig = TestRig({}, {});
  rig.cameras[1].port = "NI320";
  try {
    WriteRigFile(rig, RigFormat::kViameNpz, "OUT");
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("behind a port (NI320)"), std::string::npos) << e.what();
  }
  RigFile three = TestRig({}, {});
  three.cameras.push_back(three.cameras[1]);
  EXPECT_THROW(WriteRigFile(three, RigFormat::kOpenCVStereoYaml, "OUT"), InvalidInput);
  // A missing key is named.
  const RigWriteResult w = WriteRigFile(TestRig({}, {}), RigFormat::kOpenCVStereoYaml, "OUT");
  std::string text = w.files[0].second;
  const auto k2 = text.find("K2:");
  text.replace(k2, 3, "KX:");
  RigReadOptions yaml;
  yaml.format = RigFormat::kOpenCVStereoYaml;
  try {
    ParseRigFiles({text}, {"s.yml"}, yaml, "IN");
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "IN 's.yml': K2");
  }
  // Not a rig at all.
  EXPECT_THROW(ParseRigFiles({"image_width: 5\ncamera_matrix: [1]\n"}, {"c.yml"}, {}, "IN"), InvalidInput);
  // npz: not a zip, and a member missing.
  EXPECT_THROW(ParseRigFiles({"PK\x03\x04garbage"}, {"x.npz"}, {}, "IN"), InvalidInput);
  const std::string zip = ZipStored({{"R.npy", NpyBytes({{3, 3}, {1, 0, 0, 0, 1, 0, 0, 0, 1}, "", false})}}, "OUT");
  try {
    ParseRigFiles({zip}, {"x.npz"}, {}, "IN");
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "IN 'x.npz': cameraMatrixL");
  }
  EXPECT_THROW(RigOutputFormat("rig.yaml", std::nullopt, "OUT"), InvalidInput);
  EXPECT_EQ(RigOutputFormat("rig.yaml", "kalibr", "OUT"), RigFormat::kKalibr);
}

TEST(RigFiles, HostileFilesGetOneLine) {
  const auto refused = [](const std::string& text, const std::string& name, RigFormat f) {
    RigReadOptions o;
    o.format = f;
    o.length_unit = LengthUnit::kMm;
    EXPECT_THROW(ParseRigFiles({text}, {name}, o, "IN"), InvalidInput) << text.substr(0, 80);
  };
  std::string deep = "cam0:\n";
  for (int i = 1; i < 40; ++i) deep += std::string(2 * i, ' ') + "a:\n";
  refused(deep, "c.yaml", RigFormat::kKalibr);                                    // nested deeper than 16
  refused("cam0:\n  intrinsics: [1, [2, [3]\n", "c.yaml", RigFormat::kKalibr);   // unbalanced [ ]
  refused("cam0:\n\tintrinsics: [1]\n", "c.yaml", RigFormat::kKalibr);           // a tab
  refused("cam0:\n  a: 1\n  a: 2\n", "c.yaml", RigFormat::kKalibr);              // a key twice
  refused(std::string(100, '['), "c.yaml", RigFormat::kKalibr);
  refused("K1: {a: 1}\nK2: 1\nT: 1\n", "s.yml", RigFormat::kOpenCVStereoYaml);   // flow mappings
  refused("", "s.yml", RigFormat::kOpenCVStereoYaml);
  refused("<opencv_storage><K1>1 2</K1></opencv_storage>", "s.xml", RigFormat::kOpenCVStereoXml);
  // npy: a bad dtype, a shape whose product overflows, truncated data.
  const std::string header = "{'descr': '<Ux', 'fortran_order': False, 'shape': (), }";
  const std::string bad_text = std::string("\x93NUMPY\x01\x00", 8) + std::string{static_cast<char>(header.size()), 0} + header;
  EXPECT_THROW(ParseNpy(bad_text, "x"), InvalidInput);
  const std::string big = "{'descr': '<f8', 'fortran_order': False, 'shape': (4096, 4096, 4096, 4096), }";
  EXPECT_THROW(ParseNpy(std::string("\x93NUMPY\x01\x00", 8) + std::string{static_cast<char>(big.size()), 0} + big, "x"),
               InvalidInput);
  NpyArray a;
  a.shape = {3, 3};
  a.data = std::vector<double>(9, 1.0);
  const std::string ok = NpyBytes(a);
  EXPECT_THROW(ParseNpy(ok.substr(0, ok.size() - 1), "x"), InvalidInput);
  EXPECT_THROW(ParseNpy("\x93NUMPY", "x"), InvalidInput);
}

}  // namespace
}  // namespace porthole::interop
