// The rig formats of rig_files.h as one list (kRigFormats: name, extension, reader, writer), the
// detection of a rig file's format, and the read and write dispatch over the list. Each format is a
// file of its own: rig_json.cc, rig_opencv.cc (opencv-stereo, opencv-stereo-xml), rig_viame.cc,
// rig_ros.cc, rig_kalibr.cc; what they share is rig_yaml.cc and rig_common.cc (rig_internal.h).
#include "porthole/interop/rig_files.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <filesystem>

#include "porthole/camera/validate.h"
#include "porthole/core/error.h"
#include "porthole/core/input.h"
#include "porthole/interop/interop.h"
#include "porthole/interop/rig_internal.h"
#include "porthole/interop/text.h"

namespace porthole::interop {
namespace {

// The rig formats: the name `to` takes, the extension RigOutputFormat writes it for (empty: none),
// the reader and the writer (interop/rig_internal.h). The order is RigFormatNames'.
struct RigFormatEntry {
  RigFormat format;
  std::string_view name;
  std::string_view extension;
  detail::RigReader read;
  detail::RigWriter write;
};
constexpr std::array<RigFormatEntry, 6> kRigFormats{{
    {RigFormat::kJson, "json", ".json", detail::ReadRigJsonFile, detail::WriteRigJsonFile},
    {RigFormat::kOpenCVStereoYaml, "opencv-stereo", "", detail::ReadOpenCVStereoFile, detail::WriteOpenCVStereoFile},
    {RigFormat::kOpenCVStereoXml, "opencv-stereo-xml", ".xml", detail::ReadOpenCVStereoFile,
     detail::WriteOpenCVStereoFile},
    {RigFormat::kViameNpz, "viame-npz", ".npz", detail::ReadViameNpzFile, detail::WriteViameNpzFile},
    {RigFormat::kRosCameraInfo, "ros-camera-info", "", detail::ReadRosFile, detail::WriteRosFile},
    {RigFormat::kKalibr, "kalibr", "", detail::ReadKalibrFile, detail::WriteKalibrFile},
}};

const RigFormatEntry& Entry(RigFormat f) {
  for (const auto& e : kRigFormats) {
    if (e.format == f) return e;
  }
  throw InternalError("rig format not in kRigFormats");
}

}  // namespace

std::string_view RigFormatName(RigFormat f) {
  for (const auto& e : kRigFormats) {
    if (e.format == f) return e.name;
  }
  return "?";
}

std::string RigFormatNames() {
  std::string s;
  for (const auto& e : kRigFormats) s += (s.empty() ? "" : ", ") + std::string(e.name);
  return s;
}

RigFormat RigFormatFromName(std::string_view name, const std::string& field) {
  for (const auto& e : kRigFormats) {
    if (e.name == name) return e.format;
  }
  throw InvalidInput(field, fmt::format("unknown rig format '{}' (known: {})", std::string(name).substr(0, 40), RigFormatNames()));
}

LengthUnit LengthUnitFromName(std::string_view name, const std::string& field) {
  if (name == "mm") return LengthUnit::kMm;
  if (name == "cm") return LengthUnit::kCm;
  if (name == "m") return LengthUnit::kM;
  throw InvalidInput(field, fmt::format("unknown length unit '{}' (choices: mm, cm, m)", std::string(name).substr(0, 20)));
}

bool RigWriteResult::exact() const {
  return std::all_of(cameras.begin(), cameras.end(), [](const RigWriteCamera& c) { return c.exact; });
}
double RigWriteResult::worst_rms_px() const {
  double w = 0;
  for (const auto& c : cameras) {
    if (!c.exact) w = std::max(w, c.fit.rms_px);
  }
  return w;
}

std::optional<RigFormat> DetectRigFormat(const std::string& path, const std::string& content) {
  const std::string ext = Lower(std::filesystem::path(path).extension().string());
  if (ext == ".npz" || content.rfind("PK\x03\x04", 0) == 0) return RigFormat::kViameNpz;
  const auto start = content.find_first_not_of(" \t\r\n");
  if (start == std::string::npos) return std::nullopt;
  if (content[start] == '{') {  // a rig JSON has a top-level "rig" object (ParseRigFiles checks it)
    for (std::size_t p = content.find("\"rig\""); p != std::string::npos; p = content.find("\"rig\"", p + 1)) {
      const auto colon = content.find_first_not_of(" \t\r\n", p + 5);
      if (colon != std::string::npos && content[colon] == ':') return RigFormat::kJson;
    }
    return std::nullopt;
  }
  const auto has_key = [&](std::string_view key) {
    for (std::size_t p = content.find(key); p != std::string::npos; p = content.find(key, p + 1)) {
      const bool line_start = p == 0 || content[p - 1] == '\n';
      const bool xml_tag = p > 0 && content[p - 1] == '<';
      const std::size_t e = p + key.size();
      if ((line_start && e < content.size() && content[e] == ':') || (xml_tag && e < content.size() && (content[e] == '>' || content[e] == ' '))) {
        return true;
      }
    }
    return false;
  };
  if (content[start] == '<') {
    if (has_key("K1") && has_key("T")) return RigFormat::kOpenCVStereoXml;
    return std::nullopt;
  }
  if (has_key("K1") && has_key("K2") && has_key("T")) return RigFormat::kOpenCVStereoYaml;
  if (has_key("cam0") && content.find("intrinsics") != std::string::npos) return RigFormat::kKalibr;
  if (has_key("camera_name") && has_key("projection_matrix")) return RigFormat::kRosCameraInfo;
  return std::nullopt;
}

RigFile ParseRigFiles(const std::vector<std::string>& contents, const std::vector<std::string>& names,
                      const RigReadOptions& options, const std::string& field) {
  if (contents.empty()) throw InvalidInput(field, "no rig file given");
  if (!(options.pixel_pitch_mm > 0)) throw InvalidInput("pixel_pitch_mm", "must be > 0");
  std::optional<RigFormat> format = options.format;
  if (!format) {
    format = DetectRigFormat(names[0], contents[0]);
    if (!format) {
      throw InvalidInput(field, fmt::format("'{}' is not a rig file ({}; a single camera's calibration is not a rig)",
                                            names[0], RigFormatNames()));
    }
  }
  const std::string f = contents.size() == 1 || *format != RigFormat::kRosCameraInfo ? field + " '" + names[0] + "'" : field;
  if (*format != RigFormat::kRosCameraInfo && contents.size() != 1) {
    throw InvalidInput(field, fmt::format("{} is one file; {} were given (only ros-camera-info takes one per camera)",
                                          RigFormatName(*format), contents.size()));
  }
  // One file a camera (ros-camera-info) is named by each file; one file by its name.
  RigFile rig = Entry(*format).read(contents, names, *format, options, *format == RigFormat::kRosCameraInfo ? field : f);
  for (auto& c : rig.cameras) {
    try {
      camera::ValidateCalibration(c.calibration.camera, "camera " + c.name);
    } catch (const InvalidInput& e) {
      throw InvalidInput(f, e.what());
    }
  }
  return rig;
}

RigFile ReadRigFiles(const std::vector<std::string>& paths, const RigReadOptions& options, const std::string& field) {
  std::vector<std::string> contents;
  for (const auto& p : paths) contents.push_back(ReadInputFile(p, field, kMaxCalibrationFileBytes));
  return ParseRigFiles(contents, paths, options, field);
}

RigWriteResult WriteRigFile(const RigFile& rig, RigFormat format, const std::string& field) {
  RigWriteResult out;
  out.files = Entry(format).write(rig, format, field, &out.cameras);
  return out;
}

RigFormat RigOutputFormat(const std::string& path, const std::optional<std::string>& to, const std::string& field) {
  if (to) return RigFormatFromName(*to, "to");
  const std::string ext = Lower(std::filesystem::path(path).extension().string());
  for (const auto& e : kRigFormats) {
    if (!e.extension.empty() && e.extension == ext) return e.format;
  }
  if (std::filesystem::is_directory(path)) return RigFormat::kRosCameraInfo;
  if (ext == ".yml" || ext == ".yaml") {
    throw InvalidInput(field, fmt::format("'{}': a rig in .yaml could be opencv-stereo or kalibr (or ros-camera-info, one file a "
                                          "camera into a directory): give `to`",
                                          path));
  }
  throw InvalidInput(field, fmt::format("'{}': no rig format for this name; give `to` ({})", path, RigFormatNames()));
}

std::vector<calib::CalibrationRecord> ReadRigCalibrations(const std::vector<std::string>& paths,
                                                          const RigReadOptions& options, const std::string& field) {
  RigFile rig = ReadRigFiles(paths, options, field);
  std::vector<calib::CalibrationRecord> out;
  for (auto& c : rig.cameras) out.push_back(std::move(c.calibration));
  return out;
}

}  // namespace porthole::interop
