#include "porthole/interop/interop.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "porthole/calib/result_json.h"
#include "porthole/camera/validate.h"
#include "porthole/core/error.h"
#include "porthole/core/input.h"
#include "porthole/interop/metashape.h"
#include "porthole/interop/opencv_storage.h"
#include "porthole/interop/pyliteral.h"
#include "porthole/interop/refit.h"
#include "porthole/interop/refractive.h"
#include "porthole/interop/text.h"

namespace porthole::interop {
namespace {

using camera::Camera;
using camera::CameraModelId;
using OpenCV = camera::OpenCVModel;
using KB = camera::KannalaBrandtModel;

constexpr std::array<std::pair<Format, std::string_view>, 8> kFormatNames = {{
    {Format::kJson, "json"},
    {Format::kOpenCVYaml, "opencv-yaml"},
    {Format::kOpenCVXml, "opencv-xml"},
    {Format::kColmapText, "colmap"},
    {Format::kColmapBinary, "colmap-bin"},
    {Format::kMrcal, "mrcal"},
    {Format::kMetashape, "metashape"},
    {Format::kCalibmar, "calibmar"},
}};

// COLMAP's models as it numbers and names them (colmap/src/base/camera_models.h), with their
// parameter counts.
struct ColmapModelInfo {
  int id;
  std::string_view name;
  int num_params;
};
constexpr std::array<ColmapModelInfo, 7> kColmapModels = {{
    {0, "SIMPLE_PINHOLE", 3},
    {1, "PINHOLE", 4},
    {2, "SIMPLE_RADIAL", 4},
    {3, "RADIAL", 5},
    {4, "OPENCV", 8},
    {5, "OPENCV_FISHEYE", 8},
    {6, "FULL_OPENCV", 12},
}};

const ColmapModelInfo* ColmapModelByName(std::string_view name) {
  for (const auto& m : kColmapModels) {
    if (m.name == name) return &m;
  }
  return nullptr;
}
const ColmapModelInfo* ColmapModelById(int id) {
  for (const auto& m : kColmapModels) {
    if (m.id == id) return &m;
  }
  return nullptr;
}
std::string ColmapModelNames() {
  std::string s;
  for (const auto& m : kColmapModels) s += (s.empty() ? "" : ", ") + std::string(m.name);
  return s;
}

// mrcal's OpenCV lens models: the number of distortion coefficients (k1 k2 p1 p2 [k3 [k4 k5 k6]]).
constexpr std::array<std::pair<std::string_view, int>, 4> kMrcalModels = {{
    {"LENSMODEL_PINHOLE", 0},
    {"LENSMODEL_OPENCV4", 4},
    {"LENSMODEL_OPENCV5", 5},
    {"LENSMODEL_OPENCV8", 8},
}};


std::string Ext(const std::string& path) {
  return Lower(std::filesystem::path(path).extension().string());
}

camera::Sensor PixelSensor(int w, int h, double pitch_mm) { return {w, h, pitch_mm}; }

// A camera of the opencv model with these parameters (missing trailing ones 0).
Camera OpenCVCamera(const camera::Sensor& s, std::initializer_list<double> p) {
  Camera c{CameraModelId::kOpenCV, s, std::vector<double>(OpenCV::kNumParams, 0.0)};
  std::copy(p.begin(), p.end(), c.params.begin());
  return c;
}

// ---- Conversions with σ (interop/refit.h) ----

// A refit's result is written or used only when possible (camera::RequirePossibleResult), valid as
// a calibration (camera::ValidateCalibration: what a reader refuses is never written) and close to
// the camera it replaces: RMS at most kMaxRefitRmsPx over the image.
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

std::vector<bool> FreeFirst(int n, int count) {
  std::vector<bool> f(n, false);
  std::fill(f.begin(), f.begin() + count, true);
  return f;
}

// The record converted from `src` (parameters p of the record `in`) to the list model M: q starts
// at `start` (the closed form); q's `free_q` parameters are refit over the image
// so that M reprojects src's pixels (`refit_q`; false: start is exact, or already a refit). Rays from `start`'s unprojection of a 40 × 30 pixel grid.
template <typename M, typename Src>
calib::CalibrationRecord ConvertTo(const Src& src, const std::vector<double>& p, const calib::FreeMask& adjusted_p,
                                   const Eigen::MatrixXd& cov_p, const calib::CalibrationRecord& in,
                                   const Camera& start, const std::vector<bool>& free_q, bool refit_q,
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

// A calibration in the model family the pixel formats share: Brown refit to opencv (over the
// image, camera::BrownToOpenCV); equidistant as kannala-brandt (exact); opencv and kannala-brandt
// unchanged. σ carried through.
struct PixelCalibration {
  calib::CalibrationRecord cal;
  bool exact = true;
  camera::ConversionFit fit;
};
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
[[noreturn]] void NoRepresentation(const Camera& cam, std::string_view format,
                                   const std::string& field, std::string_view hint) {
  throw InvalidInput(field, fmt::format("the {} model has no {} equivalent ({})", cam.model_name(),
                                        format, hint));
}

std::string Num(double v) { return fmt::format("{:.17g}", v); }

// ---- OpenCV FileStorage YAML and XML (interop/opencv_storage.h) ----

ReadResult ReadOpenCVStorage(const std::string& text, Format format, double pitch_mm, const std::string& field) {
  const OpenCVStorageCalibration c = ParseOpenCVStorage(text, format == Format::kOpenCVXml, field);
  const auto& k = c.camera_matrix;
  const auto& d = c.distortion;
  const auto s = PixelSensor(c.width_px, c.height_px, pitch_mm);
  ReadResult r;
  if (c.fisheye) {
    r.calibration.camera = Camera{CameraModelId::kKannalaBrandt, s, {k[0], k[4], k[2], k[5], d[0], d[1], d[2], d[3]}};
    r.format_model = "fisheye, 4 coefficients";
  } else {
    const auto at = [&](std::size_t i) { return i < d.size() ? d[i] : 0.0; };
    r.calibration.camera = OpenCVCamera(s, {k[0], k[4], k[2], k[5], at(0), at(1), at(2), at(3), at(4), at(5), at(6), at(7)});
    r.format_model = fmt::format("{} coefficients", d.size());
  }
  r.format = format;
  return r;
}

// The camera as a FileStorage calibration: opencv with the fewest of 4, 5, 8 coefficients that hold
// it exactly, kannala-brandt as cv::fisheye's 4.
OpenCVStorageCalibration ToOpenCVStorage(const Camera& cam, const std::string& field) {
  OpenCVStorageCalibration c;
  c.width_px = cam.sensor.width_px;
  c.height_px = cam.sensor.height_px;
  const auto& p = cam.params;
  const auto matrix = [&](double fx, double fy, double cx, double cy) {
    c.camera_matrix = {fx, 0, cx, 0, fy, cy, 0, 0, 1};
  };
  if (cam.model == CameraModelId::kKannalaBrandt) {
    c.fisheye = true;
    matrix(p[KB::kFx], p[KB::kFy], p[KB::kCx], p[KB::kCy]);
    c.distortion = {p[KB::kK1], p[KB::kK2], p[KB::kK3], p[KB::kK4]};
    return c;
  }
  if (cam.model != CameraModelId::kOpenCV) {
    NoRepresentation(cam, "OpenCV FileStorage", field, "write opencv, brown (refit) or kannala-brandt (cv::fisheye)");
  }
  matrix(p[OpenCV::kFx], p[OpenCV::kFy], p[OpenCV::kCx], p[OpenCV::kCy]);
  const bool rational = p[OpenCV::kK4] != 0 || p[OpenCV::kK5] != 0 || p[OpenCV::kK6] != 0;
  const int n = rational ? 8 : p[OpenCV::kK3] != 0 ? 5 : 4;
  c.distortion.assign(p.begin() + OpenCV::kK1, p.begin() + OpenCV::kK1 + n);
  return c;
}

// ---- COLMAP ----

double ColmapNumber(const std::string& tok, const std::string& where) {
  char* end = nullptr;
  const double v = std::strtod(tok.c_str(), &end);
  if (end != tok.c_str() + tok.size() || !std::isfinite(v)) {
    throw InvalidInput(where, "'" + tok.substr(0, 40) + "' is not a finite number");
  }
  return v;
}

std::vector<ColmapCamera> ParseColmapText(const std::string& text, const std::string& field) {
  std::vector<ColmapCamera> out;
  std::istringstream in(text);
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    const std::string where = fmt::format("{}: line {}", field, line_no);
    std::istringstream ls(line);
    ColmapCamera c;
    long long id = 0, w = 0, h = 0;
    if (!(ls >> id >> c.model >> w >> h)) {
      throw InvalidInput(where, "expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]");
    }
    const ColmapModelInfo* m = ColmapModelByName(c.model);
    if (m == nullptr) {
      throw InvalidInput(where + ": MODEL", "'" + c.model + "' is not supported (porthole reads " +
                                                ColmapModelNames() + ")");
    }
    if (w < 1 || h < 1 || w > 1000000 || h > 1000000) {
      throw InvalidInput(where + ": WIDTH/HEIGHT", "must be positive whole pixels");
    }
    std::vector<std::string> toks;
    for (std::string tok; ls >> tok;) toks.push_back(tok);
    // PARAMS: the numbers up to the end, or to refractive COLMAP's housing ([REFRAC] MODEL p1 … p8).
    const auto is_number = [](const std::string& t) {
      char* end = nullptr;
      std::strtod(t.c_str(), &end);
      return !t.empty() && end == t.c_str() + t.size();
    };
    std::size_t i = 0;
    for (; i < toks.size() && static_cast<int>(c.params.size()) < m->num_params; ++i) {
      c.params.push_back(ColmapNumber(toks[i], where + ": PARAMS"));
    }
    std::size_t count = c.params.size();
    while (count < toks.size() && is_number(toks[count])) ++count;
    if (static_cast<int>(count) != m->num_params) {
      throw InvalidInput(where + ": PARAMS", fmt::format("{} has {} parameters, the line has {}",
                                                         c.model, m->num_params, count));
    }
    if (i < toks.size()) {
      if (toks[i] == "REFRAC") ++i;
      if (i == toks.size() || (toks[i] != "FLATPORT" && toks[i] != "DOMEPORT")) {
        throw InvalidInput(where + ": REFRAC_MODEL", "expected FLATPORT or DOMEPORT (refractive COLMAP's housing)");
      }
      RefractiveHousing h;
      h.model = toks[i++];
      if (toks.size() - i != h.params.size()) {
        throw InvalidInput(where + ": REFRAC_PARAMS", fmt::format("{} has {} parameters, the line has {}", h.model,
                                                                  h.params.size(), toks.size() - i));
      }
      for (double& v : h.params) v = ColmapNumber(toks[i++], where + ": REFRAC_PARAMS");
      double n_water = 0;
      PortFromRefractive(h, where + ": " + h.model, &n_water);  // a housing porthole can use, or an error naming it
      c.housing = h;
    }
    c.camera_id = static_cast<int>(id);
    c.width_px = static_cast<int>(w);
    c.height_px = static_cast<int>(h);
    out.push_back(std::move(c));
  }
  return out;
}

std::string ColmapText(const std::vector<ColmapCamera>& cameras) {
  const bool refractive = std::any_of(cameras.begin(), cameras.end(), [](const auto& c) { return c.housing.has_value(); });
  std::string out = fmt::format(
      "# Camera list with one line of data per camera:\n"
      "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]{}\n"
      "# Number of cameras: {}\n"
      "# written by porthole convert (COLMAP pixel convention: top-left pixel centre at 0.5, 0.5){}\n",
      refractive ? " OPTIONAL[REFRAC_MODEL REFRAC_PARAMS[]]" : "", cameras.size(),
      refractive ? "; the housing is refractive COLMAP's (COLMAP-Underwater), metres" : "");
  for (const auto& c : cameras) {
    out += fmt::format("{} {} {} {}", c.camera_id, c.model, c.width_px, c.height_px);
    for (double v : c.params) out += " " + Num(v);
    if (c.housing) {
      out += " " + c.housing->model;
      for (double v : c.housing->params) out += " " + Num(v);
    }
    out += "\n";
  }
  return out;
}

// cameras.bin, little-endian (colmap/src/base/reconstruction.cc, WriteCamerasBinary): uint64 count,
// then per camera uint32 camera_id, int32 model_id, uint64 width, uint64 height, double params[].
template <typename T>
void PutLE(std::string* out, T v) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));  // x86-64 and aarch64 are little-endian
  out->append(reinterpret_cast<const char*>(b), sizeof(T));
}
static_assert(std::endian::native == std::endian::little, "cameras.bin I/O assumes little-endian");

