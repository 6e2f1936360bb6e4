#include "porthole/calib/compare.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "porthole/camera/json.h"
#include "porthole/camera/profile.h"
#include "porthole/camera/sensor.h"
#include "porthole/core/error.h"

namespace porthole::calib {

double UpperIncompleteGammaQ(double s, double x) {
  if (x <= 0) return 1.0;
  const double log_prefix = s * std::log(x) - x - std::lgamma(s);
  if (x < s + 1) {  // series for P(s, x)
    double sum = 1.0 / s, term = sum;
    for (int n = 1; n < 1000 && std::abs(term) > 1e-17 * std::abs(sum); ++n) {
      term *= x / (s + n);
      sum += term;
    }
    return 1.0 - sum * std::exp(log_prefix);
  }
  // Continued fraction for Q(s, x) (modified Lentz).
  const double tiny = 1e-300;
  double b = x + 1 - s, c = 1 / tiny, d = 1 / b, h = d;
  for (int i = 1; i < 1000; ++i) {
    const double an = -i * (i - s);
    b += 2;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1) < 1e-16) break;
  }
  return std::exp(log_prefix) * h;
}

namespace {

// The variance of parameter i when the record knows it (positive and finite), else NaN.
double KnownVariance(const CalibrationRecord& c, int i) {
  const double v = c.covariance.rows() > i ? c.covariance(i, i) : NAN;
  return v > 0 && std::isfinite(v) ? v : NAN;
}

}  // namespace

