// `porthole compare A B`: two calibrations of one camera (e.g. in air and under water) side by
// side with σ, the paper's Fig. 14 curves and Fig. 15 maps, and a χ² test of the difference.
// A and B are calibrations in any format interop reads (porthole JSON, OpenCV YAML, COLMAP, mrcal,
// Metashape), detected from the file; of two models, the one not Brown is refit to Brown.
#include <fmt/format.h>

#include <filesystem>

#include "commands.h"
#include "common.h"
#include "porthole/calib/compare.h"
#include "porthole/camera/json.h"
#include "porthole/core/atomic_file.h"
#include "porthole/core/error.h"
#include "porthole/interop/interop.h"

namespace porthole::cli {
namespace {

Json Num(double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); }

}  // namespace

void RegisterCompare(CLI::App& app) {
  struct Options {
    std::string a, b, csv_dir;
    double pitch_mm = 1.0;
    calib::CompareOptions compare;
    bool json = false, force = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "compare", "Compare two calibrations: parameters with std, distortion curves and maps, chi2");
  cmd->add_option("A", o->a,
                  "Calibration: porthole JSON, OpenCV YAML, COLMAP cameras.txt/.bin, mrcal .cameramodel or "
                  "Metashape XML (detected from the file)")
      ->required();
  cmd->add_option("B", o->b, "The second calibration (any of those formats)")->required();
  cmd->add_option("--pixel-pitch-mm", o->pitch_mm, "Pixel pitch for inputs without one (all but porthole JSON), mm")
      ->capture_default_str();
  cmd->add_option("--alpha", o->compare.alpha, "Significance level of the chi2 test")
      ->capture_default_str();
  cmd->add_option("--map-cols", o->compare.map_cols, "Distortion map columns")->capture_default_str();
  cmd->add_option("--map-rows", o->compare.map_rows, "Distortion map rows")->capture_default_str();
  cmd->add_option("--csv-dir", o->csv_dir,
                  "Write curves.csv (Fig. 14) and map.csv (Fig. 15) into this directory (created if missing)");
  cmd->add_flag("--json", o->json, "JSON output for scripts");
  AddForceFlag(cmd, &o->force);
  cmd->callback([o, cmd] {
    if (!(o->compare.alpha > 0 && o->compare.alpha < 1)) throw InvalidInput("--alpha", "in (0, 1)");
    const OutputRules rules{.force = o->force, .inputs = InputFiles(cmd, {"--csv-dir"})};
    if (!o->csv_dir.empty()) {
      EnsureOutputDirectory(o->csv_dir, "--csv-dir");
      for (const char* name : {"curves.csv", "map.csv"}) CheckOutput(std::filesystem::path(o->csv_dir) / name, "--csv-dir", rules);
    }
    if (o->pitch_mm != 1.0) WarnIfImplausible("--pixel-pitch-mm", o->pitch_mm, kPixelPitchRange);
    auto ra = interop::ReadCalibrationFile(o->a, o->pitch_mm, "A");
    auto rb = interop::ReadCalibrationFile(o->b, o->pitch_mm, "B");
    // One model for both: Brown (the paper's) when either is Brown, else A's; the other is refit.
    const auto model = ra.camera().model == camera::CameraModelId::kBrown ||
                               rb.camera().model == camera::CameraModelId::kBrown
                           ? camera::CameraModelId::kBrown
                           : ra.camera().model;
    ra = interop::ConvertRead(std::move(ra), model, "A");
    rb = interop::ConvertRead(std::move(rb), model, "B");
    const auto& a = ra.calibration;
    const auto& b = rb.calibration;
    const camera::ConversionFit fit_a = ra.exact ? camera::ConversionFit{} : ra.fit;
    const camera::ConversionFit fit_b = rb.exact ? camera::ConversionFit{} : rb.fit;
    // A file without a pixel pitch (all formats but porthole JSON) is read at --pixel-pitch-mm: say
    // how to make it match the other's instead of only that the sensors differ.
    const double pa = a.camera.sensor.pixel_pitch_mm, pb = b.camera.sensor.pixel_pitch_mm;
    if (pa != pb && ra.pitch_known != rb.pitch_known) {
      const bool a_known = ra.pitch_known;
      const std::string& known_file = a_known ? o->a : o->b;
      const std::string& other_file = a_known ? o->b : o->a;
      const double known = a_known ? pa : pb;
      throw InvalidInput("--pixel-pitch-mm",
                         fmt::format("{} ({}) holds no pixel pitch and was read at {:g} mm, but {} gives "
                                     "{:g} mm: pass --pixel-pitch-mm {:g}",
                                     other_file, interop::FormatName((a_known ? rb : ra).format),
                                     a_known ? pb : pa, known_file, known, known));
    }
    const auto r = calib::Compare(a, b, o->compare);

    std::string curves_csv = "r_mm,radial_a_um,radial_b_um,decentring_a_um,decentring_b_um\n";
    for (const auto& p : r.curves) {
      curves_csv += fmt::format("{:.6g},{:.6g},{:.6g},{:.6g},{:.6g}\n", p.r_mm, p.radial_a_um,
                                p.radial_b_um, p.decentring_a_um, p.decentring_b_um);
    }
    std::string map_csv = "u_px,v_px,x_mm,y_mm,a_um,b_um,diff_um,ax_um,ay_um,bx_um,by_um\n";
    for (const auto& p : r.map) {
      map_csv += fmt::format("{:.6g},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g},{:.6g},"
                             "{:.6g},{:.6g}\n", p.u_px, p.v_px, p.x_mm, p.y_mm, p.a_um.norm(),
                             p.b_um.norm(), p.diff_um.norm(), p.a_um.x(), p.a_um.y(), p.b_um.x(),
                             p.b_um.y());
    }
    if (!o->csv_dir.empty()) {
      WriteOutput(std::filesystem::path(o->csv_dir) / "curves.csv", curves_csv, "--csv-dir", rules);
      WriteOutput(std::filesystem::path(o->csv_dir) / "map.csv", map_csv, "--csv-dir", rules);
    }
    const std::string verdict =
        !std::isfinite(r.chi2) ? "chi2 not computed: " + r.covariance_note
        : fmt::format("chi2 = {:.2f} with {} dof (the parameters both calibrations adjusted), p = {:.3g}: "
                      "the calibrations {} at alpha {:g} (covariance: {})", r.chi2, r.dof, r.p_value,
                      r.significant ? "DIFFER significantly" : "do not differ significantly",
                      o->compare.alpha, r.covariance_note);
    if (o->json) {
      Json j = calib::CompareToJson(r, o->a, o->b, /*with_map=*/true);
      j["alpha"] = o->compare.alpha;
      j["verdict"] = verdict;
      j["map_cols"] = o->compare.map_cols;
      j["map_rows"] = o->compare.map_rows;
      if (fit_a.num_points > 0) {
        j["a_refit_rms_px"] = Num(fit_a.rms_px);
        j["a_refit_points_not_projected"] = fit_a.num_not_projected;
      }
      if (fit_b.num_points > 0) {
        j["b_refit_rms_px"] = Num(fit_b.rms_px);
        j["b_refit_points_not_projected"] = fit_b.num_not_projected;
      }
      return fmt::print("{}\n", j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace));
    }
    auto cell = [](bool adj, double v, double s) {  // σ "?": unknown (the format holds none)
      return adj ? fmt::format("{:>12.5g} {:>9}", v, std::isfinite(s) ? fmt::format("{:.2g}", s) : "?")
                 : fmt::format("{:>12} {:>9}", v != 0 ? fmt::format("{:.5g}", v) : "-", "-");
    };
    std::string t = fmt::format("A = {}   B = {}\n{:<8} {:>22} {:>22} {:>12} {:>7}\n", o->a, o->b,
                                "param", "A value      std", "B value      std", "B - A", "z");
    for (const auto& row : r.rows) {
      t += fmt::format("{:<8} {} {} {:>12.4g} {:>7}\n",
                       camera::Info(r.model).params[row.index].json_key,
                       cell(row.adjusted_a, row.a, row.sigma_a),
                       cell(row.adjusted_b, row.b, row.sigma_b), row.diff,
                       std::isfinite(row.z) ? fmt::format("{:.1f}", row.z)
                       : row.left_out.empty() ? "" : "out");
    }
    t += "radial dr(r) and decentring P(r), um (Fig. 14):\n   r_mm   dr_A   dr_B    P_A    P_B\n";
    const int step = std::max(1, static_cast<int>(r.curves.size()) / 8);
    for (std::size_t k = 0; k < r.curves.size(); k += step) {
      const auto& p = r.curves[k];
      t += fmt::format("{:7.2f} {:6.1f} {:6.1f} {:6.2f} {:6.2f}\n", p.r_mm, p.radial_a_um,
                       p.radial_b_um, p.decentring_a_um, p.decentring_b_um);
    }
    t += fmt::format("distortion maps (Fig. 15): max |D| A {:.1f} um, B {:.1f} um, A-B {:.1f} um\n",
                     r.max_a_um, r.max_b_um, r.max_diff_um);
    if (a.camera.sensor.pixel_pitch_mm == 1.0) t += "pitch 1: millimetres are pixels, um are 1e-3 px\n";
    if (fit_a.num_points > 0) t += "A " + interop::DescribeRead(ra, o->a) + "\n";
    if (fit_b.num_points > 0) t += "B " + interop::DescribeRead(rb, o->b) + "\n";
    if (!r.left_out_note.empty()) t += r.left_out_note + "\n";
    fmt::print("{}{}\n", t, verdict);
  });
}

}  // namespace porthole::cli
