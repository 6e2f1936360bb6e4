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
#include <optional>
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
  // This target seen through its own homography instead of the sheet's: a target raised off the
  // sheet (its plane's homography), or a lens's distortion to first order about the target.
  std::optional<Eigen::Matrix3d> image_from_sheet;
};
std::vector<double> RasterizeRaw(int width, int height, const Eigen::Matrix3d& image_from_sheet,
                                 const std::vector<RawTarget>& targets, const RasterOptions& options);

// A pinhole view of a sheet for tests: focal length f px, principal point at the image centre
// ((W−1)/2, (H−1)/2), no distortion; `rot`/`t` take sheet mm to the camera frame (X right, Y down,
// Z forward).
struct SheetView {
  int width = 1200, height = 900;
  double f_px = 2400;
  Eigen::Matrix3d rot = Eigen::Matrix3d::Identity();  // cam_from_sheet rotation
  Eigen::Vector3d t = Eigen::Vector3d::Zero();        // sheet origin in the camera frame, mm
  Eigen::Matrix3d K() const;
  Eigen::Matrix3d H() const;                           // pixels from sheet mm (plane Z = 0)
};

// The sheet point `look_at_mm` on the optical axis at `distance_mm`, the sheet tilted by
// `tilt_deg` about the in-plane axis at `axis_deg` from X, and turned by `roll_deg` about its
// normal.
SheetView LookAtSheet(const Eigen::Vector2d& look_at_mm, double distance_mm, double tilt_deg, double axis_deg,
                      double roll_deg, double f_px = 2400, int width = 1200, int height = 900);

}  // namespace porthole::coded
