// Dome, flat and cylindrical ports, placed in front of a camera's entrance pupil.
//
// Frame: the housing frame of docs/conventions.md (origin at the lens-mount flange centre, +Z along
// the optical axis toward the scene, +X right, +Y down), millimetres. A port is written either in
// the housing frame, or in the cam frame (origin at the entrance pupil, axes parallel to housing):
// the latter describes an ideal port "centred on the pupil" whatever the lens.
#pragma once

#include <nlohmann/json_fwd.hpp>
#include <algorithm>
#include <array>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <variant>
#include <vector>

#include "porthole/core/plausible.h"
#include "porthole/optics/trace.h"

namespace porthole::ports {

using optics::Vec3;
template <typename T>
using Vec3T = optics::Vec3T<T>;
// A port's two refracting surfaces as the tracer (optics::Step) takes them, inner then outer:
// air → glass → water.
template <typename T>
using TwoInterfaces = std::array<optics::InterfaceT<T>, 2>;

// The port shapes: one closed list, the alternatives of PortSpec::shape (dome, flat, cylinder).
// Each shape is one struct with its fields and the same members, which Validate, Place and
// PortSystem visit (port.cc): kName (its `type` in port files); Validate(where) (InvalidInput
// naming `where`.<key>); Translate(by) (a cam-frame description moved to the housing frame);
// RequirePupilInside(ep) (InvalidInput "entrance_pupil_mm" unless the pupil is inside);
// Interfaces<T>(shape values…, n_glass, n_water) (static: its two surfaces for a ray leaving the
// camera, in scalar T — double, or ceres::Jet where a calibration adjusts the port — the ONE
// statement of the shape's surfaces, defined below the structs); Outward(n_glass, n_water)
// (Interfaces<double> of its own fields: what PortSystem traces); InsideOuterSurface(p);
// VertexZ(ep, of_outer) (where the axis {ep + s ẑ} meets its outer or inner surface). The refractive
// projection (refraction/refraction.h, InterfacesOf) calls Interfaces<T> with the shape's values
// in the cam frame.
//
// Each shape also states as data what the modules above need of it (issue 25: "adding a shape =
// one struct + one list entry"; they read it through the variant, never by switching on a shape):
//   kPortParams, kPortParamsMeaning  its three parameters as a refractive camera's port
//                                    (refraction/refraction.h): name, JSON key, unit; in words
//   kShellParams                     its shell values a calibration may adjust, after the water
//                                    index factor (refraction::ShellParams)
//   kShellJsonKeys                   the keys of its `shell` JSON block (refraction/shell_json.cc)
//   kDefaultPredictedSigma           a calibration's default σ of the predicted parameters
//   kAxialSearch                     which parameter lies along the optical axis and the
//                                    candidates a calibration's start tries for it
//   and, as a refractive camera's port in the cam frame (see CamShell below):
//   AsShell(), PortParams(ep)        its shell and parameters as placed (refraction::ShellOf,
//                                    ParamsOf)
//   ShellValues(s), SetShellValues(v, s), ValidateShellValues(v, field)  its kShellParams in a
//                                    CamShell, and InvalidInput unless they make a port
//   SurfacesAt<T>(shell, p, v, g)    the surfaces its shell and parameters make, in scalar T
//                                    (refraction::MakeGeometry); InterfacesAt<T>(g) its two
//                                    surfaces there (Interfaces<T>: refraction::InterfacesOf)
//   AtSurfaces(g)                    the shape at those surfaces (refraction::PortSpecOf,
//                                    SpecWithParams); InWater(g, x); ValidateParams(shell, p, field)
//   AxisThroughPupil, StartDirection, ApproximateAxis, InPlaneStart  how the refractive
//                                    projection starts its iteration (refraction.cc SolveDirection)
//   PlausibleValues()                which of its values have a plausible range (housing/plausible.h)
//   Fields(self, f)                  its port-file keys, in the order read, each with its member
//                                    (catalogue/presets.cc reads and writes them generically)
//   Section(), RevolvesAbout(ep)     its x–z section (PortSection: the report's cross-section, the
//                                    paraxial trace) and whether it is a surface of revolution about
//                                    the axis through the pupil (virtual_image.cc)
//   ShellPrior(sigma, row)           which [sigma] values of its port file are a prior on which of
//                                    its kShellParams (calib/refractive.cc)

// A port parameter or shell value of a refractive camera (refraction/refraction.h).
struct ParamInfo {
  std::string_view name;      // as --free-port and the tables say it
  std::string_view json_key;  // with its unit
  std::string_view unit;
};

// The port parameter along the optical axis, which a refractive calibration's start searches
// (calib/refractive.cc), and the candidates it tries around the predicted value: predicted + step,
// or predicted × step when `relative`, in this order.
struct AxialSearch {
  int param = 2;
  bool relative = false;
  std::array<double, 5> steps{};

