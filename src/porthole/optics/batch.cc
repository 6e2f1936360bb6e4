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

// One interface over rays [begin, end), reading `in` and writing `out` (which may be the same).
// The loop body is Step() on locals, which gcc vectorises once inlined (the surface kind is the
// same for every iteration).
template <KindHint Kind>
PORTHOLE_INLINE void TraceRangeOf(const Interface& f_in, const RayBatch& in, RayBatch* out, std::ptrdiff_t begin,
                  std::ptrdiff_t end) {
  const Interface f = f_in;  // a local copy: provably not aliased by the stores below
  const double* __restrict ix = in.ox.data();
  const double* __restrict iy = in.oy.data();
  const double* __restrict iz = in.oz.data();
  const double* __restrict jx = in.dx.data();
  const double* __restrict jy = in.dy.data();
  const double* __restrict jz = in.dz.data();
  const RayStatus* __restrict is = in.status.data();
  double* ox = out->ox.data();
  double* oy = out->oy.data();
  double* oz = out->oz.data();
  double* dx = out->dx.data();
  double* dy = out->dy.data();
  double* dz = out->dz.data();
  RayStatus* st = out->status.data();
#pragma omp simd
  for (std::ptrdiff_t i = begin; i < end; ++i) {
    P3<double> o{ix[i], iy[i], iz[i]};
    P3<double> d{jx[i], jy[i], jz[i]};
    const RayStatus s = Step<double, Kind>(f, &o, &d);
    const bool live = is[i] == RayStatus::kOk;
    ox[i] = live ? o.x : ix[i];
    oy[i] = live ? o.y : iy[i];
    oz[i] = live ? o.z : iz[i];
    dx[i] = live ? d.x : jx[i];
    dy[i] = live ? d.y : jy[i];
    dz[i] = live ? d.z : jz[i];
    st[i] = live ? s : is[i];
  }
}

void TraceRange(const Interface& f, const RayBatch& in, RayBatch* out, std::ptrdiff_t begin,
                std::ptrdiff_t end) {
  if (f.surface.kind == Surface::Kind::kSphere) {
    TraceRangeOf<KindHint::kSphere>(f, in, out, begin, end);
  } else {
    TraceRangeOf<KindHint::kPlane>(f, in, out, begin, end);
  }
}

}  // namespace

void TraceBatch(const std::vector<Interface>& seq, RayBatch* rays, const BatchOptions& options) {
  TraceBatch(seq, *rays, rays, options);
}

void TraceBatch(const std::vector<Interface>& seq, const RayBatch& in, RayBatch* out,
                const BatchOptions& options) {
  const auto n = static_cast<std::ptrdiff_t>(in.size());
  if (out != &in) out->resize(in.size());
  if (seq.empty()) {
    if (out != &in) *out = in;
    return;
  }
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
    TraceRange(seq.front(), in, out, begin, end);
    for (std::size_t k = 1; k < seq.size(); ++k) TraceRange(seq[k], *out, out, begin, end);
  }
}

}  // namespace porthole::optics
