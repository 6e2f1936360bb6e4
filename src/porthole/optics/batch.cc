#include "porthole/optics/batch.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdlib>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "porthole/core/error.h"
#include "porthole/optics/batch_isa.h"

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>  // _mm_pause; SSE2 streaming stores
#endif

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

// Runs work(0) … work(blocks − 1) on the calling thread and up to threads − 1 helper threads,
// handing blocks out one at a time. The caller never waits for a helper that has not started:
// it takes blocks itself until none is left, then waits only for blocks other threads already
// hold. On a machine shared with other jobs a helper the system has not scheduled yet costs
// nothing (an OpenMP parallel loop, whose end waits for every thread of the team, took ~12 ms for
// a 0.3 ms batch there). Between batches a helper first looks for the next one for kSpin without
// sleeping, then sleeps, so that back-to-back batches (the renderer's, a benchmark's) find it
// awake rather than waiting on the system to wake it (a system call and a reschedule, for a batch
// that may itself take only some 100 µs). The caller likewise waits kSpin for the last blocks
// other threads hold before it sleeps. A spin is bounded: idle helpers sleep.
class BlockPool {
 public:
  static BlockPool& Instance() {
    static BlockPool pool;
    return pool;
  }

  void Run(int threads, std::ptrdiff_t blocks, const std::function<void(std::ptrdiff_t)>& work) {
    if (threads <= 1 || blocks <= 1) {
      for (std::ptrdiff_t b = 0; b < blocks; ++b) work(b);
      return;
    }
    auto job = std::make_shared<Job>();
    job->work = &work;
    job->blocks = blocks;
    job->max_helpers = threads - 1;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (job_) {  // another thread's batch is running: trace this one here, alone
        job.reset();
      } else {
        while (static_cast<int>(helpers_.size()) < threads - 1) {
          helpers_.emplace_back([this] { HelperLoop(); });
        }
        job_ = job;
        ++generation_;
      }
    }
    if (!job) {
      for (std::ptrdiff_t b = 0; b < blocks; ++b) work(b);
      return;
    }
    wake_.notify_all();
    Help(job.get());
    SpinUntil([&] { return job->done.load(std::memory_order_acquire) == blocks; });
    std::unique_lock<std::mutex> lock(mutex_);
    done_.wait(lock, [&] { return job->done.load() == blocks; });
    job_.reset();
  }

  ~BlockPool() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_.store(true);
    }
    wake_.notify_all();
    for (auto& t : helpers_) t.join();
  }

 private:
  struct Job {
    const std::function<void(std::ptrdiff_t)>* work = nullptr;  // valid while blocks remain
    std::ptrdiff_t blocks = 0;
    int max_helpers = 0;
    std::atomic<std::ptrdiff_t> next{0};
    std::atomic<std::ptrdiff_t> done{0};
    std::atomic<int> helpers{0};
  };

  // Takes blocks until none is left. `work` is only called for a block below `blocks`, and the
  // caller of Run waits for every such block, so it is alive whenever it is called.
  void Help(Job* job) {
    for (;;) {
      const std::ptrdiff_t b = job->next.fetch_add(1);
      if (b >= job->blocks) return;
      (*job->work)(b);
      if (job->done.fetch_add(1) + 1 == job->blocks) {
        { std::lock_guard<std::mutex> lock(mutex_); }
        done_.notify_all();
      }
    }
  }

  // Returns when ready() or after kSpin, whichever comes first, without sleeping.
  template <typename Ready>
  static void SpinUntil(const Ready& ready) {
    const auto until = std::chrono::steady_clock::now() + kSpin;
    for (int i = 0; !ready(); ++i) {
#if defined(__x86_64__) || defined(__i386__)
      _mm_pause();
#endif
      if (i % 64 == 63 && std::chrono::steady_clock::now() > until) return;
    }
  }

  void HelperLoop() {
    std::uint64_t seen = 0;
    for (;;) {
      SpinUntil(
          [&] { return generation_.load(std::memory_order_acquire) != seen || stop_.load(); });
      std::shared_ptr<Job> job;  // shared: a late helper may still look at a finished job
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [&] { return stop_ || generation_ != seen; });
        if (stop_) return;
        seen = generation_;
        job = job_;
      }
      if (job && job->helpers.fetch_add(1) < job->max_helpers) Help(job.get());
    }
  }

  std::mutex mutex_;
  std::condition_variable wake_, done_;
  static constexpr std::chrono::microseconds kSpin{100};
  std::shared_ptr<Job> job_;                  // the running batch, if any
  std::atomic<std::uint64_t> generation_{0};  // written under mutex_, read by spinning helpers too
  std::atomic<bool> stop_{false};
  std::vector<std::thread> helpers_;
};

// Rays per block: small enough to stay in L1/L2 across the surfaces of the sequence.
constexpr std::ptrdiff_t kBlock = 1024;

