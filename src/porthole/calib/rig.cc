// CalibrateRig (rig.h): the start from each camera's own calibration, one Ceres adjustment of every
// camera's intrinsics, cam_from_rig and the frames' poses, and its statistics.
#include "porthole/calib/rig.h"
#include "porthole/refraction/shell_json.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <filesystem>
#include <map>
#include <set>

#include "porthole/calib/bundle.h"
#include "porthole/calib/free_target.h"
#include "porthole/calib/housed_prior.h"
#include "porthole/calib/prior_cost.h"
#include "porthole/calib/refractive.h"
#include "porthole/calib/result_json.h"
#include "porthole/calib/scales.h"
#include "porthole/core/error.h"

namespace porthole::calib {
namespace {

using Pose6 = std::array<double, 6>;  // angle-axis (rad), translation (mm)

struct Rt {
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
};

Rt ToRt(const Pose6& p) {
  Rt x;
  ceres::AngleAxisToRotationMatrix(p.data(), x.r.data());  // column-major, as Eigen
  x.t = Eigen::Vector3d(p[3], p[4], p[5]);
  return x;
}
Rt ToRt(const Eigen::Vector3d& rotation_rad, const Eigen::Vector3d& translation_mm) {
  return ToRt(Pose6{rotation_rad.x(), rotation_rad.y(), rotation_rad.z(), translation_mm.x(), translation_mm.y(),
                    translation_mm.z()});
}
Pose6 ToPose(const Rt& x) {
  Pose6 p;
  ceres::RotationMatrixToAngleAxis(x.r.data(), p.data());
  p[3] = x.t.x(), p[4] = x.t.y(), p[5] = x.t.z();
  return p;
}
Rt Compose(const Rt& a, const Rt& b) { return {a.r * b.r, a.r * b.t + a.t}; }  // a ∘ b
Rt Inverse(const Rt& a) { return {a.r.transpose(), -a.r.transpose() * a.t}; }

struct Cam {
  camera::Camera camera;      // model, sensor, parameters (current estimate)
  FreeMask free;
  std::vector<double> scale, scaled;
  Pose6 extrinsic{};          // cam_from_rig
  // Behind a port: its system, shell, parameters (adjusted), predicted parameters.
  std::optional<ports::PortSystem> system;
  std::optional<refraction::Shell> shell;
  std::array<double, refraction::kPortNumParams> port{}, predicted{};
  // The in-air prior on the scaled intrinsics (RigOptions::air_lens): r = a·scaled − b; rows 0: none.
  Eigen::MatrixXd prior_a;
  Eigen::VectorXd prior_b;
  // An in-air calibration made through its port: the prior on the lens and the port (housed_prior.h).
  std::optional<HousedPrior> housed;
  std::optional<refraction::Shell> air_shell;  // behind a port with air images: the shell with air outside
  // Its air images at another focus (RigOptions::air_refocused): their factor on its focal length(s).
  std::array<double, 1> air_focus{1.0};
  bool air_focus_free = false;
  CalibrationResult alone;    // its own calibration (the start)
  const CalibrationOptions* options = nullptr;
  std::string name;
};

struct Obs {
  int cam = 0, frame = 0, point = 0, image = 0;  // image: index in the camera's detections
  double u_px = 0, v_px = 0;
  bool active = true;
  // An air image's observation (RigOptions::air_images): `frame` indexes the air images, `image`
  // the camera's air detections.
  bool air = false;
};

// An image taken in air through a camera's port (RigOptions::air_images): its own pose.
struct AirImage {
  int cam = 0;
  std::string image;
  Pose6 pose{};  // cam_from_target
};

std::vector<double> Scales(const camera::Camera& c) {
  return camera::VisitModel(c.model, [&](auto m) {
    using M = decltype(m);
    const auto s = ModelScales<M>(c.sensor);
    return std::vector<double>(s.begin(), s.end());
  });
}

// Camera c as the Bundle (bundle.h) sees it: its blocks are c's own.
BundleCamera BundleCameraOf(Cam& c) {
  BundleCamera b;
  b.model = c.camera.model;
  b.sensor = c.camera.sensor;
  b.scaled = c.scaled.data();
  b.scale = c.scale;
  b.free = c.free;
  if (c.shell) {
    b.water_shell = &*c.shell;
    b.air_shell = c.air_shell ? &*c.air_shell : nullptr;
    b.port = c.port.data();
  }
  return b;
}

// An observation of camera `cam_index` (c) at `pose`: a frame's rig_from_target, with the camera's
// cam_from_rig but for the first camera; an air image's own cam_from_target (air set).
BundleObservation BundleObservationOf(Cam& c, int cam_index, Pose6& pose, const Eigen::Vector3d& x, const Obs& ob,
                                      double weight, double* point_block = nullptr) {
  BundleObservation b;
  b.point_block = point_block;
  b.camera = cam_index;
  b.pose = pose.data();
  b.cam_from_rig = cam_index == 0 || ob.air ? nullptr : c.extrinsic.data();
  b.point = x;
  b.u_px = ob.u_px, b.v_px = ob.v_px;
  b.weight = weight;
  b.medium = ob.air ? Medium::kAir : Medium::kWater;
  if (ob.air && c.air_focus_free) b.focal_scale = c.air_focus.data();
  return b;
}

// The residual (px) of one observation at the current estimate; nullopt where it cannot project.
std::optional<Eigen::Vector2d> Residual(Cam& c, int cam_index, Pose6& pose, const Eigen::Vector3d& x, const Obs& ob) {
  return ObservationResidual(BundleCameraOf(c), BundleObservationOf(c, cam_index, pose, x, ob, 1.0));
}

Eigen::Matrix3d ChordalMean(const std::vector<Eigen::Matrix3d>& rs) {
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  for (const auto& r : rs) sum += r;
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(sum, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() > 0 ? 1 : -1;
  return svd.matrixU() * d * svd.matrixV().transpose();
}

}  // namespace

std::string FrameName(const std::string& image) {
  return std::filesystem::path(image).stem().string();
}

RigResult CalibrateRig(const std::vector<std::vector<ImageDetections>>& per_camera, const TargetSpec& target,
                       const RigOptions& options) {
  QuietCeresLogs();
  const auto t0 = std::chrono::steady_clock::now();
  const int n_cams = static_cast<int>(per_camera.size());
  if (n_cams < 2) throw InvalidInput("cameras", "a rig needs 2 or more cameras (one set of images per camera)");
  const int n_opt = static_cast<int>(options.cameras.size());
  if (n_opt != 1 && n_opt != n_cams) {
    throw InvalidInput("camera_options", fmt::format("{} sets of camera options for {} cameras: give 1 or {}", n_opt,
                                                     n_cams, n_cams));
  }
  const CalibrationOptions& first = options.cameras.front();
  const bool free_target = first.target_free;
  const auto say = [&](const std::string& m) {
    if (first.progress) first.progress(m);
  };
  if (!options.names.empty() && static_cast<int>(options.names.size()) != n_cams) {
    throw InvalidInput("names", fmt::format("{} names for {} cameras", options.names.size(), n_cams));
  }
  const int n_ports = static_cast<int>(options.ports.size());
  if (n_ports != 0 && n_ports != 1 && n_ports != n_cams) {
    throw InvalidInput("ports", fmt::format("{} ports for {} cameras: give 1 or {}", n_ports, n_cams, n_cams));
  }
  const int n_air = static_cast<int>(options.air_lens.size());
  if (n_air != 0 && n_air != n_cams) {
    throw InvalidInput("air_lens", fmt::format("{} in-air calibrations for {} cameras: one per camera", n_air, n_cams));
  }
  if (n_air > 0 && n_ports == 0) throw InvalidInput("air_lens", "a prior on the lens behind a port: give the ports");
  const int n_air_sets = static_cast<int>(options.air_images.size());
  if (n_air_sets != 0 && n_air_sets != n_cams) {
    throw InvalidInput("air_images", fmt::format("{} given for {} cameras: one list of air images per camera",
                                                 n_air_sets, n_cams));
  }
  if (n_air_sets > 0 && n_ports == 0) {
    throw InvalidInput("air_images", "images in air through the ports: give the ports");
  }
  if (options.air_refocused && n_air_sets == 0) {
    throw InvalidInput("air_refocused", "says the air images were taken at another focus: give `air_images`");
  }
  if (n_air_sets > 0 && n_air > 0) {
    throw InvalidInput("air_images", "not with `air_calibration`: the lenses come from the air images adjusted with "
                                     "the water ones; give one of them");
  }

  // Frames by name; each camera's own calibration (the start).
  std::map<std::string, int> frame_index;
  for (const auto& set : per_camera) {
    for (const auto& d : set) frame_index.emplace(FrameName(d.image), 0);
  }
  RigResult res;
  for (auto& [name, index] : frame_index) {
    index = static_cast<int>(res.frames.size());
    res.frames.push_back(name);
  }
  const int n_frames = static_cast<int>(res.frames.size());
  std::vector<Cam> cams(n_cams);
  std::vector<AirImage> air_images;  // every camera's air images (RigOptions::air_images), in order
  // Per camera: frame → the pose of its own calibration (cam_from_target), for the start.
  std::vector<std::map<int, Rt>> seen(n_cams);
  for (int k = 0; k < n_cams; ++k) {
    Cam& c = cams[k];
    c.options = &options.cameras[n_opt == 1 ? 0 : k];
    c.name = options.names.empty() ? fmt::format("camera{}", k) : options.names[k];
    std::set<std::string> names;
    for (const auto& d : per_camera[k]) {
      if (!names.insert(FrameName(d.image)).second) {
        throw InvalidInput("cameras", fmt::format("{}: two images are frame {} (frames are matched by file name "
                                                  "without extension)", c.name, FrameName(d.image)));
      }
    }
    CalibrationOptions co = *c.options;
    // A free target: the first camera's own calibration adjusts it too (the start and the datum).
    co.target_free = free_target && k == 0;
    if (!co.target_free) co.datum = CalibrationOptions::DatumKind::kAuto;
    co.statistics = false;  // a start: its covariance is not used
    co.progress = [&, k](const std::string& m) { say(fmt::format("{}: {}", cams[k].name, m)); };
    if (n_ports > 0) {  // the lens behind its port, calibrated alone through it (the start)
      RefractiveOptions ro;
      ro.lens = co;
      ro.port = options.ports[n_ports == 1 ? 0 : k];
      ro.compare_central = false;
      ro.search = options.port_search;
      if (n_air > 0) {
        ro.air = options.air_lens[k];
        ro.air_of = options.air_of;
        ro.intrinsics = IntrinsicsMode::kPrior;
      }
      if (n_air_sets > 0) ro.air_detections = options.air_images[k];
      ro.air_refocused = options.air_refocused && !ro.air_detections.empty();
      const RefractiveResult alone = CalibrateRefractive(per_camera[k], target, ro);
      if (ro.air_refocused) c.air_focus = {alone.air_focal_scale}, c.air_focus_free = true;
      c.alone = alone.lens;
      c.system = ro.port;
      c.shell = refraction::ShellOf(ro.port);
      if (!alone.air_images.empty()) {  // its air images, at the poses of its own calibration
        c.air_shell = *c.shell;
        c.air_shell->n_water = 1;
        for (const ImageResult& im : alone.air_images) {
          air_images.push_back({k, im.image, ToPose(ToRt(im.rotation_rad, im.translation_mm))});
        }
      }
      c.port = alone.port;
      c.predicted = refraction::ParamsOf(ro.port);
    } else {
      c.alone = Calibrate(per_camera[k], target, co);
    }
    c.camera = c.alone.camera;
    c.free = c.alone.free;
    c.scale = Scales(c.camera);
    if (n_air > 0 && options.air_of == RefractiveOptions::AirCalibrationOf::kThroughPort) {
      // The target at this camera's own poses: a network like its air calibration's.
      std::vector<std::vector<Eigen::Vector3d>> views;
      const std::vector<Eigen::Vector3d> target_points = TargetPoints(target);
      for (const auto& im : c.alone.images) {
        const Rt x = ToRt(im.rotation_rad, im.translation_mm);
        views.emplace_back();
        for (const auto& p : target_points) views.back().push_back(x.r * p + x.t);
      }
      c.housed = camera::VisitModel(c.camera.model, [&](auto m) {
        return MakeHousedPrior<decltype(m)>(options.air_lens[k], views);
      });
    } else if (n_air > 0) {  // the lens alone: every parameter it adjusted but the focal length(s)
      const CalibrationRecord& air = options.air_lens[k];
      const camera::ModelInfo& info = c.camera.info();
      std::vector<int> idx;
      for (int i = info.num_focal; i < info.num_params; ++i) {
        if (air.free[i]) idx.push_back(i);
      }
      const int m = static_cast<int>(idx.size());
      if (m > 0) {
        const WhitenedPrior w = WhitenedPriorOf(air, idx, "air_lens", c.name + ": ");
        Eigen::MatrixXd e = Eigen::MatrixXd::Zero(m, info.num_params);
        for (int a = 0; a < m; ++a) e(a, idx[a]) = c.scale[idx[a]];
        c.prior_a = w.whiten * e;
        c.prior_b = w.whiten * w.mean;
      }
    }
    for (const auto& im : c.alone.images) seen[k][frame_index.at(FrameName(im.image))] = ToRt(im.rotation_rad, im.translation_mm);
  }

  // cam_from_rig of each camera: breadth first from camera 0 over shared frames.
  std::vector<std::optional<Rt>> placed(n_cams);
  placed[0] = Rt{};
  std::deque<int> queue{0};
  while (!queue.empty()) {
    const int j = queue.front();
    queue.pop_front();
    for (int k = 0; k < n_cams; ++k) {
      if (placed[k]) continue;
      std::vector<Eigen::Matrix3d> rs;
      std::vector<Eigen::Vector3d> ts;
      for (const auto& [f, k_from_target] : seen[k]) {
        const auto it = seen[j].find(f);
        if (it == seen[j].end()) continue;
        const Rt x = Compose(Compose(k_from_target, Inverse(it->second)), *placed[j]);
        rs.push_back(x.r);
        ts.push_back(x.t);
      }
      if (rs.empty()) continue;
      Rt x;
      x.r = ChordalMean(rs);
      for (const auto& t : ts) x.t += t / static_cast<double>(ts.size());
      placed[k] = x;
      queue.push_back(k);
    }
  }
  for (int k = 0; k < n_cams; ++k) {
    if (!placed[k]) {
      throw InvalidInput("cameras", fmt::format("{} shares no frame with {} nor with a camera linked to it: give images "
                                                "of the target seen by both at once (frames are matched by file name)",
                                                cams[k].name, cams[0].name));
    }
    cams[k].extrinsic = ToPose(*placed[k]);
  }
  // Each frame's rig_from_target from the first camera that has its pose.
  std::vector<Pose6> frame_pose(n_frames);
  std::vector<bool> has_pose(n_frames, false);
  for (int f = 0; f < n_frames; ++f) {
    for (int k = 0; k < n_cams && !has_pose[f]; ++k) {
      const auto it = seen[k].find(f);
      if (it == seen[k].end()) continue;
      frame_pose[f] = ToPose(Compose(Inverse(*placed[k]), it->second));
      has_pose[f] = true;
    }
  }

  // Observations: every point of every image whose frame has a pose.
  std::vector<Eigen::Vector3d> points = free_target ? cams[0].alone.target_points_mm : TargetPoints(target);
  std::vector<Obs> obs;
  for (int k = 0; k < n_cams; ++k) {
    for (std::size_t i = 0; i < per_camera[k].size(); ++i) {
      const ImageDetections& d = per_camera[k][i];
      const int f = frame_index.at(FrameName(d.image));
      if (!has_pose[f]) continue;
      for (std::size_t p = 0; p < d.ids.size(); ++p) {
        if (d.ids[p] < 0 || d.ids[p] >= static_cast<int>(points.size())) continue;
        obs.push_back({k, f, d.ids[p], static_cast<int>(i), d.points_px[p].x(), d.points_px[p].y(), true});
      }
    }
  }
  // The air images' observations (the images their cameras' own calibrations kept).
  for (std::size_t a = 0; a < air_images.size(); ++a) {
    const int k = air_images[a].cam;
    const auto& set = options.air_images[k];
    for (std::size_t i = 0; i < set.size(); ++i) {
      const ImageDetections& d = set[i];
      if (d.image != air_images[a].image) continue;
      for (std::size_t p = 0; p < d.ids.size(); ++p) {
        if (d.ids[p] < 0 || d.ids[p] >= static_cast<int>(points.size())) continue;
        obs.push_back({k, static_cast<int>(a), d.ids[p], static_cast<int>(i), d.points_px[p].x(), d.points_px[p].y(),
                       true, true});
      }
    }
  }
  // A free target: every observed point adjusted, the first camera's datum held.
  std::optional<FreeTarget> field;
  if (free_target) {
    std::set<int> observed;
    for (const Obs& ob : obs) observed.insert(ob.point);
    field = FreeTargetOf(cams[0].alone, observed, target, &points);
  }
  const auto point_block = [&](const Obs& ob) { return field && field->Adjusted(ob.point) ? points[ob.point].data() : nullptr; };
  // The pose an observation is seen at: its frame's rig_from_target, or its air image's cam_from_target.
  const auto pose_of = [&](const Obs& ob) -> Pose6& {
    return ob.air ? air_images[ob.frame].pose : frame_pose[ob.frame];
  };
  for (auto& c : cams) {
    c.scaled.resize(c.scale.size());
    for (std::size_t i = 0; i < c.scale.size(); ++i) c.scaled[i] = c.camera.params[i] / c.scale[i];
  }

  // The adjustment: poses eliminated first, then every camera's intrinsics and extrinsics. With
  // in-air priors: a first pass without them gives σ0, then the images are weighted by 1/σ0 and the
  // priors added (RefractiveOptions' kPrior).
  double weight = 1;
  bool with_priors = false;
  int n_prior = 0;
  for (const auto& c : cams) n_prior += static_cast<int>(c.prior_a.rows()) + (c.housed ? c.housed->idx.size() : 0);
  // The housed priors (housed_prior.h): (re-)linearised at each camera's estimate; the largest move
  // of their pixels; and their squared residuals.
  const auto linearise_housed = [&] {
    double moved = 0;
    for (auto& c : cams) {
      if (!c.housed) continue;
      refraction::Shell air = *c.shell;
      air.n_water = 1;
      std::vector<double> lens(c.scale.size());
      for (std::size_t i = 0; i < lens.size(); ++i) lens[i] = c.scaled[i] * c.scale[i];
      camera::VisitModel(c.camera.model, [&](auto m) {
        moved = std::max(moved, LineariseHousedPrior<decltype(m)>(&*c.housed, c.camera.sensor, air, lens.data(),
                                                                  c.port.data(), nullptr));
      });
    }
    return moved;
  };
  const auto housed_cost = [](const Cam& c, auto m) {
    using M = decltype(m);
    refraction::Shell air = *c.shell;
    air.n_water = 1;
    HousedPriorCost<M> f{&*c.housed, c.camera.sensor, {}, air};
    std::copy(c.scale.begin(), c.scale.end(), f.scale.begin());
    return f;
  };
  // The adjustment as a Bundle (bundle.h): every camera (its port behind one), every active
  // observation at its frame's pose (air images at their own), the priors once weighed.
  const auto build = [&](Bundle* bundle) {
    for (auto& c : cams) bundle->AddCamera(BundleCameraOf(c));
    for (const Obs& ob : obs) {
      if (!ob.active) continue;
      bundle->AddObservation(
          BundleObservationOf(cams[ob.cam], ob.cam, pose_of(ob), points[ob.point], ob, weight, point_block(ob)));
    }
    if (field) field->AddTo(bundle, &points);
    for (auto& c : cams) {
      if (!with_priors || !bundle->HasBlock(c.scaled.data())) continue;
      if (c.prior_a.rows() > 0) bundle->AddCost(new LinearPriorCost(c.prior_a, c.prior_b), {c.scaled.data()});
      if (c.housed) {
        camera::VisitModel(c.camera.model, [&](auto m) {
          using M = decltype(m);
          bundle->AddCost(new ceres::AutoDiffCostFunction<HousedPriorCost<M>, M::kNumParams, M::kNumParams,
                                                          refraction::kPortNumParams>(
                              new HousedPriorCost<M>(housed_cost(c, m))),
                          {c.scaled.data(), c.port.data()});
        });
      }
    }
  };
  int iterations = 0;
  const auto solve = [&] {
    Bundle bundle;
    build(&bundle);
    BundleSolveOptions so;
    so.max_iterations = first.max_iterations;
    so.function_tolerance = 1e-12;
    so.parameter_tolerance = 1e-12;
    so.gradient_tolerance = 1e-14;
    so.num_threads = first.num_threads;
    iterations += static_cast<int>(bundle.Solve(so).iterations.size());
  };
  int n_unknowns = 6 * (n_cams - 1);
  for (const auto& c : cams) {
    n_unknowns += static_cast<int>(std::count(c.free.begin(), c.free.end(), true));
    if (c.shell) n_unknowns += refraction::kPortNumParams;
    if (c.air_focus_free) ++n_unknowns;
  }
  int n_used_frames = 0;
  {
    std::set<int> used;
    for (const Obs& ob : obs) {
      if (!ob.air) used.insert(ob.frame);
    }
    n_used_frames = static_cast<int>(used.size());
  }
  n_unknowns += 6 * n_used_frames;
  if (field) n_unknowns += field->n_unknowns, n_prior += field->n_prior;
  {
    std::set<int> used;
    for (const Obs& ob : obs) {
      if (ob.air) used.insert(ob.frame);
    }
    n_unknowns += 6 * static_cast<int>(used.size());
  }
  double ss = 0;
  int n_active = 0;
  const auto sum_squares = [&] {
    ss = 0, n_active = 0;
    for (const Obs& ob : obs) {
      if (!ob.active) continue;
      const auto r = Residual(cams[ob.cam], ob.cam, pose_of(ob), points[ob.point], ob);
      ss += r ? r->squaredNorm() : 0;
      ++n_active;
    }
  };
  const int reject_rounds = first.reject_k > 0 ? first.max_reject_rounds : 0;
  for (int round = 0;; ++round) {
    solve();
    sum_squares();
    if (2 * n_active - n_unknowns <= 0) {
      throw InvalidInput("cameras", fmt::format("{} points in {} frames give {} observations for {} unknowns: add "
                                                "frames", n_active, n_used_frames, 2 * n_active, n_unknowns));
    }
    const double sigma0 = std::sqrt(ss / (2 * n_active - n_unknowns));
    if (round >= reject_rounds) break;
    int rejected = 0;
    for (Obs& ob : obs) {
      if (!ob.active) continue;
      const auto r = Residual(cams[ob.cam], ob.cam, pose_of(ob), points[ob.point], ob);
      if (!r || r->norm() > first.reject_k * sigma0) ob.active = false, ++rejected;
    }
    if (rejected == 0) break;
    say(fmt::format("rig: rejected {} points beyond {:g} sigma0 ({:.3f} px); readjusting", rejected, first.reject_k,
                    sigma0));
  }
  if (n_prior > 0) {  // the images weighted by 1/σ0 of the adjustment above, the priors added
    weight = 1 / std::sqrt(ss / (2 * n_active - n_unknowns));
    with_priors = true;
    linearise_housed();
    solve();
    // Housed priors: re-linearised at the new estimate until their pixels move by < 1e-4 px.
    for (int round = 0; round < 8 && linearise_housed() >= 1e-4; ++round) solve();
    sum_squares();
  }
  res.n_points = n_active;
  res.n_rejected = static_cast<int>(obs.size()) - n_active;
  res.n_unknowns = n_unknowns;
  res.redundancy = 2 * n_active + n_prior - n_unknowns;
  res.iterations = iterations;
  res.sigma0_px = std::sqrt(ss / (2 * n_active - n_unknowns));  // of the images (px)
  res.rms_px = std::sqrt(ss / n_active);
  for (auto& c : cams) {
    for (std::size_t i = 0; i < c.scale.size(); ++i) c.camera.params[i] = c.scaled[i] * c.scale[i];
  }

  // Statistics: each camera's intrinsics and cam_from_rig, marginal over the frames.
  say("rig: covariance");
  Bundle bundle;
  build(&bundle);
  ceres::Problem& problem = bundle.problem();
  ceres::Covariance::Options co;
  co.num_threads = first.num_threads;
  ceres::Covariance covariance(co);
  std::vector<std::pair<const double*, const double*>> pairs;
  // Every block of every camera, and every pair of them (the joint covariance RigResult::covariance).
  struct Block {
    const double* data;
    int size;
    std::vector<double> scale;  // physical = scaled · scale
    std::vector<std::string> names;
  };
  std::vector<Block> blocks;
  for (int k = 0; k < n_cams; ++k) {
    const Cam& c = cams[k];
    if (problem.HasParameterBlock(c.scaled.data())) {
      Block b{c.scaled.data(), static_cast<int>(c.scaled.size()), c.scale, {}};
      for (const auto& p : c.camera.info().params) b.names.push_back(c.name + "." + std::string(p.json_key));
      blocks.push_back(std::move(b));
    }
    if (c.shell && problem.HasParameterBlock(c.port.data())) {
      Block b{c.port.data(), refraction::kPortNumParams, std::vector<double>(refraction::kPortNumParams, 1.0), {}};
      for (const auto& p : refraction::PortParams(c.shell->kind)) b.names.push_back(c.name + "." + std::string(p.json_key));
      blocks.push_back(std::move(b));
    }
    if (c.air_focus_free && problem.HasParameterBlock(c.air_focus.data())) {
      blocks.push_back({c.air_focus.data(), 1, {1.0}, {c.name + ".air_focal_scale"}});
    }
    if (k > 0 && problem.HasParameterBlock(c.extrinsic.data())) {
      Block b{c.extrinsic.data(), 6, std::vector<double>(6, 1.0), {}};
      for (const char* key : {"rx_rad", "ry_rad", "rz_rad", "tx_mm", "ty_mm", "tz_mm"}) {
        b.names.push_back(c.name + ".cam_from_rig." + key);
      }
      blocks.push_back(std::move(b));
    }
  }
  for (std::size_t a = 0; a < blocks.size(); ++a) {
    for (std::size_t b = a; b < blocks.size(); ++b) {
      if (problem.IsParameterBlockConstant(const_cast<double*>(blocks[a].data)) ||
          problem.IsParameterBlockConstant(const_cast<double*>(blocks[b].data))) {
        continue;
      }
      pairs.push_back({blocks[a].data, blocks[b].data});
    }
  }
  if (field) AddPointCovariancePairs(*field, problem, &points, &pairs);
  const bool cov_ok = covariance.Compute(pairs, &problem);
  if (!cov_ok) {
    throw InvalidInput("cameras", "the rig is not determined by these frames (singular covariance): add frames seen "
                                  "by the cameras together, at other ranges and angles");
  }
  // σ0² of the (weighted) adjustment: the images' Σ r²·w² and the priors' squared residuals.
  double prior_ss = 0;
  for (const auto& c : cams) {
    if (c.prior_a.rows() > 0) {
      prior_ss += (c.prior_a * Eigen::Map<const Eigen::VectorXd>(c.scaled.data(), c.scaled.size()) - c.prior_b).squaredNorm();
    }
    if (c.housed) {
      camera::VisitModel(c.camera.model, [&](auto m) {
        std::vector<double> r(decltype(m)::kNumParams);
        if (housed_cost(c, m).template Residual<double>(c.scaled.data(), c.port.data(), nullptr, r.data())) {
          for (double x : r) prior_ss += x * x;
        }
      });
    }
  }
  if (field) prior_ss += field->ControlSumSquares(points);
  const double s02 = with_priors ? (ss * weight * weight + prior_ss) / res.redundancy
                                 : res.sigma0_px * res.sigma0_px;
  if (field) {
    std::vector<Eigen::Vector3d> variance;
    if (!PointVariances(*field, problem, covariance, &points, &variance)) {
      throw InternalError("rig: the covariance of a free target's point was computed but cannot be read");
    }
    res.target_points_mm = points;
    res.target_sigma_mm = field->Sigma(variance, s02, points.size());
    res.datum = field->datum;
  }
  {
    int n_joint = 0;
    std::vector<int> offset;
    for (const Block& b : blocks) {
      offset.push_back(n_joint);
      n_joint += b.size;
      res.covariance_parameters.insert(res.covariance_parameters.end(), b.names.begin(), b.names.end());
    }
    res.covariance = Eigen::MatrixXd::Zero(n_joint, n_joint);
    for (std::size_t a = 0; a < blocks.size(); ++a) {
      for (std::size_t b = a; b < blocks.size(); ++b) {
        const Block &ba = blocks[a], &bb = blocks[b];
        if (problem.IsParameterBlockConstant(const_cast<double*>(ba.data)) ||
            problem.IsParameterBlockConstant(const_cast<double*>(bb.data))) {
          continue;
        }
        Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> m(ba.size, bb.size);
        covariance.GetCovarianceBlock(ba.data, bb.data, m.data());
        const Eigen::Map<const Eigen::VectorXd> sa(ba.scale.data(), ba.size), sb(bb.scale.data(), bb.size);
        const Eigen::MatrixXd phys = s02 * (sa.asDiagonal() * Eigen::MatrixXd(m) * sb.asDiagonal());
        res.covariance.block(offset[a], offset[b], ba.size, bb.size) = phys;
        res.covariance.block(offset[b], offset[a], bb.size, ba.size) = phys.transpose();
      }
    }
  }
  for (int k = 0; k < n_cams; ++k) {
    Cam& c = cams[k];
    const int n = static_cast<int>(c.scale.size());
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> cs(n, n);
    covariance.GetCovarianceBlock(c.scaled.data(), c.scaled.data(), cs.data());
    const Eigen::Map<const Eigen::VectorXd> sv(c.scale.data(), n);
    const Eigen::MatrixXd cov = s02 * (sv.asDiagonal() * Eigen::MatrixXd(cs) * sv.asDiagonal());

    RigCamera rc;
    rc.name = c.name;
    CalibrationResult& cr = rc.calibration;
    cr.camera = c.camera;
    cr.free = c.free;
    cr.covariance = cov;
    cr.covariance_ok = cov.allFinite();
    cr.sigma.assign(n, NAN);
    cr.correlation = Eigen::MatrixXd::Constant(n, n, NAN);
    const camera::ModelInfo& info = c.camera.info();
    for (int i = 0; i < n; ++i) {
      if (!c.free[i]) continue;
      cr.sigma[i] = std::sqrt(cov(i, i));
      for (int j = 0; j < n; ++j) {
        if (c.free[j]) cr.correlation(i, j) = cov(i, j) / std::sqrt(cov(i, i) * cov(j, j));
      }
      if (i >= info.first_distortion) {
        const double t = std::abs(c.camera.params[i]) / cr.sigma[i];
        cr.significance.push_back({i, t, t >= c.options->significance_t});
      }
    }
    cr.sigma0_px = res.sigma0_px;
    cr.n_unknowns = res.n_unknowns;
    cr.redundancy = res.redundancy;
    cr.iterations = res.iterations;
    cr.target_points_mm = points;
    cr.start_focal_px = c.alone.start_focal_px;
    cr.start_rms_px = c.alone.start_rms_px;
    // Per image: its residuals and cam_from_target = cam_from_rig ∘ rig_from_target.
    const Rt extr = ToRt(c.extrinsic);
    std::map<int, std::pair<double, int>> per_image;  // image index → (Σ|r|², n)
    std::map<int, int> rejected_in;
    double cam_ss = 0;
    std::map<int, std::pair<double, int>> per_air;  // air image index → (Σ|r|², n)
    for (const Obs& ob : obs) {
      if (ob.cam != k) continue;
      if (ob.air) {
        if (!ob.active) continue;
        const auto r = Residual(c, k, pose_of(ob), points[ob.point], ob);
        per_air[ob.frame].first += r ? r->squaredNorm() : 0;
        ++per_air[ob.frame].second;
        continue;
      }
      if (!ob.active) {
        ++rejected_in[ob.image];
        ++cr.n_rejected;
        continue;
      }
      const auto r = Residual(c, k, pose_of(ob), points[ob.point], ob);
      const double r2 = r ? r->squaredNorm() : 0;
      per_image[ob.image].first += r2;
      ++per_image[ob.image].second;
      cam_ss += r2;
      ++cr.n_points;
    }
    cr.rms_px = cr.n_points > 0 ? std::sqrt(cam_ss / cr.n_points) : NAN;
    for (const auto& [i, sn] : per_image) {
      const ImageDetections& d = per_camera[k][i];
      const Rt pose = Compose(k == 0 ? Rt{} : extr, ToRt(frame_pose[frame_index.at(FrameName(d.image))]));
      const Pose6 p = ToPose(pose);
      ImageResult im;
      im.image = d.image;
      im.n_points = sn.second;
      im.n_rejected = rejected_in[i];
      im.rms_px = std::sqrt(sn.first / sn.second);
      im.rotation_rad = Eigen::Vector3d(p[0], p[1], p[2]);
      im.translation_mm = Eigen::Vector3d(p[3], p[4], p[5]);
      cr.images.push_back(im);
    }
    cr.n_images = static_cast<int>(cr.images.size());
    rc.n_frames = cr.n_images;
    double air_ss = 0;
    int air_n = 0;
    for (const auto& [a, sn] : per_air) {
      ImageResult im;
      im.image = air_images[a].image;
      im.n_points = sn.second;
      im.rms_px = std::sqrt(sn.first / sn.second);
      const Pose6& p = air_images[a].pose;
      im.rotation_rad = Eigen::Vector3d(p[0], p[1], p[2]);
      im.translation_mm = Eigen::Vector3d(p[3], p[4], p[5]);
      rc.air_images.push_back(im);
      air_ss += sn.first, air_n += sn.second;
    }
    if (air_n > 0) rc.air_rms_px = std::sqrt(air_ss / air_n);
    if (c.air_focus_free) {
      double v = NAN;
      covariance.GetCovarianceBlock(c.air_focus.data(), c.air_focus.data(), &v);
      rc.air_focal_scale = c.air_focus[0];
      rc.air_focal_scale_sigma = std::sqrt(s02 * v);
    }
    const std::string poor = PoorFitStatus(cr.rms_px);
    cr.message = poor.empty() ? "ok" : poor;
    if (k > 0) {
      Eigen::Matrix<double, 6, 6, Eigen::RowMajor> pc;
      covariance.GetCovarianceBlock(c.extrinsic.data(), c.extrinsic.data(), pc.data());
      rc.pose_covariance = s02 * pc;
      for (int i = 0; i < 6; ++i) rc.pose_sigma(i) = std::sqrt(rc.pose_covariance(i, i));
      rc.rotation_rad = Eigen::Vector3d(c.extrinsic[0], c.extrinsic[1], c.extrinsic[2]);
      rc.translation_mm = Eigen::Vector3d(c.extrinsic[3], c.extrinsic[4], c.extrinsic[5]);
      // |centre| = |−Rᵀt| = |t|: its σ from the translation's covariance alone.
      rc.baseline_mm = rc.translation_mm.norm();
      const Eigen::Vector3d u = rc.translation_mm / rc.baseline_mm;
      rc.baseline_sigma_mm = std::sqrt(u.dot(rc.pose_covariance.bottomRightCorner<3, 3>() * u));
      const Eigen::Vector3d axis = extr.r.transpose() * Eigen::Vector3d::UnitZ();  // in the rig frame
      rc.convergence_deg = std::acos(std::clamp(axis.z(), -1.0, 1.0)) * 180 / M_PI;
    }
    if (c.shell) {
      Eigen::Matrix<double, refraction::kPortNumParams, refraction::kPortNumParams, Eigen::RowMajor> pc;
      covariance.GetCovarianceBlock(c.port.data(), c.port.data(), pc.data());
      rc.has_port = true;
      rc.port_kind = c.shell->kind;
      rc.port = c.port;
      rc.port_predicted = c.predicted;
      for (int i = 0; i < refraction::kPortNumParams; ++i) rc.port_sigma[i] = std::sqrt(s02 * pc(i, i));
      refraction::ValidateParams(*c.shell, c.port.data(), "port");
      rc.estimated_port = refraction::SpecWithParams(*c.system, c.port);
      rc.estimated_port.name = c.system->spec.name + "-as-calibrated";
      rc.estimated_port.description = fmt::format("{} as calibrated from the images of camera {} of a rig ({})",
                                                  c.system->spec.name, rc.name, c.system->spec.description);
      rc.estimated_port.source = "porthole calibrate, a rig through its ports: estimated from images";
      rc.shell = *c.shell;
    }
    res.cameras.push_back(std::move(rc));
  }
  const std::string poor = PoorFitStatus(res.rms_px);
  res.message = poor.empty() ? "ok" : poor;
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  say(fmt::format("rig: {} cameras, {} frames, sigma0 {:.4f} px, RMS {:.4f} px, {} iterations, {:.3f} s", n_cams,
                  n_used_frames, res.sigma0_px, res.rms_px, res.iterations, res.seconds));
  return res;
}

namespace {

nlohmann::ordered_json JointCovarianceJson(const RigResult& r) {
  using Json = nlohmann::ordered_json;
  Json m = Json::array();
  for (int i = 0; i < r.covariance.rows(); ++i) {
    Json row = Json::array();
    for (int j = 0; j < r.covariance.cols(); ++j) {
      row.push_back(std::isfinite(r.covariance(i, j)) ? Json(r.covariance(i, j)) : Json(nullptr));
    }
    m.push_back(row);
  }
  return {{"meaning", "sigma0^2-scaled covariance of every camera's intrinsics, port and cam_from_rig, marginal "
                      "over the frames (fixed parameters: zero rows)"},
          {"parameters", r.covariance_parameters},
          {"matrix", m}};
}

}  // namespace

nlohmann::ordered_json RigToJson(const RigResult& r, const TargetSpec& target, const RigOptions& options) {
  using Json = nlohmann::ordered_json;
  const auto num = [](double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); };
  Json cameras = Json::array();
  for (std::size_t k = 0; k < r.cameras.size(); ++k) {
    const RigCamera& c = r.cameras[k];
    const CalibrationOptions& o = options.cameras[options.cameras.size() == 1 ? 0 : k];
    Json j = CalibrationToJson(c.calibration, target, o);
    Json cov = Json::array();
    for (int i = 0; i < 6; ++i) {
      Json row = Json::array();
      for (int m = 0; m < 6; ++m) row.push_back(num(c.pose_covariance(i, m)));
      cov.push_back(row);
    }
    Json out = {{"name", c.name},
                {"cam_from_rig",
                 {{"rotation_rad", {c.rotation_rad.x(), c.rotation_rad.y(), c.rotation_rad.z()}},
                  {"translation_mm", {c.translation_mm.x(), c.translation_mm.y(), c.translation_mm.z()}},
                  {"sigma", {{"rotation_rad", {num(c.pose_sigma(0)), num(c.pose_sigma(1)), num(c.pose_sigma(2))}},
                             {"translation_mm", {num(c.pose_sigma(3)), num(c.pose_sigma(4)), num(c.pose_sigma(5))}}}},
                  {"covariance", cov},
                  {"order", "rotation_rad x y z, translation_mm x y z"}}},
                {"baseline_mm", c.baseline_mm},
                {"baseline_sigma_mm", c.baseline_sigma_mm},
                {"convergence_deg", c.convergence_deg},
                {"n_frames", c.n_frames}};
    if (c.has_port) {
      const auto& names = refraction::PortParams(c.port_kind);
      Json params = Json::object(), sigma = Json::object(), predicted = Json::object();
      for (int i = 0; i < refraction::kPortNumParams; ++i) {
        const std::string key(names[i].json_key);
        params[key] = c.port[i];
        sigma[key] = num(c.port_sigma[i]);
        predicted[key] = c.port_predicted[i];
      }
      out["port"] = {{"name", options.ports[options.ports.size() == 1 ? 0 : k].spec.name},
                     {"kind", refraction::PortKindName(c.port_kind)},
                     {"n_water", options.ports[options.ports.size() == 1 ? 0 : k].n_water},
                     {"parameters", params},
                     {"sigma", sigma},
                     {"predicted", predicted},
                     {"shell", refraction::ShellToJson(c.shell)}};
      if (!c.air_images.empty()) {  // its air images through the port (RigOptions::air_images)
        out["port"]["air"] = {{"lens_from", "air and water images through the port, adjusted with the rig"},
                              {"n_images", c.air_images.size()},
                              {"rms_px", num(c.air_rms_px)},
                              {"refocused", options.air_refocused},
                              {"images", ImagesJson(c.air_images)}};
        if (options.air_refocused) {  // the air images' focal length(s) / the water images'
          out["port"]["air"]["focal_scale"] = num(c.air_focal_scale);
          out["port"]["air"]["focal_scale_sigma"] = num(c.air_focal_scale_sigma);
        }
      }
      if (!options.air_lens.empty()) {  // what its in-air calibration was taken as (RigOptions::air_of)
        out["port"]["air_calibration_taken_as"] =
            options.air_of == RefractiveOptions::AirCalibrationOf::kThroughPort ? "through_port" : "lens_bare";
      }
    }
    out.update(j);
    cameras.push_back(out);
  }
  Json out = {{"rig",
           {{"frame", "camera 0's camera frame (X right, Y down, Z forward, mm); cam_from_rig maps it into each "
                      "camera: x_cam = R(rotation_rad) x_rig + translation_mm"},
            {"n_cameras", r.cameras.size()},
            {"n_frames", r.frames.size()},
            {"n_points", r.n_points},
            {"n_rejected", r.n_rejected},
            {"n_unknowns", r.n_unknowns},
            {"redundancy", r.redundancy},
            {"iterations", r.iterations},
            {"sigma0_px", num(r.sigma0_px)},
            {"rms_px", num(r.rms_px)},
            {"seconds", r.seconds},
            {"status", r.message},
            {"cameras", cameras},
            {"covariance", JointCovarianceJson(r)}}}};
  if (r.datum.Set()) {  // a free target: the points adjusted with the rig (the first camera's datum)
    CalibrationResult adjusted;
    adjusted.target_points_mm = r.target_points_mm;
    adjusted.target_sigma_mm = r.target_sigma_mm;
    adjusted.datum = r.datum;
    out["rig"]["target_adjusted"] = AdjustedTargetJson(adjusted, target);
  }
  return out;
}

}  // namespace porthole::calib
