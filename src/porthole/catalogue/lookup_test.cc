// Proves that camera and lens names match exactly (case, spaces, hyphens and underscores aside) or
// are refused with three "did you mean" candidates, never loosely substituted (issue 23: 38 real
// names in tests/data/camera_lens_names.csv), and that lens data lensfun lacks is flagged as
// assumed or taken as given (--min-focus-mm, --pupil-mm).
#include "porthole/catalogue/lookup.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "porthole/core/error.h"
#include "porthole/catalogue/presets.h"

namespace porthole::catalogue {
namespace {

struct NameRow {
  std::string kind, name, expect, from;
};

std::vector<NameRow> ReadNames() {
  std::ifstream in(std::string(PORTHOLE_TEST_DATA_DIR) + "/camera_lens_names.csv");
  std::vector<NameRow> rows;
  std::string line;
  bool header = true;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (header) {
      header = false;
      continue;
    }
    std::stringstream ss(line);
    NameRow r;
    std::getline(ss, r.kind, ',');
    std::getline(ss, r.name, ',');
    std::getline(ss, r.expect, ',');
    std::getline(ss, r.from);
    rows.push_back(r);
  }
  return rows;
}

// The resolved name, or the refusal's text prefixed by "!".
std::string Resolve(const NameRow& r) {
  try {
    if (r.kind == "camera") return FindCamera(r.name, 0.004).name;
    // A zoom needs a focal length: its shortest, from the name ("16-35mm" → 16).
    std::optional<double> focal;
    const auto mm = r.name.find("mm");
    if (mm != std::string::npos) {
      std::size_t b = mm;
      while (b > 0 && (std::isdigit(static_cast<unsigned char>(r.name[b - 1])) || r.name[b - 1] == '-' ||
                       r.name[b - 1] == '.')) {
        --b;
      }
      if (b < mm) focal = std::stod(r.name.substr(b, mm - b));
    }
    return FindLens(r.name, focal).name;
  } catch (const InvalidInput& e) {
    return std::string("!") + e.what();
  }
}

TEST(Lookup, RealNamesResolveExactlyOrAreRefusedWithCandidates) {
  const std::vector<NameRow> rows = ReadNames();
  ASSERT_GE(rows.size(), 30u);
  int resolved = 0, refused = 0;
  for (const NameRow& r : rows) {
    const std::string got = Resolve(r);
    if (std::getenv("PORTHOLE_SHOW_NAMES")) std::cout << r.name << " -> " << got << "\n";
    if (r.expect == "refuse") {
      ASSERT_FALSE(got.empty());
      EXPECT_EQ(got[0], '!') << r.name << " resolved to " << got << " (" << r.from << ")";
      EXPECT_NE(got.find("did you mean"), std::string::npos) << r.name << ": " << got;
      // Three candidates, each quoted and naming its source.
      int quoted = 0;
      for (std::size_t p = got.find("' ("); p != std::string::npos; p = got.find("' (", p + 1)) ++quoted;
      EXPECT_GE(quoted, 3) << got;
      EXPECT_EQ(got.find('\n'), std::string::npos) << "one line: " << got;
      ++refused;
    } else {
      EXPECT_EQ(got, r.expect) << r.name << " (" << r.from << ")";
      ++resolved;
    }
  }
  EXPECT_GT(resolved, 10);
  EXPECT_GT(refused, 10);
}

std::string Refusal(const std::string& kind, const std::string& name) {
  return Resolve({kind, name, "refuse", ""});
}

TEST(Lookup, CandidatesAreTheNearNames) {
  // The near miss of a preset names the preset first; the Sony is offered Sonys.
  EXPECT_NE(Refusal("lens", "nikkor-24mm").find("did you mean 'nikkor-24mm-f2.8d' (preset)"), std::string::npos)
      << Refusal("lens", "nikkor-24mm");
  const std::string sony = Refusal("camera", "Sony A7R V");
  EXPECT_NE(sony.find("'Sony Alpha 7R IV' (lensfun)"), std::string::npos) << sony;
  EXPECT_EQ(sony.find("Fujifilm"), std::string::npos) << sony;
  const std::string gopro = Refusal("camera", "gopro-hero12");
  EXPECT_NE(gopro.find("'gopro-hero12-black' (preset)"), std::string::npos) << gopro;
  EXPECT_EQ(gopro.find("PowerShot"), std::string::npos) << gopro;
}

TEST(Lookup, SaysWhichSourceAnswered) {
  EXPECT_EQ(FindCamera("nikon-d300").lookup, "preset");
  EXPECT_EQ(FindCamera("Sony ILCE-7M3", 0.006).lookup, "lensfun");
  EXPECT_EQ(FindLens("Nikon NIKKOR Z 14-30mm f/4 S", 14.0).lookup, "lensfun");
  CameraLensQuery g;
  g.camera = "GoPro-HERO4-Black";
  const CameraAndLens gopro = FindCameraAndLens(g);
  EXPECT_EQ(gopro.camera.lookup, "preset");
  EXPECT_EQ(gopro.lens.lookup, "preset");
  // GoPro publishes no pupil: the preset flags it estimated, and the line says so.
  EXPECT_NE(DescribeCameraAndLens(gopro.camera, gopro.lens)
                .find("lens    gopro-hero4-black-wide (the camera's own lens, porthole preset; entrance pupil assumed)"),
            std::string::npos)
      << DescribeCameraAndLens(gopro.camera, gopro.lens);
}

// lensfun records no minimum focus and no entrance pupil: assumed and flagged, or given.
TEST(Lookup, LensDataLensfunLacksIsAssumedOrGiven) {
  const lens::LensSpec assumed = FindLens("Sony FE 16-35mm f/4 ZA OSS", 16.0);
  EXPECT_TRUE(assumed.min_focus_assumed);
  EXPECT_TRUE(assumed.pupil_estimated);
  EXPECT_DOUBLE_EQ(assumed.min_focus_mm, 160.0);  // 10 f
  // Sony publishes 0.28 m; the pupil measured 60 mm ahead of the sensor (a made-up measurement).
  const lens::LensSpec given = FindLens("Sony FE 16-35mm f/4 ZA OSS", 16.0, {280.0, 60.0});
  EXPECT_FALSE(given.min_focus_assumed);
  EXPECT_FALSE(given.pupil_estimated);
  EXPECT_DOUBLE_EQ(given.min_focus_mm, 280.0);
  constexpr double kInf = std::numeric_limits<double>::infinity();
  EXPECT_DOUBLE_EQ(given.PupilToFlangeMm(kInf), 60.0 - 18.0);  // Sony E flange 18 mm
  // The pupil moves forward by the thin-lens extension f²/(FD − 2f) at the given minimum focus.
  EXPECT_NEAR(given.PupilToFlangeMm(280.0), 42.0 + 16.0 * 16.0 / (280.0 - 32.0), 1e-9);
  EXPECT_NE(given.description.find("minimum focus 280 mm (given)"), std::string::npos) << given.description;
  // A measured preset lens given another pupil keeps its measured movement with focus.
  const lens::LensSpec nikkor = LoadLens("nikkor-24mm-f2.8d");  // 24.6 mm at inf, 26.9 at 300 (Table 2)
  const lens::LensSpec moved = FindLens("nikkor-24mm-f2.8d", std::nullopt, {std::nullopt, 46.5 + 30.0});
  EXPECT_DOUBLE_EQ(moved.PupilToFlangeMm(kInf), 30.0);
  EXPECT_DOUBLE_EQ(moved.PupilToFlangeMm(300.0), 30.0 + 26.9 - 24.6);
  EXPECT_FALSE(nikkor.min_focus_assumed);
  // Nonsense is refused, naming the field.
  auto field_of = [](const LensData& d) {
    try {
      FindLens("Sony FE 16-35mm f/4 ZA OSS", 16.0, d);
    } catch (const InvalidInput& e) {
      return e.field();
    }
    return std::string();
  };
  EXPECT_EQ(field_of({20.0, std::nullopt}), "min_focus_mm");  // not beyond 2 f
  EXPECT_EQ(field_of({std::nullopt, -5.0}), "pupil_mm");
  EXPECT_EQ(field_of({std::nan(""), std::nullopt}), "min_focus_mm");
  // A fixed lens takes the given data too.
  CameraLensQuery q;
  q.camera = "olympus-tg6";
  q.lens_data.min_focus_mm = 100;
  EXPECT_DOUBLE_EQ(FindCameraAndLens(q).lens.min_focus_mm, 100.0);
}

// lensfun names a camera's built-in lens by a private lower-case "mount" ("goProHero4black"):
// such a camera is a fixed-lens camera with lensfun's lens for that mount, not an unknown mount.
TEST(Lookup, LensfunActionCameraBringsItsOwnLens) {
  EXPECT_EQ(MountFromLensfun("goProHero4black"), "fixed");
  EXPECT_EQ(MountFromLensfun("Nikon F AF"), "nikon-f");
  EXPECT_FALSE(MountFromLensfun("Leica M").has_value());
  CameraLensQuery q;
  q.camera = "GoPro HERO4 Silver";  // lensfun: mount goProHero4, crop factor 7.66 (no preset)
  q.pixel_pitch_mm = 0.00112;
  const CameraAndLens cl = FindCameraAndLens(q);
  EXPECT_EQ(cl.camera.mount, "fixed");
  EXPECT_EQ(cl.camera.lookup, "lensfun");
  EXPECT_EQ(cl.lens.lookup, "lensfun");
  EXPECT_EQ(cl.lens.mount, "fixed");
  EXPECT_EQ(cl.lens.name, "GoPro HERO4");  // lensfun's lens of that mount
  EXPECT_EQ(cl.lens.projection, camera::Projection::kEquisolid);  // its recorded type
  // The sensor: 43.27 mm / 7.66 across the diagonal (one pixel of rounding), 4:3 from the lens
  // entry's aspect ratio.
  EXPECT_NEAR(cl.camera.SensorDiagonalMm(), 43.2666 / 7.66, 0.002);
  EXPECT_NEAR(cl.camera.SensorWidthMm() / cl.camera.SensorHeightMm(), 4.0 / 3.0, 1e-3);
  // A lensfun name that a preset also has is the preset (presets come first).
  q.camera = "GoPro HERO5 Black";
  q.pixel_pitch_mm.reset();
  EXPECT_EQ(FindCameraAndLens(q).camera.lookup, "preset");
  q.camera = "GoPro HERO4 Silver";
  q.pixel_pitch_mm = 0.00112;
  // No aperture recorded: a fixed f/2.8, said to be assumed.
  EXPECT_EQ(cl.lens.f_number_min, 2.8);
  EXPECT_EQ(cl.lens.f_number_max, 2.8);
  EXPECT_NE(cl.lens.description.find("aperture assumed f/2.8"), std::string::npos) << cl.lens.description;
  EXPECT_EQ(lens::DefaultFNumber(cl.lens), 2.8);
  // The pupil 68.1 mm / crop factor ahead of the sensor (flange 0: distances from the sensor).
  EXPECT_NEAR(cl.lens.PupilToFlangeMm(std::numeric_limits<double>::infinity()), 68.1 / 7.66, 1e-5);
  // It takes no other lens.
  q.lens = "nikkor-24mm-f2.8d";
  EXPECT_THROW(FindCameraAndLens(q), InvalidInput);
}

TEST(Lookup, LensTomlTakesPupilMm) {
  const lens::LensSpec l = ParseLensToml(
      "mount = \"sony-e\"\nfocal_length_mm = 20\nf_number_min = 1.8\nf_number_max = 16\nmin_focus_mm = 190\n"
      "pupil_mm = 55\nmin_focus_assumed = false\n",
      "my-lens.toml");
  EXPECT_DOUBLE_EQ(l.PupilToFlangeMm(std::numeric_limits<double>::infinity()), 55.0 - 18.0);
  EXPECT_THROW(ParseLensToml("mount = \"sony-e\"\nfocal_length_mm = 20\nf_number_min = 1.8\nf_number_max = 16\n"
                             "min_focus_mm = 190\npupil_mm = 55\npupil = [ { focus_mm = inf, d_ep2f_mm = 30 } ]\n",
                             "both.toml"),
               InvalidInput);
}

}  // namespace
}  // namespace porthole::catalogue
