#include "porthole/optics/batch.h"

#include <omp.h>

#include <algorithm>

namespace porthole::optics {

void RayBatch::resize(std::size_t n) {
  for (auto* v : {&ox, &oy, &oz, &dx, &dy, &dz}) v->resize(n);
  status.resize(n, RayStatus::kOk);
}

void RayBatch::Set(std::size_t i, const Ray& r) {
  ox[i] = r.origin.x();
  oy[i] = r.origin.y();
  oz[i] = r.origin.z();
  dx[i] = r.dir.x();
  dy[i] = r.dir.y();
  dz[i] = r.dir.z();
  status[i] = RayStatus::kOk;
}

Ray RayBatch::Get(std::size_t i) const {
  return Ray{Vec3(ox[i], oy[i], oz[i]), Vec3(dx[i], dy[i], dz[i])};
}

namespace {

// One interface over rays [begin, end). The loop body is Step() on locals, which gcc vectorises
// once inlined (the surface kind is the same for every iteration).
void TraceRange(const Interface& f, RayBatch* r, std::ptrdiff_t begin, std::ptrdiff_t end) {
  double* __restrict ox = r->ox.data();
  double* __restrict oy = r->oy.data();
  double* __restrict oz = r->oz.data();
  double* __restrict dx = r->dx.data();
  double* __restrict dy = r->dy.data();
  double* __restrict dz = r->dz.data();
  RayStatus* __restrict st = r->status.data();
#pragma omp simd
  for (std::ptrdiff_t i = begin; i < end; ++i) {
    Vec3 o(ox[i], oy[i], oz[i]);
    Vec3 d(dx[i], dy[i], dz[i]);
    const RayStatus s = Step<double>(f, &o, &d);
    const bool live = st[i] == RayStatus::kOk;
    ox[i] = live ? o.x() : ox[i];
    oy[i] = live ? o.y() : oy[i];
    oz[i] = live ? o.z() : oz[i];
    dx[i] = live ? d.x() : dx[i];
    dy[i] = live ? d.y() : dy[i];
    dz[i] = live ? d.z() : dz[i];
    st[i] = live ? s : st[i];
  }
}

}  // namespace

void TraceBatch(const std::vector<Interface>& seq, RayBatch* rays, const BatchOptions& options) {
  const auto n = static_cast<std::ptrdiff_t>(rays->size());
  // Blocks small enough to stay in L1/L2 across the surfaces of the sequence.
  constexpr std::ptrdiff_t kBlock = 1024;
  const std::ptrdiff_t blocks = (n + kBlock - 1) / kBlock;
  const int threads = static_cast<std::size_t>(n) < options.min_parallel ? 1
                      : options.num_threads > 0                        ? options.num_threads
                                                                       : omp_get_max_threads();
#pragma omp parallel for schedule(static) num_threads(threads)
  for (std::ptrdiff_t b = 0; b < blocks; ++b) {
    const std::ptrdiff_t begin = b * kBlock;
    const std::ptrdiff_t end = std::min(n, begin + kBlock);
    for (const Interface& f : seq) TraceRange(f, rays, begin, end);
  }
}

}  // namespace porthole::optics
