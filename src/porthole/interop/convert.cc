// `porthole convert` as one call: the format rules of a conversion (convert.h).
#include "porthole/interop/convert.h"

#include <fmt/format.h>

#include <filesystem>
#include <string_view>

#include "porthole/core/error.h"
#include "porthole/core/field_names.h"
#include "porthole/core/input.h"
#include "porthole/core/output.h"
#include "porthole/core/plausible.h"
#include "porthole/interop/refractive.h"
#include "porthole/catalogue/presets.h"
#include "porthole/materials/materials.h"

namespace porthole::interop {
namespace {

namespace fs = std::filesystem;

std::optional<std::string> NoWord(std::string_view) { return std::nullopt; }

// The rig format names `to` may give (RigFormatNames() but json, which a single camera shares).
bool IsRigFormatName(const std::string& to) {
  for (const std::string_view name : {"opencv-stereo", "opencv-stereo-xml", "viame-npz", "ros-camera-info", "kalibr"}) {
    if (to == name) return true;
  }
  return false;
}

// The options a rig conversion cannot use, and those only a rig conversion can.
void CheckRigOptions(const ConvertOptions& o, bool rig) {
  if (rig) {
    if (!o.port.empty() || !o.port_out.empty() || o.water_index || o.camera_id != 0) {
      throw InvalidInput(!o.port.empty()       ? "port"
                         : !o.port_out.empty() ? "port_out"
                         : o.water_index       ? "water_index"
                                               : "camera_id",
                         "is for a single camera's calibration, not a rig");
    }
  } else if (!o.length_unit.empty() || o.image_size_px) {
    throw InvalidInput(o.length_unit.empty() ? "image_size_px" : "length_unit", "is for rig files (`inputs` is not one)");
  }
}

// Every input (and, for a COLMAP folder, its cameras.txt / .bin) and `port`: no output replaces them.
OutputRules RulesOf(const ConvertOptions& o, bool with_colmap_files) {
  OutputRules rules{.force = o.force, .inputs = {}};
  if (!o.port.empty()) rules.inputs.emplace_back(o.port);
  for (const auto& path : o.inputs) {
    rules.inputs.emplace_back(path);
    if (!with_colmap_files) continue;
    for (const char* name : {"cameras.txt", "cameras.bin"}) rules.inputs.push_back(fs::path(path) / name);
  }
  return rules;
}

// The inputs read as one rig, written as one (ROS: one file per camera into the directory `out`).
ConvertResult ConvertRig(const ConvertOptions& o, ConvertResult res) {
  RigReadOptions opt;
  opt.pixel_pitch_mm = o.pixel_pitch_mm.value_or(1.0);
  if (!o.length_unit.empty()) opt.length_unit = LengthUnitFromName(o.length_unit, "length_unit");
  if (o.image_size_px) {
    const auto [w, h] = *o.image_size_px;
    if (!(w >= 1 && h >= 1 && w <= 1000000 && h <= 1000000)) {
      throw InvalidInput("image_size_px", fmt::format("{} x {} must be a width and height in pixels, each 1 to 1000000", w, h));
    }
    opt.image_size = o.image_size_px;
  }
  res.rig = true;
  res.out = o.out;
  res.pitch_given = o.pixel_pitch_mm.has_value();
  res.rig_in = ReadRigFiles(o.inputs, opt, "inputs");
  res.rig_format = RigOutputFormat(o.out, o.to, "out");
  res.rig_written = WriteRigFile(res.rig_in, res.rig_format, "out '" + o.out + "'");
  const OutputRules rules = RulesOf(o, false);
  std::vector<fs::path> paths;
  if (res.rig_format == RigFormat::kRosCameraInfo) {
    if (fs::exists(o.out) && !fs::is_directory(o.out)) {
      throw InvalidInput("out", "'" + o.out + "': ros-camera-info writes one file per camera into a directory");
    }
    std::error_code ec;
    fs::create_directories(o.out, ec);
    if (ec) throw InvalidInput("out", "'" + o.out + "': cannot create the directory: " + ec.message());
    for (const auto& [name, unused] : res.rig_written.files) paths.push_back(fs::path(o.out) / name);
  } else {
    paths.emplace_back(o.out);
  }
  const FileKind kind = res.rig_format == RigFormat::kJson ? FileKind::kCalibration : FileKind::kOther;
  for (const auto& p : paths) CheckOutput(p, "out", rules, kind);
  for (std::size_t i = 0; i < paths.size(); ++i) WriteOutput(paths[i], res.rig_written.files[i].second, "out", rules);
  for (const auto& p : paths) res.out_files.push_back(p.string());
  return res;
}

// The housing of `port` (a preset or TOML) for every camera of a calibmar or COLMAP cameras.txt output.
std::optional<RefractiveHousing> HousingOfPort(const ConvertOptions& o, Format format) {
  if (o.water_index && o.port.empty()) throw InvalidInput("water_index", "goes with `port`");
  if (o.port.empty()) return std::nullopt;
  if (format != Format::kCalibmar && format != Format::kColmapText) {
    throw InvalidInput("port", "only calibmar and COLMAP cameras.txt (refractive COLMAP) outputs hold a housing");
  }
  const ports::PortSpec port = catalogue::LoadPort(o.port);
  const double n_water = o.water_index ? *o.water_index : materials::Index("seawater");
  return RefractiveFromPort(port, materials::Index(port.material()), n_water, "port");
}

// Reading (a Metashape model with terms porthole's lacks) or writing (Brown to a pixel format) may be
// a refit: the one that is, the largest by RMS if several are.
void CombineFits(ConvertResult* res) {
  res->exact = res->written.exact;
  res->fit = res->written.fit;
  for (const auto& r : res->reads) {
    if (!r.read.exact && (res->exact || r.read.fit.rms_px > res->fit.rms_px)) res->fit = r.read.fit;
    res->exact = res->exact && r.read.exact;
  }
}

}  // namespace

bool IsRigConversion(const ConvertOptions& o) {
  if (o.to && IsRigFormatName(*o.to)) return true;
  if (o.inputs.empty()) return false;
  std::error_code ec;
  if (!fs::is_regular_file(o.inputs.front(), ec)) return false;
  std::string head;
  try {
    head = ReadInputFile(o.inputs.front(), "inputs", kMaxCalibrationFileBytes);
  } catch (const InvalidInput&) {
    return false;  // the calibration reader reports it
  }
  const auto f = DetectRigFormat(o.inputs.front(), head);
  if (!f) return false;
  if (*f == RigFormat::kRosCameraInfo) {  // one camera_info is a camera (opencv-yaml), two a rig into JSON
    return o.inputs.size() > 1 && (o.to == "json" || fs::path(o.out).extension() == ".json");
  }
  return true;
}

std::vector<std::string> ConvertWarnings(const ConvertOptions& o) {
  std::vector<std::string> w;
  if (o.pixel_pitch_mm) {
    if (auto text = PlausibilityWarning("pixel_pitch_mm", *o.pixel_pitch_mm, kPixelPitchRange)) w.push_back(*text);
  }
  return w;
}

ConvertResult Convert(const ConvertOptions& o) {
  if (o.pixel_pitch_mm) RequirePositive("pixel_pitch_mm", *o.pixel_pitch_mm);
  if (o.inputs.empty()) throw InvalidInput("inputs", "give at least one calibration (or rig) file to read");
  if (o.out.empty()) throw InvalidInput("out", "give the file to write");
  ConvertResult res;
  res.inputs = o.inputs;
  res.warnings = ConvertWarnings(o);
  const bool rig = IsRigConversion(o);
  CheckRigOptions(o, rig);
  if (rig) return ConvertRig(o, std::move(res));

  for (const auto& path : o.inputs) {
    res.reads.push_back({path, ReadCalibrationFile(path, o.pixel_pitch_mm.value_or(1.0), "inputs", o.camera_id)});
  }
  fs::path out = o.out;
  if (fs::is_directory(out)) {  // a COLMAP sparse-model folder: its cameras.txt (or .bin)
    const auto dir_format = o.to ? FormatFromName(*o.to, "to") : Format::kColmapText;
    if (dir_format != Format::kColmapText && dir_format != Format::kColmapBinary) {
      throw InvalidInput("out", "'" + o.out + "' is a directory: only COLMAP writes into one");
    }
    out /= dir_format == Format::kColmapText ? "cameras.txt" : "cameras.bin";
  }
  res.out = out.string();
  res.format = OutputFormat(out.string(), o.to, "out");
  res.several = res.reads.size() > 1;
  if (res.several && res.format != Format::kColmapText && res.format != Format::kColmapBinary) {
    throw InvalidInput("out", fmt::format("{} inputs: only COLMAP's cameras.txt / cameras.bin hold several cameras, "
                                          "not {}", res.reads.size(), FormatName(res.format)));
  }
  // The refractive housing: the input's, or the port given (for every camera).
  const std::optional<RefractiveHousing> port_housing = HousingOfPort(o, res.format);
  const ReadResult& in = res.reads.front().read;
  std::string port_toml;
  if (!o.port_out.empty()) {
    if (res.several) throw InvalidInput("port_out", "goes with one `inputs`");
    if (!in.housing) {
      throw InvalidInput("port_out", "`inputs` has no housing (only calibmar files and refractive COLMAP cameras.txt hold one)");
    }
    ports::PortSpec port = PortFromRefractive(*in.housing, "inputs '" + o.inputs.front() + "'", &res.port_water_index);
    const std::string note = fmt::format("; water index {:g} (give `water_index`)", res.port_water_index);
    port.description += o.words ? o.words(note) : RenameQuotedFieldsBy(NoWord, note);
    port_toml = catalogue::PortToToml(port) + HousingSigmaToml(*in.housing);
    catalogue::ParsePortToml(port_toml, "port_out");  // porthole reads what it writes
    res.port_out = o.port_out;
  }
  const std::string out_field = "out '" + out.string() + "'";
  if (res.several) {
    std::vector<ColmapEntry> entries;
    for (std::size_t i = 0; i < res.reads.size(); ++i) {
      entries.push_back({res.reads[i].read.calibration, static_cast<int>(i) + 1,
                         port_housing ? port_housing : res.reads[i].read.housing});
      if (res.format == Format::kColmapBinary) entries.back().housing.reset();  // cameras.txt only
    }
    res.written = WriteColmapCameras(entries, res.format, out_field);
  } else {
    const WriteExtras extras{port_housing ? port_housing : in.housing, in.rt_fromref};  // where the output holds them
    res.written = WriteCalibration(in.calibration, res.format, out_field, extras);
  }
  // The overwrite rule (core/output.h): both outputs checked before either is written.
  const OutputRules rules = RulesOf(o, true);
  CheckOutput(out, "out", rules, KindOfText(res.written.content));
  if (!port_toml.empty()) CheckOutput(o.port_out, "port_out", rules);
  WriteOutput(out, res.written.content, "out", rules);
  res.out_files.push_back(out.string());
  if (!port_toml.empty()) {
    WriteOutput(o.port_out, port_toml, "port_out", rules);
    res.out_files.push_back(o.port_out);
  }
  CombineFits(&res);
  res.housing_written = (res.format == Format::kCalibmar || res.format == Format::kColmapText) &&
                        (in.housing || port_housing);
  return res;
}

nlohmann::ordered_json ConvertJson(const ConvertResult& r) {
  using Json = nlohmann::ordered_json;
  if (r.rig) {
    Json cams = Json::array();
    for (const auto& c : r.rig_written.cameras) {
      cams.push_back({{"name", c.name},
                      {"out_model", c.format_model},
                      {"exact", c.exact},
                      {"refit_rms_px", c.exact ? 0.0 : c.fit.rms_px},
                      {"refit_max_px", c.exact ? 0.0 : c.fit.max_px}});
    }
    const RigFormat in = r.rig_in.format, out = r.rig_format;
    return Json{{"in", r.inputs},
                {"in_format", std::string(RigFormatName(in))},
                {"out", r.out},
                {"out_files", r.out_files},
                {"out_format", std::string(RigFormatName(out))},
                {"n_cameras", r.rig_in.cameras.size()},
                {"length_unit", r.rig_in.length_unit_note},
                {"pitch", r.rig_in.pitch_known ? "from the file" : r.pitch_given ? "`pixel_pitch_mm`" : "none: pixels are mm"},
                {"exact", r.rig_written.exact()},
                {"sigma", in != RigFormat::kJson    ? "unknown: the input holds none"
                          : out != RigFormat::kJson ? "dropped: the format holds none"
                                                    : "dropped: the rig JSON is rewritten without its covariance"},
                {"cameras", cams}};
  }
  const ReadResult& in = r.reads.front().read;
  Json cameras = Json::array();
  for (std::size_t i = 0; i < r.reads.size(); ++i) {
    cameras.push_back({{"in", r.reads[i].path},
                       {"in_format", std::string(FormatName(r.reads[i].read.format))},
                       {"in_model", r.reads[i].read.format_model},
                       {"camera_id", r.several ? Json(i + 1) : Json(nullptr)}});
  }
  return Json{{"in", r.reads.front().path},
              {"in_format", std::string(FormatName(in.format))},
              {"in_model", in.format_model},
              {"camera_model", std::string(in.camera().model_name())},
              {"cameras", cameras},
              {"out", r.out},
              {"out_format", std::string(FormatName(r.format))},
              {"out_model", r.written.format_model},
              {"exact", r.exact},
              {"refit_rms_px", r.exact ? Json(0.0) : Json(r.fit.rms_px)},
              {"refit_max_px", r.exact ? Json(0.0) : Json(r.fit.max_px)},
              {"sigma", r.written.sigma_written              ? "written"
                        : in.calibration.has_covariance ? "dropped: the format holds none"
                                                        : "unknown"},
              {"housing", in.housing ? Json(in.housing->model) : Json(nullptr)},
              {"housing_written", r.housing_written},
              {"port_out", r.port_out.empty() ? Json(nullptr) : Json(r.port_out)},
              {"water_index", std::isfinite(r.port_water_index) ? Json(r.port_water_index) : Json(nullptr)},
              {"in_rms_px", std::isfinite(in.file_rms_px) ? Json(in.file_rms_px) : Json(nullptr)},
              {"width_px", in.camera().sensor.width_px},
              {"height_px", in.camera().sensor.height_px}};
}

}  // namespace porthole::interop
