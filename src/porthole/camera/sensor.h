// The sensor and the pixel ↔ image-millimetre conversions of docs/conventions.md
// ("Image coordinates"):
//  - Pixels: (0, 0) is the CENTRE of the top-left pixel, u right, v down (OpenCV/mrcal).
//  - Image mm: origin at the sensor centre, x right, y UP:
//        x = (u − (W−1)/2)·pitch,   y = −(v − (H−1)/2)·pitch.
//  - COLMAP puts the top-left pixel centre at (0.5, 0.5); convert only at that boundary with
//    ColmapToPixel / PixelToColmap.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "porthole/camera/brown.h"  // Vec2
#include "porthole/core/error.h"

namespace porthole::camera {

struct Sensor {
  int width_px = 0;           // W, pixels along u
  int height_px = 0;          // H, pixels along v
  double pixel_pitch_mm = 0;  // square pixels, mm
};

// Throws InvalidInput unless W ≥ 1, H ≥ 1 and the pitch is finite and > 0.
inline void ValidateSensor(const Sensor& s) {
  if (s.width_px < 1) throw InvalidInput("width_px", "must be >= 1");
  if (s.height_px < 1) throw InvalidInput("height_px", "must be >= 1");
  RequirePositive("pixel_pitch_mm", s.pixel_pitch_mm);
}

// Pixel (u, v) → image mm (x, y up).
template <typename T>
Vec2<T> PixelToImageMm(const Sensor& s, const T& u, const T& v) {
  const double u_mid = 0.5 * (s.width_px - 1);
  const double v_mid = 0.5 * (s.height_px - 1);
  return Vec2<T>((u - T(u_mid)) * T(s.pixel_pitch_mm), -(v - T(v_mid)) * T(s.pixel_pitch_mm));
}

// Image mm (x, y up) → pixel (u, v).
template <typename T>
Vec2<T> ImageMmToPixel(const Sensor& s, const T& x, const T& y) {
  const double u_mid = 0.5 * (s.width_px - 1);
  const double v_mid = 0.5 * (s.height_px - 1);
  return Vec2<T>(x / T(s.pixel_pitch_mm) + T(u_mid), T(v_mid) - y / T(s.pixel_pitch_mm));
}

// Pixel centres on a cols × rows grid spanning the whole frame, edges and corners included
// (u from 0 to W−1, v from 0 to H−1), row by row from the top-left; cols, rows ≥ 2.
inline std::vector<Eigen::Vector2d> FramePixels(const Sensor& s, int cols, int rows) {
  std::vector<Eigen::Vector2d> px;
  for (int j = 0; j < rows; ++j) {
    for (int i = 0; i < cols; ++i) {
      px.emplace_back(i * (s.width_px - 1.0) / (cols - 1), j * (s.height_px - 1.0) / (rows - 1));
    }
  }
  return px;
}

// COLMAP pixel (top-left pixel centre at (0.5, 0.5)) → porthole pixel (centre at (0, 0)).
inline Eigen::Vector2d ColmapToPixel(const Eigen::Vector2d& uv_colmap) {
  return uv_colmap - Eigen::Vector2d(0.5, 0.5);
}
// porthole pixel → COLMAP pixel.
inline Eigen::Vector2d PixelToColmap(const Eigen::Vector2d& uv) {
  return uv + Eigen::Vector2d(0.5, 0.5);
}

}  // namespace porthole::camera
