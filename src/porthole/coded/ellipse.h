// Where the image of a circle has its centre: the centre of the projected conic (what an ellipse
// fit measures) against the projection of the circle's centre (what a point projection predicts).
// They differ under perspective (the "eccentricity" of circular targets; Ahn, Warnecke & Kotowski
// 1999; Luhmann 2014): the image of a circle is an ellipse whose centre is not the image of the
// circle's centre.
#pragma once

#include <Eigen/Dense>

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

}  // namespace porthole::coded
