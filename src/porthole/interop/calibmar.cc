// calibmar's calibration.yaml (format calibmar): a COLMAP camera (colmap.cc's models) with its σ
// ("# params_est_std_dev") and the refractive housing of its non_svp_model (FLATPORT / DOMEPORT),
// as calibmar (MDSKiel/calibmar, src/calibmar/core/report.cpp) writes it; docs/interop.md,
// "Refractive COLMAP and calibmar". The YAML
// itself and the housing are read and written by interop/refractive.h.
#include <cmath>
#include <string>

#include "porthole/interop/interop.h"
#include "porthole/interop/internal.h"
#include "porthole/interop/refractive.h"

namespace porthole::interop::detail {

ReadResult ReadCalibmarFile(const std::string& content, const ReadArgs& args) {
  const CalibmarFile f = ParseCalibmarYaml(content, args.field);
  ReadResult r;
  r.format = args.format;
  r.format_model = f.camera.model;
  r.housing = f.housing;
  r.file_rms_px = f.overall_rms_px;
  const camera::Camera cam = FromColmap(f.camera, args.pixel_pitch_mm, args.field);
  if (f.camera_sigma.empty()) {
    r.calibration = WithoutSigma(cam, "σ unknown: the calibmar file has no # params_est_std_dev");
    return r;
  }
  r.calibration.camera = cam;
  r.calibration.covariance = ColmapSigmaToCovariance(f.camera, f.camera_sigma);
  r.calibration.free.assign(cam.params.size(), false);
  bool known = true;  // "nan" in the file: that parameter adjusted, its σ unknown
  for (std::size_t i = 0; i < cam.params.size(); ++i) {
    const double v = r.calibration.covariance(i, i);
    r.calibration.free[i] = v > 0 || std::isnan(v);
    known = known && !std::isnan(v);
  }
  r.calibration.has_covariance = known;
  r.calibration.covariance_note =
      known ? "diagonal from sigma" : "σ unknown: nan in the calibmar file's # params_est_std_dev";
  return r;
}

WriteResult WriteCalibmarFile(const calib::CalibrationRecord& cal, Format /*format*/, const std::string& field,
                              const WriteExtras& extras) {
  const PixelCalibration pc = ToPixelFamily(cal, field);  // Brown: refit to opencv
  WriteResult w;
  w.exact = pc.exact;
  w.fit = pc.fit;
  CalibmarFile f;
  f.camera = ToColmap(pc.cal.camera, field);
  if (pc.cal.has_covariance) f.camera_sigma = CovarianceToColmapSigma(f.camera, pc.cal.covariance);
  f.housing = extras.housing;
  w.content = CalibmarYaml(f);
  w.format_model = f.camera.model;
  w.sigma_written = !f.camera_sigma.empty();
  return w;
}

}  // namespace porthole::interop::detail
