// Undistortion to a virtual pinhole camera (issue 28, docs/undistort.md): the pinhole's intrinsics
// chosen for a calibration, the remapping table from it to the calibrated image, the remap itself,
// and for a camera behind a port the residual error of the pinhole against depth.
//
// A calibration is a measure::RigCamera: a lens model alone (central: every format interop reads)
// or a lens behind its port (refractive: porthole's `calibrate --port` JSON). Frames and pixels
// follow docs/conventions.md: camera frame at the entrance pupil (X right, Y down, Z forward, mm),
// pixel (0, 0) the centre of the top-left pixel.
//
// The pinhole (Pinhole): fx, fy, cx, cy on an output image of width × height, its centre at
// `centre_mm` in the camera frame (the entrance pupil for a central camera; for a refractive one
// the point on the axis that best fits the port's rays over the working distances, FitCentre). Its
// image of a point X is (fx·x + cx, fy·y + cy), (x, y) = (X − C)_xy / (X − C)_z.
//
// The map (Map): for output pixel q the source pixel m(q) the pinhole's ray of q comes from.
//  - central: m(q) = Project(ray of q), the lens model's exact forward projection (the exact
//  inverse
//    of the undistortion: no lookup, no iteration beyond the model's own);
//  - refractive: the pinhole's ray of q meets the depths Z_k of the working distances; m(q) is the
//    mean over k of the exact refractive projection (lens + port) of those points.
//
// The residual at depth Z (refractive; docs/undistort.md "Residual"): a point X at depth Z images
// at source pixel s = P(X) through the exact model; after the remap it sits at the output pixel q'
// with m(q') = s; the pinhole puts it at q = π(X). residual = q' − q, in output pixels. Depths Z
// are working distances: from the port's outer vertex (where the backward ray of the principal
// point leaves the port) along the axis, in water, mm; in the camera frame z = Z + vertex_z_mm. A
// central camera has no port: its working distances are z itself.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "porthole/measure/rig_model.h"

namespace porthole::undistort {

enum class Interpolation { kNearest, kLinear, kCubic, kLanczos };
// "nearest", "linear", "cubic", "lanczos"; throws InvalidInput(field, "… (known: …)").
Interpolation InterpolationFromName(std::string_view name, const std::string& field);
std::string_view InterpolationName(Interpolation i);

struct UndistortOptions {
  // The output field, as cv2.getOptimalNewCameraMatrix's alpha: 0 keeps only valid pixels (no
  // black border, the largest rectangle inside the undistorted frame), 1 keeps every source pixel
  // (the bounding box of the undistorted frame). The output has the input's size. Default 0.
  std::optional<double> alpha;
  // Instead: the input's size and focal length (fx = fy = the lens's, the principal point where the
  // axis images); corners may be cut or black.
  bool keep_focal = false;
  // Refractive only (required there, refused for a central camera): the working distance(s) in
  // water, mm from the port's outer vertex: one value, or {near, far}.
  std::vector<double> wd_mm;
  Interpolation interpolation = Interpolation::kLinear;
  int threads = 0;  // 0: every core
};
// Throws InvalidInput naming the field (alpha, keep_focal, wd_mm, threads) for `camera`.
void Validate(const UndistortOptions& o, const measure::RigCamera& camera);

struct Pinhole {
  int width_px = 0, height_px = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;                // porthole pixels
  Eigen::Vector3d centre_mm = Eigen::Vector3d::Zero();  // projection centre in the camera frame
  Eigen::Vector2d Project(const Eigen::Vector3d& x_cam) const;
  Eigen::Vector3d Ray(const Eigen::Vector2d& q) const;  // direction with z = 1
};

// The depths of the refractive map (camera-frame z, mm) for working distances wd_mm: one value, or
// five from near to far evenly spaced in inverse depth.
std::vector<double> MapDepthsZ(const std::vector<double>& wd_mm, double vertex_z_mm);

// Everything undistortion needs for one calibration, built once.
struct Undistorter {
  measure::RigCamera camera;
  bool refractive = false;
  double vertex_z_mm = 0;           // refractive: the port's outer vertex (camera frame z)
  std::vector<double> depths_z_mm;  // refractive: the map's depths (camera frame z)
  Pinhole pinhole;
  UndistortOptions options;
  // Refractive: the pinhole's parallax over the fit depths (RMS over the frame of f·|n_k − n̄|, to
  // first order the residual) with the fitted centre, and with the centre left at the entrance
  // pupil.
  double centre_fit_rms_px = 0;
  double centre_at_pupil_rms_px = 0;

