// Dive planning behind a dome or flat port (issue 3): where to focus, whether the lens gets there,
// the minimum working distance and the close-up lens for closer work, depth of field under water
// and in air, the focus that keeps infinity sharp, field of view, ground sample distance, and the
// field curvature of the port with the blur it causes across the frame. docs/planning.md.
//
// Frames and distances (docs/conventions.md): the housing frame, mm. WD is from the real object to
// the port's outer vertex; subject distances and D_S2EP from the entrance pupil, along the axis;
// FD is the lens's focus-scale distance (sensor to subject), related to D_S2EP by Eq. 2. Every
// focus is set on the paraxial virtual image (the paper's Section 4). For a port given in the
// housing frame (an as-built dome) the entrance pupil moves with focus (LensSpec::PupilToFlangeMm)
// and focus and virtual image are solved together; a cam-frame port (nominal) stays centred on the
// pupil. Infinity is std::numeric_limits<double>::infinity(); NaN marks "not available".
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "porthole/planning/centring.h"
#include "porthole/planning/focus.h"

namespace porthole::planning {

struct PlanOptions {
  // The target (at most one): WD from the port's outer vertex, or the subject's distance from the
  // entrance pupil. Neither: the plan holds only what needs no target (minimum WD, infinity focus,
  // field of view).
  std::optional<double> wd_mm;
  std::optional<double> subject_distance_mm;
  double f_number = 8;              // the paper's Section 4 aperture
  std::optional<double> coc_mm;     // unset: kCocPixels pixel pitches
  static constexpr double kCocPixels = 2;  // a blur of two pixels is the finest a Bayer sensor shows
  int field_samples = 11;           // field-curvature rows from the centre to the corner
  std::vector<double> closeup_dioptres = {1, 2, 3, 4};  // the usual close-up lens strengths
  double lambda_nm = 546.07;        // for the diffraction check (the design wavelength)
};

struct Fov {
  double horizontal_deg = 0, vertical_deg = 0, diagonal_deg = 0;  // full angles; NaN: ray blocked
};

// The camera's edge and corner chief rays (principal distance c_mm, a centred sensor, the lens's
// projection: a fisheye's reach beyond 90° off axis) in air, and the same rays traced out through
// the port into the water: the full angle between opposite edges, through the axis (it may exceed
// 180° for a fisheye behind a dome).
struct FovPair {
  Fov air, water;
};
FovPair FieldOfView(const ports::PortSystem& sys, const lens::CameraBody& camera, const lens::LensSpec& lens,
                    double c_mm);

// What part of the frame sees the port's rim (or the housing) instead of the water: its chief
// rays do not get through the port.
struct FieldCut {
  double blocked_fraction = 0;  // of the frame's area (a 64 x 43 grid of chief rays)
  // Along the frame diagonal (the worst of the four): the largest image radius (mm) and air field
  // angle (deg, from the axis) whose chief ray passes; the half diagonal and its angle when
  // nothing is cut.
  double clear_radius_mm = 0, clear_angle_deg = 0;
  double clear_water_angle_deg = 0;  // that last passing ray's angle from the axis in the water
  // "nothing", "the corners", "the corners and the left and right edges", "the whole frame edge".
  std::string what = "nothing";
};
FieldCut FieldCutByPort(const ports::PortSystem& sys, const lens::CameraBody& camera, const lens::LensSpec& lens,
                        double c_mm);

// The WD whose paraxial virtual image lies d_s2ep_mm from the entrance pupil (bisection on WD):
// infinite when d_s2ep_mm is at or beyond the image of infinity, 0 when it is closer than the
// image of an object touching the port.
double WdForVirtualImage(const ports::PortSystem& sys, double d_s2ep_mm);

using housing::FocusSetting;

struct DofAir {
  double focus_mm = 0, near_mm = 0, far_mm = 0, total_mm = 0;  // from the entrance pupil
  std::optional<double> focus_distance_mm;  // FD to set in air (Eq. 2)
};
struct DofWater {
  // In the virtual image space (where the thin-lens limits apply), from the entrance pupil.
  double virtual_focus_mm = 0, virtual_near_mm = 0, virtual_far_mm = 0, virtual_total_mm = 0;
  // Mapped back to the real objects in the water, from the entrance pupil.
  double focus_mm = 0, near_mm = 0, far_mm = 0, total_mm = 0;
  double near_wd_mm = 0, far_wd_mm = 0;  // the same limits as working distances
};

// A rectilinear lens images a flat object plane at the target's WD; a fisheye images the sphere
// at the target's distance from the pupil (it sees beyond 90° off axis), and its distances are
// taken along the chief ray rather than the axis.
struct FieldRow {
  double image_height_mm = 0;  // on the sensor, along the diagonal toward the corner
  double field_angle_deg = 0;  // chief-ray angle in air
  double object_height_mm = 0; // where that ray meets the object plane (fisheye: the object sphere),
                               // from the axis
  double d_s2ep_mm = 0;        // distance of the real-ray virtual image from the pupil (axial;
                               // fisheye: along the chief ray)
  double sag_mm = 0;           // its shift toward the camera from the on-axis image
  double blur_px = 0;          // defocus blur diameter on the sensor at the set focus and f-number
  double spread_px = 0;        // the bundle's own spread (astigmatism, coma), imaged on the sensor
};
struct FieldCurvature {
  double aperture_height_mm = 0;  // pupil radius f/(2N) used for the real rays
  std::vector<FieldRow> rows;     // centre to the corner
  double corner_blur_px = 0;      // the largest of the four corners
  double f_number_for_sharp_corners = 0;  // defocus blur at the corners = the circle of confusion
};

struct TargetPlan {
  double wd_mm = 0;                  // object to the port's outer vertex
  double subject_distance_mm = 0;    // object to the entrance pupil
  ports::VirtualImage virtual_image;         // paraxial
  double d_s2ep_real_mm = 0;         // real rays at the pupil radius f/(2N) (NaN: failed)
  FocusSetting focus;
  double principal_distance_mm = 0;  // thin lens at that focus
  DofAir air;
  DofWater water;
  double dof_ratio_water_to_air = 0;  // water total / air total; NaN (not applicable) if either is unlimited
  double gsd_water_mm = 0, gsd_air_mm = 0;  // object size of one pixel at the centre
  std::optional<FieldCurvature> field;     // nullopt when the real rays fail
};

struct InfinityFocus {
  double air_focus_mm = 0, air_near_mm = 0;  // hyperfocal f + f²/(N c) and its near limit
  std::optional<double> air_focus_distance_mm;
  // Under water: the focus on the virtual image whose far limit is the image of infinity.
  double water_virtual_focus_mm = 0, water_virtual_near_mm = 0;
  double water_near_mm = 0, water_near_wd_mm = 0;  // the near limit as a real object
  std::optional<double> water_focus_distance_mm;  // FD to set; nullopt: closer than the lens goes
};

struct CloseupRow {
  double dioptre = 0;
  double min_wd_mm = 0, max_wd_mm = 0;  // the WD range the lens then covers (max may be infinite)
  bool needed = true;  // false when the lens alone already focuses on the whole virtual-image range
};

struct Plan {
  double f_number = 0, coc_mm = 0;
  std::string coc_source;              // how the circle of confusion was chosen
  ports::PortSystem system;            // at the target's focus (or at infinity focus)
  // The virtual image of infinity from the pupil, with the lens focused on it (the pupil moves with
  // focus: at the focus-scale infinity it would be ~2 mm farther for the NI320 and a 24 mm lens).
  // The report's Table 5 row WD = inf is the same number.
  double d_s2ep_infinity_mm = 0;
  std::optional<double> infinity_image_focus_distance_mm;  // FD that focuses on it; nullopt: out of reach
  double closest_d_s2ep_mm = 0;        // the lens at its minimum focus (Eq. 2)
  double min_wd_mm = 0;                // infinite: nothing in the water is in reach
  // The virtual image of an object touching the port's outer vertex (the limit WD → 0), at the
  // lens's minimum focus. When the lens's closest subject is nearer than this, the lens focuses on
  // the whole virtual-image range (touching the glass to infinity): min_wd_mm is 0 and it is the
  // glass, not the lens, that sets the closest working distance.
  double d_s2ep_touching_mm = 0;
  bool lens_covers_virtual_range = false;
  double pupil_to_outer_mm = 0;        // the glass on the axis, from the pupil (at minimum focus)
  std::vector<CloseupRow> closeup;
  InfinityFocus infinity;
  double principal_distance_mm = 0;    // used for the field of view
  FovPair fov;
  FieldCut field_cut;                  // what the port's rim cuts off the frame
  std::optional<TargetPlan> target;
  // Domes: the pupil against the dome's centre at the plan's focus (the target's, else the
  // infinity focus) and the extension ring that would centre it (centring.h). nullopt: flat port.
  std::optional<PupilCentring> centring;
  std::vector<std::string> warnings;   // plain language, the paper's advice
};

// Throws InvalidInput naming the option field: wd_mm and subject_distance_mm together, a target
// inside the port (wd_mm <= 0, or a subject closer than the outer vertex), f_number outside the
// lens's range, coc_mm not > 0; and whatever the housed camera's checks throw ("lens", "camera",
// port and water fields).
Plan MakePlan(const Setup& setup, const PlanOptions& options);

}  // namespace porthole::planning