std::string ColmapBinary(const std::vector<ColmapCamera>& cameras) {
  std::string out;
  PutLE<std::uint64_t>(&out, cameras.size());
  for (const auto& c : cameras) {
    PutLE<std::uint32_t>(&out, static_cast<std::uint32_t>(c.camera_id));
    PutLE<std::int32_t>(&out, ColmapModelByName(c.model)->id);
    PutLE<std::uint64_t>(&out, static_cast<std::uint64_t>(c.width_px));
    PutLE<std::uint64_t>(&out, static_cast<std::uint64_t>(c.height_px));
    for (double v : c.params) PutLE<double>(&out, v);
  }
  return out;
}

std::vector<ColmapCamera> ParseColmapBinary(const std::string& bin, const std::string& field) {
  std::size_t pos = 0;
  auto get = [&]<typename T>(T* v, const char* what) {
    if (pos + sizeof(T) > bin.size()) throw InvalidInput(field + ": " + what, "file ends early");
    std::memcpy(v, bin.data() + pos, sizeof(T));
    pos += sizeof(T);
  };
  std::uint64_t count = 0;
  get(&count, "number of cameras");
  if (count > bin.size() / 28) throw InvalidInput(field + ": number of cameras", "larger than the file holds");
  std::vector<ColmapCamera> out;
  for (std::uint64_t i = 0; i < count; ++i) {
    std::uint32_t id = 0;
    std::int32_t model = 0;
    std::uint64_t w = 0, h = 0;
    get(&id, "camera_id");
    get(&model, "model_id");
    get(&w, "width");
    get(&h, "height");
    const ColmapModelInfo* m = ColmapModelById(model);
    if (m == nullptr) {
      throw InvalidInput(field + ": model_id", fmt::format("{} is not supported (porthole reads {})",
                                                           model, ColmapModelNames()));
    }
    if (w < 1 || h < 1 || w > 1000000 || h > 1000000) {
      throw InvalidInput(field + ": width/height", "must be positive whole pixels");
    }
    ColmapCamera c{static_cast<int>(id), std::string(m->name), static_cast<int>(w), static_cast<int>(h), {}, std::nullopt};
    c.params.resize(m->num_params);
    for (auto& v : c.params) {
      get(&v, "params");
      if (!std::isfinite(v)) throw InvalidInput(field + ": params", "not finite");
    }
    out.push_back(std::move(c));
  }
  if (pos != bin.size()) throw InvalidInput(field, "trailing bytes after the cameras");
  return out;
}