CompareResult Compare(const CalibrationRecord& a, const CalibrationRecord& b,
                      const CompareOptions& o) {
  const camera::Sensor& s = a.camera.sensor;
  const camera::Sensor& sb = b.camera.sensor;
  if (s.width_px != sb.width_px || s.height_px != sb.height_px ||
      s.pixel_pitch_mm != sb.pixel_pitch_mm) {
    throw InvalidInput("B", fmt::format("the two calibrations are of different sensors: A {}x{} px, pixel "
                                        "pitch {:g} mm; B {}x{} px, pixel pitch {:g} mm",
                                        s.width_px, s.height_px, s.pixel_pitch_mm, sb.width_px,
                                        sb.height_px, sb.pixel_pitch_mm));
  }
  if (a.camera.model != b.camera.model) {
    throw InvalidInput("B", "A is a " + std::string(a.camera.model_name()) + " calibration, B a " +
                                std::string(b.camera.model_name()) +
                                " one: compare calibrations of one model");
  }

  if (o.curve_points < 2 || o.map_cols < 2 || o.map_rows < 2) {
    throw InvalidInput("map", "at least 2 curve points and a 2x2 map");
  }
  CompareResult r;
  r.model = a.camera.model;
  const std::vector<double>& va = a.camera.params;
  const std::vector<double>& vb = b.camera.params;
  std::vector<int>& tested = r.tested;
  bool untested_sigma = false;
  std::string only_a, only_b;  // keys adjusted in one calibration only
  for (int i = 0; i < a.camera.info().num_params; ++i) {
    CompareRow row;
    row.index = i;
    row.adjusted_a = a.free[i];
    row.adjusted_b = b.free[i];
    row.a = va[i];
    row.b = vb[i];
    row.diff = vb[i] - va[i];
    // σ of an adjusted parameter is known only as a positive finite variance: a format without σ
    // (OpenCV YAML, COLMAP, mrcal) leaves it unknown (NaN), never 0, so it cannot make z large.
    const double var_a = a.free[i] ? KnownVariance(a, i) : 0;
    const double var_b = b.free[i] ? KnownVariance(b, i) : 0;
    if (a.free[i]) row.sigma_a = std::sqrt(var_a);
    if (b.free[i]) row.sigma_b = std::sqrt(var_b);
    if (a.free[i] || b.free[i]) row.sigma_diff = std::sqrt(var_a + var_b);  // NaN when a σ is unknown
    if (a.free[i] && b.free[i]) {
      row.tested = true;
      row.z = row.diff / row.sigma_diff;
      tested.push_back(i);
      if (!std::isfinite(row.sigma_diff)) untested_sigma = true;
    } else if (a.free[i] || b.free[i]) {
      // A fixed value has no variance: the other σ alone would decide, and a parameter a
      // conversion refit (B1, B2 from Metashape's fx, fy) has a tiny one. Not tested.
      row.left_out = a.free[i] ? "adjusted in A only" : "adjusted in B only";
      r.left_out.push_back(i);
      std::string& list = a.free[i] ? only_a : only_b;
      list += (list.empty() ? "" : ", ") + std::string(a.camera.info().params[i].json_key);
    }
    r.rows.push_back(row);
  }
  if (!r.left_out.empty()) {
    std::string which;
    if (!only_a.empty()) which += only_a + " (adjusted in A only)";
    if (!only_b.empty()) which += (which.empty() ? "" : "; ") + only_b + " (adjusted in B only)";
    r.left_out_note = "left out of chi2: " + which +
                      ": a parameter fixed in one calibration has no variance there to test against, "
                      "and a refit from another format can give it a tiny one";
  }

  // χ² on the parameters adjusted in both calibrations.
  const auto any = [](const FreeMask& f) { return std::find(f.begin(), f.end(), true) != f.end(); };
  const auto why = [](const CalibrationRecord& c, const char* name) {
    return std::string(name) + (c.covariance_note.empty() ? " has no covariance" : ": " + c.covariance_note);
  };
  if (!a.has_covariance && any(a.free)) {
    r.covariance_note = why(a, "A") + "; no significance test";
  } else if (!b.has_covariance && any(b.free)) {
    r.covariance_note = why(b, "B") + "; no significance test";
  } else if (untested_sigma) {
    r.covariance_note = "a σ is unknown; no significance test";
  } else if (tested.empty()) {
    r.covariance_note = "no parameter adjusted in both; no significance test";
  } else {
    const int n = static_cast<int>(tested.size());
    Eigen::MatrixXd sum(n, n);
    Eigen::VectorXd dp(n);
    for (int p = 0; p < n; ++p) {
      dp(p) = r.rows[tested[p]].diff;
      for (int q = 0; q < n; ++q) {
        const int i = tested[p], j = tested[q];
        sum(p, q) = (a.free[i] && a.free[j] ? a.covariance(i, j) : 0) +
                    (b.free[i] && b.free[j] ? b.covariance(i, j) : 0);
      }
    }
    // Scale to unit diagonal first: the parameters span ~20 orders of magnitude.
    const Eigen::VectorXd s = sum.diagonal().cwiseSqrt().cwiseInverse();
    const Eigen::MatrixXd corr = s.asDiagonal() * sum * s.asDiagonal();
    const Eigen::VectorXd zs = s.asDiagonal() * dp;
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(corr);
    if (n > 0 && ldlt.info() == Eigen::Success && ldlt.isPositive()) {
      r.chi2 = zs.dot(ldlt.solve(zs));
      r.dof = n;
      r.p_value = UpperIncompleteGammaQ(0.5 * n, 0.5 * r.chi2);
      r.significant = r.p_value < o.alpha;
      r.covariance_note = a.covariance_note.empty() && b.covariance_note.empty()
                              ? "full"
                              : "A: " + (a.covariance_note.empty() ? "full" : a.covariance_note) +
                                    ", B: " + (b.covariance_note.empty() ? "full" : b.covariance_note);
    } else {
      r.covariance_note = "Σa + Σb is singular";
    }
  }

  // The curves and maps are the Brown model's (the paper's Figs. 14-15).
  if (r.model != camera::CameraModelId::kBrown) return r;
  const camera::BrownParams ba = camera::ToBrown(a.camera, "A");
  const camera::BrownParams bb = camera::ToBrown(b.camera, "B");
  // Curves to the frame corner, from each calibration's principal point.
  const double r_max = 0.5 * std::hypot(s.width_px, s.height_px) * s.pixel_pitch_mm;
  for (int k = 0; k < o.curve_points; ++k) {
    CurvePoint c;
    c.r_mm = r_max * k / (o.curve_points - 1);
    c.radial_a_um = 1e3 * camera::RadialProfileMm(ba, c.r_mm);
    c.radial_b_um = 1e3 * camera::RadialProfileMm(bb, c.r_mm);
    c.decentring_a_um = 1e3 * camera::DecentringProfileMm(ba, c.r_mm);
    c.decentring_b_um = 1e3 * camera::DecentringProfileMm(bb, c.r_mm);
    r.curves.push_back(c);
  }
  // Maps: Δ of each at the same measured image point.
  for (int j = 0; j < o.map_rows; ++j) {
    for (int i = 0; i < o.map_cols; ++i) {
      ComparePoint p;
      p.u_px = i * (s.width_px - 1.0) / (o.map_cols - 1);
      p.v_px = j * (s.height_px - 1.0) / (o.map_rows - 1);
      const Eigen::Vector2d xy = camera::PixelToImageMm(s, p.u_px, p.v_px);
      p.x_mm = xy.x();
      p.y_mm = xy.y();
      p.a_um = 1e3 * camera::Correction(ba, xy.x(), xy.y());
      p.b_um = 1e3 * camera::Correction(bb, xy.x(), xy.y());
      p.diff_um = p.a_um - p.b_um;
      r.max_a_um = std::max(r.max_a_um, p.a_um.norm());
      r.max_b_um = std::max(r.max_b_um, p.b_um.norm());
      r.max_diff_um = std::max(r.max_diff_um, p.diff_um.norm());
      r.map.push_back(p);
    }
  }
  return r;
}

