// OpenCV's pinhole + (k1, k2, p1, p2, k3) distortion model, in pixels, and the conversions between
// it and the Brown–Conrady model of docs/conventions.md.
//
// OpenCV is a FORWARD model: on normalised camera coordinates x = X/Z, y = Y/Z (Y down),
// r² = x² + y²,
//     x_d = x(1 + k1 r² + k2 r⁴ + k3 r⁶) + 2 p1 x y + p2 (r² + 2x²)
//     y_d = y(1 + k1 r² + k2 r⁴ + k3 r⁶) + p1 (r² + 2y²) + 2 p2 x y
//     u = fx x_d + cx,   v = fy y_d + cy        (pixels, (0,0) = centre of the top-left pixel)
// so a barrel lens has k1 < 0, whereas Brown (a correction of measured points) has K1 > 0.
#pragma once

#include <optional>

#include "porthole/camera/brown.h"
#include "porthole/camera/sensor.h"

namespace porthole::camera {

// Parameter ordering of a `const T* params` OpenCV array.
enum OpenCVIndex : int {
  kCvFx = 0,  // px
  kCvFy,      // px
  kCvCx,      // px
  kCvCy,      // px
  kCvK1,      // dimensionless (normalised coordinates)
  kCvK2,
  kCvP1,
  kCvP2,
  kCvK3,
  kOpenCVNumParams
};

struct OpenCVParams {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0, k3 = 0;

  std::array<double, kOpenCVNumParams> ToArray() const {
    return {fx, fy, cx, cy, k1, k2, p1, p2, k3};
  }
  static OpenCVParams FromArray(const double* p) {
    return {p[kCvFx], p[kCvFy], p[kCvCx], p[kCvCy], p[kCvK1],
            p[kCvK2], p[kCvP1], p[kCvP2], p[kCvK3]};
  }
};

// Forward distortion on normalised coordinates (x, y) = (X/Z, Y/Z) → (x_d, y_d).
template <typename T>
Vec2<T> OpenCVDistortNormalized(const T* p, const T& x, const T& y) {
  const T r2 = x * x + y * y;
  const T radial = T(1) + r2 * (p[kCvK1] + r2 * (p[kCvK2] + r2 * p[kCvK3]));
  const T xy = x * y;
  return Vec2<T>(x * radial + T(2) * p[kCvP1] * xy + p[kCvP2] * (r2 + T(2) * x * x),
                 y * radial + p[kCvP1] * (r2 + T(2) * y * y) + T(2) * p[kCvP2] * xy);
}

// Point in the camera frame (mm; X right, Y down, Z forward) → pixel (u, v). nullopt if Z ≤ 0.
template <typename T>
std::optional<Vec2<T>> OpenCVProject(const T* p, const Vec3<T>& point_in_cam) {
  if (!(ScalarValue(point_in_cam(2)) > 0)) return std::nullopt;
  const Vec2<T> d = OpenCVDistortNormalized(p, point_in_cam(0) / point_in_cam(2),
                                            point_in_cam(1) / point_in_cam(2));
  return Vec2<T>(p[kCvFx] * d(0) + p[kCvCx], p[kCvFy] * d(1) + p[kCvCy]);
}

// Pixel (u, v) → undistorted normalised coordinates (X/Z, Y/Z), by Newton iteration on the forward
// model (to 1e-14 in normalised units). nullopt if it does not converge.
std::optional<Eigen::Vector2d> OpenCVUnprojectNormalized(const OpenCVParams& p, double u, double v);

// Options for both conversions.
struct CameraConversionOptions {
  int grid_cols = 40;        // image points along u, spanning pixel centres 0 … W−1 (≥ 3)
  int grid_rows = 30;        // image points along v, spanning pixel centres 0 … H−1 (≥ 3)
  bool fit_k3 = true;        // Brown→OpenCV: refit k3 (else k3 = 0). OpenCV→Brown: refit K3.
  bool fit_affinity = true;  // OpenCV→Brown: refit B1, B2 (else 0). OpenCV always has fx and fy.
  int max_iterations = 200;  // Ceres iterations per refit stage
};

// Refit quality: the image distance between the two models' measured points for the same ray,
// over the grid, in pixels (RMS of the 2-D distance, and its maximum), over the grid points where
// the target model can project the ray. A strongly distorted lens can leave the refitted
// polynomial non-invertible in the frame corners: those points are counted in num_not_projected
// (and left out of the RMS) rather than making the RMS infinite.
struct ConversionFit {
  double rms_px = 0;
  double max_px = 0;
  int num_points = 0;
  int num_not_projected = 0;
};

struct BrownToOpenCVResult {
  OpenCVParams opencv;   // the refit
  OpenCVParams initial;  // the closed-form starting guess
  ConversionFit fit;
};

struct OpenCVToBrownResult {
  BrownParams brown;    // the refit
  BrownParams initial;  // the closed-form starting guess
  ConversionFit fit;
};

// Closed-form first-order conversions, used as the refit's starting guess:
//   fx = c / (pitch (1 + B1)), fy = c / pitch,
//   cx = (W−1)/2 + x0/pitch,   cy = (H−1)/2 − y0/pitch,
//   k1 = −K1 c², k2 = −K2 c⁴, k3 = −K3 c⁶,   p1 = P2 c,   p2 = −P1 c.
// (y flips between image-mm y-up and camera Y-down; Brown corrects, OpenCV distorts.)
OpenCVParams BrownToOpenCVClosedForm(const BrownParams& brown, const Sensor& sensor);
BrownParams OpenCVToBrownClosedForm(const OpenCVParams& opencv, const Sensor& sensor);

// The closed form, then a Ceres least-squares refit of all OpenCV parameters (k3 optional) over
// the grid: rays from Brown's Unproject of each grid pixel, residual = OpenCV pixel − grid pixel.
// Throws InvalidInput on invalid parameters, sensor or options.
BrownToOpenCVResult BrownToOpenCV(const BrownParams& brown, const Sensor& sensor,
                                  const CameraConversionOptions& options = {});

// The closed form, then a Ceres refit of the Brown parameters (K3, B1/B2 optional) over the grid:
// rays from OpenCV's undistortion of each grid pixel; a first stage minimises the correction-space
// residual (x̄ + Δx − c·X/Z)/pitch, which needs no iteration, and the second the pixel residual
// Project(ray) − grid pixel. Throws InvalidInput on invalid parameters, sensor or options, or if
// the OpenCV model cannot be inverted at a grid point.
OpenCVToBrownResult OpenCVToBrown(const OpenCVParams& opencv, const Sensor& sensor,
                                  const CameraConversionOptions& options = {});

}  // namespace porthole::camera
