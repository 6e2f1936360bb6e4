#include "porthole/render/pattern.h"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <memory>
#include <numbers>
#include <optional>
#include <limits>
#include <unordered_map>
#include <algorithm>
#include <cstdint>
#include <opencv2/aruco/charuco.hpp>

#include "porthole/calib/detect.h"
#include "porthole/coded/codes.h"
#include "porthole/coded/sheet.h"
#include "porthole/core/error.h"

namespace porthole::render {
namespace {

using calib::TargetKind;
using calib::TargetSpec;

bool Inside(const Extent& e, double x, double y) {
  return x >= e.x_min && x <= e.x_max && y >= e.y_min && y <= e.y_max;
}

// ---- Chessboard: (cols + 1) × (rows + 1) squares around the cols × rows inner corners; the square
// just past the first corner along +X and +Y is black (as calib/render_board.h draws it).
Extent ChessboardExtent(const TargetSpec& t, const PatternStyle& st) {
  const double s = t.spacing_mm, m = st.margin * s;
  return {-s - m, -s - m, t.cols * s + m, t.rows * s + m};
}
Reflectance ChessboardReflectance(const TargetSpec& t, const PatternStyle& st) {
  const Extent board = ChessboardExtent(t, st);
  const double s = t.spacing_mm;
  return [=](double x, double y) {
    if (!Inside(board, x, y)) return st.background;
    const long i = static_cast<long>(std::floor(x / s)), j = static_cast<long>(std::floor(y / s));
    if (i < -1 || j < -1 || i > t.cols - 1 || j > t.rows - 1) return st.white;  // the margin
    return ((i + j) & 1) ? st.white : st.black;
  };
}

// ---- Circle grids: black discs on white, centred on the target's points. Symmetric grid: radius
// a quarter of the spacing; asymmetric grid (nearest neighbours √2·s apart): 0.3·s.
double CircleRadius(const TargetSpec& t) { return (t.kind == TargetKind::kCircles ? 0.25 : 0.3) * t.spacing_mm; }
Extent CirclesExtent(const TargetSpec& t, const PatternStyle& st) {
  const double s = t.spacing_mm, m = st.margin * s, r = CircleRadius(t);
  const double x_last = t.kind == TargetKind::kCircles ? (t.cols - 1) * s : (2 * (t.cols - 1) + 1) * s;
  return {-r - m, -r - m, x_last + r + m, (t.rows - 1) * s + r + m};
}
Reflectance CirclesReflectance(const TargetSpec& t, const PatternStyle& st) {
  const Extent board = CirclesExtent(t, st);
  const double s = t.spacing_mm, r2 = CircleRadius(t) * CircleRadius(t);
  const bool asymmetric = t.kind == TargetKind::kAsymmetricCircles;
  return [=](double x, double y) {
    if (!Inside(board, x, y)) return st.background;
    // The nearest point of the lattice: row i, then the column of that row.
    const double i = std::clamp(std::round(y / s), 0.0, t.rows - 1.0);
    const double pitch = asymmetric ? 2 * s : s;
    for (double di : {-1.0, 0.0, 1.0}) {  // a disc of a neighbouring row may be the one nearby
      const double row = i + di;
      if (row < 0 || row > t.rows - 1) continue;
      const double sh = asymmetric ? std::fmod(row, 2.0) * s : 0.0;
      const double j = std::clamp(std::round((x - sh) / pitch), 0.0, t.cols - 1.0);
      const double dx = x - (j * pitch + sh), dy = y - row * s;
      if (dx * dx + dy * dy <= r2) return st.black;
    }
    return st.white;
  };
}

// ---- ChArUco: OpenCV's own board (cv::aruco::CharucoBoard) gives where each marker lies and its
// id, so the drawing and the detector agree by construction. Squares: cols × rows from the board
// origin; the squares holding markers are white, the others black; a marker is markerSize + 2 cells
// across (one black border cell each side), its cell (0, 0) at its first corner, rows toward its
// fourth corner, a set bit white (cv::aruco::drawMarker).
Extent CharucoExtent(const TargetSpec& t, const PatternStyle& st) {
  const double s = t.spacing_mm, m = st.margin * s;
  return {-m, -m, t.cols * s + m, t.rows * s + m};
}

struct Marker {
  Eigen::Vector2d origin, ex, ey;  // corner 0, and the edges to corners 1 and 3
  cv::Mat bits;                    // markerSize × markerSize, 1 = white
};

Reflectance CharucoReflectance(const TargetSpec& t, const PatternStyle& st) {
  const auto dict = calib::ArucoDictionary(t.dictionary);
  const int n_markers = (t.cols * t.rows) / 2;
  if (n_markers > dict->bytesList.rows) {
    throw InvalidInput("target", fmt::format("a {}x{} board needs {} markers; {} holds {}", t.cols, t.rows, n_markers,
                                               t.dictionary, dict->bytesList.rows));
  }
  const auto board = cv::aruco::CharucoBoard::create(t.cols, t.rows, static_cast<float>(t.spacing_mm),
                                                     static_cast<float>(t.marker_mm), dict);
  const double s = t.spacing_mm;
  // Markers by square (index y·cols + x), and the parity of the squares that hold them.
  auto markers = std::make_shared<std::vector<std::optional<Marker>>>(t.cols * t.rows);
  int white_parity = -1;
  for (std::size_t k = 0; k < board->objPoints.size(); ++k) {
    const auto& c = board->objPoints[k];
    Marker m;
    m.origin = Eigen::Vector2d(c[0].x, c[0].y);
    m.ex = Eigen::Vector2d(c[1].x - c[0].x, c[1].y - c[0].y);
    m.ey = Eigen::Vector2d(c[3].x - c[0].x, c[3].y - c[0].y);
    m.bits = cv::aruco::Dictionary::getBitsFromByteList(dict->bytesList.rowRange(board->ids[k], board->ids[k] + 1),
                                                        dict->markerSize);
    const Eigen::Vector2d centre = m.origin + 0.5 * (m.ex + m.ey);
    const int x = static_cast<int>(std::floor(centre.x() / s)), y = static_cast<int>(std::floor(centre.y() / s));
    PORTHOLE_CHECK(x >= 0 && y >= 0 && x < t.cols && y < t.rows);
    white_parity = (x + y) % 2;
    (*markers)[y * t.cols + x] = std::move(m);
  }
  PORTHOLE_CHECK(white_parity >= 0);
  const Extent board_extent = CharucoExtent(t, st);
  const int cells = dict->markerSize + 2;
  return [=](double x, double y) {
    if (!Inside(board_extent, x, y)) return st.background;
    const double i = std::floor(x / s), j = std::floor(y / s);
    if (i < 0 || j < 0 || i > t.cols - 1 || j > t.rows - 1) return st.white;  // the margin
    const int sq = static_cast<int>(j) * t.cols + static_cast<int>(i);
    if ((static_cast<int>(i + j)) % 2 != white_parity) return st.black;
    const auto& m = (*markers)[sq];
    if (!m) return st.white;
    const Eigen::Vector2d d = Eigen::Vector2d(x, y) - m->origin;
    const double a = d.dot(m->ex) / m->ex.squaredNorm(), b = d.dot(m->ey) / m->ey.squaredNorm();
    if (a < 0 || b < 0 || a >= 1 || b >= 1) return st.white;
    const int col = static_cast<int>(a * cells), row = static_cast<int>(b * cells);
    if (col == 0 || row == 0 || col == cells - 1 || row == cells - 1) return st.black;  // the border
    return m->bits.at<unsigned char>(row - 1, col - 1) ? st.white : st.black;
  };
}

// ---- Coded targets: the sheet `porthole target-sheet` prints with its defaults for the spec's
// bits, profile and dot radius (calib/target.h), or the spec's target field (TargetSpec::field):
// the paper is the board, a target's dot and its ring segments (coded/sheet.h: RingArcs) are the
// ink; an ID the profile has no code for (an uncoded dot of a field) is a dot without a ring. The
// IDs printed beside the targets, the scale bar and the caption are not drawn. Ink is the style's
// black, paper its white (swap them for white targets on black). A field's targets off the board's
// plane (Z != 0) are printed on plates of PlateRadiusMm at their Z (Surfaces).
struct CodedDisc {
  Eigen::Vector2d centre;
  std::optional<uint32_t> code;  // none: an uncoded dot
};

// The discs of one level in a uniform grid whose cells are at least a disc across, each disc
// registered in every cell its square overlaps: a point's disc is among its own cell's.
class DiscGrid {
 public:
  DiscGrid(std::vector<CodedDisc> discs, double radius_mm)
      : discs_(std::move(discs)), cell_(2 * radius_mm), r2_(radius_mm * radius_mm) {
    for (std::size_t k = 0; k < discs_.size(); ++k) {
      const Eigen::Vector2d& c = discs_[k].centre;
      for (long i = Cell(c.x() - radius_mm); i <= Cell(c.x() + radius_mm); ++i) {
        for (long j = Cell(c.y() - radius_mm); j <= Cell(c.y() + radius_mm); ++j) cells_[Key(i, j)].push_back(static_cast<int>(k));
      }
    }
  }
  // The disc whose centre lies within the radius of (x, y), or null.
  const CodedDisc* Find(double x, double y) const {
    const auto it = cells_.find(Key(Cell(x), Cell(y)));
    if (it == cells_.end()) return nullptr;
    for (int k : it->second) {
      const Eigen::Vector2d d = Eigen::Vector2d(x, y) - discs_[k].centre;
      if (d.squaredNorm() <= r2_) return &discs_[k];
    }
    return nullptr;
  }

