// PlanRig (plan_rig.h): σ of a length over the common field against range, and the central model's
// systematic error.
#include "porthole/measure/plan_rig.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>

#include "porthole/calib/rig.h"
#include "porthole/camera/brown.h"
#include "porthole/camera/projection.h"
#include "porthole/core/error.h"
#include "porthole/measure/triangulate.h"
#include "porthole/refraction/refraction.h"

namespace porthole::measure {
namespace {

bool SeenByAll(const Rig& rig, const Eigen::Vector3d& x, std::vector<Observation>* obs) {
  if (obs) obs->clear();
  for (std::size_t k = 0; k < rig.cameras.size(); ++k) {
    const auto uv = ProjectPoint(rig.cameras[k], x);
    if (!uv || !InImage(rig.cameras[k], *uv)) return false;
    if (obs) obs->push_back({static_cast<int>(k), *uv});
  }
  return true;
}

// Directions spread over a hemisphere (z ≥ 0; a length has no sign): a Fibonacci spiral.
std::vector<Eigen::Vector3d> Directions(int n) {
  std::vector<Eigen::Vector3d> out;
  const double golden = M_PI * (3 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double z = (i + 0.5) / n;  // cos of the angle from the axis, uniform on the hemisphere
    const double r = std::sqrt(1 - z * z);
    out.emplace_back(r * std::cos(golden * i), r * std::sin(golden * i), z);
  }
  return out;
}

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const double at = q * (v.size() - 1);
  const std::size_t i = static_cast<std::size_t>(at);
  return i + 1 < v.size() ? v[i] + (at - i) * (v[i + 1] - v[i]) : v.back();
}

// The field every camera sees at depth z: the grid points of a fine grid, with its bounding box.
struct Field {
  std::vector<Eigen::Vector3d> points;
  double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
};

Field CommonField(const Rig& rig, double z) {
  // Search region: wide enough for any lens up to a 150° field (tan 75° ≈ 3.7), shifted along the
  // cameras' spread in x.
  double cx0 = 0, cx1 = 0;
  for (const auto& c : rig.cameras) {
    const Eigen::Vector3d centre = -(c.CamFromRigRotation().transpose() * c.translation_mm);
    cx0 = std::min(cx0, centre.x());
    cx1 = std::max(cx1, centre.x());
  }
  const double half = 3.7 * z;
  constexpr int kFine = 81;
  Field f;
  for (int i = 0; i < kFine; ++i) {
    for (int j = 0; j < kFine; ++j) {
      const Eigen::Vector3d x(cx0 - half + (cx1 - cx0 + 2 * half) * i / (kFine - 1.0), -half + 2 * half * j / (kFine - 1.0), z);
      if (!SeenByAll(rig, x, nullptr)) continue;
      f.points.push_back(x);
      f.x0 = std::min(f.x0, x.x()), f.x1 = std::max(f.x1, x.x());
      f.y0 = std::min(f.y0, x.y()), f.y1 = std::max(f.y1, x.y());
    }
  }
  return f;
}

// Noise-free views of a chessboard through the real rig at `range` ± 25 %, tilted up to 30°, placed
// over the common field: per camera, its detections (frames named f000 …).
std::vector<std::vector<calib::ImageDetections>> CentralFitViews(const Rig& rig, double range, const calib::TargetSpec& t) {
  const auto points = calib::TargetPoints(t);
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const auto& p : points) centre += p / static_cast<double>(points.size());
  const Field field = CommonField(rig, range);
  std::vector<std::vector<calib::ImageDetections>> out(rig.cameras.size());
  if (field.points.empty()) return out;
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int f = 0; f < 24; ++f) {
    const double wx = u(rng), wy = u(rng), wz = u(rng), s = u(rng), ax = u(rng), ay = u(rng);
    const double z = range * (1 + 0.25 * s);
    const Eigen::Vector3d aim(0.5 * (field.x0 + field.x1) + 0.3 * (field.x1 - field.x0) * ax * z / range,
                              0.5 * (field.y0 + field.y1) + 0.3 * (field.y1 - field.y0) * ay * z / range, z);
    const Eigen::Matrix3d r = (Eigen::AngleAxisd(0.5 * wx, Eigen::Vector3d::UnitX()) *
                               Eigen::AngleAxisd(0.5 * wy, Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(0.3 * wz, Eigen::Vector3d::UnitZ()))
                                  .toRotationMatrix();
    for (std::size_t k = 0; k < rig.cameras.size(); ++k) {
      calib::ImageDetections d;
      d.image = fmt::format("f{:03d}", f);
      d.width_px = rig.cameras[k].camera.sensor.width_px;
      d.height_px = rig.cameras[k].camera.sensor.height_px;
      for (std::size_t id = 0; id < points.size(); ++id) {
        const auto uv = ProjectPoint(rig.cameras[k], r * (points[id] - centre) + aim);
        if (!uv || !InImage(rig.cameras[k], *uv)) continue;
        d.ids.push_back(static_cast<int>(id));
        d.points_px.push_back(*uv);
      }
      if (d.ids.size() >= 12) out[k].push_back(d);
    }
  }
  return out;
}

}  // namespace

