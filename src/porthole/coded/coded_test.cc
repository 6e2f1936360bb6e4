// Proves: the code lists follow their rules and match the published tables (counts 147/516,
// 161/561, IDs in order); sheets place every target inside the paper with exact ring arcs; the
// field file round-trips; the rasteriser's inked area equals the closed-form area; the closed-form
// ellipse centre of a projected circle agrees with a conic fitted to projected circle points.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <array>
#include <cstdio>
#include <fstream>
#include <map>
#include <numbers>
#include <regex>
#include <sstream>

#include "porthole/coded/codes.h"
#include "porthole/coded/ellipse.h"
#include "porthole/coded/raster.h"
#include "porthole/coded/sheet.h"
#include "porthole/core/error.h"

namespace porthole::coded {
namespace {

constexpr double kPi = std::numbers::pi;

// tests/data/coded_target_tables.txt: name+bits → (published count, codes listed).
std::map<std::pair<std::string, int>, std::pair<int, std::vector<uint32_t>>> PublishedTables() {
  std::ifstream in(std::string(PORTHOLE_TEST_DATA_DIR) + "/coded_target_tables.txt");
  EXPECT_TRUE(in.good());
  std::map<std::pair<std::string, int>, std::pair<int, std::vector<uint32_t>>> tables;
  std::pair<std::string, int> key;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    if (line.rfind("table", 0) == 0) {
      std::string word;
      int count = 0;
      ls >> word >> key.first >> key.second >> count;
      tables[key].first = count;
      continue;
    }
    for (uint32_t c; ls >> c;) tables[key].second.push_back(c);
  }
  return tables;
}

TEST(Codes, CountsOfEachProfile) {
  EXPECT_EQ(Codes(Profile::kAicon, 14).size(), 516u);
  EXPECT_EQ(Codes(Profile::kAicon, 12).size(), 147u);
  EXPECT_EQ(Codes(Profile::kMetashape, 12).size(), 161u);
  EXPECT_EQ(Codes(Profile::kMetashape, 14).size(), 561u);
}

TEST(Codes, MatchThePublishedTables) {
  const auto tables = PublishedTables();
  ASSERT_EQ(tables.size(), 3u);
  for (const auto& [key, table] : tables) {
    const Profile p = ParseProfile(key.first);
    const auto& ours = Codes(p, key.second);
    EXPECT_EQ(static_cast<int>(ours.size()), table.first) << key.first << " " << key.second;
    ASSERT_LE(table.second.size(), ours.size());
    for (std::size_t i = 0; i < table.second.size(); ++i) {
      EXPECT_EQ(ours[i], table.second[i]) << key.first << " " << key.second << "-bit ID " << i + 1;
      EXPECT_EQ(IdOfRing(p, key.second, table.second[i]), static_cast<int>(i) + 1);
    }
  }
  EXPECT_EQ(tables.at({"metashape", 12}).second.size(), 161u);  // the whole tables
  EXPECT_EQ(tables.at({"metashape", 14}).second.size(), 561u);
}

TEST(Codes, EveryCodeIsCanonicalAndFoundFromAnyRotation) {
  for (Profile p : {Profile::kAicon, Profile::kMetashape}) {
    for (int bits : {12, 14}) {
      const auto& list = Codes(p, bits);
      for (std::size_t i = 0; i < list.size(); ++i) {
        ASSERT_EQ(MinimalRotation(list[i], bits), list[i]);
        if (i > 0) {
          ASSERT_LT(list[i - 1], list[i]);
        }
        for (int k = 0; k < bits; ++k) {
          const uint32_t mask = (1u << bits) - 1;
          const uint32_t rot = ((list[i] << k) | (list[i] >> (bits - k))) & mask;
          ASSERT_EQ(IdOfRing(p, bits, rot), static_cast<int>(i) + 1);
        }
        EXPECT_EQ(CodeOfId(p, bits, static_cast<int>(i) + 1), list[i]);
      }
      EXPECT_EQ(IdOfRing(p, bits, 0), 0);                    // a plain dot
      EXPECT_EQ(IdOfRing(p, bits, (1u << bits) - 1), 0);     // a full ring
      EXPECT_EQ(IdOfRing(p, bits, 1), 0);                    // odd weight: one bit flipped
      EXPECT_THROW(CodeOfId(p, bits, static_cast<int>(list.size()) + 1), InvalidInput);
    }
  }
}

TEST(Codes, OneFlippedBitNeverGivesAnotherId) {
  // Even weight in both profiles: a single misread bit makes the weight odd, never a valid code.
  for (Profile p : {Profile::kAicon, Profile::kMetashape}) {
    for (int bits : {12, 14}) {
      for (uint32_t c : Codes(p, bits)) {
        for (int k = 0; k < bits; ++k) ASSERT_EQ(IdOfRing(p, bits, c ^ (1u << k)), 0);
      }
    }
  }
}

TEST(Codes, BadNamesAndBits) {
  EXPECT_EQ(ParseProfile("AICON"), Profile::kAicon);
  EXPECT_EQ(ParseProfile("Metashape"), Profile::kMetashape);
  EXPECT_THROW(ParseProfile("gom"), InvalidInput);
  EXPECT_THROW(ValidateBits(16), InvalidInput);
}

TEST(Sheet, TargetsInsideThePaperAndApart) {
  for (Profile p : {Profile::kAicon, Profile::kMetashape}) {
    SheetOptions o;
    o.profile = p;
    o.radius_mm = 3;
    const SheetLayout l = LayoutSheet(o);
    ASSERT_FALSE(l.targets.empty());
    const double outer = Ring(p).outer * o.radius_mm;
    for (std::size_t i = 0; i < l.targets.size(); ++i) {
      const auto& t = l.targets[i];
      EXPECT_EQ(t.id, static_cast<int>(i) + 1);
      EXPECT_GE(t.xyz_mm.x() - outer, o.margin_mm);
      EXPECT_LE(t.xyz_mm.x() + outer, l.width_mm - o.margin_mm);
      EXPECT_GE(t.xyz_mm.y() - outer, o.margin_mm);
      EXPECT_LE(t.xyz_mm.y() + outer, l.scale_bar_mm.y());
      for (std::size_t j = 0; j < i; ++j) {
        EXPECT_GE((t.xyz_mm - l.targets[j].xyz_mm).norm(), 2 * outer + 2 * o.radius_mm - 1e-9);
      }
    }
  }
  SheetOptions tiny;
  tiny.radius_mm = 40;
  EXPECT_THROW(LayoutSheet(tiny), InvalidInput);
  SheetOptions many;
  many.count = 10000;
  EXPECT_THROW(LayoutSheet(many), InvalidInput);
  SheetOptions last;
  last.first_id = 516;
  EXPECT_EQ(LayoutSheet(last).targets.size(), 1u);
  EXPECT_THROW(PaperSizeMm("B7"), InvalidInput);
  EXPECT_NEAR(PaperSizeMm("300x200").x(), 300, 0);
}

TEST(Sheet, SvgArcsLieOnTheRingCircles) {
  SheetOptions o;
  o.count = 12;
  const SheetLayout l = LayoutSheet(o);
  const std::string svg = SheetSvg(l);
  // Every path: M p A R R 0 large 1 q L p' A r r 0 large 0 q' Z with all four ends on their circles
  // about one of the targets' centres, and the arcs' angles on the 14 segment borders.
  const std::regex path(R"re(d="M ([-\d.]+) ([-\d.]+) A ([\d.]+) [\d.]+ 0 [01] 1 ([-\d.]+) ([-\d.]+) L ([-\d.]+) ([-\d.]+) A ([\d.]+) [\d.]+ 0 [01] 0 ([-\d.]+) ([-\d.]+) Z")re");
  int arcs = 0;
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), path); it != std::sregex_iterator(); ++it) {
    const auto& m = *it;
    const double ro = std::stod(m[3]), ri = std::stod(m[8]);
    EXPECT_NEAR(ro, 7.5, 1e-9);
    EXPECT_NEAR(ri, 5.0, 1e-9);
    const Eigen::Vector2d p[4] = {{std::stod(m[1]), std::stod(m[2])}, {std::stod(m[4]), std::stod(m[5])},
                                  {std::stod(m[6]), std::stod(m[7])}, {std::stod(m[9]), std::stod(m[10])}};
    double best = 1e9;
    Eigen::Vector2d c;
    for (const auto& t : l.targets) {
      if ((p[0] - t.xyz_mm.head<2>()).norm() < best) best = (p[0] - t.xyz_mm.head<2>()).norm(), c = t.xyz_mm.head<2>();
    }
    const double radii[4] = {ro, ro, ri, ri};
    for (int k = 0; k < 4; ++k) {
      EXPECT_NEAR((p[k] - c).norm(), radii[k], 2e-6);  // 6 decimals written
      double ang = std::atan2(p[k].y() - c.y(), p[k].x() - c.x());
      const double seg = ang / (2 * kPi / 14);
      EXPECT_NEAR(seg, std::round(seg), 1e-6);
    }
    ++arcs;
  }
  EXPECT_GE(arcs, 12);
  EXPECT_NE(svg.find("100 mm"), std::string::npos);
}

