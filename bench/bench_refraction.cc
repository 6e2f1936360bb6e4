// Forward projection through a port (refraction::Project): projections per second on one core,
// with the round-trip accuracy beside it, against the peer a user would otherwise have — the
// scheme of refractive COLMAP (MDSKiel): a 2-D Gauss–Newton on the image point whose Jacobian is
// taken by central differences of the backward projection (lens unprojection, then the Snell
// trace), measured here on the same points and the same optics tracer.
//
// Points: pixels spread over the whole image of a D300 + 24 mm lens (Brown), each ray traced out
// through the port and a point taken 0.2–20 m along it; accuracy = max |pixel − projected| (px).
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <random>
#include <vector>

#include "port_samples.h"
#include "porthole/camera/camera.h"
#include "porthole/refraction/refraction.h"

namespace {

using namespace porthole;
using optics::Vec3;

camera::Camera D300() { return bench::BenchD300(); }

ports::PortSystem Port(int which) {
  ports::PortSpec s;
  const Vec3 ep(0, 0, 26.9);
  if (which == 2) return bench::TiltedFlat5();
  ports::DomePort d;
  if (which == 0) {  // the paper's as-built NI320: not axial
    d.outer = {Vec3(-0.4, -1.0, 21.5), 83.4};
    d.inner = {Vec3(-0.4, -1.5, 20.3), 75.7};
  } else {  // concentric, pupil 10 mm behind the centre: axial
    d.outer = {ep + Vec3(0, 0, 10), 83.4};
    d.inner = {ep + Vec3(0, 0, 10), 75.7};
  }
  s.shape = d;
  return ports::Place(s, ep, 1.5168, 1.341);
}

using Sample = bench::PortSample;

std::vector<Sample> Samples(const camera::Camera& cam, const ports::PortSystem& sys, int n) {
  return bench::PortSamples(cam, sys, n, 7);
}

void BM_ForwardProjection(benchmark::State& state) {
  const camera::Camera cam = D300();
  const ports::PortSystem sys = Port(static_cast<int>(state.range(0)));
  const auto shell = refraction::ShellOf(sys);
  const auto port = refraction::ParamsOf(sys);
  const auto samples = Samples(cam, sys, 4096);
  double worst = 0;
  std::size_t i = 0;
  for (auto _ : state) {
    const Sample& s = samples[i++ & 4095];
    const auto uv = refraction::Project<camera::BrownModel, double>(cam.sensor, cam.params.data(),
                                                                     shell, port.data(),
                                                                     s.point_in_cam);
    benchmark::DoNotOptimize(uv);
    if (i <= 4096) worst = std::max(worst, uv ? (*uv - s.pixel).norm() : INFINITY);
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["max_err_px"] = worst;
  state.SetLabel(state.range(0) == 0 ? "as-built NI320 (2-D Newton)"
                 : state.range(0) == 1 ? "axial dome (1-D Newton)"
                                       : "flat 5 deg (1-D Newton)");
}
BENCHMARK(BM_ForwardProjection)->Arg(0)->Arg(1)->Arg(2);

// The peer: Gauss–Newton on the pixel, r(x) = the point's offset from the backward-projected
// water ray (perpendicular components in a fixed frame), J by central differences (h = 1e-4 px),
// stopped at |step| < 1e-9 px or 50 iterations; started at the central camera's projection.
void BM_ForwardProjectionPeerFiniteDifferences(benchmark::State& state) {
  const camera::Camera cam = D300();
  const ports::PortSystem sys = Port(static_cast<int>(state.range(0)));
  // The trace runs in the cam frame: the sequence's surfaces shifted by the pupil.
  std::vector<optics::Interface> seq = sys.Outward();
  for (auto& f : seq) {
    f.surface.center -= sys.ep_in_housing_mm;
    f.surface.aperture_point -= sys.ep_in_housing_mm;
  }
  const auto samples = Samples(cam, sys, 4096);
  const auto residual = [&](const Eigen::Vector2d& px, const Vec3& x, const Vec3& e1,
                            const Vec3& e2) -> std::optional<Eigen::Vector2d> {
    const auto ray = cam.Unproject(px);
    if (!ray) return std::nullopt;
    optics::Ray r;
    if (optics::TraceSequence(seq, optics::Ray{Vec3::Zero(), *ray}, &r) != optics::RayStatus::kOk) {
      return std::nullopt;
    }
    const Vec3 w = x - r.origin;
    const Vec3 perp = w - w.dot(r.dir) * r.dir;
    return Eigen::Vector2d(perp.dot(e1), perp.dot(e2));
  };
  double worst = 0;
  std::size_t i = 0;
  for (auto _ : state) {
    const Sample& s = samples[i++ & 4095];
    const Vec3 z = s.point_in_cam.normalized();
    const Vec3 e1 = z.cross(Vec3::UnitY()).normalized(), e2 = z.cross(e1);
    auto px = cam.Project(s.point_in_cam);
    bool ok = px.has_value();
    for (int it = 0; it < 50 && ok; ++it) {
      const auto r0 = residual(*px, s.point_in_cam, e1, e2);
      if (!r0) {
        ok = false;
        break;
      }
      Eigen::Matrix2d jac;
      const double h = 1e-4;
      for (int k = 0; k < 2; ++k) {
        Eigen::Vector2d d = Eigen::Vector2d::Zero();
        d(k) = h;
        const auto a = residual(*px + d, s.point_in_cam, e1, e2);
        const auto b = residual(*px - d, s.point_in_cam, e1, e2);
        if (!a || !b) {
          ok = false;
          break;
        }
        jac.col(k) = (*a - *b) / (2 * h);
      }
      if (!ok) break;
      const Eigen::Vector2d step = jac.partialPivLu().solve(*r0);
      *px -= step;
      if (step.norm() < 1e-9) break;
    }
    benchmark::DoNotOptimize(px);
    if (i <= 4096) worst = std::max(worst, ok ? (*px - s.pixel).norm() : INFINITY);
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["max_err_px"] = worst;
  state.SetLabel(state.range(0) == 0 ? "as-built NI320" : state.range(0) == 1 ? "axial dome"
                                                                               : "flat 5 deg");
}
BENCHMARK(BM_ForwardProjectionPeerFiniteDifferences)->Arg(0)->Arg(1)->Arg(2);

}  // namespace
