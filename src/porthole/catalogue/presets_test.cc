// Proves that the built-in presets carry the paper's geometry, that port TOML files are parsed with
// errors naming file, line and key, and that writing and re-reading a port is lossless.
#include "porthole/catalogue/presets.h"

#include <gtest/gtest.h>

#include <fstream>
#include <limits>
#include <set>
#include <sstream>

#include "porthole/core/error.h"

namespace porthole::catalogue {
namespace {

std::string ErrorOf(const std::string& text) {
  try {
    ParsePortToml(text, "my-dome.toml");
  } catch (const InvalidInput& e) {
    return e.what();
  }
  return "";
}

TEST(Presets, BuiltinPortsCarryThePapersGeometry) {
  const auto as_built = LoadPort("nimar-ni320");
  const auto& d = std::get<ports::DomePort>(as_built.shape);
  // Menna et al. 2016, Table 3.
  EXPECT_EQ(d.outer.center_mm, ports::Vec3(-0.4, -1.0, 21.5));
  EXPECT_EQ(d.outer.radius_mm, 83.4);
  EXPECT_EQ(d.inner.center_mm, ports::Vec3(-0.4, -1.5, 20.3));
  EXPECT_EQ(d.inner.radius_mm, 75.7);
  EXPECT_EQ(d.material, "n-bk7");
  // Table 4: the 24 mm lens's entrance pupil.
  EXPECT_EQ(as_built.default_ep_in_housing_mm, ports::Vec3(0, 0, 26.9));
  const auto nominal = LoadPort("nimar-ni320-nominal");
  EXPECT_EQ(nominal.frame, ports::PortFrame::kCam);
  EXPECT_TRUE(LoadPort("flat-acrylic-10mm").shape.index() == 1);
  for (const Preset& p : BuiltinPresets()) EXPECT_FALSE(PresetDescription(p).empty()) << p.name;
}

TEST(Presets, UnknownPresetListsTheBuiltins) {
  try {
    LoadPort("nimar-ni999");
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "port");
    EXPECT_NE(std::string(e.what()).find("nimar-ni320-nominal"), std::string::npos);
  }
  EXPECT_THROW(LoadPort("/nonexistent/dome.toml"), InvalidInput);
}

TEST(PortToml, ErrorsNameFileLineAndKey) {
  const std::string good =
      "type = \"dome\"\n[outer]\ncenter_mm = [0, 0, 21.5]\nradius_mm = 83.4\n"
      "[inner]\ncenter_mm = [0, 0, 21.5]\nradius_mm = 75.7\n";
  EXPECT_EQ(ErrorOf(good), "");
  EXPECT_EQ(ErrorOf("type = \"dome\"\n[outer]\ncenter_mm = [0, 0]\nradius_mm = 83.4\n"),
            "my-dome.toml:3: outer.center_mm: must be an array of three numbers [x, y, z]");
  EXPECT_EQ(ErrorOf("colour = \"blue\"\n" + good), "my-dome.toml:1: colour: unknown key");
  EXPECT_EQ(ErrorOf(good + "colour = \"blue\"\n"), "my-dome.toml:8: inner.colour: unknown key");
  EXPECT_NE(ErrorOf("type = \"dome\"\n[outer\n").find("my-dome.toml:2"), std::string::npos);
  // An unknown type is refused naming every shape of the list.
  const std::string cone = ErrorOf("type = \"cone\"\n");
  EXPECT_NE(cone.find("type: must be \"dome\", \""), std::string::npos) << cone;
  for (std::string_view shape : ports::ShapeNames()) {
    EXPECT_NE(cone.find("\"" + std::string(shape) + "\""), std::string::npos) << cone;
  }
  // Geometry rules come from ports::Validate, with the file named.
  std::string bad = good;
  bad.replace(bad.find("75.7"), 4, "90.0");
  EXPECT_NE(ErrorOf(bad).find("my-dome.toml:7: inner.radius_mm: must be smaller"), std::string::npos)
      << ErrorOf(bad);
  // Issue 12: an enum with a bad value names its own line, not the table's (line 1).
  EXPECT_EQ(ErrorOf("name = \"x\"\nframe = \"camm\"\n" + good),
            "my-dome.toml:2: frame: must be \"housing\" (flange origin) or \"cam\" (entrance-pupil origin)");
  EXPECT_NE(ErrorOf("\ntype = \"cone\"\n").find("my-dome.toml:2: type:"), std::string::npos) << ErrorOf("\ntype = \"cone\"\n");
  EXPECT_NE(ErrorOf("type = \"flat\"\nthickness_mm = -3\ninner_point_mm = [0,0,20]\n")
                .find("my-dome.toml:2: thickness_mm: must be > 0"),
            std::string::npos);
  EXPECT_NE(ErrorOf("type = \"flat\"\nthickness_mm = nan\ninner_point_mm = [0,0,20]\n")
                .find("thickness_mm: must be a finite number"),
            std::string::npos);
}

// Issue 23: a typo of a required key is named at its own line with the key it resembles, not
// reported as the required key missing at the table's line.
TEST(PortToml, ATypoIsNamedAtItsLineWithTheKeyItResembles) {
  EXPECT_EQ(ErrorOf("type = \"dome\"\n[outer]\ncenter_mm = [0, 0, 21.5]\nradus_mm = 83.4\n"
                    "[inner]\ncenter_mm = [0, 0, 21.5]\nradius_mm = 75.7\n"),
            "my-dome.toml:4: outer.radus_mm: unknown key (did you mean outer.radius_mm?)");
  EXPECT_EQ(ErrorOf("tpye = \"dome\"\n"), "my-dome.toml:1: tpye: unknown key (did you mean type?)");
  // An optional key mistyped beside the required ones: the nearest key read.
  EXPECT_EQ(ErrorOf("type = \"flat\"\nthickness_mm = 3\ninner_point_mm = [0,0,20]\nnormall = [0,0,1]\n"),
            "my-dome.toml:4: normall: unknown key (did you mean normal?)");
  try {
    ParseCameraToml("name = \"x\"\nmount = \"nikon-f\"\nwidht_px = 4288\nheight_px = 2848\npixel_pitch_mm = 0.0055\n",
                    "cam.toml");
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_EQ(std::string(e.what()), "cam.toml:3: widht_px: unknown key (did you mean width_px?)");
  }
}

// Every built-in port preset written and read back unchanged; every shape of the closed list has a
// preset (a new shape without one fails here).
TEST(PortToml, WriteThenReadIsLossless) {
  std::set<std::string> shapes;
  for (const Preset& preset : BuiltinPresets()) {
    if (preset.kind != "port") continue;
    const std::string name(preset.name);
    const auto p = LoadPort(name);
    const auto q = ParsePortToml(PortToToml(p), "roundtrip.toml");
    EXPECT_EQ(PortToToml(q), PortToToml(p)) << name;
    EXPECT_EQ(q.frame, p.frame) << name;
    EXPECT_EQ(q.default_ep_in_housing_mm, p.default_ep_in_housing_mm) << name;
    shapes.insert(std::string(p.KindName()));
  }
  for (std::string_view shape : ports::ShapeNames()) {
    EXPECT_TRUE(shapes.count(std::string(shape))) << "no port preset of shape " << shape;
  }
}

// The shell's σ in the [sigma] table (ports::ShellSigma; calibrate --port --free-shell): read,
// written back unchanged, refused with file, line and key when negative; the table's other keys
// (calibmar's placement and index σ, interop::HousingSigmaToml) are accepted and not kept.
TEST(PortToml, ShellSigmaRoundTrips) {
  const std::string dome =
      "type = \"dome\"\n[outer]\ncenter_mm = [0, 0, 21.5]\nradius_mm = 83.4\n"
      "[inner]\ncenter_mm = [0, 0, 21.5]\nradius_mm = 75.7\n"
      "[sigma]\nouter_radius_mm = 0.02\ninner_radius_mm = 0.03\nthickness_mm = 0.05\n"
      "inner_offset_mm = [0.01, 0.01, 0]\ncenter_mm = [0.2, 0.1, 0.3]\nn_water = 0.001\n";
  const auto p = ParsePortToml(dome, "dome.toml");
  EXPECT_EQ(p.sigma.thickness_mm, 0.05);
  EXPECT_EQ(p.sigma.outer_radius_mm, 0.02);
  EXPECT_EQ(p.sigma.inner_radius_mm, 0.03);
  EXPECT_EQ(p.sigma.inner_offset_mm, ports::Vec3(0.01, 0.01, 0));
  const auto q = ParsePortToml(PortToToml(p), "roundtrip.toml");
  EXPECT_EQ(PortToToml(q), PortToToml(p));
  EXPECT_EQ(q.sigma.inner_offset_mm, p.sigma.inner_offset_mm);
  EXPECT_EQ(q.sigma.thickness_mm, 0.05);
  const auto flat = ParsePortToml(
      "type = \"flat\"\nthickness_mm = 10\ninner_point_mm = [0,0,40]\n[sigma]\nthickness_mm = 0.1\n", "f.toml");
  EXPECT_EQ(flat.sigma.thickness_mm, 0.1);
  EXPECT_EQ(ParsePortToml(PortToToml(flat), "f2.toml").sigma.thickness_mm, 0.1);
  std::string bad = dome;
  bad.replace(bad.find("0.02"), 4, "-0.1");
  EXPECT_NE(ErrorOf(bad).find("my-dome.toml:9: sigma.outer_radius_mm: a sigma must be >= 0"), std::string::npos)
      << ErrorOf(bad);
  EXPECT_TRUE(LoadPort("nimar-ni320").sigma.Empty());
  EXPECT_EQ(PortToToml(LoadPort("nimar-ni320")).find("[sigma]"), std::string::npos);
}

TEST(Presets, CameraAndLensPresetsCarryThePapersValues) {
  const auto d300 = LoadCamera("nikon-d300");
  EXPECT_EQ(d300.sensor.width_px, 4288);
  EXPECT_EQ(d300.sensor.height_px, 2848);
  EXPECT_EQ(d300.sensor.pixel_pitch_mm, 0.0055);
  const auto l24 = LoadLens("nikkor-24mm-f2.8d");
  const auto& f = lens::MountByName(l24.mount);
  EXPECT_NEAR(lens::SubjectToPupilMm(l24, f, 300), 226.6, 1e-9);  // Table 2
  EXPECT_EQ(l24.PupilToFlangeMm(std::numeric_limits<double>::infinity()), 24.6);
  const auto l35 = LoadLens("nikkor-35mm-f2d");
  EXPECT_NEAR(lens::SubjectToPupilMm(l35, f, 250), 176.6, 1e-9);
  EXPECT_EQ(l35.min_focus_mm, 250);
  EXPECT_THROW(LoadLens("nikkor-999mm"), InvalidInput);
  EXPECT_THROW(ParseLensToml("focal_length_mm = 24\n", "x.toml"), InvalidInput);
  const std::string body = "mount = \"nikon-f\"\nheight_px = 2848\npixel_pitch_mm = 0.0055\n";
  for (const char* w : {"4288.7", "1e20", "0", "-5"}) {
    EXPECT_THROW(ParseCameraToml(body + "width_px = " + w + "\n", "cam.toml"), InvalidInput) << w;
  }
  EXPECT_EQ(ParseCameraToml(body + "width_px = 4288\n", "cam.toml").sensor.width_px, 4288);
}

// Issue 12: presets users have. Every camera body reproduces its maker's published sensor and image
// size (tests/data/camera_bodies.csv): pixels x pitch = sensor size within the published rounding.
TEST(Presets, CameraBodiesMatchTheirPublishedSensors) {
  std::ifstream in(std::string(PORTHOLE_TEST_DATA_DIR) + "/camera_bodies.csv");
  ASSERT_TRUE(in.good());
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line.rfind("preset,", 0) == 0) continue;
    std::stringstream ss(line);
    std::string name, w, h, wp, hp, mount;
    std::getline(ss, name, ',');
    std::getline(ss, w, ',');
    std::getline(ss, h, ',');
    std::getline(ss, wp, ',');
    std::getline(ss, hp, ',');
    std::getline(ss, mount, ',');
    const auto b = LoadCamera(name);
    EXPECT_EQ(b.sensor.width_px, std::stoi(wp)) << name;
    EXPECT_EQ(b.sensor.height_px, std::stoi(hp)) << name;
    EXPECT_EQ(b.mount, mount) << name;
    EXPECT_NEAR(b.SensorWidthMm(), std::stod(w), 1e-3) << name;   // the pitch is width / pixels
    // Square pixels: the height follows from the pitch; makers round their sizes (a7 IV, a6400: 0.07 mm).
    EXPECT_NEAR(b.SensorHeightMm(), std::stod(h), 0.1) << name;
    EXPECT_FALSE(b.source.empty()) << name;
    ++n;
  }
  EXPECT_EQ(n, 6);
}

// Every preset names its source; a port whose geometry is not published says so in its description
// (ASSUMED) instead of presenting assumed values as data.
TEST(Presets, EveryPresetNamesItsSourceAndAssumedGeometryIsLabelled) {
  int assumed = 0;
  for (const Preset& p : BuiltinPresets()) {
    const std::string toml(p.toml);
    EXPECT_NE(toml.find("source = \""), std::string::npos) << p.name;
    if (p.kind != "port") continue;
    const auto spec = LoadPort(std::string(p.name));
    EXPECT_FALSE(spec.source.empty()) << p.name;
    if (spec.source.rfind("assumed", 0) == 0) {
      ++assumed;
      EXPECT_EQ(spec.description.rfind("ASSUMED", 0), 0u) << p.name;
    }
  }
  EXPECT_GE(assumed, 4);
}

}  // namespace
}  // namespace porthole::catalogue
