// Proves interop/convert.h, the format rules as one call: a camera goes where the output's extension
// (or `to`) says and reads back parameter for parameter, an existing directory means its cameras.txt,
// several inputs go only into COLMAP, a housing only into calibmar or COLMAP cameras.txt; each refusal
// names the option's field (never a flag) and writes nothing; an input is never replaced, an
// existing file only with `force`.
#include "porthole/interop/convert.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <unistd.h>

#include "porthole/core/error.h"

namespace porthole::interop {
namespace {

namespace fs = std::filesystem;
using camera::Camera;
using camera::CameraModelId;

// A fresh directory for one test, removed afterwards.
struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& name)
      : path(fs::temp_directory_path() / ("porthole_convert_test_" + name + "_" + std::to_string(::getpid()))) {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
  std::string operator/(const std::string& name) const { return (path / name).string(); }
  int Files() const {
    int n = 0;
    for (const auto& e : fs::recursive_directory_iterator(path)) n += e.is_regular_file();
    return n;
  }
};

Camera OpenCVCam() {
  Camera c{CameraModelId::kOpenCV, {4288, 2848, 0.0055}, std::vector<double>(12, 0.0)};
  const std::vector<double> p = {4690.25, 4692.5, 2150.3, 1420.7, -0.1, 0.05, 1e-4, -2e-4};
  for (std::size_t i = 0; i < p.size(); ++i) c.params[i] = p[i];
  return c;
}

std::string WriteJson(const TempDir& d, const std::string& name) {
  const std::string path = d / name;
  std::ofstream(path) << WriteCamera(OpenCVCam(), Format::kJson, "test").content;
  return path;
}

TEST(Convert, AFileByItsExtensionAndAFolderAsItsCamerasTxt) {
  TempDir d("ext");
  ConvertOptions o;
  o.inputs = {WriteJson(d, "cal.json")};
  o.out = d / "cam.yml";
  const ConvertResult r = Convert(o);
  EXPECT_FALSE(r.rig);
  EXPECT_EQ(r.format, Format::kOpenCVYaml);
  EXPECT_TRUE(r.exact);
  EXPECT_EQ(r.out_files, std::vector<std::string>{o.out});
  const ReadResult back = ReadCalibrationFile(o.out, 0.0055, "back");
  EXPECT_EQ(back.camera().params, OpenCVCam().params);
  fs::create_directories(d / "sparse");
  o.out = d / "sparse";
  const ConvertResult c = Convert(o);
  EXPECT_EQ(c.out, d / "sparse/cameras.txt");
  EXPECT_EQ(c.format, Format::kColmapText);
  EXPECT_EQ(ConvertJson(c)["out_format"], "colmap");
}

TEST(Convert, RefusalsNameTheFieldAndWriteNothing) {
  TempDir d("refuse");
  const std::string cal = WriteJson(d, "cal.json");
  fs::create_directories(d / "sparse");
  struct Case {
    std::function<void(ConvertOptions*)> set;
    std::string field;
  };
  const std::vector<Case> cases = {
      {[&](ConvertOptions* o) { o->inputs = {cal, cal}; }, "out"},  // only COLMAP holds several
      {[&](ConvertOptions* o) { o->port = "nimar-ni320"; }, "port"},  // OpenCV YAML holds no housing
      {[&](ConvertOptions* o) { o->water_index = 1.33; }, "water_index"},  // without a port
      {[&](ConvertOptions* o) { o->port_out = d / "p.toml"; }, "port_out"},  // the input has no housing
      {[&](ConvertOptions* o) { o->length_unit = "m"; }, "length_unit"},  // not a rig
      {[&](ConvertOptions* o) { o->image_size_px = std::pair{640, 480}; }, "image_size_px"},
      {[&](ConvertOptions* o) { o->pixel_pitch_mm = -1; }, "pixel_pitch_mm"},
      {[&](ConvertOptions* o) { o->to = "nonsense"; }, "to"},
      {[&](ConvertOptions* o) { o->out = d / "sparse", o->to = "mrcal"; }, "out"},  // only COLMAP writes into a folder
      {[&](ConvertOptions* o) { o->out = cal, o->force = true; }, "out"},  // never an input
      {[&](ConvertOptions* o) { o->inputs = {d / "missing.json"}; }, "inputs"},
      {[&](ConvertOptions* o) { o->to = "kalibr"; }, "inputs"},  // a rig format: the input is no rig
  };
  for (const Case& c : cases) {
    ConvertOptions o;
    o.inputs = {cal};
    o.out = d / "x.yml";
    c.set(&o);
    try {
      Convert(o);
      ADD_FAILURE() << "accepted: " << c.field;
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.field().substr(0, c.field.size()), c.field) << e.what();
      EXPECT_EQ(std::string(e.what()).find("--"), std::string::npos) << e.what();
    }
    EXPECT_EQ(d.Files(), 1) << c.field;  // cal.json alone
  }
}

TEST(Convert, AnExistingFileOnlyWithForce) {
  TempDir d("force");
  ConvertOptions o;
  o.inputs = {WriteJson(d, "cal.json")};
  o.out = d / "cam.yml";
  Convert(o);
  try {
    Convert(o);
    ADD_FAILURE() << "replaced without force";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "out");
  }
  o.force = true;
  EXPECT_NO_THROW(Convert(o));
}

}  // namespace
}  // namespace porthole::interop
