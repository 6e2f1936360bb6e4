// Proves render::RenderJob (the call behind `porthole render` and porthole.render) holds what it
// writes: each image's pixels, encoded, are the PNG's bytes and its ground truth is the JSON file's;
// a described rig's set writes every camera's frame under one name with its `rig` block; bad options
// are refused naming the field, before any file exists.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <unistd.h>

#include "porthole/catalogue/presets.h"
#include "porthole/render/job.h"
#include "porthole/render/test_scenes.h"

namespace porthole::render {
namespace {

namespace fs = std::filesystem;

std::string ReadAll(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

// A fresh folder under the system's temporary directory.
fs::path TempDir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("porthole_job_test_" + std::to_string(getpid()) + "_" + name);
  fs::remove_all(d);
  return d;
}

RenderJobOptions Small() {
  RenderJobOptions o;
  o.housed = testing::PaperScene("nimar-ni320", 240).housed;
  o.target = "chessboard:5x4:40";
  o.f_number = std::numeric_limits<double>::infinity();
  o.render.samples_per_pixel = 1;
  o.keep_truth = o.keep_pixels = true;
  return o;
}

TEST(RenderJob, OneImageHoldsWhatItWrote) {
  const fs::path dir = TempDir("one");
  fs::create_directories(dir);
  RenderJobOptions o = Small();
  o.out = dir / "board.png";
  const RenderJobResult r = RenderJob(o);
  ASSERT_EQ(r.images.size(), 1u);
  const JobImage& im = r.images[0];
  EXPECT_EQ(im.image, o.out);
  EXPECT_EQ(im.truth, dir / "board.json");
  EXPECT_EQ(EncodePng(im.pixels, 8), ReadAll(im.image));
  EXPECT_EQ(im.ground_truth, nlohmann::ordered_json::parse(ReadAll(im.truth)));
  EXPECT_EQ(im.ground_truth["points"].size(), 20u);
  EXPECT_EQ(r.summary["points"], 20);
  EXPECT_EQ(im.medium, "water");
  fs::remove_all(dir);
}

TEST(RenderJob, ADescribedRigSetNamesEveryFrameOnce) {
  const fs::path dir = TempDir("rig");
  RenderJobOptions o = Small();
  o.baseline_mm = 200;
  o.set_count = 2;
  o.focus_distance_mm = 1500;
  o.out = dir;
  const RenderJobResult r = RenderJob(o);
  EXPECT_EQ(r.cameras, (std::vector<std::string>{"cam0", "cam1"}));
  EXPECT_EQ(r.frames, 2);
  ASSERT_EQ(r.images.size(), 8u);  // 2 frames x water, air x 2 cameras
  for (const JobImage& im : r.images) {
    EXPECT_EQ(im.image, dir / im.medium / im.camera / (im.frame + ".png"));
    EXPECT_EQ(EncodePng(im.pixels, 8), ReadAll(im.image));
    EXPECT_EQ(im.ground_truth, nlohmann::ordered_json::parse(ReadAll(im.truth)));
    EXPECT_EQ(im.ground_truth["rig"]["camera"], im.camera);
  }
  EXPECT_EQ(r.focus_distance_mm, (std::vector<double>{1500, 1500}));
  fs::remove_all(dir);
}

TEST(RenderJob, BadOptionsNameTheFieldAndWriteNothing) {
  const fs::path dir = TempDir("bad");
  fs::create_directories(dir);
  const auto field_of = [&](RenderJobOptions o) -> std::string {
    o.out = o.out.empty() ? dir / "x.png" : o.out;
    try {
      RenderJob(o);
    } catch (const InvalidInput& e) {
      return e.field();
    }
    return "(none)";
  };
  RenderJobOptions o = Small();
  o.medium = "oil";
  EXPECT_EQ(field_of(o), "medium");
  o = Small();
  o.color = "sepia";
  EXPECT_EQ(field_of(o), "color");
  o = Small();
  o.bit_depth = 12;
  EXPECT_EQ(field_of(o), "bit_depth");
  o = Small();
  o.noise_e = std::array<double, 2>{0, 5};
  EXPECT_EQ(field_of(o), "noise_e");
  o = Small();
  o.set_count = -1;
  EXPECT_EQ(field_of(o), "count");
  o = Small();
  o.rig = "rig.json";
  o.baseline_mm = 300;
  EXPECT_EQ(field_of(o), "rig");
  o = Small();
  o.out = dir / "x.jpg";
  EXPECT_EQ(field_of(o), "out");
  EXPECT_TRUE(fs::is_empty(dir));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace porthole::render
