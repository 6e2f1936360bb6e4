// Calibration of a rig of cameras (issue 26): several cameras fixed to one another see the same
// target in synchronised frames; one bundle adjustment gives each camera's intrinsics (any model of
// the camera list, each its own) and its pose in the rig, with σ and correlations.
//
// Contract:
//  - Observations: per camera, the detections of its images (observations.h). Frames are matched
//    by image name: the file name without its folder and extension ("f012.png" of camera 0 and
//    "f012.jpg" of camera 1 are one frame). A frame seen by one camera only still counts (it
//    constrains that camera's intrinsics); every camera must share at least one frame with a
//    camera already linked to camera 0, else the rig is not connected and is refused.
//  - Frames: the rig frame is camera 0's camera frame (docs/conventions.md: X right, Y down, Z
//    forward, mm). Unknowns: each camera's free intrinsics (CalibrationOptions::free, scaled as
//    calibrate.cc does), each camera k > 0's cam_from_rig (angle-axis rad, translation mm; camera
//    0's is the identity), and each frame's rig_from_target. A point X of the target is seen by
//    camera k in frame f at Project_k(cam_from_rig_k · rig_from_target_f · X); the residual is
//    projected − observed, px, by automatic differentiation through the model's Project.
//  - Behind ports (RigOptions::ports): each camera is its lens model behind its port in water
//    (refraction::Project), its port parameters adjusted too; with in-air calibrations
//    (RigOptions::air_lens) as priors: made through the ports in air, on each lens and its port
//    (housed_prior.h); of the lenses alone, on every parameter but the focal length.
//  - Start: each camera calibrated alone (calib::Calibrate, its own start; behind a port
//    calib::CalibrateRefractive, with its prior); cam_from_rig of each
//    camera from its poses and those of a camera already placed over the frames they share
//    (breadth first from camera 0; the chordal mean of the rotations, the mean of the
//    translations); each frame's pose from the first placed camera that sees it.
//  - Adjustment: Ceres, Schur elimination of the frame poses (one 6-parameter block each), outlier
//    rejection at reject_k·σ0 as Calibrate, the first camera's options for iterations and threads.
//  - Statistics: σ0 = sqrt(Σ|r|²/(2n − u)) over all cameras; the covariance σ0²·(JᵀJ)⁻¹ of every
//    camera's intrinsics and cam_from_rig, marginal over the frames (Ceres Covariance); each
//    camera's RMS and per-image RMS; baselines (|t| of cam_from_rig, the camera centre's distance
//    from camera 0's) and convergence angles (between each optical axis and camera 0's).
// Bad input throws InvalidInput naming the field: fewer than 2 cameras, options whose count is
// neither 1 nor the cameras', a camera whose images' size differs between frames, cameras with
// no frame name in common (not connected), too few frames or points.
#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "porthole/calib/calibrate.h"
#include "porthole/calib/refractive.h"
#include "porthole/calib/result_json.h"
#include "porthole/ports/port.h"
#include "porthole/refraction/refraction.h"

