// Printable sheets of coded targets and the target field they carry.
//
// Sheet frame (mm): origin at the top-left corner of the paper, X right, Y down, Z = 0 on the
// paper, Z toward the viewer's side negative (right-handed, like calib's target frame). A target's
// position is the centre of its dot. Drawings are vector paths: SVG with exact circular arcs, PDF
// (1.4, written here, no library) with arcs as cubic Béziers of at most 22.5° (radial error
// 6.3e-8 of the radius, coded_test), coordinates to 1e-6 mm.
#pragma once

#include <Eigen/Core>
#include <string>
#include <optional>
#include <vector>

#include "porthole/coded/codes.h"

namespace porthole::coded {

struct SheetOptions {
  int bits = 14;                       // 12 or 14
  Profile profile = Profile::kAicon;   // numbering and ring radii
  double radius_mm = 2.5;              // radius of the central dot (the ring scales with it)
  std::string paper = "A4";            // A5, A4, A3, A2, letter, legal, or WxH in mm (e.g. 300x200)
  bool landscape = false;              // swap the paper's sides
  bool white_on_black = false;         // white targets on a black field (common under water)
  int first_id = 1;                    // the first ID on the sheet
  int count = 0;                       // targets on the sheet; 0 = as many as fit
  double margin_mm = 10;               // blank border (printers do not print to the edge)
};

struct PlacedTarget {
  int id = 0;
  Eigen::Vector3d xyz_mm = Eigen::Vector3d::Zero();  // dot centre in the sheet frame
  // The unit normal of the dot's plane, pointing to the side it is printed on (where a camera must
  // be to see it): −Z for the sheet and for a board's targets; a cage's wall targets face inward.
  Eigen::Vector3d normal = -Eigen::Vector3d::UnitZ();
  // A control point (a field file's "# ... control" comment, e.g. from a PhotoModeler or DBAT
  // project): its position is known in the field's frame with this σ per coordinate, mm (0: exact,
  // held). Unset: an ordinary point. calib::CalibrationOptions::datum uses them.
  std::optional<Eigen::Vector3d> control_sigma_mm;
};

// Whether a target faces the sheet's viewer side (normal −Z within 1e-12): every target of a sheet.
bool FacesMinusZ(const PlacedTarget& t);
// Two unit vectors spanning the dot's plane, right-handed with the normal: (u, v, −normal) is
// (X, Y, Z) for a target facing −Z, so a dot's ring reads as on the sheet.
std::pair<Eigen::Vector3d, Eigen::Vector3d> DotAxes(const Eigen::Vector3d& normal);

struct SheetLayout {
  SheetOptions options;
  double width_mm = 0, height_mm = 0;       // paper
  double pitch_mm = 0;                      // centre-to-centre distance of the target grid
  int cols = 0, rows = 0;                   // grid (the last row may be partial)
  std::vector<PlacedTarget> targets;        // row by row, IDs ascending
  Eigen::Vector2d scale_bar_mm{0, 0};       // left end of the 100 mm scale bar (its top edge)
};

// Paper size in mm (portrait); throws InvalidInput("paper", ...) for an unknown name.
Eigen::Vector2d PaperSizeMm(const std::string& paper);

// Places the targets on a square grid of pitch 2·(outer ring radius + dot radius), rounded up to
// 0.5 mm, inside the margins, above a strip holding the scale bar and the caption. Throws
// InvalidInput naming the option when nothing fits or an option is out of range.
SheetLayout LayoutSheet(const SheetOptions& options);

// The sheet as SVG (mm user units) and as a one-page PDF.
std::string SheetSvg(const SheetLayout& layout);
std::string SheetPdf(const SheetLayout& layout);

// The target field as text: a header naming the sheet, then "id x_mm y_mm z_mm" a line.
std::string FieldText(const SheetLayout& layout);

// Reads a target field written by FieldText (or by hand: '#' comments, blank lines, whitespace or
// commas between the numbers): "id x_mm y_mm z_mm", or "id x_mm y_mm z_mm nx ny nz" for a target
// facing another way than −Z (the direction it faces, normalised here). Throws InvalidInput(field,
// ...) naming the line at fault (duplicate ID, not four or seven numbers, ID < 1, a normal of
// length 0).
std::vector<PlacedTarget> ParseField(const std::string& text, const std::string& field = "field");

// The ring's filled segments of a code: [start, end) angles in radians, clockwise on the sheet
// from +X (toward +Y), one interval per run of consecutive 1 bits; bit `bits − 1 − i` (MSB first)
// spans [2πi/bits, 2π(i+1)/bits).
std::vector<std::pair<double, double>> RingArcs(uint32_t code, int bits);

}  // namespace porthole::coded
