// The housed camera: one description of a camera body, its lens, the port in front of it, the
// water outside and where the lens is focused, shared by planning (plan, flat, report) and
// simulate; and the one focus solver that finds where the lens must focus and where its entrance
// pupil then sits (docs/architecture.md, "housing").
//
// Frames and units (docs/conventions.md): the housing frame (origin at the centre of the body's
// lens-mount flange — the sensor plane for a fixed-lens camera —, +Z toward the scene), mm.
// FD is the focus-scale distance (sensor to subject), D_EP2F the pupil ahead of the flange,
// D_S2EP the subject (or its virtual image) in front of the pupil (Eq. 2). Infinity is
// std::numeric_limits<double>::infinity().
#pragma once

#include <functional>
#include <optional>

#include "porthole/lens/lens.h"
#include "porthole/ports/environment.h"
#include "porthole/ports/port.h"

namespace porthole::housing {

using ports::Vec3;

struct HousedCamera {
  lens::CameraBody camera;  // sensor and mount
  lens::LensSpec lens;      // as mounted on the body (lens::MountOn): its mount is the body's
  ports::PortSpec port;
  ports::Environment env;
  // Fixes the entrance pupil (housing frame) whatever the focus. Unset: (x, y) of the port's
  // default pupil and z = D_EP2F(FD) from the lens.
  std::optional<Vec3> ep_in_housing_mm;
  // Moves the pupil from where the lens puts it, relative to the port (a tolerance study): a port
  // written in the cam frame stays centred on the lens's own pupil.
  Vec3 ep_offset_mm = Vec3::Zero();
};

// Checks the lens and the body and that the lens sits on the body's mount. Field names: "lens",
// "camera", "ep_offset_mm" (prefixed by `where` when given).
void Validate(const HousedCamera& h);
// The mount the lens's Eq. 2 uses (the body's).
const lens::Mount& MountOf(const HousedCamera& h);

// Where the lens puts its pupil at focus-scale distance fd_mm (may be infinite), before the
// offset; the pupil itself is this + ep_offset_mm.
Vec3 NominalPupilAtFocus(const HousedCamera& h, double fd_mm);
// The port placed in front of the pupil at focus fd_mm, indices resolved from the water.
ports::PortSystem SystemAtFocus(const HousedCamera& h, double fd_mm);

// Where the lens is focused and where its pupil then is.
struct FocusSetting {
  double d_s2ep_mm = 0;            // where the lens must focus (a virtual image), from the pupil
  std::optional<double> focus_distance_mm;  // FD to set (Eq. 2); nullopt: closer than the lens goes
  double ep_to_flange_mm = 0;      // D_EP2F at that focus (at the minimum focus if unreachable)
  Vec3 ep_in_housing_mm = Vec3::Zero();  // the pupil, offset included
  double closeup_dioptre = 0;      // weakest close-up lens that would reach it (0 when reachable)
};

struct Focused {
  ports::PortSystem sys;  // the port placed for that focus
  FocusSetting focus;
};

// The one focus solver. `required(sys)` says how far in front of the pupil the lens must focus
// with the port placed as `sys` (the virtual image of the subject); the pupil moves with the focus
// (D_EP2F(FD)), so both are solved together by fixed-point iteration from infinity focus until
// the pupil moves less than 1e-10 mm (it moves a few mm while FD moves by hundreds: it contracts
// in a few passes; at most 100). A focus closer than the lens goes leaves the pupil at the minimum
// focus. One pass when the pupil is fixed.
Focused SolveFocus(const HousedCamera& h, const std::function<double(const ports::PortSystem&)>& required);

// The focus on an object subject_distance_mm in front of the pupil, along the axis (on its
// paraxial virtual image). Throws InvalidInput("subject_distance_mm") when the object is inside
// the port or the lens cannot focus on its image.
Focused FocusOnSubject(const HousedCamera& h, double subject_distance_mm);

// Distance from the entrance pupil to the port's outer vertex, along the axis.
double PupilToOuterMm(const ports::PortSystem& sys);

// The chief ray of image point (x, y) (image mm from the sensor centre, y up) in the camera frame
// (X right, Y down, Z forward), unit length, for principal distance c_mm and the lens's
// projection: at field angle θ = g⁻¹(r/c) from the axis, in the point's azimuth. Beyond 90° for a
// fisheye (Z < 0). nullopt beyond the projection's reach.
std::optional<Vec3> ChiefRay(const lens::LensSpec& lens, double c_mm, double x_mm, double y_mm);

}  // namespace porthole::housing