TEST(Sheet, PdfCrossReferenceOffsetsPointAtTheirObjects) {
  SheetOptions o;
  o.count = 5;
  o.white_on_black = true;
  const std::string pdf = SheetPdf(LayoutSheet(o));
  ASSERT_EQ(pdf.rfind("%PDF-1.4", 0), 0u);
  const auto sx = pdf.rfind("startxref\n");
  const std::size_t xref = std::stoul(pdf.substr(sx + 10));
  ASSERT_EQ(pdf.compare(xref, 4, "xref"), 0);
  std::istringstream in(pdf.substr(xref));
  std::string word;
  int first = 0, n = 0;
  in >> word >> first >> n;
  for (int i = 0; i < n; ++i) {
    std::string off, gen, kind;
    in >> off >> gen >> kind;
    if (i == 0) continue;
    EXPECT_EQ(pdf.compare(std::stoul(off), std::to_string(i).size() + 6, std::to_string(i) + " 0 obj"), 0) << i;
  }
}

TEST(Sheet, PdfDotsAreCirclesToAMillionthOfTheRadius) {
  // The first dot of the content stream: "x y m" then Bézier pieces "x1 y1 x2 y2 x3 y3 c" up to
  // "h f". Every piece evaluated at 64 parameters lies on the circle about the target's centre.
  SheetOptions o;
  o.count = 1;
  o.radius_mm = 4;
  const SheetLayout l = LayoutSheet(o);
  const std::string pdf = SheetPdf(l);
  std::istringstream in(pdf.substr(pdf.find("stream\n") + 7));
  std::vector<double> nums;
  Eigen::Vector2d start;
  std::vector<std::array<Eigen::Vector2d, 3>> pieces;
  for (std::string w; in >> w && w != "h";) {
    if (w == "m") {
      start = {nums[nums.size() - 2], nums.back()};
      nums.clear();
    } else if (w == "c") {
      const auto n = nums.size();
      pieces.push_back({Eigen::Vector2d(nums[n - 6], nums[n - 5]), Eigen::Vector2d(nums[n - 4], nums[n - 3]),
                        Eigen::Vector2d(nums[n - 2], nums[n - 1])});
      nums.clear();
    } else {
      try {
        nums.push_back(std::stod(w));
      } catch (const std::exception&) {
        nums.clear();
      }
    }
  }
  ASSERT_EQ(pieces.size(), 16u);
  const Eigen::Vector2d c = l.targets[0].xyz_mm.head<2>();
  double worst = 0;
  Eigen::Vector2d p0 = start;
  for (const auto& pc : pieces) {
    for (int k = 0; k <= 64; ++k) {
      const double t = k / 64.0, u = 1 - t;
      const Eigen::Vector2d b = u * u * u * p0 + 3 * u * u * t * pc[0] + 3 * u * t * t * pc[1] + t * t * t * pc[2];
      worst = std::max(worst, std::abs((b - c).norm() - o.radius_mm) / o.radius_mm);
    }
    p0 = pc[2];
  }
  std::printf("PDF circle: worst radial error %.2e of the radius\n", worst);
  EXPECT_LT(worst, 1e-6);
}

