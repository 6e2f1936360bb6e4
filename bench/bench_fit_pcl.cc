// Peer: PCL's sample-consensus sphere segmentation (pcl::SACSegmentation, SACMODEL_SPHERE, with
// its coefficient refinement on the inliers) on the same 170,000-point scans as bench_fit.cc,
// with the same 0.25 mm inlier threshold; time beside centre and radius error. Compiled only when
// CMake finds PCL (Debian libpcl-dev, installed by `scripts/install-deps --bench`).
#include <benchmark/benchmark.h>
#include <pcl/ModelCoefficients.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/method_types.h>
#include <pcl/sample_consensus/model_types.h>
#include <pcl/segmentation/sac_segmentation.h>

#include "fit_scans.h"
#include "porthole/fit/sphere_fit.h"

namespace {

// The scan as a PCL cloud (float coordinates, as PCL's PointXYZ stores them), built once.
pcl::PointCloud<pcl::PointXYZ>::Ptr Cloud(double outlier_fraction) {
  const Eigen::Matrix3Xd& p = porthole::bench::PaperDomeScan(outlier_fraction).points;
  pcl::PointCloud<pcl::PointXYZ>::Ptr c(new pcl::PointCloud<pcl::PointXYZ>);
  c->reserve(p.cols());
  for (Eigen::Index i = 0; i < p.cols(); ++i)
    c->push_back(pcl::PointXYZ(static_cast<float>(p(0, i)), static_cast<float>(p(1, i)),
                               static_cast<float>(p(2, i))));
  return c;
}

// range(0): 0 = RANSAC, 1 = MSAC; range(1): outliers in percent (0 or 20).
void BM_PclSphere170k(benchmark::State& state) {
  static const auto clean = Cloud(0.0), dirty = Cloud(0.2);
  const auto& cloud = state.range(1) > 0 ? dirty : clean;
  pcl::SACSegmentation<pcl::PointXYZ> seg;
  seg.setModelType(pcl::SACMODEL_SPHERE);
  seg.setMethodType(state.range(0) == 0 ? pcl::SAC_RANSAC : pcl::SAC_MSAC);
  seg.setDistanceThreshold(porthole::fit::SphereFitOptions{}.inlier_threshold_mm);
  seg.setMaxIterations(porthole::fit::SphereFitOptions{}.max_ransac_iterations);
  seg.setOptimizeCoefficients(true);  // refine on the inliers, as porthole does
  seg.setInputCloud(cloud);
  pcl::ModelCoefficients coef;
  pcl::PointIndices inliers;
  for (auto _ : state) {
    seg.segment(inliers, coef);
    const float r = coef.values.size() == 4 ? coef.values[3] : 0.0f;
    benchmark::DoNotOptimize(r);
  }
  if (coef.values.size() != 4) return state.SkipWithError("PCL found no sphere");
  porthole::bench::ReportSphere(state, {coef.values[0], coef.values[1], coef.values[2]},
                                coef.values[3], static_cast<double>(inliers.indices.size()));
  state.SetLabel(state.range(0) == 0 ? "pcl ransac" : "pcl msac");
}
BENCHMARK(BM_PclSphere170k)
    ->ArgsProduct({{0, 1}, {0, 20}})
    ->ArgNames({"msac", "outlier_pct"})
    ->Unit(benchmark::kMillisecond);

}  // namespace
