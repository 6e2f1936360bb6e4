// Sphere fits on the paper's dome scan size (170,000 points, R 83.4 mm, σ 0.05 mm): time beside
// the centre and radius error against the synthetic ground truth. Targets: plain < 20 ms, robust
// (20 % gross outliers) < 200 ms. The PCL SACMODEL_SPHERE peer is bench_fit_pcl.cc.
#include <benchmark/benchmark.h>

#include <cmath>

#include "fit_scans.h"
#include "porthole/fit/sphere_fit.h"

namespace {

using porthole::fit::FitSphere;
using porthole::fit::SphereFitOptions;
using porthole::fit::SphereFitSummary;

const porthole::pointcloud::SyntheticCap& Scan(double outlier_fraction) {
  return porthole::bench::PaperDomeScan(outlier_fraction);
}

void Report(benchmark::State& state, const SphereFitSummary& s) {
  porthole::bench::ReportSphere(state, s.sphere.center_mm, s.sphere.radius_mm,
                                static_cast<double>(s.n_inliers));
  state.counters["usable"] = s.IsUsable() ? 1 : 0;
}

void BM_SphereFit170k(benchmark::State& state) {
  const auto& scan = Scan(0.0);
  SphereFitSummary s;
  for (auto _ : state) {
    s = FitSphere(scan.points);
    // A const copy: DoNotOptimize on a mutable double may be kept in a general register and
    // clobbered by GCC (benchmark 1.7 "+m,r" constraint), which corrupts the struct.
    const double r = s.sphere.radius_mm;
    benchmark::DoNotOptimize(r);
  }
  Report(state, s);
}
BENCHMARK(BM_SphereFit170k)->Unit(benchmark::kMillisecond);

void BM_SphereFitRobust170k20pct(benchmark::State& state) {
  const auto& scan = Scan(0.2);
  SphereFitOptions o;
  o.robust = true;
  o.loss =
      state.range(0) == 0 ? porthole::fit::RobustLoss::kCauchy : porthole::fit::RobustLoss::kHuber;
  SphereFitSummary s;
  for (auto _ : state) {
    s = FitSphere(scan.points, o);
    // A const copy: DoNotOptimize on a mutable double may be kept in a general register and
    // clobbered by GCC (benchmark 1.7 "+m,r" constraint), which corrupts the struct.
    const double r = s.sphere.radius_mm;
    benchmark::DoNotOptimize(r);
  }
  Report(state, s);
  state.SetLabel(state.range(0) == 0 ? "cauchy" : "huber");
}
BENCHMARK(BM_SphereFitRobust170k20pct)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

}  // namespace