  std::vector<double> Candidates(double predicted) const {
    std::vector<double> c;
    for (double s : steps) c.push_back(relative ? predicted * s : predicted + s);
    return c;
  }
};

// A value of a port with its plausible range (core/plausible.h), keyed as the port file's key.
struct PlausibleValue {
  std::string_view key;
  double value;
  PlausibleRange range;
};

// How a port file states a field (Fields): required, or optional with the struct's default (both
// always written), or a std::optional (written when set). A key "table.key" lies in [table].
enum class FieldUse { kRequired, kDefaulted, kOptional };

// 1σ of a port's shell values where the port file states them (its `[sigma]` table: a scan's
// sphere fits, a datasheet's tolerances, calibmar's estimate through `porthole convert`), mm; unset:
// not stated, 0: exact. `porthole calibrate --port --free-shell` adjusts the values with a σ > 0,
// each with a Gaussian prior of that σ (docs/calibration.md). Dome: the two radii, the thickness
// outer − inner radius, the inner centre relative to the outer one per axis. Flat: the thickness.
struct ShellSigma {
  std::optional<double> outer_radius_mm, inner_radius_mm, thickness_mm;
  std::optional<Vec3> inner_offset_mm;

  bool Empty() const { return !outer_radius_mm && !inner_radius_mm && !thickness_mm && !inner_offset_mm; }
};

// A surface of a port in the x–z section of the housing frame, as the report's cross-section draws
// it and the paraxial trace (virtual_image.cc) takes it: a sphere of radius_mm about center_mm, cut
// by the plane y = 0 (a dome's; a cylinder's centred at y = 0, cut across its axis) or, radius_mm
// infinite, a plane square to the optical axis (center_mm: a point of it).
struct SectionCurve {
  Vec3 center_mm = Vec3::Zero();
  double radius_mm = std::numeric_limits<double>::infinity();
  bool IsCircle() const { return std::isfinite(radius_mm); }
};
struct PortSection {
  SectionCurve outer, inner;
  std::optional<double> rim_z_mm;  // curved: glass only where z >= this (unset: the outer centre's z)
};

// ---- A shape as a refractive camera's port (refraction/refraction.h) ----
// There a port is its shell — what a port file fixes and the images do not estimate — and three
// parameters a calibration estimates (kPortParams), in the cam frame (origin at the entrance pupil,
// axes of the housing frame), mm. CamShell holds every shape's shell (each uses its own fields);
// CamSurfaces<T> the surfaces a shell and parameters make, in scalar T (double, or a ceres::Jet).
struct CamShell {
  double outer_radius_mm = 0, inner_radius_mm = 0;  // dome, cylinder
  Vec3 inner_from_outer_mm = Vec3::Zero();          // dome: inner centre − outer centre
  // Glass where z ≥ (the outer centre's z, a cylinder's axis z) + this: the rim plane.
  double rim_from_outer_z_mm = 0;
  double thickness_mm = 0;                          // flat
};

template <typename T>
struct CamSurfaces {
  Vec3T<T> outer_center, inner_center;  // dome
  T outer_radius, inner_radius;         // dome, cylinder
  double rim_z = 0;                     // dome, cylinder: glass where z ≥ rim_z (value only)
  Vec3T<T> normal;                      // flat: unit, toward the scene; cylinder: unit axis
  Vec3T<T> axis_point;                  // cylinder: the axis's point nearest the pupil
  T distance, thickness;                // flat: pupil to inner face along normal; glass
  T n_glass, n_water;
};

namespace detail {
// The value of a scalar: itself for double, the (recursive) real part `a` of a ceres::Jet.
template <typename T>
double ValueOf(const T& x) {
  if constexpr (std::is_arithmetic_v<T>) {
    return x;
  } else {
    return ValueOf(x.a);
  }
}
}  // namespace detail

struct SphereSpec {
  Vec3 center_mm = Vec3::Zero();
  double radius_mm = 0;
};

// A thick dome: glass between an inner and an outer sphere, which need not be concentric.
struct DomePort {
  SphereSpec outer, inner;
  std::string material = "n-bk7";
  // Glass exists only where z >= rim_z_mm (in the port's frame): a hemisphere's rim plane. Unset:
  // the outer sphere's centre plane (a hemisphere).
  std::optional<double> rim_z_mm;

