// Rig files of the tools users have (issue 26; docs/interop.md, "Rig files"): a calibrated rig
// written to, and read back from,
//
//   format            file(s)                            holds
//   json              porthole's rig JSON (calibrate)    every model, ports, σ (calib::RigToJson)
//   opencv-stereo     OpenCV FileStorage YAML / XML      two opencv cameras: K1 D1 K2 D2 R T as
//   opencv-stereo-xml (cv::stereoCalibrate's outputs,    cv::stereoCalibrate returns them and
//                     read by cv::stereoRectify)         cv::stereoRectify takes them; image_width,
//                                                        image_height; porthole adds T_unit
//   viame-npz         VIAME's stereo .npz (numpy)        two opencv cameras: cameraMatrixL/R (3×3),
//                                                        distCoeffsL/R (1×n), R (3×3), T (3×1), all
//                                                        float64 (what VIAME's
//                                                        tools/calibrate_cameras.py --npz writes,
//                                                        VIAME 05ee7881, and camtrawl's
//                                                        StereoCalibration.from_npzfile reads);
//                                                        porthole adds T_unit, imageSizeL/R
//   ros-camera-info   one ROS camera_info YAML per       a stereo pair: each camera's K, D
//                     camera (camera_calibration_        (plumb_bob, rational_polynomial or
//                     parsers' format)                   equidistant) and the stereo
//                                                        rectification R, P (see below)
//   kalibr            Kalibr camchain YAML               any number of cameras, pinhole-radtan or
//                                                        pinhole-equi, T_cn_cnm1 in metres
//
// Frames: each camera's cam_from_rig (x_cam = R·x_rig + t, mm; the rig frame is camera 0's).
// OpenCV's and VIAME's R, T take camera 1's frame into camera 2's (x2 = R·x1 + T): camera 1 is the
// rig's camera 0. Kalibr's T_cn_cnm1 takes camera n−1's frame into camera n's.
//
// Units: porthole is mm. Kalibr and ROS state metres (Kalibr's camchain, ROS REP 103), and are
// converted at the boundary. OpenCV's and VIAME's T are in the unit of the target the calibration
// used, which the formats do not state: porthole writes mm and says so in an extra T_unit entry
// ("mm"; cv2 and VIAME ignore it); reading a file without T_unit needs RigReadOptions::length_unit,
// and is refused without it (never guessed).
//
// Models: an opencv camera is written exactly where the format holds its coefficients (Kalibr's
// radtan holds k1 k2 p1 p2 only; a camera with k3…k6 is refit). Other models are refit over the
// image (interop.h's ConvertCalibration: brown → opencv; equidistant → kannala-brandt exact;
// kannala-brandt → opencv where the format has no fisheye model) and the refit's RMS is reported;
// a refit above kMaxRefitRmsPx is refused. A camera behind a port is refused: these formats have
// no refraction.
//
// ROS's R and P (what porthole writes): the stereo rectification of the pair, as
// cv::stereoRectify computes R1, R2 (each camera's rotation into the common rectified frame;
// x_rect = R·x_cam) with P = [f' 0 cx' Tx; 0 f' cy' Ty; 0 0 1 0], f' the mean of the four focal
// lengths, (cx', cy') the mean principal point, and for the second camera (Tx, Ty) = f'·(offset of
// camera 1's centre in the rectified frame), metres: Tx = −f'·B for a horizontal baseline B. Read
// back: R = R2ᵀR1 and T = R2ᵀ·(Tx/f', Ty/f', 0). A camera_info with R = I and P = [K|0] (a single
// camera) holds no pose.
//
// Files: each format is one .cc of interop/ (rig_json.cc, rig_opencv.cc, rig_viame.cc, rig_ros.cc,
// rig_kalibr.cc) and one row of the list in rig_files.cc, which also detects and dispatches.
//
// Untrusted input: the YAML reader is a bounded line scanner (nesting ≤ 16, ≤ 100 000 lines);
// the npz through libzip with each member ≤ 1 MiB and at most 64 members. Errors are
// InvalidInput("<field>: <key>", rule), one line.
#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "porthole/calib/result_json.h"
#include "porthole/camera/camera.h"

namespace porthole::calib {
struct RigResult;
}

