// Pixels through a port and scene points on their rays (0.2 … 20 m, log-uniform): the inputs of the
// refractive projection benchmarks (bench_refraction.cc, bench_geometry.cc).
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "porthole/camera/brown.h"
#include "porthole/camera/camera.h"
#include "porthole/optics/trace.h"
#include "porthole/ports/port.h"

namespace porthole::bench {

struct PortSample {
  Eigen::Vector2d pixel;
  Eigen::Vector3d point_in_cam;  // mm, the pupil at the origin
};

// The camera of the refraction benchmarks: a D300 body (4288 × 2848 px of 5.5 µm), Brown lens c 24.6 mm.
inline camera::Camera BenchD300() {
  camera::BrownParams b;
  b.c_mm = 24.6;
  b.K1 = 1.8e-4;
  b.K2 = -3e-7;
  b.P1 = 2e-6;
  return camera::FromBrown(b, camera::Sensor{4288, 2848, 0.0055});
}

// A flat port tilted 5° about y: its inner face 20 mm from the pupil (0, 0, 26.9) along the normal,
// 10 mm of acrylic (n 1.49), seawater (1.341).
inline ports::PortSystem TiltedFlat5() {
  const Eigen::Vector3d ep(0, 0, 26.9);
  ports::FlatPort f;
  const double t = 5 * M_PI / 180;
  f.normal = Eigen::Vector3d(std::sin(t), 0, std::cos(t));
  f.inner_point_mm = ep + 20 * f.normal;
  f.thickness_mm = 10;
  ports::PortSpec s;
  s.shape = f;
  return ports::Place(s, ep, 1.49, 1.341);
}

// n pixels uniform over the frame whose rays leave the port, each with a point on its ray in the
// water; `seed` of the generator.
inline std::vector<PortSample> PortSamples(const camera::Camera& cam, const ports::PortSystem& sys, int n,
                                           std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  const auto seq = sys.Outward();
  std::vector<PortSample> out;
  while (static_cast<int>(out.size()) < n) {
    const Eigen::Vector2d px(u(rng) * (cam.sensor.width_px - 1), u(rng) * (cam.sensor.height_px - 1));
    const auto ray = cam.Unproject(px);
    optics::Ray r;
    if (!ray || optics::TraceSequence(seq, optics::Ray{sys.ep_in_housing_mm, *ray}, &r) !=
                    optics::RayStatus::kOk) {
      continue;
    }
    const double s = 200 * std::pow(100.0, u(rng));  // 0.2 … 20 m, log-uniform
    out.push_back({px, r.origin + s * r.dir - sys.ep_in_housing_mm});
  }
  return out;
}

}  // namespace porthole::bench