  static constexpr std::string_view kName = "dome";
  // Its members in the port list (see "The port shapes" above).
  void Validate(const std::string& where) const;
  void Translate(const Vec3& by);
  void RequirePupilInside(const Vec3& ep) const;
  // The inner sphere then the outer, glass only where z >= rim_z_mm on both.
  template <typename T>
  static TwoInterfaces<T> Interfaces(const Vec3T<T>& inner_center_mm, const T& inner_radius_mm,
                                     const Vec3T<T>& outer_center_mm, const T& outer_radius_mm,
                                     double rim_z_mm, const T& n_glass, const T& n_water);
  TwoInterfaces<double> Outward(double n_glass, double n_water) const;
  bool InsideOuterSurface(const Vec3& p) const;
  double VertexZ(const Vec3& ep, bool of_outer) const;
  PortSection Section() const;
  bool RevolvesAbout(const Vec3& ep) const;
  // Both centres at `ep` within tol_mm: rays from it go straight through.
  bool CentralAt(const Vec3& ep, double tol_mm) const;

  // As data (see "The port shapes" above).
  static constexpr std::array<ParamInfo, 3> kPortParams = {{
      {"ep_x", "ep_in_dome_x_mm", "mm"}, {"ep_y", "ep_in_dome_y_mm", "mm"}, {"ep_z", "ep_in_dome_z_mm", "mm"}}};
  static constexpr std::string_view kPortParamsMeaning = "dome: entrance pupil minus outer centre";
  static constexpr std::array<ParamInfo, 5> kShellParams = {{{"r_outer", "outer_radius_mm", "mm"},
                                                             {"r_inner", "inner_radius_mm", "mm"},
                                                             {"off_x", "inner_from_outer_x_mm", "mm"},
                                                             {"off_y", "inner_from_outer_y_mm", "mm"},
                                                             {"off_z", "inner_from_outer_z_mm", "mm"}}};
  static constexpr std::array<std::string_view, 4> kShellJsonKeys = {
      "outer_radius_mm", "inner_radius_mm", "inner_from_outer_mm", "rim_from_outer_z_mm"};
  static constexpr std::array<double, 3> kDefaultPredictedSigma = {0.5, 0.5, 0.5};
  static constexpr AxialSearch kAxialSearch{2, false, {0.0, -8.0, -4.0, 4.0, 8.0}};  // ep_z, mm
  // Its radii, the inner centre minus the outer one, the rim above the outer centre (0 unset).
  CamShell AsShell() const;
  // The pupil `ep` minus the outer centre.
  std::array<double, 3> PortParams(const Vec3& ep) const;
  static std::array<double, 5> ShellValues(const CamShell& s);
  static void SetShellValues(const double* v, CamShell* s);
  static void ValidateShellValues(const double* v, const std::string& field);
  // The outer centre at −p, the inner one at −p + the offset, the rim above the outer centre;
  // the shell values from `v` (kShellParams) when given, else from `s`.
  template <typename T>
  static void SurfacesAt(const CamShell& s, const T* p, const T* v, CamSurfaces<T>* g);
  template <typename T>
  static TwoInterfaces<T> InterfacesAt(const CamSurfaces<T>& g) {
    return Interfaces<T>(g.inner_center, g.inner_radius, g.outer_center, g.outer_radius, g.rim_z, g.n_glass, g.n_water);
  }
  static DomePort AtSurfaces(const CamSurfaces<double>& g);
  static bool InWater(const CamSurfaces<double>& g, const Vec3& x);
  // The pupil inside the inner sphere.
  static void ValidateParams(const CamShell& s, const double* p, const std::string& field);
  // The line through both centres when the pupil is on it (*identity: both centres at the pupil).
  static std::optional<Vec3> AxisThroughPupil(const CamSurfaces<double>& g, bool* identity);
  static std::optional<Vec3> StartDirection(const CamSurfaces<double>&, const Vec3&) { return std::nullopt; }
  // From the pupil through the outer centre (or the inner one when the pupil is at the outer).
  static Vec3 ApproximateAxis(const CamSurfaces<double>& g);
  static double InPlaneStart(const CamSurfaces<double>&, double theta) { return theta; }
  std::array<PlausibleValue, 2> PlausibleValues() const {
    return {{{"outer.radius_mm", outer.radius_mm, kDomeRadiusRange},
             {"inner.radius_mm", inner.radius_mm, kDomeRadiusRange}}};
  }
  template <typename Self, typename F>
  static void Fields(Self& self, F&& f) {
    f("outer.center_mm", self.outer.center_mm, FieldUse::kRequired);
    f("outer.radius_mm", self.outer.radius_mm, FieldUse::kRequired);
    f("inner.center_mm", self.inner.center_mm, FieldUse::kRequired);
    f("inner.radius_mm", self.inner.radius_mm, FieldUse::kRequired);
    f("rim_z_mm", self.rim_z_mm, FieldUse::kOptional);
  }
  // row(σ, {(index in kShellParams, coefficient)…}, the index it frees): each radius, the thickness
  // outer − inner radius, the inner centre's offset per axis.
  template <typename Row>
  static void ShellPrior(const ShellSigma& sg, Row&& row) {
    row(sg.outer_radius_mm, {{0, 1.0}}, 0);
    row(sg.inner_radius_mm, {{1, 1.0}}, 1);
    row(sg.thickness_mm, {{0, 1.0}, {1, -1.0}}, 1);
    for (int k = 0; k < 3; ++k) {
      row(sg.inner_offset_mm ? std::optional<double>((*sg.inner_offset_mm)(k)) : std::nullopt, {{2 + k, 1.0}}, 2 + k);
    }
  }
};

// A flat port: a plate whose inner (air-side) plane passes through inner_point_mm with unit normal
// `normal` pointing from the camera toward the scene; the outer plane lies thickness_mm further.
struct FlatPort {
  Vec3 inner_point_mm = Vec3::Zero();
  Vec3 normal = Vec3(0, 0, 1);
  double thickness_mm = 0;
  std::string material = "pmma";

