#include "porthole/fit/assembly.h"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vector>

#include "porthole/core/error.h"
#include "porthole/core/input.h"

namespace porthole::fit {
namespace {

void RequireFiniteVec(const std::string& field, const Eigen::Vector3d& v, const char* what) {
  if (!v.allFinite()) throw InvalidInput(field, fmt::format("{} must be finite numbers", what));
}

Eigen::Vector3d UnitNormal(const std::string& field, const PlaneWithCenter& p) {
  RequireFiniteVec(field, p.center_mm, "the centre");
  RequireFiniteVec(field, p.normal, "the normal");
  if (!(p.normal.norm() > 0)) throw InvalidInput(field, "the normal must not be zero");
  return p.normal.normalized();
}

void CheckSphere(const std::string& field, const Sphere& s) {
  RequireFiniteVec(field, s.center_mm, "the centre");
  if (!(std::isfinite(s.radius_mm) && s.radius_mm > 0))
    throw InvalidInput(field, "the radius must be a finite number > 0");
}

// The hint projected on the plane of unit normal n must not vanish.
void CheckHint(const std::string& field, const Eigen::Vector3d& hint, const Eigen::Vector3d& n) {
  RequireFiniteVec(field, hint, "the direction");
  if (!((hint - hint.dot(n) * n).norm() > 1e-6 * hint.norm()))
    throw InvalidInput(field, "must not be zero or parallel to the flange normal");
}

// plane_from_a for a planar reference given in frame a: origin at its centre, +Z along its unit
// normal n as given, +X along the hint projected on the plane.
RigidTransform PlaneFrame(const Eigen::Vector3d& center, const Eigen::Vector3d& n,
                          const Eigen::Vector3d& x_hint) {
  return HousingFromFlange(center, n, center + n, x_hint);
}

Sphere Moved(const RigidTransform& b_from_a, const Sphere& s) {
  return {b_from_a.Apply(s.center_mm), s.radius_mm};
}

// Numbers "a,b,c" → values; std::nullopt when any item is not a number (then it is a path).
std::optional<std::vector<double>> ParseNumbers(const std::string& spec) {
  std::vector<double> v;
  std::stringstream ss(spec);
  std::string item;
  while (std::getline(ss, item, ',')) {
    const auto b = item.find_first_not_of(" \t"), e = item.find_last_not_of(" \t");
    if (b == std::string::npos) return std::nullopt;
    double x = 0;
    const char* first = item.data() + b;
    const char* last = item.data() + e + 1;
    if (*first == '+') ++first;
    const auto [ptr, ec] = std::from_chars(first, last, x);
    if (ec != std::errc() || ptr != last) return std::nullopt;
    v.push_back(x);
  }
  if (v.empty()) return std::nullopt;
  return v;
}

using Json = nlohmann::json;

// The JSON written by `porthole fit <shape> --json`, with its text so that errors name the line.
struct FitJson {
  Json j;
  std::string text, path;
  // "path:line" of `key` (of the document when the key is absent).
  std::string Where(const std::string& key) const { return fmt::format("{}:{}", path, JsonPathLine(text, key)); }
};

// Reads a fit file; `shapes` lists the acceptable shapes.
FitJson LoadFitJson(const std::string& path, const std::string& field, const std::string& expected,
                    const std::vector<std::string>& shapes) {
  std::ifstream f(path, std::ios::binary);
  if (!f)
    throw InvalidInput(field,
                       fmt::format("'{}' is neither {} nor a readable file", path, expected));
  FitJson out{Json(), ReadInputFile(path, field, kMaxTextFileBytes), path};  // a fit file: a few kB
  try {
    out.j = Json::parse(out.text);
  } catch (const Json::parse_error& e) {
    const std::size_t line = 1 + std::count(out.text.begin(), out.text.begin() + std::min(e.byte, out.text.size()), '\n');
    throw InvalidInput(field, fmt::format("{}:{}: not valid JSON at byte {} (expected the output of "
                                          "the JSON of 'porthole fit')",
                                          path, line, e.byte));
  }
  if (!out.j.is_object()) throw InvalidInput(field, out.Where("") + ": not a JSON object");
  if (out.j.contains("shape")) {
    const std::string shape = out.j["shape"].is_string() ? out.j["shape"].get<std::string>() : "?";
    if (std::find(shapes.begin(), shapes.end(), shape) == shapes.end())
      throw InvalidInput(field, fmt::format("{}: a '{}' fit where a {} fit is expected", out.Where("shape"),
                                            shape, fmt::join(shapes, " or ")));
  }
  return out;
}

double JsonNumber(const FitJson& f, const std::string& key, const std::string& field) {
  const Json& j = f.j;
  if (!j.contains(key) || !j[key].is_number())
    throw InvalidInput(field, fmt::format("{}: key '{}' missing or not a number", f.Where(key), key));
  return j[key].get<double>();
}

Eigen::Vector3d JsonVec3(const FitJson& f, const std::string& key, const std::string& field) {
  const Json& j = f.j;
  if (!j.contains(key) || !j[key].is_array() || j[key].size() != 3 ||
      !std::all_of(j[key].begin(), j[key].end(), [](const Json& x) { return x.is_number(); }))
    throw InvalidInput(field, fmt::format("{}: key '{}' missing or not [x, y, z]", f.Where(key), key));
  return {j[key][0].get<double>(), j[key][1].get<double>(), j[key][2].get<double>()};
}

}  // namespace

HousingAssembly AssembleHousing(const AssemblyInput& in) {
  const Eigen::Vector3d n_cam = UnitNormal("camera_flange", in.camera_flange);
  const Eigen::Vector3d n_housing_s = UnitNormal("housing_flange", in.housing_flange);
  CheckSphere("outer", in.outer);
  CheckSphere("inner", in.inner);
  if (!std::isfinite(in.pupil_to_flange_mm))
    throw InvalidInput("pupil_offset", "must be a finite number");
  if (!((in.inner.center_mm - in.outer.center_mm).norm() + in.inner.radius_mm < in.outer.radius_mm))
    throw InvalidInput("inner", "the inner sphere must lie inside the outer sphere");
  const Eigen::Vector3d flanges = in.housing_flange.center_mm - in.camera_flange.center_mm;
  if (!(std::abs(flanges.dot(n_cam)) > 1e-6 * std::max(1.0, flanges.norm())))
    throw InvalidInput("housing_flange", "its centre lies in the camera flange's plane");
  CheckHint("x_hint", in.survey_x_hint, n_cam);

  HousingAssembly a;
  // Origin at the camera flange centre, +Z toward the housing flange (the paper's Section 3.3).
  a.housing_from_survey = HousingFromFlange(in.camera_flange.center_mm, n_cam,
                                            in.housing_flange.center_mm, in.survey_x_hint);
  a.camera_flange_center_mm = a.housing_from_survey.Apply(in.camera_flange.center_mm);
  a.housing_flange_center_mm = a.housing_from_survey.Apply(in.housing_flange.center_mm);
  a.housing_flange_normal = a.housing_from_survey.rotation * n_housing_s;
  if (a.housing_flange_normal.z() < 0) a.housing_flange_normal = -a.housing_flange_normal;
  a.housing_flange_tilt_rad = std::acos(std::clamp(a.housing_flange_normal.z(), -1.0, 1.0));

  if (in.dome_rear) {
    // The dome's rear face seated on the housing flange: rear frame → flange frame → housing.
    const Eigen::Vector3d n_rear = UnitNormal("dome_rear", *in.dome_rear);
    Eigen::Vector3d c_rear = in.dome_rear->center_mm;
    if (in.dome_centered)
      c_rear = in.outer.center_mm - (in.outer.center_mm - c_rear).dot(n_rear) * n_rear;
    CheckHint("dome_x_hint", in.scan_x_hint, n_rear);
    CheckHint("housing_flange", Eigen::Vector3d::UnitX(), a.housing_flange_normal);
    const RigidTransform rear_from_scan = PlaneFrame(c_rear, n_rear, in.scan_x_hint);
    const RigidTransform flange_from_housing =
        PlaneFrame(a.housing_flange_center_mm, a.housing_flange_normal, Eigen::Vector3d::UnitX());
    a.housing_from_scan = flange_from_housing.Inverse() * rear_from_scan;
  } else {
    if (in.dome_centered) throw InvalidInput("dome_centered", "needs `dome_rear`");
    a.housing_from_scan = a.housing_from_survey;
  }
  a.outer = Moved(a.housing_from_scan, in.outer);
  a.inner = Moved(a.housing_from_scan, in.inner);
  a.entrance_pupil_mm = Eigen::Vector3d(0, 0, in.pupil_to_flange_mm);
  if (!((a.entrance_pupil_mm - a.inner.center_mm).norm() < a.inner.radius_mm))
    throw InvalidInput("pupil_offset",
                       fmt::format("the entrance pupil (0, 0, {:.1f}) mm lies outside the dome's "
                                   "inner sphere: check the flanges, the dome rear's normal "
                                   "(it points toward the apex) and the offset",
                                   in.pupil_to_flange_mm));
  const Eigen::Vector3d d_out = a.entrance_pupil_mm - a.outer.center_mm;
  const Eigen::Vector3d d_in = a.entrance_pupil_mm - a.inner.center_mm;
  a.pupil_ahead_of_outer_mm = d_out.z();
  a.pupil_off_axis_outer_mm = d_out.head<2>().norm();
  a.pupil_ahead_of_inner_mm = d_in.z();
  a.pupil_off_axis_inner_mm = d_in.head<2>().norm();
  a.thickness_mm = a.outer.radius_mm - a.inner.radius_mm;
  a.center_distance_mm = (a.inner.center_mm - a.outer.center_mm).norm();
  return a;
}

std::string HousingAssembly::Report() const {
  std::string s = fmt::format("{:<24} {:>8} {:>8} {:>8}\n", "housing frame, mm", "X", "Y", "Z");
  auto row = [&](const char* name, const Eigen::Vector3d& p) {
    s += fmt::format("{:<24} {:>8.2f} {:>8.2f} {:>8.2f}\n", name, p.x(), p.y(), p.z());
  };
  row("camera flange centre", camera_flange_center_mm);
  row("dome outer centre", outer.center_mm);
  row("dome inner centre", inner.center_mm);
  row("lens entrance pupil", entrance_pupil_mm);
  row("housing flange centre", housing_flange_center_mm);
  s += fmt::format(
      "dome: R_out {:.2f} mm, R_in {:.2f} mm, thickness {:.2f} mm, centres {:.2f} mm apart; "
      "housing flange tilted {:.3f} deg to the camera flange\n",
      outer.radius_mm, inner.radius_mm, thickness_mm, center_distance_mm,
      housing_flange_tilt_rad * 180 / M_PI);
  s += fmt::format(
      "entrance pupil {:.2f} mm {} the outer centre along the axis and {:.2f} mm off axis "
      "(inner centre: {:.2f} mm along, {:.2f} mm off)\n",
      std::abs(pupil_ahead_of_outer_mm), pupil_ahead_of_outer_mm >= 0 ? "ahead of" : "behind",
      pupil_off_axis_outer_mm, pupil_ahead_of_inner_mm, pupil_off_axis_inner_mm);
  return s;
}

ports::PortSpec AsBuiltPort(const HousingAssembly& a, const std::string& name,
                            const std::string& material) {
  ports::PortSpec p;
  p.name = name;
  p.description = fmt::format(
      "As-built dome: R {:.2f}/{:.2f} mm, pupil {:.2f} mm ahead of the outer centre, {:.2f} mm "
      "off axis",
      a.outer.radius_mm, a.inner.radius_mm, a.pupil_ahead_of_outer_mm, a.pupil_off_axis_outer_mm);
  p.source = "porthole assemble: flange survey, dome scan sphere fits, lens pupil offset";
  p.frame = ports::PortFrame::kHousing;
  ports::DomePort d;
  d.outer = {a.outer.center_mm, a.outer.radius_mm};
  d.inner = {a.inner.center_mm, a.inner.radius_mm};
  d.material = material;
  d.rim_z_mm = a.housing_flange_center_mm.z();  // no glass behind the flange it is seated on
  p.shape = d;
  p.default_ep_in_housing_mm = a.entrance_pupil_mm;
  ports::Validate(p);
  return p;
}

PlaneWithCenter ParsePlaneSpec(const std::string& spec, const std::string& field) {
  const char* expected = "six numbers X,Y,Z,NX,NY,NZ";
  if (const auto v = ParseNumbers(spec)) {
    if (v->size() != 6)
      throw InvalidInput(field, fmt::format("expected {}, got {} numbers", expected, v->size()));
    return {{(*v)[0], (*v)[1], (*v)[2]}, {(*v)[3], (*v)[4], (*v)[5]}};
  }
  const FitJson f = LoadFitJson(spec, field, expected, {"circle", "plane"});
  const bool circle = f.j.contains("center_mm");
  return {JsonVec3(f, circle ? "center_mm" : "centroid_mm", field), JsonVec3(f, "normal", field)};
}

Sphere ParseSphereSpec(const std::string& spec, const std::string& field) {
  const char* expected = "four numbers X,Y,Z,R";
  if (const auto v = ParseNumbers(spec)) {
    if (v->size() != 4)
      throw InvalidInput(field, fmt::format("expected {}, got {} numbers", expected, v->size()));
    return {{(*v)[0], (*v)[1], (*v)[2]}, (*v)[3]};
  }
  const FitJson f = LoadFitJson(spec, field, expected, {"sphere"});
  if (f.j.contains("usable") && f.j["usable"] == false)
    throw InvalidInput(field, fmt::format("{}: the sphere fit is not usable ({})", f.Where("usable"),
                                          f.j.value("status", std::string("no status"))));
  return {JsonVec3(f, "center_mm", field), JsonNumber(f, "radius_mm", field)};
}

nlohmann::ordered_json AssemblyToJson(const HousingAssembly& a, double pupil_to_flange_mm) {
  using Json = nlohmann::ordered_json;
  const auto vec = [](const Eigen::Vector3d& v) { return Json::array({v.x(), v.y(), v.z()}); };
  const auto transform = [&](const RigidTransform& t) {
    Json rows = Json::array();
    for (int r = 0; r < 3; ++r) rows.push_back(vec(t.rotation.row(r).transpose()));
    return Json{{"rotation", rows}, {"translation_mm", vec(t.translation)}};
  };
  return Json{{"frame", "housing"},
              {"camera_flange_center_mm", vec(a.camera_flange_center_mm)},
              {"dome_outer_center_mm", vec(a.outer.center_mm)},
              {"dome_inner_center_mm", vec(a.inner.center_mm)},
              {"entrance_pupil_mm", vec(a.entrance_pupil_mm)},
              {"housing_flange_center_mm", vec(a.housing_flange_center_mm)},
              {"housing_flange_normal", vec(a.housing_flange_normal)},
              {"housing_flange_tilt_deg", a.housing_flange_tilt_rad * 180 / M_PI},
              {"outer_radius_mm", a.outer.radius_mm},
              {"inner_radius_mm", a.inner.radius_mm},
              {"thickness_mm", a.thickness_mm},
              {"center_distance_mm", a.center_distance_mm},
              {"pupil_to_flange_mm", pupil_to_flange_mm},
              {"pupil_ahead_of_outer_mm", a.pupil_ahead_of_outer_mm},
              {"pupil_off_axis_outer_mm", a.pupil_off_axis_outer_mm},
              {"pupil_ahead_of_inner_mm", a.pupil_ahead_of_inner_mm},
              {"pupil_off_axis_inner_mm", a.pupil_off_axis_inner_mm},
              {"housing_from_survey", transform(a.housing_from_survey)},
              {"housing_from_scan", transform(a.housing_from_scan)}};
}

}  // namespace porthole::fit
