// Control points as the datum of a free target (CalibrationOptions::datum kControl, issue 26):
// "Monte Carlo for every reported σ". A 3-D field (a board with raised targets) seen in 20
// convergent views by a D300 with a 24 mm lens, 0.3 px Gaussian noise, 5 control points (the
// board's corners and one raised target). Over fresh noise — and, for control points with a prior,
// fresh control coordinates drawn with their σ — the reported σ of the camera (every free
// parameter) and of adjusted non-control points (in the control frame, whose truth is the field's)
// must match the spread of the estimates within [0.67, 1.5], with no bias beyond 3·spread/√runs. And outlier
// rejection keeps its own rounds when the priors are re-weighted.
// PORTHOLE_MC_RUNS sets the number of runs (default 50).
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "porthole/calib/calibrate.h"
#include "porthole/calib/synthetic.h"
#include "porthole/calib/test_fields.h"
#include "porthole/core/error.h"
#include "porthole/refraction/test_camera.h"

namespace porthole::calib {
namespace {

using camera::kBrownParamInfo;

using fixtures::RaisedBoard;
// The board's four corners and one raised target.
const std::vector<int>& kControl = fixtures::kRaisedBoardControl;

// Adjusted points compared with their truth: a board point near the middle, one on an edge, two
// raised ones; with priors, the raised control point too.
const std::vector<int> kChecked = {20, 5, 50, 59};

SyntheticOptions Network() {
  SyntheticOptions o;
  o.camera = refraction::testing::D300Brown();
  o.target = RaisedBoard();
  o.n_images = 20;
  o.noise_px = 0.3;
  return o;
}

CalibrationOptions Options() {
  CalibrationOptions c;
  c.pixel_pitch_mm = 0.0055;
  c.reject_k = 0;  // Gaussian data: no outliers
  c.centre_correction = CalibrationOptions::CentreCorrection::kOff;  // synthetic centres
  c.target_free = true;
  c.datum = CalibrationOptions::DatumKind::kControl;
  return c;
}

// "p20.X": coordinate k of point id.
std::string PointName(int id, int k) {
  char name[32];
  std::snprintf(name, sizeof name, "p%d.%c", id, "XYZ"[k]);
  return name;
}

int Runs() {
  const char* env = std::getenv("PORTHOLE_MC_RUNS");
  return env ? std::max(3, std::atoi(env)) : 50;
}

// One quantity's estimates and reported σ over the runs.
struct Spread {
  std::string name;
  double truth = 0;
  double sum = 0, sum2 = 0, sigma2 = 0;
  int n = 0;
  void Add(double value, double sigma) {
    sum += value - truth;
    sum2 += (value - truth) * (value - truth);
    sigma2 += sigma * sigma;
    ++n;
  }
  double Bias() const { return sum / n; }
  double Spread_() const { return std::sqrt((sum2 - n * Bias() * Bias()) / (n - 1)); }
  double Sigma() const { return std::sqrt(sigma2 / n); }  // RMS of the reported σ
};

// Runs the network `runs` times with control points of σ `sigma_mm` (0: held at their truth; > 0:
// given at their truth plus Gaussian errors of that σ, drawn afresh each run) and checks every
// quantity's σ against its spread. Each case draws its own noise (seeds from `first_seed`): the
// cases are independent samples.
void CheckSigmaAgainstSpread(double sigma_mm, const char* label, uint64_t first_seed) {
  SyntheticOptions o = Network();
  const std::vector<Eigen::Vector3d> truth = TargetPoints(o.target);
  const int runs = Runs();
  std::vector<Spread> q;
  // Every free camera parameter (c, x0, y0, K1, K2, P1, P2).
  std::vector<int> camera_params;
  for (int i = 0; i < camera::kBrownNumParams; ++i) {
    if (DefaultFree(camera::CameraModelId::kBrown)[i]) camera_params.push_back(i);
  }
  for (int i : camera_params) q.push_back({std::string(kBrownParamInfo[i].name), o.camera.params[i]});
  std::vector<int> points = kChecked;
  if (sigma_mm > 0) points.push_back(kControl.back());
  for (int id : points) {
    for (int k = 0; k < 3; ++k) q.push_back({PointName(id, k), truth[id](k)});
  }
  std::mt19937_64 control_rng(first_seed + 999);
  std::normal_distribution<double> control_error(0, sigma_mm > 0 ? sigma_mm : 1);
  double sigma0 = 0;
  for (int run = 0; run < runs; ++run) {
    o.noise_seed = first_seed + run;
    TargetSpec given = o.target;
    for (auto& t : given.field) {
      if (std::find(kControl.begin(), kControl.end(), t.id) == kControl.end()) continue;
      t.control_sigma_mm = Eigen::Vector3d::Constant(sigma_mm);
      if (sigma_mm > 0) {
        for (int k = 0; k < 3; ++k) t.xyz_mm(k) += control_error(control_rng);
      }
    }
    const CalibrationResult r = Calibrate(MakeSyntheticSet(o).detections, given, Options());
    ASSERT_TRUE(r.covariance_ok) << r.message;
    ASSERT_EQ(r.datum.control, kControl);
    sigma0 += r.sigma0_px / runs;
    std::size_t k = 0;
    for (int i : camera_params) q[k++].Add(r.camera.params[i], r.sigma[i]);
    for (int id : points) {
      for (int a = 0; a < 3; ++a) q[k++].Add(r.target_points_mm[id](a), r.target_sigma_mm[id](a));
    }
  }
  std::printf("[control] %s: %d runs, mean sigma0 %.4f px\n", label, runs, sigma0);
  for (const auto& s : q) {
    const double ratio = s.Sigma() / s.Spread_();
    const double bias = std::abs(s.Bias()) / (s.Spread_() / std::sqrt(runs));
    std::printf("[control] %s %-5s sigma %.3g, Monte-Carlo spread %.3g, ratio %.2f; "
                "|bias| %.2f spread/sqrt(runs)\n",
                label, s.name.c_str(), s.Sigma(), s.Spread_(), ratio, bias);
    EXPECT_GE(ratio, 0.67) << label << " " << s.name;
    EXPECT_LE(ratio, 1.5) << label << " " << s.name;
    EXPECT_LT(bias, 3.0) << label << " " << s.name;
  }
}

TEST(ControlDatum, HeldControlPointsSigmaMatchesMonteCarlo) { CheckSigmaAgainstSpread(0, "held", 6000); }

TEST(ControlDatum, ControlPriorsSigmaMatchesMonteCarlo) { CheckSigmaAgainstSpread(0.5, "prior 0.5 mm", 7000); }

// Priors about as precise as the network's own points (≈ 0.02 mm): images and priors share the shape.
TEST(ControlDatum, TightControlPriorsSigmaMatchesMonteCarlo) {
  CheckSigmaAgainstSpread(0.02, "prior 0.02 mm", 8000);
}

// Outliers that take 4 rounds of 5σ0 rejection to find, each level hidden by the one above it in
// σ0: 3 observations off by 800 px (σ0 ≈ 30 px), 3 by 120 px (then σ0 ≈ 4.4 px), 3 by 18 px
// (σ0 ≈ 0.7 px), 3 by 3 px (σ0 0.3 px), each in its own image and on its own point (no control
// point). With the control points held, or with priors (whose weight, σ0, is re-adjusted after
// each rejection), all 12 and no other observation are rejected within the 5 rounds of
// `max_reject_rounds`, and σ0 is the noise's: re-weighting the priors does not use up rejection's
// rounds (it did: with priors, 2 rounds of rejection were left and 6 outliers kept).
TEST(ControlDatum, OutlierRejectionKeepsItsRoundsWithControlPriors) {
  SyntheticOptions o = Network();
  auto set = MakeSyntheticSet(o);
  const std::vector<double> levels_px = {800, 120, 18, 3};
  const Eigen::Vector2d centre(0.5 * (o.camera.sensor.width_px - 1), 0.5 * (o.camera.sensor.height_px - 1));
  int image = 0;
  for (double offset_px : levels_px) {
    for (int k = 0; k < 3; ++k, ++image) {
      auto& d = set.detections[image];
      // Point 10 + image (no control point; one outlier per point), moved toward the image centre.
      const auto at = std::find(d.ids.begin(), d.ids.end(), 10 + image) - d.ids.begin();
      ASSERT_LT(at, static_cast<long>(d.ids.size())) << "point " << 10 + image << " unseen in image " << image;
      d.points_px[at] += offset_px * (centre - d.points_px[at]).normalized();
    }
  }
  for (double sigma_mm : {0.0, 0.5}) {
    TargetSpec given = o.target;
    for (auto& t : given.field) {
      if (std::find(kControl.begin(), kControl.end(), t.id) == kControl.end()) continue;
      t.control_sigma_mm = Eigen::Vector3d::Constant(sigma_mm);
    }
    CalibrationOptions c = Options();
    c.reject_k = 5;
    c.max_reject_rounds = 5;
    std::vector<std::string> said;
    c.progress = [&](const std::string& m) {
      if (m.find("rejected") != std::string::npos) said.push_back(m);
    };
    const CalibrationResult r = Calibrate(set.detections, given, c);
    std::printf("[control] outliers, control sigma %g mm: %d rejected in %zu rounds, sigma0 %.4f px\n",
                sigma_mm, r.n_rejected, said.size(), r.sigma0_px);
    for (const auto& m : said) std::printf("[control]   %s\n", m.c_str());
    EXPECT_EQ(r.n_rejected, 12) << "control sigma " << sigma_mm;
    ASSERT_EQ(r.images.size(), set.detections.size());  // no image skipped: image i is detections[i]
    for (int i = 0; i < static_cast<int>(r.images.size()); ++i) {
      EXPECT_EQ(r.images[i].n_rejected, i < 12 ? 1 : 0) << "image " << i << ", control sigma " << sigma_mm;
    }
    EXPECT_NEAR(r.sigma0_px, o.noise_px, 0.05 * o.noise_px) << "control sigma " << sigma_mm;
  }
}

// docs/calibration.md: by default (`auto`) the control points are the datum when 3 or more off one
// line are observed; fewer, or all on one line, leave the minimal datum, and `control` then refuses
// naming how many were observed.
TEST(ControlDatum, AutoTakesThreeControlPointsOffOneLineAndNoFewer) {
  SyntheticOptions o = Network();
  o.n_images = 8;
  const auto set = MakeSyntheticSet(o);
  const auto run = [&](const std::vector<int>& ids, CalibrationOptions::DatumKind kind) {
    TargetSpec given = o.target;
    for (auto& t : given.field) {
      if (std::find(ids.begin(), ids.end(), t.id) != ids.end()) t.control_sigma_mm = Eigen::Vector3d::Zero();
    }
    CalibrationOptions c = Options();
    c.datum = kind;
    return Calibrate(set.detections, given, c);
  };
  using Kind = CalibrationOptions::DatumKind;
  const std::vector<int> three_off_a_line = {1, 8, 41}, two = {1, 8}, three_on_a_line = {1, 4, 8};  // 1–8: row 0
  const CalibrationResult three = run(three_off_a_line, Kind::kAuto);
  EXPECT_EQ(three.datum.control, three_off_a_line);
  EXPECT_EQ(three.datum.a, -1);
  for (const auto& ids : {two, three_on_a_line}) {
    const CalibrationResult r = run(ids, Kind::kAuto);
    EXPECT_TRUE(r.datum.control.empty()) << ids.size() << " control points";
    EXPECT_GE(r.datum.a, 0) << ids.size() << " control points";  // the minimal datum
    try {
      run(ids, Kind::kControl);
      ADD_FAILURE() << "datum control accepted " << ids.size() << " control points";
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.field(), "datum");
      EXPECT_NE(std::string(e.what()).find(fmt::format("off one line: {} observed", ids.size())), std::string::npos)
          << e.what();
    }
  }
}

}  // namespace
}  // namespace porthole::calib