  static constexpr std::string_view kName = "flat";
  // Its members in the port list (see "The port shapes" above).
  void Validate(const std::string& where) const;
  void Translate(const Vec3& by);
  void RequirePupilInside(const Vec3& ep) const;
  // The inner plane distance_mm along the unit normal from `from_mm`, then the outer one
  // thickness_mm further; unbounded. (Its own Outward: from its inner point, distance 0; the
  // refractive projection: from the pupil.)
  template <typename T>
  static TwoInterfaces<T> Interfaces(const Vec3T<T>& from_mm, const Vec3T<T>& normal,
                                     const T& distance_mm, const T& thickness_mm, const T& n_glass,
                                     const T& n_water);
  TwoInterfaces<double> Outward(double n_glass, double n_water) const;
  bool InsideOuterSurface(const Vec3& p) const;
  double VertexZ(const Vec3& ep, bool of_outer) const;
  PortSection Section() const;
  bool RevolvesAbout(const Vec3& ep) const;

  // As data (see "The port shapes" above).
  static constexpr std::array<ParamInfo, 3> kPortParams = {
      {{"n_x", "normal_x", "1"}, {"n_y", "normal_y", "1"}, {"distance", "distance_mm", "mm"}}};
  static constexpr std::string_view kPortParamsMeaning = "flat: inner-face normal and pupil distance";
  static constexpr std::array<ParamInfo, 1> kShellParams = {{{"thickness", "thickness_mm", "mm"}}};
  static constexpr std::array<std::string_view, 1> kShellJsonKeys = {"thickness_mm"};
  static constexpr std::array<double, 3> kDefaultPredictedSigma = {0.005, 0.005, 1.0};
  static constexpr AxialSearch kAxialSearch{2, true, {1.0, 0.5, 0.75, 1.5, 2.0}};  // distance, ×
  // Its thickness; no rim.
  CamShell AsShell() const {
    CamShell s;
    s.thickness_mm = thickness_mm;
    return s;
  }
  // The normal's n_x, n_y and the pupil-to-inner-face distance along it.
  std::array<double, 3> PortParams(const Vec3& ep) const;
  static std::array<double, 1> ShellValues(const CamShell& s) { return {s.thickness_mm}; }
  static void SetShellValues(const double* v, CamShell* s) { s->thickness_mm = v[0]; }
  static void ValidateShellValues(const double* v, const std::string& field);
  // The normal (p[0], p[1], sqrt(1 − p[0]² − p[1]²)), the inner face at p[2] along it.
  template <typename T>
  static void SurfacesAt(const CamShell& s, const T* p, const T* v, CamSurfaces<T>* g);
  template <typename T>
  static TwoInterfaces<T> InterfacesAt(const CamSurfaces<T>& g) {
    return Interfaces<T>(Vec3T<T>::Zero(), g.normal, g.distance, g.thickness, g.n_glass, g.n_water);
  }
  static FlatPort AtSurfaces(const CamSurfaces<double>& g);
  static bool InWater(const CamSurfaces<double>& g, const Vec3& x) { return x.dot(g.normal) > g.distance + g.thickness; }
  // A normal toward the scene, a positive distance.
  static void ValidateParams(const CamShell& s, const double* p, const std::string& field);
  // Its normal: a flat port is axial.
  static std::optional<Vec3> AxisThroughPupil(const CamSurfaces<double>& g, bool* identity) {
    *identity = false;
    return g.normal;
  }
  static std::optional<Vec3> StartDirection(const CamSurfaces<double>&, const Vec3&) { return std::nullopt; }
  static Vec3 ApproximateAxis(const CamSurfaces<double>& g) { return g.normal; }
  // The direction to the point steepened by the water index (its far field: sin θ_air = n_w sin θ_water).
  static double InPlaneStart(const CamSurfaces<double>& g, double theta) {
    return std::asin(std::min(0.999, g.n_water * std::sin(theta)));
  }
  std::array<PlausibleValue, 1> PlausibleValues() const { return {{{"thickness_mm", thickness_mm, kPortThicknessRange}}}; }
  template <typename Self, typename F>
  static void Fields(Self& self, F&& f) {
    f("thickness_mm", self.thickness_mm, FieldUse::kRequired);
    f("inner_point_mm", self.inner_point_mm, FieldUse::kRequired);
    f("normal", self.normal, FieldUse::kDefaulted);
  }
  // The thickness.
  template <typename Row>
  static void ShellPrior(const ShellSigma& sg, Row&& row) {
    row(sg.thickness_mm, {{0, 1.0}}, 0);
  }
};

// A cylindrical port: glass between two coaxial circular cylinders whose axis crosses the optical
// axis at a right angle (a tube housing looking out through its wall, as action-camera and ROV
// housings do). Bent across the axis like a dome, along it like a flat port.
struct CylinderPort {
  Vec3 axis_point_mm = Vec3::Zero();  // a point on the axis
  Vec3 axis = Vec3(0, 1, 0);          // unit, across the optical axis (axis.z = 0); either sense
  double inner_radius_mm = 0, outer_radius_mm = 0;
  std::string material = "pmma";
  // Glass exists only where z >= rim_z_mm (in the port's frame). Unset: the axis's plane (the
  // front half of the tube).
  std::optional<double> rim_z_mm;

