// Conversions between camera models that carry σ (interop.h's ConvertCalibration, WithoutSigma;
// docs/interop.md, "What is exact and what is refit"): the closed forms and dense refits
// (camera::BrownToOpenCV / OpenCVToBrown, interop/refit.h) with the covariance propagated through
// the conversion's Jacobian, and the pixel-format family every pixel format is written from
// (ToPixelFamily, interop/internal.h).
#include <fmt/format.h>

#include <cmath>

#include "porthole/camera/validate.h"
#include "porthole/core/error.h"
#include "porthole/interop/interop.h"
#include "porthole/interop/internal.h"
#include "porthole/interop/refit.h"

namespace porthole::interop {
namespace detail {

using camera::Camera;
using camera::CameraModelId;
using OpenCV = camera::OpenCVModel;
using KB = camera::KannalaBrandtModel;

void CheckRefit(const Camera& result, const camera::ConversionFit& fit, const std::string& field) {
  const std::string what = fmt::format("the refit to the {} model", result.model_name());
  camera::RequirePossibleResult(result, fit.rms_px, field, what);
  if (fit.rms_px > kMaxRefitRmsPx) {
    throw InvalidInput(field, fmt::format("{} misses the camera by RMS {:.3g} px (max {:.3g} px) over the image, above "
                                          "the {:g} px a conversion may differ: the {} model cannot hold this camera",
                                          what, fit.rms_px, fit.max_px, kMaxRefitRmsPx, result.model_name()));
  }
  try {
    camera::ValidateCalibration(result, "refit");
  } catch (const InvalidInput& e) {
    throw InvalidInput(field, what + " is not a valid calibration: " + e.what());
  }
}

namespace {

// A list model's record as its projector's inputs.
template <typename M>
calib::CalibrationRecord FromListModel(const calib::CalibrationRecord& in, const Camera& start,
                                       const std::vector<bool>& free_q, bool refit_q,
                                       camera::ConversionFit* fit) {
  calib::CalibrationRecord r;
  camera::VisitModel(in.camera.model, [&](auto src_model) {
    using S = decltype(src_model);
    const refit::ListProjector<S> src{in.camera.sensor};
    r = [&] {
      switch (start.model) {
        case CameraModelId::kOpenCV:
          return ConvertTo<OpenCV>(src, in.camera.params, in.free, in.covariance, in, start, free_q, refit_q, fit);
        case CameraModelId::kKannalaBrandt:
          return ConvertTo<KB>(src, in.camera.params, in.free, in.covariance, in, start, free_q, refit_q, fit);
        case CameraModelId::kBrown:
          return ConvertTo<camera::BrownModel>(src, in.camera.params, in.free, in.covariance, in, start,
                                               free_q, refit_q, fit);
        default: throw InternalError("conversion target not handled");
      }
    }();
  });
  return r;
}

}  // namespace

PixelCalibration ToPixelFamily(const calib::CalibrationRecord& in, const std::string& field) {
  const Camera& cam = in.camera;
  PixelCalibration out{in, true, {}};
  if (cam.model == CameraModelId::kBrown) {
    const auto conv = camera::BrownToOpenCV(camera::ToBrown(cam), cam.sensor);
    const auto& o = conv.opencv;
    const Camera start = OpenCVCamera(cam.sensor, {o.fx, o.fy, o.cx, o.cy, o.k1, o.k2, o.p1, o.p2, o.k3});
    CheckRefit(start, conv.fit, field);  // never written: fx −875.9 at RMS 181.5 px (issue 24)
    out.cal = FromListModel<OpenCV>(in, start, FreeFirst(OpenCV::kNumParams, 9), /*refit_q=*/false, nullptr);
    out.exact = false;
    out.fit = conv.fit;
  } else if (cam.model == CameraModelId::kEquidistant) {
    using E = camera::EquidistantModel;
    const auto& p = cam.params;
    const Camera start{CameraModelId::kKannalaBrandt, cam.sensor,
                       {p[E::kF], p[E::kF], p[E::kCx], p[E::kCy], p[E::kK1], p[E::kK2], 0, 0}};
    out.cal = FromListModel<KB>(in, start, FreeFirst(KB::kNumParams, 6), false, nullptr);
  }
  return out;
}

}  // namespace detail

using camera::Camera;
using camera::CameraModelId;
using OpenCV = camera::OpenCVModel;
using detail::CheckRefit;
using detail::FreeFirst;
using detail::FromListModel;
using detail::PixelCalibration;
using detail::ToPixelFamily;

calib::CalibrationRecord WithoutSigma(const Camera& cam, const std::string& note) {
  calib::CalibrationRecord r;
  r.camera = cam;
  const auto& info = cam.info();
  r.free.assign(info.num_params, false);
  for (int i = 0; i < info.num_params; ++i) r.free[i] = i < info.first_distortion || cam.params[i] != 0;
  r.covariance = Eigen::MatrixXd::Zero(info.num_params, info.num_params);
  for (int i = 0; i < info.num_params; ++i) {
    for (int j = 0; j < info.num_params; ++j) {
      if (r.free[i] && r.free[j]) r.covariance(i, j) = NAN;
    }
  }
  r.has_covariance = false;
  r.covariance_note = note;
  return r;
}

namespace {
calib::CalibrationRecord ConvertCalibrationUnnamed(const calib::CalibrationRecord& cal, CameraModelId model,
                                                   const std::string& field, camera::ConversionFit* fit);
}  // namespace

calib::CalibrationRecord ConvertCalibration(const calib::CalibrationRecord& cal, CameraModelId model,
                                            const std::string& field, camera::ConversionFit* fit) {
  try {
    return ConvertCalibrationUnnamed(cal, model, field, fit);
  } catch (const InvalidInput& e) {
    if (e.field().rfind(field, 0) == 0) throw;
    // An inner step's field ("opencv": the distortion cannot be inverted): name the file too.
    throw InvalidInput(field, fmt::format("cannot be converted from {} to {}: {}", cal.camera.model_name(),
                                          camera::Info(model).name, e.what()));
  }
}

namespace {
calib::CalibrationRecord ConvertCalibrationUnnamed(const calib::CalibrationRecord& cal, CameraModelId model,
                                                   const std::string& field, camera::ConversionFit* fit) {
  if (fit != nullptr) *fit = {};
  const Camera& c = cal.camera;
  if (c.model == model) return cal;
  if (model == CameraModelId::kOpenCV && c.model == CameraModelId::kBrown) {
    const PixelCalibration pc = ToPixelFamily(cal, field);
    if (fit != nullptr) *fit = pc.fit;
    return pc.cal;
  }
  if (model == CameraModelId::kKannalaBrandt && c.model == CameraModelId::kEquidistant) {
    return ToPixelFamily(cal, field).cal;
  }
  if (model == CameraModelId::kBrown && c.model == CameraModelId::kOpenCV) {
    const auto& p = c.params;
    if (p[OpenCV::kK4] != 0 || p[OpenCV::kK5] != 0 || p[OpenCV::kK6] != 0) {
      throw InvalidInput(field, "an opencv calibration with rational k4-k6 has no Brown equivalent");
    }
    const auto conv = camera::OpenCVToBrown(
        {p[OpenCV::kFx], p[OpenCV::kFy], p[OpenCV::kCx], p[OpenCV::kCy], p[OpenCV::kK1], p[OpenCV::kK2],
         p[OpenCV::kP1], p[OpenCV::kP2], p[OpenCV::kK3]},
        c.sensor);
    if (fit != nullptr) *fit = conv.fit;
    CheckRefit(camera::FromBrown(conv.brown, c.sensor), conv.fit, field);
    return FromListModel<camera::BrownModel>(cal, camera::FromBrown(conv.brown, c.sensor),
                                             FreeFirst(camera::kBrownNumParams, camera::kBrownNumParams),
                                             /*refit_q=*/false, nullptr);
  }
  throw InvalidInput(field, fmt::format("a {} calibration cannot be converted to the {} model "
                                        "(porthole converts brown <-> opencv and equidistant -> kannala-brandt)",
                                        c.model_name(), camera::Info(model).name));
}
}  // namespace

}  // namespace porthole::interop
