// `porthole trace`: a fan of rays from the entrance pupil out through the port into the water (or
// back), with every intersection, as CSV or JSON for diagrams.
#include <fmt/format.h>

#include <cmath>

#include "commands.h"
#include "common.h"
#include "porthole/core/atomic_file.h"
#include "porthole/core/error.h"
#include "porthole/optics/trace.h"

namespace porthole::cli {

void RegisterTrace(CLI::App& app) {
  struct Options {
    PortOptions port;
    WaterOptions water;
    double half_angle_deg = 45;
    int rays = 11;
    std::string plane = "xz";
    double length_mm = 300;
    std::string format = "csv";
    std::string out;
    bool json = false, force = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "trace", "Trace a fan of rays from the entrance pupil out through the port into the water");
  o->port.Add(cmd);
  o->water.Add(cmd);
  cmd->add_option("--half-angle", o->half_angle_deg, "Half-angle of the fan in air, deg")->capture_default_str();
  cmd->add_option("--rays", o->rays, "Number of rays in the fan (>= 1)")->capture_default_str();
  cmd->add_option("--plane", o->plane, "Plane of the fan: xz or yz")->check(CLI::IsMember({"xz", "yz"}))
      ->capture_default_str();
  cmd->add_option("--length", o->length_mm, "Length of each ray in the water, mm")->capture_default_str();
  cmd->add_option("--format", o->format, "csv or json")->check(CLI::IsMember({"csv", "json"}))->capture_default_str();
  cmd->add_option("-o,--out", o->out, "Write to this file (default: standard output)");
  cmd->add_flag("--json", o->json, "JSON output for scripts (the same as --format json)");

  AddForceFlag(cmd, &o->force);
  cmd->callback([o, cmd] {
    if (!(o->half_angle_deg > 0 && o->half_angle_deg < 90)) throw InvalidInput("--half-angle", "must be in (0, 90) deg");
    if (o->rays < 1 || o->rays > 100000) throw InvalidInput("--rays", "must be between 1 and 100000");
    RequirePositive("--length", o->length_mm);
    if (o->json) o->format = "json";
    const OutputRules rules{.force = o->force, .inputs = InputFiles(cmd, {"--out"})};
    if (!o->out.empty()) CheckOutput(o->out, "--out", rules);
    const ports::Environment env = o->water.ToEnvironment();
    const ports::PortSystem sys = ports::MakeSystem(o->port.Spec(), env, o->port.Ep());
    const auto seq = sys.Outward();
    const int axis = o->plane == "xz" ? 0 : 1;

    std::string csv = "ray,angle_air_deg,status,point,x_mm,y_mm,z_mm,medium\n";
    Json rays = Json::array();
    const char* media[] = {"air", "glass", "water"};
    for (int k = 0; k < o->rays; ++k) {
      const double a = o->rays == 1 ? 0.0
                                    : (-o->half_angle_deg + 2 * o->half_angle_deg * k / (o->rays - 1)) * M_PI / 180;
      ports::Vec3 d(0, 0, std::cos(a));
      d[axis] = std::sin(a);
      optics::Ray out;
      optics::RayPath path;
      const optics::RayStatus st = optics::TraceSequence<double>(seq, {sys.ep_in_housing_mm, d}, &out, &path);
      if (st == optics::RayStatus::kOk) path.points.push_back(out.origin + o->length_mm * out.dir);
      Json pts = Json::array();
      for (std::size_t i = 0; i < path.points.size(); ++i) {
        const auto& p = path.points[i];
        // Point i lies at the end of segment i-1: air, glass, then water.
        const char* medium = media[std::min<std::size_t>(i == 0 ? 0 : i - 1, 2)];
        csv += fmt::format("{},{:.6f},{},{},{:.6f},{:.6f},{:.6f},{}\n", k, a * 180 / M_PI, optics::ToString(st), i,
                           p.x(), p.y(), p.z(), medium);
        pts.push_back(Vec3Json(p));
      }
      Json r = {{"angle_air_deg", a * 180 / M_PI}, {"status", optics::ToString(st)}, {"points_mm", pts}};
      if (st == optics::RayStatus::kOk) {
        r["angle_water_deg"] = std::atan2(out.dir[axis], out.dir.z()) * 180 / M_PI;
        r["direction_water"] = Vec3Json(out.dir);
      }
      rays.push_back(r);
    }
    std::string text;
    if (o->format == "json") {
      Json j = DescribeSystem(sys, env);
      j["plane"] = o->plane;
      j["rays"] = rays;
      text = j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
    } else {
      text = csv;
    }
    if (o->out.empty()) {
      fmt::print("{}", text);
    } else {
      WriteOutput(o->out, text, "--out", rules);
    }
  });
}

}  // namespace porthole::cli