  static constexpr std::string_view kName = "cylinder";
  // Its members in the port list (see "The port shapes" above).
  void Validate(const std::string& where) const;
  void Translate(const Vec3& by);
  void RequirePupilInside(const Vec3& ep) const;
  // The inner cylinder then the outer about one axis (a point on it, unit direction), glass only
  // where z >= rim_z_mm on both.
  template <typename T>
  static TwoInterfaces<T> Interfaces(const Vec3T<T>& axis_point_mm, const Vec3T<T>& unit_axis,
                                     const T& inner_radius_mm, const T& outer_radius_mm,
                                     double rim_z_mm, const T& n_glass, const T& n_water);
  TwoInterfaces<double> Outward(double n_glass, double n_water) const;
  bool InsideOuterSurface(const Vec3& p) const;
  double VertexZ(const Vec3& ep, bool of_outer) const;
  PortSection Section() const;
  bool RevolvesAbout(const Vec3& ep) const;

  // As data (see "The port shapes" above).
  static constexpr std::array<ParamInfo, 3> kPortParams = {{{"ep_x", "ep_in_cylinder_x_mm", "mm"},
                                                            {"ep_z", "ep_in_cylinder_z_mm", "mm"},
                                                            {"axis_angle", "axis_angle_deg", "deg"}}};
  static constexpr std::string_view kPortParamsMeaning = "cylinder: entrance pupil minus axis, axis angle";
  static constexpr std::array<ParamInfo, 2> kShellParams = {
      {{"r_outer", "outer_radius_mm", "mm"}, {"r_inner", "inner_radius_mm", "mm"}}};
  static constexpr std::array<std::string_view, 3> kShellJsonKeys = {"outer_radius_mm", "inner_radius_mm",
                                                                     "rim_from_axis_z_mm"};
  static constexpr std::array<double, 3> kDefaultPredictedSigma = {0.5, 0.5, 1.0};
  static constexpr AxialSearch kAxialSearch{1, false, {0.0, -8.0, -4.0, 4.0, 8.0}};  // ep_z, mm
  // Its radii; the rim above the axis (0 unset).
  CamShell AsShell() const {
    CamShell s;
    s.outer_radius_mm = outer_radius_mm;
    s.inner_radius_mm = inner_radius_mm;
    s.rim_from_outer_z_mm = rim_z_mm ? *rim_z_mm - axis_point_mm.z() : 0.0;
    return s;
  }
  // The pupil `ep` minus the axis (across it, along Z) and the axis angle from +Y (deg).
  std::array<double, 3> PortParams(const Vec3& ep) const;
  static std::array<double, 2> ShellValues(const CamShell& s) { return {s.outer_radius_mm, s.inner_radius_mm}; }
  static void SetShellValues(const double* v, CamShell* s) {
    s->outer_radius_mm = v[0];
    s->inner_radius_mm = v[1];
  }
  static void ValidateShellValues(const double* v, const std::string& field);
  // The axis a = (sin φ, cos φ, 0), φ = p[2] in degrees; the pupil at p[0] along a × ẑ and p[1]
  // along Z from it (the axis's point nearest the pupil); the rim above the axis.
  template <typename T>
  static void SurfacesAt(const CamShell& s, const T* p, const T* v, CamSurfaces<T>* g);
  template <typename T>
  static TwoInterfaces<T> InterfacesAt(const CamSurfaces<T>& g) {
    return Interfaces<T>(g.axis_point, g.normal, g.inner_radius, g.outer_radius, g.rim_z, g.n_glass, g.n_water);
  }
  static CylinderPort AtSurfaces(const CamSurfaces<double>& g);
  static bool InWater(const CamSurfaces<double>& g, const Vec3& x);
  // The pupil inside the inner cylinder.
  static void ValidateParams(const CamShell& s, const double* p, const std::string& field);
  // No axis of symmetry through the pupil: the 2-D iteration from StartDirection, the direction
  // whose ray would reach the point far away with the pupil on the axis.
  static std::optional<Vec3> AxisThroughPupil(const CamSurfaces<double>&, bool* identity) {
    *identity = false;
    return std::nullopt;
  }
  static std::optional<Vec3> StartDirection(const CamSurfaces<double>& g, const Vec3& x);
  static Vec3 ApproximateAxis(const CamSurfaces<double>& g) { return g.normal; }  // not used
  static double InPlaneStart(const CamSurfaces<double>&, double theta) { return theta; }
  std::array<PlausibleValue, 3> PlausibleValues() const {
    return {{{"outer_radius_mm", outer_radius_mm, kDomeRadiusRange},
             {"inner_radius_mm", inner_radius_mm, kDomeRadiusRange},
             {"thickness_mm", outer_radius_mm - inner_radius_mm, kPortThicknessRange}}};
  }
  // rim_z_mm first: it is written before the others (top-level keys before tables).
  template <typename Self, typename F>
  static void Fields(Self& self, F&& f) {
    f("rim_z_mm", self.rim_z_mm, FieldUse::kOptional);
    f("axis_point_mm", self.axis_point_mm, FieldUse::kRequired);
    f("axis", self.axis, FieldUse::kDefaulted);
    f("inner_radius_mm", self.inner_radius_mm, FieldUse::kRequired);
    f("outer_radius_mm", self.outer_radius_mm, FieldUse::kRequired);
  }
  // Each radius, and the thickness outer − inner radius.
  template <typename Row>
  static void ShellPrior(const ShellSigma& sg, Row&& row) {
    row(sg.outer_radius_mm, {{0, 1.0}}, 0);
    row(sg.inner_radius_mm, {{1, 1.0}}, 1);
    row(sg.thickness_mm, {{0, 1.0}, {1, -1.0}}, 1);
  }
};

// The axis of a cylinder in the sense the port parameters use: unit, +Y half (+X where y = 0).
Vec3 CanonicalAxis(const Vec3& axis);

// ---- The shapes' surfaces, in scalar T (declared in the structs above) ----

namespace detail {
// Inner and outer surface, air → glass → water; with a rim, glass only where z >= rim_z_mm (the
// aperture is a value only: optics::SurfaceT).
template <typename T>
TwoInterfaces<T> GlassBetween(optics::SurfaceT<T> inner, optics::SurfaceT<T> outer, const T& n_glass,
                              const T& n_water, std::optional<double> rim_z_mm) {
  if (rim_z_mm) {
    for (optics::SurfaceT<T>* s : {&inner, &outer}) {
      s->aperture_point = Vec3(0, 0, *rim_z_mm);
      s->aperture_normal = Vec3(0, 0, 1);
    }
  }
  return {optics::InterfaceT<T>{inner, T(1.0), n_glass}, optics::InterfaceT<T>{outer, n_glass, n_water}};
}
}  // namespace detail

template <typename T>
TwoInterfaces<T> DomePort::Interfaces(const Vec3T<T>& inner_center_mm, const T& inner_radius_mm,
                                      const Vec3T<T>& outer_center_mm, const T& outer_radius_mm,
                                      double rim_z_mm, const T& n_glass, const T& n_water) {
  using S = optics::SurfaceT<T>;
  return detail::GlassBetween<T>(S::MakeSphere(inner_center_mm, inner_radius_mm),
                                 S::MakeSphere(outer_center_mm, outer_radius_mm), n_glass, n_water, rim_z_mm);
}

template <typename T>
TwoInterfaces<T> FlatPort::Interfaces(const Vec3T<T>& from_mm, const Vec3T<T>& normal,
                                      const T& distance_mm, const T& thickness_mm, const T& n_glass,
                                      const T& n_water) {
  using S = optics::SurfaceT<T>;
  return detail::GlassBetween<T>(S::MakePlane(Vec3T<T>(from_mm + normal * distance_mm), normal),
                                 S::MakePlane(Vec3T<T>(from_mm + normal * (distance_mm + thickness_mm)), normal),
                                 n_glass, n_water, std::nullopt);
}

template <typename T>
TwoInterfaces<T> CylinderPort::Interfaces(const Vec3T<T>& axis_point_mm, const Vec3T<T>& unit_axis,
                                          const T& inner_radius_mm, const T& outer_radius_mm,
                                          double rim_z_mm, const T& n_glass, const T& n_water) {
  using S = optics::SurfaceT<T>;
  return detail::GlassBetween<T>(S::MakeCylinder(axis_point_mm, unit_axis, inner_radius_mm),
                                 S::MakeCylinder(axis_point_mm, unit_axis, outer_radius_mm), n_glass,
                                 n_water, rim_z_mm);
}

template <typename T>
void DomePort::SurfacesAt(const CamShell& s, const T* p, const T* v, CamSurfaces<T>* g) {
  g->outer_center = Vec3T<T>(-p[0], -p[1], -p[2]);
  g->inner_center = g->outer_center + (v ? Vec3T<T>(v[2], v[3], v[4]) : s.inner_from_outer_mm.cast<T>());
  g->outer_radius = v ? v[0] : T(s.outer_radius_mm);
  g->inner_radius = v ? v[1] : T(s.inner_radius_mm);
  g->rim_z = -detail::ValueOf(p[2]) + s.rim_from_outer_z_mm;
}

template <typename T>
void FlatPort::SurfacesAt(const CamShell& s, const T* p, const T* v, CamSurfaces<T>* g) {
  using std::sqrt;
  g->normal = Vec3T<T>(p[0], p[1], sqrt(T(1) - p[0] * p[0] - p[1] * p[1]));
  g->distance = p[2];
  g->thickness = v ? v[0] : T(s.thickness_mm);
}

template <typename T>
void CylinderPort::SurfacesAt(const CamShell& s, const T* p, const T* v, CamSurfaces<T>* g) {
  using std::cos;
  using std::sin;
  const T phi = p[2] * T(M_PI / 180);
  g->normal = Vec3T<T>(sin(phi), cos(phi), T(0));
  const Vec3T<T> across(cos(phi), -sin(phi), T(0));  // a × ẑ
  g->axis_point = -(across * p[0] + Vec3T<T>(T(0), T(0), p[1]));
  g->outer_radius = v ? v[0] : T(s.outer_radius_mm);
  g->inner_radius = v ? v[1] : T(s.inner_radius_mm);
  g->rim_z = -detail::ValueOf(p[1]) + s.rim_from_outer_z_mm;
}

enum class PortFrame { kHousing, kCam };


// The closed list of shapes (a shape's index here is its refraction::PortKind).
using PortShape = std::variant<DomePort, FlatPort, CylinderPort>;
// The shapes' kNames in the list's order ("dome", "flat", "cylinder").
std::vector<std::string_view> ShapeNames();
// The shape named `name` (its kName), default-constructed; nullopt for no shape of that name.
std::optional<PortShape> ShapeNamed(std::string_view name);

struct PortSpec {
  std::string name;
  std::string description;
  std::string source;  // where the numbers come from
  PortFrame frame = PortFrame::kHousing;
  PortShape shape;
  // The entrance pupil to use when no lens says otherwise (housing frame).
  Vec3 default_ep_in_housing_mm = Vec3(0, 0, 26.9);
  // σ of the shell's values, where the file's [sigma] table states them.
  ShellSigma sigma;