Rig DescribedRig(const std::vector<camera::Camera>& cameras, const std::vector<std::optional<ports::PortSystem>>& ports,
                 double baseline_mm, double convergence_deg) {
  if (cameras.size() < 2) throw InvalidInput("cameras", "a rig needs 2 or more cameras");
  if (ports.size() != cameras.size()) {
    throw InvalidInput("ports", fmt::format("{} ports for {} cameras", ports.size(), cameras.size()));
  }
  if (!(baseline_mm > 0) || !std::isfinite(baseline_mm)) throw InvalidInput("baseline_mm", "must be > 0 mm");
  if (!(convergence_deg >= 0 && convergence_deg < 45)) {
    throw InvalidInput("convergence_deg", "must be in [0, 45) degrees");
  }
  Rig rig;
  for (std::size_t k = 0; k < cameras.size(); ++k) {
    RigCamera c;
    c.name = fmt::format("camera{}", k);
    c.camera = cameras[k];
    if (ports[k]) {
      c.shell = refraction::ShellOf(*ports[k]);
      c.port = refraction::ParamsOf(*ports[k]);
    }
    if (k > 0) {
      // Turned towards camera 0 (at −x from it): its axis in the rig frame, Rᵀ·z, is
      // (−sin θ, 0, cos θ) for R = R_y(+θ); R_y(−θ) made the axes diverge.
      const Eigen::Matrix3d r =
          Eigen::AngleAxisd(convergence_deg * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
      c.rotation_rad = Eigen::Vector3d(0, convergence_deg * M_PI / 180, 0);
      c.translation_mm = -r * Eigen::Vector3d(baseline_mm * static_cast<double>(k), 0, 0);
    }
    c.intrinsic_index.assign(c.camera.params.size(), -1);
    rig.cameras.push_back(c);
  }
  rig.covariance_note = "none (a described rig)";
  return rig;
}

Rig CentralRig(const Rig& rig, double fit_range_mm, double* fit_rms_px, int num_threads) {
  if (!(fit_range_mm > 0) || !std::isfinite(fit_range_mm)) throw InvalidInput("central_fit_range_mm", "must be > 0 mm");
  const double square = std::max(5.0, std::round(fit_range_mm / 25));
  const calib::TargetSpec target = calib::ParseTarget(fmt::format("chessboard:13x10:{:g}", square), "target");
  const auto views = CentralFitViews(rig, fit_range_mm, target);
  calib::RigOptions ro;
  for (std::size_t k = 0; k < rig.cameras.size(); ++k) {
    calib::CalibrationOptions co;
    co.model = rig.cameras[k].camera.model;
    co.pixel_pitch_mm = rig.cameras[k].camera.sensor.pixel_pitch_mm;
    co.reject_k = 0;  // noise-free: nothing to reject
    co.num_threads = std::max(1, num_threads);
    ro.cameras.push_back(co);
    ro.names.push_back(rig.cameras[k].name);
  }
  const calib::RigResult r = calib::CalibrateRig(views, target, ro);
  if (fit_rms_px) *fit_rms_px = r.rms_px;
  return RigFromResult(r);
}

Rig DescribedRig(const planning::Setup& setup, double baseline_mm, double convergence_deg, double focus_wd_mm,
                 double f_number, std::string* what) {
  if (setup.lens.projection != camera::Projection::kRectilinear) {
    throw InvalidInput("lens", "a described rig takes a rectilinear lens (a fisheye: calibrate the rig and plan "
                               "from its file)");
  }
  planning::PlanOptions po;
  po.wd_mm = focus_wd_mm;
  po.f_number = f_number;
  po.lambda_nm = setup.env.conditions.lambda_nm;
  const planning::Plan plan = planning::MakePlan(setup, po);  // the port at the focus for that range
  camera::BrownParams b;
  b.c_mm = plan.principal_distance_mm;
  const camera::Camera cam = camera::FromBrown(b, setup.camera.sensor);
  Rig rig = DescribedRig({cam, cam}, {plan.system, plan.system}, baseline_mm, convergence_deg);
  if (what) {
    *what = fmt::format("two {} + {} behind {}, {:g} mm apart, {:g} deg convergence", setup.camera.name,
                        setup.lens.name, plan.system.spec.name, baseline_mm, convergence_deg);
  }
  return rig;
}

RigPlan PlanRig(const Rig& rig, const RigPlanOptions& o) {
  if (rig.cameras.size() < 2) throw InvalidInput("rig", "a rig needs 2 or more cameras");
  if (!(o.sigma_px > 0) || !std::isfinite(o.sigma_px)) throw InvalidInput("sigma_px", "must be > 0 px");
  if (!(o.length_mm > 0) || !std::isfinite(o.length_mm)) throw InvalidInput("length_mm", "must be > 0 mm");
  if (o.ranges_mm.empty()) throw InvalidInput("ranges_mm", "give at least one range");
  for (double r : o.ranges_mm) {
    if (!(r > 0) || !std::isfinite(r)) throw InvalidInput("ranges_mm", fmt::format("{}: must be > 0 mm", r));
  }
  if (o.grid < 2 || o.grid > 50) throw InvalidInput("grid", "must be 2 … 50");
  if (o.orientations < 1 || o.orientations > 200) throw InvalidInput("orientations", "must be 1 … 200");
  RigPlan plan;
  plan.sigma_px = o.sigma_px;
  plan.length_mm = o.length_mm;
  plan.orientations = o.orientations;
  const bool with_cal = o.calibration_sigma && rig.covariance.rows() > 0 && rig.covariance.cwiseAbs().maxCoeff() > 0;
  plan.calibration_sigma = with_cal ? "image noise and the rig calibration (" + rig.covariance_note + ")"
                                    : "image noise only";

  // The central rig, calibrated on views through the real ports.
  std::optional<Rig> central;
  if (o.central_fit_range_mm > 0) {
    bool any_port = false;
    for (const auto& c : rig.cameras) any_port |= c.shell.has_value();
    if (!any_port) {
      plan.notes.push_back("no camera is behind a port: the central model is exact, no comparison");
    } else {
      for (const auto& c : rig.cameras) plan.central_models.push_back(std::string(c.camera.model_name()));
      try {
        central = CentralRig(rig, o.central_fit_range_mm, &plan.central_fit_rms_px,
                             o.num_threads > 0 ? o.num_threads : 1);
        plan.central = true;
        plan.central_fit_range_mm = o.central_fit_range_mm;
      } catch (const InvalidInput& e) {
        plan.notes.push_back(std::string("no central comparison: the central calibration failed: ") + e.what());
      }
    }
  }

  TriangulateOptions to;
  to.sigma_px = o.sigma_px;
  to.calibration_sigma = with_cal;
  TriangulateOptions to_central;
  to_central.sigma_px = o.sigma_px;
  to_central.calibration_sigma = false;
  const auto dirs = Directions(o.orientations);
  for (double z : o.ranges_mm) {
    RigPlanRow row;
    row.range_mm = z;
    const Field field = CommonField(rig, z);
    if (field.points.empty()) {
      plan.rows.push_back(row);
      continue;
    }
    row.common_width_mm = field.x1 - field.x0;
    row.common_height_mm = field.y1 - field.y0;
    std::vector<std::vector<Observation>> ends;  // a, b, a, b, …
    std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> placed;  // centre, direction
    for (int i = 0; i < o.grid; ++i) {
      for (int j = 0; j < o.grid; ++j) {
        const Eigen::Vector3d c(field.x0 + (field.x1 - field.x0) * (i + 0.5) / o.grid,
                                field.y0 + (field.y1 - field.y0) * (j + 0.5) / o.grid, z);
        for (const auto& d : dirs) {
          std::vector<Observation> oa, ob;
          if (!SeenByAll(rig, c - 0.5 * o.length_mm * d, &oa) || !SeenByAll(rig, c + 0.5 * o.length_mm * d, &ob)) {
            continue;
          }
          ends.push_back(std::move(oa));
          ends.push_back(std::move(ob));
          placed.emplace_back(c, d);
        }
      }
    }
    const auto pts = TriangulateMany(rig, ends, to, o.num_threads);
    std::vector<Point> cpts;
    if (central) cpts = TriangulateMany(*central, ends, to_central, o.num_threads);
    std::vector<double> sigma, cerr;
    for (std::size_t i = 0; i + 1 < pts.size(); i += 2) {
      if (!pts[i].ok || !pts[i + 1].ok) continue;
      PlannedLength l;
      l.centre_mm = placed[i / 2].first;
      l.direction = placed[i / 2].second;
      l.end_a = ends[i];
      l.end_b = ends[i + 1];
      l.sigma_mm = MeasureLength(rig, pts[i], pts[i + 1]).sigma_mm;
      sigma.push_back(l.sigma_mm);
      if (central && cpts[i].ok && cpts[i + 1].ok) {
        l.central_error_mm = (cpts[i + 1].x_mm - cpts[i].x_mm).norm() - o.length_mm;
        cerr.push_back(l.central_error_mm);
      }
      row.lengths.push_back(std::move(l));
    }
    row.n_lengths = static_cast<int>(sigma.size());
    if (!sigma.empty()) {
      row.sigma_median_mm = Quantile(sigma, 0.5);
      row.sigma_p90_mm = Quantile(sigma, 0.9);
      row.sigma_max_mm = *std::max_element(sigma.begin(), sigma.end());
      row.sigma_median_percent = 100 * row.sigma_median_mm / o.length_mm;
    }
    if (!cerr.empty()) {
      std::vector<double> a;
      double mean = 0;
      for (double e : cerr) a.push_back(std::abs(e)), mean += e / cerr.size();
      row.central_abs_median_mm = Quantile(a, 0.5);
      row.central_abs_max_mm = *std::max_element(a.begin(), a.end());
      row.central_mean_mm = mean;
      row.central_abs_max_percent = 100 * row.central_abs_max_mm / o.length_mm;
    }
    plan.rows.push_back(row);
  }
  bool any = false;
  for (const auto& r : plan.rows) any |= r.n_lengths > 0;
  if (!any) {
    plan.notes.push_back(fmt::format("no {:g} mm length fits in the field every camera sees at these ranges",
                                     o.length_mm));
  }
  return plan;
}

nlohmann::ordered_json RigPlanToJson(const RigPlan& p, const std::string& rig) {
  using Json = nlohmann::ordered_json;
  const auto num = [](double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); };
  Json rows = Json::array();
  for (const auto& r : p.rows) {
    rows.push_back({{"range_mm", r.range_mm},
                    {"common_width_mm", r.common_width_mm},
                    {"common_height_mm", r.common_height_mm},
                    {"n_lengths", r.n_lengths},
                    {"sigma_median_mm", num(r.sigma_median_mm)},
                    {"sigma_p90_mm", num(r.sigma_p90_mm)},
                    {"sigma_max_mm", num(r.sigma_max_mm)},
                    {"sigma_median_percent", num(r.sigma_median_percent)},
                    {"central_abs_median_mm", num(r.central_abs_median_mm)},
                    {"central_abs_max_mm", num(r.central_abs_max_mm)},
                    {"central_mean_mm", num(r.central_mean_mm)},
                    {"central_abs_max_percent", num(r.central_abs_max_percent)}});
  }
  return {{"rig_plan",
           {{"rig", rig},
            {"sigma_px", p.sigma_px},
            {"length_mm", p.length_mm},
            {"orientations", p.orientations},
            {"sigma_holds", p.calibration_sigma},
            {"range", "depth along the first camera's axis (rig frame z), mm"},
            {"central_model",
             {{"compared", p.central},
              {"meaning", "each camera's lens model without refraction, calibrated with the rig under water on "
                          "noise-free views of a chessboard at fit_range_mm +- 25 %; error = its length - the true "
                          "length"},
              {"models", p.central_models},
              {"fit_range_mm", num(p.central_fit_range_mm)},
              {"fit_rms_px", num(p.central_fit_rms_px)}}},
            {"ranges", rows},
            {"notes", p.notes}}}};
}

}  // namespace porthole::measure
