// JsonPathLine and WithJsonLines: the line of a key in JSON text, for errors that nlohmann::json
// (no positions for values) cannot place; JSON count limits refused before anything is parsed.
#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "porthole/core/hartley.h"
#include "porthole/core/input.h"

#include <chrono>
#include <string>

namespace porthole {
namespace {

constexpr const char* kDoc = R"({
  "camera": {
    "c_mm": 25.8,
    "K1": "big"
  },
  "images": [
    {"image": "a.jpg", "ids": [0, 1]},
    {
      "image": "b \"quoted\" {[",
      "points_px": [[1, 2],
                    [3, 4]]
    }
  ],
  "sensor": {"width_px": 4288}
})";

TEST(JsonPathLine, FindsKeysElementsAndAncestors) {
  EXPECT_EQ(JsonPathLine(kDoc, ""), 1u);
  EXPECT_EQ(JsonPathLine(kDoc, "camera"), 2u);
  EXPECT_EQ(JsonPathLine(kDoc, "camera.K1"), 4u);
  EXPECT_EQ(JsonPathLine(kDoc, "images[0]"), 7u);
  EXPECT_EQ(JsonPathLine(kDoc, "images[0].ids"), 7u);
  EXPECT_EQ(JsonPathLine(kDoc, "images[1]"), 8u);
  EXPECT_EQ(JsonPathLine(kDoc, "images[1].points_px"), 10u);  // after a string holding quotes and brackets
  EXPECT_EQ(JsonPathLine(kDoc, "images[1].points_px[1]"), 11u);
  EXPECT_EQ(JsonPathLine(kDoc, "sensor.width_px"), 14u);
  // Absent: the deepest ancestor that is present (the object lacking the key).
  EXPECT_EQ(JsonPathLine(kDoc, "camera.K2"), 2u);
  EXPECT_EQ(JsonPathLine(kDoc, "images[5].ids"), 6u);
  EXPECT_EQ(JsonPathLine(kDoc, "nothing"), 1u);
}

TEST(WithJsonLines, NamesFileAndLineOfTheKey) {
  const auto message = [](auto f) -> std::string {
    try {
      WithJsonLines(kDoc, "--calib", "c.json", f);
    } catch (const InvalidInput& e) {
      return e.what();
    }
    return "no error";
  };
  EXPECT_EQ(message([] { throw InvalidInput("--calib.camera.K1", "must be a number"); }),
            "--calib.camera.K1: c.json:4: must be a number");
  EXPECT_EQ(message([] { throw InvalidInput("--calib", "sensor.width_px: must be whole"); }),
            "--calib: c.json:14: sensor.width_px: must be whole");
  EXPECT_EQ(message([] { throw InvalidInput("--calib.images[1]", "points_px: [u, v] pairs"); }),
            "--calib.images[1]: c.json:10: points_px: [u, v] pairs");
  // Another field passes through unchanged.
  EXPECT_EQ(message([] { throw InvalidInput("--other", "x"); }), "--other: x");
  EXPECT_EQ(message([] { throw InvalidInput("--calibrate", "x"); }), "--calibrate: x");
}

}  // namespace
}  // namespace porthole

// Hartley's normalisation (core/hartley.h): the normalised set has its centroid at the origin and a
// mean distance of √D from it, for any offset and scale; a set of one repeated point is left unscaled.
namespace porthole {
namespace {
// Issue 24: a 250 MB calibration JSON took 5.5 GB and 18 s once parsed. Counts are checked by
// one pass over the text before nlohmann builds anything, and the error names the limit.
std::string Repeat(const std::string& item, std::size_t n, char open = '[', char close = ']') {
  std::string s(1, open);
  s.reserve(n * (item.size() + 1) + 2);
  for (std::size_t i = 0; i < n; ++i) s += (i ? "," : "") + item;
  return s + close;
}

TEST(JsonLimits, ElementsPerArrayAndMembersPerObject) {
  EXPECT_NO_THROW(ParseJsonText(Repeat("0", kMaxJsonElements), "f", "a.json"));
  const auto t0 = std::chrono::steady_clock::now();
  try {
    ParseJsonText("{\"x\":\n" + Repeat("0", kMaxJsonElements + 1) + "}", "--detections", "big.json");
    FAIL() << "no error";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "--detections: big.json:2");
    EXPECT_NE(std::string(e.what()).find("more than the limit of 1000000 elements in one JSON array"), std::string::npos)
        << e.what();
  }
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 2.0);
  std::string members = "{";
  for (std::size_t i = 0; i <= kMaxJsonElements; ++i) members += (i ? ",\"" : "\"") + std::to_string(i) + "\":0";
  members += "}";
  try {
    ParseJsonText(members, "f", "o.json");
    FAIL() << "no error";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("members in one JSON object"), std::string::npos) << e.what();
  }
  // Commas and brackets inside strings are not counted.
  EXPECT_NO_THROW(ParseJsonText("[\"" + std::string(2 * kMaxJsonElements, ',') + "[\"]", "f", "s.json"));
}

TEST(JsonLimits, ValuesPerDocument) {
  // 9 arrays of 900 000 pairs: each array under the element limit, 16 million values in all.
  std::string doc = "[";
  const std::string pairs = Repeat("[1,2]", 900'000);
  for (int i = 0; i < 9; ++i) doc += (i ? "," : "") + pairs;
  doc += "]";
  try {
    ParseJsonText(doc, "f", "v.json");
    FAIL() << "no error";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("more than the limit of 8000000 values in one JSON document"), std::string::npos)
        << e.what();
  }
}

TEST(Hartley, CentroidAtTheOriginMeanDistanceSqrtD) {
  std::vector<Eigen::Vector3d> p = {{1000, 2000, 5}, {1040, 1990, -20}, {990, 2070, 11}, {1013, 2011, 40}};
  const Eigen::Matrix4d t = HartleyNormaliser<3>(p);
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  double d = 0;
  for (const auto& q : p) {
    const Eigen::Vector4d n = t * q.homogeneous();
    EXPECT_DOUBLE_EQ(n.w(), 1.0);
    c += n.head<3>() / 4.0;
    d += n.head<3>().norm() / 4.0;
  }
  EXPECT_LT(c.norm(), 1e-12);
  EXPECT_NEAR(d, std::sqrt(3.0), 1e-12);
  const std::vector<Eigen::Vector2d> same(3, Eigen::Vector2d(5, -7));
  const Eigen::Matrix3d u = HartleyNormaliser<2>(same);
  EXPECT_TRUE((u.topLeftCorner<2, 2>() == Eigen::Matrix2d::Identity()));
  EXPECT_TRUE(((u * same[0].homogeneous()).head<2>() == Eigen::Vector2d::Zero()));
}
}  // namespace
}  // namespace porthole
