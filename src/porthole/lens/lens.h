// Camera bodies, lens mounts and lenses: what planning needs to know about the camera behind the
// port. The entrance pupil moves when the lens focuses; its offset from the mount flange is a table
// against the focus-scale distance, interpolated (the paper's Table 2 and Eq. 2).
//
// A fixed-lens camera (a compact, an action camera) has mount "fixed" with a flange focal distance
// of 0: its "flange" is the sensor plane, so D_EP2F is the pupil ahead of the sensor and the housing
// frame's origin is the sensor centre. Its lens is part of the camera file (CameraBody::fixed_lens).
//
// Distances (docs/conventions.md): FD is the focus-scale distance, sensor plane to subject; FFD
// the mount's flange focal distance; D_EP2F the entrance pupil ahead of the flange;
// D_S2EP = FD − FFD − D_EP2F (Eq. 2), the subject (or virtual image) to the entrance pupil.
// Infinity is std::numeric_limits<double>::infinity().
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "porthole/camera/projection.h"
#include "porthole/camera/sensor.h"

namespace porthole::lens {

struct Mount {
  std::string name;
  double flange_focal_distance_mm;
};
// The known mounts: nikon-f 46.5, canon-ef 44.0, sony-e 18.0, nikon-z 16.0, canon-rf 20.0,
// mft 19.25, fujifilm-x 17.7, l-mount 20.0, pentax-k 45.46 mm; fixed 0 (lens built into the body).
const std::vector<Mount>& KnownMounts();
// Throws InvalidInput("mount") for an unknown name.
const Mount& MountByName(const std::string& name);


// One measurement of the entrance pupil: with the focus scale at focus_mm (FD, may be infinite),
// the pupil lies d_ep2f_mm ahead of the flange.
struct PupilSample {
  double focus_mm;
  double d_ep2f_mm;
};

struct LensSpec {
  std::string name, description, source;
  std::string mount;
  double focal_length_mm = 0;
  double f_number_min = 0, f_number_max = 0;  // widest and smallest aperture
  double min_focus_mm = 0;                    // closest focus-scale distance (FD)
  bool min_focus_assumed = false;             // true when not known (lensfun records none): say so
  std::vector<PupilSample> pupil;             // at least one sample
  bool pupil_estimated = false;               // true when not measured (say so to the user)
  // How the lens maps field angle θ to image radius r = f·g(θ) (camera/projection.h): rectilinear
  // (tan θ) for ordinary lenses, one of the fisheye projections otherwise.
  camera::Projection projection = camera::Projection::kRectilinear;
  bool projection_estimated = false;          // true when taken from a type guess (say so)
  // A fixed-focus lens (an action camera's): nothing to set; the focus range min_focus_mm to
  // infinity is what it renders sharp, and planning gives no focus advice for it.
  bool fixed_focus = false;
  // Other mounts the same optical design is made for (a lens sold in several mounts, as lensfun
  // lists them). The pupil samples are for `mount`; on another of these mounts the pupil keeps its
  // distance from the sensor.
  std::vector<std::string> other_mounts;
  // Where the name was found: "preset", "file" or "lensfun" (catalogue::FindLens); empty when built in code.
  std::string lookup;

  // D_EP2F at focus-scale distance fd_mm, linear in 1/FD between samples (lens extension is close
  // to linear in 1/FD), held constant beyond the first and last sample. Throws InvalidInput("focus")
  // for fd_mm below the minimum focus or not positive.
  double PupilToFlangeMm(double fd_mm) const;
};

struct CameraBody {
  std::string name, description, source;
  camera::Sensor sensor;
  std::string mount;
  // The lens of a fixed-lens camera (mount "fixed"): body and lens in one file.
  std::optional<LensSpec> fixed_lens;
  // Where the name was found: "preset", "file" or "lensfun" (catalogue::FindCamera); empty when built in code.
  std::string lookup;
  double SensorWidthMm() const { return sensor.width_px * sensor.pixel_pitch_mm; }
  double SensorHeightMm() const { return sensor.height_px * sensor.pixel_pitch_mm; }
  double SensorDiagonalMm() const;
};

// Eq. 2: D_S2EP = FD − FFD − D_EP2F(FD). Infinite FD gives infinity.
double SubjectToPupilMm(const LensSpec& lens, const Mount& mount, double fd_mm);

// The inverse: the focus-scale distance FD at which the lens is sharp on a subject (or virtual
// image) d_s2ep_mm in front of its entrance pupil. std::nullopt when even the minimum focus is
// farther (the lens cannot focus that close). Infinite input gives infinity.
std::optional<double> FocusForSubjectMm(const LensSpec& lens, const Mount& mount, double d_s2ep_mm);

// The thin-lens principal distance (image distance) of a lens of focal length f focused on a
// subject d in front of its entrance pupil: c = f d / (d − f); f at infinity. Distances from the
// entrance pupil stand in for those from the principal planes, so this is an estimate (the
// paper's 24 mm lens calibrates at 25.8 mm where this gives 26.7 mm). Throws
// InvalidInput("subject_distance_mm") unless d > f, InvalidInput("focal_length_mm") unless f > 0.
double PrincipalDistanceMm(double focal_length_mm, double d_s2ep_mm);

// The image radius (mm) of a chief ray at field angle θ (rad) for principal distance c:
// c·g(θ) with the lens's projection; and the inverse, nullopt beyond the projection's reach.
double ImageRadiusMm(const LensSpec& lens, double c_mm, double theta_rad);
std::optional<double> FieldAngleRad(const LensSpec& lens, double c_mm, double image_radius_mm);

// The lens as mounted on `body`: re-expressed against the body's mount, so that Eq. 2 with the
// body's flange focal distance holds. On its own mount (or one of other_mounts) the pupil keeps
// its distance from the sensor; with `allow_adapter`, a lens whose flange focal distance exceeds
// the body's sits on an adapter of the difference (its pupil moves forward by it, FD stays from
// the sensor). A fixed-lens body gives its own lens. Throws InvalidInput("lens") when the lens does
// not fit (naming the mounts, and --allow-adapter when an adapter would do).
LensSpec MountOn(const LensSpec& lens, const CameraBody& body, bool allow_adapter = false);

// The f-number a command uses when none is given: f/8 (the paper's Section 4 aperture), or the
// nearest the lens has — its own aperture for a fixed-aperture lens (an action camera's f/2.8).
double DefaultFNumber(const LensSpec& lens);
inline constexpr double kDefaultFNumber = 8;

// Checks a lens (positive focal length, f-number range, sorted finite samples) and a body.
void Validate(const LensSpec& lens, const std::string& where = "lens");
void Validate(const CameraBody& body, const std::string& where = "camera");

}  // namespace porthole::lens
