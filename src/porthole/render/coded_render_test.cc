// Coded targets rendered by `porthole render` (pattern.cc's coded entry), read back by the coded
// detector and checked against the renderer's detector-equivalent truth (dots.h: the centre of the
// ellipse fitted to each dot's rim, traced through the port) — a truth computed by forward
// projection alone, independent of the image and of the detector:
//  - clean 16-bit renders, dots >= 16 px across, tilts 0–60°, both profiles, both polarities:
//    every target decoded, centres within 0.02 px;
//  - 2 % noise (of the ink–paper contrast) and 1.5 px defocus (the thin lens's blur-circle radius):
//    within 0.05 px;
//  - dots >= 10 px across at tilts <= 60°: >= 99 % decoded, no wrong ID;
//  - through the as-built NI320 in water, a 75 px dot tilted 0–70°: the error left against the
//    traced truth <= 0.02 px while the bias removed (the image of the dot's centre) grows to tenths
//    of a pixel; in air through a dome concentric with the pupil (the camera alone) that bias
//    follows the closed-form eccentricity (coded/ellipse.h) within 1 %.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <map>
#include <vector>
#include <opencv2/core.hpp>

#include "porthole/coded/detect.h"
#include "porthole/coded/ellipse.h"
#include "porthole/core/error.h"
#include "porthole/catalogue/presets.h"
#include "porthole/render/dots.h"
#include "porthole/render/render.h"
#include "porthole/render/test_scenes.h"

