// Where a detector of circular targets measures each dot: the centre of the dot's IMAGE, which is
// not the image of the dot's centre (coded/ellipse.h). This is the "detector-equivalent truth" of
// renders of coded targets and circle grids: what a perfect ellipse-centre detector would report.
//
// The dot's rim (radius DotRadiusMm, in the target plane) is sampled at n_rim points evenly round
// it; each is imaged by the forward projection through the port (ProjectThroughPort: the chief ray
// traced through the port and the camera model, Newton-solved to 1e-10 mm), and the centre of the
// conic fitted to those images is the truth (coded::ImagedCircleCentre). Without a port's
// refraction and distortion the image is an exact conic and this is its centre (to ~1e-9 px);
// through a dome or a flat port it is no conic, and the fitted ellipse's centre is what an
// ellipse-fitting detector measures from edge points spread round the dot.
#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "porthole/render/render.h"

namespace porthole::render {

// The centre (px) of the image of the circle of `radius_mm` about `centre_in_target_mm` in its
// plane parallel to the board (Z = its z in the target frame), through `band`; nullopt when a rim point cannot be
// imaged (beyond the port's rim).
std::optional<Eigen::Vector2d> DotImageCentre(const Setup& setup, const Band& band, const Pose& pose,
                                              const Eigen::Vector3d& centre_in_target_mm, double radius_mm,
                                              int n_rim = 64);

struct DotTruth {
  int id = 0;
  std::vector<Eigen::Vector2d> centre_px_per_band;  // one per band of the setup
};

// Every dot's image centre per band, for the points of `truth` (GroundTruth's, in its order; a
// dot of a 3-D field in its own plane Z = z); empty for targets without dots (DotRadiusMm = 0).
// Throws InvalidInput("port") where a rim cannot be imaged.
std::vector<DotTruth> DotImageCentres(const Scene& scene, const Setup& setup, const std::vector<TruthPoint>& truth);
// The same for GroundTruth(scene, setup).
std::vector<DotTruth> DotImageCentres(const Scene& scene, const Setup& setup);

// The same as the ground-truth JSON's "dot_centres": [{id, px: [[u, v] per band]}].
nlohmann::ordered_json DotCentresJson(const Scene& scene, const Setup& setup, const std::vector<TruthPoint>& truth);

}  // namespace porthole::render
