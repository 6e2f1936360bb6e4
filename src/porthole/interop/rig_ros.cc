// ROS's camera_info YAML, one file per camera of a stereo pair (rig format ros-camera-info): the
// layout of camera_calibration_parsers (image_width, image_height, camera_name, camera_matrix,
// distortion_model plumb_bob / rational_polynomial / equidistant, distortion_coefficients,
// rectification_matrix, projection_matrix), metres as ROS REP 103 states; the pose goes through the
// stereo rectification as cv::stereoRectify computes it (rig_files.h; docs/interop.md, "Rig files").
#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>

#include "porthole/core/error.h"
#include "porthole/interop/interop.h"
#include "porthole/interop/rig_internal.h"

namespace porthole::interop::detail {
namespace {

using camera::Camera;
using camera::CameraModelId;

// cv::stereoRectify's rotations (calib3d/src/calibration.cpp, cvStereoRectify): half the relative
// rotation to each camera, then the rotation taking the baseline onto the x (or y) axis.
std::pair<Eigen::Matrix3d, Eigen::Matrix3d> RectifyRotations(const Eigen::Matrix3d& r, const Eigen::Vector3d& t) {
  const Eigen::Matrix3d r_r = FromRotationVector(-0.5 * RotationVector(r));
  const Eigen::Vector3d tt = r_r * t;
  const int idx = std::abs(tt(0)) > std::abs(tt(1)) ? 0 : 1;
  const double c = tt(idx), nt = tt.norm();
  Eigen::Vector3d uu = Eigen::Vector3d::Zero();
  uu(idx) = c > 0 ? 1 : -1;
  Eigen::Vector3d ww = tt.cross(uu);
  const double nw = ww.norm();
  if (nw > 0) ww *= std::acos(std::abs(c) / nt) / nw;
  const Eigen::Matrix3d wr = FromRotationVector(ww);
  return {wr * r_r.transpose(), wr * r_r};
}

struct RosCamera {
  Fitted fit;
  std::string model;  // plumb_bob, rational_polynomial, equidistant
  std::vector<double> d;
};
RosCamera ToRos(const Camera& c, const std::string& field) {
  if (const auto kb = AsKB(c, field)) return {{*kb, true, {}}, "equidistant", Coefficients(*kb, 4)};
  const int n = c.model == CameraModelId::kOpenCV && OpenCVCount(c) == 8 ? 8 : 5;
  if (c.model != CameraModelId::kOpenCV && c.model != CameraModelId::kBrown) {
    ConvertCalibration(WithoutSigma(c, ""), CameraModelId::kOpenCV, field);  // throws its line
  }
  RosCamera r{AsOpenCV(c, n, field), n == 8 ? "rational_polynomial" : "plumb_bob", {}};
  r.d = Coefficients(r.fit.cam, n);
  return r;
}

std::string RosText(const std::string& name, const Camera& cam, const std::string& model, const std::vector<double>& d,
                    const Eigen::Matrix3d& rect, const std::vector<double>& p) {
  Eigen::Matrix3d rt = rect.transpose();
  const auto m = [](std::string_view key, int rows, int cols, const std::vector<double>& v) {
    return fmt::format("{}:\n  rows: {}\n  cols: {}\n  data: [{}]\n", key, rows, cols, NumList(v));
  };
  std::string clean = name.substr(0, 200);
  for (char& ch : clean) {
    if (static_cast<unsigned char>(ch) < 0x20 || ch == 0x7f) ch = '_';  // one line
  }
  std::string quoted = clean;
  if (clean.find_first_of(":#'\"[]{},&*!|>%@`\\ -?") != std::string::npos || clean.empty()) {
    quoted = "\"";
    for (char ch : clean) {
      if (ch == '"' || ch == '\\') quoted += '\\';
      quoted += ch;
    }
    quoted += "\"";
  }
  return fmt::format("image_width: {}\nimage_height: {}\ncamera_name: {}\n{}distortion_model: {}\n{}{}{}", cam.sensor.width_px,
                     cam.sensor.height_px, quoted, m("camera_matrix", 3, 3, KMatrix(cam)), model,
                     m("distortion_coefficients", 1, static_cast<int>(d.size()), d),
                     m("rectification_matrix", 3, 3, std::vector<double>(rt.data(), rt.data() + 9)),
                     m("projection_matrix", 3, 4, p));
}

std::vector<std::pair<std::string, std::string>> WriteRos(const RigFile& rig, const std::string& field,
                                                          std::vector<RigWriteCamera>* info) {
  RequirePair(rig, RigFormat::kRosCameraInfo, field);
  RequireNoPort(rig, RigFormat::kRosCameraInfo, field);
  if (rig.cameras[0].name == rig.cameras[1].name) {
    throw InvalidInput(field, "both cameras are called " + rig.cameras[0].name + ": ROS's files are named after them");
  }
  const RosCamera a = ToRos(rig.cameras[0].calibration.camera, field + ": camera " + rig.cameras[0].name);
  const RosCamera b = ToRos(rig.cameras[1].calibration.camera, field + ": camera " + rig.cameras[1].name);
  const auto [r, t_mm] = Relative(rig.cameras[0], rig.cameras[1]);
  const Eigen::Vector3d t = t_mm / 1000;  // metres (REP 103)
  const auto [r1, r2] = RectifyRotations(r, t);
  const auto& pa = a.fit.cam.params;
  const auto& pb = b.fit.cam.params;
  const double f = 0.25 * (pa[0] + pa[1] + pb[0] + pb[1]);
  const double cx = 0.5 * (pa[2] + pb[2]), cy = 0.5 * (pa[3] + pb[3]);
  const Eigen::Vector3d t2 = r2 * t;  // camera 1's centre seen from camera 2, rectified frame
  const std::vector<double> p1{f, 0, cx, 0, 0, f, cy, 0, 0, 0, 1, 0};
  const std::vector<double> p2{f, 0, cx, f * t2(0), 0, f, cy, f * t2(1), 0, 0, 1, 0};
  // File names from the camera names, kept to [A-Za-z0-9._-] (a name is never a path).
  const auto file_name = [](const std::string& name) {
    std::string f = name.substr(0, 100);
    for (char& ch : f) {
      if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '.' && ch != '_' && ch != '-') ch = '_';
    }
    if (f.empty() || f[0] == '.') f = "camera_" + f;
    return f + ".yaml";
  };
  if (file_name(rig.cameras[0].name) == file_name(rig.cameras[1].name)) {
    throw InvalidInput(field, "the cameras' names give one file name (" + file_name(rig.cameras[0].name) + "): rename them");
  }
  std::vector<std::pair<std::string, std::string>> files;
  files.emplace_back(file_name(rig.cameras[0].name), RosText(rig.cameras[0].name, a.fit.cam, a.model, a.d, r1, p1));
  files.emplace_back(file_name(rig.cameras[1].name), RosText(rig.cameras[1].name, b.fit.cam, b.model, b.d, r2, p2));
  info->push_back({rig.cameras[0].name, a.model, a.fit.exact, a.fit.fit});
  info->push_back({rig.cameras[1].name, b.model, b.fit.exact, b.fit.fit});
  return files;
}

struct RosRead {
  std::string name;
  Camera cam;
  Eigen::Matrix3d rect;
  std::vector<double> p;
};
RosRead ReadRosOne(const std::string& text, double pitch, const std::string& field) {
  const YNode root = ParseYaml(text, field);
  if (root.kind != YNode::kMap) throw InvalidInput(field, "not a ROS camera_info YAML");
  RosRead r;
  const YNode* name = root.Get("camera_name");
  r.name = name != nullptr && name->kind == YNode::kScalar ? name->scalar : "";
  const int w = Pixels(Need(root, "image_width", field), field + ": image_width");
  const int h = Pixels(Need(root, "image_height", field), field + ": image_height");
  const auto k = CheckCameraMatrix(Matrix(Need(root, "camera_matrix", field), 9, field + ": camera_matrix"),
                                   field + ": camera_matrix");
  const auto d = Matrix(Need(root, "distortion_coefficients", field), 0, field + ": distortion_coefficients");
  const YNode* dm = root.Get("distortion_model");
  const std::string model = dm != nullptr && dm->kind == YNode::kScalar ? dm->scalar : "plumb_bob";
  if (model == "equidistant" || model == "fisheye") {
    if (d.size() != 4) throw InvalidInput(field + ": distortion_coefficients", fmt::format("{} holds 4 (k1-k4), not {}", model, d.size()));
    r.cam = PixelKB(w, h, pitch, k, d);
  } else if (model == "plumb_bob" || model == "rational_polynomial") {
    if (d.size() > 8 && std::any_of(d.begin() + 8, d.end(), [](double x) { return x != 0; })) {
      throw InvalidInput(field + ": distortion_coefficients", "more than 8 non-zero coefficients (porthole's opencv model has k1-k6, p1, p2)");
    }
    r.cam = PixelOpenCV(w, h, pitch, k, d);
  } else {
    throw InvalidInput(field + ": distortion_model",
                       "'" + model.substr(0, 40) + "' is not read (plumb_bob, rational_polynomial, equidistant)");
  }
  r.rect = Rotation(Matrix(Need(root, "rectification_matrix", field), 9, field + ": rectification_matrix"),
                    field + ": rectification_matrix");
  r.p = Matrix(Need(root, "projection_matrix", field), 12, field + ": projection_matrix");
  if (!(r.p[0] > 0 && r.p[5] > 0)) throw InvalidInput(field + ": projection_matrix", "fx' and fy' must be > 0");
  return r;
}

RigFile ReadRos(const std::vector<std::string>& contents, const std::vector<std::string>& names, const RigReadOptions& o,
                const std::string& field) {
  if (contents.size() != 2) {
    throw InvalidInput(field, fmt::format("ROS camera_info: give one file per camera of a stereo pair (2), not {}", contents.size()));
  }
  std::vector<RosRead> cams;
  for (std::size_t i = 0; i < 2; ++i) cams.push_back(ReadRosOne(contents[i], o.pixel_pitch_mm, field + " '" + names[i] + "'"));
  const auto& p2 = cams[1].p;
  if (std::abs(cams[0].p[3]) > 0 || std::abs(cams[0].p[7]) > 0) {
    throw InvalidInput(field + " '" + names[0] + "': projection_matrix",
                       "the first camera's P has a translation: give the files in the pair's order (left, right)");
  }
  if (p2[3] == 0 && p2[7] == 0) {
    throw InvalidInput(field + " '" + names[1] + "': projection_matrix",
                       "Tx = Ty = 0: not a stereo pair's second camera (camera_info holds the pose only through the stereo "
                       "rectification)");
  }
  const Eigen::Vector3d t_rect(p2[3] / p2[0], p2[7] / p2[5], 0);  // metres
  const Eigen::Matrix3d r = cams[1].rect.transpose() * cams[0].rect;
  const Eigen::Vector3d t = cams[1].rect.transpose() * t_rect * 1000;
  RigFile rig = PairRig(cams[0].cam, cams[1].cam, r, t,
                        cams[0].name.empty() ? std::filesystem::path(names[0]).stem().string() : cams[0].name,
                        cams[1].name.empty() ? std::filesystem::path(names[1]).stem().string() : cams[1].name);
  rig.format = RigFormat::kRosCameraInfo;
  rig.length_unit_note = "metres (ROS REP 103)";
  return rig;
}

}  // namespace

RigFile ReadRosFile(const std::vector<std::string>& contents, const std::vector<std::string>& names,
                    RigFormat /*format*/, const RigReadOptions& options, const std::string& field) {
  return ReadRos(contents, names, options, field);
}

RigFiles WriteRosFile(const RigFile& rig, RigFormat /*format*/, const std::string& field,
                      std::vector<RigWriteCamera>* info) {
  return WriteRos(rig, field, info);
}

}  // namespace porthole::interop::detail
