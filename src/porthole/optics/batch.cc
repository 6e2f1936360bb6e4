#include "porthole/optics/batch.h"

#include <omp.h>

#include <algorithm>
#include <cstdlib>
#include <string>

#include "porthole/core/error.h"
#include "porthole/optics/batch_isa.h"

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

std::string_view ToString(Isa isa) {
  switch (isa) {
    case Isa::kAuto: return "auto";
    case Isa::kSse2: return "sse2";
    case Isa::kAvx2: return "avx2";
    case Isa::kAvx512: return "avx512";
  }
  return "unknown";
}

Isa ParseIsa(std::string_view name, std::string_view field) {
  for (Isa isa : {Isa::kAuto, Isa::kSse2, Isa::kAvx2, Isa::kAvx512}) {
    if (name == ToString(isa)) return isa;
  }
  throw InvalidInput(std::string(field), "must be one of auto, sse2, avx2, avx512 (got '" +
                                             std::string(name) + "')");
}

namespace {

// Whether this build has the kernel and this processor (and its operating system, which must save
// the wide registers: __builtin_cpu_supports checks that too) runs it.
bool Runs(Isa isa) {
#if defined(PORTHOLE_OPTICS_X86_KERNELS)
  __builtin_cpu_init();
  const bool avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  switch (isa) {
    case Isa::kSse2: return true;
    case Isa::kAvx2: return avx2;
    case Isa::kAvx512:
      return avx2 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
             __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512bw");
    case Isa::kAuto: return false;
  }
  return false;
#else
  return isa == Isa::kSse2;
#endif
}

batch_detail::Kernels KernelsOf(Isa isa) {
  switch (isa) {
#if defined(PORTHOLE_OPTICS_X86_KERNELS)
    case Isa::kAvx2: return batch_detail::KernelsAvx2();
    case Isa::kAvx512: return batch_detail::KernelsAvx512();
#endif
    default: return batch_detail::KernelsSse2();
  }
}

std::string SupportedList() {
  std::string s;
  for (Isa isa : SupportedIsas()) s += (s.empty() ? "" : ", ") + std::string(ToString(isa));
  return s;
}

Isa Require(Isa isa, const std::string& field) {
  if (!Runs(isa)) {
    throw InvalidInput(field, std::string(ToString(isa)) +
                                  " is not supported by this processor or build (supported: " +
                                  SupportedList() + ")");
  }
  return isa;
}

// One interface over rays [begin, end) of `in`, written to `out` (which may be `in`).
void TraceRange(const batch_detail::Kernels& k, const Interface& f, const RayBatch& in,
                RayBatch* out, std::ptrdiff_t begin, std::ptrdiff_t end) {
  const batch_detail::SoaView v{in.ox.data(), in.oy.data(), in.oz.data(), in.dx.data(),
                                in.dy.data(), in.dz.data(), in.status.data()};
  const batch_detail::SoaOut o{out->ox.data(), out->oy.data(), out->oz.data(), out->dx.data(),
                               out->dy.data(), out->dz.data(), out->status.data()};
  (f.surface.kind == Surface::Kind::kSphere ? k.sphere : k.plane)(f, v, o, begin, end);
}

}  // namespace

std::vector<Isa> SupportedIsas() {
  std::vector<Isa> out;
  for (Isa isa : {Isa::kSse2, Isa::kAvx2, Isa::kAvx512}) {
    if (Runs(isa)) out.push_back(isa);
  }
  return out;
}

Isa ResolveIsa(Isa requested) {
  if (requested != Isa::kAuto) return Require(requested, "isa");
  static const Isa from_env = [] {
    const char* v = std::getenv("PORTHOLE_ISA");
    return v == nullptr || *v == '\0' ? Isa::kAuto : ParseIsa(v, "PORTHOLE_ISA");
  }();
  if (from_env != Isa::kAuto) return Require(from_env, "PORTHOLE_ISA");
  static const Isa widest = SupportedIsas().back();
  return widest;
}

void TraceBatch(const std::vector<Interface>& seq, RayBatch* rays, const BatchOptions& options) {
  TraceBatch(seq, *rays, rays, options);
}

void TraceBatch(const std::vector<Interface>& seq, const RayBatch& in, RayBatch* out,
                const BatchOptions& options) {
  const auto n = static_cast<std::ptrdiff_t>(in.size());
  if (out != &in) out->resize(in.size());
  const batch_detail::Kernels kernels = KernelsOf(ResolveIsa(options.isa));
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
  // Blocks are handed out one at a time (a few µs of work each): on a machine shared with other
  // work, a thread the system pauses delays the batch by at most one block, as the others take
  // over the rest (a static split would wait for its whole share).
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
  for (std::ptrdiff_t b = 0; b < blocks; ++b) {
    const std::ptrdiff_t begin = b * kBlock;
    const std::ptrdiff_t end = std::min(n, begin + kBlock);
    TraceRange(kernels, seq.front(), in, out, begin, end);
    for (std::size_t k = 1; k < seq.size(); ++k) TraceRange(kernels, seq[k], *out, out, begin, end);
  }
}

}  // namespace porthole::optics
