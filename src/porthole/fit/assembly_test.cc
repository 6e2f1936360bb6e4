// Proves the assembly puts the paper's Table 3 spheres and Table 4 flanges into the housing frame
// with the entrance pupil 5.4 mm ahead of the outer centre and ≈1 mm off axis, from any survey
// and scan frames, and that its input parsers accept the fit JSON and reject malformed input.
#include "porthole/fit/assembly.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include "porthole/core/error.h"

namespace porthole::fit {
namespace {

struct PaperPoint {
  Eigen::Vector3d p;
  double radius_mm;
};

// tests/data/menna2016_table4.csv: point → housing-frame position (and radius for spheres).
std::map<std::string, PaperPoint> PaperTable4() {
  std::ifstream f(std::string(PORTHOLE_TEST_DATA_DIR) + "/menna2016_table4.csv");
  EXPECT_TRUE(f.good());
  std::map<std::string, PaperPoint> out;
  std::string line;
  bool header = true;
  while (std::getline(f, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (header) {
      header = false;
      continue;
    }
    std::stringstream ss(line);
    std::string name, x, y, z, r;
    std::getline(ss, name, ',');
    std::getline(ss, x, ',');
    std::getline(ss, y, ',');
    std::getline(ss, z, ',');
    std::getline(ss, r, ',');
    out[name] = {{std::stod(x), std::stod(y), std::stod(z)}, r.empty() ? NAN : std::stod(r)};
  }
  return out;
}

// The paper's numbers as they are: flanges and spheres all in the housing frame.
AssemblyInput PaperInput() {
  auto t = PaperTable4();
  AssemblyInput in;
  in.camera_flange = {t["camera_flange_center"].p, Eigen::Vector3d::UnitZ()};
  in.housing_flange = {t["housing_flange_center"].p, Eigen::Vector3d::UnitZ()};
  in.outer = {t["dome_outer_center"].p, t["dome_outer_center"].radius_mm};
  in.inner = {t["dome_inner_center"].p, t["dome_inner_center"].radius_mm};
  in.pupil_to_flange_mm = t["lens_entrance_pupil"].p.z();
  return in;
}

void ExpectTable4(const HousingAssembly& a, double tol) {
  auto t = PaperTable4();
  EXPECT_LT((a.camera_flange_center_mm - t["camera_flange_center"].p).norm(), tol);
  EXPECT_LT((a.housing_flange_center_mm - t["housing_flange_center"].p).norm(), tol);
  EXPECT_LT((a.outer.center_mm - t["dome_outer_center"].p).norm(), tol);
  EXPECT_LT((a.inner.center_mm - t["dome_inner_center"].p).norm(), tol);
  EXPECT_LT((a.entrance_pupil_mm - t["lens_entrance_pupil"].p).norm(), tol);
  EXPECT_NEAR(a.outer.radius_mm, 83.4, 1e-12);
  EXPECT_NEAR(a.thickness_mm, 7.7, 1e-9);
}

TEST(Assembly, PaperTablesGivePupil5p4mmAheadAnd1mmOffAxis) {
  const HousingAssembly a = AssembleHousing(PaperInput());
  ExpectTable4(a, 1e-12);
  // Section 3.4: "5.4 mm ahead of the center of curvature", "misalignment in the XY plane ...
  // about 1 mm": 26.9 − 21.5 along Z, |(0.4, 1.0)| across.
  EXPECT_NEAR(a.pupil_ahead_of_outer_mm, 5.4, 1e-9);
  EXPECT_NEAR(a.pupil_off_axis_outer_mm, std::hypot(0.4, 1.0), 1e-9);
  EXPECT_GT(a.pupil_off_axis_outer_mm, 0.9);
  EXPECT_LT(a.pupil_off_axis_outer_mm, 1.2);
  EXPECT_NEAR(a.pupil_ahead_of_inner_mm, 6.6, 1e-9);
  EXPECT_NEAR(a.center_distance_mm, 1.3, 1e-9);  // Table 3: centres < 1.5 mm apart
  EXPECT_NEAR(a.housing_flange_tilt_rad, 0, 1e-12);
  const ports::PortSpec port = AsBuiltPort(a, "as-built");
  ASSERT_TRUE(port.IsDome());
  EXPECT_EQ(port.frame, ports::PortFrame::kHousing);
  EXPECT_NEAR(*std::get<ports::DomePort>(port.shape).rim_z_mm, 34.3, 1e-12);
  EXPECT_LT((port.default_ep_in_housing_mm - Eigen::Vector3d(0, 0, 26.9)).norm(), 1e-12);
}

RigidTransform Random(int seed, double shift_mm) {
  std::srand(seed);
  const Eigen::Quaterniond q = Eigen::Quaterniond(Eigen::Vector4d::Random()).normalized();
  return {q.toRotationMatrix(), shift_mm * Eigen::Vector3d::Random()};
}

// The flanges measured in a survey frame and the dome scanned in a scan frame, both unrelated to
// the housing frame: the assembly must undo both and land on Table 4.
TEST(Assembly, RecoversTable4FromArbitrarySurveyAndScanFrames) {
  const AssemblyInput paper = PaperInput();
  for (int seed = 1; seed <= 5; ++seed) {
    const RigidTransform survey_from_housing = Random(seed, 500);
    const RigidTransform scan_from_housing = Random(100 + seed, 300);
    const Eigen::Matrix3d& rs = survey_from_housing.rotation;
    const Eigen::Matrix3d& rd = scan_from_housing.rotation;
    AssemblyInput in;
    // Flange normals with either sign: the assembly orients them itself.
    in.camera_flange = {survey_from_housing.Apply(paper.camera_flange.center_mm),
                        (seed % 2 ? 1.0 : -1.0) * rs.col(2)};
    in.housing_flange = {survey_from_housing.Apply(paper.housing_flange.center_mm), -rs.col(2)};
    in.survey_x_hint = rs.col(0);
    in.outer = {scan_from_housing.Apply(paper.outer.center_mm), paper.outer.radius_mm};
    in.inner = {scan_from_housing.Apply(paper.inner.center_mm), paper.inner.radius_mm};
    // The rear face lies on the housing flange; its normal points toward the apex (+Z).
    in.dome_rear = PlaneWithCenter{scan_from_housing.Apply(paper.housing_flange.center_mm),
                                   rd.col(2)};
    in.scan_x_hint = rd.col(0);
    in.pupil_to_flange_mm = paper.pupil_to_flange_mm;
    ExpectTable4(AssembleHousing(in), 1e-9);

    // A plane without a centre: any point of it, and the dome centred on its rear face.
    in.dome_rear->center_mm =
        scan_from_housing.Apply(Eigen::Vector3d(paper.housing_flange.center_mm + Eigen::Vector3d(17, -9, 0)));
    in.dome_centered = true;
    ExpectTable4(AssembleHousing(in), 1e-9);
  }
}

TEST(Assembly, TiltedHousingFlangeTiltsTheDome) {
  AssemblyInput in = PaperInput();
  const double tilt = 2.0 * M_PI / 180;
  in.housing_flange.normal = Eigen::Vector3d(std::sin(tilt), 0, std::cos(tilt));
  // Scan frame = the rear face's own frame: rear centre at the origin, apex toward +Z.
  in.dome_rear = PlaneWithCenter{Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ()};
  in.outer.center_mm = Eigen::Vector3d(0, 0, -12.8);
  in.inner.center_mm = Eigen::Vector3d(0, -0.5, -14.0);
  const HousingAssembly a = AssembleHousing(in);
  EXPECT_NEAR(a.housing_flange_tilt_rad, tilt, 1e-12);
  // The outer centre lies 12.8 mm behind the flange centre along the tilted normal.
  const Eigen::Vector3d expect = a.housing_flange_center_mm - 12.8 * in.housing_flange.normal;
  EXPECT_LT((a.outer.center_mm - expect).norm(), 1e-9);
  EXPECT_NEAR(a.pupil_ahead_of_outer_mm, 26.9 - expect.z(), 1e-9);
}

TEST(Assembly, RejectsImpossibleGeometry) {
  auto throws_field = [](AssemblyInput in, const std::string& field) {
    try {
      AssembleHousing(in);
      ADD_FAILURE() << "no error for " << field;
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.field(), field) << e.what();
    }
  };
  AssemblyInput in = PaperInput();
  in.housing_flange.center_mm.z() = 0;  // in the camera flange's plane
  throws_field(in, "housing_flange");
  in = PaperInput();
  in.camera_flange.normal.setZero();
  throws_field(in, "camera_flange");
  in = PaperInput();
  in.inner.radius_mm = 83.0;  // pokes out of the outer sphere
  throws_field(in, "inner");
  in = PaperInput();
  in.outer.radius_mm = NAN;
  throws_field(in, "outer");
  in = PaperInput();
  in.pupil_to_flange_mm = 120;  // beyond the inner sphere
  throws_field(in, "pupil_offset");
  in = PaperInput();
  in.dome_centered = true;
  throws_field(in, "dome_centered");
  in = PaperInput();
  in.survey_x_hint = Eigen::Vector3d::UnitZ();
  throws_field(in, "x_hint");
}

std::string WriteTemp(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + "/" + name;
  std::ofstream(path) << text;
  return path;
}

TEST(AssemblyParse, NumbersAndFitJson) {
  const PlaneWithCenter p = ParsePlaneSpec("-0.4, -1.0,34.3,0,0,+1", "--housing-flange");
  EXPECT_EQ(p.center_mm, Eigen::Vector3d(-0.4, -1.0, 34.3));
  EXPECT_EQ(p.normal, Eigen::Vector3d(0, 0, 1));
  const Sphere s = ParseSphereSpec("-0.4,-1,21.5,83.4", "--outer");
  EXPECT_EQ(s.radius_mm, 83.4);

  const auto circle = WriteTemp("c.json", R"({"shape": "circle", "center_mm": [1, 2, 3],
      "radius_mm": 30, "normal": [0, 0.6, 0.8]})");
  EXPECT_EQ(ParsePlaneSpec(circle, "f").center_mm, Eigen::Vector3d(1, 2, 3));
  const auto plane = WriteTemp("p.json", R"({"shape": "plane", "normal": [0, 0, 1],
      "offset_mm": 5, "centroid_mm": [4, 5, 6]})");
  EXPECT_EQ(ParsePlaneSpec(plane, "f").center_mm, Eigen::Vector3d(4, 5, 6));
  const auto sphere = WriteTemp("s.json", R"({"shape": "sphere", "center_mm": [0, 0, 21.5],
      "radius_mm": 83.4, "usable": true, "status": "ok"})");
  EXPECT_EQ(ParseSphereSpec(sphere, "f").center_mm.z(), 21.5);
}