TEST(Sheet, FieldRoundTripsAndBadFieldsAreRejected) {
  SheetOptions o;
  o.profile = Profile::kMetashape;
  o.bits = 12;
  const SheetLayout l = LayoutSheet(o);
  const auto back = ParseField(FieldText(l));
  ASSERT_EQ(back.size(), l.targets.size());
  for (std::size_t i = 0; i < back.size(); ++i) {
    EXPECT_EQ(back[i].id, l.targets[i].id);
    EXPECT_LT((back[i].xyz_mm - l.targets[i].xyz_mm).norm(), 1e-4);
  }
  EXPECT_THROW(ParseField("1 2 3\n"), InvalidInput);
  EXPECT_THROW(ParseField("1 2 3 4\n1 5 6 7\n"), InvalidInput);
  EXPECT_THROW(ParseField("0 2 3 4\n"), InvalidInput);
  EXPECT_THROW(ParseField("1 2 x 4\n"), InvalidInput);
  EXPECT_THROW(ParseField("# nothing\n"), InvalidInput);
  EXPECT_EQ(ParseField("7, 1.5, 2, -3  # a raised target\n")[0].xyz_mm.z(), -3);
  // Control points: "# control" held exactly, "# sigma_mm SX SY SZ control" with its σ; a σ on an
  // ordinary point is no control point; a bad σ is refused.
  EXPECT_FALSE(ParseField("7 1 2 3  # sigma_mm 1 1 1\n")[0].control_sigma_mm.has_value());
  EXPECT_EQ(*ParseField("7 1 2 3  # control\n")[0].control_sigma_mm, Eigen::Vector3d::Zero());
  EXPECT_EQ(*ParseField("7 1 2 3  # sigma_mm 0.5 0.5 2 control\n")[0].control_sigma_mm, Eigen::Vector3d(0.5, 0.5, 2));
  EXPECT_THROW(ParseField("7 1 2 3  # sigma_mm 0.5 -1 2 control\n"), InvalidInput);
  EXPECT_THROW(ParseField("7 1 2 3  # sigma_mm 0.5 control\n"), InvalidInput);
  // Four numbers: the dot faces −Z; seven: the normal given, normalised.
  EXPECT_TRUE(FacesMinusZ(ParseField("1 0 0 0\n")[0]));
  const PlacedTarget wall = ParseField("2 0 10 -50 2 0 0  # a wall facing +X\n")[0];
  EXPECT_EQ(wall.normal, Eigen::Vector3d::UnitX());
  EXPECT_FALSE(FacesMinusZ(wall));
  EXPECT_THROW(ParseField("1 0 0 0 0 0 0\n"), InvalidInput);  // a zero normal
  EXPECT_THROW(ParseField("1 0 0 0 1 0\n"), InvalidInput);    // six numbers
}