// The camera `camera_id` of the list (0: the only one).
ReadResult FromColmapList(const std::vector<ColmapCamera>& list, Format format, double pitch_mm,
                          const std::string& field, int camera_id) {
  std::string ids;
  for (const auto& c : list) ids += (ids.empty() ? "" : ", ") + std::to_string(c.camera_id);
  const ColmapCamera* chosen = nullptr;
  for (const auto& c : list) {
    if (camera_id == 0 ? list.size() == 1 : c.camera_id == camera_id) chosen = &c;
  }
  if (list.empty()) {
    throw InvalidInput(field, "holds no camera (COLMAP's cameras.txt has a line CAMERA_ID MODEL WIDTH HEIGHT PARAMS[] "
                              "per camera; cameras.bin a count of at least 1)");
  }
  if (chosen == nullptr) {
    throw InvalidInput(field, camera_id == 0 ? fmt::format("holds {} cameras (ids {}): choose one with `camera_id`",
                                                           list.size(), ids)
                                             : fmt::format("has no camera {} (ids {})", camera_id, ids));
  }
  ReadResult r;
  r.calibration.camera = FromColmap(*chosen, pitch_mm, field);
  r.format = format;
  r.format_model = chosen->model + (chosen->housing ? " + " + chosen->housing->model : "");
  r.housing = chosen->housing;
  return r;
}

