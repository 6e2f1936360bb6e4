// CalibrateJob: the steps of `porthole calibrate` (one camera) and of Python's calibrate and
// calibrate_refractive, written once (calib/job.h).
#include "porthole/calib/job.h"

#include <fmt/format.h>

#include <cmath>
#include <utility>

#include "porthole/calib/detections_json.h"
#include "porthole/camera/validate.h"
#include "porthole/core/error.h"
#include "porthole/core/plausible.h"
#include "porthole/housing/plausible.h"
#include "porthole/interop/interop.h"
#include "porthole/catalogue/presets.h"

namespace porthole::calib {
namespace {

using Say = std::function<void(const std::string&)>;

// An adjustment that ended impossible (a focal length <= 0, a parameter, the RMS or a sigma not
// finite) is an error naming the images, never returned as a calibration (camera/validate.h).
void RequirePossibleCalibration(const CalibrationResult& r, const std::string& field) {
  camera::RequirePossibleResult(r.camera, r.rms_px, field, "the calibration of these images");
  const camera::ModelInfo& m = r.camera.info();
  for (int i = 0; r.covariance_ok && i < m.num_params && i < static_cast<int>(r.sigma.size()); ++i) {
    if (i < static_cast<int>(r.free.size()) && r.free[i] && !std::isfinite(r.sigma[i])) {
      throw InvalidInput(field, fmt::format("the calibration of these images is impossible: the sigma of {} is {}",
                                            m.params[i].json_key, r.sigma[i]));
    }
  }
}

LossKind LossOf(const std::string& name) {
  if (name == "none") return LossKind::kNone;
  if (name == "huber") return LossKind::kHuber;
  if (name == "cauchy") return LossKind::kCauchy;
  throw InvalidInput("loss", "none | huber | cauchy");
}

CalibrationOptions::CentreCorrection CentreCorrectionOf(const std::string& name) {
  using CC = CalibrationOptions::CentreCorrection;
  if (name == "auto") return CC::kAuto;
  if (name == "on") return CC::kOn;
  if (name == "off") return CC::kOff;
  throw InvalidInput("centre_correction", "auto | on | off");
}

// The lens options from their names, the pitch as the job's policy gives it (job.h).
CalibrationOptions LensOptions(const CalibrateJobOptions& o, CalibrateJobResult* out) {
  CalibrationOptions c = LensOptionsFromNames(o.lens, o.model, o.free, o.loss, o.centre_correction, o.datum);
  // A port with an in-air calibration that states its pitch (porthole JSON): that pitch, unless
  // one is given (issue 23: not asked for twice).
  double pitch = o.pixel_pitch_mm.value_or(1.0);
  if (!o.pixel_pitch_mm && !o.port.empty() && !o.air_calibration.empty()) {
    if (const auto stated = interop::StatedPixelPitchMm(o.air_calibration, "air_calibration")) pitch = *stated;
  }
  c.pixel_pitch_mm = RequirePositive("pixel_pitch_mm", pitch);
  if (pitch != 1.0) {
    if (const auto w = PlausibilityWarning("`pixel_pitch_mm`", pitch, kPixelPitchRange)) {
      out->warnings.push_back(*w);
      if (o.warn) o.warn(*w);
    }
  }
  return c;
}

// The option combinations that cannot be made (before any file is read).
void RequireConsistent(const CalibrateJobOptions& o, const CalibrationOptions& lens) {
  if (o.field_out && !lens.target_free) {
    throw InvalidInput("field_out", "needs `free_target` (without it no point is adjusted)");
  }
  const bool refractive = !o.port.empty();
  if (!refractive) {
    const std::pair<const char*, bool> given[] = {
        {"air_calibration", !o.air_calibration.empty() || o.air_given}, {"intrinsics", !o.intrinsics.empty()},
        {"port_sigma", o.port_sigma.has_value()}, {"port_out", o.port_out},
        {"ep", o.ep_mm.has_value()}, {"plan_only", o.plan_only},
        {"free_water_index", o.free_water_index}, {"free_shell", o.free_shell},
        {"air_detections", !o.air_detections.empty() || o.air_given_detections},
        {"air_images", !o.air_images.empty()}, {"air_lens_bare", o.air_lens_bare},
        {"air_refocused", o.air_refocused}};
    for (const auto& [field, is_given] : given) {
      if (is_given) throw InvalidInput(field, "only with `port` (the refractive calibration)");
    }
  }
  const bool air_images = !o.air_images.empty() || !o.air_detections.empty() || o.air_given_detections;
  if (o.air_refocused && !air_images) {
    throw InvalidInput("air_refocused", "says the air images were taken at another focus: give `air_images` or "
                                        "`air_detections`");
  }
  if (o.plan_only && air_images) {
    throw InvalidInput("plan_only",
                       "plans the water images alone: not with air images (`air_images`, `air_detections`)");
  }
  if (refractive) {
    if (o.opencv_yaml) throw InvalidInput("opencv_yaml", "not with `port` (a refractive camera is not an OpenCV one)");
    if (lens.target_free && o.plan_only) throw InvalidInput("free_target", "not with `plan_only` (nothing is adjusted)");
    if (o.air_lens_bare && o.air_calibration.empty() && !o.air_given) {
      throw InvalidInput("air_lens_bare", "says what `air_calibration` holds: give `air_calibration`");
    }
    if (o.plan_only && o.port_out) throw InvalidInput("port_out", "not with `plan_only` (nothing is estimated)");
  }
}

// The refractive options: the port in its water, the in-air calibration, the parameters adjusted.
RefractiveOptions RefractiveOptionsOf(const CalibrateJobOptions& o, const CalibrationOptions& lens,
                                      CalibrateJobResult* out) {
  RefractiveOptions ro;
  ro.lens = lens;
  const ports::PortSpec spec = catalogue::LoadPort(o.port);
  for (const std::string& w : housing::PortPlausibilityWarnings(spec, o.port + ": port")) {
    out->warnings.push_back(w);
    if (o.warn) o.warn(w);
  }
  ro.port = ports::MakeSystem(spec, o.water, o.ep_mm);
  const std::string of = o.air_lens_bare ? ", the bare lens (`air_lens_bare`)"
                                         : ", made through the port in air (the housing on): the lens behind the port in air";
  if (!o.air_calibration.empty()) {  // any format (docs/interop.md), as the lens model of this calibration
    const auto read = interop::ReadCalibrationFileAs(o.air_calibration, lens.pixel_pitch_mm, lens.model, "air_calibration");
    ro.air = read.calibration;
    out->air_note = interop::DescribeRead(read, o.air_calibration) + of;
  } else if (o.air_given) {
    ro.air = interop::ConvertCalibration(*o.air_given, lens.model, "air_calibration");
  }
  ro.air_of = o.air_lens_bare ? RefractiveOptions::AirCalibrationOf::kLensBare
                              : RefractiveOptions::AirCalibrationOf::kThroughPort;
  const std::string mode = !o.intrinsics.empty() ? o.intrinsics : ro.air ? "prior" : "free";
  ro.intrinsics = ParseIntrinsicsMode(mode, "intrinsics");
  ro.port_free = ParsePortFree(refraction::KindOf(ro.port.spec), o.free_port, "free_port");
  ro.predicted_sigma = o.port_sigma;
  ro.free_water_index = o.free_water_index;
  ro.free_shell = o.free_shell;
  ro.air_refocused = o.air_refocused;
  ro.compare_central = o.compare_central;
  return ro;
}

// The images' detections: searched here, read from a file, or given; the target filled in from
// detections that name it.
void ReadImages(const CalibrateJobOptions& o, const Say& say, CalibrateJobResult* out) {
  if (!o.images.empty()) {
    auto source = DetectSource(o.images, out->target, o.frames, say, o.detect, "images");
    out->images_source = FrameChoiceToJson(source.choice, source.run.detections);
    out->detections = std::move(source.run.detections);
    out->skipped = std::move(source.run.skipped);
  } else if (o.image_files) {
    DetectionRun run = DetectAll(*o.image_files, out->target, say, o.detect);
    out->detections = std::move(run.detections);
    out->skipped = std::move(run.skipped);
  } else if (o.given) {
    out->detections = *o.given;
  } else {
    out->detections = LoadDetections(o.detections, "detections", &out->target);
    if (out->target.cols == 0) throw InvalidInput("target", "the detections name no target");
    if (!o.field.empty() && out->target.field.empty()) LoadTargetField(o.field, &out->target);
  }
  // Detections of IDs the field does not hold are no points (the refractive calibration needs
  // them gone; Calibrate would drop them too).
  KeepTargetPoints(out->target, &out->detections, say);
}

// The air images through the same port (issue 26): the same target, detected here, read or given.
void ReadAirImages(const CalibrateJobOptions& o, const Say& say, CalibrateJobResult* out,
                   std::vector<ImageDetections>* air) {
  if (!o.air_images.empty()) {
    if (o.target.empty()) throw InvalidInput("target", "required with `air_images`");
    const auto say_air = [say](const std::string& m) {
      if (say) say("air images: " + m);
    };
    auto source = DetectSource(o.air_images, out->target, o.frames, say_air, o.detect, "air_images");
    out->air_images_source = FrameChoiceToJson(source.choice, source.run.detections);
    *air = std::move(source.run.detections);
    for (auto& s : source.run.skipped) out->skipped.push_back({"air: " + s.image, s.reason});
    if (air->empty()) throw InvalidInput("air_images", "the target was found in no air image");
  } else if (!o.air_detections.empty()) {
    TargetSpec air_target = out->target;  // detections of another target are refused
    *air = LoadDetections(o.air_detections, "air_detections", &air_target);
  } else if (o.air_given_detections) {
    *air = *o.air_given_detections;
  }
  KeepTargetPoints(out->target, air, say);
}

}  // namespace

CalibrationOptions LensOptionsFromNames(CalibrationOptions c, const std::string& model, const std::string& free,
                                        const std::string& loss, const std::string& centre_correction,
                                        const std::string& datum) {
  c.centre_correction = CentreCorrectionOf(centre_correction);
  c.datum = ParseDatumKind(datum, "datum");
  if (datum != "auto" && !c.target_free) {
    throw InvalidInput("datum", "is the datum of a free target: give it with `free_target`");
  }
  c.model = camera::ModelFromName(model, "model");
  c.free = ParseFreeParameters(c.model, free, "free");
  c.loss = LossOf(loss);
  return c;
}

CalibrateJobResult CalibrateJob(const CalibrateJobOptions& o) {
  CalibrateJobResult out;
  if (o.images.empty() && !o.image_files && o.detections.empty() && !o.given) {
    throw InvalidInput("images", "give `images` DIR or `detections` PATH");
  }
  if (o.image_files && o.image_files->empty()) throw InvalidInput("images", "no image files given");
  if (o.image_files && (o.frames.every != 0 || o.frames.max_frames != 0)) {
    throw InvalidInput(o.frames.every != 0 ? "every" : "max_frames", "for a folder or a video, not a list of files");
  }
  if (!o.target.empty()) {
    out.target = ParseTarget(o.target, "target");
    if (!o.field.empty()) LoadTargetField(o.field, &out.target, "field");  // before any detection
  }
  const bool searched = !o.images.empty() || o.image_files;  // images searched here
  if (searched && o.target.empty()) throw InvalidInput("target", "required with `images`");
  if (o.given && o.target.empty()) throw InvalidInput("target", "required with detections given");
  const std::string images_field = searched ? "images" : "detections";
  out.lens = LensOptions(o, &out);
  RequireConsistent(o, out.lens);
  if (o.check_outputs) o.check_outputs();
  const bool refractive = !o.port.empty();
  if (refractive) out.refractive_options = RefractiveOptionsOf(o, out.lens, &out);
  const Say& say = out.lens.progress;
  ReadImages(o, say, &out);
  std::vector<ImageDetections> air;
  ReadAirImages(o, say, &out, &air);
  if (refractive) {
    RefractiveOptions& ro = *out.refractive_options;
    ro.air_detections = std::move(air);
    if (o.plan_only) {
      out.plan = PlanRefractiveFromImages(out.detections, out.target, ro, o.plan_sigma_px);
      return out;
    }
    out.refractive = CalibrateRefractive(out.detections, out.target, ro);
    RequirePossibleCalibration(out.refractive->lens, images_field);
    if (o.port_out) out.port_toml = catalogue::PortToToml(out.refractive->estimated_port);
    if (o.field_out) out.field_text = AdjustedFieldText(out.refractive->lens, out.target);
    return out;
  }
  out.central = Calibrate(out.detections, out.target, out.lens);
  RequirePossibleCalibration(*out.central, images_field);
  if (o.opencv_yaml) {  // through the calibration's JSON, as a file of it would be read
    const auto j = CalibrationToJson(*out.central, out.target, out.lens);
    out.opencv_yaml = ExportOpenCVYaml(
        CalibrationFromJson(nlohmann::json::parse(j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace)),
                            "opencv_yaml"),
        &out.opencv_yaml_fit);
  }
  if (o.field_out) out.field_text = AdjustedFieldText(*out.central, out.target);
  return out;
}

nlohmann::ordered_json CalibrateJobJson(const CalibrateJobResult& r) {
  if (r.plan) return PlanToJson(*r.plan);
  nlohmann::ordered_json j = r.refractive ? RefractiveToJson(*r.refractive, r.target, *r.refractive_options)
                                          : CalibrationToJson(*r.central, r.target, r.lens);
  nlohmann::ordered_json skip = nlohmann::ordered_json::array();
  for (const auto& s : r.skipped) skip.push_back({{"image", s.image}, {"reason", s.reason}});
  j["skipped"] = skip;
  if (r.images_source) j["images_source"] = *r.images_source;
  if (r.air_images_source) j["air_images_source"] = *r.air_images_source;
  if (!r.air_note.empty()) j["port"]["air_calibration"] = r.air_note;
  return j;
}

}  // namespace porthole::calib
