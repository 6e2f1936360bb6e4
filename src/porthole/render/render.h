// What the camera sees through the port: a planar calibration target at a pose, imaged by a camera
// of the camera-model list behind a dome or flat port, in water or in air (docs/render.md).
//
// The model, per pixel (u, v) of the W × H frame:
//  - n = m² stratified sample positions inside the pixel (pixel (u, v) covers [u ± 0.5] × [v ± 0.5],
//    docs/conventions.md); each is unprojected by the camera model (its distortion applied exactly)
//    to the chief-ray direction d in the cam frame (origin at the entrance pupil, housing axes).
//    Optionally the pixels near an edge are rendered again with more samples
//    (RenderOptions::edge_samples_per_pixel).
//  - Thin lens (depth of field): the lens is focused at D_S2EP = s in front of the pupil (in the
//    housing's air: on a virtual image under water). Each sample also takes one point A of the
//    entrance-pupil disc (radius f / 2N; m × m strata, shuffled per pixel); its ray leaves A toward
//    the point where the chief ray meets the focus surface (the plane Z = s; for fisheye models the
//    sphere |P| = s), so a point whose image (through the port) lies at s is sharp and others blur
//    as planning predicts. f_number = ∞ is a pinhole (A = 0).
//  - Each ray is traced outward through the port (optics::TraceBatch) once per wavelength band
//    (glass and water indices at that band's λ) into the water (or air), and meets the target
//    plane: the target's reflectance there (render/pattern.h), the background where it misses the
//    board, black (0) when the ray cannot leave the housing (beyond the dome's rim, total internal
//    reflection). The lens itself is achromatic: bands differ only through the port and the water.
//  - A pixel is the mean over its samples, per band; grey = mean of the bands, RGB = each channel
//    the mean of its bands (λ < 500 nm blue, < 590 nm green, else red). Linear, no gamma:
//    value = exposure · V · reflectance (exposure 1: white paper at the style's 0.9), V the lens's
//    vignetting (Scene::natural_vignetting, vignetting_pa; 1 by default).
//
// Frames (docs/conventions.md): housing (flange origin, +Z to the scene), cam (entrance pupil,
// housing axes). The pose is cam_from_target: point_in_cam = R · point_in_target + t (mm).
//
// Ground truth: each target point's image, per band, is the pixel whose chief ray (from the pupil
// centre, through the port) meets the target plane at that point: a Newton solve on the pixel
// through the same tracer (GroundTruth below); converged to 1e-9 mm on the target.
//
// Failures: bad input (a target behind the camera or inside the port, a target that falls outside
// the image, a port no ray from the target can pass, bad options) → InvalidInput naming the field,
// before any pixel is rendered.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "porthole/calib/target.h"
#include "porthole/camera/camera.h"
#include "porthole/housing/housed.h"
#include "porthole/optics/trace.h"
#include "porthole/render/pattern.h"

