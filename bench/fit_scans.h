// The scans every sphere-fit benchmark (porthole's and the peers') runs on, built once: the paper's
// outer dome (Table 3: centre (−0.4, −1.0, 21.5) mm, R 83.4 mm), 170,000 points on a hemisphere,
// σ 0.05 mm per axis, clean or with 20 % gross outliers. Accuracy counters against this truth.
#pragma once

#include <benchmark/benchmark.h>

#include <Eigen/Core>
#include <cmath>

#include "porthole/pointcloud/synthetic.h"

namespace porthole::bench {

inline const pointcloud::SyntheticCap& PaperDomeScan(double outlier_fraction) {
  static const auto make = [](double f) {
    pointcloud::SyntheticCapOptions o;  // defaults: paper Table 3 outer sphere
    o.n_points = 170000;
    o.noise_sigma_mm = 0.05;
    o.outlier_fraction = f;
    o.seed = 2024;
    return pointcloud::MakeSyntheticCap(o);
  };
  static const auto clean = make(0.0);
  static const auto dirty = make(0.2);
  return outlier_fraction > 0 ? dirty : clean;
}

// center_err_mm, radius_err_mm and n_inliers counters of a fitted sphere against the truth.
inline void ReportSphere(benchmark::State& state, const Eigen::Vector3d& center_mm,
                         double radius_mm, double n_inliers) {
  const pointcloud::SyntheticCapOptions truth;
  state.counters["center_err_mm"] = (center_mm - truth.center_mm).norm();
  state.counters["radius_err_mm"] = std::abs(radius_mm - truth.radius_mm);
  state.counters["n_inliers"] = n_inliers;
}

}  // namespace porthole::bench
