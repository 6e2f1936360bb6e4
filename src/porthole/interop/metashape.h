// Agisoft Metashape (and PhotoScan) camera calibration XML: the file Tools › Camera Calibration ›
// Export writes and Import reads (docs/interop.md, "Metashape"). Its camera model, as the
// Metashape Professional 1.5 manual, Appendix C "Camera models", gives it:
//
//   frame:   x = X/Z, y = Y/Z
//   fisheye: x0 = X/Z, y0 = Y/Z, r0 = √(x0² + y0²), (x, y) = (x0, y0)·atan(r0)/r0
//   both:    r = √(x² + y²)
//            x' = x(1 + K1r² + K2r⁴ + K3r⁶ + K4r⁸) + (P1(r² + 2x²) + 2P2xy)(1 + P3r² + P4r⁴)
//            y' = y(1 + K1r² + K2r⁴ + K3r⁶ + K4r⁸) + (P2(r² + 2y²) + 2P1xy)(1 + P3r² + P4r⁴)
//            u = w/2 + cx + x'(f + B1) + y'B2,   v = h/2 + cy + y'f
//
// in Metashape's image coordinates, whose top-left pixel centre is (0.5, 0.5) (porthole's is
// (0, 0)): cx, cy are offsets from the image centre, and P1 multiplies (r² + 2x²) in x where
// OpenCV's p2 does (Metashape's P1, P2 are OpenCV's p2, p1). Old PhotoScan files give fx, fy, the
// principal point cx, cy from the image corner and skew instead: u = cx + x'fx + y'skew,
// v = cy + y'fy, i.e. f = fy, B1 = fx − fy, B2 = skew, and cx, cy less w/2, h/2.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <optional>
#include <string>
#include <string_view>

#include "porthole/camera/brown.h"
#include "porthole/camera/scalar.h"

namespace porthole::interop {

// Metashape's parameters in porthole's fixed order (the XML element names).
enum MetashapeIndex : int { kMsF = 0, kMsCx, kMsCy, kMsB1, kMsB2, kMsK1, kMsK2, kMsK3, kMsK4, kMsP1, kMsP2, kMsP3, kMsP4 };
inline constexpr int kMetashapeNumParams = 13;
inline constexpr std::array<std::string_view, kMetashapeNumParams> kMetashapeNames = {
    "f", "cx", "cy", "b1", "b2", "k1", "k2", "k3", "k4", "p1", "p2", "p3", "p4"};

struct MetashapeCalibration {
  bool fisheye = false;  // <projection>fisheye</projection>, else frame
  int width_px = 0, height_px = 0;
  std::array<double, kMetashapeNumParams> params{};  // in MetashapeIndex order; absent = 0
  std::array<bool, kMetashapeNumParams> present{};   // the element was in the file
  bool photoscan_form = false;  // read from fx, fy, absolute cx, cy, skew
  // <covariance>: <params> names the parameters, <coeffs> the row-major matrix. n×n in
  // MetashapeIndex order, 0 outside the named parameters; empty when the file has none.
  Eigen::MatrixXd covariance;
};

// Metashape's projection as a projector (interop/refit.h), in porthole pixels (top-left pixel
// centre (0, 0): Metashape's u, v less 0.5). Frame: nullopt for Z ≤ 0.
struct MetashapeProjector {
  static constexpr int kNumParams = kMetashapeNumParams;
  bool fisheye = false;
  int width_px = 0, height_px = 0;

  template <typename T>
  std::optional<camera::Vec2<T>> operator()(const T* p, const camera::Vec3<T>& X) const {
    using std::atan;
    using std::sqrt;
    if (!(camera::ScalarValue(X(2)) > 0)) return std::nullopt;
    T x = X(0) / X(2), y = X(1) / X(2);
    if (fisheye) {
      const T r0sq = x * x + y * y;
      // atan(r0)/r0, and its series near the axis (r0 = 0 has no derivative of √).
      const T s = camera::ScalarValue(r0sq) < 1e-16 ? T(1) - r0sq / T(3)
                                                    : atan(sqrt(r0sq)) / sqrt(r0sq);
      x = x * s;
      y = y * s;
    }
    const T r2 = x * x + y * y;
    const T radial =
        T(1) + r2 * (p[kMsK1] + r2 * (p[kMsK2] + r2 * (p[kMsK3] + r2 * p[kMsK4])));
    const T tang = T(1) + r2 * (p[kMsP3] + r2 * p[kMsP4]);
    const T xd = x * radial + (p[kMsP1] * (r2 + T(2) * x * x) + T(2) * p[kMsP2] * x * y) * tang;
    const T yd = y * radial + (p[kMsP2] * (r2 + T(2) * y * y) + T(2) * p[kMsP1] * x * y) * tang;
    return camera::Vec2<T>(T(0.5 * width_px - 0.5) + p[kMsCx] + xd * (p[kMsF] + p[kMsB1]) + yd * p[kMsB2],
                           T(0.5 * height_px - 0.5) + p[kMsCy] + yd * p[kMsF]);
  }
};

// Reads the calibration XML (root <calibration>, or the first <calibration> of a larger document
// such as a project's doc.xml, with a <covariance> inside it or beside it). Throws
// InvalidInput("<field>: <element>", rule).
MetashapeCalibration ParseMetashapeXml(std::string_view text, const std::string& field);
// Writes the calibration XML Metashape imports: f, cx, cy, k1–k3, p1, p2 always; b1, b2, k4, p3,
// p4 when non-zero or present; the covariance block when `covariance` is not empty.
std::string MetashapeXml(const MetashapeCalibration& m);

}  // namespace porthole::interop
