// Where the image of a circle has its centre: the centre of the projected conic (what an ellipse
// fit measures) against the projection of the circle's centre (what a point projection predicts).
// They differ under perspective (the "eccentricity" of circular targets; Ahn, Warnecke & Kotowski
// 1999; Luhmann 2014): the image of a circle is an ellipse whose centre is not the image of the
// circle's centre.
#pragma once

#include <Eigen/Dense>
#include <cmath>
#include <numbers>
#include <optional>
#include <vector>

namespace porthole::coded {

// Centre (pixels) of the ellipse that the circle of `radius` about `centre` (plane units) becomes
// under the homography `image_from_plane` (plane → pixels). The dual conic of the circle,
// C* = T diag(r², r², −1) Tᵀ with T the translation to the centre, maps to H C* Hᵀ; the pole of the
// line at infinity, (H C* Hᵀ) e₃, is the ellipse's centre. The plane must lie in front of the
// camera over the whole circle.
template <class T>
Eigen::Matrix<T, 2, 1> ConicCentreOfCircle(const Eigen::Matrix<T, 3, 3>& image_from_plane,
                                           const Eigen::Matrix<T, 2, 1>& centre, T radius) {
  Eigen::Matrix<T, 3, 3> t = Eigen::Matrix<T, 3, 3>::Identity();
  t(0, 2) = centre.x();
  t(1, 2) = centre.y();
  const Eigen::Matrix<T, 3, 1> d(radius * radius, radius * radius, T(-1));
  const Eigen::Matrix<T, 3, 3> h = image_from_plane * t;
  const Eigen::Matrix<T, 3, 1> c = h * d.asDiagonal() * h.row(2).transpose();
  return Eigen::Matrix<T, 2, 1>(c.x() / c.z(), c.y() / c.z());
}

// The eccentricity in closed form for a pinhole camera (focal length f px, principal point at
// the origin): a circle of radius R whose centre is at t (camera frame, mm, Z forward) on a plane
// spanned by the unit vectors r1, r2 (its normal r3 = r1 × r2). With h₃ = (r1z, r2z, tz), the
// ellipse centre is K (tz t − R² (r1z r1 + r2z r2)) and the projected centre K t, so
//   e = f [ (tz t − R² s)_xy / (tz² − R² (r1z² + r2z²)) − t_xy / tz ],   s = r1z r1 + r2z r2,
// where r1z² + r2z² = sin² of the plane's tilt to the image plane. Zero for a plane parallel to
// the image (no tilt); grows as R²/tz² at fixed tilt.
inline Eigen::Vector2d EccentricityPx(double f_px, const Eigen::Matrix3d& cam_from_plane_rotation,
                                      const Eigen::Vector3d& centre_in_cam, double radius) {
  const Eigen::Vector3d r1 = cam_from_plane_rotation.col(0), r2 = cam_from_plane_rotation.col(1);
  const Eigen::Vector3d& t = centre_in_cam;
  const Eigen::Vector3d s = r1.z() * r1 + r2.z() * r2;
  const double den = t.z() * t.z() - radius * radius * (r1.z() * r1.z() + r2.z() * r2.z());
  const Eigen::Vector2d ellipse = (t.z() * t.head<2>() - radius * radius * s.head<2>()) / den;
  return f_px * (ellipse - t.head<2>() / t.z());
}

// Centre of the conic fitted to `points` (pixels) by algebraic least squares (a u² + b uv + c v² +
// d u + e v + f = 0, unit coefficient norm, the points centred and scaled first): the gradient's
// zero. Exact for points on a conic; for a closed curve that is nearly one (a circle imaged
// through distortion or a port), the centre an ellipse-fitting detector measures from edge points
// spread round the curve. nullopt with fewer than 6 points or when the fit is no ellipse.
inline std::optional<Eigen::Vector2d> ConicCentreOfPoints(const std::vector<Eigen::Vector2d>& points) {
  const int n = static_cast<int>(points.size());
  if (n < 6) return std::nullopt;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& p : points) mean += p;
  mean /= n;
  double spread = 0;
  for (const auto& p : points) spread += (p - mean).norm();
  spread /= n;
  if (!(spread > 0)) return std::nullopt;
  Eigen::MatrixXd design(n, 6);
  for (int k = 0; k < n; ++k) {
    const Eigen::Vector2d q = (points[k] - mean) / spread;
    design.row(k) << q.x() * q.x(), q.x() * q.y(), q.y() * q.y(), q.x(), q.y(), 1;
  }
  const Eigen::Matrix<double, 6, 6> ata = design.transpose() * design;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> es(ata);
  const Eigen::Matrix<double, 6, 1> c = es.eigenvectors().col(0);
  Eigen::Matrix2d m;
  m << 2 * c(0), c(1), c(1), 2 * c(2);
  if (!(m.determinant() > 0 || m.determinant() < 0) || 4 * c(0) * c(2) - c(1) * c(1) <= 0) return std::nullopt;
  const Eigen::Vector2d centre = m.inverse() * Eigen::Vector2d(-c(3), -c(4));
  if (!centre.allFinite()) return std::nullopt;
  return Eigen::Vector2d(mean + spread * centre);
}

// What a perfect ellipse-centre detector measures for a circle of `radius` about `centre` in the
// plane spanned by the orthonormal `axis1`, `axis2` (any 3-D frame, the units of `project`'s
// input): the centre of the conic fitted to `n_rim` points of the rim spread evenly round it, each
// imaged by `project` (a callable Eigen::Vector3d → std::optional<Eigen::Vector2d>: a camera
// model, or a trace through a port). Exactly ConicCentreOfCircle under a homography; through
// distortion or a port, where a circle's image is no conic, the centre of the ellipse that best
// fits it. nullopt when a rim point cannot be imaged.
template <class Project>
std::optional<Eigen::Vector2d> ImagedCircleCentre(Project&& project, const Eigen::Vector3d& centre,
                                                  const Eigen::Vector3d& axis1, const Eigen::Vector3d& axis2,
                                                  double radius, int n_rim = 32) {
  std::vector<Eigen::Vector2d> rim;
  rim.reserve(n_rim);
  for (int k = 0; k < n_rim; ++k) {
    const double a = 2 * std::numbers::pi * k / n_rim;
    const std::optional<Eigen::Vector2d> uv = project(Eigen::Vector3d(centre + radius * (std::cos(a) * axis1 + std::sin(a) * axis2)));
    if (!uv) return std::nullopt;
    rim.push_back(*uv);
  }
  return ConicCentreOfPoints(rim);
}

}  // namespace porthole::coded
