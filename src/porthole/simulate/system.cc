// The whole system (focus, pupil, c), the prediction, the sweeps and the maps of simulate.h.
#include <cmath>
#include <string>

#include <fmt/format.h>

#include "porthole/core/error.h"
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

// The port in the housing frame. A port written in the cam frame (an ideal port centred on
// whatever lens is used) is centred on the lens's own pupil, so that the offset moves the pupil
// relative to the port rather than carrying the port along.
ports::PortSpec PortInHousing(const ports::PortSpec& port, const Vec3& nominal_ep) {
  if (port.frame == ports::PortFrame::kHousing) return port;
  return ports::Place(port, nominal_ep, 1.5, 1.34).spec;  // indices unused: only the geometry
}

}  // namespace

FocusSetting FocusUnderWater(const SystemSpec& spec) {
  const double object = RequirePositive("--focus-distance", spec.object_distance_mm);
  if (!spec.ep_offset_mm.allFinite()) throw InvalidInput("--ep-offset", "must be finite numbers");
  lens::Validate(spec.lens);
  const lens::Mount& mount = lens::MountByName(spec.lens.mount);
  FocusSetting f;
  f.object_distance_mm = object;
  // Start with the pupil at infinity focus; each pass moves it to where the focus for the object's
  // virtual image puts it. The pupil moves ~2 mm over the whole focus range, so this converges in
  // a few passes.
  f.d_ep2f_mm = spec.lens.PupilToFlangeMm(std::numeric_limits<double>::infinity());
  for (int it = 0; it < 50; ++it) {
    f.ep_in_housing_mm = Vec3(0, 0, f.d_ep2f_mm) + spec.ep_offset_mm;
    const ports::PortSystem sys = ports::MakeSystem(
        PortInHousing(spec.port, Vec3(0, 0, f.d_ep2f_mm)), spec.env, f.ep_in_housing_mm);
    f.wd_mm = object - (sys.OuterVertexZ() - f.ep_in_housing_mm.z());
    if (!(f.wd_mm > 0)) {
      throw InvalidInput("--focus-distance", "the object lies inside the port (" +
                                                 fmt::format("{:.1f}", object) + " mm)");
    }
    f.d_s2ep_mm = ports::ParaxialVirtualImage(sys, f.wd_mm).d_s2ep_mm;
    const auto fd = lens::FocusForSubjectMm(spec.lens, mount, f.d_s2ep_mm);
    if (!fd) {
      throw InvalidInput("--focus-distance",
                         fmt::format("the virtual image of an object {:.0f} mm away is {:.1f} mm "
                                     "from the pupil; the {} focuses no closer than {:.1f} mm",
                                     object, f.d_s2ep_mm, spec.lens.name,
                                     lens::SubjectToPupilMm(spec.lens, mount, spec.lens.min_focus_mm)));
    }
    f.fd_mm = *fd;
    const double d_ep2f = spec.lens.PupilToFlangeMm(f.fd_mm);
    const bool done = std::abs(d_ep2f - f.d_ep2f_mm) < 1e-10;
    f.d_ep2f_mm = d_ep2f;
    if (done) break;
  }
  f.ep_in_housing_mm = Vec3(0, 0, f.d_ep2f_mm) + spec.ep_offset_mm;
  return f;
}

double ThinLensPrincipalDistanceMm(double focal_length_mm, double d_s2ep_mm) {
  RequirePositive("focal_length_mm", focal_length_mm);
  if (std::isinf(d_s2ep_mm)) return focal_length_mm;
  if (!(d_s2ep_mm > focal_length_mm)) {
    throw InvalidInput("focus", "the subject must lie beyond the focal length");
  }
  return focal_length_mm * d_s2ep_mm / (d_s2ep_mm - focal_length_mm);
}

Prediction Predict(const SystemSpec& spec, const FitOptions& options) {
  lens::Validate(spec.body);
  Prediction p;
  p.focus = FocusUnderWater(spec);
  p.options = options;
  p.options.reference_distance_mm = spec.object_distance_mm;
  Validate(p.options);
  p.camera.sensor = spec.body.sensor;
  p.camera.ep_in_housing_mm = p.focus.ep_in_housing_mm;
  if (spec.air_calibration) {
    p.camera.lens = *spec.air_calibration;
  } else {
    p.camera.lens.c_mm =
        spec.c_mm ? RequirePositive("--c", *spec.c_mm)
                  : ThinLensPrincipalDistanceMm(spec.lens.focal_length_mm, p.focus.d_s2ep_mm);
  }
  camera::ValidateBrownParams(p.camera.lens);
  p.water_system = ports::MakeSystem(PortInHousing(spec.port, Vec3(0, 0, p.focus.d_ep2f_mm)),
                                     spec.env, p.camera.ep_in_housing_mm);
  p.air_system = WithAirOutside(p.water_system);
  p.water = SimulateFit(p.water_system, p.camera, p.options);
  p.air = SimulateFit(p.air_system, p.camera, p.options);
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
    row.water = SimulateFit(water, cam, prediction.options);
    row.air = SimulateFit(WithAirOutside(water), cam, prediction.options);
    rows.push_back(std::move(row));
  }
  return rows;
}

std::vector<MapPoint> DistortionMap(const Prediction& prediction) {
  const FitOptions& o = prediction.options;
  const camera::Sensor& s = prediction.camera.sensor;
  const auto grid = ImageGrid(s, o.grid_cols, o.grid_rows);
  std::vector<MapPoint> out;
  out.reserve(grid.size());
  for (std::size_t i = 0; i < grid.size(); ++i) {
    MapPoint m;
    m.x_mm = grid[i](0);
    m.y_mm = grid[i](1);
    const Eigen::Vector2d uv = camera::ImageMmToPixel(s, m.x_mm, m.y_mm);
    m.u_px = uv(0);
    m.v_px = uv(1);
    m.water_um = 1000 * camera::Correction(prediction.water.params, m.x_mm, m.y_mm);
    m.air_um = 1000 * camera::Correction(prediction.air.params, m.x_mm, m.y_mm);
    m.difference_um = m.water_um - m.air_um;
    m.residual_um = i < prediction.water.residual_um.size() ? prediction.water.residual_um[i]
                                                            : std::nan("");
    out.push_back(m);
  }
  return out;
}

}  // namespace porthole::simulate
