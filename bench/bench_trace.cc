// Ray-surface throughput through the as-built NiMAR NI320 (preset nimar-ni320: two refracting
// spheres with their rim, double precision; N-BK7 at the e line, water n 1.341), for every
// instruction set of the batched tracer's kernel (SSE2, AVX2, AVX-512: each row is skipped where
// the processor lacks it), on 1 and 2 threads, against two peers measured in the same run:
// porthole's own one-ray-at-a-time loop, and a vectorised NumPy trace of the same rays
// (bench_trace_numpy.py, run by BM_TraceNumpyPeer).
//
// Counters: `ray_surfaces_per_s` (rays × surfaces per wall-clock second: the figure of issue 13,
// target >= 3e8 on the 2-core machine), `rays_per_s`, `ray_surfaces_per_cpu_s` (per CPU-second,
// see SetRates), `threads`, and accuracy beside speed:
// `max_dir_diff` (the batch against the single-ray tracer on a sample of the same rays: 0, the
// kernels are bit-for-bit) and, for the NumPy peer, `max_dir_diff` and `status_mismatches`
// against porthole. BM_TraceNumpyPeer also times porthole (the kernel chosen at run time, 2
// threads, same rays, same best-of-k rule) and reports `porthole_over_numpy` (issue 13: >= 25;
// NumPy runs its element-wise operations on one core) and `porthole_1thread_over_numpy`.
//
// Sizes: 1 M rays (48 MB of rays in, 48 MB out: streams from memory, the rendering case) and
// 32 k rays (cache-resident: the kernel's own speed).
#include <benchmark/benchmark.h>
#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <string>

#include "peer.h"
#include "porthole/catalogue/presets.h"
#include "porthole/materials/materials.h"
#include "porthole/optics/batch.h"
#include "porthole/ports/port.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace {

using porthole::optics::Isa;
using porthole::optics::Ray;
using porthole::optics::RayBatch;
using porthole::optics::RayStatus;
using porthole::optics::Vec3;

constexpr double kWaterIndex = 1.341;  // the paper's sea water

const porthole::ports::PortSystem& Ni320() {
  static const porthole::ports::PortSystem s = [] {
    const auto spec = porthole::catalogue::LoadPort("nimar-ni320");
    return porthole::ports::Place(spec, spec.default_ep_in_housing_mm,
                                  porthole::materials::Index(spec.material()), kWaterIndex);
  }();
  return s;
}

// Rays from the entrance pupil, uniform over the solid angle up to 57° off axis.
std::vector<Ray> FanOfRays(std::size_t n) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Ray> rays(n);
  const Vec3 ep = Ni320().ep_in_housing_mm;
  for (auto& r : rays) {
    const double th = 1.0 * std::sqrt(u(rng)), ph = 2 * M_PI * u(rng);
    r = Ray{ep, Vec3(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th))};
  }
  return rays;
}

RayBatch ToBatch(const std::vector<Ray>& rays) {
  RayBatch b;
  b.resize(rays.size());
  for (std::size_t i = 0; i < rays.size(); ++i) b.Set(i, rays[i]);
  return b;
}

double ThreadCpuSeconds() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

