// Where a port forms the virtual image of an object in the water, paraxially (a y-nu trace) and
// with real rays at a chosen aperture height; the port's focal lengths. The paper's Table 5.
//
// Axis: the line through the entrance pupil parallel to housing +Z; the object lies on it. For a
// port symmetric about that axis the paraxial image is a y-nu trace along it. For a decentred or
// tilted port it is the first-order image about the real chief ray (the ray from the object through
// the pupil centre): the limit of RealRayVirtualImage as the aperture shrinks, so that their
// difference is the port's aberration alone.
// Distances are positive numbers as in the paper (docs/conventions.md): D_S2EP from the virtual
// image to the entrance pupil, VWD from the virtual image to the outer vertex, WD from the object
// to the outer vertex. Infinity is std::numeric_limits<double>::infinity().
#pragma once

#include <optional>

#include "porthole/ports/port.h"

namespace porthole::ports {

struct VirtualImage {
  double wd_mm = 0;      // object to outer vertex (input)
  double d_s2ep_mm = 0;  // virtual image to entrance pupil
  double vwd_mm = 0;     // virtual image to outer vertex
  double magnification = 0;  // lateral, image height / object height (paraxial only; 0 for real)
  double lateral_offset_mm = 0;  // distance of the image from the axis (real rays, decentred ports)
  // The two focal lines of an astigmatic port (a cylinder: across and along its axis; a decentred
  // dome, slightly), as distances from the entrance pupil like d_s2ep_mm, nearer first; both equal
  // d_s2ep_mm for a port symmetric about the axis. Paraxial only (0 for real rays).
  double focal_line_near_d_s2ep_mm = 0, focal_line_far_d_s2ep_mm = 0;
};

// The paraxial virtual image of the axial object at wd_mm (may be infinite): a y-nu trace for a
// port symmetric about the axis; otherwise the limit of real rays about the chief ray (its
// lateral_offset_mm set; magnification from the axial y-nu trace, first order in the decentring).
// Throws InvalidInput("wd_mm") for wd_mm <= 0 or NaN.
VirtualImage ParaxialVirtualImage(const PortSystem& port, double wd_mm);

// RealRayVirtualPoint for the on-axis object point at wd_mm: rays through eight points of a circle
// of radius `aperture_height_mm` in the entrance-pupil plane; the least-squares point where they
// meet on the air side is the virtual image (exact for any geometry; for a decentred port, whose
// bundle is slightly astigmatic, its centre of least spread, possibly off the axis). As the height goes to zero this
// tends to the paraxial result; the difference is the port's longitudinal spherical aberration.
// nullopt when a ray cannot be traced (it leaves the glass, or total internal reflection).
std::optional<VirtualImage> RealRayVirtualImage(const PortSystem& port, double wd_mm,
                                                double aperture_height_mm);

// A point in the water: at a finite position (housing frame, mm), or at infinity in a direction.
struct ObjectPoint {
  Vec3 v = Vec3::Zero();  // the position, or the unit direction from the pupil toward the object
  bool at_infinity = false;
  static ObjectPoint At(const Vec3& position_mm) { return {position_mm, false}; }
  static ObjectPoint Toward(const Vec3& direction) { return {direction.normalized(), true}; }
};

// Where the port images one object point, by real rays.
struct VirtualPoint {
  Vec3 position_mm = Vec3::Zero();  // housing frame; meaningless when at_infinity
  double rms_spread_mm = 0;  // rms distance of the air rays from position_mm (astigmatism, coma)
  bool at_infinity = false;  // the air rays are parallel (a flat port imaging infinity)
};

// Real rays from `object` through eight points of a circle of radius `aperture_height_mm` about
// the entrance pupil centre, in the pupil plane (z = ep.z, normal to the axis): the least-squares
// point where the air-side rays meet is the virtual image of the object (exact for any geometry
// and field angle; for an astigmatic bundle, its centre of least spread). nullopt when a ray
// cannot be traced (it leaves the glass, total internal reflection, or Newton does not converge).
// Throws InvalidInput("aperture_height_mm") unless it is > 0.
// `pupil_normal` turns the pupil's circle to face another direction (a fisheye's pupil faces the
// chief ray, which may lie beyond 90° off axis); default: normal to the axis.
std::optional<VirtualPoint> RealRayVirtualPoint(const PortSystem& port, const ObjectPoint& object,
                                                double aperture_height_mm,
                                                const Vec3& pupil_normal = Vec3(0, 0, 1));

struct FocalProperties {
  // Power Φ = 1/efl (mm⁻¹) of the port between water and air; negative for a dome (diverging),
  // zero for a flat port (afocal: efl_mm is infinite).
  double power_per_mm = 0;
  double efl_mm = 0;              // 1/Φ: focal length on the air side (n = 1)
  double efl_water_mm = 0;        // n_w/Φ: focal length on the water side
  double back_focal_mm = 0;       // air-side focal point from the inner vertex (signed, +toward camera)
  double front_focal_mm = 0;      // water-side focal point from the outer vertex (signed, +toward scene)
};
FocalProperties ParaxialFocal(const PortSystem& port);

}  // namespace porthole::ports
