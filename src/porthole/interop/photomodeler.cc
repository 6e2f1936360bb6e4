// PhotoModeler's text export and DBAT's control-point file (photomodeler.h).
#include "porthole/interop/photomodeler.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "porthole/core/error.h"
#include "porthole/core/input.h"
#include "porthole/interop/text.h"

namespace porthole::interop {
namespace {

constexpr double kMmPerMetre = 1000.0;
constexpr int kMaxId = 1000000;  // the target-field file's ID range (coded/sheet.h ParseField)

// The export's lines, one at a time, with the file name and line number for messages.
class Lines {
 public:
  Lines(const std::string& text, std::string origin, std::string field)
      : in_(text), origin_(std::move(origin)), field_(std::move(field)) {}

  // The next line (without its line end); false at the end of the text.
  bool Next(std::string* line) {
    if (!std::getline(in_, *line)) return false;
    ++n_;
    while (!line->empty() && line->back() == '\r') line->pop_back();  // the tables end lines with \r\r\n
    return true;
  }
  [[noreturn]] void Fail(const std::string& what) const {
    if (n_ == 0) throw InvalidInput(field_, fmt::format("'{}': {}", origin_, what));
    throw InvalidInput(field_, fmt::format("'{}' line {}: {}", origin_, n_, what));
  }
  int number() const { return n_; }
  void At(int n) { n_ = n; }  // messages about a line read earlier (a table's rows)