namespace porthole::render {

// cam_from_target: point_in_cam = rotation · point_in_target + translation_mm.
struct Pose {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d Apply(const Eigen::Vector3d& p) const { return rotation * p + translation_mm; }
};

// The pose that puts the centre of the target's points at (shift_mm, distance_mm) in the cam frame,
// the target facing the camera (its X along cam X, Y along cam Y) turned by tilt_x_deg about its
// own X axis, then tilt_y_deg about its Y axis, then roll_deg about the optical axis.
Pose PoseFacing(const calib::TargetSpec& target, double distance_mm, const Eigen::Vector2d& shift_mm = {0, 0},
                double tilt_x_deg = 0, double tilt_y_deg = 0, double roll_deg = 0);
// a_from_c = a_from_b ∘ b_from_c.
Pose Compose(const Pose& a_from_b, const Pose& b_from_c);
// The centre of the target's points (target frame, mm).
Eigen::Vector3d TargetCentre(const calib::TargetSpec& target);

enum class Medium { kWater, kAir };  // what is outside the port (air: the in-air calibration)
enum class ColorMode { kGrey, kRgb };

// The default bands: the F, e and C lines (nm).
inline const std::vector<double> kDefaultBandsNm = {486.13, 546.07, 656.27};

struct Scene {
  housing::HousedCamera housed;  // body, lens, port, water (its λ is replaced by each band's)
  calib::TargetSpec target;
  Pose pose;
  Medium medium = Medium::kWater;
  // No port: the lens alone (in air, whatever `medium`): rays leave the pupil unbent, focus is on the
  // target itself; housed.port only places the pupil (CLI: --port none). An in-air calibration of
  // the bare lens is made from such renders.
  bool bare = false;
  // The lens's focus-scale distance FD (sensor to subject, mm; may be infinite). Unset: focused
  // on the target, i.e. on the virtual image of its centre (housing::FocusOnSubject).
  std::optional<double> focus_distance_mm;
  double f_number = 8;  // aperture; infinity: a pinhole (no depth of field)
  // The camera that unprojects pixels (any model of the list; its sensor is the image). Unset:
  // the ideal camera of the lens's projection (Brown for a rectilinear lens) with principal
  // distance c_mm, or the thin-lens c at the focus (lens::PrincipalDistanceMm) when c_mm is unset.
  std::optional<camera::Camera> camera;
  std::optional<double> c_mm;
  std::vector<double> bands_nm = kDefaultBandsNm;
  PatternStyle style;
  // The lens's own vignetting, off by default (the image is then the target's reflectance). Each
  // pixel is multiplied, at its centre, by
  //  - natural_vignetting: the illumination an ideal lens gives a uniform (Lambertian) scene,
  //    relative to the optical axis: cos θ · (dΩ/dA) / (dΩ/dA at the principal point), θ the
  //    pixel's chief ray's angle from the axis and dΩ/dA the solid angle per pixel area of the
  //    camera's unprojection (its distortion included). A rectilinear camera gives cos⁴θ, an
  //    equisolid fisheye cos θ; barrel distortion brightens the corners. The pupil is in the
  //    housing's air, so the port changes where the rays go, not this factor.
  //  - vignetting_pa {k1, k2, k3}: the lens's mechanical and optical vignetting as lensfun's "pa"
  //    model, 1 + k1 r² + k2 r⁴ + k3 r⁶, r the distance from the frame's centre over its
  //    half-diagonal (1 at the corners). Must stay > 0 over the frame.
  bool natural_vignetting = false;
  std::array<double, 3> vignetting_pa = {0, 0, 0};
};

// A rendered frame holds at most this many pixel values (width x height x channels: 64 megapixels
// grey, 21 RGB); Resolve refuses a larger sensor (InvalidInput "frame"): the frame is allocated
// whole before the first ray (docs/robustness.md, "Limits").
inline constexpr double kMaxFrameValues = 64e6;

struct RenderOptions {
  int samples_per_pixel = 16;  // a square m², m × m strata (and m × m pupil strata)
  // Adaptive refinement, off while 0 (or not above samples_per_pixel): a pixel near an edge — one
  // of its 3 × 3 neighbourhood saw more than one value among its samples, or differs from it — is
  // rendered again with this many samples (a square; fresh strata), which replace its first ones.
  // Edges (and blur, and the rim) get the samples they need at a fraction of the cost of giving
  // them to every pixel.
  int edge_samples_per_pixel = 0;
  ColorMode color = ColorMode::kGrey;
  double exposure = 1.0;       // pixel value = exposure · reflectance (clipped to 1)
  // Sensor noise, off while full_well_e is 0: a pixel value v is v·full_well_e photo-electrons
  // with shot noise (Gaussian of σ = √electrons: Poisson's limit, good above ~20 e⁻) and Gaussian
  // read noise of read_noise_e, divided back and clipped to 0 … 1: σ_v = √(v·F + r²) / F.
  double full_well_e = 0;
  double read_noise_e = 0;
  std::uint64_t seed = 1;      // the same seed gives the same image, on any number of threads
  int threads = 0;             // 0: every core
  // Called now and then with the fraction of rows done (from one thread at a time). May be empty.
  std::function<void(double)> progress;
};
// Throws InvalidInput naming the option.
void Validate(const RenderOptions& o);

// Everything the scene resolves to before rendering.
struct Band {
  double lambda_nm = 0;
  int channel = 0;  // 0 grey; RGB: 0 red, 1 green, 2 blue
  double n_glass = 1, n_water = 1;
  std::vector<optics::Interface> outward;  // air → glass → water (or air), housing frame
};
struct Setup {
  camera::Camera camera;
  housing::FocusSetting focus;      // FD, D_S2EP (= s), pupil
  bool focused_on_target = false;
  double focus_subject_mm = 0;      // the subject the focus was set on (from the pupil), if any
  ports::PortSystem system;         // at the design wavelength (the housed camera's λ)
  std::vector<Band> bands;
  double pupil_radius_mm = 0;       // f / 2N (0: pinhole)
  Eigen::Vector3d ep_in_housing_mm = Eigen::Vector3d::Zero();
};
// Resolves focus, camera, port and bands; checks the scene (InvalidInput). ColorMode decides each
// band's channel.
Setup Resolve(const Scene& scene, ColorMode color = ColorMode::kGrey);

// The scene's vignetting factor at pixel uv (Scene::natural_vignetting × vignetting_pa; 1 when both
// are off); 0 where the camera cannot unproject the pixel.
double VignettingAt(const Scene& scene, const camera::Camera& camera, const Eigen::Vector2d& uv);

// One target point's image.
struct TruthPoint {
  int id = 0;
  Eigen::Vector3d point_in_target_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d point_in_cam_mm = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector2d> pixel_per_band;  // (u, v), one per band of the setup
};

// The points of a coded target left out of its ground truth (docs/render.md, "Partial views").
struct LeftOut {
  std::vector<int> partial;   // ids whose dot and ring with its band (FrameRadiusMm) do not image whole inside the frame
  std::vector<int> occluded;  // ids whose dot or ring (SeenRadiusMm) a surface nearer the camera hides, wholly or in part
};

// Every target point's image per band (the Newton solve above), a point of a 3-D field (Z != 0)
// imaged in its own plane Z = z. Throws InvalidInput("pose") when a point lies behind the camera
// or inside the port, InvalidInput("port") when no ray from it passes the port. Outside the
// image: for a coded target (whose detector reads targets one by one) a target is in the truth
// only when, in every band, its centre and 32 points round the circle of FrameRadiusMm image inside
// the frame, and the chief rays of its centre and of 32 points round the circle of SeenRadiusMm
// meet that target first (Surfaces: no plate nearer the camera hides its dot or ring); the others
// are listed in *left_out; InvalidInput("pose") when none is. Other targets (seen whole by their detectors): InvalidInput("pose") when any
// point images outside the frame.
std::vector<TruthPoint> GroundTruth(const Scene& scene, const Setup& setup, LeftOut* left_out = nullptr);

// The image of a chief ray: the pixel whose chief ray, traced through `band`, meets the plane
// Z = point.z of the target frame (`pose`) at the point — the forward projection; nullopt if
// Newton fails.
std::optional<Eigen::Vector2d> ProjectThroughPort(const Setup& setup, const Band& band, const Pose& pose,
                                                  const Eigen::Vector3d& point_in_target_mm);

// A linear image, row-major, channels interleaved, values 0 … 1.
struct Image {
  int width = 0, height = 0, channels = 1;
  std::vector<float> data;
  float at(int u, int v, int c = 0) const { return data[(static_cast<std::size_t>(v) * width + u) * channels + c]; }
};

struct Rendered {
  Image image;
  Setup setup;
  std::vector<TruthPoint> truth;
  LeftOut left_out;             // coded targets: points not in the truth (partial, occluded)
  double blocked_fraction = 0;  // of the first pass's rays, those that could not leave the housing
  double refined_fraction = 0;  // of the pixels, those rendered again with edge_samples_per_pixel
  double seconds = 0;
};

// Renders the scene (the model above). Throws InvalidInput for bad scenes and options.
Rendered Render(const Scene& scene, const RenderOptions& options = {});

// The ground-truth JSON (docs/render.md, "Ground truth"): image, target, pose, camera (readable by
// calib::CalibrationFromJson), lens and focus, port (its TOML), medium and water, bands with their
// indices, sampling, and every point's pixel per band.
nlohmann::ordered_json TruthJson(const Scene& scene, const RenderOptions& options, const Rendered& r,
                                 const std::string& image_file, int bit_depth);

// The image as PNG bytes, 8 or 16 bits per channel (RGB written in PNG's order). Throws
// InvalidInput("bit_depth") for another depth.
std::string EncodePng(const Image& image, int bit_depth);

// ---- Sets: N poses rendered in water and in air, ready for `detect` and `calibrate`.

struct SetOptions {
  int count = 12;
  std::uint64_t seed = 1;
  double near_mm = 0, far_mm = 0;  // distances of the target's centre from the pupil; 0: chosen
                                   // so the target fills 30–80 % of the frame's width
  double max_tilt_deg = 35;        // tilts drawn uniformly in ±max about X and Y
  double max_roll_deg = 15;
  double margin = 0.04;            // points at least this fraction of the frame from its edges
  // Coded targets only: below 1, a pose may show part of the target (partial views): it is kept
  // when at least this fraction of the target's points image whole inside the frame (GroundTruth:
  // the others are left out of the truth), with no margin.
  double min_whole_fraction = 1;
};

// N seeded poses: distances, tilts and rolls spread over their ranges, the target's centre over
// the frame, each kept only when every point lands inside the frame (with the margin) in water and
// in air (coded targets with min_whole_fraction < 1: enough of them whole in both). Throws InvalidInput("count") when poses cannot be found (a target too large).
std::vector<Pose> SetPoses(const Scene& scene, const SetOptions& options);

// One camera of a set seen by several (a rig): its scene (its camera, port and focus) and where it
// sits relative to the reference camera (the set's poses are ref_from_target).
struct SetView {
  Scene scene;
  Pose cam_from_ref;
};
// SetPoses for several cameras at once: each pose (ref_from_target) is kept only when it fits every
// view in water and in air (a bare view: in air). With two or more views the poses are drawn as
// SetPoses draws them, through the first view's camera model, but from a frame between the cameras
// (at the mean of their pupils, with the chordal mean of their orientations), the target's centre
// pushed toward that frame's edges as far as every view still sees it whole; the default distances
// are SetPoses' plus f·b/W (b the largest distance between two pupils: the target fills 80 % … 30 %
// of the frame's width less the baseline). SetPoses(scene, o) is this with one view at the identity.
std::vector<Pose> SetPosesSeenBy(const std::vector<SetView>& views, const SetOptions& options);

}  // namespace porthole::render
