// Batched ray tracing for millions of rays: structure of arrays, vectorised loops, all cores.
// Each ray runs through exactly the same Step() as the single-ray tracer (trace.h), so the two
// agree bit for bit; tests check that.
#pragma once

#include <cstddef>
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

struct BatchOptions {
  int num_threads = 0;             // 0: every core (OpenMP default); 1: this thread only
  std::size_t min_parallel = 4096;  // smaller batches run on one thread: threads cost ~10 µs
};

// Traces every ray in `rays` through `seq`, in place: on return each ray with status kOk is the
// ray after the last surface; others hold their failure status and the point where they stopped.
void TraceBatch(const std::vector<Interface>& seq, RayBatch* rays, const BatchOptions& options = {});

// The same, out of place: `in` is left as it is and `out` receives the traced rays (resized).
void TraceBatch(const std::vector<Interface>& seq, const RayBatch& in, RayBatch* out,
                const BatchOptions& options = {});

}  // namespace porthole::optics