double ProcessCpuSeconds() {
  timespec t;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// Rates per wall-clock second, and `ray_surfaces_per_cpu_s`: per second of CPU time summed over
// the process's threads — what one core delivers, whatever else the machine runs at the time
// (wall-clock rates fall when other jobs share the cores; this one does not).
void SetRates(benchmark::State& state, double rays_per_iteration, std::size_t surfaces,
              double cpu_seconds) {
  const double rays = static_cast<double>(state.iterations()) * rays_per_iteration;
  const double ray_surfaces = rays * static_cast<double>(surfaces);
  state.counters["rays_per_s"] = benchmark::Counter(rays, benchmark::Counter::kIsRate);
  state.counters["ray_surfaces_per_s"] =
      benchmark::Counter(ray_surfaces, benchmark::Counter::kIsRate);
  if (cpu_seconds > 0) state.counters["ray_surfaces_per_cpu_s"] = ray_surfaces / cpu_seconds;
}

constexpr std::size_t kRays = 1 << 20;

// ---- The memory roofline: STREAM-like loops over the same bytes, on the tracer's own threads ----
//
// Bytes are counted as STREAM counts them: what the program reads plus what it writes (the read
// a cache line's first write may cost, "read for ownership", is not counted). A trace of a batch
// out of place reads each ray once and writes it once, whatever the number of surfaces:
// 6 doubles and a status in, as many out, 98 B per ray.
constexpr double kTraceBytesPerRay = 2 * (6 * sizeof(double) + sizeof(RayStatus));
constexpr std::ptrdiff_t kMemBlock = 1 << 14;  // elements per block handed to a thread

enum class MemLoop : std::int64_t { kCopy, kCopyNonTemporal, kTriad };
const char* Name(MemLoop k) {
  return k == MemLoop::kCopy              ? "copy"
         : k == MemLoop::kCopyNonTemporal ? "copy, non-temporal stores"
                                          : "triad";
}

// The arrays of one memory loop: `copy` the trace's own (1 M rays in, 1 M out: six double arrays
// and the statuses, 98 MB), `triad` a = b + s·c over three arrays of 4 M doubles (96 MB).
struct MemArrays {
  explicit MemArrays(MemLoop k) : kind(k) {
    if (kind == MemLoop::kTriad) {
      for (auto* v : {&a, &b, &c}) v->assign(4 * kRays, 1.0);
    } else {
      in.resize(kRays);
      out.resize(kRays);
      for (auto* v : {&in.ox, &in.oy, &in.oz, &in.dx, &in.dy, &in.dz}) v->assign(kRays, 1.0);
    }
  }
  double Bytes() const {
    return kind == MemLoop::kTriad ? 3.0 * sizeof(double) * static_cast<double>(a.size())
                                   : kTraceBytesPerRay * static_cast<double>(kRays);
  }
  // One pass on `threads` threads (the pool TraceBatch uses). `one` is 1.0, read at run time so
  // that the compiler cannot turn the copy into memcpy (whose large copies use non-temporal
  // stores: the plain copy is the traffic of ordinary stores, the tracer's).
  void Run(int threads, double one) {
    const std::ptrdiff_t n = kind == MemLoop::kTriad ? static_cast<std::ptrdiff_t>(a.size())
                                                     : static_cast<std::ptrdiff_t>(kRays);
    porthole::optics::ParallelBlocks(
        threads, (n + kMemBlock - 1) / kMemBlock, [&](std::ptrdiff_t blk) {
          const std::ptrdiff_t lo = blk * kMemBlock, hi = std::min(n, lo + kMemBlock);
          if (kind == MemLoop::kTriad) {
            double *pa = a.data(), *pb = b.data(), *pc = c.data();
            for (std::ptrdiff_t i = lo; i < hi; ++i) pa[i] = pb[i] + one * pc[i];
            return;
          }
          const std::vector<double>* src[6] = {&in.ox, &in.oy, &in.oz, &in.dx, &in.dy, &in.dz};
          std::vector<double>* dst[6] = {&out.ox, &out.oy, &out.oz, &out.dx, &out.dy, &out.dz};
          const auto* ss = reinterpret_cast<const std::uint8_t*>(in.status.data());
          auto* ds = reinterpret_cast<std::uint8_t*>(out.status.data());
          if (kind == MemLoop::kCopy) {
            for (int k = 0; k < 6; ++k) {
              const double* x = src[k]->data();
              double* y = dst[k]->data();
              for (std::ptrdiff_t i = lo; i < hi; ++i) y[i] = one * x[i];
            }
            const auto zero = static_cast<std::uint8_t>(one - 1.0);
            for (std::ptrdiff_t i = lo; i < hi; ++i) ds[i] = ss[i] ^ zero;
          } else {
#if defined(__SSE2__)  // streaming stores (x86-64's baseline has them); arrays are 16-byte aligned
            for (int k = 0; k < 6; ++k) {
              const double* x = src[k]->data();
              double* y = dst[k]->data();
              for (std::ptrdiff_t i = lo; i < hi; i += 2) _mm_stream_pd(y + i, _mm_load_pd(x + i));
            }
            for (std::ptrdiff_t i = lo; i < hi; i += 16) {
              _mm_stream_si128(reinterpret_cast<__m128i*>(ds + i),
                               _mm_load_si128(reinterpret_cast<const __m128i*>(ss + i)));
            }
            _mm_sfence();
#endif
          }
        });
  }
  MemLoop kind;
  RayBatch in, out;
  std::vector<double> a, b, c;
};

// Memory bandwidth (bytes/s, as STREAM counts them) on `threads` threads: the best of 10 passes of
// both copies (ordinary and non-temporal stores) over the trace's own bytes, measured once per
// thread count in a run. The roofline the 1 M-ray trace is set against.
double CopyBandwidth(int threads) {
  static std::map<int, double> measured;
  auto [it, fresh] = measured.try_emplace(threads, 0.0);
  if (!fresh) return it->second;
  for (const MemLoop kind : {MemLoop::kCopy, MemLoop::kCopyNonTemporal}) {
    MemArrays m(kind);
    for (int r = 0; r < 10; ++r) {
      const auto t0 = std::chrono::steady_clock::now();
      m.Run(threads, 1.0);
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      it->second = std::max(it->second, m.Bytes() / s);
    }
  }
  return it->second;
}

// Args: {MemLoop, threads}.
void BM_MemoryBandwidth(benchmark::State& state) {
  const auto kind = static_cast<MemLoop>(state.range(0));
  const int threads = static_cast<int>(state.range(1));
#if !defined(__SSE2__)
  if (kind == MemLoop::kCopyNonTemporal) {
    state.SkipWithError("no streaming stores in this build");
    return;
  }
#endif
  MemArrays m(kind);
  double one = 1.0;
  benchmark::DoNotOptimize(one);
  m.Run(threads, one);  // first touch of the output pages
  for (auto _ : state) {
    m.Run(threads, one);
    benchmark::ClobberMemory();
  }
  state.counters["bytes_per_s"] = benchmark::Counter(
      m.Bytes() * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["threads"] = threads;
  state.SetLabel(Name(kind));
}

void BM_TraceSingleRayLoop(benchmark::State& state) {
  const auto seq = Ni320().Outward();
  const auto rays = FanOfRays(kRays);
  std::vector<Ray> out(rays.size());
  const double cpu0 = ProcessCpuSeconds();
  for (auto _ : state) {
    for (std::size_t i = 0; i < rays.size(); ++i) {
      porthole::optics::TraceSequence<double>(seq, rays[i], &out[i]);
    }
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  SetRates(state, kRays, seq.size(), ProcessCpuSeconds() - cpu0);
  state.counters["threads"] = 1;
}

bool Supported(Isa isa) {
  const auto isas = porthole::optics::SupportedIsas();
  return std::find(isas.begin(), isas.end(), isa) != isas.end();
}

// Args: {isa (Isa enum value), threads, rays}.
void BM_TraceBatch(benchmark::State& state) {
  const auto isa = static_cast<Isa>(state.range(0));
  state.SetLabel(std::string(porthole::optics::ToString(isa)));
  if (!Supported(isa)) {
    state.SkipWithError("this processor lacks the instruction set");
    return;
  }
  const auto seq = Ni320().Outward();
  const std::size_t n_rays = static_cast<std::size_t>(state.range(2));
  const auto rays = FanOfRays(n_rays);
  const RayBatch in = ToBatch(rays);
  RayBatch out;
  porthole::optics::BatchOptions opt;
  opt.num_threads = static_cast<int>(state.range(1));
  opt.isa = isa;
  porthole::optics::TraceBatch(seq, in, &out, opt);  // first touch of the output pages
  const double cpu0 = ProcessCpuSeconds();
  const auto wall0 = std::chrono::steady_clock::now();
  for (auto _ : state) {
    porthole::optics::TraceBatch(seq, in, &out, opt);
    benchmark::DoNotOptimize(out.dx.data());
    benchmark::ClobberMemory();
  }
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  SetRates(state, static_cast<double>(n_rays), seq.size(), ProcessCpuSeconds() - cpu0);
  state.counters["threads"] = opt.num_threads;
  if (n_rays == kRays) {  // streams from memory: the roofline
    const double bytes_per_s =
        kTraceBytesPerRay * static_cast<double>(n_rays * state.iterations()) / wall_s;
    state.counters["bytes_per_s"] = bytes_per_s;
    state.counters["of_memory_roofline"] = bytes_per_s / CopyBandwidth(opt.num_threads);
  }
  // Accuracy beside speed: the batch against the single-ray tracer on a sample of the same rays.
  double max_diff = 0;
  for (std::size_t i = 0; i < rays.size(); i += 97) {
    Ray r;
    porthole::optics::TraceSequence<double>(seq, rays[i], &r);
    max_diff = std::max(max_diff, (out.Get(i).dir - r.dir).norm());
  }
  state.counters["max_dir_diff"] = max_diff;
}

// The NumPy peer: writes the rays and the surfaces for bench_trace_numpy.py, which traces them
// `repeats` times and reports its best time (the trace alone, not the file reading); porthole is
// timed here on the same rays with the same best-of rule, and the answers are compared.
// Arg: NumPy's slice (rays per array operation): 0 = the whole 1 M-ray arrays at once (the plain
// way to write it), 32768 = slices whose temporaries stay in the cache (NumPy's fastest).
void BM_TraceNumpyPeer(benchmark::State& state) {
  const auto seq = Ni320().Outward();
  const std::size_t n = kRays;
  const std::size_t chunk = state.range(0) > 0 ? static_cast<std::size_t>(state.range(0)) : n;
  const auto rays = FanOfRays(n);
  const RayBatch in = ToBatch(rays);
  constexpr int kRepeats = 5;  // NumPy's best of 5 (~1 s); porthole's best of 4×5 (~0.1 s)

  namespace fs = std::filesystem;
  const std::string stem =
      (fs::temp_directory_path() / ("porthole_bench_trace_" + std::to_string(getpid()))).string();
  const std::string rays_path = stem + ".rays", out_path = stem + ".out",
                    spec_path = stem + ".json";
  {
    std::ofstream f(rays_path, std::ios::binary);
    for (const auto* v : {&in.ox, &in.oy, &in.oz, &in.dx, &in.dy, &in.dz}) {
      f.write(reinterpret_cast<const char*>(v->data()),
              static_cast<std::streamsize>(n * sizeof(double)));
    }
  }
  {
    std::ofstream f(spec_path);
    f.precision(17);
    auto vec = [](const Vec3& v) {
      char b[128];
      std::snprintf(b, sizeof b, "[%.17g, %.17g, %.17g]", v.x(), v.y(), v.z());
      return std::string(b);
    };
    f << "{\"rays\": \"" << rays_path << "\", \"out\": \"" << out_path << "\", \"n\": " << n
      << ", \"repeats\": " << kRepeats << ", \"chunk\": " << chunk << ", \"surfaces\": [";
    for (std::size_t k = 0; k < seq.size(); ++k) {
      const auto& s = seq[k].surface;
      f << (k ? ", " : "") << "{\"center_mm\": " << vec(s.center) << ", \"radius_mm\": " << s.radius
        << ", \"aperture_point_mm\": " << vec(s.aperture_point)
        << ", \"aperture_normal\": " << vec(s.aperture_normal)
        << ", \"n_before\": " << seq[k].n_before << ", \"n_after\": " << seq[k].n_after << "}";
    }
    f << "]}\n";
  }
  const std::string cmd =
      "/usr/bin/python3 " PORTHOLE_BENCH_DIR "/bench_trace_numpy.py " + spec_path;
  double numpy_s = 0, numpy_cpu_s = 0;
  for (auto _ : state) {
    const std::string text = porthole::bench::RunPeer(cmd);
    const auto at = text.find("\"seconds\": ");
    if (at == std::string::npos) {
      state.SkipWithError("NumPy peer failed (python3-numpy: scripts/install-deps)");
      break;
    }
    numpy_s = std::stod(text.substr(at + 11));
    const auto cpu_at = text.find("\"cpu_seconds\": ");
    numpy_cpu_s = cpu_at == std::string::npos ? 0 : std::stod(text.substr(cpu_at + 15));
    state.SetIterationTime(numpy_s);
  }
  if (numpy_s > 0) {
    // porthole on the same rays: every core, the kernel chosen at run time, best of kRepeats.
    RayBatch out;
    auto best_seconds = [&](int threads) {
      porthole::optics::BatchOptions opt;
      opt.num_threads = threads;
      double best = 1e30;
      for (int r = 0; r < 4 * kRepeats; ++r) {
        const auto t0 = std::chrono::steady_clock::now();
        porthole::optics::TraceBatch(seq, in, &out, opt);
        best = std::min(
            best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      }
      return best;
    };
    const double one_thread_s = best_seconds(1);
    const double best_s = best_seconds(2);
    // What 2 cores can give at most, measured here: twice one core's rate in cache (the first
    // 32 k rays, best of 100) and the memory roofline (CopyBandwidth: 98 B per ray).
    RayBatch in_cache, in_cache_out;
    in_cache.resize(std::size_t{1} << 15);
    for (std::size_t i = 0; i < in_cache.size(); ++i) in_cache.Set(i, rays[i]);
    // Each also per second of CPU time (best of the same runs), which other jobs on the machine
    // disturb far less than wall-clock time: NumPy runs on one thread, and porthole's one-thread
    // runs on this one.
    double in_cache_s = 1e30, in_cache_cpu_s = 1e30;
    porthole::optics::BatchOptions one_thread;
    one_thread.num_threads = 1;
    for (int r = 0; r < 100; ++r) {
      const auto t0 = std::chrono::steady_clock::now();
      const double c0 = ThreadCpuSeconds();
      porthole::optics::TraceBatch(seq, in_cache, &in_cache_out, one_thread);
      in_cache_cpu_s = std::min(in_cache_cpu_s, ThreadCpuSeconds() - c0);
      in_cache_s = std::min(
          in_cache_s, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    double one_thread_cpu_s = 1e30;
    for (int r = 0; r < 4 * kRepeats; ++r) {
      const double c0 = ThreadCpuSeconds();
      porthole::optics::TraceBatch(seq, in, &out, one_thread);
      one_thread_cpu_s = std::min(one_thread_cpu_s, ThreadCpuSeconds() - c0);
    }
    // The NumPy answer against porthole's, ray by ray.
    std::vector<double> np_rays(6 * n);
    std::vector<std::uint8_t> np_status(n);
    std::ifstream f(out_path, std::ios::binary);
    f.read(reinterpret_cast<char*>(np_rays.data()),
           static_cast<std::streamsize>(np_rays.size() * sizeof(double)));
    f.read(reinterpret_cast<char*>(np_status.data()), static_cast<std::streamsize>(n));
    double max_diff = 0;
    int mismatches = 0;
    for (std::size_t i = 0; i < n && f; ++i) {
      const Vec3 d(np_rays[3 * n + i], np_rays[4 * n + i], np_rays[5 * n + i]);
      max_diff = std::max(max_diff, (out.Get(i).dir - d).norm());
      mismatches += static_cast<int>(out.status[i]) != np_status[i];
    }
    if (!f) mismatches = -1;
    const double rs = static_cast<double>(n * seq.size());
    state.counters["ray_surfaces_per_s"] = rs / numpy_s;
    state.counters["rays_per_s"] = static_cast<double>(n) / numpy_s;
    state.counters["porthole_ray_surfaces_per_s"] = rs / best_s;
    state.counters["porthole_over_numpy"] = numpy_s / best_s;
    state.counters["porthole_1thread_over_numpy"] = numpy_s / one_thread_s;
    // Issue 13's 25×, against the two ceilings of 2 cores (ray-surfaces/s).
    state.counters["for_25x_ray_surfaces_per_s"] = 25 * rs / numpy_s;
    state.counters["ceiling_2x1core_in_cache"] =
        2 * static_cast<double>(in_cache.size() * seq.size()) / in_cache_s;
    state.counters["ceiling_memory_2threads"] =
        CopyBandwidth(2) / kTraceBytesPerRay * static_cast<double>(seq.size());
    if (numpy_cpu_s > 0) {  // the same per CPU-second
      state.counters["numpy_ray_surfaces_per_cpu_s"] = rs / numpy_cpu_s;
      state.counters["for_25x_per_cpu_s"] = 25 * rs / numpy_cpu_s;
      state.counters["porthole_1thread_over_numpy_per_cpu_s"] = numpy_cpu_s / one_thread_cpu_s;
      state.counters["ceiling_2x1core_in_cache_per_cpu_s"] =
          2 * static_cast<double>(in_cache.size() * seq.size()) / in_cache_cpu_s;
    }
    state.counters["max_dir_diff"] = max_diff;
    state.counters["status_mismatches"] = mismatches;
    state.counters["threads"] = 1;
    state.SetLabel(
        "numpy (slices of " + std::to_string(chunk) + " rays) vs porthole " +
        std::string(porthole::optics::ToString(porthole::optics::ResolveIsa(Isa::kAuto))) +
        " 2 threads");
  }
  for (const auto& p : {rays_path, out_path, spec_path}) std::remove(p.c_str());
}

// {MemLoop, threads}: the memory loops first, so that the trace's roofline is at hand.
BENCHMARK(BM_MemoryBandwidth)
    ->ArgsProduct({{static_cast<std::int64_t>(MemLoop::kCopy),
                    static_cast<std::int64_t>(MemLoop::kCopyNonTemporal),
                    static_cast<std::int64_t>(MemLoop::kTriad)},
                   {1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_TraceSingleRayLoop)->Unit(benchmark::kMillisecond)->UseRealTime();
// {isa, threads, rays}: every kernel on 1 and 2 threads, 1 M rays (memory) and 32 k (cache).
void BatchArgs(benchmark::internal::Benchmark* b) {
  for (const Isa isa : {Isa::kSse2, Isa::kAvx2, Isa::kAvx512}) {
    for (const std::int64_t rays : {std::int64_t{kRays}, std::int64_t{1} << 15}) {
      for (const std::int64_t threads : {1, 2})
        b->Args({static_cast<std::int64_t>(isa), threads, rays});
    }
  }
}
BENCHMARK(BM_TraceBatch)->Apply(BatchArgs)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_TraceNumpyPeer)
    ->Arg(0)
    ->Arg(1 << 15)
    ->Unit(benchmark::kMillisecond)
    ->UseManualTime()
    ->Iterations(1);

}  // namespace
