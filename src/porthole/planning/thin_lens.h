// Thin-lens closed forms used by planning: depth-of-field limits, the blur of a defocused point,
// the focus whose far limit is a given distance (hyperfocal), and close-up lenses.
//
// Distances are positive numbers in mm from the entrance pupil, as the paper gives them
// (docs/conventions.md, "Depth of field"): s the focused distance, f the focal length, N the
// f-number, c the circle of confusion (mm on the sensor). Under water every formula here is applied
// to the virtual image the port forms, never to the real object. Infinity is
// std::numeric_limits<double>::infinity(). Valid for s > f.
#pragma once

namespace porthole::planning {

struct DofLimits {
  double near_mm = 0;  // s f² / (f² + N c (s − f))
  double far_mm = 0;   // s f² / (f² − N c (s − f)), infinite when the denominator is <= 0
};
// The thin-lens depth-of-field limits of docs/conventions.md. s may be infinite (near = f²/(N c)).
DofLimits ThinLensDof(double s_mm, double f_mm, double n, double coc_mm);

// The focus s whose far limit is d (the inverse of DofLimits::far_mm):
// s = d (f² + N c f) / (f² + N c d). d = inf gives the hyperfocal distance f + f²/(N c).
double FocusForFarLimitMm(double d_mm, double f_mm, double n, double coc_mm);

// Diameter on the sensor (mm) of the blur spot of a point at distance d when the lens is focused
// at s: b = f² |s − d| / (N d (s − f)). Equals c exactly at the DofLimits. d may be infinite.
double BlurDiameterMm(double s_mm, double d_mm, double f_mm, double n);

// Thin-lens image distance (the camera's principal distance) when focused at s: c = f s / (s − f);
// f at infinity. Distances from the entrance pupil stand in for those from the principal planes.
double PrincipalDistanceMm(double s_mm, double f_mm);

// A thin close-up lens of power P (dioptres) at the entrance pupil adds P to the vergence of the
// light from a subject at d (vergence −1000/d in m⁻¹), so the lens must focus at
// d' = 1 / (1/d − P/1000). Returns d' (infinite when P = 1000/d, NaN when P > 1000/d: the subject
// is then beyond the lens's infinity).
double ApparentDistanceWithCloseupMm(double d_mm, double dioptre);
// The weakest close-up (dioptres) that brings a subject at d within a lens whose closest distance
// is d_min: P = 1000/d − 1000/d_min (0 when d >= d_min).
double CloseupDioptreNeeded(double d_mm, double d_min_mm);

}  // namespace porthole::planning
