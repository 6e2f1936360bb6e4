// Batched ray tracing for millions of rays: structure of arrays, vectorised loops, all cores.
// Each ray runs through exactly the same Step() as the single-ray tracer (trace.h), so the two
// agree bit for bit; tests check that for every instruction set.
//
// Instruction sets: the loop over rays is compiled once per vector width — the baseline (SSE2 on
// x86-64, 2 doubles), AVX2 + FMA (4) and AVX-512 F/VL/DQ/BW (8) — and the widest one the
// processor runs is chosen once, at the first call. BatchOptions::isa, or the environment
// variable PORTHOLE_ISA (sse2, avx2, avx512 or auto), forces one.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string_view>
#include <vector>

#include "porthole/optics/trace.h"

namespace porthole::optics {

// Rays as a structure of arrays (mm, unit directions, one frame). `status` starts kOk; a ray whose
// status is not kOk is left untouched by further tracing.
struct RayBatch {
  std::vector<double> ox, oy, oz, dx, dy, dz;
  std::vector<RayStatus> status;

  std::size_t size() const { return ox.size(); }
  void resize(std::size_t n);
  void Set(std::size_t i, const Ray& r);
  Ray Get(std::size_t i) const;
};

// The instruction set of the batched tracer's kernel. kAuto: PORTHOLE_ISA if set, otherwise the
// widest the processor supports.
enum class Isa : std::uint8_t { kAuto, kSse2, kAvx2, kAvx512 };
std::string_view ToString(Isa isa);  // "auto", "sse2", "avx2", "avx512"
// Parses a name as ToString writes it; InvalidInput(field, ...) for anything else.
Isa ParseIsa(std::string_view name, std::string_view field = "isa");
// The kernels this build has and this processor runs, narrowest (the baseline, always present)
// first.
std::vector<Isa> SupportedIsas();
// The kernel TraceBatch runs for `requested`: kAuto resolved (PORTHOLE_ISA, read once, else the
// widest supported). InvalidInput when the request (or PORTHOLE_ISA) names a kernel this build or
// this processor lacks, or PORTHOLE_ISA is not a known name.
Isa ResolveIsa(Isa requested);

struct BatchOptions {
  int num_threads = 0;  // 0: every core (omp_get_max_threads(), so OMP_NUM_THREADS); 1: this thread
  std::size_t min_parallel = 4096;  // smaller batches run on one thread: threads cost ~10 µs
  Isa isa = Isa::kAuto;            // the kernel's instruction set (see ResolveIsa)
  // Out-of-place batches of at least this many rays write their results with streaming
  // (non-temporal) stores, past the cache: for batches larger than the cache, whose results are
  // not in it when read anyway, this saves the memory read an ordinary store makes first.
  std::size_t stream_min = std::size_t{1} << 18;
};

// Traces every ray in `rays` through `seq`, in place: on return each ray with status kOk is the
// ray after the last surface; others hold their failure status and the point where they stopped.
void TraceBatch(const std::vector<Interface>& seq, RayBatch* rays,
                const BatchOptions& options = {});

// The same, out of place: `in` is left as it is and `out` receives the traced rays (resized).
void TraceBatch(const std::vector<Interface>& seq, const RayBatch& in, RayBatch* out,
                const BatchOptions& options = {});

// Runs work(0) … work(blocks − 1) on the calling thread and up to threads − 1 helpers of the
// batched tracer's thread pool (threads 0: every core, as BatchOptions::num_threads), handing
// blocks out one at a time; returns when all are done. For work around the tracer that should
// use the same threads (the renderer's ray generation and shading); a TraceBatch called inside
// `work` runs on its caller's thread.
void ParallelBlocks(int threads, std::ptrdiff_t blocks, const std::function<void(std::ptrdiff_t)>& work);

}  // namespace porthole::optics
