// CalibrateRigJob: the steps of `porthole calibrate` with a rig and of Python's calibrate_rig,
// written once (calib/rig_job.h).
#include "porthole/calib/rig_job.h"

#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <utility>

#include "porthole/calib/detections_json.h"
#include "porthole/calib/job.h"
#include "porthole/calib/result_json.h"
#include "porthole/camera/validate.h"
#include "porthole/catalogue/presets.h"
#include "porthole/core/error.h"
#include "porthole/core/plausible.h"
#include "porthole/housing/plausible.h"
#include "porthole/interop/interop.h"
#include "porthole/interop/rig_files.h"

namespace porthole::calib {
namespace {

using Say = std::function<void(const std::string&)>;

// Item k of a list that holds one for all or one per camera.
template <typename T>
const T& OneOrEach(const std::vector<T>& list, int k) {
  return list[list.size() == 1 ? 0 : k];
}

// One for all or one per camera, else refused naming `field` ("3 models for 2 cameras: …").
void RequireOneOrEach(std::size_t given, int n, const std::string& field, const std::string& what) {
  if (given != 1 && static_cast<int>(given) != n) {
    throw InvalidInput(field, fmt::format("{} {} for {} cameras: give one for all or one per camera", given, what, n));
  }
}

void Warn(const CalibrateRigJobOptions& o, CalibrateRigJobResult* out, const std::string& w) {
  out->warnings.push_back(w);
  if (o.warn) o.warn(w);
}

// The single camera's options a rig does not take (yet), refused by their names.
void RequireRigOptions(const CalibrateRigJobOptions& o) {
  const std::pair<const char*, bool> not_in_rig[] = {
      {"intrinsics", o.intrinsics},
      {"free_water_index", o.free_water_index}, {"free_shell", o.free_shell}, {"port_sigma", o.port_sigma},
      {"plan_only", o.plan_only}, {"drop_insignificant", o.lens.drop_insignificant},
      {"free_port", o.free_port}};
  for (const auto& [field, given] : not_in_rig) {
    if (given) throw InvalidInput(field, "not with a rig (several cameras) yet");
  }
  if (o.opencv_yaml) {
    throw InvalidInput("opencv_yaml", "writes one camera: a rig's first two cameras go to OpenCV's stereo file "
                                      "(`stereo_out`)");
  }
}

// The in-air lenses of a rig given as one rig file (porthole's rig JSON, OpenCV's stereo YAML/XML,
// VIAME's npz, a Kalibr camchain) or as one ROS camera_info per camera: each camera's calibration,
// in rig order; nullopt when the files are single cameras' calibrations.
std::optional<std::vector<CalibrationRecord>> AirLensesOfARigFile(const std::vector<std::string>& files,
                                                                   double pixel_pitch_mm) {
  std::ifstream in(files.front(), std::ios::binary);
  if (!in) return std::nullopt;  // the single-camera reader names the missing file
  const std::string content((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!interop::DetectRigFormat(files.front(), content)) return std::nullopt;
  interop::RigReadOptions ro;
  ro.pixel_pitch_mm = pixel_pitch_mm;
  // Only the lenses are taken: the cameras' poses (and so the unit of T) are not used.
  ro.length_unit = interop::LengthUnit::kMm;
  return interop::ReadRigCalibrations(files, ro, "air_calibration");
}

// The lens options: one set for all, or one per camera when the models or the pitches differ.
std::vector<CalibrationOptions> CameraOptions(const CalibrateRigJobOptions& o, const std::vector<double>& pitches,
                                              int n) {
  std::vector<CalibrationOptions> cameras;
  const int n_options = o.model.size() == 1 && pitches.size() == 1 ? 1 : n;
  for (int k = 0; k < n_options; ++k) {
    CalibrationOptions c =
        LensOptionsFromNames(o.lens, OneOrEach(o.model, k), o.free, o.loss, o.centre_correction, o.datum);
    c.pixel_pitch_mm = OneOrEach(pitches, k);
    cameras.push_back(c);
  }
  return cameras;
}

// The in-air calibrations as each camera's model: from one rig file, one file per camera, or given.
void ReadAirLenses(const CalibrateRigJobOptions& o, const std::optional<std::vector<CalibrationRecord>>& rig_air,
                   const std::vector<double>& pitches, int n, RigOptions* ro) {
  const auto model_of = [&](int k) { return OneOrEach(ro->cameras, k).model; };
  if (o.air_given) {
    for (int k = 0; k < n; ++k) {
      ro->air_lens.push_back(interop::ConvertCalibration((*o.air_given)[k], model_of(k), "air_calibration"));
    }
    return;
  }
  if (!rig_air) {
    for (int k = 0; k < static_cast<int>(o.air_calibration.size()); ++k) {
      ro->air_lens.push_back(
          interop::ReadCalibrationFileAs(o.air_calibration[k], OneOrEach(pitches, k), model_of(k), "air_calibration")
              .calibration);
    }
    return;
  }
  const Say& say = ro->cameras.front().progress;
  for (int k = 0; k < n; ++k) {  // a rig file: each camera's lens as the camera's model
    if (!(*rig_air)[k].has_covariance) {
      throw InvalidInput("air_calibration",
                         fmt::format("{} holds no covariance, and a rig takes each in-air lens as a prior with its "
                                     "covariance: give porthole's JSON of that calibration (the rig's `out`, or each "
                                     "lens's)",
                                     o.air_calibration.front()));
    }
    interop::ReadResult r;
    r.calibration = (*rig_air)[k];
    const interop::ReadResult as = interop::ConvertRead(std::move(r), model_of(k), fmt::format("air_calibration: camera {}", k));
    if (!as.exact && say) {
      say(fmt::format("air calibration of camera {}: refit to {} over the image, RMS {:.4f} px, max {:.4f} px", k,
                      camera::Info(model_of(k)).name, as.fit.rms_px, as.fit.max_px));
    }
    ro->air_lens.push_back(as.calibration);
  }
}

// A camera's name: its folder's or file's name (a folder given with a trailing slash too).
std::string NameOf(const std::string& source) {
  const std::filesystem::path p(source);
  const std::string name = p.filename().string();
  return name.empty() ? p.parent_path().filename().string() : name;
}

// Each camera's detections: searched here, read from files (the target from the first camera's,
// the others' refused when another), or given.
std::vector<std::vector<ImageDetections>> ReadCameras(const CalibrateRigJobOptions& o, const Say& say,
                                                      CalibrateRigJobResult* out) {
  const bool from_images = !o.images.empty();
  const std::vector<std::string>& sources = from_images ? o.images : o.detections;
  std::vector<std::vector<ImageDetections>> per_camera;
  if (from_images) out->images_source = nlohmann::ordered_json::array();
  const int n = o.given ? static_cast<int>(o.given->size()) : static_cast<int>(sources.size());
  for (int k = 0; k < n; ++k) {
    std::vector<ImageDetections> dets;
    if (o.given) {
      dets = (*o.given)[k];
    } else if (from_images) {
      const auto say_k = [say, name = out->rig_options.names[k]](const std::string& m) {
        if (say) say(name + ": " + m);
      };
      auto source = DetectSource(sources[k], out->target, o.frames, say_k, {}, "images");
      out->images_source->push_back(FrameChoiceToJson(source.choice, source.run.detections));
      dets = std::move(source.run.detections);
      for (auto& s : source.run.skipped) out->skipped.push_back({sources[k] + ": " + s.image, s.reason});
    } else {
      TargetSpec t = out->target;  // detections of another target than the first camera's are refused
      dets = LoadDetections(sources[k], "detections", &t);
      if (t.cols == 0) throw InvalidInput("target", "the detections name no target");
      if (k == 0) out->target = t;
      if (!o.field.empty() && out->target.field.empty()) LoadTargetField(o.field, &out->target);
    }
    KeepTargetPoints(out->target, &dets, say);
    per_camera.push_back(std::move(dets));
  }
  return per_camera;
}

// Air images through each camera's port (the housing on): one source per camera, in rig order.
void ReadAirImages(const CalibrateRigJobOptions& o, const Say& say, CalibrateRigJobResult* out) {
  const bool from_images = !o.air_images.empty();
  const std::vector<std::string>& sources = from_images ? o.air_images : o.air_detections;
  const int n = o.air_given_detections ? static_cast<int>(o.air_given_detections->size())
                                       : static_cast<int>(sources.size());
  const std::string field = from_images ? "air_images" : "air_detections";
  for (int k = 0; k < n; ++k) {
    const std::string& name = out->rig_options.names.empty() ? fmt::format("camera{}", k) : out->rig_options.names[k];
    std::vector<ImageDetections> dets;
    if (o.air_given_detections) {
      dets = (*o.air_given_detections)[k];
    } else if (from_images) {
      const auto say_k = [say, name](const std::string& m) {
        if (say) say(name + " in air: " + m);
      };
      auto source = DetectSource(sources[k], out->target, o.frames, say_k, {}, "air_images");
      dets = std::move(source.run.detections);
      for (auto& s : source.run.skipped) out->skipped.push_back({sources[k] + ": " + s.image, s.reason});
    } else {
      TargetSpec t = out->target;  // detections of another target are refused
      dets = LoadDetections(sources[k], "air_detections", &t);
    }
    KeepTargetPoints(out->target, &dets, say);
    if (dets.empty()) {
      throw InvalidInput(field, (o.air_given_detections ? name : sources[k]) +
                                    ": no image in which the target was found");
    }
    out->rig_options.air_images.push_back(std::move(dets));
  }
}

// The option combinations a rig cannot make, and the counts (before any image is searched).
void RequireConsistent(const CalibrateRigJobOptions& o, int n, const std::vector<double>& pitches,
                       const std::optional<std::vector<CalibrationRecord>>& rig_air) {
  const std::size_t n_air = o.air_given ? o.air_given->size() : o.air_calibration.size();
  if (rig_air && std::any_of(pitches.begin(), pitches.end(), [&](double p) { return p != pitches.front(); })) {
    // A pixel format read at one pitch would be wrong for the other cameras.
    throw InvalidInput("air_calibration", "one rig file with a pitch per camera: give each lens's calibration "
                                          "(a comma list) instead");
  }
  if (rig_air && static_cast<int>(rig_air->size()) != n) {
    throw InvalidInput("air_calibration", fmt::format("the rig file holds {} cameras, the rig {}", rig_air->size(), n));
  }
  if (!rig_air && n_air > 0 && static_cast<int>(n_air) != n) {
    throw InvalidInput("air_calibration", fmt::format("{} in-air calibrations for {} cameras: one per camera "
                                                      "(a comma list)", n_air, n));
  }
  if (o.port_out && o.port.empty()) throw InvalidInput("port_out", "only with `port` (cameras behind ports)");
  if (o.ep_mm && o.port.empty()) throw InvalidInput("ep", "only with `port` (cameras behind ports)");
  if (o.field_out && !o.lens.target_free) {
    throw InvalidInput("field_out", "needs `free_target` (without it no point is adjusted)");
  }
  if (o.air_lens_bare && n_air == 0) {
    throw InvalidInput("air_lens_bare", "says what `air_calibration` holds: give `air_calibration`");
  }
  if (o.free != "default" && o.model.size() > 1) {
    throw InvalidInput("free", "names one model's parameters: not with a model per camera");
  }
  const bool air_from_images = !o.air_images.empty();
  if (air_from_images || !o.air_detections.empty() || o.air_given_detections) {
    const std::string field = air_from_images ? "air_images" : "air_detections";
    if (o.port.empty()) throw InvalidInput(field, "only with `port` (images in air through the ports)");
    const std::size_t given = o.air_given_detections ? o.air_given_detections->size()
                              : air_from_images      ? o.air_images.size()
                                                     : o.air_detections.size();
    if (static_cast<int>(given) != n) {
      throw InvalidInput(field, fmt::format("{} given for {} cameras: one set of air images per camera (a comma "
                                            "list, in the order of the cameras)", given, n));
    }
  }
}

// The first two cameras as OpenCV knows them (the opencv model without a port), refused before
// the work otherwise.
void RequireStereoPair(const std::vector<CalibrationOptions>& cameras, bool ports) {
  for (int k = 0; k < 2; ++k) {
    const auto model = OneOrEach(cameras, k).model;
    if (model != camera::CameraModelId::kOpenCV || ports) {
      throw InvalidInput("stereo_out", fmt::format("writes two cameras of the opencv model without a port; camera {} "
                                                   "is {}{}", k, camera::Info(model).name,
                                                   ports ? " behind a port" : ": give `model` opencv"));
    }
  }
}

}  // namespace

CalibrateRigJobResult CalibrateRigJob(const CalibrateRigJobOptions& o) {
  CalibrateRigJobResult out;
  const bool from_images = !o.images.empty();
  if (int(from_images) + int(!o.detections.empty()) + int(o.given.has_value()) > 1) {
    throw InvalidInput("images", "a rig's cameras come all from `images` or all from `detections`");
  }
  if (!from_images && o.detections.empty() && !o.given) {
    throw InvalidInput("images", "give `images` or `detections`, one per camera");
  }
  RequireRigOptions(o);
  if (from_images && o.target.empty()) throw InvalidInput("target", "required with `images`");
  if (o.given && o.target.empty()) throw InvalidInput("target", "required with detections given");
  if (!o.target.empty()) {
    out.target = ParseTarget(o.target, "target");
    if (!o.field.empty()) LoadTargetField(o.field, &out.target, "field");
  }
  const int n = o.given ? static_cast<int>(o.given->size())
                        : static_cast<int>(from_images ? o.images.size() : o.detections.size());
  if (!o.names.empty() && static_cast<int>(o.names.size()) != n) {
    throw InvalidInput("names", fmt::format("{} names for {} cameras", o.names.size(), n));
  }
  // One for all or one per camera: the models, the pitches, the ports.
  if (o.model.empty()) throw InvalidInput("model", "give a model (one for all or one per camera)");
  RequireOneOrEach(o.model.size(), n, "model", "models");
  const std::vector<double> pitches = o.pixel_pitch_mm.empty() ? std::vector<double>{1.0} : o.pixel_pitch_mm;
  RequireOneOrEach(pitches.size(), n, "pixel_pitch_mm", "pitches");
  for (double p : pitches) {
    RequirePositive("pixel_pitch_mm", p);
    if (p == 1.0) continue;
    if (const auto w = PlausibilityWarning("`pixel_pitch_mm`", p, kPixelPitchRange)) Warn(o, &out, *w);
  }
  if (o.port.size() > 1) RequireOneOrEach(o.port.size(), n, "port", "ports");
  const bool air_given = !o.air_calibration.empty() || o.air_given;
  if (air_given && o.port.empty()) throw InvalidInput("air_calibration", "only with `port`");
  if (!o.air_calibration.empty() && o.air_given) {
    throw InvalidInput("air_calibration", "files or calibrations given, not both");
  }
  const auto rig_air = o.air_calibration.empty() ? std::nullopt
                                                 : AirLensesOfARigFile(o.air_calibration, pitches.front());
  RequireConsistent(o, n, pitches, rig_air);
  RigOptions& ro = out.rig_options;
  ro.air_refocused = o.air_refocused;
  ro.cameras = CameraOptions(o, pitches, n);
  ro.air_of = o.air_lens_bare ? RefractiveOptions::AirCalibrationOf::kLensBare
                              : RefractiveOptions::AirCalibrationOf::kThroughPort;
  if (!o.stereo_out.empty()) RequireStereoPair(ro.cameras, !o.port.empty());
  if (o.check_outputs) o.check_outputs();
  for (const std::string& name : o.port) {
    const ports::PortSpec spec = catalogue::LoadPort(name);
    for (const std::string& w : housing::PortPlausibilityWarnings(spec, name + ": port")) Warn(o, &out, w);
    ro.ports.push_back(ports::MakeSystem(spec, o.water, o.ep_mm));
  }
  ReadAirLenses(o, rig_air, pitches, n, &ro);
  // The cameras' names: given, or their folders' or files' names.
  if (!o.names.empty()) {
    ro.names = o.names;
  } else if (!o.given) {
    for (const std::string& s : from_images ? o.images : o.detections) ro.names.push_back(NameOf(s));
  }
  const Say& say = o.lens.progress;
  const std::vector<std::vector<ImageDetections>> per_camera = ReadCameras(o, say, &out);
  ReadAirImages(o, say, &out);
  out.rig = CalibrateRig(per_camera, out.target, ro);
  for (const auto& c : out.rig.cameras) {
    camera::RequirePossibleResult(c.calibration.camera, c.calibration.rms_px, from_images ? "images" : "detections",
                                  "the calibration of camera " + c.name);
  }
  if (o.port_out) {
    for (const auto& c : out.rig.cameras) out.port_tomls.push_back(catalogue::PortToToml(c.estimated_port));
  }
  if (o.field_out) {  // the rig's free target, written as one camera's (its images: every camera's)
    CalibrationResult adjusted;
    adjusted.target_points_mm = out.rig.target_points_mm;
    adjusted.target_sigma_mm = out.rig.target_sigma_mm;
    adjusted.datum = out.rig.datum;
    adjusted.sigma0_px = out.rig.sigma0_px;
    for (const auto& c : out.rig.cameras) adjusted.n_images += c.n_frames;
    out.field_text = AdjustedFieldText(adjusted, out.target);
  }
  if (!o.stereo_out.empty()) {  // the first two cameras as cv::stereoCalibrate's K1 D1 K2 D2 R T
    interop::RigFile pair = interop::RigFileFromResult(out.rig);
    pair.cameras.resize(2);  // opencv models without a port (checked above)
    const bool xml = std::filesystem::path(o.stereo_out).extension() == ".xml";
    out.stereo_text = interop::WriteRigFile(pair, xml ? interop::RigFormat::kOpenCVStereoXml
                                                      : interop::RigFormat::kOpenCVStereoYaml,
                                            "stereo_out")
                          .files.front()
                          .second;
  }
  return out;
}

nlohmann::ordered_json CalibrateRigJobJson(const CalibrateRigJobResult& r) {
  nlohmann::ordered_json j = RigToJson(r.rig, r.target, r.rig_options);
  if (r.images_source) j["images_source"] = *r.images_source;
  nlohmann::ordered_json skip = nlohmann::ordered_json::array();
  for (const auto& s : r.skipped) skip.push_back({{"image", s.image}, {"reason", s.reason}});
  j["skipped"] = skip;
  return j;
}

}  // namespace porthole::calib
