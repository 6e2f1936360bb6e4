// The whole of `porthole render` as one call, for the CLI and Python alike (issue 25): one image of
// a target at a pose, a calibration set of N seeded poses in water and in air (`set_count`), or
// every camera of a rig (`rig`: a rig file or its JSON, or `baseline_mm`: two of the scene's camera),
// one frame or a synchronised set. Every image is written with its ground truth beside it, each
// whole or absent, under core/output.h's overwrite rule; the result says what was written (the
// JSON `porthole render --json` prints) and, when asked, holds each image's ground truth and pixels
// in memory. docs/render.md describes the model, the files and the sets; render.h and rig.h the
// steps this strings together.
//
// Errors: InvalidInput naming the options' fields below (`out`, `medium`, `color`, `bit_depth`,
// `distance_mm`, `noise_e`, `camera_model`, `rig`, ...; the steps' own: `samples_per_pixel`,
// `count`, `near_mm`, `cameras`, `pose`, ...), thrown before the first image is written. Outputs are
// checked before anything is read: an input named as an output is refused as that.
#pragma once

#include <Eigen/Core>
#include <array>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "porthole/core/output.h"
#include "porthole/housing/housed.h"
#include "porthole/render/render.h"
#include "porthole/render/rig.h"

namespace porthole::render {

struct RenderJobOptions {
  // The camera: body, lens, port (its glass for a rig camera whose port the file does not name),
  // water and pupil, as the front end's camera options build it.
  housing::HousedCamera housed;
  bool bare = false;                    // no port: the lens alone (Scene::bare)
  std::string target = "chessboard:9x6:40";  // a target spec (calib::ParseTarget)
  std::string field;                    // a target-field file (coded targets), or empty
  std::string medium = "water";         // water or air
  std::optional<double> focus_distance_mm;  // FD (may be infinite); unset: on the target (a set: SetFocusDistanceMm)
  std::optional<double> f_number;       // unset: lens::DefaultFNumber (f/8 or the nearest the lens has)
  bool natural_vignetting = false;
  std::array<double, 3> vignetting_pa = {0, 0, 0};
  std::string camera_model;             // a calibration file (any format) or a render's ground truth; empty: ideal
  std::optional<double> c_mm;           // the ideal camera's principal distance
  std::vector<double> bands_nm = kDefaultBandsNm;
  bool white_on_black = false;

  // The target's pose (one image, or the rig frame of a rig's one frame): PoseFacing.
  double distance_mm = 1000;
  Eigen::Vector2d shift_mm = Eigen::Vector2d::Zero();
  Eigen::Vector2d tilt_deg = Eigen::Vector2d::Zero();
  double roll_deg = 0;

  // The image: RenderOptions' samples, seed, exposure, threads (its color and noise from below).
  RenderOptions render;
  std::string color = "grey";                       // grey or rgb
  std::optional<std::array<double, 2>> noise_e;     // full well, read noise (electrons); unset: none
  int bit_depth = 8;                                // 8 or 16

  // A set: N > 0 seeded poses (SetOptions; its count and seed are set_count and render.seed).
  int set_count = 0;
  std::optional<std::array<double, 2>> distances_mm;  // near, far; unset: the target fills 30-80 %
  double max_tilt_deg = 35;
  double min_whole_fraction = 1;                    // coded targets: partial views

  // A rig: a rig file (any format measure::LoadRig reads), or its JSON (rig_json), or two of the
  // camera baseline_mm apart turned convergence_deg towards each other (DescribedRig).
  std::string rig;
  std::optional<nlohmann::json> rig_json;
  std::optional<double> baseline_mm;
  double convergence_deg = 0;

  // Where: one image: a .png (its truth the same name .json); a set or a rig: a directory.
  std::filesystem::path out;
  OutputRules rules;
  bool keep_truth = false;   // hold each image's ground truth in the result
  bool keep_pixels = false;  // and its pixels

  // Progress, one line at a time ("pose_003.png 40%", what each image took), and notes (a lens that
  // cannot focus as close as the set, a rig port's glass taken from `port`); notes may name fields
  // between backquotes. Either may be empty.
  std::function<void(const std::string&)> log;
  std::function<void(const std::string&)> note;
};

// One image written.
struct JobImage {
  std::string camera;                    // a rig's camera; empty for one camera
  std::string medium;                    // water or air
  std::string frame;                     // its name without extension (render, pose_NNN, or out's stem)
  std::filesystem::path image, truth;    // the files written
  nlohmann::ordered_json summary;        // what `render --json` lists of it
  nlohmann::ordered_json ground_truth;   // keep_truth: the truth file's JSON
  Image pixels;                          // keep_pixels: the linear image before encoding
};

struct RenderJobResult {
  // What `porthole render --json` prints: one image its summary; a set {poses, focus_distance_mm,
  // images: {water, air}}; a rig {cameras, frames, images, focus_distance_mm (a set)}.
  nlohmann::ordered_json summary;
  std::vector<JobImage> images;          // in the order rendered
  std::vector<std::string> cameras;      // a rig's camera names
  int frames = 0;                        // poses (a set) or frames (a rig); 1 for one image
  std::vector<double> focus_distance_mm; // a set: its focus (one per rig camera)
  std::vector<std::string> warnings;     // the housed camera's plausibility warnings (housing/plausible.h)
};

RenderJobResult RenderJob(const RenderJobOptions& options);

// The cameras of a rig file or its JSON (measure::RigFromJson): each its calibration, cam_from_rig and
// port (the port's glass from the preset or port file it names, else `fallback_material`, with a
// note), or none. Field `rig`.
std::vector<RigCamera> RigCamerasOf(const nlohmann::json& rig_json, const std::string& fallback_material,
                                    const std::function<void(const std::string&)>& note);
std::vector<RigCamera> LoadRigCameras(const std::string& path, const std::string& fallback_material,
                                      const std::function<void(const std::string&)>& note);

// Whether `name` is one a set writes (pose_NNN.png or pose_NNN.json).
bool IsSetFileName(const std::string& name);

}  // namespace porthole::render
