// What the rig formats of rig_files.h share, inside the library only: the format list's reader and
// writer signatures, each format's reader and writer (one .cc a format: rig_json.cc, rig_opencv.cc,
// rig_viame.cc, rig_ros.cc, rig_kalibr.cc), the bounded YAML reader of the YAML formats
// (rig_yaml.cc) and the cameras, poses and units they hold alike (rig_common.cc). Not installed,
// not for the front ends.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "porthole/camera/camera.h"
#include "porthole/interop/rig_files.h"
#include "porthole/interop/xml.h"

namespace porthole::interop::detail {

// ---- The format list (rig_files.cc's kRigFormats) ----

// A reader gets the files' contents and names (one file, or one a camera for ros-camera-info) and
// names the file in errors by `field`; ParseRigFiles validates the cameras it returns.
using RigReader = RigFile (*)(const std::vector<std::string>& contents, const std::vector<std::string>& names,
                              RigFormat format, const RigReadOptions& options, const std::string& field);
// A writer returns the files (name, content; name empty: the output path itself) and appends to
// `info` how faithfully each camera was written.
using RigFiles = std::vector<std::pair<std::string, std::string>>;
using RigWriter = RigFiles (*)(const RigFile& rig, RigFormat format, const std::string& field,
                               std::vector<RigWriteCamera>* info);

// rig_json.cc, rig_opencv.cc (opencv-stereo and opencv-stereo-xml), rig_viame.cc, rig_ros.cc,
// rig_kalibr.cc
RigFile ReadRigJsonFile(const std::vector<std::string>& contents, const std::vector<std::string>& names,
                        RigFormat format, const RigReadOptions& options, const std::string& field);
RigFiles WriteRigJsonFile(const RigFile& rig, RigFormat format, const std::string& field,
                          std::vector<RigWriteCamera>* info);
RigFile ReadOpenCVStereoFile(const std::vector<std::string>& contents, const std::vector<std::string>& names,
                             RigFormat format, const RigReadOptions& options, const std::string& field);
RigFiles WriteOpenCVStereoFile(const RigFile& rig, RigFormat format, const std::string& field,
                               std::vector<RigWriteCamera>* info);
RigFile ReadViameNpzFile(const std::vector<std::string>& contents, const std::vector<std::string>& names,
                         RigFormat format, const RigReadOptions& options, const std::string& field);
RigFiles WriteViameNpzFile(const RigFile& rig, RigFormat format, const std::string& field,
                           std::vector<RigWriteCamera>* info);
RigFile ReadRosFile(const std::vector<std::string>& contents, const std::vector<std::string>& names,
                    RigFormat format, const RigReadOptions& options, const std::string& field);
RigFiles WriteRosFile(const RigFile& rig, RigFormat format, const std::string& field,
                      std::vector<RigWriteCamera>* info);
RigFile ReadKalibrFile(const std::vector<std::string>& contents, const std::vector<std::string>& names,
                       RigFormat format, const RigReadOptions& options, const std::string& field);
RigFiles WriteKalibrFile(const RigFile& rig, RigFormat format, const std::string& field,
                         std::vector<RigWriteCamera>* info);

// ---- A bounded reader of the YAML these files use (rig_yaml.cc): block mappings and sequences,
// flow sequences of scalars ([a, b], nested), scalars, comments, tags (!!opencv-matrix) and
// directives skipped; nesting ≤ 16, ≤ 100 000 lines. ----

struct YNode {
  enum Kind { kNull, kScalar, kSeq, kMap } kind = kNull;
  std::string scalar;
  std::vector<YNode> seq;
  std::vector<std::pair<std::string, YNode>> map;
  int line = 0;