  bool IsDome() const { return std::holds_alternative<DomePort>(shape); }
  bool IsCylinder() const { return std::holds_alternative<CylinderPort>(shape); }
  bool IsFlat() const { return std::holds_alternative<FlatPort>(shape); }
  // Its outer surface is curved in the x–z section (Section): a dome, a cylinder across its axis.
  // Such a port images infinity at a finite distance.
  bool IsCurved() const;
  // "dome", "flat", "cylinder".
  std::string_view KindName() const;
  const std::string& material() const;
};

// A port placed in front of an entrance pupil, everything in the housing frame, with the indices of
// the glass and the water resolved (relative to air; the housing air has n = 1).
struct PortSystem {
  PortSpec spec;  // shape converted to the housing frame (frame == kHousing)
  Vec3 ep_in_housing_mm = Vec3::Zero();
  double n_glass = 1.5168;
  double n_water = 1.341;

  bool IsDome() const { return spec.IsDome(); }
  bool IsCylinder() const { return spec.IsCylinder(); }
  bool IsFlat() const { return spec.IsFlat(); }
  const DomePort& dome() const { return std::get<DomePort>(spec.shape); }
  const FlatPort& flat() const { return std::get<FlatPort>(spec.shape); }
  const CylinderPort& cylinder() const { return std::get<CylinderPort>(spec.shape); }

