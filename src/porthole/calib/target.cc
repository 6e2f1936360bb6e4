#include "porthole/calib/target.h"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>

#include "porthole/coded/sheet.h"
#include "porthole/core/error.h"
#include "porthole/core/input.h"

namespace porthole::calib {
namespace {

std::vector<std::string> Split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::size_t start = 0;
  for (std::size_t i = 0; i <= s.size(); ++i) {
    if (i == s.size() || s[i] == sep) {
      out.push_back(s.substr(start, i - start));
      start = i + 1;
    }
  }
  return out;
}

double ParseNumber(const std::string& s, const std::string& field, const std::string& what) {
  double v = 0;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || ptr != s.data() + s.size() || !(v > 0)) {
    throw InvalidInput(field, fmt::format("{} must be a number > 0, got '{}'", what, s));
  }
  return v;
}

TargetSpec ParseCoded(const std::vector<std::string>& parts, const std::string& field) {
  if (parts.size() < 3 || parts.size() > 4) {
    throw InvalidInput(field, "expected coded:BITS:RADIUS_MM[:PROFILE] (BITS 12 or 14, PROFILE aicon or metashape)");
  }
  TargetSpec t;
  t.kind = TargetKind::kCoded;
  const double bits = ParseNumber(parts[1], field, "BITS");
  if (bits != 12 && bits != 14) throw InvalidInput(field, "BITS must be 12 or 14, got '" + parts[1] + "'");
  t.code_bits = static_cast<int>(bits);
  t.dot_radius_mm = ParseNumber(parts[2], field, "RADIUS_MM (the dot's radius)");
  t.code_profile = coded::ProfileName(coded::ParseProfile(parts.size() == 4 ? parts[3] : "aicon", field));
  try {
    const coded::SheetLayout l = CodedSheet(t);
    t.cols = l.cols;
    t.rows = l.rows;
    t.spacing_mm = l.pitch_mm;
  } catch (const InvalidInput& e) {
    throw InvalidInput(field, std::string("no default sheet for it: ") + e.what());
  }
  return t;
}

}  // namespace

int TargetSpec::PointCols() const { return kind == TargetKind::kCharuco ? cols - 1 : cols; }
int TargetSpec::PointRows() const { return kind == TargetKind::kCharuco ? rows - 1 : rows; }
int TargetSpec::NumPoints() const {
  if (kind == TargetKind::kCoded) {
    int last = 0;
    for (const auto& p : field.empty() ? CodedSheet(*this).targets : field) last = std::max(last, p.id);
    return last + 1;
  }
  return PointCols() * PointRows();
}

bool TargetSpec::HasPoint(int id) const {
  if (id < 0 || id >= NumPoints()) return false;
  if (kind != TargetKind::kCoded) return true;
  const auto& pts = field.empty() ? CodedSheet(*this).targets : field;
  return std::any_of(pts.begin(), pts.end(), [id](const coded::PlacedTarget& p) { return p.id == id; });
}

std::string TargetSpec::ToString() const {
  switch (kind) {
    case TargetKind::kChessboard:
      return fmt::format("chessboard:{}x{}:{:g}", cols, rows, spacing_mm);
    case TargetKind::kCharuco:
      return fmt::format("charuco:{}x{}:{:g}:{:g}:{}", cols, rows, spacing_mm, marker_mm,
                         dictionary);
    case TargetKind::kCircles:
      return fmt::format("circles:{}x{}:{:g}", cols, rows, spacing_mm);
    case TargetKind::kAsymmetricCircles:
      return fmt::format("acircles:{}x{}:{:g}", cols, rows, spacing_mm);
    case TargetKind::kCoded:
      return fmt::format("coded:{}:{:g}:{}", code_bits, dot_radius_mm, code_profile);
  }
  return "";
}