namespace porthole::render {
namespace {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;

// The paper's D300 + 24 mm behind `port`, its sensor reduced to width × (2/3 width) pixels of the
// same size in mm; one band (546 nm), a pinhole unless the test sets an aperture.
Scene CodedScene(const std::string& target, int width, Medium medium, const std::string& port = "nimar-ni320") {
  Scene s = testing::PaperScene(port, width);
  s.target = calib::ParseTarget(target);
  s.medium = medium;
  s.bands_nm = {546.07};
  s.f_number = INFINITY;
  return s;
}

using testing::ConcentricDome;

cv::Mat Gray16(const Image& im) {
  cv::Mat g(im.height, im.width, CV_16U);
  for (int v = 0; v < im.height; ++v) {
    for (int u = 0; u < im.width; ++u) g.at<uint16_t>(v, u) = static_cast<uint16_t>(std::lround(65535.0 * im.at(u, v)));
  }
  return g;
}

// Long axis (px) of a dot's image: the largest distance between opposite rim points.
double LongAxisPx(const Setup& s, const Pose& pose, const Vec3& centre, double radius) {
  double best = 0;
  for (int k = 0; k < 24; ++k) {
    const double a = M_PI * k / 24;
    const Vec3 d(radius * std::cos(a), radius * std::sin(a), 0);
    const auto p = ProjectThroughPort(s, s.bands[0], pose, centre + d), q = ProjectThroughPort(s, s.bands[0], pose, centre - d);
    if (p && q) best = std::max(best, (*p - *q).norm());
  }
  return best;
}

struct Score {
  int targets = 0, big = 0, decoded = 0, decoded_big = 0, wrong = 0;
  int left_out_read = 0;  // targets the truth left out (cut by the frame near its edge) read at their dots
  double max_err_px = 0, sum_err2 = 0, min_axis_px = 1e9;
  coded::DetectionCounts counts;
};

// Renders the scene, detects, and scores every decoded target against the dot truth of band 0.
// `big`: targets whose dot's image is at least min_axis_px long.
Score RenderAndScore(const Scene& scene, const RenderOptions& ro, double min_axis_px = 0) {
  const Rendered r = Render(scene, ro);
  const std::vector<DotTruth> truth = DotImageCentres(scene, r.setup, r.truth);
  const auto pts = calib::TargetPoints(scene.target);
  std::map<int, Vec2> at;
  Score sc;
  std::map<int, bool> big;
  for (const DotTruth& d : truth) {
    at[d.id] = d.centre_px_per_band[0];
    const double axis = LongAxisPx(r.setup, scene.pose, pts[d.id], scene.target.dot_radius_mm);
    sc.min_axis_px = std::min(sc.min_axis_px, axis);
    // Counted when big enough and its ring (with a band around it) lies inside the frame.
    const double outer = 1.3 * coded::Ring(coded::ParseProfile(scene.target.code_profile)).outer * scene.target.dot_radius_mm;
    bool inside = true;
    for (int k = 0; k < 16 && inside; ++k) {
      const auto p = ProjectThroughPort(r.setup, r.setup.bands[0], scene.pose,
                                        pts[d.id] + outer * Vec3(std::cos(M_PI * k / 8), std::sin(M_PI * k / 8), 0));
      inside = p && p->x() > 3 && p->y() > 3 && p->x() < r.image.width - 4 && p->y() < r.image.height - 4;
    }
    big[d.id] = axis >= min_axis_px && inside;
    sc.big += big[d.id];
  }
  sc.targets = static_cast<int>(truth.size());
  coded::CodedDetectOptions o;
  o.bits = scene.target.code_bits;
  o.profile = coded::ParseProfile(scene.target.code_profile);
  const coded::CodedDetection det = coded::DetectCodedTargets(Gray16(r.image), o);
  sc.counts = det.counts;
  for (const auto& t : det.targets) {
    const auto it = at.find(t.id);
    if (it == at.end()) {  // not in the truth: right only if that target's dot images there
      const bool known = t.id >= 0 && static_cast<std::size_t>(t.id) < pts.size() && scene.target.HasPoint(t.id);
      const auto dot = known ? DotImageCentre(r.setup, r.setup.bands[0], scene.pose, pts[t.id], scene.target.dot_radius_mm)
                             : std::nullopt;
      if (dot && (t.centre_px - *dot).norm() <= 2) {
        ++sc.left_out_read;
      } else {
        ++sc.wrong;
      }
      continue;
    }
    if ((t.centre_px - it->second).norm() > 2) {
      ++sc.wrong;
      continue;
    }
    const double e = (t.centre_px - it->second).norm();
    ++sc.decoded;
    sc.decoded_big += big[t.id];
    sc.max_err_px = std::max(sc.max_err_px, e);
    sc.sum_err2 += e * e;
  }
  return sc;
}

// The distance at which a dot of radius r_mm images `dot_px` across on the axis.
double DistanceFor(const Scene& s, double dot_px) {
  const double f_px = s.housed.lens.focal_length_mm / s.housed.camera.sensor.pixel_pitch_mm;
  return f_px * 2 * s.target.dot_radius_mm / dot_px;
}

TEST(CodedRender, CleanRendersCentreWithin002Px) {
  // 16-bit, 16 spp, dots 18 px across on the axis (>= 16 px everywhere: checked), NI320 in air:
  // AICON 14-bit dark on light and Metashape 12-bit white on black, tilts 0 / 45 / 60°.
  struct Case {
    const char* target;
    bool white_on_black;
  };
  for (const Case c : {Case{"coded:14:7", false}, Case{"coded:12:7:metashape", true}}) {
    for (const double tilt : {0.0, 45.0, 60.0}) {
      Scene s = CodedScene(c.target, 720, Medium::kAir);
      if (c.white_on_black) std::swap(s.style.black, s.style.white);
      const double dist = DistanceFor(s, 18 / std::sqrt(std::cos(tilt * M_PI / 180)));
      s.pose = PoseFacing(s.target, dist, {0, 0}, tilt * 0.8, tilt * 0.6, 10);
      RenderOptions ro;
      ro.samples_per_pixel = 36;  // the stratified samples' edge noise: 0.013 px RMS at 16 spp, 0.006 at 36
      const Score sc = RenderAndScore(s, ro, 16);
      std::printf("%s%s tilt %2.0f: %d/%d decoded (dots >= %.1f px), worst %.4f px, RMS %.4f px\n", c.target,
                  c.white_on_black ? " white on black" : "", tilt, sc.decoded, sc.targets, sc.min_axis_px, sc.max_err_px,
                  std::sqrt(sc.sum_err2 / std::max(1, sc.decoded)));
      EXPECT_GE(sc.min_axis_px, 16);
      EXPECT_EQ(sc.decoded, sc.targets) << sc.counts.ToString();
      EXPECT_EQ(sc.wrong, 0);
      EXPECT_LT(sc.max_err_px, 0.02);
    }
  }
}

TEST(CodedRender, NoisyDefocusedRendersCentreWithin005Px) {
  // 2 % noise: read noise 2 % of the ink–paper contrast (full well 1e5 e-, so shot noise adds
  // under 3 % to it); 1.5 px defocus: the thin lens focused nearer than the target, the f-number
  // chosen so the blur circle's radius at the farthest dot is 1.5 px (at tilt 0 at every dot; at
  // 60° the nearest dots are blurred by 0.3 px).
  for (const unsigned seed : {1u, 2u, 3u}) {  // three draws of the noise
    for (const double tilt : {0.0, 40.0, 60.0}) {
      Scene s = CodedScene("coded:14:7", 720, Medium::kAir);
      const double dist = DistanceFor(s, 18 / std::sqrt(std::cos(tilt * M_PI / 180)));
      s.pose = PoseFacing(s.target, dist, {0, 0}, tilt * 0.6, -tilt * 0.8, -20);
      s.focus_distance_mm = 0.8 * dist;
      const render::Setup focus = Resolve(s);
      const double c_px = focus.camera.FocalLengthPx(), sharp = focus.focus.d_s2ep_mm;
      double d = 0;  // the farthest dot: the most blurred (the lens is focused nearer)
      for (const Vec3& p : calib::TargetPoints(s.target)) d = std::max(d, s.pose.Apply(p).z());
      const double blur_radius_px = 1.5;
      s.f_number = s.housed.lens.focal_length_mm * c_px * std::abs(1 / d - 1 / sharp) / (2 * blur_radius_px);
      RenderOptions ro;
      ro.samples_per_pixel = 36;
      // Edges (and the blur) get 400 samples, so the render's own sampling of the pixel and the
      // pupil does not count against the detector.
      ro.edge_samples_per_pixel = 400;
      ro.seed = seed;
      ro.full_well_e = 1e5;
      ro.read_noise_e = 0.02 * (s.style.white - s.style.black) * ro.full_well_e;
      const Score sc = RenderAndScore(s, ro, 16);
      std::printf("noise 2 %%, defocus 1.5 px (f/%.1f, focused at %.0f mm, farthest dot at %.0f mm), tilt %2.0f, seed %u: %d/%d "
                  "decoded, worst %.4f px, RMS %.4f px\n", s.f_number, sharp, d, tilt, seed, sc.decoded, sc.targets, sc.max_err_px,
                  std::sqrt(sc.sum_err2 / std::max(1, sc.decoded)));
      EXPECT_EQ(sc.decoded, sc.targets) << sc.counts.ToString();
      EXPECT_EQ(sc.wrong, 0);
      EXPECT_LT(sc.max_err_px, 0.05);
    }
  }
}

// One large dot (the 12-bit AICON sheet of 20 mm dots holds one target) tilted 0–70°, 70–75 px
// across: the detected centre against (a) the image of the dot's centre (the uncorrected model)
// and (b) the centre of its traced rim's ellipse (the model-based correction, dots.h).
struct BiasRow {
  double tilt_deg, uncorrected_px, corrected_px, closed_form_px, axis_px;
};
std::vector<BiasRow> BiasOverTilts(Scene s, double dot_px) {
  s.housed.camera.sensor.width_px = 400;  // a crop of the 720-px frame round the dot and its ring
  s.housed.camera.sensor.height_px = 360;
  std::vector<BiasRow> rows;
  const auto pts = calib::TargetPoints(s.target);
  for (const double tilt : {0.0, 20.0, 40.0, 55.0, 70.0}) {
    s.pose = PoseFacing(s.target, DistanceFor(s, dot_px), {0, 0}, tilt * 0.8, tilt * 0.6, 15);
    s.pose.translation_mm -= s.pose.Apply(pts[1]) - s.pose.Apply(TargetCentre(s.target));  // the dot, not the sheet, at the centre
    RenderOptions ro;
    ro.samples_per_pixel = 36;
    // Edges get 400 samples: at 36 the render's own sampling error of the dot's centre was as large
    // as the 1 % to be measured; at 400 the differences are at most 0.001 px (docs/targets.md).
    ro.edge_samples_per_pixel = 400;
    const Rendered r = Render(s, ro);
    coded::CodedDetectOptions o;
    o.bits = 12;
    const coded::CodedDetection det = coded::DetectCodedTargets(Gray16(r.image), o);
    EXPECT_EQ(det.targets.size(), 1u) << det.counts.ToString();
    if (det.targets.size() != 1) continue;
    const Vec2 measured = det.targets[0].centre_px;
    const Vec2 point = r.truth.front().pixel_per_band[0];
    const Vec2 dot = DotImageCentres(s, r.setup).front().centre_px_per_band[0];
    const Vec2 cf = coded::EccentricityPx(r.setup.camera.FocalLengthPx(), s.pose.rotation, s.pose.Apply(pts[1]),
                                          s.target.dot_radius_mm);
    const Vec2 e = measured - point;
    rows.push_back({tilt, e.norm(), (measured - dot).norm(), cf.norm(), LongAxisPx(r.setup, s.pose, pts[1], 20)});
    std::printf("tilt %2.0f: dot %.0f px, uncorrected %.4f px (closed form %.4f, differ %.4f px), corrected %.4f px\n",
                tilt, rows.back().axis_px, e.norm(), cf.norm(), (e - cf).norm(), rows.back().corrected_px);
    rows.back().closed_form_px = (e - cf).norm();  // kept as the difference from here on
  }
  return rows;
}

TEST(CodedRender, UncorrectedBiasIsTheClosedFormInAir) {
  // The camera alone (a dome concentric with the pupil, in air): the image of a circle is an exact
  // conic, and the detector's error against the image of the dot's centre is the closed-form
  // eccentricity (ellipse.h).
  Scene s = CodedScene("coded:12:20", 720, Medium::kAir);
  s.housed.port = ConcentricDome();
  for (const BiasRow& b : BiasOverTilts(s, 66)) {
    // Within 1 % where there is a bias; at tilt 0 (none) the render's sampling noise (< 0.001 px).
    EXPECT_LE(b.closed_form_px, b.tilt_deg > 0 ? 0.01 * b.uncorrected_px : 0.002) << "tilt " << b.tilt_deg;
    EXPECT_LE(b.corrected_px, 0.02) << "tilt " << b.tilt_deg;
    if (b.tilt_deg >= 40) {
      EXPECT_GT(b.uncorrected_px, 0.2);  // a real bias to remove
    }
  }
}

TEST(CodedRender, CorrectionThroughTheAsBuiltDomeLeaves002Px) {
  // Behind the as-built NI320 in sea water, the pupil where the paper had it (the 24 mm focused at
  // 300 mm, Table 4): the image of a circle is no conic; the centre of the ellipse fitted to its
  // traced rim is still where the detector measures it.
  Scene s = CodedScene("coded:12:20", 720, Medium::kWater);
  s.focus_distance_mm = 300;
  for (const BiasRow& b : BiasOverTilts(s, 66)) {
    EXPECT_LE(b.corrected_px, 0.02) << "tilt " << b.tilt_deg;
    if (b.tilt_deg >= 40) {
      EXPECT_GT(b.uncorrected_px, 0.1);
    }
  }
}

// Views of the default sheets of both profiles at 12 and 14 bits, dots 10–12 px across on the
// axis, tilts up to 60° about any axis, any roll, 1 % noise: the decoded fraction of the dots
// >= 10 px, and wrong IDs over every view.
struct DecodeTally {
  int big = 0, decoded_big = 0, decoded = 0, left_out_read = 0, wrong = 0, views = 0;
};
DecodeTally DecodeViews(int n_views, unsigned seed) {
  DecodeTally tally;
  const char* targets[] = {"coded:14:2.5", "coded:12:2.5", "coded:14:2.5:metashape", "coded:12:2.5:metashape"};
  std::uint64_t state = seed;
  auto uniform = [&] {  // splitmix64
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return static_cast<double>((z ^ (z >> 31)) >> 11) * 0x1.0p-53;
  };
  for (int v = 0; v < n_views; ++v) {
    Scene s = CodedScene(targets[v % 4], 1080, Medium::kAir);
    if (v % 2) std::swap(s.style.black, s.style.white);
    const double tilt = 60 * std::sqrt(uniform()), axis = 2 * M_PI * uniform();
    const double dot_px = 10.2 + 2 * uniform();
    s.pose = PoseFacing(s.target, DistanceFor(s, dot_px / std::sqrt(std::cos(tilt * M_PI / 180))), {0, 0},
                        tilt * std::cos(axis), tilt * std::sin(axis), 90 + 20 * (2 * uniform() - 1));
    RenderOptions ro;
    ro.samples_per_pixel = 9;
    ro.seed = seed + v;
    ro.full_well_e = 1e5;
    ro.read_noise_e = 0.01 * std::abs(s.style.white - s.style.black) * ro.full_well_e;
    Score sc;
    try {
      sc = RenderAndScore(s, ro, 10);
    } catch (const InvalidInput&) {
      continue;  // no target of the sheet images whole in the frame at this pose
    }
    ++tally.views;
    tally.big += sc.big;
    tally.decoded_big += sc.decoded_big;
    tally.decoded += sc.decoded;
    tally.left_out_read += sc.left_out_read;
    tally.wrong += sc.wrong;
  }
  return tally;
}

TEST(CodedRender, DotsOf10PxDecodeAt99PercentWithNoWrongId) {
  const DecodeTally t = DecodeViews(8, 1);
  std::printf("%d views: %d of %d dots >= 10 px decoded (%.2f %%), %d decoded in all (and %d the truth left out, "
              "near the frame's edge, read at their dots), %d wrong IDs\n", t.views, t.decoded_big, t.big,
              100.0 * t.decoded_big / t.big, t.decoded, t.left_out_read, t.wrong);
  EXPECT_GE(t.views, 6);
  EXPECT_GE(t.decoded_big, 0.99 * t.big);
  EXPECT_EQ(t.wrong, 0);
}

// The "no wrong ID in 10,000 decoded targets" on renders: 125 views (~100 fit; 3 CPU-minutes on
// two cores), run by hand: coded_render_test --gtest_also_run_disabled_tests --gtest_filter=*TenThousand*
TEST(CodedRender, DISABLED_TenThousandDecodedWithNoWrongId) {
  const DecodeTally t = DecodeViews(125, 7);
  std::printf("%d views: %d of %d dots >= 10 px decoded (%.2f %%), %d decoded in all (and %d the truth left out, "
              "near the frame's edge, read at their dots), %d wrong IDs\n", t.views, t.decoded_big, t.big,
              100.0 * t.decoded_big / t.big, t.decoded, t.left_out_read, t.wrong);
  EXPECT_GE(t.decoded, 10000);
  EXPECT_GE(t.decoded_big, 0.99 * t.big);
  EXPECT_EQ(t.wrong, 0);
}

}  // namespace
}  // namespace porthole::render
