// Planar calibration targets: what a target spec string means and where its points lie.
//
// Target frame: the target plane is Z = 0, X along a row of points (OpenCV's column index), Y down
// the rows, in mm; point 0 is the first point OpenCV reports. Point ids are row-major:
// id = row·cols + col (a ChArUco corner id is the same number OpenCV's aruco module gives it).
//
// Spec strings (sizes in mm):
//   chessboard:COLSxROWS:SQUARE          inner corners, e.g. chessboard:9x6:25
//   charuco:SQX xSQY:SQUARE:MARKER[:DICT] squares (not corners), e.g. charuco:5x7:30:22:DICT_4X4_50
//   circles:COLSxROWS:SPACING            symmetric circle grid (centre spacing)
//   acircles:COLSxROWS:SPACING           asymmetric circle grid (OpenCV's layout: row i, col j at
//                                        ((2j + i mod 2)·s, i·s); SPACING = s)
//   coded:BITS:RADIUS[:PROFILE]          circular coded targets (coded/codes.h: BITS 12 or 14, PROFILE
//                                        aicon (default) or metashape, RADIUS = the dot's radius) on
//                                        the sheet `porthole target-sheet` prints with its defaults
//                                        (A4 portrait, IDs from 1): point id = target ID, so id 0
//                                        is no target; X, Y from the paper's top-left corner
#pragma once

#include <Eigen/Core>
#include <map>
#include <string>
#include <vector>

#include "porthole/coded/sheet.h"

namespace porthole::calib {

enum class TargetKind { kChessboard, kCharuco, kCircles, kAsymmetricCircles, kCoded };

struct TargetSpec {
  TargetKind kind = TargetKind::kChessboard;
  int cols = 0;              // points per row (ChArUco: squares along X)
  int rows = 0;              // rows of points (ChArUco: squares along Y)
  double spacing_mm = 0;     // square size or circle spacing, mm
  double marker_mm = 0;      // ChArUco marker side, mm
  std::string dictionary;    // ChArUco ArUco dictionary name (default DICT_4X4_50)
  int code_bits = 0;         // coded: 12 or 14
  std::string code_profile;  // coded: aicon or metashape
  double dot_radius_mm = 0;  // coded: radius of the central dot, mm
  // coded: the target field, ID → dot centre (X, Y, Z mm in the target frame; coded/sheet.h),
  // e.g. read from a --field file (LoadTargetField); empty: the default sheet's targets. Its
  // points may leave the Z = 0 plane (a 3-D field: raised targets). A dot lies in the plane
  // through its point normal to PlacedTarget::normal (−Z unless the file gives another: a cage's
  // walls).
  std::vector<coded::PlacedTarget> field;
  // coded: the file `field` was read from (LoadTargetField), as given; recorded in the results.
  std::string field_file;

  // Number of points the target carries (ChArUco: the (cols−1)·(rows−1) inner corners; coded:
  // the largest ID + 1, ids being target IDs).
  int NumPoints() const;
  // Whether `id` is one of the target's points (coded: an ID of the sheet or field).
  bool HasPoint(int id) const;
  // Columns and rows of the point lattice (ChArUco: squares − 1).
  int PointCols() const;
  int PointRows() const;
  // The spec string that ParseTarget reads back to this target.
  std::string ToString() const;
};

// Parses a spec string (above). Throws InvalidInput(field, ...) naming the rule broken.
TargetSpec ParseTarget(const std::string& spec, const std::string& field = "target");

// Every point of the target in the target frame (mm), indexed by id (coded: ids that are no
// target, 0 among them, at the origin; HasPoint tells them apart).
std::vector<Eigen::Vector3d> TargetPoints(const TargetSpec& target);
// The unit normal of each point's dot, indexed as TargetPoints: the side it is printed on, −Z for
// every point of a sheet or a board; a field's targets as its file gives them (coded/sheet.h).
std::vector<Eigen::Vector3d> TargetNormals(const TargetSpec& target);

// The field's control points: id → σ per coordinate (mm; 0: held), the datum of a free target
// (CalibrationOptions::datum). Empty for a target without a field or a field without control points.
std::map<int, Eigen::Vector3d> FieldControl(const TargetSpec& target);

// HasPoint of every id at once (size NumPoints()): true where the id is one of the target's points.
// HasPoint lays out a coded sheet at every call; loops over points use this.
std::vector<bool> TargetPointMask(const TargetSpec& target);

// Reads a target-field file (coded/sheet.h ParseField: "id x_mm y_mm z_mm" lines) into
// target->field, with the size limit of every text input (core/input.h). Throws
// InvalidInput(field, ...) naming the file and line, or when the target is not coded.
void LoadTargetField(const std::string& path, TargetSpec* target, const std::string& field = "field");

// A coded target (kind kCoded): the sheet `porthole target-sheet` prints with its defaults for the
// spec's bits, profile and dot radius.
coded::SheetLayout CodedSheet(const TargetSpec& target);

}  // namespace porthole::calib
