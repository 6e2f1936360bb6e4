// calibmar's calibration.yaml (format calibmar): a COLMAP camera (colmap.cc's models) with its σ
// ("# params_est_std_dev") and the refractive housing of its non_svp_model (FLATPORT / DOMEPORT),
// as calibmar (MDSKiel/calibmar, src/calibmar/core/report.cpp, GenerateCalibrationYaml) writes it
// and its ImportFromYaml reads it; docs/interop.md, "Refractive COLMAP and calibmar". The reader and
// writer are declared in interop/refractive.h (with the housing ↔ port conversion, refractive.cc).
#include <fmt/format.h>

#include <Eigen/Core>
#include <cmath>
#include <cstdlib>
#include <optional>
#include <sstream>
#include <string>

#include "porthole/core/error.h"
#include "porthole/interop/interop.h"
#include "porthole/interop/internal.h"
#include "porthole/interop/refractive.h"
#include "porthole/interop/text.h"

namespace porthole::interop {
namespace {

using detail::kDomePortNames;
using detail::kFlatPortNames;
using detail::ShortNum;

// For each COLMAP parameter of `model`, the porthole parameters it sets (FromColmap's mapping).
std::vector<std::vector<int>> ColmapTargets(const std::string& model) {
  if (model == "SIMPLE_PINHOLE") return {{0, 1}, {2}, {3}};
  if (model == "PINHOLE") return {{0}, {1}, {2}, {3}};
  if (model == "SIMPLE_RADIAL") return {{0, 1}, {2}, {3}, {4}};
  if (model == "RADIAL") return {{0, 1}, {2}, {3}, {4}, {5}};
  std::vector<std::vector<int>> t;
  const int n = model == "OPENCV" ? 8 : model == "OPENCV_FISHEYE" ? 8 : model == "FULL_OPENCV" ? 12 : 0;
  for (int i = 0; i < n; ++i) t.push_back({i});
  return t;
}
int PortholeParams(const std::string& model) { return model == "OPENCV_FISHEYE" ? 8 : 12; }

// "a, b, c" (or "[a, b, c]") as at most 32 finite numbers (`allow_nan`: "nan" too, read as NaN).
std::vector<double> Numbers(std::string text, const std::string& field, bool allow_nan = false) {
  text = Trim(text);
  if (!text.empty() && text.front() == '[') {
    if (text.back() != ']') throw InvalidInput(field, "a list [ … ] without its ']'");
    text = text.substr(1, text.size() - 2);
  }
  std::vector<double> out;
  std::stringstream ss(text);
  for (std::string item; std::getline(ss, item, ',');) {
    item = Trim(item);
    if (item.empty() && out.empty() && ss.eof()) break;  // "[]"
    char* end = nullptr;
    const double v = std::strtod(item.c_str(), &end);
    const bool nan_ok = allow_nan && std::isnan(v);
    if (item.empty() || end != item.c_str() + item.size() || !(std::isfinite(v) || nan_ok)) {
      throw InvalidInput(field, "'" + item.substr(0, 40) + "' is not a finite number");
    }
    out.push_back(v);
    if (out.size() > 32) throw InvalidInput(field, "more than 32 numbers");
  }
  return out;
}

}  // namespace

CalibmarFile ParseCalibmarYaml(std::string_view text, const std::string& field) {
  CalibmarFile f;
  std::optional<std::vector<double>> params, housing_params, housing_sigma;
  std::optional<std::string> model, housing_model;
  std::optional<int> width, height;
  std::istringstream in{std::string(text)};
  int line_no = 0;
  for (std::string line; std::getline(in, line);) {
    ++line_no;
    if (line.size() > 65536) throw InvalidInput(fmt::format("{}: line {}", field, line_no), "longer than 64 KiB");
    line = Trim(line);
    const auto value = [&](std::string_view key) -> std::optional<std::string> {
      if (line.rfind(key, 0) != 0) return std::nullopt;
      return Trim(line.substr(key.size()));
    };
    const auto at = [&](std::string_view key) { return field + ": " + std::string(key); };
    const auto whole = [&](const std::string& v, std::string_view key) {
      const auto n = Numbers(v, at(key));
      if (n.size() != 1 || !(n[0] >= 1 && n[0] <= 1e6 && n[0] == std::floor(n[0]))) {
        throw InvalidInput(at(key), "must be a whole number of pixels from 1 to 1000000");
      }
      return static_cast<int>(n[0]);
    };
    if (auto v = value("model:")) {
      model = *v;
    } else if (auto v = value("parameters:")) {
      params = Numbers(*v, at("parameters"));
    } else if (auto v = value("non_svp_model:")) {
      housing_model = *v;
    } else if (auto v = value("non_svp_parameters:")) {
      housing_params = Numbers(*v, at("non_svp_parameters"));
    } else if (auto v = value("width:")) {
      width = whole(*v, "width");
    } else if (auto v = value("height:")) {
      height = whole(*v, "height");
    } else if (auto v = value("# params_est_std_dev:")) {
      // "nan": a σ the writer did not know (porthole before issue 24 wrote it for fixed parameters).
      f.camera_sigma = Numbers(*v, at("params_est_std_dev"), /*allow_nan=*/true);
      for (double sd : f.camera_sigma) {
        if (sd < 0) throw InvalidInput(at("params_est_std_dev"), "a standard deviation must be >= 0 (or nan: unknown)");
      }
    } else if (auto v = value("# non_svp_est_std_dev:")) {
      housing_sigma = Numbers(*v, at("non_svp_est_std_dev"));
    } else if (auto v = value("# overall_rms:")) {
      const auto n = Numbers(*v, at("overall_rms"));
      if (n.size() == 1) f.overall_rms_px = n[0];
    } else if (auto v = value("# target:")) {
      f.target = v->substr(0, 200);
    }
  }
  if (!model) throw InvalidInput(field + ": model", "missing (calibmar writes model: OPENCV, …)");
  if (!params) throw InvalidInput(field + ": parameters", "missing");
  if (!width || !height) throw InvalidInput(field + (width ? ": height" : ": width"), "missing");
  f.camera = {1, *model, *width, *height, *params, std::nullopt};
  if (!f.camera_sigma.empty() && f.camera_sigma.size() != params->size()) {
    throw InvalidInput(field + ": params_est_std_dev", fmt::format("has {} values for {} parameters",
                                                                   f.camera_sigma.size(), params->size()));
  }
  if (housing_model && *housing_model != "NONE") {
    if (*housing_model != "FLATPORT" && *housing_model != "DOMEPORT") {
      throw InvalidInput(field + ": non_svp_model", "'" + housing_model->substr(0, 40) +
                                                        "' is not supported (NONE, FLATPORT, DOMEPORT)");
    }
    if (!housing_params || housing_params->size() != 8) {
      throw InvalidInput(field + ": non_svp_parameters", "needs 8 numbers for " + *housing_model);
    }
    RefractiveHousing h;
    h.model = *housing_model;
    std::copy(housing_params->begin(), housing_params->end(), h.params.begin());
    if (housing_sigma) {
      // calibmar's σ cover the housing parameters it adjusts (the first 3 or 4); the rest is fixed.
      if (housing_sigma->size() > 8) throw InvalidInput(field + ": non_svp_est_std_dev", "more than 8 values");
      for (double v : *housing_sigma) {
        if (v < 0) throw InvalidInput(field + ": non_svp_est_std_dev", "a standard deviation must be >= 0");
      }
      std::copy(housing_sigma->begin(), housing_sigma->end(), h.sigma.begin());
    }
    double n_water = 0;
    PortFromRefractive(h, field + ": non_svp_parameters", &n_water);  // usable, or an error naming the parameter
    f.housing = h;
  }
  return f;
}

std::string CalibmarYaml(const CalibmarFile& f) {
  auto list = [](const auto& v, std::size_t n) {
    std::string s;
    for (std::size_t i = 0; i < n; ++i) s += (i ? ", " : "") + ShortNum(v[i]);
    return s;
  };
  std::string out = "model: " + f.camera.model + "\n";
  out += "parameters: [" + list(f.camera.params, f.camera.params.size()) + "]\n";
  if (!f.camera_sigma.empty()) out += "# params_est_std_dev: " + list(f.camera_sigma, f.camera_sigma.size()) + "\n";
  out += "non_svp_model: " + (f.housing ? f.housing->model : std::string("NONE")) + "\n";
  if (f.housing) {
    const auto& names = f.housing->model == "FLATPORT" ? kFlatPortNames : kDomePortNames;
    std::string info;
    for (auto n : names) info += (info.empty() ? "" : ", ") + std::string(n);
    out += "# " + info + "\n";
  }
  out += "non_svp_parameters: [" + (f.housing ? list(f.housing->params, 8) : std::string()) + "]\n";
  if (f.housing) {
    std::size_t n = 0;
    while (n < 8 && std::isfinite(f.housing->sigma[n])) ++n;
    if (n > 0) out += "# non_svp_est_std_dev: " + list(f.housing->sigma, n) + "\n";
  }
  out += fmt::format("width: {}\nheight: {}\n", f.camera.width_px, f.camera.height_px);
  if (std::isfinite(f.overall_rms_px)) out += "# overall_rms: " + ShortNum(f.overall_rms_px) + "\n";
  out += "# target: " + (f.target.empty() ? std::string("written by porthole convert") : f.target) + "\n";
  return out;
}

Eigen::MatrixXd ColmapSigmaToCovariance(const ColmapCamera& c, const std::vector<double>& sigma) {
  const auto t = ColmapTargets(c.model);
  const int n = PortholeParams(c.model);
  Eigen::MatrixXd cov = Eigen::MatrixXd::Zero(n, n);
  for (std::size_t a = 0; a < t.size() && a < sigma.size(); ++a) {
    for (int i : t[a]) {
      for (int j : t[a]) cov(i, j) = sigma[a] * sigma[a];
    }
  }
  return cov;
}

std::vector<double> CovarianceToColmapSigma(const ColmapCamera& c, const Eigen::MatrixXd& covariance) {
  std::vector<double> s;
  for (const auto& targets : ColmapTargets(c.model)) {
    const double v = covariance(targets.front(), targets.front());
    if (!(v >= 0 && std::isfinite(v))) return {};  // a σ unknown: no # params_est_std_dev line at all
    s.push_back(std::sqrt(v));                      // 0: not adjusted (fixed), as calibmar writes it
  }
  return s;
}

}  // namespace porthole::interop

