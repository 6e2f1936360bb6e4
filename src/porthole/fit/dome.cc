#include "porthole/fit/dome.h"

#include <fmt/core.h>

#include <Eigen/Geometry>
#include <cmath>

#include "porthole/core/error.h"

namespace porthole::fit {
namespace {

void RequireFiniteVector(const std::string& field, const Eigen::Vector3d& v) {
  if (!v.allFinite()) throw InvalidInput(field, "must be finite");
}

// Fills the quantities derived from the two sphere fits.
void Derive(DomeAnalysis& d, double nominal_r, double nominal_t) {
  const Sphere& o = d.outer.sphere;
  const Sphere& i = d.inner.sphere;
  d.thickness_mm = o.radius_mm - i.radius_mm;
  d.sigma_thickness_mm = std::hypot(d.outer.sigma_radius_mm, d.inner.sigma_radius_mm);
  d.center_offset_mm = i.center_mm - o.center_mm;
  d.center_distance_mm = d.center_offset_mm.norm();
  const Eigen::Matrix3d cov =
      d.outer.covariance.topLeftCorner<3, 3>() + d.inner.covariance.topLeftCorner<3, 3>();
  if (d.center_distance_mm > 0) {
    const Eigen::Vector3d g = d.center_offset_mm / d.center_distance_mm;
    d.sigma_center_distance_mm = std::sqrt(g.dot(cov * g));
  } else {
    d.sigma_center_distance_mm = std::sqrt(cov.trace());  // distance 0: a non-Gaussian corner
  }
  d.min_wall_mm = d.thickness_mm - d.center_distance_mm;
  d.max_wall_mm = d.thickness_mm + d.center_distance_mm;
  if (nominal_r > 0) d.outer_radius_deviation_mm = o.radius_mm - nominal_r;
  if (nominal_t > 0) d.thickness_deviation_mm = d.thickness_mm - nominal_t;
}

}  // namespace

RigidTransform HousingFromFlange(const Eigen::Vector3d& flange_center_in_scan,
                                 const Eigen::Vector3d& flange_normal_in_scan,
                                 const Eigen::Vector3d& scene_point_in_scan,
                                 const Eigen::Vector3d& x_hint_in_scan) {
  RequireFiniteVector("flange_center", flange_center_in_scan);
  RequireFiniteVector("flange_normal", flange_normal_in_scan);
  RequireFiniteVector("scene_point", scene_point_in_scan);
  RequireFiniteVector("x_hint", x_hint_in_scan);
  if (!(flange_normal_in_scan.norm() > 0)) throw InvalidInput("flange_normal", "must be non-zero");
  Eigen::Vector3d z = flange_normal_in_scan.normalized();
  const Eigen::Vector3d to_scene = scene_point_in_scan - flange_center_in_scan;
  const double side = z.dot(to_scene);
  if (!(std::abs(side) > 1e-9 * std::max(1.0, to_scene.norm())))
    throw InvalidInput("scene_point", "lies in the flange plane: cannot tell the +Z side");
  if (side < 0) z = -z;
  Eigen::Vector3d x = x_hint_in_scan - x_hint_in_scan.dot(z) * z;
  if (!(x.norm() > 1e-9 * x_hint_in_scan.norm()) || !(x_hint_in_scan.norm() > 0))
    throw InvalidInput("x_hint", "must not be zero or parallel to the flange normal");
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);
  RigidTransform housing_from_scan;
  housing_from_scan.rotation.row(0) = x.transpose();
  housing_from_scan.rotation.row(1) = y.transpose();
  housing_from_scan.rotation.row(2) = z.transpose();
  housing_from_scan.translation = -housing_from_scan.rotation * flange_center_in_scan;
  return housing_from_scan;
}

DomeAnalysis AnalyzeDome(const Eigen::Matrix3Xd& outer_points, const Eigen::Matrix3Xd& inner_points,
                         const DomeAnalysisOptions& o) {
  RequireNonNegative("nominal_outer_radius_mm", o.nominal_outer_radius_mm);
  RequireNonNegative("nominal_thickness_mm", o.nominal_thickness_mm);
  DomeAnalysis d;
  try {
    d.outer = FitSphere(outer_points, o.sphere);
  } catch (const InvalidInput& e) {
    throw InvalidInput("outer_points", e.what());
  }
  try {
    d.inner = FitSphere(inner_points, o.sphere);
  } catch (const InvalidInput& e) {
    throw InvalidInput("inner_points", e.what());
  }
  Derive(d, o.nominal_outer_radius_mm, o.nominal_thickness_mm);
  return d;
}

DomeAnalysis TransformDome(const DomeAnalysis& in_a, const RigidTransform& b_from_a) {
  DomeAnalysis d = in_a;
  for (SphereFitSummary* s : {&d.outer, &d.inner}) {
    s->sphere.center_mm = b_from_a.Apply(s->sphere.center_mm);
    Eigen::Matrix4d r = Eigen::Matrix4d::Identity();
    r.topLeftCorner<3, 3>() = b_from_a.rotation;
    s->covariance = r * s->covariance * r.transpose();
    s->sigma_center_mm = s->covariance.diagonal().head<3>().cwiseSqrt();
  }
  d.center_offset_mm = b_from_a.rotation * in_a.center_offset_mm;
  return d;
}

std::string DomeAnalysis::Report() const {
  std::string s;
  s += "outer " + outer.BriefReport() + "\n";
  s += "inner " + inner.BriefReport() + "\n";
  s += fmt::format("thickness {:.4f} ± {:.4f} mm (wall {:.4f} .. {:.4f} mm)\n", thickness_mm,
                   sigma_thickness_mm, min_wall_mm, max_wall_mm);
  s += fmt::format(
      "centre offset inner − outer ({:.4f}, {:.4f}, {:.4f}) mm, distance {:.4f} ± {:.4f} mm\n",
      center_offset_mm.x(), center_offset_mm.y(), center_offset_mm.z(), center_distance_mm,
      sigma_center_distance_mm);
  if (std::isfinite(outer_radius_deviation_mm))
    s += fmt::format("outer radius − nominal {:+.4f} mm\n", outer_radius_deviation_mm);
  if (std::isfinite(thickness_deviation_mm))
    s += fmt::format("thickness − nominal {:+.4f} mm\n", thickness_deviation_mm);
  return s;
}

}  // namespace porthole::fit
