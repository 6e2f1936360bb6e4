// The refractive projection as a calibration's cost function calls it (issue 25: one port geometry
// templated on the scalar): refraction::Project in ceres::Jet, the derivatives taken with respect
// to the 10 Brown parameters, the 3 port parameters and the 6 shell values (19, as a refractive
// bundle adjustment with a free shell), for the three port shapes. Also the surfaces alone
// (refraction::InterfacesOf in Jets) and the double-valued trace of ports::PortSystem::Outward,
// the two callers of the one description of a port's surfaces. Reported beside the speed: the
// largest |pixel − projected| (px) over the first 4096 calls, so a faster wrong answer shows.
//
// Points: pixels over the whole image of a D300 + 24 mm lens (Brown), each traced out through the
// port and a point taken 0.2–20 m along it.
#include <benchmark/benchmark.h>
#include <ceres/jet.h>

#include <Eigen/Geometry>

#include <cmath>
#include <random>
#include <vector>

#include "port_samples.h"
#include "porthole/camera/camera.h"
#include "porthole/camera/models.h"
#include "porthole/refraction/refraction.h"

namespace {

using namespace porthole;
using optics::Vec3;
constexpr int kNCam = camera::BrownModel::kNumParams;
constexpr int kN = kNCam + refraction::kPortNumParams + refraction::kShellNumParams;
using J = ceres::Jet<double, kN>;

camera::Camera D300() { return bench::BenchD300(); }

// 0: the as-built NI320 dome (not axial); 1: a flat port tilted 5°; 2: a 4-inch acrylic tube,
// pupil 1.5 mm off its axis across and 3 mm behind it, axis turned 10° from +Y.
ports::PortSystem Port(int which) {
  ports::PortSpec s;
  const Vec3 ep(0, 0, 26.9);
  if (which == 1) return bench::TiltedFlat5();
  if (which == 2) {
    ports::CylinderPort c;
    const double t = 10 * M_PI / 180;
    c.axis = Vec3(std::sin(t), std::cos(t), 0);
    c.axis_point_mm = ep + Vec3(0, 0, 3) - 1.5 * c.axis.cross(Vec3::UnitZ());
    c.inner_radius_mm = 50.8;
    c.outer_radius_mm = 57.15;
    s.shape = c;
    return ports::Place(s, ep, 1.49, 1.341);
  }
  ports::DomePort d;
  d.outer = {Vec3(-0.4, -1.0, 21.5), 83.4};
  d.inner = {Vec3(-0.4, -1.5, 20.3), 75.7};
  s.shape = d;
  return ports::Place(s, ep, 1.5168, 1.341);
}

const char* Label(int which) {
  return which == 0 ? "as-built NI320 dome" : which == 1 ? "flat 5 deg" : "cylinder 4 in";
}

using Sample = bench::PortSample;

std::vector<Sample> Samples(const camera::Camera& cam, const ports::PortSystem& sys, int n) {
  return bench::PortSamples(cam, sys, n, 11);
}

// Project<BrownModel, Jet<19>>: what one residual of a refractive bundle adjustment costs.
void BM_ProjectJet(benchmark::State& state) {
  const int which = static_cast<int>(state.range(0));
  const camera::Camera cam = D300();
  const ports::PortSystem sys = Port(which);
  const auto shell = refraction::ShellOf(sys);
  const auto port = refraction::ParamsOf(sys);
  const auto shell_values = refraction::ShellValues(shell);
  const auto samples = Samples(cam, sys, 4096);
  J cam_j[kNCam], port_j[refraction::kPortNumParams], shell_j[refraction::kShellNumParams];
  for (int k = 0; k < kNCam; ++k) cam_j[k] = J(cam.params[k], k);
  for (int k = 0; k < refraction::kPortNumParams; ++k) port_j[k] = J(port[k], kNCam + k);
  for (int k = 0; k < refraction::kShellNumParams; ++k) {
    shell_j[k] = J(shell_values[k], kNCam + refraction::kPortNumParams + k);
  }
  double worst = 0;
  std::size_t i = 0;
  for (auto _ : state) {
    const Sample& s = samples[i++ & 4095];
    const auto uv = refraction::Project<camera::BrownModel, J>(
        cam.sensor, cam_j, shell, port_j, s.point_in_cam.cast<J>(), shell_j);
    benchmark::DoNotOptimize(uv);
    if (i <= 4096) worst = std::max(worst, uv ? std::hypot((*uv)(0).a - s.pixel(0), (*uv)(1).a - s.pixel(1)) : INFINITY);
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["max_err_px"] = worst;
  state.SetLabel(Label(which));
}
BENCHMARK(BM_ProjectJet)->Arg(0)->Arg(1)->Arg(2);

// The surfaces alone: MakeGeometry and InterfacesOf in Jet<19> (the per-trace cost of stating them).
void BM_InterfacesOfJet(benchmark::State& state) {
  const int which = static_cast<int>(state.range(0));
  const ports::PortSystem sys = Port(which);
  const auto shell = refraction::ShellOf(sys);
  const auto port = refraction::ParamsOf(sys);
  const auto shell_values = refraction::ShellValues(shell);
  J port_j[refraction::kPortNumParams], shell_j[refraction::kShellNumParams];
  for (int k = 0; k < refraction::kPortNumParams; ++k) port_j[k] = J(port[k], kNCam + k);
  for (int k = 0; k < refraction::kShellNumParams; ++k) shell_j[k] = J(shell_values[k], kNCam + refraction::kPortNumParams + k);
  for (auto _ : state) {
    benchmark::DoNotOptimize(port_j);
    const auto f = refraction::InterfacesOf<J>(refraction::MakeGeometry<J>(shell, port_j, shell_j));
    benchmark::DoNotOptimize(f);
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel(Label(which));
}
BENCHMARK(BM_InterfacesOfJet)->Arg(0)->Arg(1)->Arg(2);

// The double path: PortSystem::Outward and one ray traced through it (planning, simulate, render).
void BM_OutwardTrace(benchmark::State& state) {
  const int which = static_cast<int>(state.range(0));
  const ports::PortSystem sys = Port(which);
  const Vec3 dir = Vec3(0.2, -0.1, 1).normalized();
  for (auto _ : state) {
    const auto seq = sys.Outward();
    optics::Ray r;
    benchmark::DoNotOptimize(optics::TraceSequence(seq, optics::Ray{sys.ep_in_housing_mm, dir}, &r));
    benchmark::DoNotOptimize(r);
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel(Label(which));
}
BENCHMARK(BM_OutwardTrace)->Arg(0)->Arg(1)->Arg(2);

}  // namespace
