// What a calibration target looks like: its reflectance at every point of its plane, one function
// per target kind, kept as a list (docs/render.md, "Targets"). A new kind of target (coded rings)
// is drawn by one more entry in TargetDrawings(): nothing else in the renderer changes.
//
// Target frame (calib/target.h): the plane Z = 0, mm, X along a row of points, Y down the rows;
// the points where TargetPoints() puts them. Reflectance: 0 (no light) … 1 (a perfect white);
// a printed board's black and white and what lies around the board are PatternStyle's.
#pragma once

#include <functional>
#include <string_view>
#include <vector>

#include "porthole/calib/target.h"

namespace porthole::render {

struct PatternStyle {
  double black = 0.04;       // reflectance of the printed black (matt ink reflects a few %)
  double white = 0.9;        // of the paper
  double background = 0.25;  // of what lies beyond the board (the water, a wall)
  double margin = 1.0;       // white border around the pattern, in spacings (detectors need one)
};

// Reflectance at board point (x_mm, y_mm) of the target frame; any finite point, background
// beyond the board. Must be safe to call from several threads at once.
using Reflectance = std::function<double(double x_mm, double y_mm)>;

// A rectangle of the target plane, mm.
struct Extent {
  double x_min = 0, y_min = 0, x_max = 0, y_max = 0;
};

// One kind of target and how to draw it.
struct TargetDrawing {
  calib::TargetKind kind;
  std::string_view name;  // as in the spec string ("chessboard", "charuco", ...)
  // The reflectance of `target` in `style`; throws InvalidInput("--target") for what it cannot
  // draw (an unknown ArUco dictionary, more markers than the dictionary holds).
  Reflectance (*make)(const calib::TargetSpec& target, const PatternStyle& style);
  // The board's outline (the pattern and its margin), target frame, mm.
  Extent (*extent)(const calib::TargetSpec& target, const PatternStyle& style);
};

// Every target kind the renderer draws, one entry each.
const std::vector<TargetDrawing>& TargetDrawings();

// The reflectance of `target` (its entry of TargetDrawings()). Throws InvalidInput("--target")
// when no entry draws its kind.
Reflectance MakeReflectance(const calib::TargetSpec& target, const PatternStyle& style = {});

// The board's outline (its entry's `extent`).
Extent BoardExtent(const calib::TargetSpec& target, const PatternStyle& style = {});

// The radius (mm) of the printed dot whose centre is each point of a target of circles: coded
// targets (the spec's dot radius), circle grids (a quarter of the spacing; asymmetric grids 0.3 of
// it); 0 for targets whose points are corners (chessboard, ChArUco).
double DotRadiusMm(const calib::TargetSpec& target);

}  // namespace porthole::render