  const YNode* Get(std::string_view key) const {
    for (const auto& [k, v] : map) {
      if (k == key) return &v;
    }
    return nullptr;
  }
};

YNode ParseYaml(std::string_view text, const std::string& field);
// An XML <opencv_storage> document as the YAML tree: elements with children are mappings, others
// scalars (their text).
YNode XmlToNode(const XmlDocument& doc, const XmlElement& e);
YNode Scalar(std::string text);
// The value of `key` in a mapping; throws InvalidInput("<where>: <key>", "missing").
const YNode& Need(const YNode& map, std::string_view key, const std::string& where);
double Number(const YNode& n, const std::string& where);
// A whole number of pixels from 1 to 1000000.
int PixelsValue(double v, const std::string& where);
int Pixels(const YNode& n, const std::string& where);
// A matrix: a {rows, cols, data} mapping (OpenCV, ROS) or a list, with `count` numbers (0: any).
std::vector<double> Matrix(const YNode& n, std::size_t count, const std::string& where);

// ---- Cameras, poses and units the formats share (rig_common.cc) ----

// The numbers joined by `sep`, each with 17 significant digits and always a decimal point (PyYAML
// reads "500" as an int and "1e-05" as a string; Kalibr's reader insists on floats).
std::string NumList(const std::vector<double>& v, std::string_view sep = ", ");

// A rotation matrix from 9 row-major numbers (orthonormal, determinant +1, else InvalidInput).
Eigen::Matrix3d Rotation(const std::vector<double>& v, const std::string& where);
Eigen::Vector3d RotationVector(const Eigen::Matrix3d& r);
Eigen::Matrix3d FromRotationVector(const Eigen::Vector3d& v);

// Cameras from a camera matrix k (row-major 3 × 3) and distortion d as the formats hold them.
camera::Camera PixelOpenCV(int w, int h, double pitch, const std::vector<double>& k, const std::vector<double>& d);
camera::Camera PixelKB(int w, int h, double pitch, const std::vector<double>& k, const std::vector<double>& d);
std::vector<double> CheckCameraMatrix(const std::vector<double>& k, const std::string& where);
// OpenCV's distortion vector: 4, 5, 8, or 12/14 with zero thin-prism and tilt terms.
std::vector<double> CheckOpenCVDistortion(const std::vector<double>& d, const std::string& where);

// A camera as a format holds it, and whether that took a refit.
struct Fitted {
  camera::Camera cam;
  bool exact = true;
  camera::ConversionFit fit;
};
// The camera as an opencv camera whose distortion the first `n_dist` coefficients hold (4: k1 k2 p1
// p2; 5: + k3; 8: + k4 k5 k6): exact when it already is, else refit over the image.
Fitted AsOpenCV(const camera::Camera& c, int n_dist, const std::string& field);
// Kannala–Brandt (cv::fisheye, Kalibr's equi, ROS's equidistant): exact from kannala-brandt and
// equidistant; nullopt for other models.
std::optional<camera::Camera> AsKB(const camera::Camera& c, const std::string& field);
// The fewest of 4, 5, 8 OpenCV coefficients that hold an opencv camera exactly.
int OpenCVCount(const camera::Camera& c);
std::vector<double> KMatrix(const camera::Camera& c);
// The first n distortion coefficients of an opencv or kannala-brandt camera.
std::vector<double> Coefficients(const camera::Camera& c, int n);

void RequireNoPort(const RigFile& rig, RigFormat format, const std::string& field);
void RequirePair(const RigFile& rig, RigFormat format, const std::string& field);
// R, T of the pair: x2 = R·x1 + T (mm), from the cameras' cam_from_rig.
std::pair<Eigen::Matrix3d, Eigen::Vector3d> Relative(const RigFileCamera& a, const RigFileCamera& b);
RigFileCamera Camera1(const std::string& name, const camera::Camera& cam);
RigFile PairRig(const camera::Camera& c1, const camera::Camera& c2, const Eigen::Matrix3d& r,
                const Eigen::Vector3d& t_mm, const std::string& n1, const std::string& n2);

// OpenCV stereo and VIAME npz: the pair as two opencv cameras (refit where they are not).
struct PairCameras {
  Fitted first, second;
};
PairCameras OpenCVPair(const RigFile& rig, RigFormat format, const std::string& field);
// The unit of an unstated T: the file's T_unit, else the option, else refused.
double TUnitMm(const YNode* stated, const RigReadOptions& o, const std::string& where, RigFile* rig);

}  // namespace porthole::interop::detail
