// An exact area-integrated rasteriser of coded targets seen through a homography, for tests and
// benchmarks of detection (ground truth known to machine precision).
//
// Pixel (u, v) covers [u − ½, u + ½] × [v − ½, v + ½] (docs/conventions.md). Each pixel row is
// cut into `subrows` horizontal lines; along each line the inked part (dot, ring segments) is
// found exactly — its ends are roots of the line's intersections with the dot's and ring's circles
// (quadratics) and with the segments' radial edges (linear), mapped through the homography — so
// the ink covered within each pixel is exact along u and integrated by the midpoint rule along v
// (error O(1/subrows²) except where a line grazes a circle).
#pragma once

#include <Eigen/Dense>
#include <vector>

#include "porthole/coded/sheet.h"

namespace porthole::coded {

struct RasterOptions {
  int bits = 14;
  Profile profile = Profile::kAicon;
  double radius_mm = 2.5;   // dot radius on the sheet
  int subrows = 64;         // lines per pixel row
};

// Fraction of each pixel covered by ink (dot and filled ring segments), row-major, width·height
// values in [0, 1]. `image_from_sheet` maps sheet mm to pixels; the sheet must lie in front of the
// camera wherever a target is drawn (a target whose ring would cross the horizon is left out).
std::vector<double> RasterizeTargets(int width, int height, const Eigen::Matrix3d& image_from_sheet,
                                     const std::vector<PlacedTarget>& targets, const RasterOptions& options);

// A ring pattern by its raw code rather than an ID (look-alikes, damaged codes): as above.
struct RawTarget {
  Eigen::Vector2d centre_mm;
  uint32_t ring = 0;        // bit bits−1 is the segment at angle 0 (sheet.h: RingArcs)
  bool dot = true;          // draw the dot
};
std::vector<double> RasterizeRaw(int width, int height, const Eigen::Matrix3d& image_from_sheet,
                                 const std::vector<RawTarget>& targets, const RasterOptions& options);

}  // namespace porthole::coded
