// A chessboard rendered through a homography with exact anti-aliasing, for tests and benchmarks of
// detection: the true corner positions are known to machine precision (docs/robustness.md).
// Pixel convention: pixel (u, v) covers [u - 0.5, u + 0.5] x [v - 0.5, v + 0.5] (OpenCV's, porthole's).
#pragma once

#include <Eigen/Dense>
#include <cmath>
#include <opencv2/core.hpp>
#include <vector>

namespace porthole::calib {

struct RenderedBoard {
  cv::Mat gray;                          // 8-bit, white background
  std::vector<cv::Point2d> corners_px;   // inner corners, row-major (OpenCV's order)
};

// cols x rows inner corners, squares of 1 board unit; `image_from_board` maps board units (x right,
// y down, origin at the first inner corner) to pixels. Each pixel is the mean of s x s samples
// (s = supersample), so an edge is shaded by the area it covers, as a camera's pixel would be.
inline RenderedBoard RenderChessboard(int width, int height, int cols, int rows, const Eigen::Matrix3d& image_from_board,
                                      int supersample = 16) {
  RenderedBoard out;
  out.gray = cv::Mat(height, width, CV_8U);
  const Eigen::Matrix3d board_from_image = image_from_board.inverse();
  auto board = [&](double u, double v) {
    const Eigen::Vector3d b = board_from_image * Eigen::Vector3d(u, v, 1);
    return Eigen::Vector2d(b.x() / b.z(), b.y() / b.z());
  };
  auto value = [&](double u, double v) {  // 1 = white
    const Eigen::Vector2d b = board(u, v);
    if (b.x() < -1 || b.y() < -1 || b.x() > cols || b.y() > rows) return 1.0;  // white margin
    const long i = static_cast<long>(std::floor(b.x())), j = static_cast<long>(std::floor(b.y()));
    return ((i + j) & 1) ? 1.0 : 0.0;
  };
  const int s = supersample;
  for (int v = 0; v < height; ++v) {
    auto* row = out.gray.ptr<unsigned char>(v);
    for (int u = 0; u < width; ++u) {
      // A pixel farther than its own size (in board units) from every grid line lies inside one
      // square; the others are the mean of s x s samples.
      const Eigen::Vector2d c = board(u, v);
      const double reach = (board(u + 0.5, v + 0.5) - board(u - 0.5, v - 0.5)).norm() +
                           (board(u + 0.5, v - 0.5) - board(u - 0.5, v + 0.5)).norm();
      const double dx = std::abs(c.x() - std::round(c.x())), dy = std::abs(c.y() - std::round(c.y()));
      double mean = value(u, v);
      if (dx < reach || dy < reach) {
        double sum = 0;
        for (int a = 0; a < s; ++a) {
          for (int b = 0; b < s; ++b) sum += value(u - 0.5 + (a + 0.5) / s, v - 0.5 + (b + 0.5) / s);
        }
        mean = sum / (s * s);
      }
      row[u] = static_cast<unsigned char>(std::lround(30 + 195 * mean));  // black 30, white 225
    }
  }
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const Eigen::Vector3d p = image_from_board * Eigen::Vector3d(c, r, 1);
      out.corners_px.emplace_back(p.x() / p.z(), p.y() / p.z());
    }
  }
  return out;
}

// A board seen obliquely filling much of a width x height image: `square_px` pixels a square near
// the centre, tilted by `tilt` (perspective) and rotated by `angle_rad`.
inline Eigen::Matrix3d ObliqueBoardHomography(int width, int height, int cols, int rows, double square_px,
                                              double angle_rad = 0.12, double tilt = 0.05) {
  Eigen::Matrix3d center_board;  // board centre to origin
  center_board << 1, 0, -(cols - 1) / 2.0, 0, 1, -(rows - 1) / 2.0, 0, 0, 1;
  Eigen::Matrix3d scale_rotate;
  scale_rotate << square_px * std::cos(angle_rad), -square_px * std::sin(angle_rad), 0,
      square_px * std::sin(angle_rad), square_px * std::cos(angle_rad), 0, 0, 0, 1;
  Eigen::Matrix3d perspective;
  perspective << 1, 0, 0, 0, 1, 0, tilt / width, tilt / height, 1;
  Eigen::Matrix3d to_image;
  to_image << 1, 0, (width - 1) / 2.0, 0, 1, (height - 1) / 2.0, 0, 0, 1;
  return to_image * perspective * scale_rotate * center_board;
}

}  // namespace porthole::calib