TEST(Sheet, DotAxesSpanTheDotsPlaneRightHanded) {
  // (u, v, −n) right-handed and orthonormal for any normal; the sheet's X, Y for −Z.
  const auto [x, y] = DotAxes(-Eigen::Vector3d::UnitZ());
  EXPECT_EQ(x, Eigen::Vector3d::UnitX());
  EXPECT_EQ(y, Eigen::Vector3d::UnitY());
  for (const Eigen::Vector3d& n : {Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(-1, 0, 0), Eigen::Vector3d(0, 1, 0),
                                   Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0.3, -0.4, 0.5).normalized()}) {
    const auto [u, v] = DotAxes(n);
    EXPECT_NEAR(u.norm(), 1, 1e-12);
    EXPECT_NEAR(v.norm(), 1, 1e-12);
    EXPECT_NEAR(u.dot(n), 0, 1e-12);
    EXPECT_NEAR(v.dot(n), 0, 1e-12);
    EXPECT_NEAR((u.cross(v) + n).norm(), 0, 1e-12) << n.transpose();
  }
}

TEST(Raster, InkedAreaEqualsTheClosedForm) {
  // Fronto-parallel at 10 px/mm: the dot is π r², each 1 bit an annular sector (π/bits)(ro² − ri²).
  for (Profile p : {Profile::kAicon, Profile::kMetashape}) {
    RasterOptions o;
    o.profile = p;
    o.radius_mm = 2.2;
    o.subrows = 64;
    Eigen::Matrix3d h;
    h << 10, 0, 100.3, 0, 10, 99.6, 0, 0, 1;
    const int id = 37;
    const auto img = RasterizeTargets(200, 200, h, {{id, Eigen::Vector3d(0.02, -0.07, 0)}}, o);
    double sum = 0;
    for (double v : img) sum += v;
    const RingRadii ring = Ring(p);
    const int ones = std::popcount(CodeOfId(p, o.bits, id));
    const double r = 22, ri = ring.inner * r, ro = ring.outer * r;
    const double area = kPi * r * r + ones * kPi / o.bits * (ro * ro - ri * ri);
    EXPECT_NEAR(sum / area, 1, 1e-4) << ProfileName(p);  // 3.6e-5 measured: midpoint rule where rows graze a circle
  }
}

