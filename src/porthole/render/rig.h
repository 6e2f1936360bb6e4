// Rendering a rig: the same scene — the target at one pose in the rig frame — seen by each camera
// of a rig, each its own camera model behind its own port (or bare), in water or in air; and
// synchronised calibration sets, every camera's image of a frame under one name (docs/render.md,
// "Rigs").
//
// Frames (docs/conventions.md, docs/calibration.md "Rigs"): the rig frame is the first camera's
// camera frame; camera k maps it into its own by cam_from_rig (x_cam = R·x_rig + t, mm), its camera
// frame's origin at its entrance pupil. A pose of the target is rig_from_target; camera k renders
// the target at cam_from_rig ∘ rig_from_target, and its ground truth is that of a single-camera
// render of that pose (render.h, TruthJson) plus a "rig" block (the camera, cam_from_rig,
// rig_from_target).
#pragma once

#include <array>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "porthole/core/output.h"
#include "porthole/refraction/refraction.h"
#include "porthole/render/render.h"

namespace porthole::render {

struct RigCamera {
  std::string name;                      // its folder under the output: letters, digits, '_', '-', '.'
  std::optional<camera::Camera> camera;  // unset: the scene's (Scene::camera, else the lens's ideal one)
  enum class PortUse { kScene, kOwn, kNone };
  PortUse port_use = PortUse::kScene;    // the scene's port, `port`, or none (bare: Scene::bare)
  ports::PortSpec port;                  // kOwn: usually written in the cam frame (relative to its pupil)
  Pose cam_from_rig;                     // x_cam = R x_rig + t, mm
};

// n cameras of the scene's camera and port: camera k (k ≥ 1) baseline_mm·k to the right of the
// first (rig x) and turned convergence_deg towards it about the vertical axis, so that the optical
// axes cross in front of the rig: cam_from_rig R = R_y(+conv) (camera k's axis in the rig frame
// (−sin conv, 0, cos conv)), t = −R·(baseline·k, 0, 0). Named cam0, cam1, … Throws InvalidInput
// for n < 2 ("cameras"), a baseline ≤ 0 ("baseline_mm"), a convergence outside [0°, 45°)
// ("convergence_deg"). measure::DescribedRig (`porthole plan`) describes the same rig.
std::vector<RigCamera> DescribedRig(int n, double baseline_mm, double convergence_deg);

// Checks the cameras: at least one, names usable as folder names and distinct (InvalidInput
// "cameras"), each camera, port and cam_from_rig valid ("cameras.<name>.camera", ".port",
// ".cam_from_rig").
void ValidateRig(const std::vector<RigCamera>& cameras);

// The scene camera `cam` sees: `base` with its camera, port (or none) and the target at
// cam_from_rig ∘ rig_from_target.
Scene CameraScene(const Scene& base, const RigCamera& cam, const Pose& rig_from_target);

// The focus-scale distance a set focuses at when the scene gives none: under water (or bare, in
// air) on the middle of the set's distances (SetOptions' near/far, or those SetPosesSeenBy chooses
// for cameras whose pupils lie up to baseline_mm apart, the camera's focal length taken at infinity
// focus), or the lens's closest focus when it cannot focus that close (*closest set true);
// *middle_mm: that middle distance (from the pupil, mm).
double SetFocusDistanceMm(const Scene& scene, const SetOptions& options, double baseline_mm = 0,
                          bool* closest = nullptr, double* middle_mm = nullptr);

// One camera's ground truth (TruthJson) with its "rig" block.
nlohmann::ordered_json RigTruthJson(const Scene& scene, const RenderOptions& options, const Rendered& r,
                                    const std::string& image_file, int bit_depth, const RigCamera& cam,
                                    int index, const Pose& rig_from_target);

// One image RenderRig wrote: its camera (index), medium, frame, what was rendered, the ground truth's
// text as written and what RenderRig's summary lists of it.
struct RigImage {
  int camera = 0;
  const std::string& medium;
  const std::string& frame;
  const Rendered& rendered;
  const std::string& truth_text;
  const nlohmann::ordered_json& summary;
};

struct RigRenderOptions {
  RenderOptions render;
  int bit_depth = 8;
  // 0: one image per camera of base.pose (rig_from_target) in base.medium, written to
  // out/<camera>/render.png and .json. N > 0: a set of N synchronised frames (SetPosesSeenBy with
  // `set`, its count replaced by N), each frame rendered by every camera in water and in air into
  // out/water/<camera>/pose_NNN.png and out/air/<camera>/… (a rig of bare cameras: air only),
  // each camera focused as SetFocusDistanceMm says unless the scene gives a focus.
  int set_count = 0;
  SetOptions set;
  std::filesystem::path out;
  OutputRules rules;  // every file written under them (core/output.h); checked before the first render
  // One line of progress now and then (may be empty).
  std::function<void(const std::string&)> log;
  // Called once the images are known (the rig, scene and set checked), before the first folder is
  // made or file checked (the CLI clears an earlier set there). May be empty.
  std::function<void()> prepare;
  // Called after each image is written (may be empty): what the caller keeps of it.
  std::function<void(const RigImage&)> written;
};

// Renders the rig and writes every image and ground truth, each whole or absent; returns what was
// written: {"cameras": [names], "images": [{camera, medium, frame, image, truth, points, seconds}],
// "frames": N, "focus_distance_mm": [per camera]}. Throws InvalidInput (bad rig, scene, options or
// an output the rules refuse) before the first image is rendered.
nlohmann::ordered_json RenderRig(const Scene& base, const std::vector<RigCamera>& cameras,
                                 const RigRenderOptions& options);

}  // namespace porthole::render