namespace porthole::interop::detail {

ReadResult ReadCalibmarFile(const std::string& content, const ReadArgs& args) {
  const CalibmarFile f = ParseCalibmarYaml(content, args.field);
  ReadResult r;
  r.format = args.format;
  r.format_model = f.camera.model;
  r.housing = f.housing;
  r.file_rms_px = f.overall_rms_px;
  const camera::Camera cam = FromColmap(f.camera, args.pixel_pitch_mm, args.field);
  if (f.camera_sigma.empty()) {
    r.calibration = WithoutSigma(cam, "σ unknown: the calibmar file has no # params_est_std_dev");
    return r;
  }
  r.calibration.camera = cam;
  r.calibration.covariance = ColmapSigmaToCovariance(f.camera, f.camera_sigma);
  r.calibration.free.assign(cam.params.size(), false);
  bool known = true;  // "nan" in the file: that parameter adjusted, its σ unknown
  for (std::size_t i = 0; i < cam.params.size(); ++i) {
    const double v = r.calibration.covariance(i, i);
    r.calibration.free[i] = v > 0 || std::isnan(v);
    known = known && !std::isnan(v);
  }
  r.calibration.has_covariance = known;
  r.calibration.covariance_note =
      known ? "diagonal from sigma" : "σ unknown: nan in the calibmar file's # params_est_std_dev";
  return r;
}

WriteResult WriteCalibmarFile(const calib::CalibrationRecord& cal, Format /*format*/, const std::string& field,
                              const WriteExtras& extras) {
  const PixelCalibration pc = ToPixelFamily(cal, field);  // Brown: refit to opencv
  WriteResult w;
  w.exact = pc.exact;
  w.fit = pc.fit;
  CalibmarFile f;
  f.camera = ToColmap(pc.cal.camera, field);
  if (pc.cal.has_covariance) f.camera_sigma = CovarianceToColmapSigma(f.camera, pc.cal.covariance);
  f.housing = extras.housing;
  w.content = CalibmarYaml(f);
  w.format_model = f.camera.model;
  w.sigma_written = !f.camera_sigma.empty();
  return w;
}

}  // namespace porthole::interop::detail