// ---- mrcal ----

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

// ---- porthole JSON ----

// The camera's parameters (null: not adjusted and 0), σ (null: unknown or not adjusted) and, when
// known, the covariance of the adjusted ones (calib/result_json.h reads them back).
std::string PortholeJson(const calib::CalibrationRecord& cal) {
  using Json = nlohmann::ordered_json;
  const Camera& cam = cal.camera;
  Json params = Json::object(), sigma = Json::object(), fixed = Json::array();
  const auto& info = cam.info();
  for (int i = 0; i < info.num_params; ++i) {
    const std::string key(info.params[i].json_key);
    const bool adjusted = cal.free.size() == cam.params.size() && cal.free[i];
    const bool written = adjusted || cam.params[i] != 0 || i < info.first_distortion;
    params[key] = written ? Json(cam.params[i]) : Json(nullptr);
    if (written && !adjusted) fixed.push_back(key);
    const double var = adjusted ? cal.covariance(i, i) : NAN;
    sigma[key] = var > 0 ? Json(std::sqrt(var)) : Json(nullptr);
  }
  Json j = {
      {"model", std::string(info.name)},
      {"camera", params},
      {"sigma", sigma},
      {"fixed", fixed},
      {"units", calib::CameraUnitsJson(cam.model)},
      {"sensor",
       {{"width_px", cam.sensor.width_px},
        {"height_px", cam.sensor.height_px},
        {"pixel_pitch_mm", cam.sensor.pixel_pitch_mm}}},
      {"note", cal.has_covariance ? "written by porthole convert"
                                  : "written by porthole convert; sigma null: unknown (" + cal.covariance_note + ")"},
  };
  if (cal.has_covariance) j["covariance"] = calib::CovarianceJson(info, cal.free, cal.covariance);
  return j.dump(2) + "\n";
}

// ---- Metashape ----

// A Metashape calibration read as porthole's opencv (frame) or kannala-brandt (fisheye) model:
// exact without b2, k4, p3, p4 (frame) or b2, p1–p4 (fisheye), else refit over the image.
ReadResult ReadMetashape(const std::string& text, double pitch_mm, const std::string& field) {
  const MetashapeCalibration m = ParseMetashapeXml(text, field);
  const auto s = PixelSensor(m.width_px, m.height_px, pitch_mm);
  const auto& q = m.params;
  const double fx = q[kMsF] + q[kMsB1], fy = q[kMsF];
  const double cx = 0.5 * m.width_px - 0.5 + q[kMsCx], cy = 0.5 * m.height_px - 0.5 + q[kMsCy];
  calib::CalibrationRecord in;
  in.free.assign(kMetashapeNumParams, false);
  const bool has_cov = m.covariance.size() > 0;
  for (int i = 0; i < kMetashapeNumParams; ++i) in.free[i] = has_cov ? m.covariance(i, i) > 0 : m.present[i];
  in.covariance = has_cov ? m.covariance
                          : Eigen::MatrixXd::Constant(kMetashapeNumParams, kMetashapeNumParams, NAN);
  in.has_covariance = has_cov;
  in.covariance_note = has_cov ? "" : "σ unknown: the Metashape file has no <covariance>";
  const std::vector<double> p(q.begin(), q.end());
  const MetashapeProjector src{m.fisheye, m.width_px, m.height_px};
  ReadResult r;
  r.format = Format::kMetashape;
  if (m.fisheye) {
    r.format_model = "fisheye";
    r.exact = q[kMsB2] == 0 && q[kMsP1] == 0 && q[kMsP2] == 0 && q[kMsP3] == 0 && q[kMsP4] == 0;
    const Camera start{CameraModelId::kKannalaBrandt, s, {fx, fy, cx, cy, q[kMsK1], q[kMsK2], q[kMsK3], q[kMsK4]}};
    camera::ValidateCamera(start, field);
    r.calibration = ConvertTo<KB>(src, p, in.free, in.covariance, in, start,
                                  FreeFirst(KB::kNumParams, KB::kNumParams), !r.exact, &r.fit);
  } else {
    r.format_model = m.photoscan_form ? "frame (PhotoScan fx, fy)" : "frame";
    r.exact = q[kMsB2] == 0 && q[kMsK4] == 0 && q[kMsP3] == 0 && q[kMsP4] == 0;
    // OpenCV's p1 is Metashape's P2 and its p2 Metashape's P1.
    const Camera start = OpenCVCamera(s, {fx, fy, cx, cy, q[kMsK1], q[kMsK2], q[kMsP2], q[kMsP1], q[kMsK3]});
    camera::ValidateCamera(start, field);
    r.calibration = ConvertTo<OpenCV>(src, p, in.free, in.covariance, in, start,
                                      FreeFirst(OpenCV::kNumParams, 9), !r.exact, &r.fit);
  }
  return r;
}

