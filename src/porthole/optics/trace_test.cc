// Proves the ray tracer obeys the physics: Snell's law as an invariant, reversibility, undeviated
// rays through the centre of a concentric shell, total internal reflection reported, and that the
// batched and Jet tracers give the single-ray answer.
#include <Eigen/Geometry>
#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

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
  EXPECT_TRUE(Refract<double>(Vec3(std::sin(crit - 1e-6), 0, std::cos(crit - 1e-6)), n, n1, n2, &t));
  EXPECT_FALSE(Refract<double>(Vec3(std::sin(crit + 1e-6), 0, std::cos(crit + 1e-6)), n, n1, n2, &t));
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

TEST(TraceBatch, AgreesWithSingleRayTracerIncludingFailures) {
  const auto seq = Shell(Vec3(-0.4, -1.5, 20.3), Vec3(-0.4, -1.0, 21.5), 1.5168, 1.341);
  std::mt19937 rng(4);
  const std::size_t n = 20000;
  RayBatch batch;
  batch.resize(n);
  std::vector<Ray> rays(n);
  for (std::size_t i = 0; i < n; ++i) {
    // Include backward rays (they hit the rear of the spheres) and rays from outside.
    Vec3 d = RandomUnitForward(rng, 3.0);
    rays[i] = Ray{Vec3(0, 0, i % 7 == 0 ? 200.0 : 26.9), d};
    batch.Set(i, rays[i]);
  }
  batch.status[5] = RayStatus::kMissed;  // an already-failed ray must stay untouched
  const Ray untouched = batch.Get(5);
  TraceBatch(seq, &batch);
  for (std::size_t i = 0; i < n; ++i) {
    if (i == 5) {
      EXPECT_EQ(batch.status[i], RayStatus::kMissed);
      EXPECT_EQ(batch.Get(i).origin, untouched.origin);
      continue;
    }
    Ray out;
    const RayStatus s = TraceSequence<double>(seq, rays[i], &out);
    ASSERT_EQ(batch.status[i], s) << i;
    EXPECT_NEAR((batch.Get(i).origin - out.origin).norm(), 0, 1e-9) << i;
    EXPECT_NEAR((batch.Get(i).dir - out.dir).norm(), 0, 1e-12) << i;
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
