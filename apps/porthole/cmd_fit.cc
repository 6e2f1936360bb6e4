// `porthole fit sphere|plane|circle FILE`: fit a shape to a point cloud (scan or targets) and print
// the result with its σ, as a table or JSON; optionally write the per-point residuals as PLY.
#include <fmt/format.h>

#include "commands.h"
#include "common.h"
#include "porthole/core/error.h"
#include "porthole/fit/plane_fit.h"
#include "porthole/fit/sphere_fit.h"
#include "porthole/pointcloud/pointcloud.h"

namespace porthole::cli {

void RegisterFit(CLI::App& app) {
  struct Options {
    std::string shape, file, loss = "cauchy", residuals;
    bool robust = false, json = false, force = false;
    double threshold_mm = fit::SphereFitOptions{}.inlier_threshold_mm;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "fit", "Fit a sphere, plane or 3D circle to a point cloud (PLY, XYZ/CSV/TXT, OBJ, STL; mm)");
  cmd->add_option("shape", o->shape, "sphere | plane | circle")
      ->required()
      ->check(CLI::IsMember({"sphere", "plane", "circle"}));
  cmd->add_option("file", o->file, "Point cloud file")->required();
  cmd->add_flag("--robust", o->robust,
                "Sphere: MSAC start + robust loss, for scans with gross outliers");
  cmd->add_option("--loss", o->loss, "Robust loss: huber | cauchy")
      ->check(CLI::IsMember({"huber", "cauchy"}))
      ->capture_default_str();
  cmd->add_option("--threshold", o->threshold_mm,
                  "MSAC inlier threshold and loss scale, mm (3-5x scanner sigma)")
      ->capture_default_str();
  cmd->add_flag("--json", o->json, "JSON output for scripts");
  cmd->add_option("--residuals", o->residuals,
                  "Write points with their residual (mm) to this PLY/XYZ file");
  AddForceFlag(cmd, &o->force);
  cmd->callback([o] {
    if (o->robust && o->shape != "sphere") throw InvalidInput("--robust", "only for 'sphere'");
    // The scan is an input: never replaced by its residuals (WritePointCloud then writes the file).
    if (!o->residuals.empty()) CheckOutput(o->residuals, "--residuals", OutputRules{.force = o->force, .inputs = {o->file}});
    const auto cloud = pointcloud::ReadPointCloud(o->file);
    Json j{{"shape", o->shape}, {"file", o->file}, {"n_points", cloud.size()}};
    std::vector<std::tuple<std::string, double, double, std::string>> rows;  // name, value, σ, unit
    auto vec = [&](const std::string& name, const Eigen::Vector3d& v, const Eigen::Vector3d& s,
                   const char* unit) {
      for (int k = 0; k < 3; ++k)
        rows.emplace_back(fmt::format("{} {}", name, "xyz"[k]), v[k], s[k], unit);
    };
    Eigen::VectorXd res;
    std::string status;
    double rms = 0, max_abs = 0;
    if (o->shape == "sphere") {
      fit::SphereFitOptions fo;
      fo.robust = o->robust;
      fo.loss = o->loss == "huber" ? fit::RobustLoss::kHuber : fit::RobustLoss::kCauchy;
      fo.inlier_threshold_mm = RequirePositive("--threshold", o->threshold_mm);
      const auto s = fit::FitSphere(cloud.points, fo);
      vec("centre", s.sphere.center_mm, s.sigma_center_mm, "mm");
      rows.emplace_back("radius", s.sphere.radius_mm, s.sigma_radius_mm, "mm");
      rows.emplace_back("inliers", static_cast<double>(s.n_inliers), NAN, "points");
      j.update({{"center_mm", Vec3Json(s.sphere.center_mm)},
                {"sigma_center_mm", Vec3Json(s.sigma_center_mm)},
                {"radius_mm", Length(s.sphere.radius_mm)},
                {"sigma_radius_mm", Length(s.sigma_radius_mm)},
                {"n_inliers", s.n_inliers},
                {"robust", o->robust}});
      res = s.residuals_mm, rms = s.rms_mm, max_abs = s.max_abs_residual_mm;
      status = s.IsUsable() ? "ok" : CliWords(s.message);
    } else if (o->shape == "plane") {
      const auto s = fit::FitPlane(cloud.points);
      vec("normal", s.plane.normal, s.sigma_normal, "");
      rows.emplace_back("offset", s.plane.offset_mm, s.sigma_offset_mm, "mm");
      rows.emplace_back("tilt sigma", s.sigma_tilt_rad * 180 / M_PI, NAN, "deg");
      j.update({{"normal", Vec3Json(s.plane.normal)},
                {"sigma_tilt_deg", Length(s.sigma_tilt_rad * 180 / M_PI)},
                {"offset_mm", Length(s.plane.offset_mm)},
                {"sigma_offset_mm", Length(s.sigma_offset_mm)},
                {"centroid_mm", Vec3Json(s.centroid_mm)}});
      res = s.residuals_mm, rms = s.rms_mm, max_abs = s.max_abs_residual_mm;
      status = s.IsUsable() ? "ok" : "exact fit through 3 points: no sigma";
    } else {
      const auto s = fit::FitCircle3d(cloud.points);
      vec("centre", s.circle.center_mm, s.sigma_center_mm, "mm");
      rows.emplace_back("radius", s.circle.radius_mm, s.sigma_radius_mm, "mm");
      vec("normal", s.circle.normal, s.plane.sigma_normal, "");
      j.update({{"center_mm", Vec3Json(s.circle.center_mm)},
                {"sigma_center_mm", Vec3Json(s.sigma_center_mm)},
                {"radius_mm", Length(s.circle.radius_mm)},
                {"sigma_radius_mm", Length(s.sigma_radius_mm)},
                {"normal", Vec3Json(s.circle.normal)},
                {"sigma_normal_deg", Length(s.sigma_normal_rad * 180 / M_PI)},
                {"plane_rms_mm", Length(s.plane.rms_mm)}});
      res = s.residuals_mm, rms = s.rms_mm, max_abs = s.max_abs_residual_mm;
      status = s.IsUsable() ? "ok" : CliWords(s.message);
    }
    j.update({{"rms_mm", Length(rms)},
              {"max_abs_residual_mm", Length(max_abs)},
              {"usable", status == "ok"},
              {"status", status}});
    if (!o->residuals.empty()) pointcloud::WritePointCloud(o->residuals, cloud.points, &res);
    if (o->json) return fmt::print("{}\n", j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace));
    rows.emplace_back("rms residual", rms, NAN, "mm");
    rows.emplace_back("max |residual|", max_abs, NAN, "mm");
    std::string text = fmt::format("{} fit to {} ({} points)\n{:<16} {:>14} {:>10}  {}\n", o->shape,
                                   o->file, cloud.size(), "quantity", "value", "sigma", "unit");
    for (const auto& [name, v, s, unit] : rows)
      text += fmt::format("{:<16} {:>14} {:>10}  {}\n", name, Fixed(v, unit == "points" ? 0 : 4),
                          Fixed(s, 4), unit);
    fmt::print("{}status: {}\n", text, status);
  });
}

}  // namespace porthole::cli
