// Simulate and fit: the paper's system (NI320 as built, D300, 24 mm focused for 1 m under water),
// a 50 × 50 image grid traced through the dome and fitted at 3 distances (7500 observations).
// Target < 0.2 s. Counters: the fit's residual RMS (µm) and c water/air is in docs/simulate.md.
#include <benchmark/benchmark.h>

#include "porthole/catalogue/presets.h"
#include "porthole/simulate/simulate.h"

namespace {

using namespace porthole;

void BM_SimulateFit50x50x3(benchmark::State& state) {
  simulate::SystemSpec spec;
  spec.port = catalogue::LoadPort("nimar-ni320");
  spec.camera = catalogue::LoadCamera("nikon-d300");
  spec.lens = catalogue::LoadLens("nikkor-24mm-f2.8d");
  const housing::FocusSetting focus = simulate::FocusUnderWater(spec);
  simulate::CameraSetup cam;
  cam.sensor = spec.camera.sensor;
  cam.lens.c_mm = 25.801;
  cam.ep_in_housing_mm = focus.ep_in_housing_mm;
  const ports::PortSystem water = ports::MakeSystem(spec.port, spec.env, cam.ep_in_housing_mm);
  simulate::FitOptions o;
  o.grid_cols = 50;
  o.grid_rows = 50;
  simulate::BrownFit fit;
  for (auto _ : state) {
    fit = simulate::SimulateFit(water, cam, o);
    const double c = fit.params.c_mm;  // a const copy (see bench_fit.cc)
    benchmark::DoNotOptimize(c);
  }
  state.counters["rms_um"] = fit.rms_um;
  state.counters["observations"] = fit.num_points;
  state.counters["converged"] = fit.converged ? 1 : 0;
}
BENCHMARK(BM_SimulateFit50x50x3)->Unit(benchmark::kMillisecond);

}  // namespace