namespace porthole::interop {

enum class RigFormat { kJson, kOpenCVStereoYaml, kOpenCVStereoXml, kViameNpz, kRosCameraInfo, kKalibr };

// "json", "opencv-stereo", "opencv-stereo-xml", "viame-npz", "ros-camera-info", "kalibr".
std::string_view RigFormatName(RigFormat f);
// Throws InvalidInput(field, "unknown rig format … (known: …)").
RigFormat RigFormatFromName(std::string_view name, const std::string& field);
std::string RigFormatNames();

// One camera of a rig as the files hold it.
struct RigFileCamera {
  std::string name;
  calib::CalibrationRecord calibration;  // model, sensor, parameters (σ only from porthole JSON)
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // cam_from_rig: x_cam = R·x_rig + t
  Eigen::Vector3d translation_mm = Eigen::Vector3d::Zero();
  std::string port;  // behind a port: its name (porthole JSON only); such a camera is not written
};

struct RigFile {
  std::vector<RigFileCamera> cameras;
  RigFormat format = RigFormat::kJson;  // what it was read from
  bool pitch_known = false;             // the file gave the pixel pitch (porthole JSON only)
  std::string length_unit_note;         // how T's unit was known ("stated: mm", "given: m", …)
};

// A rig from porthole's rig JSON ({"rig": {"cameras": [...]}}, calib::RigToJson) or from a rig
// calibration in memory. Throws InvalidInput(field + ".<key>", …).
RigFile RigFileFromJson(const nlohmann::json& j, const std::string& field);
RigFile RigFileFromResult(const calib::RigResult& r);
// The rig as porthole's rig JSON (what measure::RigFromJson reads): each camera's calibration
// JSON with its name and cam_from_rig {rotation_rad, translation_mm}; no joint covariance
// ("covariance_note" says why).
nlohmann::ordered_json RigFileToJson(const RigFile& rig);

// Length units a file may leave unstated.
enum class LengthUnit { kUnstated, kMm, kCm, kM };
// "mm", "cm", "m"; throws InvalidInput(field, "… (choices: mm, cm, m)").
LengthUnit LengthUnitFromName(std::string_view name, const std::string& field);

struct RigReadOptions {
  double pixel_pitch_mm = 1.0;  // pixel formats carry no pitch (> 0; 1: pixels are mm)
  LengthUnit length_unit = LengthUnit::kUnstated;  // T's unit where the file does not state it
  std::optional<RigFormat> format;                 // else detected
  // The image size (width, height px) where the file holds none (VIAME's npz; porthole writes its
  // own imageSizeL/R): refused without it.
  std::optional<std::pair<int, int>> image_size;
};

// The rig format of a file from its name and content, or nullopt when it is not one (a single
// camera's calibration, anything else): a .npz or a zip → viame-npz; JSON with "rig" → json;
// YAML/XML with K1 and T → opencv-stereo(-xml); YAML with cam0 and its intrinsics → kalibr; YAML
// with camera_name and projection_matrix → ros-camera-info.
std::optional<RigFormat> DetectRigFormat(const std::string& path, const std::string& content);

// Reads a rig from its file(s): one file, or one ROS camera_info per camera (in rig order).
// Throws InvalidInput(field, …) naming the file and key; a file that is not a rig says so.
RigFile ReadRigFiles(const std::vector<std::string>& paths, const RigReadOptions& options, const std::string& field);
// From contents in memory (`names`: the files' names, for detection and messages).
RigFile ParseRigFiles(const std::vector<std::string>& contents, const std::vector<std::string>& names,
                      const RigReadOptions& options, const std::string& field);

// What was written: the files' names (ROS: "<camera name>.yaml" each; others: empty = the output
// path itself) and bytes, and per camera how faithfully.
struct RigWriteCamera {
  std::string name;
  std::string format_model;  // e.g. "radtan", "plumb_bob", "8 coefficients"
  bool exact = true;
  camera::ConversionFit fit;  // a refit's RMS and max over the image, px
};
struct RigWriteResult {
  std::vector<std::pair<std::string, std::string>> files;  // (name, content)
  std::vector<RigWriteCamera> cameras;
  bool exact() const;
  double worst_rms_px() const;  // the largest refit RMS (0: all exact)
};
// Writes the rig in `format`. Throws InvalidInput(field, …): a camera behind a port, a model the
// format cannot hold even by refit, a pair format (opencv-stereo, viame-npz, ros-camera-info) with
// other than two cameras, two cameras of different image sizes in OpenCV's one image size.
RigWriteResult WriteRigFile(const RigFile& rig, RigFormat format, const std::string& field);

// The format to write `path` in: `to` when given, else from the extension: .json → json; .npz →
// viame-npz; .xml → opencv-stereo-xml; a directory → ros-camera-info; .yml/.yaml is ambiguous
// (opencv-stereo or kalibr) and refused in one line naming the choices.
RigFormat RigOutputFormat(const std::string& path, const std::optional<std::string>& to, const std::string& field);

// For `calibrate --air-calibration` of a rig: each camera's calibration in a rig file of any
// format above (in rig order; σ where the file holds it, else unknown).
std::vector<calib::CalibrationRecord> ReadRigCalibrations(const std::vector<std::string>& paths,
                                                          const RigReadOptions& options, const std::string& field);

// The pieces (for the tests): a .npy array (float64, C order, any shape) and the npz zip.
struct NpyArray {
  std::vector<int> shape;
  std::vector<double> data;  // C order
  std::string text;          // a unicode ('<U…') array's string (scalar arrays only)
  bool is_text = false;
};
std::string NpyBytes(const NpyArray& a);
NpyArray ParseNpy(std::string_view bytes, const std::string& field);
std::string ZipStored(const std::vector<std::pair<std::string, std::string>>& members, const std::string& field);
std::vector<std::pair<std::string, std::string>> ReadZip(std::string_view bytes, const std::string& field);

}  // namespace porthole::interop