// The Metashape projector's parameters as a record (for CarrySigma's target side).
MetashapeCalibration ToMetashape(const calib::CalibrationRecord& in, const std::string& field,
                                 bool* exact, camera::ConversionFit* fit) {
  const PixelCalibration pc = ToPixelFamily(in, field);
  const Camera& c = pc.cal.camera;
  *exact = pc.exact;
  *fit = pc.fit;
  MetashapeCalibration m;
  m.width_px = c.sensor.width_px;
  m.height_px = c.sensor.height_px;
  const auto& p = c.params;
  std::vector<double> q(kMetashapeNumParams, 0.0);
  std::vector<bool> free_q(kMetashapeNumParams, false);
  bool refit_q = false;
  if (c.model == CameraModelId::kKannalaBrandt) {
    m.fisheye = true;
    q = {p[KB::kFy], p[KB::kCx] + 0.5 - 0.5 * m.width_px, p[KB::kCy] + 0.5 - 0.5 * m.height_px,
         p[KB::kFx] - p[KB::kFy], 0, p[KB::kK1], p[KB::kK2], p[KB::kK3], p[KB::kK4], 0, 0, 0, 0};
    for (int i : {kMsF, kMsCx, kMsCy, kMsB1, kMsK1, kMsK2, kMsK3, kMsK4}) free_q[i] = true;
  } else if (c.model == CameraModelId::kOpenCV) {
    q = {p[OpenCV::kFy], p[OpenCV::kCx] + 0.5 - 0.5 * m.width_px, p[OpenCV::kCy] + 0.5 - 0.5 * m.height_px,
         p[OpenCV::kFx] - p[OpenCV::kFy], 0, p[OpenCV::kK1], p[OpenCV::kK2], p[OpenCV::kK3], 0,
         p[OpenCV::kP2], p[OpenCV::kP1], 0, 0};
    for (int i : {kMsF, kMsCx, kMsCy, kMsB1, kMsK1, kMsK2, kMsK3, kMsP1, kMsP2}) free_q[i] = true;
    // OpenCV's rational k4–k6 have no Metashape term: refit with Metashape's k4 free.
    refit_q = p[OpenCV::kK4] != 0 || p[OpenCV::kK5] != 0 || p[OpenCV::kK6] != 0;
    if (refit_q) free_q[kMsK4] = true;
  } else {
    NoRepresentation(in.camera, "Metashape", field, "Metashape's frame and fisheye models hold opencv and kannala-brandt");
  }
  const MetashapeProjector dst{m.fisheye, m.width_px, m.height_px};
  const auto rays = refit::GridRays(c.sensor, [&](const Eigen::Vector2d& uv) { return c.Unproject(uv); });
  calib::CalibrationRecord out;
  camera::VisitModel(c.model, [&](auto model) {
    using S = decltype(model);
    if constexpr (S::kId == CameraModelId::kOpenCV || S::kId == CameraModelId::kKannalaBrandt) {
      const refit::ListProjector<S> src{c.sensor};
      if (refit_q) {
        const refit::ProjectedRays data = refit::ProjectRays(src, p, rays);
        const camera::ConversionFit f = refit::Fit(dst, &q, free_q, data.rays, data.px);
        *exact = false;
        *fit = f;
        if (!(f.rms_px <= kMaxRefitRmsPx) || !(q[kMsF] > 0)) {
          throw InvalidInput(field, fmt::format("the refit to Metashape's frame model misses the camera by RMS {:.3g} "
                                                "px (f {:g} px): Metashape's model cannot hold this camera",
                                                f.rms_px, q[kMsF]));
        }
      }
      CarrySigma(src, p, pc.cal.free, pc.cal.covariance, dst, q, free_q, rays, &out);
    }
  });
  std::copy(q.begin(), q.end(), m.params.begin());
  for (int i = 0; i < kMetashapeNumParams; ++i) m.present[i] = out.free[i];
  if (pc.cal.has_covariance && out.has_covariance) m.covariance = out.covariance;
  return m;
}

}  // namespace

std::string_view FormatName(Format f) {
  for (const auto& [fm, name] : kFormatNames) {
    if (fm == f) return name;
  }
  throw InternalError("format not in kFormatNames");
}

std::string FormatNames() {
  std::string s;
  for (const auto& [fm, name] : kFormatNames) s += (s.empty() ? "" : ", ") + std::string(name);
  return s;
}

Format FormatFromName(std::string_view name, const std::string& field) {
  const std::string n = Lower(std::string(name));
  for (const auto& [fm, fname] : kFormatNames) {
    if (fname == n) return fm;
  }
  throw InvalidInput(field, "unknown format '" + std::string(name) + "' (known: " + FormatNames() + ")");
}

Format DetectInputFormat(const std::string& path, const std::string& content, const std::string& field) {
  const std::string ext = Ext(path);
  if (ext == ".json") return Format::kJson;
  // calibmar's calibration.yaml: no %YAML header, "non_svp_model:" and "parameters: [".
  if (content.find("non_svp_model:") != std::string::npos && content.find("%YAML") == std::string::npos) {
    return Format::kCalibmar;
  }
  if (ext == ".yml" || ext == ".yaml") return Format::kOpenCVYaml;
  if (ext == ".cameramodel") return Format::kMrcal;
  if (ext == ".bin") return Format::kColmapBinary;
  if (ext == ".txt") return Format::kColmapText;
  if (content.find("<opencv_storage") != std::string::npos) return Format::kOpenCVXml;
  if (ext == ".xml" || content.find("<calibration") != std::string::npos) return Format::kMetashape;
  const auto first = content.find_first_not_of(" \t\r\n");
  if (first != std::string::npos) {
    if (content[first] == '{' && content.find("'lensmodel'") != std::string::npos) return Format::kMrcal;
    if (content[first] == '{') return Format::kJson;
    if (content.compare(first, 5, "%YAML") == 0) return Format::kOpenCVYaml;
    if (content.find("'lensmodel'") != std::string::npos) return Format::kMrcal;
    try {
      if (!ParseColmapText(content, field).empty()) return Format::kColmapText;
    } catch (const InvalidInput&) {
    }
  }
  throw InvalidInput(field, "'" + path + "': cannot tell its format from the extension or the content "
                            "(known: " + FormatNames() + ")");
}

