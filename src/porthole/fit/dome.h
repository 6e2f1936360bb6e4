// Dome port analysis from scans of its outer and inner surfaces (paper Section 3, Table 3), and
// the rigid transform from the scan frame to the housing frame (docs/conventions.md).
#pragma once

#include <Eigen/Core>
#include <string>

#include "porthole/fit/sphere_fit.h"

namespace porthole::fit {

// p_in_b = rotation · p_in_a + translation, for a transform named b_from_a. Lengths in mm.
struct RigidTransform {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // orthonormal, det +1
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();   // mm

  Eigen::Vector3d Apply(const Eigen::Vector3d& p) const { return rotation * p + translation; }
  Eigen::Matrix3Xd Apply(const Eigen::Matrix3Xd& p) const {
    return (rotation * p).colwise() + translation;
  }
  RigidTransform Inverse() const {
    return {rotation.transpose(), -rotation.transpose() * translation};
  }
  // (c_from_b * b_from_a) = c_from_a.
  RigidTransform operator*(const RigidTransform& b_from_a) const {
    return {rotation * b_from_a.rotation, rotation * b_from_a.translation + translation};
  }
};

// housing_from_scan for a lens-mount flange measured in the scan frame: origin at the flange
// centre; +Z along the flange normal, oriented toward `scene_point_in_scan` (any point in front
// of the camera, e.g. the dome centre); +X along `x_hint_in_scan` projected onto the flange plane
// (the housing's "right"); +Y = Z × X (down). Throws InvalidInput when the normal is zero, the
// scene point lies in the flange plane, or the hint is parallel to the normal.
RigidTransform HousingFromFlange(const Eigen::Vector3d& flange_center_in_scan,
                                 const Eigen::Vector3d& flange_normal_in_scan,
                                 const Eigen::Vector3d& scene_point_in_scan,
                                 const Eigen::Vector3d& x_hint_in_scan = Eigen::Vector3d::UnitX());

struct DomeAnalysisOptions {
  SphereFitOptions sphere;             // used for both surfaces
  double nominal_outer_radius_mm = 0;  // design outer radius; 0: no comparison
  double nominal_thickness_mm = 0;     // design wall thickness; 0: no comparison
};

struct DomeAnalysis {
  SphereFitSummary outer, inner;    // centres in the frame of the input (or transformed)
  double thickness_mm = NAN;        // R_out − R_in
  double sigma_thickness_mm = NAN;  // √(σ²_Rout + σ²_Rin): the two scans are independent
  Eigen::Vector3d center_offset_mm = Eigen::Vector3d::Constant(NAN);  // c_in − c_out
  double center_distance_mm = NAN;        // |c_in − c_out|; 0 for an ideal (concentric) shell
  double sigma_center_distance_mm = NAN;  // propagated from both centre covariances
  // Wall thickness along radial lines from the outer centre: extremes on the line of centres,
  // R_out − R_in ∓ |Δc|. An ideal shell has min = max.
  double min_wall_mm = NAN;
  double max_wall_mm = NAN;
  double outer_radius_deviation_mm = NAN;  // R_out − nominal (NaN without a nominal)
  double thickness_deviation_mm = NAN;     // thickness − nominal (NaN without a nominal)

  bool IsUsable() const { return outer.IsUsable() && inner.IsUsable() && thickness_mm > 0; }
  std::string Report() const;  // a few lines, units in mm
};

// Fits both spheres and derives the shell quantities. Points: 3×N in mm, same frame for both.
DomeAnalysis AnalyzeDome(const Eigen::Matrix3Xd& outer_points_mm,
                         const Eigen::Matrix3Xd& inner_points_mm,
                         const DomeAnalysisOptions& options = {});

// The same analysis expressed in frame b: centres and their covariances rotated and moved; radii,
// thickness and distances are unchanged. Residuals and inlier flags are kept as they are.
DomeAnalysis TransformDome(const DomeAnalysis& in_a, const RigidTransform& b_from_a);

}  // namespace porthole::fit
