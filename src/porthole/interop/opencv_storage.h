// OpenCV FileStorage calibration files, YAML and XML (docs/interop.md, "OpenCV FileStorage"): the
// camera matrix and distortion coefficients of cv::calibrateCamera (the pinhole model: 4, 5, 8, 12
// or 14 coefficients, cv::projectPoints' order) or of cv::fisheye::calibrate (Kannala–Brandt: k1–k4),
// with the image size.
//
//   keys read (the first present): camera_matrix | cameraMatrix | K;
//     distortion_coefficients | distCoeffs | dist_coeffs | D; image_size | imageSize (a cv::Size or a
//     2-vector), else image_width and image_height.
//   model: fisheye when `fisheye_model` is not 0 (OpenCV's camera_calibration sample writes it) or
//     `distortion_model` is fisheye or equidistant (ROS camera_info); pinhole when fisheye_model is
//     0 or distortion_model is plumb_bob or rational_polynomial; with neither, fisheye exactly when
//     the file names them K and D (cv::fisheye's names) and D has 4 coefficients.
//   written: the layout of OpenCV's camera_calibration sample — image_width, image_height,
//     fisheye_model (1 for a fisheye), camera_matrix, distortion_coefficients (the smallest of 4, 5,
//     8 entries that holds the camera exactly; 4 for a fisheye) — as !!opencv-matrix / type_id
//     "opencv-matrix" nodes with dt d and 17 significant digits.
//
// Untrusted input: YAML is scanned linearly for these keys (nothing recurses); XML goes through the
// bounded Expat reader (interop/xml.h: no DOCTYPE or entities, nesting ≤ 32, ≤ 100 000 elements).
// Errors are InvalidInput("<field>: <key>", rule).
#pragma once

#include <array>
#include <string>
#include <string_view>
#include <vector>

namespace porthole::interop {

struct OpenCVStorageCalibration {
  std::array<double, 9> camera_matrix{};  // row-major [fx 0 cx; 0 fy cy; 0 0 1], pixels
  std::vector<double> distortion;         // pinhole: k1 k2 p1 p2 [k3 [k4 k5 k6 [s1–s4 [τx τy]]]];
                                          // fisheye: k1 k2 k3 k4
  int width_px = 0, height_px = 0;
  bool fisheye = false;
};

// Reads a FileStorage calibration (`xml`: the XML form, else YAML). Thin-prism and tilt terms must
// be 0 (porthole's opencv model has none); skew must be 0.
OpenCVStorageCalibration ParseOpenCVStorage(std::string_view text, bool xml, const std::string& field);
// Writes it (what cv::FileStorage reads), with `comment` as a YAML/XML comment.
std::string OpenCVStorageText(const OpenCVStorageCalibration& c, bool xml, std::string_view comment);

// A stereo pair as cv::stereoCalibrate returns it and cv::stereoRectify takes it: K1 D1 K2 D2 (the
// camera matrices and distortion of each camera, as above), R (3 × 3, row-major) and T (mm) taking
// camera 1's frame into camera 2's (x2 = R·x1 + T), and the image size.
struct OpenCVStereo {
  OpenCVStorageCalibration first, second;
  std::array<double, 9> r{};
  std::array<double, 3> t{};
};
// Writes it as a FileStorage file (YAML or XML): image_width, image_height, K1, D1, K2, D2, R, T.
std::string OpenCVStereoText(const OpenCVStereo& s, bool xml, std::string_view comment);

}  // namespace porthole::interop
