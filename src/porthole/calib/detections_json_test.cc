// Detection files read as what they claim (issue 24): ids are whole non-negative numbers that fit,
// no point twice in an image, no point outside the image, and counts within the limits; each error
// names the file, the line, the image and the point.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <unistd.h>
#include <string>

#include <fmt/format.h>

#include "porthole/calib/detections_json.h"
#include "porthole/core/error.h"
#include "porthole/core/input.h"

namespace porthole::calib {
namespace {
namespace fs = std::filesystem;

// In a directory of this process's own: ctest runs the tests of this file at once, in processes of
// their own, and a file they shared was read half-written (a test failed at random).
std::string WriteFile(const std::string& name, const std::string& text) {
  const fs::path dir = fs::temp_directory_path() / ("porthole_dets_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path p = dir / name;
  std::ofstream(p) << text;
  return p.string();
}

// A set of one 640 x 480 image whose ids and points are the given JSON texts, one key a line.
std::string OneImage(const std::string& ids, const std::string& points) {
  return "{\"target\": \"chessboard:9x6:25\",\n\"images\": [{\n\"image\": \"left01.jpg\",\n\"width_px\": 640,\n"
         "\"height_px\": 480,\n\"ids\": " + ids + ",\n\"points_px\": " + points + "}]}\n";
}

// The error of loading `text` as a set file, "" when it loads.
std::string LoadError(const std::string& text, const std::string& name = "porthole_dets.json") {
  const std::string path = WriteFile(name, text);
  TargetSpec target;
  try {
    LoadDetections(path, "--detections", &target);
  } catch (const InvalidInput& e) {
    return e.what();
  }
  return "";
}

TEST(DetectionsJson, AValidImageLoads) {
  EXPECT_EQ(LoadError(OneImage("[0, 1, 53]", "[[1, 2], [639.5, -0.5], [320, 240]]")), "");
}

TEST(DetectionsJson, IdsAreWholeNonNegativeNumbersThatFit) {
  // Before: get<int>() read 1.9 as 1, 4294967296 as 0, and 1e20 was undefined behaviour.
  for (const char* id : {"1.9", "4294967296", "1e20", "-1", "2147483648", "\"3\"", "null"}) {
    const std::string e = LoadError(OneImage(fmt::format("[0, {}]", id), "[[1, 2], [3, 4]]"));
    EXPECT_NE(e.find("ids[1]: "), std::string::npos) << id << ": " << e;
    EXPECT_NE(e.find("is not a point id (a whole number from 0 to 2147483647)"), std::string::npos) << id << ": " << e;
    EXPECT_NE(e.find("image 'left01.jpg'"), std::string::npos) << e;
    EXPECT_NE(e.find("porthole_dets.json:6:"), std::string::npos) << e;  // the line of "ids"
  }
}

TEST(DetectionsJson, APointListedTwiceInAnImageIsRefused) {
  // Before: every point listed 3 times made σ √3 too small; conflicting duplicates gave "ok" at 35 px.
  const std::string e = LoadError(OneImage("[0, 1, 0]", "[[1, 2], [3, 4], [100, 200]]"));
  EXPECT_NE(e.find("ids[2]: point 0 is listed twice in image 'left01.jpg' (also ids[0])"), std::string::npos) << e;
  EXPECT_NE(e.find("porthole_dets.json:6:"), std::string::npos) << e;
}

TEST(DetectionsJson, PointsOutsideTheImageAreRefused) {
  EXPECT_EQ(LoadError(OneImage("[0, 1]", "[[-0.5, -0.5], [639.5, 479.5]]")), "");  // the corners of the frame
  for (const char* p : {"[640, 3]", "[-0.6, 3]", "[3, 479.6]", "[3, -1000]"}) {
    const std::string e = LoadError(OneImage("[0, 1]", fmt::format("[[1, 2], {}]", p)));
    EXPECT_NE(e.find("points_px[1]: point 1 at"), std::string::npos) << p << ": " << e;
    EXPECT_NE(e.find("lies outside image 'left01.jpg' of 640 x 480 px"), std::string::npos) << p << ": " << e;
  }
}

TEST(DetectionsJson, CountLimitsNameTheLimit) {
  // Points per image.
  std::string ids = "[", pts = "[";
  for (std::size_t i = 0; i <= kMaxPointsPerImage; ++i) {
    ids += (i ? "," : "") + std::to_string(i);
    pts += i ? ",[1,1]" : "[1,1]";
  }
  std::string e = LoadError(OneImage(ids + "]", pts + "]"));
  EXPECT_NE(e.find("100001 points in image 'left01.jpg', more than the limit of 100000 points per image"),
            std::string::npos) << e;
  // Images per set: 10 001 images without points.
  std::string set = "{\"images\": [";
  for (std::size_t i = 0; i <= kMaxImagesPerSet; ++i) {
    set += fmt::format("{}{{\"image\": \"{}.jpg\", \"width_px\": 10, \"height_px\": 10, \"ids\": [], \"points_px\": []}}",
                       i ? "," : "", i);
  }
  e = LoadError(set + "]}");
  EXPECT_NE(e.find("more than the limit of 10000 images per set"), std::string::npos) << e;
  // Points per set: 11 images of 100 000 points (each within the per-image limit).
  std::string big = "{\"images\": [";
  ids = "[";
  pts = "[";
  for (std::size_t i = 0; i < kMaxPointsPerImage; ++i) {
    ids += (i ? "," : "") + std::to_string(i);
    pts += i ? ",[1,1]" : "[1,1]";
  }
  for (int k = 0; k < 11; ++k) {
    big += fmt::format("{}{{\"image\": \"{}.jpg\", \"width_px\": 10, \"height_px\": 10, \"ids\": {}], \"points_px\": {}]}}",
                       k ? "," : "", k, ids, pts);
  }
  e = LoadError(big + "]}");
  EXPECT_NE(e.find("image '10.jpg' brings the set to 1100000 points, more than the limit of 1000000 points per set"),
            std::string::npos) << e;
}

}  // namespace
}  // namespace porthole::calib
