// The calibration formats of interop.h as one list (kFormats: name, extensions, reader, writer),
// the detection of a file's format, and the read and write dispatch over the list. Each format is a
// file of its own: porthole_json.cc, opencv_storage.cc (opencv-yaml, opencv-xml), colmap.cc
// (colmap, colmap-bin), mrcal.cc, metashape.cc, calibmar.cc; the model refits with σ are refit.cc.
#include "porthole/interop/interop.h"

#include <fmt/format.h>

#include <array>
#include <filesystem>
#include <optional>

#include "porthole/camera/validate.h"
#include "porthole/core/error.h"
#include "porthole/core/input.h"
#include "porthole/interop/internal.h"
#include "porthole/interop/text.h"

namespace porthole::interop {
namespace {

using camera::Camera;
using camera::CameraModelId;

// The formats: the name `to` takes, the extensions OutputFormat writes them for, the reader and the
// writer (interop/internal.h). The order is FormatNames'.
struct FormatEntry {
  Format format;
  std::string_view name;
  std::array<std::string_view, 2> extensions;  // lower case, with the dot; empty: none
  detail::Reader read;
  detail::Writer write;
  // The reader validates the calibration itself (porthole JSON: CalibrationFromJson, naming the
  // line of the offending key), so ReadCalibration does not again.
  bool reader_validates = false;
};
constexpr std::array<FormatEntry, 8> kFormats = {{
    {Format::kJson, "json", {".json"}, detail::ReadPortholeJson, detail::WritePortholeJson, true},
    {Format::kOpenCVYaml, "opencv-yaml", {".yml", ".yaml"}, detail::ReadOpenCVStorageFile,
     detail::WriteOpenCVStorageFile},
    {Format::kOpenCVXml, "opencv-xml", {}, detail::ReadOpenCVStorageFile, detail::WriteOpenCVStorageFile},
    {Format::kColmapText, "colmap", {".txt"}, detail::ReadColmapFile, detail::WriteColmapFile},
    {Format::kColmapBinary, "colmap-bin", {".bin"}, detail::ReadColmapFile, detail::WriteColmapFile},
    {Format::kMrcal, "mrcal", {".cameramodel"}, detail::ReadMrcalFile, detail::WriteMrcalFile},
    {Format::kMetashape, "metashape", {".xml"}, detail::ReadMetashapeFile, detail::WriteMetashapeFile},
    {Format::kCalibmar, "calibmar", {}, detail::ReadCalibmarFile, detail::WriteCalibmarFile},
}};

const FormatEntry& Entry(Format f) {
  for (const auto& e : kFormats) {
    if (e.format == f) return e;
  }
  throw InternalError("format not in kFormats");
}

std::string Ext(const std::string& path) {
  return Lower(std::filesystem::path(path).extension().string());
}

// The format the list writes for this extension, if any.
std::optional<Format> FormatOfExtension(const std::string& ext) {
  for (const auto& e : kFormats) {
    for (const auto x : e.extensions) {
      if (!x.empty() && x == ext) return e.format;
    }
  }
  return std::nullopt;
}

// ReadCalibration, with `origin` (the file) naming the line of a bad JSON value ("file:N:").
ReadResult ReadCalibrationFrom(const std::string& content, Format format, double pixel_pitch_mm,
                               const std::string& field, int camera_id, const std::string& origin) {
  RequirePositive("pixel_pitch_mm", pixel_pitch_mm);
  const FormatEntry& entry = Entry(format);
  ReadResult r = entry.read(content, {format, pixel_pitch_mm, field, camera_id, origin});
  // The one validation of what was read.
  if (!entry.reader_validates) camera::ValidateCalibration(r.camera(), field);
  return r;
}

}  // namespace

namespace detail {

[[noreturn]] void NoRepresentation(const Camera& cam, std::string_view format, const std::string& field,
                                   std::string_view hint) {
  throw InvalidInput(field, fmt::format("the {} model has no {} equivalent ({})", cam.model_name(),
                                        format, hint));
}

calib::CalibrationRecord NoSigmaRecord(const Camera& cam, Format format) {
  return WithoutSigma(cam, fmt::format("σ unknown: {} holds none", FormatName(format)));
}

}  // namespace detail

std::string_view FormatName(Format f) { return Entry(f).name; }

std::string FormatNames() {
  std::string s;
  for (const auto& e : kFormats) s += (s.empty() ? "" : ", ") + std::string(e.name);
  return s;
}

Format FormatFromName(std::string_view name, const std::string& field) {
  const std::string n = Lower(std::string(name));
  for (const auto& e : kFormats) {
    if (e.name == n) return e.format;
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
  // The extension of a format of the list (.yml/.yaml, .cameramodel, .bin, .txt, …), but an .xml
  // is OpenCV's when it holds <opencv_storage>, else Metashape's.
  const std::optional<Format> by_ext = FormatOfExtension(ext);
  if (by_ext && *by_ext != Format::kMetashape) return *by_ext;
  if (content.find("<opencv_storage") != std::string::npos) return Format::kOpenCVXml;
  if (by_ext || content.find("<calibration") != std::string::npos) return Format::kMetashape;
  const auto first = content.find_first_not_of(" \t\r\n");
  if (first != std::string::npos) {
    if (content[first] == '{' && content.find("'lensmodel'") != std::string::npos) return Format::kMrcal;
    if (content[first] == '{') return Format::kJson;
    if (content.compare(first, 5, "%YAML") == 0) return Format::kOpenCVYaml;
    if (content.find("'lensmodel'") != std::string::npos) return Format::kMrcal;
    try {
      if (!detail::ParseColmapText(content, field).empty()) return Format::kColmapText;
    } catch (const InvalidInput&) {
    }
  }
  throw InvalidInput(field, "'" + path + "': cannot tell its format from the extension or the content "
                            "(known: " + FormatNames() + ")");
}

Format OutputFormat(const std::string& path, const std::optional<std::string>& to, const std::string& field) {
  if (to) return FormatFromName(*to, "to");
  if (const auto f = FormatOfExtension(Ext(path))) return *f;
  throw InvalidInput(field, "'" + path + "': cannot tell the format from the extension (.json, .yml, "
                            ".cameramodel, cameras.txt, cameras.bin, .xml): give `to`");
}

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

WriteResult WriteCamera(const Camera& cam, Format format, const std::string& field) {
  return WriteCalibration(WithoutSigma(cam, ""), format, field);
}

WriteResult WriteCalibration(const calib::CalibrationRecord& cal, Format format, const std::string& field,
                             const WriteExtras& extras) {
  camera::ValidateCalibration(cal.camera, field);  // porthole writes nothing its readers refuse
  return Entry(format).write(cal, format, field, extras);
}

}  // namespace porthole::interop
