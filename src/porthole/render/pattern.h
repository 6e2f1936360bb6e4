// What a calibration target looks like: its reflectance at every point of its plane, one function
// per target kind, kept as a list (docs/render.md, "Targets"). A new kind of target (coded rings)
// is drawn by one more entry in TargetDrawings(): nothing else in the renderer changes.
//
// Target frame (calib/target.h): the plane Z = 0, mm, X along a row of points, Y down the rows;
// the points where TargetPoints() puts them. Reflectance: 0 (no light) … 1 (a perfect white);
// a printed board's black and white and what lies around the board are PatternStyle's.
#pragma once

#include <Eigen/Core>
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
  // The reflectance of `target` in `style`; throws InvalidInput("target") for what it cannot
  // draw (an unknown ArUco dictionary, more markers than the dictionary holds).
  Reflectance (*make)(const calib::TargetSpec& target, const PatternStyle& style);
  // The board's outline (the pattern and its margin), target frame, mm.
  Extent (*extent)(const calib::TargetSpec& target, const PatternStyle& style);
};

// Every target kind the renderer draws, one entry each.
const std::vector<TargetDrawing>& TargetDrawings();

// The reflectance of `target` (its entry of TargetDrawings()). Throws InvalidInput("target")
// when no entry draws its kind.
Reflectance MakeReflectance(const calib::TargetSpec& target, const PatternStyle& style = {});

// The board's outline (its entry's `extent`).
Extent BoardExtent(const calib::TargetSpec& target, const PatternStyle& style = {});

// What a ray can meet: the board in the plane Z = 0 of the target frame and, for a 3-D coded field
// (TargetSpec::field with Z != 0), the plates its raised targets are printed on, each a disc
// parallel to the board at its target's Z (−Z is the camera's side: a raised target has Z < 0).
// Levels are planes Z = z_mm[k]; level 0 is the board (z = 0). A ray's value is that of the
// nearest level along it that has something where the ray meets it (Surfaces::value not NaN);
// the background where it meets nothing. The plates' sides and posts are not drawn.
struct Surfaces {
  std::vector<double> z_mm = {0.0};
  // Reflectance at board point (x_mm, y_mm) of level k; NaN where the level has nothing (beyond
  // the board, beside a plate). Safe to call from several threads at once.
  std::function<double(int level, double x_mm, double y_mm)> value;
};
// The surfaces of `target`: level 0 its drawing (MakeReflectance; NaN beyond BoardExtent) with the
// targets of Z = 0, one more level per other Z of a coded field. Throws as MakeReflectance.
Surfaces MakeSurfaces(const calib::TargetSpec& target, const PatternStyle& style = {});

// The first surface a ray meets: origin and unit direction given in the target frame (mm).
// Returns the level (−1: nothing, the background) and sets *value (the background when −1),
// *t (the distance along the ray, +inf for nothing) and *hit (board point x, y of that level).
int FirstHit(const Surfaces& surfaces, const Eigen::Vector3d& origin_in_target, const Eigen::Vector3d& dir_in_target,
             double background, double* value, double* t, Eigen::Vector2d* hit);

// Coded targets: the radius (mm) of a raised target's plate: its code ring's outer radius plus
// one dot radius of plain sheet around it.
double PlateRadiusMm(const calib::TargetSpec& target);
// Coded targets, what must image for target `id` to count as seen (docs/render.md, "Partial
// views"): nothing nearer the camera may hide the disc of SeenRadiusMm around its dot — the ring's
// outer radius for a coded ID, the empty gap the detector asks of a plain dot ((1 + inner)/2 ring
// radii) for an uncoded one —, and the disc of FrameRadiusMm must image inside the frame — the ring
// with half a dot radius of band around it (the detector checks that band), the gap for an
// uncoded dot.
double SeenRadiusMm(const calib::TargetSpec& target, int id);
double FrameRadiusMm(const calib::TargetSpec& target, int id);

// The radius (mm) of the printed dot whose centre is each point of a target of circles: coded
// targets (the spec's dot radius), circle grids (a quarter of the spacing; asymmetric grids 0.3 of
// it); 0 for targets whose points are corners (chessboard, ChArUco).
double DotRadiusMm(const calib::TargetSpec& target);

}  // namespace porthole::render