TargetSpec ParseTarget(const std::string& spec, const std::string& field) {
  const auto parts = Split(spec, ':');
  const std::string usage =
      "expected chessboard:COLSxROWS:SQUARE_MM, charuco:SQXxSQY:SQUARE_MM:MARKER_MM[:DICT], "
      "circles:COLSxROWS:SPACING_MM, acircles:COLSxROWS:SPACING_MM or coded:BITS:RADIUS_MM[:PROFILE]";
  if (!parts.empty() && parts[0] == "coded") return ParseCoded(parts, field);
  if (parts.size() < 3) throw InvalidInput(field, usage + ", got '" + spec + "'");
  TargetSpec t;
  const std::string& kind = parts[0];
  std::size_t expected = 3;
  if (kind == "chessboard") {
    t.kind = TargetKind::kChessboard;
  } else if (kind == "charuco") {
    t.kind = TargetKind::kCharuco;
    expected = parts.size() == 5 ? 5 : 4;
  } else if (kind == "circles") {
    t.kind = TargetKind::kCircles;
  } else if (kind == "acircles") {
    t.kind = TargetKind::kAsymmetricCircles;
  } else {
    throw InvalidInput(field, usage + ", got '" + spec + "'");
  }
  if (parts.size() != expected) throw InvalidInput(field, usage + ", got '" + spec + "'");
  const auto dims = Split(parts[1], 'x');
  if (dims.size() != 2) throw InvalidInput(field, "size must be COLSxROWS, got '" + parts[1] + "'");
  const double cols = ParseNumber(dims[0], field, "COLS");
  const double rows = ParseNumber(dims[1], field, "ROWS");
  if (cols != std::floor(cols) || rows != std::floor(rows) || cols > 1000 || rows > 1000) {
    throw InvalidInput(field, "COLS and ROWS must be whole numbers <= 1000");
  }
  t.cols = static_cast<int>(cols);
  t.rows = static_cast<int>(rows);
  t.spacing_mm = ParseNumber(parts[2], field, "the spacing (mm)");
  if (t.kind == TargetKind::kCharuco) {
    t.marker_mm = ParseNumber(parts[3], field, "MARKER_MM");
    if (!(t.marker_mm < t.spacing_mm)) throw InvalidInput(field, "MARKER_MM must be < SQUARE_MM");
    t.dictionary = expected == 5 ? parts[4] : "DICT_4X4_50";
  }
  if (t.PointCols() < 2 || t.PointRows() < 2) {
    throw InvalidInput(field, "the target needs at least 2x2 points");
  }
  return t;
}

std::vector<Eigen::Vector3d> TargetPoints(const TargetSpec& t) {
  std::vector<Eigen::Vector3d> pts;
  if (t.kind == TargetKind::kCoded) {  // indexed by target ID; id 0 (no target) at the origin
    pts.assign(t.NumPoints(), Eigen::Vector3d::Zero());
    for (const auto& p : t.field.empty() ? CodedSheet(t).targets : t.field) pts[p.id] = p.xyz_mm;
    return pts;
  }
  pts.reserve(t.NumPoints());
  const double s = t.spacing_mm;
  for (int i = 0; i < t.PointRows(); ++i) {
    for (int j = 0; j < t.PointCols(); ++j) {
      // ChArUco corners start one square in from the board corner (OpenCV's chessboardCorners).
      const double off = t.kind == TargetKind::kCharuco ? s : 0.0;
      const double x = t.kind == TargetKind::kAsymmetricCircles ? (2 * j + i % 2) * s : j * s + off;
      pts.emplace_back(x, i * s + off, 0.0);
    }
  }
  return pts;
}

std::vector<Eigen::Vector3d> TargetNormals(const TargetSpec& t) {
  std::vector<Eigen::Vector3d> n(t.NumPoints(), -Eigen::Vector3d::UnitZ());
  for (const auto& p : t.field) n[p.id] = p.normal;  // a sheet's targets all face −Z
  return n;
}

std::map<int, Eigen::Vector3d> FieldControl(const TargetSpec& t) {
  std::map<int, Eigen::Vector3d> control;
  for (const auto& p : t.field) {
    if (p.control_sigma_mm) control[p.id] = *p.control_sigma_mm;
  }
  return control;
}

std::vector<bool> TargetPointMask(const TargetSpec& t) {
  if (t.kind != TargetKind::kCoded) return std::vector<bool>(t.NumPoints(), true);
  const auto& pts = t.field.empty() ? CodedSheet(t).targets : t.field;
  int last = 0;
  for (const auto& p : pts) last = std::max(last, p.id);
  std::vector<bool> mask(last + 1, false);
  for (const auto& p : pts) mask[p.id] = true;
  return mask;
}

coded::SheetLayout CodedSheet(const TargetSpec& t) {
  coded::SheetOptions o;
  o.bits = t.code_bits;
  o.profile = coded::ParseProfile(t.code_profile, "target");
  o.radius_mm = t.dot_radius_mm;
  return coded::LayoutSheet(o);
}

void LoadTargetField(const std::string& path, TargetSpec* target, const std::string& field) {
  if (target->kind != TargetKind::kCoded) {
    throw InvalidInput(field, "a target field holds coded targets: give `target` coded:BITS:RADIUS_MM[:PROFILE]");
  }
  const std::string text = ReadInputFile(path, field, kMaxTextFileBytes);
  target->field = coded::ParseField(text, fmt::format("{} ({})", field, path));
  target->field_file = path;
}

}  // namespace porthole::calib
