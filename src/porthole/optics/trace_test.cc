// Proves the ray tracer obeys the physics: Snell's law as an invariant, reversibility, undeviated
// rays through the centre of a concentric shell, total internal reflection reported, and that the
// batched and Jet tracers give the single-ray answer.
#include <Eigen/Geometry>
#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <thread>
#include <utility>

#include "porthole/core/error.h"
#include "porthole/optics/batch.h"
#include "porthole/optics/trace.h"

namespace porthole::optics {
namespace {

// A thick concentric shell around `c` (inner 75.7, outer 83.4 mm), air → glass → water outward.
std::vector<Interface> Shell(const Vec3& c_in, const Vec3& c_out, double n_glass, double n_water) {
  return {Interface{Surface::MakeSphere(c_in, 75.7), 1.0, n_glass},
          Interface{Surface::MakeSphere(c_out, 83.4), n_glass, n_water}};
}

Vec3 RandomUnitForward(std::mt19937& rng, double max_angle) {
  std::uniform_real_distribution<double> u(0, 1);
  const double th = max_angle * std::sqrt(u(rng)), ph = 2 * M_PI * u(rng);
  return Vec3(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th));
}

TEST(Refract, SnellInvariantAndUnitLength) {
  std::mt19937 rng(1);
  for (int k = 0; k < 1000; ++k) {
    const Vec3 d = RandomUnitForward(rng, 1.2);
    const Vec3 n = RandomUnitForward(rng, 0.3);
    Vec3 t;
    ASSERT_TRUE(Refract<double>(d, n, 1.0, 1.5168, &t));
    // Tangential component scaled by the index is conserved: n1 (d × n) = n2 (t × n).
    EXPECT_NEAR(((1.0 * d.cross(n)) - (1.5168 * t.cross(n))).norm(), 0, 1e-14);
    EXPECT_NEAR(t.norm(), 1.0, 1e-14);
    // The refracted ray stays on the same side (transmitted, not reflected).
    EXPECT_GT(t.dot(n) * d.dot(n), 0);
  }
}

TEST(Refract, NormalIncidenceIsUndeviatedEitherNormalOrientation) {
  Vec3 t;
  ASSERT_TRUE(Refract<double>(Vec3(0, 0, 1), Vec3(0, 0, 1), 1.0, 1.33, &t));
  EXPECT_NEAR((t - Vec3(0, 0, 1)).norm(), 0, 1e-15);
  ASSERT_TRUE(Refract<double>(Vec3(0, 0, 1), Vec3(0, 0, -1), 1.0, 1.33, &t));
  EXPECT_NEAR((t - Vec3(0, 0, 1)).norm(), 0, 1e-15);
}

TEST(Refract, TotalInternalReflectionBeyondCriticalAngle) {
  const double n1 = 1.5168, n2 = 1.0, crit = std::asin(n2 / n1);
  Vec3 t;
  const Vec3 n(0, 0, 1);
  EXPECT_TRUE(
      Refract<double>(Vec3(std::sin(crit - 1e-6), 0, std::cos(crit - 1e-6)), n, n1, n2, &t));
  EXPECT_FALSE(
      Refract<double>(Vec3(std::sin(crit + 1e-6), 0, std::cos(crit + 1e-6)), n, n1, n2, &t));
}

TEST(TraceSequence, ConcentricShellLeavesCentralRaysUndeviated) {
  const Vec3 c(0.3, -0.2, 21.5);
  const auto seq = Shell(c, c, 1.5168, 1.341);
  std::mt19937 rng(2);
  for (int k = 0; k < 500; ++k) {
    const Vec3 d = RandomUnitForward(rng, 1.4);
    Ray out;
    ASSERT_EQ(TraceSequence<double>(seq, Ray{c, d}, &out), RayStatus::kOk);
    EXPECT_NEAR((out.dir - d).norm(), 0, 1e-13);
    EXPECT_NEAR((out.origin - c).norm(), 83.4, 1e-10);
  }
}

TEST(TraceSequence, ReversedRayReturnsToItsStart) {
  // A decentred, non-concentric shell and an off-centre start: a generic case.
  const auto seq = Shell(Vec3(-0.4, -1.5, 20.3), Vec3(-0.4, -1.0, 21.5), 1.5168, 1.341);
  const auto back = Reversed(seq);
  std::mt19937 rng(3);
  for (int k = 0; k < 500; ++k) {
    const Ray start{Vec3(0, 0, 26.9), RandomUnitForward(rng, 1.2)};
    Ray out, ret;
    ASSERT_EQ(TraceSequence<double>(seq, start, &out), RayStatus::kOk);
    // Walk 500 mm into the water, then trace back towards the camera.
    const Ray in_water{out.origin + 500 * out.dir, -out.dir};
    ASSERT_EQ(TraceSequence<double>(back, in_water, &ret), RayStatus::kOk);
    // The returning ray, extended back through the air, passes through the start point.
    const Vec3 w = start.origin - ret.origin;
    const double miss = (w - w.dot(ret.dir) * ret.dir).norm();
    EXPECT_LT(miss, 1e-10);
    EXPECT_NEAR((ret.dir + start.dir).norm(), 0, 1e-12);
  }
}

TEST(TraceSequence, StatusesAreReportedNotDropped) {
  // A flat glass plate seen from the water side at grazing incidence: TIR at glass → air is
  // impossible from water (n_w sin θ < n_g), but from a denser liquid it happens.
  std::vector<Interface> plate = {
      Interface{Surface::MakePlane(Vec3(0, 0, 10), Vec3(0, 0, 1)), 1.0, 1.5},
      Interface{Surface::MakePlane(Vec3(0, 0, 15), Vec3(0, 0, 1)), 1.5, 1.6}};
  Ray out;
  int at = -2;
  // A ray going away from the plate misses it.
  EXPECT_EQ(TraceSequence<double>(plate, Ray{Vec3(0, 0, 0), Vec3(0, 0, -1)}, &out, nullptr, &at),
            RayStatus::kMissed);
  EXPECT_EQ(at, 0);
  // From the dense side back into air: TIR at the glass → air surface.
  const auto back = Reversed(plate);
  const double a = 60 * M_PI / 180;  // 1.6 sin 60° = 1.39: passes into glass, not into air
  EXPECT_EQ(TraceSequence<double>(back, Ray{Vec3(0, 0, 20), Vec3(std::sin(a), 0, -std::cos(a))},
                                  &out, nullptr, &at),
            RayStatus::kTotalInternalReflection);
  EXPECT_EQ(at, 1);
  // A dome rim: glass only where z >= 21.5.
  auto seq = Shell(Vec3(0, 0, 21.5), Vec3(0, 0, 21.5), 1.5168, 1.341);
  seq[0].surface.aperture_point = Vec3(0, 0, 21.5);
  seq[0].surface.aperture_normal = Vec3(0, 0, 1);
  EXPECT_EQ(TraceSequence<double>(seq, Ray{Vec3(0, 0, 26.9), Vec3(0, 0, -1)}, &out),
            RayStatus::kOutsideAperture);
}

TEST(TraceSequence, RecordsPathForDiagrams) {
  const auto seq = Shell(Vec3(0, 0, 21.5), Vec3(0, 0, 21.5), 1.5168, 1.341);
  Ray out;
  RayPath path;
  ASSERT_EQ(TraceSequence<double>(seq, Ray{Vec3(0, 0, 26.9), Vec3(0, 0.6, 0.8)}, &out, &path),
            RayStatus::kOk);
  ASSERT_EQ(path.points.size(), 3u);
  EXPECT_NEAR((path.points[1] - Vec3(0, 0, 21.5)).norm(), 75.7, 1e-10);
  EXPECT_NEAR((path.points[2] - Vec3(0, 0, 21.5)).norm(), 83.4, 1e-10);
}

// A brute-force trace through coaxial cylinders, sharing nothing with the tracer's formulas: the
// intersection by bisection on the implicit surface |(p − c) across the axis| = r along the ray,
// and Snell's law in angles in the plane of incidence (θ₂ = asin(n₁ sin θ₁ / n₂)).
struct BruteCylinder {
  Vec3 c, a;
  double r;
  double Implicit(const Vec3& p) const {
    const Vec3 q = p - c;
    return (q - q.dot(a) * a).norm() - r;
  }
};
bool BruteStep(const BruteCylinder& s, double n1, double n2, Vec3* o, Vec3* d) {
  // The first sign change of the implicit function along the ray, in 1e-3 mm steps, then bisection.
  double t0 = 1e-6, f0 = s.Implicit(*o + t0 * *d);
  double t1 = t0;
  bool found = false;
  for (int k = 0; k < 400000; ++k) {
    t1 = t0 + 1e-3;
    const double f1 = s.Implicit(*o + t1 * *d);
    if ((f0 < 0) != (f1 < 0)) {
      found = true;
      break;
    }
    t0 = t1;
    f0 = f1;
  }
  if (!found) return false;
  for (int k = 0; k < 200; ++k) {
    const double tm = 0.5 * (t0 + t1);
    if ((s.Implicit(*o + tm * *d) < 0) == (f0 < 0)) t0 = tm; else t1 = tm;
  }
  const Vec3 p = *o + 0.5 * (t0 + t1) * *d;
  Vec3 n = p - s.c;
  n = (n - n.dot(s.a) * s.a).normalized();
  if (n.dot(*d) < 0) n = -n;
  const Vec3 tangential = *d - d->dot(n) * n;
  const double sin1 = tangential.norm(), cos1 = d->dot(n);
  const double theta1 = std::atan2(sin1, cos1);
  const double theta2 = std::asin(n1 * std::sin(theta1) / n2);
  const Vec3 tdir = sin1 > 0 ? Vec3(tangential / sin1) : Vec3::Zero();
  *o = p;
  *d = std::cos(theta2) * n + std::sin(theta2) * tdir;
  return true;
}

// Rays from inside a cylindrical port (the pupil off its axis, axis rolled), traced by Step()
// and by the brute force above, agree within 1e-9 mm at both surfaces and 200 mm into the water,
// and the two Snell invariants hold at every surface.
TEST(TraceSequence, CylinderMatchesBruteForceSnell) {
  const Vec3 c(1.5, -2.0, 18.0), a = Vec3(0.08, 1, 0).normalized();
  const double r_in = 55.0, r_out = 61.0, n_glass = 1.49, n_water = 1.341;
  const std::vector<Interface> seq = {
      Interface{Surface::MakeCylinder(c, a, r_in), 1.0, n_glass},
      Interface{Surface::MakeCylinder(c, a, r_out), n_glass, n_water}};
  const BruteCylinder inner{c, a, r_in}, outer{c, a, r_out};
  std::mt19937 rng(11);
  int traced = 0;
  double worst_mm = 0;
  for (int k = 0; k < 300; ++k) {
    const Ray ray{Vec3::Zero(), RandomUnitForward(rng, 1.1)};
    RayPath path;
    Ray out;
    ASSERT_EQ(TraceSequence<double>(seq, ray, &out, &path), RayStatus::kOk);
    ASSERT_EQ(path.points.size(), 3u);
    Vec3 o = ray.origin, d = ray.dir;
    ASSERT_TRUE(BruteStep(inner, 1.0, n_glass, &o, &d));
    worst_mm = std::max(worst_mm, (o - path.points[1]).norm());
    ASSERT_TRUE(BruteStep(outer, n_glass, n_water, &o, &d));
    worst_mm = std::max(worst_mm, (o - path.points[2]).norm());
    worst_mm = std::max(worst_mm, ((o + 200 * d) - (out.origin + 200 * out.dir)).norm());
    // Snell at the exit: n_glass (d_glass × n) = n_water (d_water × n), the normal across the axis.
    Vec3 nrm = out.origin - c;
    nrm = (nrm - nrm.dot(a) * a).normalized();
    const Vec3 d_glass = (path.points[2] - path.points[1]).normalized();
    EXPECT_NEAR((n_glass * d_glass.cross(nrm) - n_water * out.dir.cross(nrm)).norm(), 0, 1e-12);
    ++traced;
  }
  EXPECT_EQ(traced, 300);
  EXPECT_LT(worst_mm, 1e-9);
  std::printf("cylinder: worst distance to the brute-force Snell trace %.3g mm over %d rays\n", worst_mm, traced);
}

// A ray along the cylinder's axis never meets it; the rim plane stops rays behind it.
TEST(TraceSequence, CylinderAxialRayMissesAndRimStops) {
  Interface f{Surface::MakeCylinder(Vec3(0, 0, 10), Vec3(0, 1, 0), 50.0), 1.0, 1.5};
  Ray out;
  EXPECT_EQ(TraceSequence<double>({f}, Ray{Vec3::Zero(), Vec3(0, 1, 0)}, &out), RayStatus::kMissed);
  EXPECT_EQ(TraceSequence<double>({f}, Ray{Vec3::Zero(), Vec3(0, 0, 1)}, &out), RayStatus::kOk);
  EXPECT_NEAR(out.origin.z(), 60.0, 1e-12);
  f.surface.aperture_point = Vec3(0, 0, 10);
  f.surface.aperture_normal = Vec3(0, 0, 1);
  EXPECT_EQ(TraceSequence<double>({f}, Ray{Vec3::Zero(), Vec3(0, 0, -1)}, &out), RayStatus::kOutsideAperture);
}

// Every kernel the machine runs (SSE2, AVX2, AVX-512) against the single-ray tracer, bit for bit:
// the kernels are Step() itself compiled at other vector widths without contraction into FMA, and
// IEEE sqrt and division are correctly rounded at every width, so nothing may differ — not even
// in the last bit. Spheres (the as-built dome's shell), planes (a flat port with a rim) and
// cylinders (a cylindrical port with its rim), rays
// that pass, miss, leave the aperture or are totally internally reflected, in place and out of
// place (there with streaming stores), over a count that is not a multiple of any vector width.
TEST(TraceBatch, EveryKernelAgreesBitForBitWithSingleRayTracer) {
  auto shell = Shell(Vec3(-0.4, -1.5, 20.3), Vec3(-0.4, -1.0, 21.5), 1.5168, 1.341);
  // The inner sphere with a rim: rays beyond 60° from the axis leave its aperture.
  shell[0].surface.aperture_point = Vec3(0, 0, 20.3 + 75.7 * std::cos(60 * M_PI / 180));
  shell[0].surface.aperture_normal = Vec3(0, 0, 1);
  Surface window = Surface::MakePlane(Vec3(0, 0, 30), Vec3(0, 0, 1));
  window.aperture_point = Vec3(0, 0, 30);
  window.aperture_normal = Vec3(0, 0, 1);
  // Rays start in a dense glass (n 1.6), so those steeper than asin(1/1.6) cannot leave the last
  // interface into air: total internal reflection.
  const std::vector<Interface> flat = {
      Interface{window, 1.6, 1.49},
      Interface{Surface::MakePlane(Vec3(0, 0, 42), Vec3(0, 0, 1)), 1.49, 1.341},
      Interface{Surface::MakePlane(Vec3(0, 0, 50), Vec3(0, 0, 1)), 1.341, 1.0}};
  // A cylindrical port (axis along Y, slightly rolled and off the start point), glass in front
  // of its axis plane only.
  std::vector<Interface> cylinder = {
      Interface{Surface::MakeCylinder(Vec3(0.7, 0, 20.0), Vec3(0.05, 1, 0).normalized(), 60.0), 1.0, 1.49},
      Interface{Surface::MakeCylinder(Vec3(0.7, 0, 20.0), Vec3(0.05, 1, 0).normalized(), 66.0), 1.49, 1.341}};
  for (Interface& f : cylinder) {
    f.surface.aperture_point = Vec3(0, 0, 20.0);
    f.surface.aperture_normal = Vec3(0, 0, 1);
  }
  std::mt19937 rng(4);
  const std::size_t n = 20011;
  std::vector<Ray> rays(n);
  for (std::size_t i = 0; i < n; ++i) {
    // Include backward rays (they hit the rear of the spheres) and rays from outside.
    rays[i] = Ray{Vec3(0, 0, i % 7 == 0 ? 200.0 : 26.9), RandomUnitForward(rng, 3.0)};
  }
  const auto isas = SupportedIsas();
  ASSERT_FALSE(isas.empty());
  EXPECT_EQ(isas.front(), Isa::kSse2);
  for (const std::vector<Interface>* seq : {&std::as_const(shell), &flat, &std::as_const(cylinder)}) {
    std::vector<Ray> expected(n);
    std::vector<RayStatus> expected_status(n);
    std::size_t count[4] = {0, 0, 0, 0};
    for (std::size_t i = 0; i < n; ++i) {
      expected_status[i] = TraceSequence<double>(*seq, rays[i], &expected[i]);
      ++count[static_cast<int>(expected_status[i])];
    }
    // Every path is exercised: passed, missed, outside the aperture, and (flat port) TIR.
    EXPECT_GT(count[0], n / 50);
    EXPECT_GT(count[1], 0u);
    EXPECT_GT(count[2], 0u);
    if (seq == &flat) {
      EXPECT_GT(count[3], 0u);
    }
    for (const Isa isa : isas) {
      for (const bool in_place : {true, false}) {
        SCOPED_TRACE(std::string(ToString(isa)) + (in_place ? " in place" : " out of place") +
                     (seq == &shell ? " shell" : seq == &flat ? " flat" : " cylinder"));
        RayBatch batch;
        batch.resize(n);
        for (std::size_t i = 0; i < n; ++i) batch.Set(i, rays[i]);
        batch.status[5] = RayStatus::kMissed;  // an already-failed ray must stay untouched
        BatchOptions o;
        o.isa = isa;
        RayBatch out;
        if (in_place) {
          TraceBatch(*seq, &batch, o);
        } else {
          // Out of place, the results streamed past the cache (here n >= stream_min; the last
          // block ends in an odd tail).
          o.stream_min = n / 2;
          TraceBatch(*seq, batch, &out, o);
          EXPECT_EQ(batch.Get(7).origin, rays[7].origin);  // the input is left as it was
        }
        const RayBatch& r = in_place ? batch : out;
        EXPECT_EQ(r.status[5], RayStatus::kMissed);
        EXPECT_EQ(r.Get(5).origin, rays[5].origin);
        EXPECT_EQ(r.Get(5).dir, rays[5].dir);
        std::size_t mismatches = 0;
        for (std::size_t i = 0; i < n; ++i) {
          if (i == 5) continue;
          // Exact equality of every coordinate, and of the status.
          const bool same = r.status[i] == expected_status[i] &&
                            r.Get(i).origin == expected[i].origin &&
                            r.Get(i).dir == expected[i].dir;
          if (!same && mismatches++ < 3) {
            ADD_FAILURE() << "ray " << i << ": batch " << r.Get(i).dir.transpose() << " status "
                          << ToString(r.status[i]) << ", single " << expected[i].dir.transpose()
                          << " status " << ToString(expected_status[i]);
          }
        }
        EXPECT_EQ(mismatches, 0u);
      }
    }
  }
}

// The batch's threads: many batches in a row (helpers that wake late must not disturb the next
// one), several callers at once (one uses the helpers, the others trace alone), and more threads
// than cores; every answer is still the single-ray tracer's, bit for bit.
TEST(TraceBatch, ManyAndConcurrentBatchesGiveTheSingleRayAnswer) {
  const auto seq = Shell(Vec3(-0.4, -1.5, 20.3), Vec3(-0.4, -1.0, 21.5), 1.5168, 1.341);
  std::mt19937 rng(9);
  const std::size_t n = 9000;  // 9 blocks
  RayBatch in;
  in.resize(n);
  std::vector<Ray> expected(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Ray r{Vec3(0, 0, 26.9), RandomUnitForward(rng, 1.2)};
    in.Set(i, r);
    TraceSequence<double>(seq, r, &expected[i]);
  }
  auto check = [&](const RayBatch& out) {
    std::size_t bad = 0;
    for (std::size_t i = 0; i < n; ++i) {
      bad += !(out.Get(i).origin == expected[i].origin && out.Get(i).dir == expected[i].dir);
    }
    return bad;
  };
  std::atomic<std::size_t> bad{0};
  auto caller = [&](int threads, int repeats) {
    BatchOptions o;
    o.num_threads = threads;
    RayBatch out;
    for (int r = 0; r < repeats; ++r) {
      TraceBatch(seq, in, &out, o);
      bad += check(out);
    }
  };
  caller(2, 200);
  caller(5, 50);
  std::vector<std::thread> callers;
  for (int t = 0; t < 4; ++t) callers.emplace_back(caller, 2 + t % 2, 50);
  for (auto& t : callers) t.join();
  EXPECT_EQ(bad.load(), 0u);
}

TEST(TraceBatch, InstructionSetsAreNamedAndAnUnsupportedOneIsRefused) {
  for (const Isa isa : {Isa::kAuto, Isa::kSse2, Isa::kAvx2, Isa::kAvx512}) {
    EXPECT_EQ(ParseIsa(ToString(isa)), isa);
  }
  EXPECT_THROW(ParseIsa("avx"), InvalidInput);
  EXPECT_THROW(ParseIsa("AVX2"), InvalidInput);
  const auto isas = SupportedIsas();
  // Auto picks the widest the processor runs (unless PORTHOLE_ISA forces one for this run).
  const char* env = std::getenv("PORTHOLE_ISA");
  if (env == nullptr || *env == '\0') {
    EXPECT_EQ(ResolveIsa(Isa::kAuto), isas.back());
  }
  for (const Isa isa : {Isa::kSse2, Isa::kAvx2, Isa::kAvx512}) {
    const bool supported = std::find(isas.begin(), isas.end(), isa) != isas.end();
    if (supported) {
      EXPECT_EQ(ResolveIsa(isa), isa);
    } else {
      try {
        ResolveIsa(isa);
        ADD_FAILURE() << "expected InvalidInput for " << ToString(isa);
      } catch (const InvalidInput& e) {
        EXPECT_EQ(e.field(), "isa");
        EXPECT_NE(std::string(e.what()).find("not supported"), std::string::npos) << e.what();
      }
    }
  }
}

TEST(TraceSequence, JetDerivativesMatchFiniteDifferences) {
  using J = ceres::Jet<double, 1>;
  const auto seq = Shell(Vec3(-0.4, -1.5, 20.3), Vec3(-0.4, -1.0, 21.5), 1.5168, 1.341);
  // d(out.dir.x)/d(angle) of a ray in the xz plane.
  auto trace = [&](double a) {
    Ray out;
    TraceSequence<double>(seq, Ray{Vec3(0, 0, 26.9), Vec3(std::sin(a), 0, std::cos(a))}, &out);
    return out.dir.x();
  };
  const double a0 = 0.5, h = 1e-6;
  const J a(a0, 0);
  RayT<J> in{Vec3T<J>(J(0), J(0), J(26.9)), Vec3T<J>(sin(a), J(0), cos(a))};
  RayT<J> out;
  ASSERT_EQ(TraceSequence<J>(seq, in, &out), RayStatus::kOk);
  EXPECT_NEAR(out.dir.x().a, trace(a0), 1e-15);
  EXPECT_NEAR(out.dir.x().v[0], (trace(a0 + h) - trace(a0 - h)) / (2 * h), 1e-7);
}

}  // namespace
}  // namespace porthole::optics
