// COLMAP's camera list, cameras.txt (format colmap) and cameras.bin (colmap-bin): its models as
// colmap/src/base/camera_models.h numbers and names them, the text and binary layouts of
// colmap/src/base/reconstruction.cc (WriteCamerasText, WriteCamerasBinary), and refractive COLMAP's
// housing appended to a cameras.txt line (the COLMAP-Underwater fork; interop/refractive.h);
// docs/interop.md, "COLMAP". COLMAP's top-left pixel centre is (0.5, 0.5), porthole's (0, 0).
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <sstream>

#include "porthole/camera/validate.h"
#include "porthole/core/error.h"
#include "porthole/interop/interop.h"
#include "porthole/interop/internal.h"
#include "porthole/interop/refractive.h"

namespace porthole::interop {
namespace {

using camera::Camera;
using camera::CameraModelId;
using OpenCV = camera::OpenCVModel;
using KB = camera::KannalaBrandtModel;
using detail::NoRepresentation;
using detail::Num;
using detail::OpenCVCamera;
using detail::PixelCalibration;
using detail::PixelSensor;
using detail::ToPixelFamily;

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


double ColmapNumber(const std::string& tok, const std::string& where) {
  char* end = nullptr;
  const double v = std::strtod(tok.c_str(), &end);
  if (end != tok.c_str() + tok.size() || !std::isfinite(v)) {
    throw InvalidInput(where, "'" + tok.substr(0, 40) + "' is not a finite number");
  }
  return v;
}

}  // namespace

namespace detail {

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

}  // namespace detail

namespace {

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

}  // namespace

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

namespace detail {

ReadResult ReadColmapFile(const std::string& content, const ReadArgs& args) {
  ReadResult r = FromColmapList(args.format == Format::kColmapBinary ? ParseColmapBinary(content, args.field)
                                                                     : ParseColmapText(content, args.field),
                                args.format, args.pixel_pitch_mm, args.field, args.camera_id);
  r.calibration = NoSigmaRecord(r.camera(), args.format);
  return r;
}

WriteResult WriteColmapFile(const calib::CalibrationRecord& cal, Format format, const std::string& field,
                            const WriteExtras& extras) {
  // The housing goes into refractive COLMAP's cameras.txt only.
  return WriteColmapCameras({{cal, 1, format == Format::kColmapText ? extras.housing : std::nullopt}}, format, field);
}

}  // namespace detail

}  // namespace porthole::interop
