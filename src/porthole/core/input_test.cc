// JsonPathLine and WithJsonLines: the line of a key in JSON text, for errors that nlohmann::json
// (no positions for values) cannot place.
#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "porthole/core/hartley.h"
#include "porthole/core/input.h"

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
