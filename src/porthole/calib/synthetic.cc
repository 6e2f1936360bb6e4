#include "porthole/calib/synthetic.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <random>

namespace porthole::calib {

SyntheticSet MakeSyntheticSet(const SyntheticOptions& o) {
  camera::ValidateCamera(o.camera, "camera");
  const camera::Sensor& sensor = o.camera.sensor;
  RequireNonNegative("max_off_axis_deg", o.max_off_axis_deg);
  const auto pts = TargetPoints(o.target);
  const std::vector<bool> is_point = TargetPointMask(o.target);
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY), hi = -lo;
  for (std::size_t k = 0; k < pts.size(); ++k) {
    if (is_point[k]) lo = lo.cwiseMin(pts[k]), hi = hi.cwiseMax(pts[k]);
  }
  const Eigen::Vector3d centre = 0.5 * (lo + hi);
  const double extent = (hi - lo).head<2>().maxCoeff();
  const double distance = o.camera.FocalLengthPx() * extent / (o.fill * sensor.width_px);

  std::mt19937_64 pose_rng(o.pose_seed), noise_rng(o.noise_seed);
  std::uniform_real_distribution<double> uni(-1, 1);
  std::normal_distribution<double> gauss(0, o.noise_px);
  SyntheticSet set;
  const double tilt_max = o.max_tilt_deg * M_PI / 180;
  for (int i = 0; i < o.n_images; ++i) {
    // Camera centre on a sphere around the target centre, on the −Z side, looking at it, with a
    // random roll and a small aim offset.
    const double tilt = tilt_max * std::sqrt(0.15 + 0.85 * std::abs(uni(pose_rng)));
    const double azimuth = 2 * M_PI * (i + 0.5 * uni(pose_rng)) / o.n_images;
    const Eigen::Vector3d dir(std::sin(tilt) * std::cos(azimuth), std::sin(tilt) * std::sin(azimuth),
                              -std::cos(tilt));
    const Eigen::Vector3d eye = centre + distance * (1 + 0.15 * uni(pose_rng)) * dir;
    // Draws sequenced one per statement: the order of evaluation of function arguments is
    // unspecified (g++ evaluates right to left, clang left to right), and the same seeds must give the
    // same views with every compiler. This order is g++'s, so the data of every test is unchanged.
    const double aim_y = uni(pose_rng);
    const double aim_x = uni(pose_rng);
    const Eigen::Vector3d aim = centre + 0.05 * extent * Eigen::Vector3d(aim_x, aim_y, 0);
    Eigen::Vector3d z = (aim - eye).normalized();
    if (o.max_off_axis_deg > 0) {
      // Turn the view away from the target by up to max_off_axis_deg, in a random direction.
      const double off = o.max_off_axis_deg * M_PI / 180 * std::sqrt(std::abs(uni(pose_rng)));
      const double dir_az = M_PI * uni(pose_rng);
      const Eigen::Vector3d axis =
          z.cross(Eigen::Vector3d(std::cos(dir_az), std::sin(dir_az), 0)).normalized();
      z = Eigen::AngleAxisd(off, axis) * z;
    }
    const Eigen::Vector3d x = (Eigen::Vector3d::UnitX() - z.x() * z).normalized();
    const Eigen::Vector3d y0 = z.cross(x);
    const double roll = 0.3 * uni(pose_rng);
    const Eigen::Vector3d xr = std::cos(roll) * x + std::sin(roll) * y0;
    const Eigen::Vector3d yr = z.cross(xr);
    Eigen::Matrix3d r;
    r.row(0) = xr;
    r.row(1) = yr;
    r.row(2) = z;
    const Eigen::Vector3d t = -r * eye;
    ImageDetections d;
    d.image = fmt::format("synthetic{:02d}", i);
    d.width_px = sensor.width_px;
    d.height_px = sensor.height_px;
    for (std::size_t k = 0; k < pts.size(); ++k) {
      if (!is_point[k]) continue;  // coded: an ID that is no target
      const Eigen::Vector3d point_in_cam = r * pts[k] + t;
      const auto px = o.project ? o.project(point_in_cam) : o.camera.Project(point_in_cam);
      if (!px) continue;
      const Eigen::Vector2d& uv = *px;
      if (uv.x() < 0 || uv.y() < 0 || uv.x() > sensor.width_px - 1 ||
          uv.y() > sensor.height_px - 1) {
        continue;
      }
      d.ids.push_back(static_cast<int>(k));
      const double noise_v = gauss(noise_rng);  // sequenced as g++ evaluated the two arguments
      const double noise_u = gauss(noise_rng);
      d.points_px.emplace_back(uv.x() + noise_u, uv.y() + noise_v);
    }
    const Eigen::AngleAxisd aa(r);
    ImageResult pose;
    pose.image = d.image;
    pose.n_points = static_cast<int>(d.ids.size());
    pose.rotation_rad = aa.angle() * aa.axis();
    pose.translation_mm = t;
    set.detections.push_back(std::move(d));
    set.poses.push_back(pose);
  }
  return set;
}

}  // namespace porthole::calib
