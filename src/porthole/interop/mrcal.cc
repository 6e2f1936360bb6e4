// mrcal's camera model file, .cameramodel (format mrcal): a Python dict literal with lensmodel,
// intrinsics [fx fy cx cy distortion…], imagersize and extrinsics rt_fromref, as mrcal's
// documentation gives it (mrcal.secretsauce.net: cameramodels.html, lensmodels.html); its
// LENSMODEL_PINHOLE and LENSMODEL_OPENCV4/5/8 are porthole's opencv model, parameter for parameter.
// The dict goes through the bounded Python-literal reader (interop/pyliteral.h); docs/interop.md, "mrcal".
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

#include "porthole/camera/validate.h"
#include "porthole/core/error.h"
#include "porthole/interop/interop.h"
#include "porthole/interop/internal.h"
#include "porthole/interop/pyliteral.h"

namespace porthole::interop {
namespace {

using camera::Camera;
using camera::CameraModelId;
using OpenCV = camera::OpenCVModel;
using detail::NoRepresentation;
using detail::Num;
using detail::OpenCVCamera;
using detail::PixelSensor;

// mrcal's OpenCV lens models: the number of distortion coefficients (k1 k2 p1 p2 [k3 [k4 k5 k6]]).
constexpr std::array<std::pair<std::string_view, int>, 4> kMrcalModels = {{
    {"LENSMODEL_PINHOLE", 0},
    {"LENSMODEL_OPENCV4", 4},
    {"LENSMODEL_OPENCV5", 5},
    {"LENSMODEL_OPENCV8", 8},
}};

ReadResult ReadMrcal(const std::string& text, double pitch_mm, const std::string& field) {
  const nlohmann::json j = ParsePythonLiteral(text, field);
  if (!j.is_object()) throw InvalidInput(field, "not a mrcal camera model: expected a dict { … }");
  MrcalModel m;
  if (!j.contains("lensmodel") || !j["lensmodel"].is_string()) {
    throw InvalidInput(field + ": lensmodel", "missing or not a string");
  }
  m.lensmodel = j["lensmodel"].get<std::string>();
  if (!j.contains("intrinsics") || !j["intrinsics"].is_array()) {
    throw InvalidInput(field + ": intrinsics", "missing or not a list");
  }
  for (const auto& v : j["intrinsics"]) {
    if (!v.is_number()) throw InvalidInput(field + ": intrinsics", "must hold numbers");
    m.intrinsics.push_back(v.get<double>());
  }
  if (!j.contains("imagersize") || !j["imagersize"].is_array() || j["imagersize"].size() != 2 ||
      !j["imagersize"][0].is_number_integer() || !j["imagersize"][1].is_number_integer()) {
    throw InvalidInput(field + ": imagersize", "must be [ width, height ] in whole pixels");
  }
  for (int k : {0, 1}) {
    const auto v = j["imagersize"][k].get<std::int64_t>();
    if (v < 1 || v > 1000000) throw InvalidInput(field + ": imagersize", "must be whole pixels from 1 to 1000000");
  }
  m.width_px = j["imagersize"][0].get<int>();
  m.height_px = j["imagersize"][1].get<int>();
  ReadResult r;
  if (j.contains("extrinsics")) {  // rt_fromref: 3 rotation-vector components, then the translation
    const auto& e = j["extrinsics"];
    if (!e.is_array() || e.size() != 6) throw InvalidInput(field + ": extrinsics", "must be 6 numbers (rt_fromref)");
    std::array<double, 6> rt{};
    for (int k = 0; k < 6; ++k) {
      if (!e[k].is_number() || !std::isfinite(e[k].get<double>())) {
        throw InvalidInput(field + ": extrinsics", "must be 6 finite numbers (rt_fromref)");
      }
      rt[k] = e[k].get<double>();
    }
    r.rt_fromref = rt;
  }
  r.calibration.camera = FromMrcal(m, pitch_mm, field);
  r.format = Format::kMrcal;
  r.format_model = m.lensmodel;
  return r;
}

std::string MrcalText(const MrcalModel& m, std::string_view source) {
  std::string intr, extr;
  for (double v : m.intrinsics) intr += " " + Num(v) + ",";
  for (double v : m.rt_fromref) extr += " " + Num(v) + ",";
  return fmt::format(
      "# mrcal camera model written by porthole convert ({})\n"
      "{{\n"
      "    'lensmodel': '{}',\n"
      "    # intrinsics are fx,fy,cx,cy,distortion0,distortion1,....\n"
      "    'intrinsics': [{} ],\n"
      "    # extrinsics are rt_fromref (the identity unless the input held them)\n"
      "    'extrinsics': [{} ],\n"
      "    'imagersize': [ {}, {} ],\n"
      "}}\n",
      source, m.lensmodel, intr, extr, m.width_px, m.height_px);
}

}  // namespace

MrcalModel ToMrcal(const Camera& cam, const std::string& field) {
  if (cam.model != CameraModelId::kOpenCV) {
    NoRepresentation(cam, "mrcal", field, "mrcal's OpenCV models hold porthole's opencv model");
  }
  const auto& p = cam.params;
  int n = 8;
  if (p[OpenCV::kK4] == 0 && p[OpenCV::kK5] == 0 && p[OpenCV::kK6] == 0) {
    n = p[OpenCV::kK3] != 0 ? 5
        : (p[OpenCV::kK1] != 0 || p[OpenCV::kK2] != 0 || p[OpenCV::kP1] != 0 || p[OpenCV::kP2] != 0)
            ? 4
            : 0;
  }
  MrcalModel m;
  for (const auto& [name, count] : kMrcalModels) {
    if (count == n) m.lensmodel = name;
  }
  m.intrinsics.assign(p.begin(), p.begin() + 4 + n);
  m.width_px = cam.sensor.width_px;
  m.height_px = cam.sensor.height_px;
  return m;
}

Camera FromMrcal(const MrcalModel& m, double pitch_mm, const std::string& field) {
  int n = -1;
  std::string known;
  for (const auto& [name, count] : kMrcalModels) {
    if (name == m.lensmodel) n = count;
    known += (known.empty() ? "" : ", ") + std::string(name);
  }
  if (n < 0) {
    throw InvalidInput(field + ": lensmodel", "'" + m.lensmodel + "' is not supported (porthole reads " + known + ")");
  }
  if (static_cast<int>(m.intrinsics.size()) != 4 + n) {
    throw InvalidInput(field + ": intrinsics", fmt::format("{} has {} intrinsics, the file has {}",
                                                           m.lensmodel, 4 + n, m.intrinsics.size()));
  }
  Camera cam = OpenCVCamera(PixelSensor(m.width_px, m.height_px, pitch_mm), {});
  std::copy(m.intrinsics.begin(), m.intrinsics.end(), cam.params.begin());
  camera::ValidateCamera(cam, field);
  return cam;
}

namespace detail {

ReadResult ReadMrcalFile(const std::string& content, const ReadArgs& args) {
  ReadResult r = ReadMrcal(content, args.pixel_pitch_mm, args.field);
  r.calibration = NoSigmaRecord(r.camera(), args.format);
  return r;
}

WriteResult WriteMrcalFile(const calib::CalibrationRecord& cal, Format /*format*/, const std::string& field,
                           const WriteExtras& extras) {
  const PixelCalibration pc = ToPixelFamily(cal, field);  // Brown: refit to opencv
  WriteResult w;
  w.exact = pc.exact;
  w.fit = pc.fit;
  MrcalModel m = ToMrcal(pc.cal.camera, field);
  if (extras.rt_fromref) m.rt_fromref = *extras.rt_fromref;
  w.content = MrcalText(m, pc.exact ? "exact" : fmt::format("refit from {}, RMS {:.6f} px",
                                                            cal.camera.model_name(), pc.fit.rms_px));
  w.format_model = m.lensmodel;
  return w;
}

}  // namespace detail

}  // namespace porthole::interop