TEST(Ellipse, ClosedFormCentreMatchesAFittedConic) {
  // Camera f = 2000 px looking at a circle of radius 8 mm at 300 mm, plane tilted 50° about a
  // skew axis: the closed-form ellipse centre against the centre of the conic through 200
  // projected points of the circle (an algebraic fit, independent of the dual-conic formula).
  const double f = 2000, radius = 8;
  const Eigen::Matrix3d rot = Eigen::AngleAxisd(50 * kPi / 180, Eigen::Vector3d(0.6, 0.8, 0)).toRotationMatrix();
  const Eigen::Vector3d t(40, -25, 300);
  Eigen::MatrixXd design(200, 6);
  for (int k = 0; k < 200; ++k) {
    const double th = 2 * kPi * k / 200;
    const Eigen::Vector3d x = rot * Eigen::Vector3d(radius * std::cos(th), radius * std::sin(th), 0) + t;
    const double u = f * x.x() / x.z(), v = f * x.y() / x.z();
    design.row(k) << u * u, u * v, v * v, u, v, 1;
  }
  const Eigen::VectorXd c = Eigen::JacobiSVD<Eigen::MatrixXd>(design, Eigen::ComputeFullV).matrixV().col(5);
  // Centre of a u² + b uv + c v² + d u + e v + f = 0: the gradient's zero.
  Eigen::Matrix2d m;
  m << 2 * c(0), c(1), c(1), 2 * c(2);
  const Eigen::Vector2d fitted = m.inverse() * (Eigen::Vector2d(-c(3), -c(4)));
  const Eigen::Vector2d projected(f * t.x() / t.z(), f * t.y() / t.z());
  const Eigen::Vector2d e = EccentricityPx(f, rot, t, radius);
  EXPECT_GT(e.norm(), 0.3);  // a real bias, several tenths of a pixel
  EXPECT_LT((projected + e - fitted).norm(), 1e-6 * e.norm() + 1e-7);
  Eigen::Matrix3d h;
  h.col(0) = rot.col(0);
  h.col(1) = rot.col(1);
  h.col(2) = t;
  h = Eigen::DiagonalMatrix<double, 3>(f, f, 1) * h;
  EXPECT_LT((ConicCentreOfCircle<double>(h, Eigen::Vector2d::Zero(), radius) - fitted).norm(), 1e-6);
  EXPECT_LT(EccentricityPx(f, Eigen::Matrix3d::Identity(), t, radius).norm(), 1e-12);  // no tilt, no bias
}

}  // namespace
}  // namespace porthole::coded