  // m(q) exactly (no table); nullopt where a projection fails.
  std::optional<Eigen::Vector2d> SourcePixel(const Eigen::Vector2d& q) const;
  // The output pixel q' with m(q') = s (Newton on m from `start`); nullopt without convergence.
  std::optional<Eigen::Vector2d> OutputPixel(const Eigen::Vector2d& s,
                                             const Eigen::Vector2d& start) const;
  // Refractive residual q' − q of a point in the camera frame (mm); nullopt where it does not
  // image.
  std::optional<Eigen::Vector2d> Residual(const Eigen::Vector3d& x_cam) const;
};

// Chooses the pinhole and (refractive) its centre. Throws InvalidInput (Validate's fields).
Undistorter Prepare(const measure::RigCamera& camera, const UndistortOptions& options);

// The remapping table: CV_32FC2, output size, source pixel per output pixel (−1, −1 where there is
// none). Central: m(q) at every pixel; refractive: m(q) exact on a grid every `grid_step_px`
// pixels, bicubic in between (the grid step's error is measured in undistort_test).
cv::Mat BuildMap(const Undistorter& u, int grid_step_px = 8);

// The remap of one image (8 or 16 bit or float, 1–4 channels); pixels without source are 0.
// Linear and nearest: porthole's own loop with the map's exact fractions, on `threads` threads (0:
// every core); cubic and lanczos: cv::remap (its fractions quantised to 1/32 px).
cv::Mat Remap(const cv::Mat& image, const cv::Mat& map, Interpolation interpolation,
              int threads = 0);
// The same into *out, reusing its memory when it already has the size and type (a fresh 72 MB
// buffer per image costs its page faults: a third of the time on a 24-megapixel RGB image).
void Remap(const cv::Mat& image, const cv::Mat& map, Interpolation interpolation, cv::Mat* out,
           int threads = 0);

// ---- Residual maps (refractive) ----
struct ResidualMap {
  double wd_mm = 0;
  int cols = 0, rows = 0;             // grid over the output frame
  std::vector<Eigen::Vector2d> q_px;  // grid points (row by row)
  std::vector<double> error_px;       // |residual|, NaN where the point does not image
  double rms_px = 0, max_px = 0, median_px = 0;
};
std::vector<ResidualMap> ResidualMaps(const Undistorter& u,
                                      const std::vector<double>& wd_mm = {500, 1000, 2000, 5000},
                                      int cols = 33, int rows = 23);
nlohmann::ordered_json ResidualJson(const std::vector<ResidualMap>& maps);
// gnuplot data and script for one PNG of the maps (heat maps, one panel per depth).
std::string ResidualData(const std::vector<ResidualMap>& maps);
std::string ResidualScript(const std::vector<ResidualMap>& maps, const std::string& data_file,
                           const std::string& png_file);

// ---- The pinhole for other tools ----
// The pinhole as a porthole camera (opencv model, zero distortion) on the output image; the source
// sensor's pixel pitch kept.
camera::Camera PinholeCamera(const Undistorter& u);
// COLMAP cameras.txt (one PINHOLE camera, id 1; principal point shifted by COLMAP's 0.5 px).
std::string ColmapCamerasText(const Undistorter& u);
// nerfstudio transforms.json: camera_model OPENCV, fl_x, fl_y, cx, cy (COLMAP's pixel convention,
// as ns-process-data writes them), w, h, k1 k2 p1 p2 = 0, and frames[] with file_path only (no pose
// is known: docs/undistort.md).
nlohmann::ordered_json NerfstudioTransforms(const Undistorter& u,
                                            const std::vector<std::string>& file_paths);
// A summary: source, pinhole, options, the centre fit (undistort.json).
nlohmann::ordered_json SummaryJson(const Undistorter& u);

// ---- Images ----
// The encoded bytes of `image` in the format of `path`'s extension (png, jpg/jpeg, tif/tiff),
// depth kept (JPEG: 8 bit only). Throws InvalidInput(field, …).
std::string EncodeLike(const cv::Mat& image, const std::string& path, const std::string& field);
// Reads an image with its depth and channels (IMREAD_UNCHANGED). Throws InvalidInput(field, …).
cv::Mat ReadImage(const std::string& path, const std::string& field);

}  // namespace porthole::undistort
