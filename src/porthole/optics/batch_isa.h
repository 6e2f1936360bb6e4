// Internal to the batched tracer: the per-instruction-set kernels and their dispatch table.
// Each kernel is the same source (batch_kernel.inc: Step() from trace.h over a range of rays)
// compiled once per instruction set; batch.cc picks one at run time.
#pragma once

#include <cstddef>

#include "porthole/optics/trace.h"

namespace porthole::optics::batch_detail {

// Rays [begin, end) of a structure of arrays. `in` and `out` may be the same arrays (in-place
// tracing): each ray is read before it is written, and only at its own index.
struct SoaView {
  const double *ox, *oy, *oz, *dx, *dy, *dz;
  const RayStatus* status;
};
struct SoaOut {
  double *ox, *oy, *oz, *dx, *dy, *dz;
  RayStatus* status;
};

// One interface over rays [begin, end): rays whose status is kOk take Step(); others are copied.
using RangeKernel = void (*)(const Interface& f, const SoaView& in, const SoaOut& out,
                             std::ptrdiff_t begin, std::ptrdiff_t end);
struct Kernels {
  RangeKernel sphere;
  RangeKernel plane;
  RangeKernel cylinder;
};

Kernels KernelsSse2();  // the compiler's baseline (SSE2 on x86-64): always present
#if defined(PORTHOLE_OPTICS_X86_KERNELS)
Kernels KernelsAvx2();    // compiled with -mavx2 -mfma
Kernels KernelsAvx512();  // compiled with -mavx512f/vl/dq/bw (and AVX2, FMA)
#endif

}  // namespace porthole::optics::batch_detail
