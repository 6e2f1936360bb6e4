// What the single-camera formats of interop.h share, inside the library only: the format list's
// reader and writer signatures, each format's reader and writer (one .cc a format: porthole_json.cc,
// opencv_storage.cc, colmap.cc, mrcal.cc, metashape.cc, calibmar.cc), and the refits with σ they
// go through (refit.cc; the templates here, as the Metashape adapter instantiates them with its own
// projector). Not installed, not for the front ends.
#pragma once

#include <fmt/format.h>

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <initializer_list>
#include <string>
#include <string_view>
#include <vector>

#include "porthole/calib/result_json.h"
#include "porthole/camera/camera.h"
#include "porthole/interop/interop.h"
#include "porthole/interop/refit.h"

namespace porthole::interop::detail {

// ---- The format list (interop.cc's kFormats) ----

// What a reader gets besides the file's text.
struct ReadArgs {
  Format format;
  double pixel_pitch_mm = 1.0;  // pixel formats carry no pitch (> 0)
  std::string field;            // names the file in errors
  int camera_id = 0;            // COLMAP: the camera of a file holding several (0: the only one)
  std::string origin;           // porthole JSON: the file naming the line of a bad value ("file:N:")
};
// A reader returns the calibration with its σ where the format holds one, else NoSigmaRecord's
// (unknown); ReadCalibration validates what it returns (unless the list says the reader does).
using Reader = ReadResult (*)(const std::string& content, const ReadArgs& args);
// A writer gets a valid calibration (WriteCalibration checked it).
using Writer = WriteResult (*)(const calib::CalibrationRecord& cal, Format format, const std::string& field,
                               const WriteExtras& extras);

// porthole_json.cc
ReadResult ReadPortholeJson(const std::string& content, const ReadArgs& args);
WriteResult WritePortholeJson(const calib::CalibrationRecord& cal, Format format, const std::string& field,
                              const WriteExtras& extras);
// opencv_storage.cc (opencv-yaml and opencv-xml)
ReadResult ReadOpenCVStorageFile(const std::string& content, const ReadArgs& args);
WriteResult WriteOpenCVStorageFile(const calib::CalibrationRecord& cal, Format format, const std::string& field,
                                   const WriteExtras& extras);
// colmap.cc (colmap and colmap-bin)
ReadResult ReadColmapFile(const std::string& content, const ReadArgs& args);
WriteResult WriteColmapFile(const calib::CalibrationRecord& cal, Format format, const std::string& field,
                            const WriteExtras& extras);
// COLMAP's cameras.txt lines (also DetectInputFormat's last guess). Throws InvalidInput.
std::vector<ColmapCamera> ParseColmapText(const std::string& text, const std::string& field);
// mrcal.cc
ReadResult ReadMrcalFile(const std::string& content, const ReadArgs& args);
WriteResult WriteMrcalFile(const calib::CalibrationRecord& cal, Format format, const std::string& field,
                           const WriteExtras& extras);
// metashape.cc
ReadResult ReadMetashapeFile(const std::string& content, const ReadArgs& args);
WriteResult WriteMetashapeFile(const calib::CalibrationRecord& cal, Format format, const std::string& field,
                               const WriteExtras& extras);
// calibmar.cc
ReadResult ReadCalibmarFile(const std::string& content, const ReadArgs& args);
WriteResult WriteCalibmarFile(const calib::CalibrationRecord& cal, Format format, const std::string& field,
                              const WriteExtras& extras);

// ---- Small pieces the formats share ----

inline camera::Sensor PixelSensor(int w, int h, double pitch_mm) { return {w, h, pitch_mm}; }

// A camera of the opencv model with these parameters (missing trailing ones 0).
inline camera::Camera OpenCVCamera(const camera::Sensor& s, std::initializer_list<double> p) {
  camera::Camera c{camera::CameraModelId::kOpenCV, s, std::vector<double>(camera::OpenCVModel::kNumParams, 0.0)};
  std::copy(p.begin(), p.end(), c.params.begin());
  return c;
}

// 17 significant digits: reads back exactly.
inline std::string Num(double v) { return fmt::format("{:.17g}", v); }
// The shortest text that reads back exactly (calibmar's and the port TOML's numbers).
inline std::string ShortNum(double v) { return fmt::format("{}", v); }

// Refractive COLMAP's housing parameters in its order (interop.h's RefractiveHousing), as calibmar
// names them in its comment line.
inline constexpr std::array<std::string_view, 8> kFlatPortNames = {"Nx", "Ny", "Nz", "int_dist", "int_thick",
                                                                   "na", "ng", "nw"};
inline constexpr std::array<std::string_view, 8> kDomePortNames = {"Cx", "Cy", "Cz", "int_radius", "int_thick",
                                                                   "na", "ng", "nw"};

// What a format without σ gives: WithoutSigma with the note "σ unknown: <format> holds none".
calib::CalibrationRecord NoSigmaRecord(const camera::Camera& cam, Format format);

// Throws InvalidInput(field, "the <model> model has no <format> equivalent (<hint>)").
[[noreturn]] void NoRepresentation(const camera::Camera& cam, std::string_view format, const std::string& field,
                                   std::string_view hint);

// ---- Conversions with σ (refit.cc; interop/refit.h has the dense refit) ----

// A refit's result is written or used only when possible (camera::RequirePossibleResult), valid as
// a calibration (camera::ValidateCalibration: what a reader refuses is never written) and close to
// the camera it replaces: RMS at most kMaxRefitRmsPx over the image.
void CheckRefit(const camera::Camera& result, const camera::ConversionFit& fit, const std::string& field);

// n flags, the first `count` true.
inline std::vector<bool> FreeFirst(int n, int count) {
  std::vector<bool> f(n, false);
  std::fill(f.begin(), f.begin() + count, true);
  return f;
}

// A calibration in the model family the pixel formats share: Brown refit to opencv (over the
// image, camera::BrownToOpenCV); equidistant as kannala-brandt (exact); opencv and kannala-brandt
// unchanged. σ carried through.
struct PixelCalibration {
  calib::CalibrationRecord cal;
  bool exact = true;
  camera::ConversionFit fit;
};
PixelCalibration ToPixelFamily(const calib::CalibrationRecord& in, const std::string& field);

// q's adjusted parameters and covariance from p's, by the pixel Jacobians of both models over
// `rays`: a q parameter is adjusted when it is free in the conversion and moves with an adjusted p
// parameter (its share of the pixel motion above 1e-9). Σp unknown (NaN) stays unknown.
template <typename Src, typename Dst>
void CarrySigma(const Src& src, const std::vector<double>& p, const calib::FreeMask& adjusted_p,
                const Eigen::MatrixXd& cov_p, const Dst& dst, const std::vector<double>& q,
                const std::vector<bool>& free_q, const std::vector<Eigen::Vector3d>& rays,
                calib::CalibrationRecord* out) {
  const Eigen::MatrixXd jp = refit::PixelJacobian(src, p, rays);
  const Eigen::MatrixXd jq = refit::PixelJacobian(dst, q, rays);
  Eigen::MatrixXd sp = Eigen::MatrixXd::Zero(Src::kNumParams, Src::kNumParams);
  for (int i = 0; i < Src::kNumParams; ++i) {
    for (int j = 0; j < Src::kNumParams; ++j) {
      if (adjusted_p[i] && adjusted_p[j]) sp(i, j) = cov_p(i, j);
    }
  }
  const auto prop = refit::PropagateCovariance(jq, free_q, jp, sp);
  out->free.assign(Dst::kNumParams, false);
  for (int a = 0; a < Dst::kNumParams; ++a) {
    for (int j = 0; j < Src::kNumParams && free_q[a]; ++j) {
      const double share = jq.col(a).norm() * std::abs(prop.g(a, j)) / std::max(jp.col(j).norm(), 1e-300);
      if (adjusted_p[j] && share > 1e-9) out->free[a] = true;
    }
  }
  // A q parameter the adjusted ones determine exactly (Metashape's b1 = fx − fy of a camera with
  // one focal length adjusted) has its variance cancel: not adjusted.
  for (int a = 0; a < Dst::kNumParams; ++a) {
    double parts = 0;
    for (int j = 0; j < Src::kNumParams; ++j) parts += prop.g(a, j) * prop.g(a, j) * sp(j, j);
    if (out->free[a] && std::isfinite(parts) && prop.covariance(a, a) <= 1e-12 * parts) out->free[a] = false;
  }
  out->covariance = Eigen::MatrixXd::Zero(Dst::kNumParams, Dst::kNumParams);
  bool finite = true;
  for (int a = 0; a < Dst::kNumParams; ++a) {
    for (int b = 0; b < Dst::kNumParams; ++b) {
      if (!out->free[a] || !out->free[b]) continue;
      out->covariance(a, b) = prop.covariance(a, b);
      finite = finite && std::isfinite(prop.covariance(a, b));
    }
  }
  out->has_covariance = finite && std::find(out->free.begin(), out->free.end(), true) != out->free.end();
}

// The record converted from `src` (parameters p of the record `in`) to the list model M: q starts
// at `start` (the closed form); q's `free_q` parameters are refit over the image
// so that M reprojects src's pixels (`refit_q`; false: start is exact, or already a refit). Rays from `start`'s unprojection of a 40 × 30 pixel grid.
template <typename M, typename Src>
calib::CalibrationRecord ConvertTo(const Src& src, const std::vector<double>& p, const calib::FreeMask& adjusted_p,
                                   const Eigen::MatrixXd& cov_p, const calib::CalibrationRecord& in,
                                   const camera::Camera& start, const std::vector<bool>& free_q, bool refit_q,
                                   camera::ConversionFit* fit) {
  const auto rays = refit::GridRays(start.sensor, [&](const Eigen::Vector2d& uv) { return start.Unproject(uv); });
  calib::CalibrationRecord out = in;
  out.camera = start;
  const refit::ListProjector<M> dst{start.sensor};
  if (refit_q) {
    const refit::ProjectedRays data = refit::ProjectRays(src, p, rays);
    const camera::ConversionFit f = refit::Fit(dst, &out.camera.params, free_q, data.rays, data.px);
    if (fit != nullptr) *fit = f;
    CheckRefit(out.camera, f, "refit");
  } else if (fit != nullptr) {
    *fit = {};
  }
  CarrySigma(src, p, adjusted_p, cov_p, dst, out.camera.params, free_q, rays, &out);
  if (!in.has_covariance) {  // unknown stays unknown
    out.has_covariance = false;
    for (int a = 0; a < M::kNumParams; ++a) {
      for (int b = 0; b < M::kNumParams; ++b) {
        if (out.free[a] && out.free[b]) out.covariance(a, b) = NAN;
      }
    }
  }
  return out;
}

}  // namespace porthole::interop::detail