Format OutputFormat(const std::string& path, const std::optional<std::string>& to, const std::string& field) {
  if (to) return FormatFromName(*to, "to");
  const std::string ext = Ext(path);
  if (ext == ".json") return Format::kJson;
  if (ext == ".yml" || ext == ".yaml") return Format::kOpenCVYaml;
  if (ext == ".cameramodel") return Format::kMrcal;
  if (ext == ".bin") return Format::kColmapBinary;
  if (ext == ".txt") return Format::kColmapText;
  if (ext == ".xml") return Format::kMetashape;
  throw InvalidInput(field, "'" + path + "': cannot tell the format from the extension (.json, .yml, "
                            ".cameramodel, cameras.txt, cameras.bin, .xml): give `to`");
}

ColmapCamera ToColmap(const Camera& cam, const std::string& field) {
  ColmapCamera c;
  c.width_px = cam.sensor.width_px;
  c.height_px = cam.sensor.height_px;
  const auto& p = cam.params;
  if (cam.model == CameraModelId::kKannalaBrandt) {
    c.model = "OPENCV_FISHEYE";
    c.params = {p[KB::kFx], p[KB::kFy], p[KB::kCx] + 0.5, p[KB::kCy] + 0.5,
                p[KB::kK1], p[KB::kK2], p[KB::kK3], p[KB::kK4]};
    return c;
  }
  if (cam.model != CameraModelId::kOpenCV) {
    NoRepresentation(cam, "COLMAP", field, "write opencv or kannala-brandt");
  }
  const double fx = p[OpenCV::kFx], fy = p[OpenCV::kFy];
  const double cx = p[OpenCV::kCx] + 0.5, cy = p[OpenCV::kCy] + 0.5;
  const double k1 = p[OpenCV::kK1], k2 = p[OpenCV::kK2], p1 = p[OpenCV::kP1], p2 = p[OpenCV::kP2];
  const bool rational = p[OpenCV::kK3] != 0 || p[OpenCV::kK4] != 0 || p[OpenCV::kK5] != 0 ||
                        p[OpenCV::kK6] != 0;
  const bool tangential = p1 != 0 || p2 != 0;
  if (rational) {
    c.model = "FULL_OPENCV";
    c.params = {fx, fy, cx, cy, k1, k2, p1, p2, p[OpenCV::kK3], p[OpenCV::kK4], p[OpenCV::kK5],
                p[OpenCV::kK6]};
  } else if (tangential || (fx != fy && (k1 != 0 || k2 != 0))) {
    c.model = "OPENCV";
    c.params = {fx, fy, cx, cy, k1, k2, p1, p2};
  } else if (fx != fy) {
    c.model = "PINHOLE";
    c.params = {fx, fy, cx, cy};
  } else if (k2 != 0) {
    c.model = "RADIAL";
    c.params = {fx, cx, cy, k1, k2};
  } else if (k1 != 0) {
    c.model = "SIMPLE_RADIAL";
    c.params = {fx, cx, cy, k1};
  } else {
    c.model = "SIMPLE_PINHOLE";
    c.params = {fx, cx, cy};
  }
  return c;
}

Camera FromColmap(const ColmapCamera& c, double pitch_mm, const std::string& field) {
  const ColmapModelInfo* m = ColmapModelByName(c.model);
  if (m == nullptr) throw InvalidInput(field + ": MODEL", "'" + c.model + "' is not supported");
  if (static_cast<int>(c.params.size()) != m->num_params) {
    throw InvalidInput(field + ": PARAMS", fmt::format("{} has {} parameters", c.model, m->num_params));
  }
  const auto s = PixelSensor(c.width_px, c.height_px, pitch_mm);
  const auto& q = c.params;
  Camera cam;
  switch (m->id) {
    case 0: cam = OpenCVCamera(s, {q[0], q[0], q[1] - 0.5, q[2] - 0.5}); break;
    case 1: cam = OpenCVCamera(s, {q[0], q[1], q[2] - 0.5, q[3] - 0.5}); break;
    case 2: cam = OpenCVCamera(s, {q[0], q[0], q[1] - 0.5, q[2] - 0.5, q[3]}); break;
    case 3: cam = OpenCVCamera(s, {q[0], q[0], q[1] - 0.5, q[2] - 0.5, q[3], q[4]}); break;
    case 4: cam = OpenCVCamera(s, {q[0], q[1], q[2] - 0.5, q[3] - 0.5, q[4], q[5], q[6], q[7]}); break;
    case 5:
      cam = Camera{CameraModelId::kKannalaBrandt, s,
                   {q[0], q[1], q[2] - 0.5, q[3] - 0.5, q[4], q[5], q[6], q[7]}};
      break;
    case 6:
      cam = OpenCVCamera(s, {q[0], q[1], q[2] - 0.5, q[3] - 0.5, q[4], q[5], q[6], q[7], q[8], q[9],
                             q[10], q[11]});
      break;
    default: throw InternalError("COLMAP model id not handled");
  }
  camera::ValidateCamera(cam, field);
  return cam;
}

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

