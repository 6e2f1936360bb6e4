#include "porthole/camera/validate.h"

#include <fmt/format.h>

#include <cmath>
#include <optional>
#include <vector>

#include "porthole/core/error.h"

namespace porthole::camera {
namespace {

std::string Key(const ModelInfo& m, int i) { return std::string(m.params[i].json_key); }

// The 16 boundary pixels of the frame: corners, edge midpoints and quarter points (pixel centres).
std::vector<Eigen::Vector2d> BoundaryPixels(const Sensor& s) {
  const double w = s.width_px - 1.0, h = s.height_px - 1.0;
  std::vector<Eigen::Vector2d> b;
  for (int k = 0; k < 4; ++k) {
    const double t = k / 4.0;
    b.emplace_back(t * w, 0);
    b.emplace_back(w, t * h);
    b.emplace_back(w - t * w, h);
    b.emplace_back(0, h - t * h);
  }
  return b;
}

double AngleOffAxis(const Eigen::Vector3d& ray) { return std::atan2(std::hypot(ray(0), ray(1)), ray(2)); }

// The monotonic frame of ValidateCalibration, along the segment from the principal point to each
// boundary pixel b: pixel side, the rays of 64 pixels on the segment at increasing angles off axis;
// ray side (forward models, whose unprojection is an iteration), 64 rays at increasing angles up to
// b's project at increasing distances, the last onto b (not onto the near side of a fold).
void CheckMonotonicFrame(const Camera& cam, const std::string& where) {
  const ModelInfo& m = cam.info();
  const std::string key =
      where + "." + Key(m, m.first_distortion < m.num_params ? m.first_distortion : 0);
  const Eigen::Vector2d pp = cam.PrincipalPointPx();
  const int w = cam.sensor.width_px, h = cam.sensor.height_px;
  constexpr int kSteps = 64;
  for (const Eigen::Vector2d& b : BoundaryPixels(cam.sensor)) {
    const Eigen::Vector2d to_b = b - pp;
    if (to_b.norm() < 0.5) continue;  // the principal point on this boundary pixel
    double prev = 0;
    std::optional<Eigen::Vector3d> last;
    for (int j = 1; j <= kSteps; ++j) {
      const Eigen::Vector2d px = pp + to_b * (double(j) / kSteps);
      const auto ray = cam.Unproject(px);
      if (!ray || !ray->allFinite() || !(ray->norm() > 0)) {
        if (m.caps.fisheye) {  // outside a fisheye's image circle: the ray side checks up to 89°
          last.reset();
          break;
        }
        throw InvalidInput(key, fmt::format("the distortion folds the frame: pixel ({:.0f}, {:.0f}) of the {} x {} px "
                                            "image has no ray",
                                            px.x(), px.y(), w, h));
      }
      const double th = AngleOffAxis(*ray);
      if (!(th > prev)) {
        throw InvalidInput(key, fmt::format("the distortion folds the frame: toward pixel ({:.0f}, {:.0f}) the angle "
                                            "off axis stops growing at pixel ({:.0f}, {:.0f}), {:.1f} deg",
                                            b.x(), b.y(), px.x(), px.y(), th * 180 / M_PI));
      }
      prev = th;
      last = *ray;
    }
    // A correction-form model (Brown) unprojects in closed form, so the pixel side above is the
    // whole check; its projection is an iteration that may stop short of a ray the frame does have.
    if (m.caps.correction_form) continue;
    const double theta_end = last ? AngleOffAxis(*last) : 0.99 * M_PI / 2;
    const double phi = last ? std::atan2((*last)(1), (*last)(0)) : std::atan2(to_b.y(), to_b.x());
    prev = 0;
    for (int k = 1; k <= kSteps; ++k) {
      const double th = theta_end * k / kSteps;
      const Eigen::Vector3d d(std::sin(th) * std::cos(phi), std::sin(th) * std::sin(phi), std::cos(th));
      const auto uv = cam.Project(d);
      const double r = uv && uv->allFinite() ? (*uv - pp).norm() : NAN;
      if (std::isnan(r)) {
        throw InvalidInput(key, fmt::format("the distortion folds the frame toward pixel ({:.0f}, {:.0f}): the ray "
                                            "{:.1f} deg off axis has no image",
                                            b.x(), b.y(), th * 180 / M_PI));
      }
      if (!(r > prev)) {
        throw InvalidInput(key, fmt::format("the distortion folds the frame toward pixel ({:.0f}, {:.0f}): the image "
                                            "radius stops growing {:.1f} deg off axis, {:.0f} px from the principal "
                                            "point",
                                            b.x(), b.y(), th * 180 / M_PI, prev));
      }
      prev = r;
      if (k == kSteps && last && !((*uv - b).norm() <= 0.01 + 1e-6 * to_b.norm())) {
        throw InvalidInput(key, fmt::format("the distortion folds the frame: pixel ({:.0f}, {:.0f}) is the image of a "
                                            "ray beyond the fold, whose image on the near side is ({:.0f}, {:.0f})",
                                            b.x(), b.y(), (*uv)(0), (*uv)(1)));
      }
    }
  }
}

}  // namespace

void ValidateCalibration(const Camera& cam, const std::string& where) {
  try {
    ValidateSensor(cam.sensor);
  } catch (const InvalidInput& e) {
    throw InvalidInput(where + ".sensor." + e.field(), std::string(e.what()).substr(e.field().size() + 2));
  }
  const ModelInfo& m = cam.info();
  if (static_cast<int>(cam.params.size()) != m.num_params) {
    throw InvalidInput(where, fmt::format("model {} has {} parameters, got {}", m.name, m.num_params,
                                          cam.params.size()));
  }
  for (int i = 0; i < m.num_params; ++i) RequireFinite(where + "." + Key(m, i), cam.params[i]);
  for (int i = 0; i < m.num_focal; ++i) {
    if (!(cam.params[i] > 0)) {
      throw InvalidInput(where + "." + Key(m, i), fmt::format("a focal length must be > 0, got {:g}", cam.params[i]));
    }
  }
  const Eigen::Vector2d pp = cam.PrincipalPointPx();
  const Sensor& s = cam.sensor;
  if (!(pp.x() >= -0.5 && pp.x() <= s.width_px - 0.5 && pp.y() >= -0.5 && pp.y() <= s.height_px - 0.5)) {
    throw InvalidInput(where + "." + Key(m, m.num_focal),
                       fmt::format("the principal point ({:.1f}, {:.1f}) px lies outside the {} x {} px image", pp.x(),
                                   pp.y(), s.width_px, s.height_px));
  }
  CheckMonotonicFrame(cam, where);
}

void CheckCalibrationFits(const Camera& cal, bool pitch_known, const ExpectedCamera& e, const std::string& field) {
  const Sensor& s = cal.sensor;
  const double pitch = e.sensor.pixel_pitch_mm;
  const bool size_differs =
      e.size_estimated
          ? !(std::abs(double(s.width_px) / e.sensor.width_px - 1) <= kEstimatedSizeTolerance &&
              std::abs(double(s.height_px) / e.sensor.height_px - 1) <= kEstimatedSizeTolerance)
          : s.width_px != e.sensor.width_px || s.height_px != e.sensor.height_px;
  if (size_differs) {
    const bool turned = s.width_px == e.sensor.height_px && s.height_px == e.sensor.width_px;
    throw InvalidInput(field, fmt::format("is a calibration of {} x {} px images; the {} takes {} x {} px{}{}",
                                          s.width_px, s.height_px, e.name, e.sensor.width_px, e.sensor.height_px,
                                          e.size_estimated ? fmt::format(" (estimated at {:g} mm: {:.1f} x {:.1f} mm)",
                                                                         pitch, e.sensor.width_px * pitch,
                                                                         e.sensor.height_px * pitch)
                                                           : "",
                                          turned ? " (the calibration is of turned images)" : ""));
  }
  if (pitch_known && !(std::abs(s.pixel_pitch_mm / e.sensor.pixel_pitch_mm - 1) <= kPixelPitchTolerance)) {
    throw InvalidInput(field, fmt::format("has pixel pitch {:g} mm{}; the {} has {:g} mm", s.pixel_pitch_mm,
                                          s.pixel_pitch_mm == 1
                                              ? fmt::format(" (pitch 1: its millimetres are pixels: calibrated in "
                                                            "pixels; calibrate it again with the pixel pitch, {:g} mm)",
                                                            e.sensor.pixel_pitch_mm)
                                              : "",
                                          e.name, e.sensor.pixel_pitch_mm));
  }
  if (!(e.focal_length_mm > 0)) return;  // no lens to compare with
  const double f_px = cal.FocalLengthPx();
  const double c_mm = f_px * e.sensor.pixel_pitch_mm;
  const double lo = e.focal_length_mm * (1 - kFocalLengthTolerance);
  const double hi = std::max(e.max_principal_distance_mm, e.focal_length_mm) * (1 + kFocalLengthTolerance);
  if (!(c_mm >= lo && c_mm <= hi)) {
    throw InvalidInput(field, fmt::format("has focal length {:.4g} mm ({:.5g} px x {:g} mm); the {} gives {:.4g} to "
                                          "{:.4g} mm (f = {:g} mm from infinity to its closest focus, {:.0f} % either "
                                          "side): a calibration of another lens{}",
                                          c_mm, f_px, e.sensor.pixel_pitch_mm, e.name, lo, hi, e.focal_length_mm,
                                          100 * kFocalLengthTolerance, pitch_known ? "" : " or another pixel pitch"));
  }
}

void RequirePossibleResult(const Camera& cam, std::optional<double> rms_px, const std::string& field,
                           const std::string& what) {
  const ModelInfo& m = cam.info();
  if (static_cast<int>(cam.params.size()) != m.num_params) {
    throw InternalError(what + ": " + std::string(m.name) + " camera with a wrong parameter count");
  }
  for (int i = 0; i < m.num_params; ++i) {
    const double v = cam.params[i];
    if (!std::isfinite(v)) throw InvalidInput(field, fmt::format("{} is impossible: {} is not finite", what, Key(m, i)));
    if (i < m.num_focal && !(v > 0)) {
      throw InvalidInput(field, fmt::format("{} is impossible: focal length {} = {:g}, not > 0", what, Key(m, i), v));
    }
  }
  if (rms_px && !(std::isfinite(*rms_px) && *rms_px >= 0)) {
    throw InvalidInput(field, fmt::format("{} is impossible: its RMS is {}", what, *rms_px));
  }
}

}  // namespace porthole::camera
