#include "porthole/interop/refractive.h"

#include <fmt/format.h>

#include <cmath>
#include <sstream>

#include "porthole/core/error.h"
#include "porthole/interop/text.h"

namespace porthole::interop {
namespace {

constexpr std::array<std::string_view, 8> kFlatNames = {"Nx", "Ny", "Nz", "int_dist", "int_thick", "na", "ng", "nw"};
constexpr std::array<std::string_view, 8> kDomeNames = {"Cx", "Cy", "Cz", "int_radius", "int_thick", "na", "ng", "nw"};

std::string Num(double v) { return fmt::format("{}", v); }  // shortest text that reads back exactly

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

ports::PortSpec PortFromRefractive(const RefractiveHousing& h, const std::string& field, double* n_water) {
  const auto& p = h.params;
  const auto where = [&](int i) {
    return field + ": " + std::string(h.model == "FLATPORT" ? kFlatNames[i] : kDomeNames[i]);
  };
  for (int i = 5; i < 8; ++i) {
    if (!(p[i] >= 1 && p[i] < 5)) throw InvalidInput(where(i), "a refractive index must be in [1, 5)");
  }
  if (!(p[4] > 0)) throw InvalidInput(where(4), "the glass thickness must be > 0 m");
  const double na = p[5];
  ports::PortSpec port;
  port.frame = ports::PortFrame::kCam;
  port.source = "converted by porthole from refractive COLMAP / calibmar " + h.model + " parameters (metres)";
  const Eigen::Vector3d v(p[0], p[1], p[2]);
  if (h.model == "DOMEPORT") {
    if (!(p[3] > 0)) throw InvalidInput(where(3), "the inner radius must be > 0 m");
    ports::DomePort d;
    d.inner = {1000.0 * v, 1000.0 * p[3]};
    d.outer = {1000.0 * v, 1000.0 * (p[3] + p[4])};
    d.material = Num(p[6] / na);
    port.name = "refractive-domeport";
    port.description = fmt::format("Dome from DOMEPORT: inner radius {:g} mm, {:g} mm thick, centre {:g}, {:g}, {:g} mm "
                                   "from the pupil", 1000 * p[3], 1000 * p[4], 1000 * v.x(), 1000 * v.y(), 1000 * v.z());
    port.shape = d;
  } else if (h.model == "FLATPORT") {
    if (std::abs(v.norm() - 1) > 1e-6) throw InvalidInput(where(0), "the normal Nx, Ny, Nz must be a unit vector");
    if (!(p[3] > 0)) throw InvalidInput(where(3), "the distance to the interface must be > 0 m");
    ports::FlatPort f;
    f.normal = v.normalized();
    f.inner_point_mm = 1000.0 * p[3] * f.normal;
    f.thickness_mm = 1000.0 * p[4];
    f.material = Num(p[6] / na);
    port.name = "refractive-flatport";
    port.description = fmt::format("Flat port from FLATPORT: interface {:g} mm from the pupil, {:g} mm thick",
                                   1000 * p[3], 1000 * p[4]);
    port.shape = f;
  } else {
    throw InvalidInput(field, "'" + h.model.substr(0, 40) + "' is not a housing model (FLATPORT, DOMEPORT)");
  }
  if (n_water != nullptr) *n_water = p[7] / na;
  return port;
}

RefractiveHousing RefractiveFromPort(const ports::PortSpec& port, double n_glass, double n_water,
                                     const std::string& field) {
  if (!(n_glass >= 1) || !(n_water >= 1)) throw InvalidInput(field, "indices must be >= 1");
  // In the cam frame: a housing-frame port relative to its own entrance pupil.
  const Eigen::Vector3d origin =
      port.frame == ports::PortFrame::kCam ? Eigen::Vector3d::Zero() : port.default_ep_in_housing_mm;
  RefractiveHousing h;
  if (const auto* d = std::get_if<ports::DomePort>(&port.shape)) {
    const double offset = (d->outer.center_mm - d->inner.center_mm).norm();
    if (offset > 1e-9) {
      throw InvalidInput(field, fmt::format("refractive COLMAP's DOMEPORT is concentric, this dome's sphere "
                                            "centres are {:.4g} mm apart", offset));
    }
    const Eigen::Vector3d c = (d->inner.center_mm - origin) / 1000.0;
    h.model = "DOMEPORT";
    h.params = {c.x(), c.y(), c.z(), d->inner.radius_mm / 1000.0,
                (d->outer.radius_mm - d->inner.radius_mm) / 1000.0, 1.0, n_glass, n_water};
  } else if (port.IsCylinder()) {
    throw InvalidInput(field, "refractive COLMAP and calibmar have no cylindrical port (FLATPORT, DOMEPORT only)");
  } else {
    const auto& f = std::get<ports::FlatPort>(port.shape);
    const Eigen::Vector3d n = f.normal.normalized();
    h.model = "FLATPORT";
    h.params = {n.x(), n.y(), n.z(), (f.inner_point_mm - origin).dot(n) / 1000.0, f.thickness_mm / 1000.0,
                1.0, n_glass, n_water};
  }
  return h;
}

std::string HousingSigmaToml(const RefractiveHousing& h) {
  const auto& sg = h.sigma;
  const double na = h.params[5];
  std::string out;
  const auto scalar = [&](std::string_view key, double v) {
    if (std::isfinite(v)) out += fmt::format("{} = {}\n", key, Num(v));
  };
  const auto vector = [&](std::string_view key, double scale) {
    if (std::isfinite(sg[0]) && std::isfinite(sg[1]) && std::isfinite(sg[2])) {
      out += fmt::format("{} = [{}, {}, {}]\n", key, Num(scale * sg[0]), Num(scale * sg[1]), Num(scale * sg[2]));
    }
  };
  if (h.model == "DOMEPORT") {
    vector("center_mm", 1000);
    scalar("inner_radius_mm", 1000 * sg[3]);
  } else {
    vector("normal", 1);
    scalar("distance_mm", 1000 * sg[3]);
  }
  scalar("thickness_mm", 1000 * sg[4]);
  scalar("n_glass", sg[6] / na);  // na's own σ is not carried: porthole's housing air is n = 1
  scalar("n_water", sg[7] / na);
  if (out.empty()) return "";
  return "\n# 1 sigma of the " + h.model + " housing as the input file gives it (calibmar's # non_svp_est_std_dev),\n"
         "# in this file's units; porthole's optics do not use it (docs/interop.md)\n[sigma]\n" + out;
}

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
    for (std::size_t i = 0; i < n; ++i) s += (i ? ", " : "") + Num(v[i]);
    return s;
  };
  std::string out = "model: " + f.camera.model + "\n";
  out += "parameters: [" + list(f.camera.params, f.camera.params.size()) + "]\n";
  if (!f.camera_sigma.empty()) out += "# params_est_std_dev: " + list(f.camera_sigma, f.camera_sigma.size()) + "\n";
  out += "non_svp_model: " + (f.housing ? f.housing->model : std::string("NONE")) + "\n";
  if (f.housing) {
    const auto& names = f.housing->model == "FLATPORT" ? kFlatNames : kDomeNames;
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
  if (std::isfinite(f.overall_rms_px)) out += "# overall_rms: " + Num(f.overall_rms_px) + "\n";
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
