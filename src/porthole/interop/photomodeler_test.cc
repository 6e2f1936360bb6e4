// PhotoModeler's text export and DBAT's control-point file (photomodeler.h), on DBAT's camera
// calibration project (tests/data/README.md: dbat_camcal_*), checked against the counts DBAT's
// report states, and hostile inputs refused in one line.
#include "porthole/interop/photomodeler.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <fstream>
#include <functional>
#include <random>
#include <map>
#include <sstream>

#include "porthole/core/error.h"

namespace porthole::interop {
namespace {

const std::string kData = PORTHOLE_TEST_DATA_DIR;
const std::string kExport = kData + "/dbat_camcal_pmexport.txt";
const std::string kControl = kData + "/dbat_camcal_fixed.txt";

std::string FileText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// DBAT's report of this project (camcal-dbatreport.txt): 21 photos, 2272 x 1704 px, 4148 image
// observations (2074 points × 2), 288 object-point parameters (96 free points × 3) beside the 4
// fixed control points: 100 points.
TEST(PhotoModeler, ReadsDbatsCalibrationProjectWithTheCountsItsReportStates) {
  PhotoModelerProject p = ReadPhotoModelerExport(kExport);
  EXPECT_EQ(p.title, "Bundle Soln PhotoModeler Calibration Project");
  EXPECT_EQ(p.width_px, 2272);
  EXPECT_EQ(p.height_px, 1704);
  ASSERT_EQ(p.detections.size(), 21u);
  EXPECT_EQ(p.n_marks, 2074);
  int n = 0;
  for (const auto& d : p.detections) {
    n += static_cast<int>(d.ids.size());
    EXPECT_EQ(d.width_px, 2272);
    EXPECT_EQ(d.ids.size(), d.points_px.size());
  }
  EXPECT_EQ(n, 2074);
  EXPECT_EQ(p.field.size(), 100u);
  EXPECT_EQ(p.detections[0].image, "data/dbat/images/cam/P8250021.JPG");
  EXPECT_EQ(p.detections[20].image, "data/dbat/images/cam/P8250041.JPG");

  // The export's control block is empty: DBAT reads the control points from camcal-fixed.txt.
  int n_control = 0;
  for (const auto& q : p.field) n_control += q.control;
  EXPECT_EQ(n_control, 0);
  const std::vector<FieldPoint> cp = ReadDbatControlPoints(kControl);
  ASSERT_EQ(cp.size(), 4u);
  ApplyControlPoints(cp, &p);
  std::map<int, FieldPoint> by_id;
  for (const auto& q : p.field) by_id[q.id] = q;
  for (int id : {1001, 1002, 1003, 1004}) {
    ASSERT_TRUE(by_id.count(id));
    EXPECT_TRUE(by_id[id].control);
    EXPECT_EQ(by_id[id].sigma_mm, Eigen::Vector3d::Zero());  // no sigma in the file: fixed
  }
  // camcal-fixed.txt: CP2 at (1, 1, 0) m, CP4 at (1, 0, 0) m.
  EXPECT_EQ(by_id[1002].xyz_mm, Eigen::Vector3d(1000, 1000, 0));
  EXPECT_EQ(by_id[1004].name, "CP4");
  EXPECT_EQ(by_id[1004].xyz_mm, Eigen::Vector3d(1000, 0, 0));
  // An object point: metres × 1000, its sigma too (line "2 0.28573 1.14303 -0.00098 0.000042 …").
  EXPECT_NEAR(by_id[2].xyz_mm.x(), 285.73, 1e-9);
  EXPECT_NEAR(by_id[2].xyz_mm.z(), -0.98, 1e-9);
  EXPECT_NEAR(by_id[2].sigma_mm.z(), 0.072, 1e-12);
  EXPECT_FALSE(by_id[2].control);
}

// Pixel origin: the export's first mark "0 2 1429.1871 1456.4278" is (1428.6871, 1455.9278) in
// porthole's pixels (the centre of the top-left pixel at 0, not 0.5).
TEST(PhotoModeler, ShiftsPixelsByHalfAPixelAndConvertsTheCameraToTheCentreAndYUp) {
  const PhotoModelerProject p = ReadPhotoModelerExport(kExport);
  const auto& d = p.detections[0];
  ASSERT_FALSE(d.ids.empty());
  EXPECT_EQ(d.ids[0], 2);
  EXPECT_NEAR(d.points_px[0].x(), 1428.6871, 1e-9);
  EXPECT_NEAR(d.points_px[0].y(), 1455.9278, 1e-9);
  // Line 4: "7.4653 3.6173 2.6128 7.25319 5.43764 0.00498 -0.00010 0.00000 -0.00006 -0.00004".
  const BrownFromPhotoModeler b = BrownCamera(p);
  EXPECT_NEAR(b.pixel_pitch_mm, 5.43764 / 1704, 1e-15);
  EXPECT_NEAR(b.c_mm, 7.4653, 1e-12);
  EXPECT_NEAR(b.x0_mm, 3.6173 - 7.25319 / 2, 1e-12);
  EXPECT_NEAR(b.y0_mm, 5.43764 / 2 - 2.6128, 1e-12);  // above the centre: y up
  EXPECT_GT(b.y0_mm, 0);
  EXPECT_NEAR(b.K1, 0.00498, 1e-15);
  EXPECT_NEAR(b.P2, -0.00004, 1e-15);
}

// The field file is one porthole reads (coded/sheet.h ParseField): 100 lines of four numbers, σ and
// the control mark in the comment.
TEST(PhotoModeler, FieldFileCarriesSigmaAndTheControlMarkInComments) {
  PhotoModelerProject p = ReadPhotoModelerExport(kExport);
  ApplyControlPoints(ReadDbatControlPoints(kControl), &p);
  const std::string text = FieldFileText(p, "x.txt");
  int data = 0, control = 0;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    ++data;
    control += line.find("# sigma_mm 0 0 0 control") != std::string::npos;
  }
  EXPECT_EQ(data, 100);
  EXPECT_EQ(control, 4);
  EXPECT_NE(text.find("\n1001 0.000000 1000.000000 0.000000  # sigma_mm 0 0 0 control\n"), std::string::npos);
  EXPECT_NE(text.find("\n2 285.730000 1143.030000 -0.980000  # sigma_mm 0.042 0.041 0.072\n"), std::string::npos);
}

TEST(PhotoModeler, ControlPointFileSigmaForms) {
  const auto cp = ParseDbatControlPoints("# Id, name, X, Y, Z, s\n1, a, 1, 2, 3\n2, b, 1, 2, 3, 0.001\n"
                                         "3, c, 1, 2, 3, 0.02, 0.04\n4, d, 1, 2, 3, 0.02, 0.03, 0.04\n",
                                         "c.txt");
  ASSERT_EQ(cp.size(), 4u);
  EXPECT_EQ(cp[0].sigma_mm, Eigen::Vector3d::Zero());
  EXPECT_EQ(cp[1].sigma_mm, Eigen::Vector3d::Constant(1));
  EXPECT_EQ(cp[2].sigma_mm, Eigen::Vector3d(20, 20, 40));
  EXPECT_EQ(cp[3].sigma_mm, Eigen::Vector3d(20, 30, 40));
  EXPECT_EQ(cp[3].xyz_mm, Eigen::Vector3d(1000, 2000, 3000));
}

// The export with one line replaced (1-based), or cut after `keep` lines.
std::string WithLine(const std::string& text, int n, const std::string& replacement) {
  std::istringstream in(text);
  std::string out;
  int i = 0;
  for (std::string line; std::getline(in, line);) {
    ++i;
    out += (i == n ? replacement : line) + "\n";
  }
  return out;
}
std::string FirstLines(const std::string& text, int keep) {
  std::istringstream in(text);
  std::string out;
  std::string line;
  for (int i = 0; i < keep && std::getline(in, line); ++i) out += line + "\n";
  return out;
}

// One line naming the file and the line; never a crash.
void ExpectRefused(const std::string& text, const std::string& line_tag, const std::string& what) {
  try {
    ParsePhotoModelerExport(text, "pm.txt", {}, "photomodeler");
    ADD_FAILURE() << "accepted: " << what;
  } catch (const InvalidInput& e) {
    const std::string m = e.what();
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    EXPECT_NE(m.find(line_tag.empty() ? "photomodeler: 'pm.txt': " : "photomodeler: 'pm.txt' " + line_tag + ": "),
              std::string::npos) << m;
    EXPECT_NE(m.find(what), std::string::npos) << m;
  }
}

// Lines of the camcal export: 4 camera, 6 photo 0's name, 7 its orientation, 134 the first object
// point (2), 235 the first mark (photo 0, point 2).
TEST(PhotoModeler, RefusesHostileInputsInOneLineNamingFileAndLine) {
  const std::string t = FileText(kExport);
  ExpectRefused(FirstLines(t, 3), "line 3", "the file ends before line 4");
  ExpectRefused(WithLine(t, 4, " 7.4653  3.6173  2.6128 7.25319"), "line 4", "the line has 4");
  ExpectRefused(WithLine(t, 7, "   0    0.455    nan    1.468 -179.839   -1.181  -39.420"), "line 7", "'nan' is not a finite");
  ExpectRefused(WithLine(t, 7, "   0    0.455    1.794"), "line 7", "the line has 3 numbers");
  ExpectRefused(WithLine(t, 134, "       3    0.28573    1.14303   -0.00098   0.000042   0.000041   0.000072"), "line 135",
                "point 3 appears twice");
  ExpectRefused(WithLine(t, 235, "  21        2 1429.1871 1456.4278  0.10000  0.10000"), "line 235",
                "photo 21, which the photo list does not hold");
  ExpectRefused(WithLine(t, 235, "   0     5000 1429.1871 1456.4278  0.10000  0.10000"), "line 235", "no object point has that id");
  ExpectRefused(WithLine(t, 235, "   0        3 1429.1871 1456.4278  0.10000  0.10000"), "line 236", "point 3 is marked twice");
  ExpectRefused(WithLine(t, 235, "   0        2 1429.1871"), "line 235", "the line has 3 numbers");
  ExpectRefused(WithLine(t, 235, "   0        2 1e999 1456.4278  0.10000  0.10000"), "line 235", "not a finite number");
  ExpectRefused(WithLine(t, 235, "   0        2 -3 1456.4278  0.10000  0.10000"), "line 235", "outside the 2272x1704 image");
  ExpectRefused(WithLine(t, 2, " 0.000500 20"), "line 2", "holds no image size");
  ExpectRefused(WithLine(t, 12, "   0 data/dbat/images/cam/P8250022.JPG"), "line 12", "photo 0 appears twice");
  ExpectRefused(FirstLines(t, 40), "line 40", "the file ends inside photo 5");
  ExpectRefused("", "", "the file is empty");
  // The image size from the caller when line 2 has none.
  PhotoModelerOptions opt;
  opt.image_size_px = std::pair(2272, 1704);
  EXPECT_EQ(ParsePhotoModelerExport(WithLine(t, 2, " 0.000500 20"), "pm.txt", opt).n_marks, 2074);

  for (const auto& [text, what] : std::vector<std::pair<std::string, std::string>>{
           {"1, a, 1, 2\n", "the line has 4 fields"},
           {"1, a, 1, 2, nan\n", "not a finite number"},
           {"1, a, 1, 2, 3\n1, b, 1, 2, 3\n", "control point 1 appears twice"},
           {"# nothing\n", "holds no control point"}}) {
    try {
      ParseDbatControlPoints(text, "c.txt", "control_points");
      ADD_FAILURE() << "accepted: " << what;
    } catch (const InvalidInput& e) {
      EXPECT_NE(std::string(e.what()).find("control_points: 'c.txt' line"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  }
  PhotoModelerProject p = ReadPhotoModelerExport(kExport);
  EXPECT_THROW(ApplyControlPoints(ParseDbatControlPoints("7777, X, 0, 0, 0\n", "c.txt"), &p), InvalidInput);
}

// PhotoModeler's point tables of the same calibration (DBAT's prague2016/cam "weighted" project,
// PhotoModeler Scanner 2016): the same 2074 marks as the export above, read by the other reader, to
// the export's rounding (4 decimals: 5e-5 px); 100 points, the four "Control" ones marked.
TEST(PhotoModeler, PointTablesGiveTheExportsMarks) {
  PhotoModelerOptions opt;
  opt.image_size_px = std::pair(2272, 1704);
  const PhotoModelerProject t = ReadPhotoModelerTables(kData + "/dbat_prague2016_cam_2dpts.txt",
                                                       kData + "/dbat_prague2016_cam_3dpts.txt", opt);
  const PhotoModelerProject e = ReadPhotoModelerExport(kExport);
  ASSERT_EQ(t.detections.size(), 21u);
  EXPECT_EQ(t.n_marks, 2074);
  EXPECT_EQ(t.field.size(), 100u);
  double worst = 0;
  for (std::size_t k = 0; k < 21; ++k) {
    EXPECT_EQ(t.photo_numbers[k], e.photo_numbers[k] + 1);  // the tables count photos from 1
    EXPECT_EQ(t.detections[k].image, fmt::format("photo {}", k + 1));
    std::map<int, Eigen::Vector2d> mine;
    for (std::size_t i = 0; i < e.detections[k].ids.size(); ++i) mine[e.detections[k].ids[i]] = e.detections[k].points_px[i];
    ASSERT_EQ(t.detections[k].ids.size(), mine.size());
    for (std::size_t i = 0; i < t.detections[k].ids.size(); ++i) {
      ASSERT_TRUE(mine.count(t.detections[k].ids[i]));
      worst = std::max(worst, (t.detections[k].points_px[i] - mine[t.detections[k].ids[i]]).cwiseAbs().maxCoeff());
    }
  }
  EXPECT_LE(worst, 5e-5 + 1e-9);
  EXPECT_GT(worst, 0);  // the tables carry 6 decimals: not a copy of the export
  std::vector<int> control;
  for (const auto& q : t.field) {
    if (q.control) control.push_back(q.id);
  }
  EXPECT_EQ(control, (std::vector<int>{1001, 1002, 1003, 1004}));
  // "2," ","1,…,21",0.285750,1.143047,-0.000977,0.001116,0.001116,0.001357,…" (metres).
  EXPECT_NEAR(t.field[0].xyz_mm.x(), 285.750, 1e-9);
  EXPECT_NEAR(t.field[0].xyz_mm.z(), -0.977, 1e-9);
  EXPECT_NEAR(t.field[0].sigma_mm.z(), 1.357, 1e-9);
}

TEST(PhotoModeler, PointTablesRefuseHostileRowsInOneLine) {
  const std::string t2 = FileText(kData + "/dbat_prague2016_cam_2dpts.txt");
  const std::string t3 = FileText(kData + "/dbat_prague2016_cam_3dpts.txt");
  EXPECT_EQ(PhotoModelerTableKind(t2), 2);
  EXPECT_EQ(PhotoModelerTableKind(t3), 3);
  EXPECT_EQ(PhotoModelerTableKind(FileText(kExport)), 0);
  PhotoModelerOptions opt;
  opt.image_size_px = std::pair(2272, 1704);
  const auto refused = [&](const std::string& a, const std::string& b, const PhotoModelerOptions& o, const std::string& what) {
    try {
      ParsePhotoModelerTables(a, "2d.txt", b, "3d.txt", o);
      ADD_FAILURE() << "accepted: " << what;
    } catch (const InvalidInput& e) {
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  // Line 5 of the 2-D table is its first mark "2,1,1429.187065,1456.427823,…".
  refused(WithLine(t2, 5, "2,1,nan,1456.427823,-0.126644,0.188202,0.226846,LSM Circular,Default,White, "), t3, opt,
          "'2d.txt' line 5: 'nan' is not a finite number");
  refused(WithLine(t2, 5, "5000,1,1429.187065,1456.427823,-0.126644,0.188202,0.226846,LSM Circular,Default,White, "), t3,
          opt, "'2d.txt' line 5: image point 5000 on photo 1: the 3-D table has no point 5000");
  refused(WithLine(t2, 5, "2,1,1429.187065"), t3, opt, "'2d.txt' line 5: 3 fields, the header has 11");
  refused(t2, WithLine(t3, 6, FirstLines(t3, 5).substr(FirstLines(t3, 4).size())), opt, "'3d.txt' line 6: point 2 appears twice");
  refused(t2, WithLine(t3, 1, "Project Units: furlongs"), opt, "'3d.txt' line 1: project units 'furlongs'");
  refused(t2, t3, {}, "'2d.txt': the point table holds no image size");
  refused(t2, "x\n", opt, "'3d.txt' line 1: no header line 'Id,…'");
}

// Fuzz-like: 600 mutants of the export, the tables and a control file (a line cut, dropped or
// repeated; a number replaced by NaN, 1e999, -1, 1e12, a word or nothing; the file cut at a byte):
// each is read or refused with InvalidInput in one line, never another exception.
TEST(PhotoModeler, MutantsAreReadOrRefusedInOneLine) {
  const std::string exp = FileText(kExport);
  const std::string t2 = FileText(kData + "/dbat_prague2016_cam_2dpts.txt");
  const std::string t3 = FileText(kData + "/dbat_prague2016_cam_3dpts.txt");
  const std::string cp = FileText(kControl);
  std::mt19937 rng(26);
  const char* words[] = {"nan", "1e999", "-1", "1e12", "x", "", "0", "2.5"};
  const auto mutate = [&](const std::string& text) {
    std::vector<std::string> lines;
    std::istringstream in(text);
    for (std::string l; std::getline(in, l);) lines.push_back(l);
    const std::size_t n = std::uniform_int_distribution<std::size_t>(0, lines.size() - 1)(rng);
    switch (rng() % 5) {
      case 0: lines[n] = lines[n].substr(0, lines[n].size() / 2); break;
      case 1: lines.erase(lines.begin() + static_cast<std::ptrdiff_t>(n)); break;
      case 2: lines.insert(lines.begin() + static_cast<std::ptrdiff_t>(n), lines[n]); break;
      case 3: {  // one number (or word) of the line replaced
        std::istringstream ls(lines[n]);
        std::vector<std::string> w;
        for (std::string x; ls >> x;) w.push_back(x);
        if (!w.empty()) w[rng() % w.size()] = words[rng() % 8];
        std::string joined;
        for (const auto& x : w) joined += x + " ";
        lines[n] = joined;
        break;
      }
      default: {
        std::string out;
        for (const auto& l : lines) out += l + "\n";
        return out.substr(0, rng() % (out.size() + 1));
      }
    }
    std::string out;
    for (const auto& l : lines) out += l + "\n";
    return out;
  };
  int read = 0, refused = 0;
  const auto check = [&](const std::function<void()>& f) {
    try {
      f();
      ++read;
    } catch (const InvalidInput& e) {
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
      ++refused;
    }
  };
  PhotoModelerOptions opt;
  opt.image_size_px = std::pair(2272, 1704);
  for (int i = 0; i < 200; ++i) {
    check([&] { ParsePhotoModelerExport(mutate(exp), "pm.txt"); });
    check([&] { ParsePhotoModelerTables(mutate(t2), "2d.txt", i % 2 ? t3 : mutate(t3), "3d.txt", opt); });
    check([&] {
      PhotoModelerProject p = ParsePhotoModelerExport(exp, "pm.txt");
      ApplyControlPoints(ParseDbatControlPoints(mutate(cp), "c.txt"), &p);
    });
  }
  EXPECT_EQ(read + refused, 600);
  EXPECT_GT(refused, 100);  // the mutants do reach the checks
}

}  // namespace
}  // namespace porthole::interop
