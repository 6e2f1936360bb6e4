// The whole system (focus, pupil, c), the prediction, the sweeps and the maps of simulate.h.
#include <cmath>
#include <string>

#include <fmt/format.h>

#include "porthole/core/error.h"
#include "porthole/housing/plausible.h"
#include "porthole/ports/virtual_image.h"
#include "porthole/simulate/simulate.h"

namespace porthole::simulate {
namespace {

camera::BrownParams Subtract(const camera::BrownParams& a, const camera::BrownParams& b) {
  const auto x = a.ToArray(), y = b.ToArray();
  std::array<double, camera::kBrownNumParams> d;
  for (int i = 0; i < camera::kBrownNumParams; ++i) d[i] = x[i] - y[i];
  return camera::BrownParams::FromArray(d.data());
}

camera::BrownParams Add(const camera::BrownParams& a, const camera::BrownParams& b) {
  const auto x = a.ToArray(), y = b.ToArray();
  std::array<double, camera::kBrownNumParams> d;
  for (int i = 0; i < camera::kBrownNumParams; ++i) d[i] = x[i] + y[i];
  return camera::BrownParams::FromArray(d.data());
}

// The fit as a camera, checked possible (camera::RequirePossibleResult).
void RequirePossible(const BrownFit& f, const camera::Sensor& s, const std::string& what) {
  camera::RequirePossibleResult(camera::FromBrown(f.params, s), f.rms_um / 1000 / s.pixel_pitch_mm, "fit", what);
}
void RequirePossible(const CameraFit& f, const std::string& what) {
  camera::RequirePossibleResult(f.camera, f.rms_px, "fit", what);
}

}  // namespace

camera::ExpectedCamera ExpectedCameraOf(const housing::HousedCamera& h) {
  camera::ExpectedCamera e;
  e.name = h.camera.name + " + " + h.lens.name;
  e.sensor = h.camera.sensor;
  e.size_estimated = h.camera.source.find("lensfun") != std::string::npos;  // io/lookup.cc: crop factor, pitch
  const double f = h.lens.focal_length_mm;
  e.focal_length_mm = f;
  e.max_principal_distance_mm = 2 * f;
  try {
    const double d = lens::SubjectToPupilMm(h.lens, housing::MountOf(h), h.lens.min_focus_mm);
    const double c = lens::PrincipalDistanceMm(f, d);
    if (std::isfinite(c) && c >= f) e.max_principal_distance_mm = c;
  } catch (const InvalidInput&) {  // no closest focus known, or closer than the thin lens reaches
  }
  return e;
}

void CheckAirCalibration(const camera::Camera& calibration, bool pitch_known, const housing::HousedCamera& h,
                         const std::string& field) {
  // Whether it is of this camera first (one line naming both values), then whether it is valid.
  camera::ValidateCamera(calibration, field);
  camera::CheckCalibrationFits(calibration, pitch_known, ExpectedCameraOf(h), field);
  camera::ValidateCalibration(calibration, field);
}

housing::FocusSetting FocusUnderWater(const SystemSpec& spec) {
  return housing::FocusOnSubject(spec, spec.object_distance_mm).focus;
}

Prediction Predict(const SystemSpec& spec, const FitOptions& options) {
  const housing::Focused focused = housing::FocusOnSubject(spec, spec.object_distance_mm);
  Prediction p;
  p.object_distance_mm = spec.object_distance_mm;
  p.focus = focused.focus;
  p.wd_mm = spec.object_distance_mm - housing::PupilToOuterMm(focused.sys);
  p.options = options;
  p.options.reference_distance_mm = spec.object_distance_mm;
  Validate(p.options);
  p.camera.sensor = spec.camera.sensor;
  p.camera.ep_in_housing_mm = p.focus.ep_in_housing_mm;
  const bool fisheye = camera::IsFisheye(spec.lens.projection);
  p.lens_projection = spec.lens.projection;
  p.lens = spec.lens;
  p.warnings = housing::PlausibilityWarnings(spec);
  if (spec.air_calibration && fisheye) {
    throw InvalidInput("air_calibration", "is a Brown calibration; the " + spec.lens.name + " is a " +
                                              std::string(camera::ProjectionName(spec.lens.projection)) +
                                              " fisheye, which Brown cannot describe");
  }
  if (spec.air_fisheye_calibration && !fisheye) {
    throw InvalidInput("air_calibration", "is a " + std::string(spec.air_fisheye_calibration->model_name()) +
                                              " calibration; the " + spec.lens.name +
                                              " is rectilinear (give a Brown calibration)");
  }
  if (spec.air_fisheye_calibration) {
    CheckAirCalibration(*spec.air_fisheye_calibration, /*pitch_known=*/false, spec, "air_calibration");
    if (spec.air_fisheye_calibration->model == camera::CameraModelId::kBrown) {
      throw InvalidInput("air_calibration", "is a Brown calibration; the " + spec.lens.name +
                                                " is a fisheye (give a Kannala-Brandt calibration)");
    }
    p.air_fisheye_calibration = *spec.air_fisheye_calibration;
    p.air_fisheye_calibration->sensor = spec.camera.sensor;
    p.camera.lens.c_mm = p.air_fisheye_calibration->FocalLengthPx() * spec.camera.sensor.pixel_pitch_mm;
  } else if (spec.air_calibration) {
    // Brown parameters hold no sensor: checked on the body's (c in mm against the lens's).
    CheckAirCalibration(camera::FromBrown(*spec.air_calibration, spec.camera.sensor), /*pitch_known=*/false, spec,
                        "air_calibration");
    p.camera.lens = *spec.air_calibration;
  } else {
    p.camera.lens.c_mm =
        spec.c_mm ? RequirePositive("c_mm", *spec.c_mm)
                  : lens::PrincipalDistanceMm(spec.lens.focal_length_mm, p.focus.d_s2ep_mm);
  }
  camera::ValidateBrownParams(p.camera.lens);
  p.water_system = focused.sys;
  p.air_system = WithAirOutside(p.water_system);
  if (fisheye) {
    // The lens's own projection in air (or its in-air calibration); the fisheye model of the list
    // (or the calibration's) fitted in water and in air.
    const camera::Camera* cal = p.air_fisheye_calibration ? &*p.air_fisheye_calibration : nullptr;
    const camera::CameraModelId model = cal ? cal->model : camera::CameraModelId::kKannalaBrandt;
    p.water_fisheye =
        SimulateCameraFit(p.water_system, spec.lens, p.camera.sensor, p.camera.lens.c_mm, model, p.options, cal);
    p.air_fisheye =
        SimulateCameraFit(p.air_system, spec.lens, p.camera.sensor, p.camera.lens.c_mm, model, p.options, cal);
    RequirePossible(*p.water_fisheye, "the water fit");
    RequirePossible(*p.air_fisheye, "the air fit");
    if (cal) {
      camera::Camera predicted = *cal;
      for (std::size_t i = 0; i < predicted.params.size(); ++i) {
        predicted.params[i] += p.water_fisheye->camera.params[i] - p.air_fisheye->camera.params[i];
      }
      p.predicted_water_fisheye = predicted;
    }
    return p;
  }
  p.water = SimulateFit(p.water_system, p.camera, p.options);
  p.air = SimulateFit(p.air_system, p.camera, p.options);
  RequirePossible(p.water, p.camera.sensor, "the water fit");
  RequirePossible(p.air, p.camera.sensor, "the air fit");
  p.change = Subtract(p.water.params, p.air.params);
  if (spec.air_calibration) p.predicted_water = Add(*spec.air_calibration, p.change);
  return p;
}

std::vector<SweepRow> SweepPupilOffset(const Prediction& prediction, int axis,
                                       const std::vector<double>& offsets_mm) {
  if (axis < 0 || axis > 2) throw InvalidInput("axis", "must be 0 (X), 1 (Y) or 2 (Z)");
  std::vector<SweepRow> rows;
  for (double offset : offsets_mm) {
    RequireFinite("offset_mm", offset);
    CameraSetup cam = prediction.camera;
    cam.ep_in_housing_mm(axis) += offset;
    const ports::PortSystem& w = prediction.water_system;
    const ports::PortSystem water = ports::Place(w.spec, cam.ep_in_housing_mm, w.n_glass, w.n_water);
    SweepRow row;
    row.offset_mm = offset;
    row.lens_projection = prediction.lens_projection;
    if (prediction.water_fisheye) {
      const camera::CameraModelId model = prediction.water_fisheye->camera.model;
      const double c = prediction.camera.lens.c_mm;
      const camera::Camera* cal = prediction.air_fisheye_calibration ? &*prediction.air_fisheye_calibration : nullptr;
      row.water_fisheye = SimulateCameraFit(water, prediction.lens, cam.sensor, c, model, prediction.options, cal);
      row.air_fisheye =
          SimulateCameraFit(WithAirOutside(water), prediction.lens, cam.sensor, c, model, prediction.options, cal);
      RequirePossible(*row.water_fisheye, fmt::format("the water fit at offset {:g} mm", offset));
      RequirePossible(*row.air_fisheye, fmt::format("the air fit at offset {:g} mm", offset));
    } else {
      row.water = SimulateFit(water, cam, prediction.options);
      row.air = SimulateFit(WithAirOutside(water), cam, prediction.options);
      RequirePossible(row.water, cam.sensor, fmt::format("the water fit at offset {:g} mm", offset));
      RequirePossible(row.air, cam.sensor, fmt::format("the air fit at offset {:g} mm", offset));
    }
    rows.push_back(std::move(row));
  }
  return rows;
}

std::vector<MapPoint> DistortionMap(const Prediction& prediction) {
  const FitOptions& o = prediction.options;
  const camera::Sensor& s = prediction.camera.sensor;
  const auto grid = ImageGrid(s, o.grid_cols, o.grid_rows);
  const FitView water = prediction.water_view(), air = prediction.air_view();
  std::vector<MapPoint> out;
  out.reserve(grid.size());
  for (std::size_t i = 0; i < grid.size(); ++i) {
    MapPoint m;
    m.x_mm = grid[i](0);
    m.y_mm = grid[i](1);
    const Eigen::Vector2d uv = camera::ImageMmToPixel(s, m.x_mm, m.y_mm);
    m.u_px = uv(0);
    m.v_px = uv(1);
    m.water_um = 1000 * water.CorrectionMm(m.x_mm, m.y_mm);
    m.air_um = 1000 * air.CorrectionMm(m.x_mm, m.y_mm);
    m.difference_um = m.water_um - m.air_um;
    m.residual_um = water.ResidualUm(i);
    out.push_back(m);
  }
  return out;
}

}  // namespace porthole::simulate