 private:
  long Cell(double x) const { return static_cast<long>(std::floor(x / cell_)); }
  static std::int64_t Key(long i, long j) { return (static_cast<std::int64_t>(i) << 32) ^ (j & 0xFFFFFFFFll); }
  std::vector<CodedDisc> discs_;
  double cell_, r2_;
  std::unordered_map<std::int64_t, std::vector<int>> cells_;
};

const std::vector<coded::PlacedTarget>& CodedTargetsOf(const TargetSpec& t, coded::SheetLayout* sheet) {
  if (!t.field.empty()) return t.field;
  *sheet = calib::CodedSheet(t);
  return sheet->targets;
}

// The targets grouped by level (their Z, equal within 1e-9 mm; level 0 the board, Z = 0).
struct CodedField {
  Extent board;
  std::vector<double> z_mm;
  std::vector<std::unique_ptr<DiscGrid>> levels;  // level 0: radius r_out; others: the plates
  double r = 0, r_in = 0, r_out = 0;
  int bits = 0;
  // The ink of a target at (dx, dy) mm from its centre: black on the dot and the code's set
  // segments, else white. Segment k spans [2πk/bits, 2π(k+1)/bits) clockwise on the sheet from +X
  // toward +Y (y down), and is bit bits − 1 − k (the first segment read is the most significant).
  double Ink(const CodedDisc& d, double dx, double dy, const PatternStyle& st) const {
    const double d2 = dx * dx + dy * dy;
    if (d2 <= r * r) return st.black;
    if (!d.code || d2 < r_in * r_in || d2 > r_out * r_out) return st.white;
    double a = std::atan2(dy, dx);
    if (a < 0) a += 2 * std::numbers::pi;
    const int k = std::min(bits - 1, static_cast<int>(a * bits / (2 * std::numbers::pi)));
    return ((*d.code >> (bits - 1 - k)) & 1u) ? st.black : st.white;
  }
  // Level k's value at (x, y): NaN where it has nothing.
  double Value(int k, double x, double y, const PatternStyle& st) const {
    if (k == 0 && !Inside(board, x, y)) return std::numeric_limits<double>::quiet_NaN();
    const CodedDisc* d = levels[k]->Find(x, y);
    if (!d) return k == 0 ? st.white : std::numeric_limits<double>::quiet_NaN();
    return Ink(*d, x - d->centre.x(), y - d->centre.y(), st);
  }
};

Extent CodedExtent(const TargetSpec& t, const PatternStyle&) {
  coded::SheetLayout sheet;
  const auto& targets = CodedTargetsOf(t, &sheet);
  if (t.field.empty()) return {0, 0, sheet.width_mm, sheet.height_mm};
  // A field's board: its targets' square hull and a plate's radius plus a dot's of paper around.
  const double m = PlateRadiusMm(t) + t.dot_radius_mm;
  Extent e{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
           -std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
  for (const auto& p : targets) {
    e.x_min = std::min(e.x_min, p.xyz_mm.x() - m);
    e.y_min = std::min(e.y_min, p.xyz_mm.y() - m);
    e.x_max = std::max(e.x_max, p.xyz_mm.x() + m);
    e.y_max = std::max(e.y_max, p.xyz_mm.y() + m);
  }
  return e;
}

std::shared_ptr<const CodedField> MakeCodedField(const TargetSpec& t, const PatternStyle& st) {
  auto f = std::make_shared<CodedField>();
  const coded::Profile profile = coded::ParseProfile(t.code_profile);
  const coded::RingRadii ring = coded::Ring(profile);
  f->board = CodedExtent(t, st);
  f->bits = t.code_bits;
  f->r = t.dot_radius_mm;
  f->r_in = ring.inner * f->r;
  f->r_out = ring.outer * f->r;
  coded::SheetLayout sheet;
  const auto& targets = CodedTargetsOf(t, &sheet);
  const int n_codes = static_cast<int>(coded::Codes(profile, t.code_bits).size());
  f->z_mm = {0.0};
  std::vector<std::vector<CodedDisc>> discs(1);
  for (const auto& p : targets) {
    if (!coded::FacesMinusZ(p)) {
      throw InvalidInput("field", fmt::format("target {} faces ({:g}, {:g}, {:g}): render draws targets facing -Z "
                                                "(parallel to the board) only", p.id, p.normal.x(), p.normal.y(),
                                                p.normal.z()));
    }
    std::size_t k = 0;
    while (k < f->z_mm.size() && std::abs(f->z_mm[k] - p.xyz_mm.z()) > 1e-9) ++k;
    if (k == f->z_mm.size()) {
      f->z_mm.push_back(p.xyz_mm.z());
      discs.emplace_back();
    }
    CodedDisc d{p.xyz_mm.head<2>(), std::nullopt};
    if (p.id >= 1 && p.id <= n_codes) d.code = coded::CodeOfId(profile, t.code_bits, p.id);
    discs[k].push_back(d);
  }
  const double plate = PlateRadiusMm(t);
  for (std::size_t k = 0; k < discs.size(); ++k) {
    f->levels.push_back(std::make_unique<DiscGrid>(std::move(discs[k]), k == 0 ? f->r_out : plate));
  }
  return f;
}

Reflectance CodedReflectance(const TargetSpec& t, const PatternStyle& st) {
  const auto f = MakeCodedField(t, st);
  return [=](double x, double y) {
    const double v = f->Value(0, x, y, st);
    return std::isnan(v) ? st.background : v;
  };
}

}  // namespace

const std::vector<TargetDrawing>& TargetDrawings() {
  static const std::vector<TargetDrawing> list = {
      {TargetKind::kChessboard, "chessboard", &ChessboardReflectance, &ChessboardExtent},
      {TargetKind::kCharuco, "charuco", &CharucoReflectance, &CharucoExtent},
      {TargetKind::kCircles, "circles", &CirclesReflectance, &CirclesExtent},
      {TargetKind::kAsymmetricCircles, "acircles", &CirclesReflectance, &CirclesExtent},
      {TargetKind::kCoded, "coded", &CodedReflectance, &CodedExtent},
  };
  return list;
}

namespace {
const TargetDrawing& DrawingOf(const TargetSpec& target) {
  for (const TargetDrawing& d : TargetDrawings()) {
    if (d.kind == target.kind) return d;
  }
  throw InvalidInput("target", "the renderer cannot draw a " + target.ToString() + " target yet");
}
}  // namespace

Reflectance MakeReflectance(const TargetSpec& target, const PatternStyle& style) {
  return DrawingOf(target).make(target, style);
}

Extent BoardExtent(const TargetSpec& target, const PatternStyle& style) {
  return DrawingOf(target).extent(target, style);
}

Surfaces MakeSurfaces(const TargetSpec& target, const PatternStyle& style) {
  Surfaces s;
  if (target.kind == TargetKind::kCoded) {
    const auto f = MakeCodedField(target, style);
    s.z_mm = f->z_mm;
    s.value = [f, style](int k, double x, double y) { return f->Value(k, x, y, style); };
    return s;
  }
  const Reflectance reflect = MakeReflectance(target, style);
  const Extent board = BoardExtent(target, style);
  s.value = [reflect, board](int, double x, double y) {
    return Inside(board, x, y) ? reflect(x, y) : std::numeric_limits<double>::quiet_NaN();
  };
  return s;
}

int FirstHit(const Surfaces& surfaces, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double background,
             double* value, double* t, Eigen::Vector2d* hit) {
  *value = background;
  *t = std::numeric_limits<double>::infinity();
  const std::size_t n = surfaces.z_mm.size();
  auto try_level = [&](int k, double tk) {
    const Eigen::Vector2d at = (o + tk * d).head<2>();
    const double v = surfaces.value(k, at.x(), at.y());
    if (std::isnan(v)) return false;
    *value = v;
    *t = tk;
    *hit = at;
    return true;
  };
  if (!(std::abs(d.z()) > 1e-15)) return -1;  // along the planes: meets none
  if (n == 1) {
    const double t0 = (surfaces.z_mm[0] - o.z()) / d.z();
    return t0 > 0 && try_level(0, t0) ? 0 : -1;
  }
  thread_local std::vector<std::pair<double, int>> order;
  order.clear();
  for (std::size_t k = 0; k < n; ++k) {
    const double tk = (surfaces.z_mm[k] - o.z()) / d.z();
    if (tk > 0) order.emplace_back(tk, static_cast<int>(k));
  }
  std::sort(order.begin(), order.end());
  for (const auto& [tk, k] : order) {
    if (try_level(k, tk)) return k;
  }
  return -1;
}

double PlateRadiusMm(const TargetSpec& target) {
  return (coded::Ring(coded::ParseProfile(target.code_profile)).outer + 1.0) * target.dot_radius_mm;
}
namespace {
bool Uncoded(const TargetSpec& target, int id) {
  // As the field's rule (coded/detect.h, IsUncodedId): an ID the profile has no code for.
  return id < 1 || id > static_cast<int>(coded::Codes(coded::ParseProfile(target.code_profile), target.code_bits).size());
}
double GapRadiusMm(const TargetSpec& target) {
  return (1 + coded::Ring(coded::ParseProfile(target.code_profile)).inner) / 2 * target.dot_radius_mm;
}
}  // namespace
double SeenRadiusMm(const TargetSpec& target, int id) {
  if (Uncoded(target, id)) return GapRadiusMm(target);
  return coded::Ring(coded::ParseProfile(target.code_profile)).outer * target.dot_radius_mm;
}
double FrameRadiusMm(const TargetSpec& target, int id) {
  if (Uncoded(target, id)) return GapRadiusMm(target);
  return (coded::Ring(coded::ParseProfile(target.code_profile)).outer + 0.5) * target.dot_radius_mm;
}

double DotRadiusMm(const TargetSpec& target) {
  switch (target.kind) {
    case TargetKind::kCoded: return target.dot_radius_mm;
    case TargetKind::kCircles:
    case TargetKind::kAsymmetricCircles: return CircleRadius(target);
    default: return 0;
  }
}

}  // namespace porthole::render
