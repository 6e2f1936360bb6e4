#include "porthole/lens/lens.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "porthole/core/error.h"

namespace porthole::lens {

const std::vector<Mount>& KnownMounts() {
  // Flange focal distances, mm (manufacturers' specifications).
  static const std::vector<Mount> kMounts = {
      {"nikon-f", 46.5},  {"canon-ef", 44.0},   {"sony-e", 18.0},   {"nikon-z", 16.0},  {"canon-rf", 20.0},
      {"mft", 19.25},     {"fujifilm-x", 17.7}, {"l-mount", 20.0},  {"pentax-k", 45.46},
      {"fixed", 0.0}};  // a lens built into the body: distances from the sensor plane
  return kMounts;
}

const Mount& MountByName(const std::string& name) {
  std::string names;
  for (const Mount& m : KnownMounts()) {
    if (m.name == name) return m;
    names += (names.empty() ? "" : ", ") + m.name;
  }
  throw InvalidInput("mount", "unknown mount '" + name + "' (known: " + names + ")");
}

double CameraBody::SensorDiagonalMm() const { return std::hypot(SensorWidthMm(), SensorHeightMm()); }

double LensSpec::PupilToFlangeMm(double fd_mm) const {
  if (std::isnan(fd_mm) || !(fd_mm > 0)) throw InvalidInput("focus", "focus distance must be > 0 mm");
  if (fd_mm < min_focus_mm * (1 - 1e-12)) {
    throw InvalidInput("focus", "the " + name + " focuses no closer than " + std::to_string(min_focus_mm) + " mm");
  }
  PORTHOLE_CHECK(!pupil.empty());
  // Interpolate in vergence v = 1/FD (0 at infinity); samples sorted by decreasing FD = increasing v.
  const double v = 1.0 / fd_mm;
  auto vergence = [](const PupilSample& s) { return 1.0 / s.focus_mm; };
  if (v <= vergence(pupil.front())) return pupil.front().d_ep2f_mm;
  if (v >= vergence(pupil.back())) return pupil.back().d_ep2f_mm;
  for (std::size_t k = 1; k < pupil.size(); ++k) {
    const double v0 = vergence(pupil[k - 1]), v1 = vergence(pupil[k]);
    if (v <= v1) {
      const double w = (v - v0) / (v1 - v0);
      return pupil[k - 1].d_ep2f_mm + w * (pupil[k].d_ep2f_mm - pupil[k - 1].d_ep2f_mm);
    }
  }
  return pupil.back().d_ep2f_mm;
}

double SubjectToPupilMm(const LensSpec& lens, const Mount& mount, double fd_mm) {
  if (std::isinf(fd_mm)) return std::numeric_limits<double>::infinity();
  return fd_mm - mount.flange_focal_distance_mm - lens.PupilToFlangeMm(fd_mm);
}

std::optional<double> FocusForSubjectMm(const LensSpec& lens, const Mount& mount, double d_s2ep_mm) {
  if (std::isnan(d_s2ep_mm) || !(d_s2ep_mm > 0)) throw InvalidInput("subject_distance_mm", "must be > 0");
  if (std::isinf(d_s2ep_mm)) return d_s2ep_mm;
  if (d_s2ep_mm < SubjectToPupilMm(lens, mount, lens.min_focus_mm)) return std::nullopt;
  // D_S2EP(FD) grows monotonically with FD (the pupil moves by far less than FD does): bisect.
  double lo = lens.min_focus_mm, hi = lens.min_focus_mm;
  while (SubjectToPupilMm(lens, mount, hi) < d_s2ep_mm) hi *= 2;
  for (int it = 0; it < 200 && hi - lo > 1e-12 * hi; ++it) {
    const double mid = 0.5 * (lo + hi);
    (SubjectToPupilMm(lens, mount, mid) < d_s2ep_mm ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

double PrincipalDistanceMm(double f, double d) {
  RequirePositive("focal_length_mm", f);
  if (std::isinf(d) && d > 0) return f;
  if (std::isnan(d) || !(d > f)) {
    throw InvalidInput("subject_distance_mm", fmt::format("the subject ({:g} mm from the pupil) must lie beyond "
                                                          "the focal length ({:g} mm)", d, f));
  }
  return f * d / (d - f);
}

double ImageRadiusMm(const LensSpec& lens, double c_mm, double theta_rad) {
  return c_mm * camera::ProjectionRadius(lens.projection, theta_rad);
}

std::optional<double> FieldAngleRad(const LensSpec& lens, double c_mm, double r_mm) {
  return camera::ProjectionAngle(lens.projection, r_mm / c_mm);
}

LensSpec MountOn(const LensSpec& lens, const CameraBody& body, bool allow_adapter) {
  if (body.fixed_lens) {
    if (lens.name != body.fixed_lens->name) {
      throw InvalidInput("lens", fmt::format("the {} has a fixed lens ({}); it takes no other lens", body.name,
                                             body.fixed_lens->name));
    }
    return *body.fixed_lens;
  }
  const Mount& on = MountByName(body.mount);
  const Mount& own = MountByName(lens.mount);
  // The pupil's distance from the sensor, FFD + D_EP2F, is what the optical design fixes.
  auto moved = [&](double shift_mm, const std::string& note) {
    LensSpec out = lens;
    out.mount = body.mount;
    out.other_mounts.clear();
    for (PupilSample& p : out.pupil) p.d_ep2f_mm += shift_mm;
    if (!note.empty()) out.description += (out.description.empty() ? "" : "; ") + note;
    return out;
  };
  if (lens.mount == body.mount) return lens;
  if (lens.mount == "fixed" || body.mount == "fixed") {
    throw InvalidInput("lens", fmt::format("{} ({} mount) does not fit the {} ({} mount)", lens.name, lens.mount,
                                           body.name, body.mount));
  }
  for (const std::string& m : lens.other_mounts) {
    if (m == body.mount) return moved(own.flange_focal_distance_mm - on.flange_focal_distance_mm, "");
  }
  if (allow_adapter && own.flange_focal_distance_mm > on.flange_focal_distance_mm) {
    const double t = own.flange_focal_distance_mm - on.flange_focal_distance_mm;
    return moved(t, fmt::format("on a {} to {} adapter {:g} mm long", lens.mount, body.mount, t));
  }
  std::string why = fmt::format("{} is a {} lens, the {} has a {} mount", lens.name, lens.mount, body.name, body.mount);
  if (own.flange_focal_distance_mm > on.flange_focal_distance_mm) {
    why += fmt::format(" (an adapter {:g} mm long would fit it: set `allow_adapter`)",
                       own.flange_focal_distance_mm - on.flange_focal_distance_mm);
  } else {
    why += " (its flange focal distance is shorter than the body's: no adapter can focus it to infinity)";
  }
  throw InvalidInput("lens", why);
}

double DefaultFNumber(const LensSpec& l) {
  if (!(l.f_number_min > 0) || !(l.f_number_max >= l.f_number_min)) return kDefaultFNumber;
  return std::clamp(kDefaultFNumber, l.f_number_min, l.f_number_max);
}

void Validate(const LensSpec& l, const std::string& where) {
  RequirePositive(where + ".focal_length_mm", l.focal_length_mm);
  RequirePositive(where + ".f_number_min", l.f_number_min);
  RequirePositive(where + ".f_number_max", l.f_number_max);
  if (l.f_number_max < l.f_number_min) throw InvalidInput(where + ".f_number_max", "must be >= f_number_min");
  RequirePositive(where + ".min_focus_mm", l.min_focus_mm);
  MountByName(l.mount);
  for (const std::string& m : l.other_mounts) MountByName(m);
  if (l.pupil.empty()) throw InvalidInput(where + ".pupil", "needs at least one sample {focus_mm, d_ep2f_mm}");
  for (std::size_t k = 0; k < l.pupil.size(); ++k) {
    const auto& s = l.pupil[k];
    if (std::isnan(s.focus_mm) || !(s.focus_mm > 0)) throw InvalidInput(where + ".pupil.focus_mm", "must be > 0 or inf");
    RequireFinite(where + ".pupil.d_ep2f_mm", s.d_ep2f_mm);
    if (k > 0 && !(s.focus_mm < l.pupil[k - 1].focus_mm)) {
      throw InvalidInput(where + ".pupil", "samples must be sorted from far (inf) to near focus");
    }
  }
}

void Validate(const CameraBody& b, const std::string& where) {
  if (b.sensor.width_px <= 0 || b.sensor.height_px <= 0) throw InvalidInput(where + ".sensor", "pixel counts must be > 0");
  RequirePositive(where + ".pixel_pitch_mm", b.sensor.pixel_pitch_mm);
  MountByName(b.mount);
  if ((b.mount == "fixed") != b.fixed_lens.has_value()) {
    throw InvalidInput(where + ".mount", "a fixed-lens camera (mount \"fixed\") needs its [lens], and only it");
  }
  if (b.fixed_lens) Validate(*b.fixed_lens, where + ".lens");
}

}  // namespace porthole::lens