batch_detail::SoaView ViewOf(const RayBatch& b, std::ptrdiff_t at) {
  return {b.ox.data() + at, b.oy.data() + at, b.oz.data() + at, b.dx.data() + at,
          b.dy.data() + at, b.dz.data() + at, b.status.data() + at};
}
batch_detail::SoaOut OutOf(RayBatch* b, std::ptrdiff_t at) {
  return {b->ox.data() + at, b->oy.data() + at, b->oz.data() + at, b->dx.data() + at,
          b->dy.data() + at, b->dz.data() + at, b->status.data() + at};
}
batch_detail::SoaView ViewOf(const batch_detail::SoaOut& o) {
  return {o.ox, o.oy, o.oz, o.dx, o.dy, o.dz, o.status};
}

// One interface over rays [0, m) of `in`, written to `out` (which may be `in`).
void TraceRange(const batch_detail::Kernels& k, const Interface& f, const batch_detail::SoaView& in,
                const batch_detail::SoaOut& out, std::ptrdiff_t m) {
  const Surface::Kind kind = f.surface.kind;
  (kind == Surface::Kind::kSphere  ? k.sphere
   : kind == Surface::Kind::kPlane ? k.plane
                                   : k.cylinder)(f, in, out, 0, m);
}

// Out-of-place batches of BatchOptions::stream_min rays or more write their results with
// streaming (non-temporal) stores: each block is traced into a small per-thread buffer, then
// copied to `out` past the cache. An ordinary store first reads the line it writes ("read for
// ownership"), so a batch streamed from memory would move 49 B more per ray than it reads and
// writes. Smaller batches (the renderer's: ~1000 rays, read back at once) keep ordinary stores.
bool StreamStoresWork(const RayBatch& out) {
#if defined(__SSE2__)
  for (const void* p : {static_cast<const void*>(out.ox.data()), static_cast<const void*>(out.oy.data()),
                        static_cast<const void*>(out.oz.data()), static_cast<const void*>(out.dx.data()),
                        static_cast<const void*>(out.dy.data()), static_cast<const void*>(out.dz.data()),
                        static_cast<const void*>(out.status.data())}) {
    if (reinterpret_cast<std::uintptr_t>(p) % 16 != 0) return false;
  }
  return true;
#else
  (void)out;
  return false;
#endif
}

// Copies m rays from `from` to `to` with streaming stores; `to` 16-byte aligned (StreamStoresWork).
void StreamCopy(const batch_detail::SoaOut& from, const batch_detail::SoaOut& to, std::ptrdiff_t m) {
#if defined(__SSE2__)
  const double* src[6] = {from.ox, from.oy, from.oz, from.dx, from.dy, from.dz};
  double* dst[6] = {to.ox, to.oy, to.oz, to.dx, to.dy, to.dz};
  const std::ptrdiff_t m2 = m - m % 2, m16 = m - m % 16;
  for (int k = 0; k < 6; ++k) {
    for (std::ptrdiff_t i = 0; i < m2; i += 2) _mm_stream_pd(dst[k] + i, _mm_loadu_pd(src[k] + i));
    if (m2 < m) dst[k][m2] = src[k][m2];
  }
  for (std::ptrdiff_t i = 0; i < m16; i += 16) {
    _mm_stream_si128(reinterpret_cast<__m128i*>(to.status + i),
                     _mm_loadu_si128(reinterpret_cast<const __m128i*>(from.status + i)));
  }
  for (std::ptrdiff_t i = m16; i < m; ++i) to.status[i] = from.status[i];
  _mm_sfence();  // streaming stores are weakly ordered: done before the block is reported done
#else
  (void)from, (void)to, (void)m;
#endif
}

// A per-thread buffer of kBlock rays (on the heap: large thread_local storage does not suit a
// library the Python module loads).
batch_detail::SoaOut BlockBuffer() {
  thread_local std::vector<double> xyz(6 * kBlock);
  thread_local std::vector<RayStatus> status(kBlock);
  double* p = xyz.data();
  return {p, p + kBlock, p + 2 * kBlock, p + 3 * kBlock, p + 4 * kBlock, p + 5 * kBlock,
          status.data()};
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

void ParallelBlocks(int threads, std::ptrdiff_t blocks, const std::function<void(std::ptrdiff_t)>& work) {
  BlockPool::Instance().Run(threads > 0 ? threads : omp_get_max_threads(), blocks, work);
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
  const std::ptrdiff_t blocks = (n + kBlock - 1) / kBlock;
  const int threads = static_cast<std::size_t>(n) < options.min_parallel ? 1
                      : options.num_threads > 0                        ? options.num_threads
                                                                       : omp_get_max_threads();
  const bool stream = out != &in && in.size() >= options.stream_min && StreamStoresWork(*out);
  BlockPool::Instance().Run(threads, blocks, [&](std::ptrdiff_t b) {
    const std::ptrdiff_t begin = b * kBlock;
    const std::ptrdiff_t m = std::min(n, begin + kBlock) - begin;
    const batch_detail::SoaOut o = stream ? BlockBuffer() : OutOf(out, begin);
    TraceRange(kernels, seq.front(), ViewOf(in, begin), o, m);
    for (std::size_t k = 1; k < seq.size(); ++k) TraceRange(kernels, seq[k], ViewOf(o), o, m);
    if (stream) StreamCopy(o, OutOf(out, begin), m);
  });
}

}  // namespace porthole::optics
