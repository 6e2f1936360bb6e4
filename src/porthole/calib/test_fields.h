// Target fields shared by the tests of a free target (control_datum_test: the central
// calibration; refractive_target_test: behind a port; rig_test: in a rig). Header only, tests only.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "porthole/calib/target.h"

namespace porthole::calib::fixtures {

// A 350 × 250 mm board, an 8 × 6 grid of targets 50 mm apart (Z = 0, ids 1–48), and 12 targets
// raised 30–110 mm toward the camera (Z < 0, ids 49–60).
inline TargetSpec RaisedBoard() {
  const auto target = [](int id, const Eigen::Vector3d& xyz_mm) {
    coded::PlacedTarget t;
    t.id = id;
    t.xyz_mm = xyz_mm;
    return t;
  };
  TargetSpec t = ParseTarget("coded:14:2.5");
  int id = 1;
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 8; ++c) t.field.push_back(target(id++, Eigen::Vector3d(50.0 * c, 50.0 * r, 0)));
  }
  for (int k = 0; k < 12; ++k) {
    const double height_mm = 30 + 80 * ((k * 5) % 12) / 11.0;
    t.field.push_back(target(id++, Eigen::Vector3d(40 + 90 * (k % 4), 40 + 85 * (k / 4), -height_mm)));
  }
  return t;
}

// RaisedBoard's raised targets: ids 49–60.
inline constexpr int kFirstRaisedTarget = 49;

// RaisedBoard as measured by hand: each raised target off its truth by up to 2 mm in height and
// 1 mm across (a fixed pattern).
inline TargetSpec MeasuredByHand(const TargetSpec& truth) {
  TargetSpec given = truth;
  for (auto& t : given.field) {
    if (t.id < kFirstRaisedTarget) continue;
    const int k = t.id - kFirstRaisedTarget;
    t.xyz_mm += Eigen::Vector3d(((k * 7) % 5 - 2) * 0.5, ((k * 3) % 5 - 2) * 0.5, ((k * 5) % 9 - 4) * 0.5);
  }
  return given;
}

// The board's four corners and one raised target: control points of RaisedBoard.
inline const std::vector<int> kRaisedBoardControl = {1, 8, 41, 48, 54};

}  // namespace porthole::calib::fixtures
