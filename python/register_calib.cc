// Python bindings of the calib module: calibrate from detections (dicts as `porthole detect --json`
// writes them), synthetic detection sets with known truth, and the comparison of two
// calibrations. Inputs and outputs are the JSON objects of the CLI as Python dicts.
#include <fmt/format.h>
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <nlohmann/json.hpp>
#include <cstdio>

#include "porthole/calib/calibrate.h"
#include "porthole/calib/compare.h"
#include "porthole/calib/detect.h"
#include "porthole/calib/frames.h"
#include "porthole/calib/job.h"
#include "porthole/calib/detections_json.h"
#include "porthole/calib/refractive.h"
#include "porthole/calib/rig.h"
#include "porthole/calib/rig_job.h"
#include "porthole/calib/result_json.h"
#include "porthole/calib/synthetic.h"
#include "porthole/camera/json.h"
#include "porthole/core/field_names.h"
#include "register.h"

namespace py = pybind11;

namespace porthole::python {
namespace {

using ports::Vec3;


// A camera from a dict {"model": name (default brown), parameter keys…} and the sensor.
camera::Camera CameraFromDict(const py::dict& camera, int width_px, int height_px,
                              double pixel_pitch_mm) {
  if (width_px < 1 || width_px > 1000000) throw InvalidInput("width_px", "must be a whole number from 1 to 1000000");
  if (height_px < 1 || height_px > 1000000) throw InvalidInput("height_px", "must be a whole number from 1 to 1000000");
  RequirePositive("pixel_pitch_mm", pixel_pitch_mm);
  nlohmann::json wrapped = {{"camera", nlohmann::json::object()},
                            {"sensor", {{"width_px", width_px}, {"height_px", height_px},
                                        {"pixel_pitch_mm", pixel_pitch_mm}}}};
  const nlohmann::json given = PythonToJson(camera);  // kept alive: items() refers into it
  for (const auto& [key, val] : given.items()) {
    if (key == "model") {
      wrapped["model"] = val;
    } else {
      wrapped["camera"][key] = val;
    }
  }
  return calib::CalibrationFromJson(wrapped, "camera").camera;
}

// Detections as `porthole detect --json` writes them (a list of dicts).
std::vector<calib::ImageDetections> DetectionsArg(const py::list& detections) {
  std::vector<calib::ImageDetections> dets;
  for (std::size_t i = 0; i < detections.size(); ++i) {
    dets.push_back(calib::DetectionsFromJson(PythonToJson(detections[i]),
                                             "detections[" + std::to_string(i) + "]"));
  }
  return dets;
}

// The target spec, with a coded target's field file when one is given (None: the default sheet).
calib::TargetSpec TargetArg(const std::string& target, const py::object& field) {
  calib::TargetSpec t = calib::ParseTarget(target, "target");
  if (!field.is_none()) {
    calib::LoadTargetField(py::str(py::module_::import("os").attr("fspath")(field)), &t, "field");
  }
  return t;
}

// The progress lines on stderr, or none.
std::function<void(const std::string&)> Progress(bool progress) {
  if (!progress) return {};
  return [](const std::string& m) { std::fprintf(stderr, "calibrate: %s\n", m.c_str()); };
}

// A path (str or os.PathLike): images to search (calibrate_images), not detections.
bool IsPath(const py::object& v) { return py::isinstance<py::str>(v) || py::hasattr(v, "__fspath__"); }

// How calibrate_images searches its images (a folder, one image or a video): detect()'s threads,
// every and max_frames; a video keeps 40 frames chosen automatically unless max_frames says otherwise.
struct ImageSearch {
  int threads = 0, every = 0, max_frames = 0;
};

// The options calibrate() and calibrate_refractive() share, for calib::CalibrateJob: the
// detections given or the images to search, the target and its field, the lens by name.
calib::CalibrateJobOptions JobOptions(const py::object& detections, const py::object& image_files,
                                      const ImageSearch& search, const std::string& target, const py::object& field,
                                      const std::string& model, std::optional<double> pixel_pitch_mm,
                                      const std::string& free, double reject_k, const std::string& loss,
                                      double loss_scale_px, bool progress, const std::string& centre_correction) {
  calib::CalibrateJobOptions o;
  if (IsPath(detections) || !image_files.is_none()) {
    if (!image_files.is_none()) {  // a list of image files
      o.image_files.emplace();
      for (const auto& f : image_files) o.image_files->push_back(py::str(py::module_::import("os").attr("fspath")(f)));
    } else {  // a folder, one image or a video
      o.images = py::str(py::module_::import("os").attr("fspath")(detections));
    }
    if (search.threads < 0) throw InvalidInput("threads", "must be >= 0 (0 = all cores)");
    o.detect.threads = search.threads;
    o.frames.every = search.every;
    o.frames.max_frames = search.max_frames;
    o.frames.for_calibration = true;
  } else {
    for (const auto& [name, value] : {std::pair{"threads", search.threads}, std::pair{"every", search.every},
                                      std::pair{"max_frames", search.max_frames}}) {
      if (value != 0) throw InvalidInput(name, "searches images: give a folder, an image or a video (calibrate_images)");
    }
    o.given = DetectionsArg(detections.cast<py::list>());
  }
  o.target = target;
  if (!field.is_none()) o.field = py::str(py::module_::import("os").attr("fspath")(field));
  o.model = model;
  o.pixel_pitch_mm = pixel_pitch_mm;
  o.free = free;
  o.lens.reject_k = reject_k;
  o.loss = loss;
  o.lens.loss_scale_px = loss_scale_px;
  o.centre_correction = centre_correction;
  o.lens.progress = Progress(progress);
  return o;
}

// The job run without the GIL; its JSON (the CLI's) with the fields its notes name as keywords.
calib::CalibrateJobResult RunJob(const calib::CalibrateJobOptions& o) {
  py::gil_scoped_release release;
  return calib::CalibrateJob(o);
}
void PythonWordsInJson(nlohmann::ordered_json* j) {  // `air_lens_bare` → air_lens_bare=
  if (j->is_string()) {
    const auto& s = j->get_ref<const std::string&>();
    if (s.find('`') != std::string::npos) {
      *j = RenameQuotedFieldsBy([](std::string_view) { return std::optional<std::string>(); }, s, "=");
    }
  } else if (j->is_structured()) {
    for (auto& v : *j) PythonWordsInJson(&v);
  }
}
// A job's warnings as the CLI prints them, a quoted `field` as the bare keyword (pixel_pitch_mm: …).
nlohmann::ordered_json PythonWarnings(const std::vector<std::string>& warnings) {
  nlohmann::ordered_json out = nlohmann::ordered_json::array();
  for (const std::string& w : warnings) {
    out.push_back(RenameQuotedFieldsBy([](std::string_view) { return std::optional<std::string>(); }, w));
  }
  return out;
}
py::object JobJson(const calib::CalibrateJobResult& r) {
  nlohmann::ordered_json j = calib::CalibrateJobJson(r);
  PythonWordsInJson(&j);
  return JsonToPython(j);
}

}  // namespace

void RegisterCalib(py::module_& m) {
  m.def(
      "camera_models",
      [] {
        py::list out;
        for (const auto& info : camera::CameraModels()) {
          py::list params;
          for (const auto& p : info.params) {
            params.append(py::dict(py::arg("name") = std::string(p.name),
                                   py::arg("key") = std::string(p.json_key),
                                   py::arg("unit") = std::string(p.unit)));
          }
          out.append(py::dict(py::arg("name") = std::string(info.name),
                              py::arg("description") = std::string(info.description),
                              py::arg("parameters") = params,
                              py::arg("fisheye") = info.caps.fisheye,
                              py::arg("central") = info.caps.central,
                              py::arg("correction_form") = info.caps.correction_form));
        }
        return out;
      },
      "The camera models porthole knows (the closed list of camera/models.h): name, description, "
      "parameters (name, JSON key, unit) and capabilities.");

  m.def(
      "project",
      [](const py::dict& camera, const py::array_t<double>& points_in_cam, int width_px,
         int height_px, double pixel_pitch_mm) {
        const auto cam = CameraFromDict(camera, width_px, height_px, pixel_pitch_mm);
        const auto p = points_in_cam.unchecked<2>();
        if (p.shape(1) != 3) throw InvalidInput("points_in_cam", "must be an N x 3 array (mm)");
        py::array_t<double> out({p.shape(0), py::ssize_t(2)});
        auto o = out.mutable_unchecked<2>();
        for (py::ssize_t i = 0; i < p.shape(0); ++i) {
          const auto uv = cam.Project(Eigen::Vector3d(p(i, 0), p(i, 1), p(i, 2)));
          o(i, 0) = uv ? (*uv)(0) : NAN;
          o(i, 1) = uv ? (*uv)(1) : NAN;
        }
        return out;
      },
      py::arg("camera"), py::arg("points_in_cam"), py::kw_only(), py::arg("width_px"),
      py::arg("height_px"), py::arg("pixel_pitch_mm") = 1.0,
      "Projects N x 3 points in the camera frame (mm; X right, Y down, Z forward) to N x 2 pixels "
      "((0, 0) = centre of the top-left pixel) with a camera dict (model and its parameter keys); "
      "NaN where the model cannot project (behind the camera, beyond a fisheye's field).");

  m.def(
      "unproject",
      [](const py::dict& camera, const py::array_t<double>& pixels, int width_px, int height_px,
         double pixel_pitch_mm) {
        const auto cam = CameraFromDict(camera, width_px, height_px, pixel_pitch_mm);
        const auto p = pixels.unchecked<2>();
        if (p.shape(1) != 2) throw InvalidInput("pixels", "must be an N x 2 array (px)");
        py::array_t<double> out({p.shape(0), py::ssize_t(3)});
        auto o = out.mutable_unchecked<2>();
        for (py::ssize_t i = 0; i < p.shape(0); ++i) {
          const auto ray = cam.Unproject(Eigen::Vector2d(p(i, 0), p(i, 1)));
          for (int k = 0; k < 3; ++k) o(i, k) = ray ? (*ray)(k) : NAN;
        }
        return out;
      },
      py::arg("camera"), py::arg("pixels"), py::kw_only(), py::arg("width_px"),
      py::arg("height_px"), py::arg("pixel_pitch_mm") = 1.0,
      "Unit rays (N x 3, camera frame) of N x 2 pixels; NaN where the model cannot be inverted.");

  m.def(
      "detect",
      [](const py::object& images, const std::string& target, int threads, bool progress, const py::object& field,
         int every, int max_frames, bool for_calibration) {
        return WithFieldNames({{"images", "images"}}, [&] {
          const auto t = TargetArg(target, field);
          if (threads < 0) throw InvalidInput("threads", "must be >= 0 (0 = all cores)");
          calib::DetectOptions o;
          o.threads = threads;
          std::function<void(const std::string&)> report;
          if (progress) report = [](const std::string& line) { std::fprintf(stderr, "detect: %s\n", line.c_str()); };
          if (py::isinstance<py::str>(images) || py::hasattr(images, "__fspath__")) {
            // A folder, one image or a video (calib/frames.h).
            const std::string path = py::str(py::module_::import("os").attr("fspath")(images));
            calib::FrameOptions f;
            f.every = every;
            f.max_frames = max_frames;
            f.for_calibration = for_calibration;
            calib::SourceRun source;
            {
              py::gil_scoped_release release;
              source = calib::DetectSource(path, t, f, report, o, "images");
            }
            nlohmann::ordered_json j = calib::DetectionRunToJson(source.run, t);
            j["source"] = calib::FrameChoiceToJson(source.choice, source.run.detections);
            return JsonToPython(j);
          }
          std::vector<std::string> paths;
          for (const auto& p : images) paths.push_back(py::str(py::module_::import("os").attr("fspath")(p)));
          if (paths.empty()) throw InvalidInput("images", "no image files given");
          if (every != 0 || max_frames != 0) throw InvalidInput("every", "for a folder or a video, not a list of files");
          calib::DetectionRun run;
          {
            py::gil_scoped_release release;
            run = calib::DetectAll(paths, t, report, o);
          }
          return JsonToPython(calib::DetectionRunToJson(run, t));
        });
      },
      py::arg("images"), py::arg("target"), py::kw_only(), py::arg("threads") = 0, py::arg("progress") = false,
      py::arg("field") = py::none(), py::arg("every") = 0, py::arg("max_frames") = 0, py::arg("for_calibration") = false,
      "Detects a target (chessboard:COLSxROWS:SQUARE_MM, charuco:…, circles:…, coded:BITS:RADIUS_MM[:PROFILE]) in "
      "images: a folder, one image, a video (mp4, mov, mkv, avi: frames f<index> with frame_index and time_s) or a "
      "list of files; field: a coded target's field file (IDs outside it ignored); every: search every N-th image "
      "or frame (0: all images, a video at most 600 frames); max_frames: keep K chosen automatically (blurred ones "
      "out, the rest spread over the frame and the tilts); for_calibration: a video keeps 40 when max_frames is 0. "
      "Returns the set of `porthole detect --json`: target, images (one dict per image with the target: image, "
      "width_px, height_px, ids, points_px; a video's frame_index, time_s; blur_px), skipped (image, reason) and "
      "source (what was searched and kept).");

  m.def(
      "calibrate",
      [](const py::object& detections, const std::string& target, const std::string& model,
         double pixel_pitch_mm, const std::string& free, double reject_k, const std::string& loss, double loss_scale_px,
         bool target_free, bool drop_insignificant, double significance_t, bool progress, const py::object& field,
         const std::string& centre_correction, const std::string& datum, int threads, int every, int max_frames,
         const py::object& image_files) {
        const bool searched = IsPath(detections) || !image_files.is_none();
        return WithFieldNames({{"images", searched ? "images" : "detections"},
                               {"pixel_pitch_mm", "pixel_pitch_mm"}, {"free_target", "target_free"}},
                              [&] {
                                calib::CalibrateJobOptions o =
                                    JobOptions(detections, image_files, {threads, every, max_frames}, target, field,
                                               model, pixel_pitch_mm, free, reject_k, loss, loss_scale_px, progress,
                                               centre_correction);
                                o.lens.target_free = target_free;
                                o.datum = datum;
                                o.lens.drop_insignificant = drop_insignificant;
                                o.lens.significance_t = significance_t;
                                return JobJson(RunJob(o));
                              });
      },
      py::arg("detections"), py::arg("target"), py::kw_only(), py::arg("model") = "brown",
      py::arg("pixel_pitch_mm") = 1.0, py::arg("free") = "default", py::arg("reject_k") = 5.0,
      py::arg("loss") = "none", py::arg("loss_scale_px") = 1.0, py::arg("target_free") = false,
      py::arg("drop_insignificant") = false, py::arg("significance_t") = 2.0,
      py::arg("progress") = false, py::arg("field") = py::none(), py::arg("centre_correction") = "auto",
      py::arg("datum") = "auto", py::arg("threads") = 0, py::arg("every") = 0, py::arg("max_frames") = 0,
      py::arg("image_files") = py::none(),
      "Self-calibration from detections (list of dicts: image, width_px, height_px, ids, "
      "points_px) or from images to search (a folder, one image or a video: `porthole calibrate --images`; "
      "or image_files, a list of files, with detections []; threads, every, max_frames as detect()'s, a video "
      "keeping 40 frames chosen automatically), with any camera model (brown, opencv, kannala-brandt, equidistant, equisolid, "
      "stereographic, orthographic). field: a coded target's field file (`--field`, 3-D fields "
      "too); centre_correction: auto | on | off (`--centre-correction`); datum: auto | minimal | control "
      "(`--datum`: with target_free, the field's control points or 7 coordinates). Returns the calibration "
      "dict of `porthole calibrate --json`.");

  m.def(
      "calibrate_refractive",
      [](const py::object& detections, const std::string& target, const std::string& port,
         const std::string& model, std::optional<double> pixel_pitch_mm, const std::string& free, double reject_k,
         const std::string& loss, double loss_scale_px, const py::object& air_calibration,
         const std::string& intrinsics, const std::string& free_port,
         std::optional<std::array<double, 3>> port_sigma, bool free_water_index, bool free_shell,
         std::optional<Vec3> ep_mm, const std::string& water, std::optional<double> water_index,
         double lambda_nm, double temperature_c, double salinity_psu, double pressure_dbar,
         bool compare_central, bool progress, const py::object& field, const std::string& centre_correction,
         const py::object& air_detections, bool air_lens_bare, bool air_refocused, int threads, int every,
         int max_frames, const py::object& image_files, bool target_free, const std::string& datum) {
        const bool searched = IsPath(detections) || !image_files.is_none();
        return WithFieldNames(
            {{"images", searched ? "images" : "detections"}, {"pixel_pitch_mm", "pixel_pitch_mm"},
             {"port", "port"}, {"free_target", "target_free"},
             {"air_calibration", "air_calibration"}, {"air_lens_bare", "air_lens_bare"},
             {"air_refocused", "air_refocused"},
             {"air_detections", "air_detections"}, {"air_images", "air_detections"},
             {"intrinsics", "intrinsics"},
             {"free_port", "free_port"}, {"port_sigma", "port_sigma"},
             {"free_shell", "free_shell"}},
            [&] {
              calib::CalibrateJobOptions o =
                  JobOptions(detections, image_files, {threads, every, max_frames}, target, field, model,
                             pixel_pitch_mm, free, reject_k, loss, loss_scale_px, progress, centre_correction);
              o.port = port;
              o.ep_mm = ep_mm;
              o.water = MakeEnvironment(water, water_index, std::nullopt, lambda_nm, temperature_c, salinity_psu,
                                        pressure_dbar);
              if (py::isinstance<py::str>(air_calibration) || py::hasattr(air_calibration, "__fspath__")) {
                o.air_calibration = py::str(py::module_::import("os").attr("fspath")(air_calibration));
              } else if (py::isinstance<py::dict>(air_calibration)) {
                o.air_given = calib::CalibrationFromJson(PythonToJson(air_calibration), "air_calibration");
              } else if (!air_calibration.is_none()) {
                throw InvalidInput("air_calibration", "a file path or a calibration dict");
              }
              o.air_refocused = air_refocused;
              o.air_lens_bare = air_lens_bare;
              if (!air_detections.is_none()) o.air_given_detections = DetectionsArg(air_detections.cast<py::list>());
              o.intrinsics = intrinsics;
              o.free_port = free_port;
              o.port_sigma = port_sigma;
              o.free_water_index = free_water_index;
              o.free_shell = free_shell;
              o.compare_central = compare_central;
              o.lens.target_free = target_free;
              o.datum = datum;
              const calib::CalibrateJobResult r = RunJob(o);
              return py::make_tuple(JobJson(r), r.refractive->estimated_port, JsonToPython(PythonWarnings(r.warnings)));
            });
      },
      py::arg("detections"), py::arg("target"), py::arg("port"), py::kw_only(), py::arg("model") = "brown",
      py::arg("pixel_pitch_mm") = py::none(), py::arg("free") = "default", py::arg("reject_k") = 5.0,
      py::arg("loss") = "none", py::arg("loss_scale_px") = 1.0, py::arg("air_calibration") = py::none(),
      py::arg("intrinsics") = "", py::arg("free_port") = "all", py::arg("port_sigma") = py::none(),
      py::arg("free_water_index") = false, py::arg("free_shell") = false, py::arg("ep_mm") = py::none(),
      py::arg("water") = "seawater", py::arg("water_index") = py::none(), py::arg("lambda_nm") = 546.07,
      py::arg("temperature_c") = 20.0, py::arg("salinity_psu") = 35.0, py::arg("pressure_dbar") = 0.0,
      py::arg("compare_central") = true, py::arg("progress") = false, py::arg("field") = py::none(),
      py::arg("centre_correction") = "auto", py::arg("air_detections") = py::none(),
      py::arg("air_lens_bare") = false, py::arg("air_refocused") = false, py::arg("threads") = 0,
      py::arg("every") = 0, py::arg("max_frames") = 0, py::arg("image_files") = py::none(),
      py::arg("target_free") = false, py::arg("datum") = "auto",
      "The refractive calibration of `porthole calibrate --port` (docs/calibration.md): the lens "
      "(any model) behind the port (a preset name or TOML file) in water, from detections of water "
      "images (or the images to search, as calibrate()'s); pixel_pitch_mm None: an air_calibration file's own (porthole JSON), else 1. "
      "air_detections: detections of the same target in air through the same port (the "
      "housing on, the paper's protocol), adjusted with the water ones; air_refocused=True when they were taken at another focus (their own focal length, a factor adjusted). air_calibration: a file of "
      "any format or a calibration dict, made in air with the housing on (the default: modelled as the "
      "lens behind the port in air, a prior on both) or of the lens alone (air_lens_bare=True); "
      "intrinsics prior (the default with one), fixed (the lens alone only) or free; free_port: the port parameters adjusted; port_sigma: 1-sigma "
      "of the predicted port for the chi2 test; free_water_index, free_shell as the CLI's flags; target_free=True "
      "adjusts the target's points with the lens and the port (datum: auto | minimal | control, as calibrate()'s; "
      "the JSON's target_adjusted). "
      "Returns (the JSON of `porthole calibrate --port --json`, the estimated port, the plausibility warnings of the "
      "pitch and the port as the CLI prints them).");

  m.def(
      "calibrate_rig",
      [](const py::list& cameras, const std::string& target, const py::object& model, const py::object& pixel_pitch_mm,
         const std::string& free, double reject_k, const py::object& port, const py::object& air_calibration,
         bool air_lens_bare, const std::string& water, std::optional<double> water_index, double lambda_nm,
         double temperature_c, double salinity_psu, double pressure_dbar, bool progress,
         const std::vector<std::string>& names, const py::object& air_detections, const py::object& datum,
         const py::object& free_port, bool air_refocused, bool target_free, std::optional<Vec3> ep_mm) {
        return WithFieldNames(
            {{"cameras", "cameras"}, {"images", "cameras"}, {"detections", "cameras"}, {"model", "model"},
             {"pixel_pitch_mm", "pixel_pitch_mm"}, {"port", "port"}, {"air_calibration", "air_calibration"},
             {"air_lens", "air_calibration"}, {"air_lens_bare", "air_lens_bare"}, {"air_images", "air_detections"},
             {"air_detections", "air_detections"}, {"ports", "port"}, {"camera_options", "model"},
             {"datum", "datum"}, {"free_port", "free_port"}, {"air_refocused", "air_refocused"},
             {"free_target", "target_free"}, {"ep", "ep_mm"}},
            [&] {
              const auto list_of = [](const py::object& v) {
                std::vector<py::object> out;
                if (v.is_none()) return out;
                if (py::isinstance<py::list>(v) || py::isinstance<py::tuple>(v)) {
                  for (const auto& x : v) out.push_back(py::reinterpret_borrow<py::object>(x));
                } else {
                  out.push_back(v);
                }
                return out;
              };
              calib::CalibrateRigJobOptions o;
              o.given.emplace();
              for (const auto& c : cameras) o.given->push_back(DetectionsArg(c.cast<py::list>()));
              o.names = names;
              o.target = target;
              o.model.clear();
              for (const auto& m : list_of(model)) o.model.push_back(m.cast<std::string>());
              for (const auto& p : list_of(pixel_pitch_mm)) o.pixel_pitch_mm.push_back(p.cast<double>());
              o.free = free;
              o.lens.reject_k = reject_k;
              o.lens.progress = Progress(progress);
              for (const auto& p : list_of(port)) o.port.push_back(py::str(py::module_::import("os").attr("fspath")(p)));
              o.water = MakeEnvironment(water, water_index, std::nullopt, lambda_nm, temperature_c, salinity_psu,
                                        pressure_dbar);
              // In-air calibrations: files (one per camera, or a rig file) or dicts, one per camera.
              for (const auto& a : list_of(air_calibration)) {
                if (py::isinstance<py::dict>(a)) {
                  if (!o.air_given) o.air_given.emplace();
                  o.air_given->push_back(calib::CalibrationFromJson(PythonToJson(a), "air_calibration"));
                } else if (py::isinstance<py::str>(a) || py::hasattr(a, "__fspath__")) {
                  o.air_calibration.push_back(py::str(py::module_::import("os").attr("fspath")(a)));
                } else {
                  throw InvalidInput("air_calibration", "a file path or a calibration dict");
                }
              }
              o.air_lens_bare = air_lens_bare;
              o.air_refocused = air_refocused;
              o.lens.target_free = target_free;
              o.ep_mm = ep_mm;
              // calibrate()'s datum (with target_free); calibrate_refractive()'s free_port: given, the job
              // refuses it.
              if (!datum.is_none()) o.datum = datum.cast<std::string>();
              o.free_port = !free_port.is_none();
              if (!air_detections.is_none()) {  // one list per camera: air images through its port
                o.air_given_detections.emplace();
                for (const auto& c : air_detections.cast<py::list>()) {
                  o.air_given_detections->push_back(DetectionsArg(c.cast<py::list>()));
                }
              }
              calib::CalibrateRigJobResult r;
              {
                py::gil_scoped_release release;
                r = calib::CalibrateRigJob(o);
              }
              nlohmann::ordered_json j = calib::CalibrateRigJobJson(r);
              PythonWordsInJson(&j);
              j["warnings"] = PythonWarnings(r.warnings);  // the pitches' and the ports', as the CLI prints them
              py::list estimated;  // each camera's port as estimated (a PortSpec), None without one
              for (const auto& c : r.rig.cameras) {
                estimated.append(c.has_port ? py::cast(c.estimated_port) : py::none());
              }
              return py::make_tuple(JsonToPython(j), estimated);
            });
      },
      py::arg("cameras"), py::arg("target"), py::kw_only(), py::arg("model") = "brown", py::arg("pixel_pitch_mm") = 1.0,
      py::arg("free") = "default", py::arg("reject_k") = 5.0, py::arg("port") = py::none(),
      py::arg("air_calibration") = py::none(), py::arg("air_lens_bare") = false, py::arg("water") = "seawater",
      py::arg("water_index") = py::none(), py::arg("lambda_nm") = 546.07, py::arg("temperature_c") = 20.0,
      py::arg("salinity_psu") = 35.0, py::arg("pressure_dbar") = 0.0, py::arg("progress") = false,
      py::arg("names") = std::vector<std::string>{}, py::arg("air_detections") = py::none(),
      py::arg("datum") = py::none(), py::arg("free_port") = py::none(), py::arg("air_refocused") = false,
      py::arg("target_free") = false, py::arg("ep_mm") = py::none(),
      "The rig calibration of `porthole calibrate --detections A --detections B ...` (docs/calibration.md, "
      "\"Rigs\"): cameras is a list with each camera's detections (frames matched by image name); model one for "
      "all or a list; pixel_pitch_mm one for all or a list; port (a preset name or TOML file, one for all or a list) puts each camera behind its port in "
      "water; air_calibration a list, one per camera (files of any format or calibration dicts), or one rig file of "
      "any rig format, made with the housings on (the default) or of each lens alone (air_lens_bare=True), as a "
      "prior; air_detections a list, one per camera, of the detections of images in air "
      "through its port (the housing on), adjusted with the rig; air_refocused=True when they were taken at "
      "another focus (each camera's air images their own focal length, a factor adjusted); target_free=True adjusts "
      "the target's points with the rig (datum: auto | minimal | control, chosen by the first camera's calibration; "
      "the JSON's rig.target_adjusted); ep_mm: every camera's entrance pupil in its housing frame (mm; default: each "
      "port file's). free_port (calibrate_refractive()'s) is refused: a rig does not take it yet. "
      "Returns (the JSON of `porthole calibrate ... --json` for a rig: {\"rig\": {..., \"cameras\": [...]}, "
      "\"skipped\": []}, with warnings: the plausibility warnings of the pitches and the ports, as the CLI prints "
      "them; each camera's estimated port, a PortSpec (None without a port): --port-out's files as "
      "PortSpec.to_toml() gives them).");

  m.def(
      "synthetic_detections",
      [](const py::dict& camera, int width_px, int height_px, double pixel_pitch_mm,
         const std::string& target, int n_images, double noise_px, uint64_t seed,
         double max_tilt_deg, double max_off_axis_deg, double fill) {
        calib::SyntheticOptions o;
        o.camera = CameraFromDict(camera, width_px, height_px, pixel_pitch_mm);
        o.target = calib::ParseTarget(target, "target");
        o.n_images = n_images;
        o.max_tilt_deg = max_tilt_deg;
        o.max_off_axis_deg = max_off_axis_deg;
        o.fill = fill;
        o.noise_px = noise_px;
        o.noise_seed = seed;
        const auto set = calib::MakeSyntheticSet(o);
        py::list out;
        for (const auto& d : set.detections) out.append(JsonToPython(calib::DetectionsToJson(d, o.target)));
        return out;
      },
      py::arg("camera"), py::kw_only(), py::arg("width_px"), py::arg("height_px"),
      py::arg("pixel_pitch_mm"), py::arg("target") = "chessboard:13x9:40",
      py::arg("n_images") = 12, py::arg("noise_px") = 0.3, py::arg("seed") = 2,
      py::arg("max_tilt_deg") = 40.0, py::arg("max_off_axis_deg") = 0.0, py::arg("fill") = 0.7,
      "Detections of a planar target seen by a known camera (dict: model, default brown, and its "
      "parameter keys, e.g. c_mm … B2 or fx_px, fy_px, cx_px, cy_px, k1 … k4), with Gaussian pixel "
      "noise: ground truth for tests. max_off_axis_deg turns views away from the target (fisheyes).");

  m.def(
      "compare",
      [](const py::dict& a, const py::dict& b, double alpha) {
        calib::CompareOptions o;
        o.alpha = alpha;
        const auto r = calib::Compare(calib::CalibrationFromJson(PythonToJson(a), "a"),
                                      calib::CalibrationFromJson(PythonToJson(b), "b"), o);
        nlohmann::ordered_json rows = nlohmann::ordered_json::array(), curves = rows;
        for (const auto& row : r.rows) {
          rows.push_back({{"parameter", std::string(camera::Info(r.model).params[row.index].json_key)},
                          {"a", row.a}, {"b", row.b}, {"diff_b_minus_a", row.diff},
                          {"sigma_diff", std::isfinite(row.sigma_diff) ? nlohmann::ordered_json(row.sigma_diff) : nullptr},
                          {"z", std::isfinite(row.z) ? nlohmann::ordered_json(row.z) : nullptr}});
        }
        for (const auto& p : r.curves) {
          curves.push_back({{"r_mm", p.r_mm}, {"radial_a_um", p.radial_a_um},
                            {"radial_b_um", p.radial_b_um}, {"decentring_a_um", p.decentring_a_um},
                            {"decentring_b_um", p.decentring_b_um}});
        }
        return JsonToPython(nlohmann::ordered_json{{"parameters", rows},
                         {"chi2", std::isfinite(r.chi2) ? nlohmann::ordered_json(r.chi2) : nullptr},
                         {"dof", r.dof},
                         {"p_value", std::isfinite(r.p_value) ? nlohmann::ordered_json(r.p_value) : nullptr},
                         {"significant", r.significant},
                         {"covariance", r.covariance_note},
                         {"max_diff_um", r.max_diff_um},
                         {"curves", curves}});
      },
      py::arg("a"), py::arg("b"), py::kw_only(), py::arg("alpha") = 0.05,
      "Compares two calibration dicts: differences with sigma, chi2 test, radial and decentring "
      "curves (um).");
}

}  // namespace porthole::python
