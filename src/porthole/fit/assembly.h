// Assembly of the camera–housing–dome geometry from separate measurements (paper Section 3.4,
// Table 4): the camera and housing flanges from a photogrammetric survey, the dome's two spheres
// and its rear plane from a laser scan, and the lens's entrance-pupil offset from the flange.
//
// Frames (docs/conventions.md): `survey` is the frame of the flange targets, `scan` the frame of
// the dome scan, `housing` the result: origin at the camera flange centre, +Z along the camera
// flange normal toward the housing flange, +X along a hint projected on the flange plane, +Y = Z×X.
// Lengths in mm.
#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "porthole/fit/dome.h"
#include "porthole/ports/port.h"

namespace porthole::fit {

// A flange or other planar reference: a centre on the plane and the plane's normal.
struct PlaneWithCenter {
  Eigen::Vector3d center_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // any length > 0; normalised on use
};

struct AssemblyInput {
  PlaneWithCenter camera_flange;   // survey frame; its centre becomes the origin
  PlaneWithCenter housing_flange;  // survey frame; where the dome's rear face is seated
  Sphere outer, inner;             // dome spheres: scan frame (survey frame without a dome rear)
  // The dome's rear face in the scan frame, normal pointing from the rear face toward the dome's
  // apex. It is aligned to the housing flange: normals made equal, rear centre on the flange
  // centre (the paper's "plane fitted to the rear of the dome port and aligned to the flange
  // plane of the housing"). Unset: the spheres are already in the survey frame.
  std::optional<PlaneWithCenter> dome_rear;
  // Take the dome rear's centre as the outer sphere centre projected on the rear plane (the dome
  // is centred in its mount: what the paper assumes, a plane having no centre).
  bool dome_centered = false;
  // Rotation about the axis, which plane alignment leaves open: these hints (survey and scan
  // frames) projected on their planes become the housing's +X.
  Eigen::Vector3d survey_x_hint = Eigen::Vector3d::UnitX();
  Eigen::Vector3d scan_x_hint = Eigen::Vector3d::UnitX();
  // The entrance pupil ahead of the camera flange along the lens axis, D_EP2F (lens::LensSpec::
  // PupilToFlangeMm at the focus distance; the paper's Table 2). The lens axis is the camera
  // flange normal through its centre (the pupil's lateral offset is not measurable this way).
  double pupil_to_flange_mm = 0;
};

struct HousingAssembly {
  RigidTransform housing_from_survey, housing_from_scan;
  // Table 4, housing frame.
  Eigen::Vector3d camera_flange_center_mm = Eigen::Vector3d::Zero();  // (0, 0, 0) by construction
  Eigen::Vector3d housing_flange_center_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d housing_flange_normal = Eigen::Vector3d::UnitZ();  // unit, z > 0
  double housing_flange_tilt_rad = 0;  // angle between the two flange planes
  Sphere outer, inner;                 // housing frame
  Eigen::Vector3d entrance_pupil_mm = Eigen::Vector3d::Zero();  // (0, 0, D_EP2F)
  // Entrance pupil minus the outer (inner) sphere centre: along the axis (> 0: the pupil lies
  // ahead of the centre, toward the dome) and its distance from the axis through the centre.
  double pupil_ahead_of_outer_mm = 0, pupil_off_axis_outer_mm = 0;
  double pupil_ahead_of_inner_mm = 0, pupil_off_axis_inner_mm = 0;
  double thickness_mm = 0;        // R_out − R_in
  double center_distance_mm = 0;  // |c_in − c_out|

  std::string Report() const;  // the Table 4 rows and the pupil offsets, a few lines
};

// Throws InvalidInput naming the field ("camera_flange",
// "housing_flange", "outer", "inner", "dome_rear", "x_hint", "dome_x_hint",
// "pupil_offset") for zero normals, non-finite numbers, non-positive radii,
// an inner sphere not inside the outer, a housing flange in the camera flange's plane, or a
// pupil not inside the inner sphere.
HousingAssembly AssembleHousing(const AssemblyInput& in);

// The as-built port: a housing-frame dome with the assembled spheres, glass only ahead of the
// housing flange (rim_z_mm = its centre's z), and the entrance pupil as its default pupil.
ports::PortSpec AsBuiltPort(const HousingAssembly& a, const std::string& name,
                            const std::string& material = "n-bk7");

// The assembly as `porthole assemble --json` and Python's assemble() give it: frame, flanges, dome
// centres and radii, thickness, pupil and its offsets from both centres, the survey and scan
// transforms (rotation rows, translation_mm); units in the keys.
nlohmann::ordered_json AssemblyToJson(const HousingAssembly& a, double pupil_to_flange_mm);

// Inputs as a user types them: `spec` is either comma-separated numbers or the path of a JSON
// file written by `porthole fit ... --json`. `field` (the CLI flag) names errors.
//   plane: "X,Y,Z,NX,NY,NZ" (centre and normal), or `fit circle` JSON (center_mm, normal), or
//          `fit plane` JSON (centroid_mm as the centre: right for a symmetric ring of targets).
//   sphere: "X,Y,Z,R", or `fit sphere` JSON (center_mm, radius_mm; rejected if usable = false).
PlaneWithCenter ParsePlaneSpec(const std::string& spec, const std::string& field);
Sphere ParseSphereSpec(const std::string& spec, const std::string& field);

}  // namespace porthole::fit