namespace porthole::calib {

struct RigOptions {
  // One per camera, or one for all (model, free set, pixel pitch, outlier rejection, iterations,
  // threads, progress). The first camera's target_free and datum are the rig's: a free target
  // (free_target.h) whose start and datum are the first camera's own calibration's.
  std::vector<CalibrationOptions> cameras;
  // Names of the cameras in the output (their folders or files); unset: camera0, camera1, …
  std::vector<std::string> names;
  // Cameras behind ports, in water: one port system for all or one per camera (empty: no port, in
  // air). Each camera is then the lens model behind its port (refraction::Project, the exact
  // forward projection); its three port parameters (refraction::PortParams: a dome's pupil
  // position, a flat port's normal and distance) are adjusted with everything else, starting from
  // its own refractive calibration (calib::CalibrateRefractive, lens free, the axial search); the
  // system's values are the predicted ones the estimate is reported beside.
  std::vector<ports::PortSystem> ports;
  // With ports: an in-air calibration of each camera (one per camera), a Gaussian prior with its
  // covariance, the image residuals weighted by 1/σ0 of a first pass. What each is (air_of, as
  // RefractiveOptions::air_of): made in air with the housing on (kThroughPort, the default): a
  // prior on the lens and its port together (housed_prior.h), every parameter it adjusted, one
  // focus; of the lens alone (kLensBare): on every parameter it adjusted except the focal
  // length(s) (the lens refocuses behind a dome). Without it a dome's axial pupil offset is nearly
  // undetermined (it trades with the focal length and the cameras' positions).
  std::vector<CalibrationRecord> air_lens;
  RefractiveOptions::AirCalibrationOf air_of = RefractiveOptions::AirCalibrationOf::kThroughPort;
  // With ports: images of the target taken in air through each camera's own port (the housing on,
  // the focus unchanged; the paper's protocol, RefractiveOptions::air_detections): one list per
  // camera (a list may be empty), each image its own pose (not synchronised), modelled as the
  // camera's lens behind its port with air outside and adjusted with the rig. Not with air_lens.
  std::vector<std::vector<ImageDetections>> air_images;
  // Each camera's air images were taken at another focus (its lens refocused between the sets,
  // RefractiveOptions::air_refocused): they get their own focal length(s), the camera's times a
  // factor adjusted with the rest (start: the camera's own calibration's). Only with air_images.
  bool air_refocused = false;
  // Each camera's start behind its port searches the axial port parameter (RefractiveOptions::search);
  // off when the predicted ports are known to be close (Monte-Carlo runs).
  bool port_search = true;
};

struct RigCamera {
  std::string name;
  // The camera's calibration: model, sensor, parameters, free set, σ, correlation, σ0 and RMS of
  // its own residuals, per-image RMS and cam_from_target poses (CalibrationResult's meaning).
  CalibrationResult calibration;
  // cam_from_rig (rig frame = camera 0's): x_cam = R(rotation_rad)·x_rig + translation_mm.
  Eigen::Vector3d rotation_rad = Eigen::Vector3d::Zero();
  Eigen::Vector3d translation_mm = Eigen::Vector3d::Zero();
  // σ0²-scaled covariance of (rotation_rad, translation_mm) (6 × 6; zero for camera 0), σ.
  Eigen::Matrix<double, 6, 6> pose_covariance = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> pose_sigma = Eigen::Matrix<double, 6, 1>::Zero();
  double baseline_mm = 0;      // distance of its centre from camera 0's
  double baseline_sigma_mm = 0;
  double convergence_deg = 0;  // angle between its optical axis and camera 0's
  int n_frames = 0;            // frames it sees
  // Behind a port (RigOptions::ports): its kind, the estimated port parameters with σ, the
  // predicted ones, and the port as estimated (housing frame; named "<port>-as-calibrated": what
  // CalibrateRigJob writes as a port TOML, port_out).
  bool has_port = false;
  refraction::PortKind port_kind = refraction::PortKind::kDome;
  std::array<double, refraction::kPortNumParams> port{}, port_sigma{}, port_predicted{};
  ports::PortSpec estimated_port;
  refraction::Shell shell;  // its fixed part (radii, thickness, indices), cam-frame axes
  // Its air images (RigOptions::air_images): each one's RMS and cam_from_target, and their RMS
  // (NaN without).
  std::vector<ImageResult> air_images;
  double air_rms_px = NAN;
  // With RigOptions::air_refocused: its air images' focal length(s) over its water images', σ.
  double air_focal_scale = NAN, air_focal_scale_sigma = NAN;
};

struct RigResult {
  std::vector<RigCamera> cameras;
  std::vector<std::string> frames;  // every frame name, sorted
  // The joint σ0²-scaled covariance of every camera's adjusted parameters, marginal over the
  // frames: per camera in order its intrinsics (model order, physical units; fixed ones zero), its
  // port parameters (behind a port) and its cam_from_rig (k > 0: rotation_rad x y z, translation_mm
  // x y z). covariance_parameters names each row "<camera name>.<key>" (the model's json_key, the
  // port's json_key, cam_from_rig.rx_rad … tz_mm). What measure/ propagates: the cameras'
  // errors are correlated, through the frames they share.
  Eigen::MatrixXd covariance;
  std::vector<std::string> covariance_parameters;
  int n_points = 0, n_rejected = 0, n_unknowns = 0, redundancy = 0, iterations = 0;
  double sigma0_px = 0, rms_px = 0, seconds = 0;
  std::string message;  // "ok", "poor: …" (PoorFitStatus)
  // A free target (the first camera's target_free): the adjusted points, their σ and the datum
  // (CalibrationResult's meaning; the JSON's target_adjusted). Empty / unset otherwise.
  std::vector<Eigen::Vector3d> target_points_mm, target_sigma_mm;
  CalibrationResult::Datum datum;
};

// The frame name of an image: its file name without folder and extension.
std::string FrameName(const std::string& image);

// Calibrates the rig from `per_camera[k]`, the detections of camera k's images.
RigResult CalibrateRig(const std::vector<std::vector<ImageDetections>>& per_camera, const TargetSpec& target,
                       const RigOptions& options);

// {"cameras": [each camera's calibration JSON (CalibrationToJson) with "name" and "cam_from_rig"
// {rotation_rad, translation_mm, sigma, covariance}, baseline_mm, convergence_deg, n_frames, and
// behind a port "port" {name, kind, n_water, parameters, sigma, predicted, shell {its fixed part}}],
// "frame": "camera 0", n_frames, sigma0_px, rms_px, counts, status, "covariance" {parameters,
// matrix} (RigResult::covariance)}.
nlohmann::ordered_json RigToJson(const RigResult& r, const TargetSpec& target, const RigOptions& options);

}  // namespace porthole::calib
