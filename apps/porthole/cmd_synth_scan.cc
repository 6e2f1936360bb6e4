// `porthole synth-scan OUT`: a synthetic scan of a spherical cap (a dome surface) with noise and
// gross outliers, written as PLY or XYZ, to test fits against known ground truth.
#include <fmt/format.h>

#include "commands.h"
#include "common.h"
#include "porthole/core/error.h"
#include "porthole/pointcloud/pointcloud.h"
#include "porthole/pointcloud/synthetic.h"

namespace porthole::cli {

void RegisterSynthScan(CLI::App& app) {
  struct Options {
    std::string out;
    pointcloud::SyntheticCapOptions cap;
    std::vector<double> center{-0.4, -1.0, 21.5}, axis{0, 0, 1};
    bool ascii = false;
    bool json = false, force = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "synth-scan", "Write a synthetic scan of a spherical cap (mm) with noise and outliers");
  cmd->add_option("out", o->out, "Output file: .ply (binary unless --ascii), .xyz, .csv or .txt")
      ->required();
  cmd->add_option("--radius", o->cap.radius_mm, "Sphere radius, mm")->capture_default_str();
  cmd->add_option("--center", o->center, "Sphere centre X,Y,Z, mm")
      ->delimiter(',')
      ->expected(3)
      ->capture_default_str();
  cmd->add_option("--axis", o->axis, "Cap axis (pole direction) X,Y,Z")
      ->delimiter(',')
      ->expected(3)
      ->capture_default_str();
  cmd->add_option("--half-angle", o->cap.half_angle_deg,
                  "Cap half angle from the axis, deg (90 = hemisphere)")
      ->capture_default_str();
  cmd->add_option("--spacing", o->cap.spacing_mm,
                  "Point spacing, mm (one point per spacing^2 of surface)")
      ->capture_default_str();
  cmd->add_option("--points", o->cap.n_points, "Number of points (overrides --spacing)");
  cmd->add_option("--noise", o->cap.noise_sigma_mm, "Gaussian noise sigma per axis, mm")
      ->capture_default_str();
  cmd->add_option("--outliers", o->cap.outlier_fraction,
                  "Fraction of points replaced by gross outliers, [0, 1)")
      ->capture_default_str();
  cmd->add_option("--outlier-margin", o->cap.outlier_margin_mm,
                  "Outliers fill the cap's bounding box grown by this, mm")
      ->capture_default_str();
  cmd->add_option("--seed", o->cap.seed, "Random seed (same seed, same scan)")
      ->capture_default_str();
  cmd->add_flag("--ascii", o->ascii, "ASCII PLY instead of binary little endian");
  cmd->add_flag("--json", o->json, "Print the summary as JSON");
  AddForceFlag(cmd, &o->force);
  cmd->callback([o] {
    CheckOutput(o->out, "out", OutputRules{.force = o->force, .inputs = {}});  // WritePointCloud then replaces it
    o->cap.center_mm = Eigen::Vector3d(o->center[0], o->center[1], o->center[2]);
    o->cap.axis = Eigen::Vector3d(o->axis[0], o->axis[1], o->axis[2]);
    const pointcloud::SyntheticCap cap = pointcloud::MakeSyntheticCap(o->cap);
    pointcloud::WritePointCloud(o->out, cap.points, nullptr, {.binary = !o->ascii});
    const auto n_out = std::count(cap.is_outlier.begin(), cap.is_outlier.end(), true);
    if (o->json) {
      const Json j = {{"out", o->out}, {"points", cap.points.cols()}, {"outliers", n_out},
                      {"center_mm", o->center}, {"radius_mm", o->cap.radius_mm},
                      {"half_angle_deg", o->cap.half_angle_deg}, {"noise_mm", o->cap.noise_sigma_mm}};
      fmt::print("{}\n", j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace));
      return;
    }
    fmt::print(
        "wrote {} points ({} outliers) to {}: sphere centre ({}, {}, {}) mm, R {} mm, half angle "
        "{} deg, noise {} mm\n",
        cap.points.cols(), n_out, o->out, o->center[0], o->center[1], o->center[2],
        o->cap.radius_mm, o->cap.half_angle_deg, o->cap.noise_sigma_mm);
  });
}

}  // namespace porthole::cli
