// A flat port's effect on the camera behind it (the paper's Section 2.2): the field of view in
// water against air, thin (the entrance pupil at the glass) and for the real geometry by ray
// trace; the maximum field of view the critical angle allows; the distortion factor D of the
// paper's Eq. 1 against angle; the apparent focal length; lateral colour between two wavelengths.
//
// Angles in degrees in the results (radians in the functions' arguments), lengths in mm, image
// displacements in pixels. θ_a is the chief ray's angle to the axis in the air inside the housing,
// θ_w in the water; Snell through a plate with parallel faces gives sin θ_a = n_w sin θ_w whatever
// its thickness and index.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include "porthole/planning/plan.h"

namespace porthole::planning {

// The paper's Eq. 1 (after Ray 2002): D = r'/r = ((n_w² − sin²θ_a) / (1 − sin²θ_a))^½, the ratio
// of the image radius behind a thin flat port to the radius without it, for entrance angle θ_a
// (radians, in air) and water index n_w. Equals tan θ_a / tan θ_w.
double FlatDistortionFactor(double theta_air_rad, double n_water);

// The same ratio by an exact trace of the chief ray leaving the pupil at θ_a in the x-z plane:
// tan θ_a / tan θ_w with θ_w from the traced water direction. NaN when the ray cannot pass.
double TracedDistortionFactor(const ports::PortSystem& sys, double theta_air_rad);

struct FlatOptions {
  double wd_mm = std::numeric_limits<double>::infinity();  // object distance; sets focus and coverage
  double lambda_blue_nm = 486.13;  // Fraunhofer F line: the usual blue end of lateral colour
  double lambda_red_nm = 656.27;   // Fraunhofer C line: the red end
  double step_deg = 5;             // table step in θ_a
};

struct FlatRow {
  double theta_air_deg = 0, theta_water_deg = 0;
  double distortion_factor = 0;         // Eq. 1
  double distortion_factor_traced = 0;  // by ray trace through the real port
  double image_radius_mm = 0;           // c tan θ_a
  double distortion_px = 0;   // image radius minus that of a pinhole with focal length n_w c
  double lateral_colour_px = 0;  // blue minus red image radius, for the object seen at θ_a
};

struct FlatAnalysis {
  ports::PortSystem system;  // at the focus on wd_mm
  double n_water = 0, n_glass = 0;
  double principal_distance_mm = 0;      // c, thin lens focused on the virtual image of wd_mm
  double apparent_focal_length_mm = 0;   // paraxial n_w c
  double focal_length_increase_pct = 0;  // (n_w − 1) · 100
  Fov air, water_thin, water_traced;
  FieldCut field_cut;  // what of the frame never reaches the water (a fisheye beyond 90° off axis)
  // Light from the water reaches the housing air only if it meets the port at less than the
  // critical angle asin(1/n_w) to its normal: steeper water rays are totally reflected at the
  // glass-air face on their way in. Light from the air into the water is never totally reflected,
  // so every air angle below 90 deg passes; the field in water is what this limit compresses.
  double critical_angle_deg = 0;  // asin(1/n_w)
  double max_fov_deg = 0;         // twice that: the widest field in water, whatever the lens
  // Where the corner chief rays cross the port's outer face, as a distance from the axis through
  // the pupil (the largest of the four corners): the port's clear aperture must be at least twice
  // this, or the corners of the frame see the port's rim instead of the water.
  double corner_outer_radius_mm = 0;
  double clear_aperture_needed_mm = 0;  // 2 × corner_outer_radius_mm; NaN when a corner ray fails
  double wd_mm = 0;
  // Horizontal width of the scene covered at wd_mm: thin port (pupil at the glass) and traced.
  double coverage_thin_mm = 0, coverage_traced_mm = 0;
  double n_water_blue = 0, n_water_red = 0;
  double lateral_colour_corner_px = 0;
  std::vector<FlatRow> rows;  // θ_a from 0 to the corner
  std::vector<std::string> warnings;
};

// Throws InvalidInput("port") for a dome, "wd_mm", "step_deg", "lambda_blue_nm", "lambda_red_nm"
// for bad options, and whatever the housed camera's checks throw.
FlatAnalysis AnalyseFlat(const Setup& setup, const FlatOptions& options);

}  // namespace porthole::planning
