// 3-D points and lengths through a calibrated rig, with propagated σ (issue 27).
//
// Each image point becomes its exact ray in the water (the backward trace: the lens model's
// Unproject, then the Snell trace out through the camera's port, refraction::TraceOut; no central
// approximation), in the rig frame (rig_model.h). The point is the first-order maximum-likelihood
// intersection of the rays under isotropic image noise: with P_i(u, v, s) = o_i(u, v) + s·d_i(u, v)
// the point at range s along ray i of pixel (u, v), J_i = the first two rows of (∂P_i/∂(u, v, s))⁻¹
// is ∂(pixel)/∂X at the point, and X minimises Σ|J_i·(X − o_i)|² (J_i·d_i = 0), re-evaluated at the
// ranges of the last estimate. With noise-free pixels the rays meet and X is exact.
//
// Uncertainty, first order:
//  - image noise σ_px on every coordinate: Cov_img = σ_px²·H⁻¹, H = Σ J_iᵀJ_i;
//  - the calibration: X moves with the rays, ∂X/∂θ = H⁻¹ Σ J_iᵀJ_i ∂P_i/∂θ (each camera's
//    intrinsics, port and cam_from_rig, by automatic differentiation through the trace), and
//    Cov_cal = (∂X/∂θ)·Σ_θ·(∂X/∂θ)ᵀ with the rig's joint covariance Σ_θ. Two points measured with the
//    same calibration share this error: a length's σ propagates both points' ∂X/∂θ together.
// Consistency: chi2 = Σ|J_i(X − o_i)|²/σ_px² with 2n − 3 degrees of freedom; a point whose p-value is
// below TriangulateOptions::mismatch_p is flagged (rays that do not meet: points matched wrongly).
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "porthole/measure/rig_model.h"

namespace porthole::measure {

// One camera's image of a point: camera index in the rig, pixel (0, 0 = centre of the top-left pixel).
struct Observation {
  int camera = 0;
  Eigen::Vector2d pixel_px = Eigen::Vector2d::Zero();
};

// A ray in the water (or air for a camera without a port), rig frame, mm; direction unit.
struct Ray {
  Eigen::Vector3d origin_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();
};

// The ray of `pixel` of camera `c`; nullopt where the lens cannot unproject it or the ray does not
// get out through the port (beyond a dome's rim, total internal reflection).
std::optional<Ray> BackwardRay(const RigCamera& c, const Eigen::Vector2d& pixel_px);

// The pixel of a point in the rig frame (mm) seen by camera `c`: the exact forward projection through
// its port (refraction::Project), or the lens model's Project without one; nullopt where it does not
// project (behind the camera, beyond the port's rim). Not checked against the image's bounds.
std::optional<Eigen::Vector2d> ProjectPoint(const RigCamera& c, const Eigen::Vector3d& x_rig_mm);
// True when `pixel_px` lies in camera c's image (centres of the edge pixels included).
bool InImage(const RigCamera& c, const Eigen::Vector2d& pixel_px);

struct TriangulateOptions {
  double sigma_px = 0.3;              // image-point σ per coordinate (px), > 0
  bool calibration_sigma = true;      // add the rig calibration's uncertainty (∂X/∂θ)
  double mismatch_p = 1e-3;           // chi2 p-value below which the rays are said not to meet
};

struct Point {
  bool ok = false;
  std::string why;  // when !ok: which camera's ray failed, rays parallel, behind a camera
  Eigen::Vector3d x_mm = Eigen::Vector3d::Zero();  // rig frame
  Eigen::Matrix3d covariance_image_mm2 = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d covariance_mm2 = Eigen::Matrix3d::Zero();  // image + calibration
  Eigen::MatrixXd d_x_d_theta;          // 3 × (rig parameters): ∂X/∂θ (empty without calibration_sigma)
  std::vector<double> residual_px;      // per observation |J_i(X − o_i)|
  std::vector<double> range_mm;         // per observation: distance along its ray
  double miss_mm = 0;                   // the largest distance of X from one of its rays
  double chi2 = 0;
  int dof = 0;
  double p_value = 1;
  bool mismatched = false;
};

// Triangulates from two or more observations; a point that cannot be triangulated comes back with
// ok = false and why (never an exception for the data; InvalidInput for a camera index outside the rig).
Point Triangulate(const Rig& rig, const std::vector<Observation>& obs, const TriangulateOptions& options);

// Triangulate for each set of observations, over `num_threads` threads (0: the machine's cores);
// results in the input's order.
std::vector<Point> TriangulateMany(const Rig& rig, const std::vector<std::vector<Observation>>& points,
                                   const TriangulateOptions& options, int num_threads = 0);

// A plane known in a camera's frame (a seafloor, a wall, or the range a laser pair gives):
// normal · x = distance_mm, the normal a unit vector, x in that camera's frame (mm).
struct Plane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  double distance_mm = 0;
  double sigma_mm = 0;  // σ of distance_mm (0: known exactly)
  // The row of Rig::covariance that holds distance_mm's variance (−1: none). The plane's error is
  // common to every point measured on it (a length scales with it), so it is propagated as a
  // parameter, not as noise: Measure appends the row.
  int covariance_index = -1;
};

// The point where the ray of `obs` meets `plane` (in the frame of camera obs.camera), in the rig
// frame, with σ: image noise (options.sigma_px), the plane's distance σ, and with calibration_sigma
// the calibration's. ok = false with why when the ray misses the plane (parallel, or behind).
Point IntersectPlane(const Rig& rig, const Observation& obs, const Plane& plane, const TriangulateOptions& options);

// A laser scaler: two beams parallel to camera c's optical axis, `separation_mm` apart, put two dots
// on the subject. The range Z (along the axis, camera frame) at which the exact rays of the two dots'
// pixels are separation_mm apart in the plane z = Z, and its σ from image noise sigma_px on both dots
// (automatic differentiation of Z through the rays). nullopt when no positive range fits. The beams'
// own misalignment is not modelled.
struct LaserRange {
  double range_mm = 0, sigma_mm = 0;
};
std::optional<LaserRange> RangeFromLaserPair(const RigCamera& c, const Eigen::Vector2d& dot_a_px,
                                             const Eigen::Vector2d& dot_b_px, double separation_mm, double sigma_px);

struct Length {
  double length_mm = 0;
  double sigma_mm = 0;              // total
  double sigma_image_mm = 0;        // from the image noise of both points
  double sigma_calibration_mm = 0;  // from the rig calibration (both points' errors together)
};

// |b − a| with σ; a and b triangulated with the same rig (and independent image noise).
Length MeasureLength(const Rig& rig, const Point& a, const Point& b);

}  // namespace porthole::measure