namespace {

// ReadCalibration, with `origin` (the file) naming the line of a bad JSON value ("file:N:").
ReadResult ReadCalibrationFrom(const std::string& content, Format format, double pixel_pitch_mm,
                               const std::string& field, int camera_id, const std::string& origin) {
  RequirePositive("pixel_pitch_mm", pixel_pitch_mm);
  ReadResult r;
  switch (format) {
    case Format::kJson: {
      const nlohmann::json j = ParseJsonText(content, field, origin);
      r.calibration = WithJsonLines(content, field, origin, [&] { return calib::CalibrationFromJson(j, field); });
      r.format = format;
      r.format_model = std::string(r.camera().model_name());
      r.pitch_known = true;
      // A σ the file does not give is unknown, not 0.
      auto& rec = r.calibration;
      for (int i = 0; i < rec.camera.info().num_params; ++i) {
        if (!rec.free[i] || rec.covariance(i, i) > 0) continue;
        rec.covariance.row(i).setConstant(NAN);
        rec.covariance.col(i).setConstant(NAN);
        rec.has_covariance = false;
      }
      break;
    }
    case Format::kOpenCVYaml:
    case Format::kOpenCVXml: r = ReadOpenCVStorage(content, format, pixel_pitch_mm, field); break;
    case Format::kColmapText:
      r = FromColmapList(ParseColmapText(content, field), format, pixel_pitch_mm, field, camera_id);
      break;
    case Format::kColmapBinary:
      r = FromColmapList(ParseColmapBinary(content, field), format, pixel_pitch_mm, field, camera_id);
      break;
    case Format::kMrcal: r = ReadMrcal(content, pixel_pitch_mm, field); break;
    case Format::kMetashape: r = ReadMetashape(content, pixel_pitch_mm, field); break;
    case Format::kCalibmar: {
      const CalibmarFile f = ParseCalibmarYaml(content, field);
      r.format = format;
      r.format_model = f.camera.model;
      r.housing = f.housing;
      r.file_rms_px = f.overall_rms_px;
      const Camera cam = FromColmap(f.camera, pixel_pitch_mm, field);
      if (f.camera_sigma.empty()) {
        r.calibration = WithoutSigma(cam, "σ unknown: the calibmar file has no # params_est_std_dev");
      } else {
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
      }
      break;
    }
  }
  if (format != Format::kJson && format != Format::kMetashape && format != Format::kCalibmar) {
    r.calibration = WithoutSigma(r.camera(), fmt::format("σ unknown: {} holds none", FormatName(format)));
  }
  // The one validation of what was read (a JSON calibration had it in CalibrationFromJson, with
  // the line of the offending key).
  if (format != Format::kJson) camera::ValidateCalibration(r.camera(), field);
  return r;
}

}  // namespace

ReadResult ReadCalibration(const std::string& content, Format format, double pixel_pitch_mm,
                           const std::string& field, int camera_id) {
  return ReadCalibrationFrom(content, format, pixel_pitch_mm, field, camera_id, "JSON");
}

ReadResult ReadCalibrationFile(const std::string& path, double pixel_pitch_mm, const std::string& field,
                               int camera_id) {
  std::string file = path;
  if (std::filesystem::is_directory(path)) {
    const auto txt = std::filesystem::path(path) / "cameras.txt";
    const auto bin = std::filesystem::path(path) / "cameras.bin";
    if (std::filesystem::exists(txt)) {
      file = txt.string();
    } else if (std::filesystem::exists(bin)) {
      file = bin.string();
    } else {
      throw InvalidInput(field, "'" + path + "' is a directory without cameras.txt or cameras.bin");
    }
  }
  const std::string content = ReadInputFile(file, field, kMaxCalibrationFileBytes);
  const std::string where = field + " '" + file + "'";
  ReadResult r;
  try {
    r = ReadCalibrationFrom(content, DetectInputFormat(file, content, where), pixel_pitch_mm, where, camera_id, file);
  } catch (const InvalidInput& e) {
    if (e.field().rfind(where, 0) == 0) throw;
    throw InvalidInput(where, e.what());  // an inner step's field (e.g. "refit"): name the file too
  }
  r.calibration.label = std::filesystem::path(path).stem().string();
  return r;
}

std::optional<double> StatedPixelPitchMm(const std::string& path, const std::string& field) {
  const ReadResult r = ReadCalibrationFile(path, 1.0, field);
  // Pitch 1: a calibration made without a pitch, whose millimetres are pixels (no pitch at all).
  if (!r.pitch_known || r.camera().sensor.pixel_pitch_mm == 1.0) return std::nullopt;
  return r.camera().sensor.pixel_pitch_mm;
}

ReadResult ConvertRead(ReadResult r, CameraModelId model, const std::string& field) {
  camera::ConversionFit fit;
  const CameraModelId from = r.camera().model;
  r.calibration = ConvertCalibration(r.calibration, model, field, &fit);
  if (from != model && fit.num_points > 0) {
    r.exact = false;
    r.fit = fit;
  }
  return r;
}

ReadResult ReadCalibrationFileAs(const std::string& path, double pixel_pitch_mm, CameraModelId model,
                                 const std::string& field) {
  ReadResult r = ReadCalibrationFile(path, pixel_pitch_mm, field);
  const std::string label = r.calibration.label;
  r = ConvertRead(std::move(r), model, field + " '" + path + "'");
  r.calibration.label = label;
  return r;
}

