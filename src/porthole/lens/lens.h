// Camera bodies, lens mounts and lenses: what planning needs to know about the camera behind the
// port. The entrance pupil moves when the lens focuses; its offset from the mount flange is a table
// against the focus-scale distance, interpolated (the paper's Table 2 and Eq. 2).
//
// Distances (docs/conventions.md): FD is the focus-scale distance, sensor plane to subject; FFD
// the mount's flange focal distance; D_EP2F the entrance pupil ahead of the flange;
// D_S2EP = FD − FFD − D_EP2F (Eq. 2), the subject (or virtual image) to the entrance pupil.
// Infinity is std::numeric_limits<double>::infinity().
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "porthole/camera/sensor.h"

namespace porthole::lens {

struct Mount {
  std::string name;
  double flange_focal_distance_mm;
};
// The known mounts: nikon-f 46.5, canon-ef 44.0, sony-e 18.0, nikon-z 16.0, canon-rf 20.0,
// mft 19.25, fujifilm-x 17.7, l-mount 20.0, pentax-k 45.46 mm.
const std::vector<Mount>& KnownMounts();
// Throws InvalidInput("mount") for an unknown name.
const Mount& MountByName(const std::string& name);

struct CameraBody {
  std::string name, description, source;
  camera::Sensor sensor;
  std::string mount;
  double SensorWidthMm() const { return sensor.width_px * sensor.pixel_pitch_mm; }
  double SensorHeightMm() const { return sensor.height_px * sensor.pixel_pitch_mm; }
  double SensorDiagonalMm() const;
};

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
  std::vector<PupilSample> pupil;             // at least one sample
  bool pupil_estimated = false;               // true when not measured (say so to the user)

  // D_EP2F at focus-scale distance fd_mm, linear in 1/FD between samples (lens extension is close
  // to linear in 1/FD), held constant beyond the first and last sample. Throws InvalidInput("focus")
  // for fd_mm below the minimum focus or not positive.
  double PupilToFlangeMm(double fd_mm) const;
};

// Eq. 2: D_S2EP = FD − FFD − D_EP2F(FD). Infinite FD gives infinity.
double SubjectToPupilMm(const LensSpec& lens, const Mount& mount, double fd_mm);

// The inverse: the focus-scale distance FD at which the lens is sharp on a subject (or virtual
// image) d_s2ep_mm in front of its entrance pupil. std::nullopt when even the minimum focus is
// farther (the lens cannot focus that close). Infinite input gives infinity.
std::optional<double> FocusForSubjectMm(const LensSpec& lens, const Mount& mount, double d_s2ep_mm);

// Checks a lens (positive focal length, f-number range, sorted finite samples) and a body.
void Validate(const LensSpec& lens, const std::string& where = "lens");
void Validate(const CameraBody& body, const std::string& where = "camera");

}  // namespace porthole::lens