TEST(AssemblyParse, RejectsMalformedInput) {
  auto field_of = [](auto parse, const std::string& spec) -> std::string {
    try {
      parse(spec, "--flag");
    } catch (const InvalidInput& e) {
      return e.field() + " | " + e.what();
    }
    return "no error";
  };
  auto plane = [](const std::string& s, const std::string& f) { return ParsePlaneSpec(s, f); };
  auto sphere = [](const std::string& s, const std::string& f) { return ParseSphereSpec(s, f); };
  EXPECT_NE(field_of(plane, "1,2,3").find("got 3 numbers"), std::string::npos);
  EXPECT_NE(field_of(sphere, "1,2,3,4,5").find("got 5 numbers"), std::string::npos);
  EXPECT_NE(field_of(sphere, "/no/such/file.json").find("readable file"), std::string::npos);
  EXPECT_NE(field_of(sphere, WriteTemp("t.json", R"({"center_mm": [0, 0)"))
                .find("not valid JSON at byte"),
            std::string::npos);
  EXPECT_NE(field_of(sphere, WriteTemp("k.json", R"({"center_mm": [0, 0, 1]})"))
                .find("'radius_mm' missing"),
            std::string::npos);
  EXPECT_NE(field_of(plane, WriteTemp("w.json", R"({"shape": "sphere", "center_mm": [0,0,1]})"))
                .find("a 'sphere' fit where a circle or plane fit is expected"),
            std::string::npos);
  EXPECT_NE(field_of(sphere, WriteTemp("u.json", R"({"shape": "sphere", "center_mm": [0, 0, 1],
      "radius_mm": 1e9, "usable": false, "status": "radius not determined"})"))
                .find("not usable (radius not determined)"),
            std::string::npos);
  EXPECT_EQ(field_of(plane, "1,2,3").rfind("--flag | ", 0), 0u);
}

}  // namespace
}  // namespace porthole::fit