std::string DescribeRead(const ReadResult& r, const std::string& path) {
  const std::string what = fmt::format("{} ({} {}) as {}", path, FormatName(r.format), r.format_model,
                                       r.camera().model_name());
  if (r.exact) return what + ": exact";
  return fmt::format("{}: refit over the image, RMS {:.4f} px, max {:.4f} px", what, r.fit.rms_px,
                     r.fit.max_px);
}

WriteResult WriteColmapCameras(const std::vector<ColmapEntry>& cameras, Format format, const std::string& field) {
  if (format != Format::kColmapText && format != Format::kColmapBinary) {
    throw InvalidInput(field, fmt::format("only COLMAP's cameras.txt and cameras.bin hold several cameras, not {}",
                                          FormatName(format)));
  }
  if (cameras.empty()) throw InvalidInput(field, "no camera to write");
  std::vector<ColmapCamera> list;
  WriteResult w;
  for (const auto& e : cameras) {
    const std::string where = fmt::format("{}: camera {}", field, e.camera_id);
    if (e.camera_id < 1) throw InvalidInput(where, "CAMERA_ID must be >= 1");
    for (const auto& c : list) {
      if (c.camera_id == e.camera_id) throw InvalidInput(where, "CAMERA_ID given twice");
    }
    if (e.housing && format == Format::kColmapBinary) {
      throw InvalidInput(where, "a refractive housing goes into cameras.txt only (write colmap, not colmap-bin)");
    }
    camera::ValidateCalibration(e.calibration.camera, where);
    const PixelCalibration pc = ToPixelFamily(e.calibration, where);  // Brown: refit to opencv
    ColmapCamera c = ToColmap(pc.cal.camera, where);
    c.camera_id = e.camera_id;
    c.housing = e.housing;
    if (!pc.exact && (w.exact || pc.fit.rms_px > w.fit.rms_px)) w.fit = pc.fit;
    w.exact = w.exact && pc.exact;
    w.format_model += (w.format_model.empty() ? "" : ", ") + c.model + (c.housing ? " + " + c.housing->model : "");
    list.push_back(std::move(c));
  }
  w.content = format == Format::kColmapText ? ColmapText(list) : ColmapBinary(list);
  return w;
}

WriteResult WriteCamera(const Camera& cam, Format format, const std::string& field) {
  return WriteCalibration(WithoutSigma(cam, ""), format, field);
}

WriteResult WriteCalibration(const calib::CalibrationRecord& cal, Format format, const std::string& field,
                             const WriteExtras& extras) {
  const Camera& cam = cal.camera;
  camera::ValidateCalibration(cam, field);  // porthole writes nothing its readers refuse
  WriteResult w;
  if (format == Format::kJson) {
    w.content = PortholeJson(cal);
    w.format_model = std::string(cam.model_name());
    w.sigma_written = cal.has_covariance;
    return w;
  }
  if (format == Format::kMetashape) {
    const MetashapeCalibration m = ToMetashape(cal, field, &w.exact, &w.fit);
    w.content = MetashapeXml(m);
    w.format_model = m.fisheye ? "fisheye" : "frame";
    w.sigma_written = m.covariance.size() > 0;
    return w;
  }
  if (format == Format::kColmapText || format == Format::kColmapBinary) {
    // The housing goes into refractive COLMAP's cameras.txt only.
    return WriteColmapCameras({{cal, 1, format == Format::kColmapText ? extras.housing : std::nullopt}}, format, field);
  }
  const PixelCalibration pc = ToPixelFamily(cal, field);
  const Camera& pcam = pc.cal.camera;
  w.exact = pc.exact;
  w.fit = pc.fit;
  switch (format) {
    case Format::kCalibmar: {
      CalibmarFile f;
      f.camera = ToColmap(pcam, field);
      if (pc.cal.has_covariance) f.camera_sigma = CovarianceToColmapSigma(f.camera, pc.cal.covariance);
      f.housing = extras.housing;
      w.content = CalibmarYaml(f);
      w.format_model = f.camera.model;
      w.sigma_written = !f.camera_sigma.empty();
      break;
    }
    case Format::kOpenCVYaml:
    case Format::kOpenCVXml: {
      const OpenCVStorageCalibration c = ToOpenCVStorage(pcam, field);
      const std::string how = pc.exact ? "exact" : fmt::format("refit from {}: RMS {:.4f} px, max {:.4f} px over the image",
                                                               cam.model_name(), pc.fit.rms_px, pc.fit.max_px);
      w.content = OpenCVStorageText(c, format == Format::kOpenCVXml,
                                    fmt::format("porthole calibration, {} ({})",
                                                c.fisheye ? "cv::fisheye model" : "OpenCV pinhole model", how));
      w.format_model = c.fisheye ? "fisheye, 4 coefficients" : fmt::format("{} coefficients", c.distortion.size());
      break;
    }
    case Format::kMrcal: {
      MrcalModel m = ToMrcal(pcam, field);
      if (extras.rt_fromref) m.rt_fromref = *extras.rt_fromref;
      w.content = MrcalText(m, pc.exact ? "exact" : fmt::format("refit from {}, RMS {:.6f} px",
                                                                cam.model_name(), pc.fit.rms_px));
      w.format_model = m.lensmodel;
      break;
    }
    default: throw InternalError("format not handled");
  }
  return w;
}

}  // namespace porthole::interop
