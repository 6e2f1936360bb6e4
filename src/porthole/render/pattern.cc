#include "porthole/render/pattern.h"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <memory>
#include <numbers>
#include <optional>
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
    throw InvalidInput("--target", fmt::format("a {}x{} board needs {} markers; {} holds {}", t.cols, t.rows, n_markers,
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
// bits, profile and dot radius (calib/target.h): the paper is the board, a target's dot and its
// ring segments (coded/sheet.h: RingArcs) are the ink. The IDs printed beside the targets, the
// scale bar and the caption are not drawn. Ink is the style's black, paper its white (swap them
// for white targets on black).
Extent CodedExtent(const TargetSpec& t, const PatternStyle&) {
  const coded::SheetLayout l = calib::CodedSheet(t);
  return {0, 0, l.width_mm, l.height_mm};
}
Reflectance CodedReflectance(const TargetSpec& t, const PatternStyle& st) {
  const coded::SheetLayout l = calib::CodedSheet(t);
  const Extent paper{0, 0, l.width_mm, l.height_mm};
  const coded::RingRadii ring = coded::Ring(l.options.profile);
  const int bits = l.options.bits;
  const double r = l.options.radius_mm, pitch = l.pitch_mm;
  const double r_in = ring.inner * r, r_out = ring.outer * r;
  // The targets lie on a grid of `pitch` from the first one: (column, row) → its code, or none.
  const Eigen::Vector2d first = l.targets.front().xyz_mm.head<2>();
  auto codes = std::make_shared<std::vector<std::optional<uint32_t>>>(static_cast<std::size_t>(l.cols) * l.rows);
  for (const auto& p : l.targets) {
    const long i = std::lround((p.xyz_mm.x() - first.x()) / pitch), j = std::lround((p.xyz_mm.y() - first.y()) / pitch);
    PORTHOLE_CHECK(i >= 0 && j >= 0 && i < l.cols && j < l.rows);
    (*codes)[j * l.cols + i] = coded::CodeOfId(l.options.profile, bits, p.id);
  }
  return [=](double x, double y) {
    if (!Inside(paper, x, y)) return st.background;
    const long i = std::lround((x - first.x()) / pitch), j = std::lround((y - first.y()) / pitch);
    if (i < 0 || j < 0 || i >= l.cols || j >= l.rows) return st.white;
    const auto& code = (*codes)[j * l.cols + i];
    if (!code) return st.white;
    const double dx = x - (first.x() + i * pitch), dy = y - (first.y() + j * pitch);
    const double d2 = dx * dx + dy * dy;
    if (d2 <= r * r) return st.black;
    if (d2 < r_in * r_in || d2 > r_out * r_out) return st.white;
    // Segment k spans [2πk/bits, 2π(k+1)/bits) clockwise on the sheet from +X toward +Y (y down),
    // and is bit bits − 1 − k (the first segment read is the most significant).
    double a = std::atan2(dy, dx);
    if (a < 0) a += 2 * std::numbers::pi;
    const int k = std::min(bits - 1, static_cast<int>(a * bits / (2 * std::numbers::pi)));
    return ((*code >> (bits - 1 - k)) & 1u) ? st.black : st.white;
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
  throw InvalidInput("--target", "the renderer cannot draw a " + target.ToString() + " target yet");
}
}  // namespace

Reflectance MakeReflectance(const TargetSpec& target, const PatternStyle& style) {
  return DrawingOf(target).make(target, style);
}

Extent BoardExtent(const TargetSpec& target, const PatternStyle& style) {
  return DrawingOf(target).extent(target, style);
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
