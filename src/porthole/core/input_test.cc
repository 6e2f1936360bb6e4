// JsonPathLine and WithJsonLines: the line of a key in JSON text, for errors that nlohmann::json
// (no positions for values) cannot place.
#include <gtest/gtest.h>

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
