#include "porthole/render/dots.h"

#include <fmt/format.h>

#include "porthole/calib/target.h"
#include "porthole/coded/ellipse.h"
#include "porthole/core/error.h"

namespace porthole::render {

std::optional<Eigen::Vector2d> DotImageCentre(const Setup& setup, const Band& band, const Pose& pose,
                                              const Eigen::Vector3d& centre_in_target_mm, double radius_mm, int n_rim) {
  const auto project = [&](const Eigen::Vector3d& p) { return ProjectThroughPort(setup, band, pose, p); };
  return coded::ImagedCircleCentre(project, centre_in_target_mm, Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(),
                                   radius_mm, n_rim);
}

std::vector<DotTruth> DotImageCentres(const Scene& scene, const Setup& setup, const std::vector<TruthPoint>& truth) {
  const double radius = DotRadiusMm(scene.target);
  std::vector<DotTruth> out;
  if (!(radius > 0)) return out;
  for (const TruthPoint& tp : truth) {
    DotTruth d;
    d.id = tp.id;
    for (const Band& b : setup.bands) {
      const auto c = DotImageCentre(setup, b, scene.pose, tp.point_in_target_mm, radius);
      if (!c) {
        throw InvalidInput("port", fmt::format("the rim of dot {} cannot be imaged through the port at {:g} nm", tp.id,
                                               b.lambda_nm));
      }
      d.centre_px_per_band.push_back(*c);
    }
    out.push_back(std::move(d));
  }
  return out;
}

std::vector<DotTruth> DotImageCentres(const Scene& scene, const Setup& setup) {
  return DotImageCentres(scene, setup, GroundTruth(scene, setup));
}

nlohmann::ordered_json DotCentresJson(const Scene& scene, const Setup& setup, const std::vector<TruthPoint>& truth) {
  using Json = nlohmann::ordered_json;
  Json a = Json::array();
  for (const DotTruth& d : DotImageCentres(scene, setup, truth)) {
    Json px = Json::array();
    for (const Eigen::Vector2d& uv : d.centre_px_per_band) px.push_back({uv.x(), uv.y()});
    a.push_back({{"id", d.id}, {"px", px}});
  }
  return a;
}

}  // namespace porthole::render
