// Comparison of two calibrations of one camera (the paper's Section 5: in air vs under water):
//  - the parameter tables side by side with σ, the difference, its σ and z = Δ/σΔ;
//  - radial profile δr(r) = K1 r³ + K2 r⁵ + K3 r⁷ and decentring profile P(r) = sqrt(P1²+P2²) r²
//    of each (camera/profile.h; µm against r in mm from the principal point; the paper's Fig. 14);
//  - distortion maps: the correction vector Δ (camera::Correction, µm) of each over the image and
//    their difference Δa − Δb at the same measured point (Fig. 15 a, b, c);
//  - a χ² test of the difference: Δpᵀ(Σa + Σb)⁻¹Δp over the parameters BOTH calibrations
//    adjusted, against χ² with that many degrees of freedom. A parameter adjusted in only one is
//    left out (and listed with the reason): the other holds a fixed value with no variance, so
//    the one σ alone would decide — a refit from another format (e.g. B1, B2 of a Brown camera
//    read back from Metashape's fx, fy) carries a tiny propagated σ that made any round trip
//    "differ". Without a full covariance the σ give a diagonal one.
#pragma once

#include <string>
#include <vector>

#include "porthole/calib/result_json.h"

namespace porthole::calib {

struct CompareOptions {
  int curve_points = 41;  // radii from 0 to the frame corner
  int map_cols = 33;      // distortion map grid over the whole frame (pixel centres 0 … W−1)
  int map_rows = 22;
  double alpha = 0.05;    // significance level of the χ² test
};

struct CompareRow {
  int index = 0;          // parameter index in the model's order
  bool adjusted_a = false, adjusted_b = false;
  double a = 0, sigma_a = NAN, b = 0, sigma_b = NAN;
  double diff = 0;        // b − a
  double sigma_diff = NAN;
  double z = NAN;         // diff / sigma_diff, for a tested parameter only
  bool tested = false;    // in the χ² (adjusted in both)
  std::string left_out;   // why not, for a parameter adjusted in one only ("adjusted in B only")
};

struct CurvePoint {
  double r_mm = 0;
  double radial_a_um = 0, radial_b_um = 0;
  double decentring_a_um = 0, decentring_b_um = 0;
};

struct ComparePoint {
  double x_mm = 0, y_mm = 0, u_px = 0, v_px = 0;
  Eigen::Vector2d a_um = Eigen::Vector2d::Zero(), b_um = Eigen::Vector2d::Zero();
  Eigen::Vector2d diff_um = Eigen::Vector2d::Zero();  // a − b
};

struct CompareResult {
  camera::CameraModelId model = camera::CameraModelId::kBrown;  // of both calibrations
  std::vector<CompareRow> rows;
  std::vector<CurvePoint> curves;
  std::vector<ComparePoint> map;  // row-major from the top-left pixel
  double max_a_um = 0, max_b_um = 0, max_diff_um = 0;  // largest |Δ| over the map
  double chi2 = NAN;
  int dof = 0;
  double p_value = NAN;          // P(χ²_dof ≥ chi2)
  bool significant = false;      // p_value < alpha
  std::string covariance_note;   // "full" or why not
  std::vector<int> tested;       // the parameters of the χ² (adjusted in both), model order
  std::vector<int> left_out;     // adjusted in one calibration only: not in the χ²
  // One sentence naming the left-out parameters and why ("" when none).
  std::string left_out_note;
};

// Throws InvalidInput("B") if the sensors (size or pitch; the message gives both) or the models differ. Curves and maps
// are computed for the Brown model only (empty otherwise).
CompareResult Compare(const CalibrationRecord& a, const CalibrationRecord& b,
                      const CompareOptions& options = {});

// The comparison as JSON, with the keys of `porthole compare --json` (which adds its options):
// a, b (the labels), parameters [{parameter, a, sigma_a, b, sigma_b, diff_b_minus_a, sigma_diff,
// z, tested, left_out (null or the reason)}], units, chi2, dof, p_value, significant, covariance,
// tested [keys], left_out [{parameter, reason}], left_out_note, max_a_um, max_b_um, max_diff_um,
// curves [{r_mm, radial_a_um, radial_b_um, decentring_a_um, decentring_b_um}] and, with_map,
// map [{u_px, v_px, x_mm, y_mm, a_um, b_um, diff_um}]. Non-finite numbers are null.
nlohmann::ordered_json CompareToJson(const CompareResult& r, const std::string& a_label,
                                     const std::string& b_label, bool with_map);

// Upper regularised incomplete gamma Q(s, x): the χ² survival function is Q(dof/2, χ²/2).
double UpperIncompleteGammaQ(double s, double x);

}  // namespace porthole::calib