nlohmann::ordered_json CompareToJson(const CompareResult& r, const std::string& a_label,
                                     const std::string& b_label, bool with_map) {
  using Json = nlohmann::ordered_json;
  auto num = [](double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); };
  auto vec = [](const Eigen::Vector2d& v) { return Json::array({v.x(), v.y()}); };
  Json rows = Json::array(), curves = Json::array();
  for (const auto& row : r.rows) {
    rows.push_back({{"parameter", std::string(camera::Info(r.model).params[row.index].json_key)},
                    {"a", row.adjusted_a || row.a != 0 ? Json(row.a) : Json(nullptr)},
                    {"sigma_a", num(row.sigma_a)},
                    {"b", row.adjusted_b || row.b != 0 ? Json(row.b) : Json(nullptr)},
                    {"sigma_b", num(row.sigma_b)},
                    {"diff_b_minus_a", row.diff},
                    {"sigma_diff", num(row.sigma_diff)},
                    {"z", num(row.z)},
                    {"tested", row.tested},
                    {"left_out", row.left_out.empty() ? Json(nullptr) : Json(row.left_out)}});
  }
  Json tested = Json::array(), left_out = Json::array();
  for (int i : r.tested) tested.push_back(std::string(camera::Info(r.model).params[i].json_key));
  for (int i : r.left_out) {
    left_out.push_back({{"parameter", std::string(camera::Info(r.model).params[i].json_key)},
                        {"reason", r.rows[i].left_out}});
  }
  for (const auto& p : r.curves) {
    curves.push_back({{"r_mm", p.r_mm}, {"radial_a_um", p.radial_a_um},
                      {"radial_b_um", p.radial_b_um}, {"decentring_a_um", p.decentring_a_um},
                      {"decentring_b_um", p.decentring_b_um}});
  }
  Json j = {{"a", a_label}, {"b", b_label}, {"parameters", rows},
            {"model", std::string(camera::Info(r.model).name)},
            {"units", CameraUnitsJson(r.model)}, {"chi2", num(r.chi2)}, {"dof", r.dof},
            {"p_value", num(r.p_value)}, {"significant", r.significant},
            {"covariance", r.covariance_note}, {"tested", tested}, {"left_out", left_out},
            {"left_out_note", r.left_out_note.empty() ? Json(nullptr) : Json(r.left_out_note)}, {"max_a_um", r.max_a_um},
            {"max_b_um", r.max_b_um}, {"max_diff_um", r.max_diff_um}, {"curves", curves}};
  if (with_map) {
    Json map = Json::array();
    for (const auto& p : r.map) {
      map.push_back({{"u_px", p.u_px}, {"v_px", p.v_px}, {"x_mm", p.x_mm}, {"y_mm", p.y_mm},
                     {"a_um", vec(p.a_um)}, {"b_um", vec(p.b_um)}, {"diff_um", vec(p.diff_um)}});
    }
    j["map"] = map;
  }
  return j;
}

}  // namespace porthole::calib