 private:
  std::istringstream in_;
  std::string origin_, field_;
  int n_ = 0;
};

// The whitespace-separated numbers of `line`, each finite; refuses any other word.
std::vector<double> Numbers(const std::string& line, const Lines& lines) {
  std::istringstream ls(line);
  std::vector<double> v;
  for (std::string w; ls >> w;) {
    double x = 0;
    std::size_t used = 0;
    try {
      x = std::stod(w, &used);
    } catch (const std::out_of_range&) {  // 1e999: a number, not a finite one
      x = HUGE_VAL, used = w.size();
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != w.size()) lines.Fail(fmt::format("'{}' is not a number", w.substr(0, 40)));
    if (!std::isfinite(x)) lines.Fail(fmt::format("'{}' is not a finite number", w.substr(0, 40)));
    v.push_back(x);
  }
  return v;
}

bool Blank(const std::string& line) { return Trim(line).empty(); }

// A whole number in [lo, hi] (an id or a photo number).
int WholeNumber(double x, int lo, int hi, const char* what, const Lines& lines) {
  if (x != std::floor(x) || x < lo || x > hi) lines.Fail(fmt::format("{} {:g} must be a whole number in [{}, {}]", what, x, lo, hi));
  return static_cast<int>(x);
}

// The next line as exactly `n` numbers (or at least `n` when `at_least`).
std::vector<double> NumberLine(Lines& lines, std::size_t n, const char* what, bool at_least = false) {
  std::string line;
  if (!lines.Next(&line)) lines.Fail(fmt::format("the file ends before {}", what));
  std::vector<double> v = Numbers(line, lines);
  if (at_least ? v.size() < n : v.size() != n) {
    lines.Fail(fmt::format("{}: expected {}{} numbers, the line has {}", what, at_least ? "at least " : "", n, v.size()));
  }
  return v;
}

// One photo block after its name line: five lines opening with N (the covariance line may be blank).
void ReadPhotoBlock(int photo, Lines& lines) {
  const struct {
    const char* what;
    std::size_t n;
    bool may_be_blank;
  } rows[] = {{"the exterior orientation (N X Y Z kappa phi omega)", 7, false},
              {"its deviations (N and 6 numbers)", 7, false},
              {"its covariances (N and 3 numbers, or a blank line)", 4, true},
              {"the photo's camera (N c xp yp w h K1 K2 K3 P1 P2)", 11, false},
              {"its deviations (N and 10 numbers)", 11, false}};
  for (const auto& r : rows) {
    std::string line;
    if (!lines.Next(&line)) lines.Fail(fmt::format("the file ends inside photo {} (before {})", photo, r.what));
    if (r.may_be_blank && Blank(line)) continue;
    const std::vector<double> v = Numbers(line, lines);
    if (v.size() != r.n) lines.Fail(fmt::format("photo {}: {}: the line has {} numbers", photo, r.what, v.size()));
    if (v[0] != photo) lines.Fail(fmt::format("photo {}: the line opens with {:g}, not the photo's number", photo, v[0]));
  }
}

// "id X Y Z sX sY sZ" lines up to a blank line or the end (metres → mm).
std::vector<FieldPoint> ReadPointBlock(Lines& lines, const char* what, bool control) {
  std::vector<FieldPoint> out;
  std::set<int> seen;
  for (std::string line; lines.Next(&line);) {
    if (Blank(line)) break;
    const std::vector<double> v = Numbers(line, lines);
    if (v.size() != 7) lines.Fail(fmt::format("{}: expected 'id X Y Z sX sY sZ', the line has {} numbers", what, v.size()));
    FieldPoint p;
    p.id = WholeNumber(v[0], 1, kMaxId, "the point id", lines);
    if (!seen.insert(p.id).second) lines.Fail(fmt::format("{}: point {} appears twice", what, p.id));
    p.xyz_mm = Eigen::Vector3d(v[1], v[2], v[3]) * kMmPerMetre;
    p.sigma_mm = Eigen::Vector3d(v[4], v[5], v[6]) * kMmPerMetre;
    if ((p.sigma_mm.array() < 0).any()) lines.Fail(fmt::format("{}: point {}: a negative deviation", what, p.id));
    p.control = control;
    out.push_back(p);
  }
  return out;
}

}  // namespace

PhotoModelerProject ParsePhotoModelerExport(const std::string& text, const std::string& origin,
                                            const PhotoModelerOptions& options, const std::string& field) {
  Lines lines(text, origin, field);
  PhotoModelerProject p;
  if (!lines.Next(&p.title)) lines.Fail("the file is empty (expected PhotoModeler's text export)");
  p.title = Trim(p.title);

  // Line 2: tolerance, iterations [, width, height].
  const std::vector<double> l2 = NumberLine(lines, 2, "line 2 (tolerance, iterations[, width_px, height_px])", true);
  if (l2.size() != 2 && l2.size() != 4) {
    lines.Fail(fmt::format("line 2: expected 'tolerance iterations [width_px height_px]', the line has {} numbers", l2.size()));
  }
  if (options.image_size_px) {
    std::tie(p.width_px, p.height_px) = *options.image_size_px;
  } else if (l2.size() == 4) {
    p.width_px = WholeNumber(l2[2], 1, 1000000, "the image width", lines);
    p.height_px = WholeNumber(l2[3], 1, 1000000, "the image height", lines);
  } else {
    lines.Fail("line 2 holds no image size: append 'width_px height_px' to it (as DBAT's manual says) or give `image_size` (WIDTHxHEIGHT)");
  }
  if (!(p.width_px >= 1 && p.height_px >= 1)) lines.Fail("`image_size` must be positive");

  NumberLine(lines, 9, "line 3 (9 default deviations)");
  const std::vector<double> cam = NumberLine(lines, 10, "line 4 (the camera: c xp yp format_w format_h K1 K2 K3 P1 P2)");
  p.camera = {cam[0], cam[1], cam[2], cam[3], cam[4], cam[5], cam[6], cam[7], cam[8], cam[9]};
  if (!(p.camera.c_mm > 0 && p.camera.format_w_mm > 0 && p.camera.format_h_mm > 0)) {
    lines.Fail("the camera's c, format width and height must be positive");
  }
  NumberLine(lines, 10, "line 5 (the camera's 10 deviations)");

  // Photos: "N name" then five lines, until a blank line.
  std::map<int, std::size_t> photo_index;
  for (std::string line;;) {
    if (!lines.Next(&line)) lines.Fail("the file ends in the photo list (expected a blank line, then the points)");
    if (Blank(line)) break;
    std::istringstream ls(line);
    std::string number;
    ls >> number;
    const std::vector<double> n = Numbers(number, lines);
    const int photo = WholeNumber(n.at(0), 0, 1000000, "the photo number", lines);
    std::string name;
    std::getline(ls, name);
    name = Trim(name);
    if (name.empty()) lines.Fail(fmt::format("photo {} has no file name", photo));
    if (!photo_index.emplace(photo, p.detections.size()).second) lines.Fail(fmt::format("photo {} appears twice", photo));
    if (p.detections.size() >= kMaxImagesPerSet) lines.Fail(fmt::format("more than {} photos", kMaxImagesPerSet));
    calib::ImageDetections d;
    d.image = name;
    d.width_px = p.width_px;
    d.height_px = p.height_px;
    p.detections.push_back(d);
    p.photo_numbers.push_back(photo);
    ReadPhotoBlock(photo, lines);
  }
  if (p.detections.empty()) lines.Fail("the export holds no photo");

  std::vector<FieldPoint> control = ReadPointBlock(lines, "control points", true);
  p.field = ReadPointBlock(lines, "object points", false);
  for (const auto& c : control) {  // a control point is an object point held to its given position
    const auto it = std::find_if(p.field.begin(), p.field.end(), [&](const FieldPoint& q) { return q.id == c.id; });
    if (it == p.field.end()) {
      p.field.push_back(c);
    } else {
      *it = c;
    }
  }
  std::sort(p.field.begin(), p.field.end(), [](const FieldPoint& a, const FieldPoint& b) { return a.id < b.id; });
  if (p.field.empty()) lines.Fail("the export holds no object point");
  std::set<int> field_ids;
  for (const auto& q : p.field) field_ids.insert(q.id);

  // Marks: "N id x y sx sy", until a blank line or the end.
  std::set<std::pair<int, int>> marked;
  for (std::string line; lines.Next(&line);) {
    if (Blank(line)) break;
    const std::vector<double> v = Numbers(line, lines);
    if (v.size() != 6) lines.Fail(fmt::format("image point: expected 'photo id x_px y_px sx sy', the line has {} numbers", v.size()));
    const int photo = WholeNumber(v[0], 0, 1000000, "the photo number", lines);
    const int id = WholeNumber(v[1], 1, kMaxId, "the point id", lines);
    const auto ph = photo_index.find(photo);
    if (ph == photo_index.end()) lines.Fail(fmt::format("image point {} on photo {}, which the photo list does not hold", id, photo));
    if (!field_ids.count(id)) lines.Fail(fmt::format("image point {} on photo {}: no object point has that id", id, photo));
    if (!marked.emplace(photo, id).second) lines.Fail(fmt::format("point {} is marked twice on photo {}", id, photo));
    if (v[2] < 0 || v[3] < 0 || v[2] > p.width_px || v[3] > p.height_px) {
      lines.Fail(fmt::format("image point {} on photo {} at ({:g}, {:g}) px lies outside the {}x{} image", id, photo, v[2], v[3],
                             p.width_px, p.height_px));
    }
    calib::ImageDetections& d = p.detections[ph->second];
    if (d.ids.size() >= kMaxPointsPerImage) lines.Fail(fmt::format("photo {} holds more than {} points", photo, kMaxPointsPerImage));
    d.ids.push_back(id);
    d.points_px.emplace_back(v[2] - 0.5, v[3] - 0.5);  // corner origin → centre of the top-left pixel at 0
    if (++p.n_marks > static_cast<int>(kMaxPointsPerSet)) lines.Fail(fmt::format("more than {} image points", kMaxPointsPerSet));
  }
  if (p.n_marks == 0) lines.Fail("the export holds no image point (the marks after the object points)");
  return p;
}

PhotoModelerProject ReadPhotoModelerExport(const std::string& path, const PhotoModelerOptions& options,
                                           const std::string& field) {
  return ParsePhotoModelerExport(ReadInputFile(path, field, kMaxJsonFileBytes), path, options, field);
}

std::vector<FieldPoint> ParseDbatControlPoints(const std::string& text, const std::string& origin, const std::string& field) {
  Lines lines(text, origin, field);
  std::vector<FieldPoint> out;
  std::set<int> seen;
  for (std::string line; lines.Next(&line);) {
    const std::string t = Trim(line);
    if (t.empty() || t[0] == '#') continue;
    std::vector<std::string> parts;
    std::istringstream ls(t);
    for (std::string part; std::getline(ls, part, ',');) parts.push_back(Trim(part));
    if (parts.size() < 5 || parts.size() > 8) {
      lines.Fail(fmt::format("expected 'id, name, X, Y, Z[, sigma[, sigma[, sigma]]]' (a full covariance is not read), "
                             "the line has {} fields", parts.size()));
    }
    std::vector<double> v;
    for (std::size_t i = 0; i < parts.size(); ++i) {
      if (i == 1) continue;  // the name
      const std::vector<double> x = Numbers(parts[i], lines);
      if (x.size() != 1) lines.Fail(fmt::format("field {} '{}' is not one number", i + 1, parts[i].substr(0, 40)));
      v.push_back(x[0]);
    }
    FieldPoint p;
    p.id = WholeNumber(v[0], 1, kMaxId, "the point id", lines);
    if (!seen.insert(p.id).second) lines.Fail(fmt::format("control point {} appears twice", p.id));
    p.name = parts[1];
    p.xyz_mm = Eigen::Vector3d(v[1], v[2], v[3]) * kMmPerMetre;
    const std::size_t ns = v.size() - 4;  // 0: fixed, 1: all axes, 2: xy and z, 3: each axis
    p.sigma_mm = ns == 0   ? Eigen::Vector3d::Zero()
                 : ns == 1 ? Eigen::Vector3d::Constant(v[4])
                 : ns == 2 ? Eigen::Vector3d(v[4], v[4], v[5])
                           : Eigen::Vector3d(v[4], v[5], v[6]);
    p.sigma_mm *= kMmPerMetre;
    if ((p.sigma_mm.array() < 0).any()) lines.Fail(fmt::format("control point {}: a negative sigma", p.id));
    p.control = true;
    out.push_back(p);
  }
  if (out.empty()) lines.Fail("holds no control point");
  return out;
}

std::vector<FieldPoint> ReadDbatControlPoints(const std::string& path, const std::string& field) {
  return ParseDbatControlPoints(ReadInputFile(path, field), path, field);
}

void ApplyControlPoints(const std::vector<FieldPoint>& control, PhotoModelerProject* project, const std::string& field) {
  for (const FieldPoint& c : control) {
    const auto it = std::find_if(project->field.begin(), project->field.end(), [&](const FieldPoint& q) { return q.id == c.id; });
    if (it == project->field.end()) {
      throw InvalidInput(field, fmt::format("control point {} ('{}') is no point of the project", c.id, c.name));
    }
    *it = c;
  }
}

BrownFromPhotoModeler BrownCamera(const PhotoModelerProject& project) {
  const PhotoModelerCamera& c = project.camera;
  BrownFromPhotoModeler b;
  b.pixel_pitch_mm = c.format_h_mm / project.height_px;
  b.c_mm = c.c_mm;
  b.x0_mm = c.xp_mm - c.format_w_mm / 2;
  b.y0_mm = c.format_h_mm / 2 - c.yp_mm;
  b.K1 = c.K1, b.K2 = c.K2, b.K3 = c.K3, b.P1 = c.P1, b.P2 = c.P2;
  return b;
}

std::string FieldFileText(const PhotoModelerProject& project, const std::string& source) {
  std::string s = source;
  std::replace_if(s.begin(), s.end(), [](char ch) { return ch == '\n' || ch == '\r'; }, '?');
  int n_control = 0;
  for (const auto& q : project.field) n_control += q.control;
  std::string out = fmt::format(
      "# porthole target field from PhotoModeler's text export {}\n"
      "# {} points ({} control), metres x 1000; after '#': sigma_mm sx sy sz as given, 'control' for a control point\n"
      "# id x_mm y_mm z_mm\n",
      s, project.field.size(), n_control);
  for (const auto& q : project.field) {
    out += fmt::format("{} {:.6f} {:.6f} {:.6f}", q.id, q.xyz_mm.x(), q.xyz_mm.y(), q.xyz_mm.z());
    std::string note;
    if (q.sigma_mm.allFinite()) note += fmt::format(" sigma_mm {:.6g} {:.6g} {:.6g}", q.sigma_mm.x(), q.sigma_mm.y(), q.sigma_mm.z());
    if (q.control) note += " control";
    out += note.empty() ? "\n" : "  #" + note + "\n";
  }
  return out;
}

// ---- PhotoModeler's point tables (CSV) ----

namespace {

// The comma-separated fields of `line`, a quoted field ("1,2,3") as one, without its quotes.
std::vector<std::string> CsvFields(const std::string& line) {
  std::vector<std::string> out(1);
  bool quoted = false;
  for (const char ch : line) {
    if (ch == '"') {
      quoted = !quoted;
    } else if (ch == ',' && !quoted) {
      out.emplace_back();
    } else {
      out.back() += ch;
    }
  }
  for (auto& f : out) f = Trim(f);
  return out;
}

// mm per project unit from the table's "Project Units: …" line; metres when it has none.
double MmPerUnit(const std::string& unit, const Lines& lines) {
  const std::string u = Lower(Trim(unit));
  if (u == "meters" || u == "metres" || u == "m") return 1000;
  if (u == "centimeters" || u == "centimetres" || u == "cm") return 10;
  if (u == "millimeters" || u == "millimetres" || u == "mm") return 1;
  if (u == "feet" || u == "ft") return 304.8;
  if (u == "inches" || u == "in") return 25.4;
  lines.Fail(fmt::format("project units '{}': expected meters, centimeters, millimeters, feet or inches", u.substr(0, 40)));
}

// One table: its project unit, its header (the first line opening with `first_column`) and its data
// lines (those opening with a digit, as DBAT's loadpm2dtbl/loadpm3dtbl take them).
struct Table {
  double mm_per_unit = kMmPerMetre;
  std::vector<std::string> header;
  std::vector<std::pair<int, std::vector<std::string>>> rows;  // line number, fields
};

Table ReadTable(Lines& lines, const std::string& first_column) {
  Table t;
  for (std::string line; lines.Next(&line);) {
    const std::string s = Trim(line);
    if (s.rfind("Project Units:", 0) == 0) t.mm_per_unit = MmPerUnit(s.substr(14), lines);
    if (s.rfind(first_column + ",", 0) == 0 && t.header.empty()) t.header = CsvFields(s);
    if (s.empty() || !std::isdigit(static_cast<unsigned char>(s[0]))) continue;
    if (t.header.empty()) lines.Fail(fmt::format("a data line before the header ('{},…')", first_column));
    std::vector<std::string> f = CsvFields(s);
    if (f.size() != t.header.size()) lines.Fail(fmt::format("{} fields, the header has {}", f.size(), t.header.size()));
    t.rows.emplace_back(lines.number(), std::move(f));
  }
  if (t.header.empty()) lines.Fail(fmt::format("no header line '{},…' (expected PhotoModeler's point table)", first_column));
  return t;
}

// The column named `name` (the first whose header opens with it).
std::size_t Column(const Table& t, const std::string& name, const Lines& lines) {
  for (std::size_t i = 0; i < t.header.size(); ++i) {
    if (t.header[i].rfind(name, 0) == 0) return i;
  }
  lines.Fail(fmt::format("the header has no column '{}'", name));
}

}  // namespace

int PhotoModelerTableKind(const std::string& text) {
  std::istringstream in(text);
  std::string line;
  for (int i = 0; i < 20 && std::getline(in, line); ++i) {
    if (line.rfind("Object Point ID,Photo #", 0) == 0) return 2;
    if (line.rfind("Id,Name,", 0) == 0) return 3;
  }
  return 0;
}

PhotoModelerProject ParsePhotoModelerTables(const std::string& text_2d, const std::string& origin_2d,
                                            const std::string& text_3d, const std::string& origin_3d,
                                            const PhotoModelerOptions& options, const std::string& field) {
  PhotoModelerProject p;
  Lines l3(text_3d, origin_3d, field);
  const Table t3 = ReadTable(l3, "Id");
  const std::size_t cx = Column(t3, "X (", l3), cy = Column(t3, "Y (", l3), cz = Column(t3, "Z (", l3);
  const std::size_t sx = Column(t3, "X Precision", l3), sy = Column(t3, "Y Precision", l3), sz = Column(t3, "Z Precision", l3);
  const std::size_t ctype = Column(t3, "Type", l3), cname = Column(t3, "Name", l3);
  std::set<int> ids;
  for (const auto& [n, f] : t3.rows) {
    l3.At(n);
    const auto fail = [&, n = n](const std::string& what) {
      throw InvalidInput(field, fmt::format("'{}' line {}: {}", origin_3d, n, what));
    };
    FieldPoint q;
    const std::vector<double> id = Numbers(f[0], l3);
    if (id.size() != 1 || id[0] != std::floor(id[0]) || id[0] < 1 || id[0] > kMaxId) fail("the point id must be a whole number in [1, 1000000]");
    q.id = static_cast<int>(id[0]);
    if (!ids.insert(q.id).second) fail(fmt::format("point {} appears twice", q.id));
    double v[6];
    const std::size_t col[6] = {cx, cy, cz, sx, sy, sz};
    for (int k = 0; k < 6; ++k) {
      const std::vector<double> x = Numbers(f[col[k]], l3);
      if (x.size() != 1) fail(fmt::format("{} '{}' is not one number", t3.header[col[k]], f[col[k]].substr(0, 40)));
      v[k] = x[0];
    }
    q.xyz_mm = Eigen::Vector3d(v[0], v[1], v[2]) * t3.mm_per_unit;
    q.sigma_mm = Eigen::Vector3d(v[3], v[4], v[5]) * t3.mm_per_unit;
    if ((q.sigma_mm.array() < 0).any()) fail(fmt::format("point {}: a negative precision", q.id));
    q.control = Lower(f[ctype]) == "control";
    q.name = f[cname];
    p.field.push_back(q);
  }
  if (p.field.empty()) l3.Fail("the table holds no point");
  std::sort(p.field.begin(), p.field.end(), [](const FieldPoint& a, const FieldPoint& b) { return a.id < b.id; });

  Lines l2(text_2d, origin_2d, field);
  if (!options.image_size_px) l2.Fail("the point table holds no image size: give `image_size` (WIDTHxHEIGHT)");
  const Table t2 = ReadTable(l2, "Object Point ID");
  const std::size_t cphoto = Column(t2, "Photo #", l2), cu = Column(t2, "X (pixels)", l2), cv = Column(t2, "Y (pixels)", l2);
  std::tie(p.width_px, p.height_px) = *options.image_size_px;
  std::map<int, std::size_t> photo_index;  // photo number → detection, in order of first appearance sorted below
  std::map<int, std::vector<std::pair<int, Eigen::Vector2d>>> marks;
  std::set<std::pair<int, int>> marked;
  for (const auto& [n, f] : t2.rows) {
    l2.At(n);
    const auto fail = [&, n = n](const std::string& what) {
      throw InvalidInput(field, fmt::format("'{}' line {}: {}", origin_2d, n, what));
    };
    double v[4];
    const std::size_t col[4] = {0, cphoto, cu, cv};
    for (int k = 0; k < 4; ++k) {
      const std::vector<double> x = Numbers(f[col[k]], l2);
      if (x.size() != 1) fail(fmt::format("{} '{}' is not one number", t2.header[col[k]], f[col[k]].substr(0, 40)));
      v[k] = x[0];
    }
    if (v[0] != std::floor(v[0]) || v[0] < 1 || v[0] > kMaxId) fail("the point id must be a whole number in [1, 1000000]");
    if (v[1] != std::floor(v[1]) || v[1] < 1 || v[1] > 1000000) fail("the photo number must be a whole number >= 1");
    const int id = static_cast<int>(v[0]), photo = static_cast<int>(v[1]);
    if (!ids.count(id)) fail(fmt::format("image point {} on photo {}: the 3-D table has no point {}", id, photo, id));
    if (!marked.emplace(photo, id).second) fail(fmt::format("point {} is marked twice on photo {}", id, photo));
    if (v[2] < 0 || v[3] < 0 || v[2] > p.width_px || v[3] > p.height_px) {
      fail(fmt::format("image point {} on photo {} at ({:g}, {:g}) px lies outside the {}x{} image", id, photo, v[2], v[3],
                       p.width_px, p.height_px));
    }
    if (marks[photo].size() >= kMaxPointsPerImage) fail(fmt::format("photo {} holds more than {} points", photo, kMaxPointsPerImage));
    marks[photo].emplace_back(id, Eigen::Vector2d(v[2] - 0.5, v[3] - 0.5));  // corner origin, as the export
    if (++p.n_marks > static_cast<int>(kMaxPointsPerSet)) fail(fmt::format("more than {} image points", kMaxPointsPerSet));
    if (marks.size() > kMaxImagesPerSet) fail(fmt::format("more than {} photos", kMaxImagesPerSet));
  }
  if (p.n_marks == 0) l2.Fail("the table holds no image point");
  for (const auto& [photo, list] : marks) {  // photos in number order, named by their number
    calib::ImageDetections d;
    d.image = fmt::format("photo {}", photo);
    d.width_px = p.width_px;
    d.height_px = p.height_px;
    for (const auto& [id, uv] : list) d.ids.push_back(id), d.points_px.push_back(uv);
    p.detections.push_back(std::move(d));
    p.photo_numbers.push_back(photo);
  }
  return p;
}

PhotoModelerProject ReadPhotoModelerTables(const std::string& path_2d, const std::string& path_3d,
                                           const PhotoModelerOptions& options, const std::string& field) {
  return ParsePhotoModelerTables(ReadInputFile(path_2d, field, kMaxJsonFileBytes), path_2d,
                                 ReadInputFile(path_3d, field, kMaxJsonFileBytes), path_3d, options, field);
}

}  // namespace porthole::interop
