#include "porthole/io/lookup.h"

#include <regex>

#include <fmt/format.h>
#include <lensfun/lensfun.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>

#include "porthole/core/error.h"
#include "porthole/io/presets.h"

namespace porthole::io {
namespace {

constexpr double kFullFrameDiagonalMm = 43.2666;  // 36 × 24 mm
constexpr double kEpToSensorFullFrameMm = 68.1;   // mean of the paper's 24 and 35 mm (Table 2 + 46.5)

// The database, loaded once (lensfun's own XML under /usr/share/lensfun).
const lfDatabase* Db() {
  static lfDatabase* db = [] {
    lfDatabase* d = lf_db_new();
    if (lf_db_load(d) != LF_NO_ERROR) {
      lf_db_destroy(d);
      return static_cast<lfDatabase*>(nullptr);
    }
    return d;
  }();
  return db;
}

// True when io knows `name` as a preset or it names a TOML file.
bool IsPorthole(const std::string& kind, const std::string& name) {
  if (name.ends_with(".toml") || std::filesystem::is_regular_file(name)) return true;  // "f/2.8" is no path
  for (const Preset& p : BuiltinPresets()) {
    if (p.kind == kind && p.name == name) return true;
  }
  return false;
}

template <typename T>
using LfList = std::unique_ptr<const T*[], decltype(&lf_free)>;

std::string Str(const lfMLstr s) { return s ? lf_mlstr_get(s) : ""; }

// "Canon" + "Canon EF 24mm f/2.8" → "Canon EF 24mm f/2.8"; "Nikon" + "D850" → "Nikon D850".
std::string FullName(const lfMLstr maker, const lfMLstr model) {
  const std::string a = Str(maker), b = Str(model);
  return b.rfind(a, 0) == 0 ? b : a + " " + b;
}

// lensfun stores f-numbers as float: 2.8f reads back as 2.7999999523.
double FNumber(float v) { return std::round(v * 100.0) / 100.0; }

}  // namespace

std::optional<std::string> MountFromLensfun(const std::string& m) {
  auto starts = [&](const char* p) { return m.rfind(p, 0) == 0; };
  if (starts("Nikon F")) return "nikon-f";
  if (m == "Canon EF" || m == "Canon EF-S") return "canon-ef";
  if (m == "Sony E") return "sony-e";
  if (m == "Nikon Z") return "nikon-z";
  if (m == "Canon RF") return "canon-rf";
  if (m == "Micro 4/3 System") return "mft";
  if (m == "Fujifilm X") return "fujifilm-x";
  if (m == "Leica L") return "l-mount";
  if (starts("Pentax K")) return "pentax-k";
  return std::nullopt;
}

lens::CameraBody WithPixelPitch(lens::CameraBody body, double pitch_mm) {
  const double w = body.SensorWidthMm(), h = body.SensorHeightMm();
  const double pitch = RequirePositive("pixel_pitch_mm", pitch_mm);
  if (!(w / pitch < 1e6 && h / pitch < 1e6)) {
    throw InvalidInput("pixel_pitch_mm", "gives a million pixels or more across the sensor");
  }
  body.sensor = {static_cast<int>(std::max(1L, std::lround(w / pitch))),
                 static_cast<int>(std::max(1L, std::lround(h / pitch))), pitch};
  return body;
}

lens::CameraBody FindCamera(const std::string& name, std::optional<double> pitch) {
  if (IsPorthole("camera", name)) {
    lens::CameraBody b = LoadCamera(name);
    // Another pitch for a preset or file body: the same sensor (its size in mm), other pixels.
    if (pitch && *pitch != b.sensor.pixel_pitch_mm) b = WithPixelPitch(b, *pitch);
    return b;
  }
  if (!Db()) throw InvalidInput("camera", "unknown camera '" + name + "' (and the lensfun database is missing)");
  LfList<lfCamera> found(lf_db_find_cameras_ext(Db(), nullptr, name.c_str(), LF_SEARCH_LOOSE), &lf_free);
  if (!found || !found[0]) {
    throw InvalidInput("camera", "unknown camera '" + name + "': not a preset ('porthole presets'), a file, "
                                   "nor in the lensfun database");
  }
  const lfCamera* c = found[0];
  lens::CameraBody b;
  b.name = FullName(c->Maker, c->Model);
  const auto mount = MountFromLensfun(c->Mount ? c->Mount : "");
  if (!mount) throw InvalidInput("camera", fmt::format("{} has mount '{}', which porthole does not know", b.name, c->Mount ? c->Mount : ""));
  if (!pitch) throw InvalidInput("pixel_pitch_mm", "lensfun does not know the pixel pitch of the " + b.name + "; give it in mm");
  RequirePositive("pixel_pitch_mm", *pitch);
  b.mount = *mount;
  const double diag = kFullFrameDiagonalMm / c->CropFactor;
  const double aspect = *mount == "mft" ? 4.0 / 3.0 : 1.5;
  const double h = diag / std::hypot(aspect, 1.0);
  b.sensor = {static_cast<int>(std::lround(aspect * h / *pitch)), static_cast<int>(std::lround(h / *pitch)), *pitch};
  b.description = fmt::format("{} (lensfun: crop factor {:g}, {} aspect assumed)", b.name, c->CropFactor,
                              *mount == "mft" ? "4:3" : "3:2");
  b.source = "lensfun database (liblensfun-data-v1)";
  return b;
}

lens::LensSpec FindLens(const std::string& name, std::optional<double> focal_mm) {
  if (IsPorthole("lens", name)) return LoadLens(name);
  if (!Db()) throw InvalidInput("lens", "unknown lens '" + name + "' (and the lensfun database is missing)");
  LfList<lfLens> found(lf_db_find_lenses_hd(Db(), nullptr, nullptr, name.c_str(), LF_SEARCH_LOOSE), &lf_free);
  if (!found || !found[0]) {
    throw InvalidInput("lens", "unknown lens '" + name + "': not a preset ('porthole presets'), a file, nor in "
                                 "the lensfun database");
  }
  const lfLens* l = found[0];
  // lensfun's loose search returns its best guess even for a name that does not exist
  // ("nikkor-99mm" → a 50 mm lens): a focal length written in the query must match.
  static const std::regex kFocal(R"((\d+(?:\.\d+)?)\s*mm)", std::regex::icase);
  for (auto it = std::sregex_iterator(name.begin(), name.end(), kFocal); it != std::sregex_iterator(); ++it) {
    const double asked = std::stod((*it)[1].str());
    if (asked < l->MinFocal - 0.5 || asked > l->MaxFocal + 0.5) {
      throw InvalidInput("lens", fmt::format("unknown lens '{}': not a preset ('porthole presets'), a file, nor in "
                                               "the lensfun database (nearest: {})",
                                               name, FullName(l->Maker, l->Model)));
    }
  }
  lens::LensSpec s;
  s.name = FullName(l->Maker, l->Model);
  for (char** m = l->Mounts; m && *m; ++m) {
    const auto mount = MountFromLensfun(*m);
    if (!mount) continue;
    if (s.mount.empty()) {
      s.mount = *mount;
    } else if (*mount != s.mount) {
      s.other_mounts.push_back(*mount);
    }
  }
  if (s.mount.empty()) throw InvalidInput("lens", s.name + " has no mount porthole knows");
  bool estimated = false;
  const auto projection = ProjectionFromLensfunType(l->Type, &estimated);
  if (!projection) {
    throw InvalidInput("lens", fmt::format("{} is a {} lens in lensfun; porthole plans rectilinear and fisheye lenses "
                                           "only", s.name, l->Type == LF_PANORAMIC ? "panoramic" : "equirectangular"));
  }
  s.projection = *projection;
  s.projection_estimated = estimated;
  // lensfun's default type is rectilinear: a lens it calls a fisheye but records no type for is
  // taken as equidistant, and said to be a guess.
  std::string lower = s.name;
  for (char& ch : lower) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  if (s.projection == camera::Projection::kRectilinear && lower.find("fisheye") != std::string::npos) {
    s.projection = camera::Projection::kEquidistant;
    s.projection_estimated = true;
  }
  if (l->MinFocal != l->MaxFocal && !focal_mm) {
    throw InvalidInput("focal_length_mm", fmt::format("{} is a zoom ({:g}-{:g} mm): give the focal length", s.name,
                                              l->MinFocal, l->MaxFocal));
  }
  s.focal_length_mm = focal_mm.value_or(l->MinFocal);
  if (s.focal_length_mm < l->MinFocal - 1e-6 || s.focal_length_mm > l->MaxFocal + 1e-6) {
    throw InvalidInput("focal_length_mm", fmt::format("{} covers {:g}-{:g} mm", s.name, l->MinFocal, l->MaxFocal));
  }
  s.f_number_min = l->MinAperture > 0 ? FNumber(l->MinAperture) : 2.8;
  s.f_number_max = l->MaxAperture > 0 ? FNumber(l->MaxAperture) : 22;
  const double f = s.focal_length_mm;
  s.min_focus_mm = 10 * f;
  // Estimated pupil: a fixed distance ahead of the sensor at infinity, then the thin-lens extension.
  const double ffd = lens::MountByName(s.mount).flange_focal_distance_mm;
  const double crop = l->CropFactor > 0 ? l->CropFactor : 1.0;
  const double ep_inf = kEpToSensorFullFrameMm / crop - ffd;
  for (double fd : {std::numeric_limits<double>::infinity(), 4 * s.min_focus_mm, 2 * s.min_focus_mm, s.min_focus_mm}) {
    s.pupil.push_back({fd, ep_inf + (std::isinf(fd) ? 0.0 : f * f / (fd - 2 * f))});
  }
  s.pupil_estimated = true;
  s.description = fmt::format(
      "lensfun data; minimum focus taken as 10 f = {:g} mm; entrance pupil taken {:.1f} mm ahead of the sensor at "
      "infinity (68.1 mm / crop factor {:g}, the mean of the paper's two measured Nikkors), moving forward by the "
      "thin-lens extension f^2/(FD - 2f) when focusing; {} projection{}",
      s.min_focus_mm, ep_inf + ffd, crop, camera::ProjectionName(s.projection),
      s.projection_estimated ? " (estimated: lensfun records no exact type for it)" : " (lensfun's lens type)");
  s.source = "lensfun database (liblensfun-data-v1); pupil: porthole estimate, docs/planning.md";
  return s;
}

std::optional<camera::Projection> ProjectionFromLensfunType(int t, bool* estimated) {
  if (estimated) *estimated = false;
  switch (t) {
    case LF_UNKNOWN:
    case LF_RECTILINEAR: return camera::Projection::kRectilinear;
    case LF_FISHEYE: return camera::Projection::kEquidistant;
    case LF_FISHEYE_EQUISOLID: return camera::Projection::kEquisolid;
    case LF_FISHEYE_STEREOGRAPHIC: return camera::Projection::kStereographic;
    case LF_FISHEYE_ORTHOGRAPHIC: return camera::Projection::kOrthographic;
    case LF_FISHEYE_THOBY:  // r = 1.47 f sin(0.713 θ): within 7 % of equisolid out to 90°
      if (estimated) *estimated = true;
      return camera::Projection::kEquisolid;
    default: return std::nullopt;  // panoramic, equirectangular
  }
}

CameraAndLens FindCameraAndLens(const CameraLensQuery& q) {
  CameraAndLens out;
  out.camera = FindCamera(q.camera, q.pixel_pitch_mm);
  if (out.camera.fixed_lens) {
    if (!q.lens.empty() && q.lens != out.camera.fixed_lens->name) {
      throw InvalidInput("lens", fmt::format("the {} has a fixed lens ({}); give no lens", out.camera.name,
                                             out.camera.fixed_lens->name));
    }
    out.lens = *out.camera.fixed_lens;
    return out;
  }
  const std::string& name = q.lens.empty() ? q.default_lens : q.lens;
  if (name.empty()) throw InvalidInput("lens", "the " + out.camera.name + " takes interchangeable lenses: give one");
  out.lens = lens::MountOn(FindLens(name, q.focal_length_mm), out.camera, q.allow_adapter);
  return out;
}

}  // namespace porthole::io