  // Interfaces met by a ray leaving the camera (air → glass → water), and by one arriving from the
  // water (water → glass → air).
  std::vector<optics::Interface> Outward() const;
  std::vector<optics::Interface> Inward() const;

  // Non-central: true unless the port is a dome whose two spheres are concentric about the pupil.
  bool IsCentral(double tol_mm = 1e-9) const;

  // True where a point (housing frame) lies inside the port's outer surface: in the dome's outer
  // sphere, the cylinder's outer tube, behind the flat port's outer face.
  bool InsideOuterSurface(const Vec3& p_in_housing_mm) const;

  // Where the optical axis (through the pupil, along +Z) meets the outer and inner surfaces (z).
  double OuterVertexZ() const;
  double InnerVertexZ() const;
};

// Checks `spec` (finite numbers, radii and thickness positive, inner sphere or cylinder inside
// the outer one, unit-length normal, a cylinder's unit axis across Z, σ finite and >= 0 where given) and throws InvalidInput naming the field; `where` prefixes field names
// (e.g. "port.outer.radius_mm").
void Validate(const PortSpec& spec, const std::string& where = "port");

// Places `spec` in front of the pupil at `ep_in_housing_mm` (housing frame), with the indices given.
// Throws InvalidInput when the pupil is not inside the dome's inner sphere (behind its rim), or not
// behind a flat port's inner plane, or not inside a cylinder's inner cylinder, or the indices are
// not finite and >= 1.
PortSystem Place(const PortSpec& spec, const Vec3& ep_in_housing_mm, double n_glass, double n_water);

}  // namespace porthole::ports
