// A calibrated rig as measure/ uses it: each camera's lens model, its port (when it is behind one)
// and its pose in the rig, with the joint covariance of all of them. Read from the rig JSON that
// `porthole calibrate` writes (calib::RigToJson), or taken from a calib::RigResult in memory.
//
// Frames (docs/conventions.md): the rig frame is camera 0's camera frame (X right, Y down, Z
// forward, mm); camera k maps it into its own frame by x_cam = R(rotation_rad)·x_rig +
// translation_mm. Behind a port, a camera's frame has its origin at the lens's entrance pupil.
//
// Uncertainty: `covariance` is the joint covariance of every parameter the rig calibration
// adjusted, indexed through each camera's *_index arrays (−1: not adjusted, or not in the file).
// A rig file written before the joint covariance existed gives each camera's own blocks
// (intrinsics, cam_from_rig) and no cross terms; covariance_note then says so.
#pragma once

#include <Eigen/Core>
#include <array>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "porthole/camera/camera.h"
#include "porthole/refraction/refraction.h"

namespace porthole::calib {
struct RigResult;
}

namespace porthole::measure {

struct RigCamera {
  std::string name;
  camera::Camera camera;                    // model, sensor, parameters
  std::optional<refraction::Shell> shell;   // behind a port: its fixed part
  std::array<double, refraction::kPortNumParams> port{};  // and its parameters (refraction.h)
  Eigen::Vector3d rotation_rad = Eigen::Vector3d::Zero();   // cam_from_rig, angle-axis
  Eigen::Vector3d translation_mm = Eigen::Vector3d::Zero();
  // Rows of Rig::covariance: one per intrinsic parameter (model order), port parameter, and
  // cam_from_rig component (rx, ry, rz rad, tx, ty, tz mm); −1 where not adjusted.
  std::vector<int> intrinsic_index;
  std::array<int, refraction::kPortNumParams> port_index{-1, -1, -1};
  std::array<int, 6> pose_index{-1, -1, -1, -1, -1, -1};

  // R of cam_from_rig (from rotation_rad, angle-axis).
  Eigen::Matrix3d CamFromRigRotation() const;
};

struct Rig {
  std::vector<RigCamera> cameras;
  Eigen::MatrixXd covariance;  // joint, mm / rad / px units as the parameters
  std::string covariance_note;  // "joint", or why it is partial / absent
  double sigma0_px = 0;         // the calibration's σ0 (image residuals)
};

// Reads a rig JSON ({"rig": {…, "cameras": [...], "covariance": {...}}}). Throws
// InvalidInput(field + ".<key>", …) naming what is missing or wrong; a single camera's calibration
// is refused with a line saying it is not a rig.
Rig RigFromJson(const nlohmann::json& j, const std::string& field);
// The same read from `path` (size-capped, JSON errors with their line); also a rig file of another
// tool (interop/rig_files.h: OpenCV stereo YAML/XML, VIAME npz, Kalibr camchain), which holds no
// covariance (covariance_note says so) and must state its length unit (porthole's own do).
Rig LoadRig(const std::string& path, const std::string& field);
// One camera's calibration (porthole's JSON: a lens, or a lens behind its port with the port's
// `shell`) as a rig of that camera alone, for measuring on a known plane; its covariance: the
// lens's, and the port parameters' σ (their correlation with the lens left out: covariance_note
// says so). A rig file is read as RigFromJson.
Rig CameraFromJson(const nlohmann::json& j, const std::string& field);
Rig LoadCamera(const std::string& path, const std::string& field);
// The rig of a calibration in memory (its joint covariance included).
Rig RigFromResult(const calib::RigResult& r);

// The index of the camera called `name` (exact), or given by its index ("0", "1", …). Throws
// InvalidInput(field, "no camera … in the rig (cameras: a, b)") otherwise, naming the nearest.
int CameraIndex(const Rig& rig, std::string_view name, const std::string& field);

}  // namespace porthole::measure
