// Photogrammetric self-calibration of one camera from planar-target detections (the paper's
// Section 5): bundle adjustment with Ceres on any model of the camera-model list (camera/models.h),
// with the statistics of the paper's Table 6.
//
// Contract:
//  - Observations are pixels (observations.h). The residual is projected − observed, in px, through
//    the model's Project (camera/models.h); for the Brown model (parameters in image mm, y up) the
//    pixel pitch converts, and with pitch 1 its "millimetres" are pixels.
//  - Unknowns: the free camera parameters (the rest fixed at their start value, 0 for the
//    distortion parameters), every image's cam_from_target pose (angle-axis rad, translation mm),
//    and optionally the target points (self-calibration) with a minimal datum of 7 fixed
//    coordinates: one point fully, a second far from it fully (scale from the nominal target),
//    and one coordinate of a third — the point and coordinate that the rotation about the first
//    two's line moves most (the Z of the point farthest from that line on a planar field); on a
//    3-D field all three on its dominant plane (the board of raised targets), so that every
//    raised point is free.
//  - Start: a focal length from Zhang's closed form on plane homographies (principal point at the
//    image centre, one focal length for all images) for rectilinear models, or, for fisheye
//    models, the focal length among a range of candidates whose ideal projection best explains
//    the views; then poses from each homography of the ideal camera's rays; then the adjustment.
//    A 3-D target field (a point off the observed points' best plane by more than 2 % of their
//    extent) starts rectilinear models from the normalised DLT of every image whose points lie
//    off one plane (≥ 6 points): K by RQ decomposition, the median focal length; the poses of
//    any model by PnP of the start camera's rays (DLT of the rays off a plane, homography on
//    one), refined with the camera fixed.
//    The Brown model first adjusts in the correction (collinearity) form (residual.h), with
//    analytic Jacobians; every other model in the image residual by automatic differentiation.
//  - Statistics: σ0 = sqrt(Σ|r|² / (2n − u)) (px, a posteriori), covariance of the camera
//    parameters = σ0²·(JᵀJ)⁻¹ with J the Jacobian of the px image residuals (marginal over all
//    unknowns: the reduced camera system from the analytic Jacobians for the Brown model with a
//    fixed target and no robust loss, Ceres's Covariance otherwise), σ and correlation from it;
//    rms_px = sqrt(Σ|r|² / n) as OpenCV reports.
//  - Significance of each free distortion parameter (from ModelInfo::first_distortion on; Brown:
//    K1…B2): t = |p|/σp. With stepwise dropping on, the least significant one below the threshold
//    is fixed to 0 and the adjustment rerun, until all remaining ones pass (the paper's Table 6
//    leaves such parameters out).
//  - Outliers: iterated k·σ0 rejection on the 2-D residual length, and/or a robust loss.
// Bad input (too few images or points for the free parameters, mixed image sizes) throws
// InvalidInput naming the field.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "porthole/calib/observations.h"
#include "porthole/calib/target.h"
#include "porthole/camera/camera.h"

namespace porthole::calib {

// One flag per parameter of the model, in the model's order: true = adjusted.
using FreeMask = std::vector<bool>;

// The usual free set of each model: Brown c, x0, y0, K1, K2, P1, P2 (K3, B1, B2 fixed at 0: the
// paper's Table 6 rows); OpenCV fx, fy, cx, cy, k1, k2, p1, p2 (COLMAP's OPENCV; k3…k6 fixed at 0);
// every parameter of the fisheye models.
FreeMask DefaultFree(camera::CameraModelId model);
// Parses "c,x0,y0,K1,K2,P1,P2" (parameter names of the model, case-sensitive; JSON keys accepted
// too); "all" frees every parameter, "default" gives DefaultFree.
FreeMask ParseFreeParameters(camera::CameraModelId model, const std::string& list,
                             const std::string& field = "free");
std::string FreeParametersToString(camera::CameraModelId model, const FreeMask& free);

enum class LossKind { kNone, kHuber, kCauchy };

// The detectors porthole reads (chessboard, ChArUco, circle grids, coded targets) measure a
// point to about 0.1 px on an image they can read (docs/calibration.md): a calibration that fits
// its detections within 3 px at RMS may be blurred or poorly modelled, one beyond fits something
// else than its detections' noise (another target, mixed sets, wrong ids, points listed twice).
inline constexpr double kDetectorNoisePx = 0.1;
inline constexpr double kMaxOkRmsPx = 30 * kDetectorNoisePx;

// "" when rms_px is within max_ok_rms_px, else the one-line status of a poor result:
// "poor: RMS 35.2 px is above 3 px (30 times the detectors' noise of about 0.1 px): …".
std::string PoorFitStatus(double rms_px, double max_ok_rms_px = kMaxOkRmsPx);

// Keeps Ceres (glog) quiet on stderr for the rest of the process: only FATAL. Calibrate and the
// refractive calibration call it.
void QuietCeresLogs();

struct CalibrationOptions {
  camera::CameraModelId model = camera::CameraModelId::kBrown;  // which model of the list
  // Which camera parameters are adjusted; unset: DefaultFree(model).
  std::optional<FreeMask> free;
  // Pixel pitch, mm. 1 means image "millimetres" are pixels (no sensor data needed); only the
  // Brown model (parameters in mm) uses it.
  double pixel_pitch_mm = 1.0;
  // Start values of the fixed parameters and of the focal length/principal point if those are
  // fixed (its model must be `model`; its sensor is replaced by the images'); unset: the start
  // described above with distortion 0.
  std::optional<camera::Camera> initial;
  // Outlier rejection: points whose 2-D residual exceeds reject_k·σ0 are dropped and the
  // adjustment rerun (at most max_reject_rounds times). 0 = off. 5 drops ~4e-6 of Gaussian data.
  double reject_k = 5.0;
  int max_reject_rounds = 5;
  // Robust loss on the px residual, scale loss_scale_px (≈ 2–3× the expected σ0).
  LossKind loss = LossKind::kNone;
  double loss_scale_px = 1.0;
  // Self-calibration: adjust the target points too (with the datum above).
  bool target_free = false;
  // The datum of a free target. kMinimal: 7 coordinates of 3 points (above), the field's frame
  // as the nominal points give it. kControl: the field's control points (coded::PlacedTarget::
  // control_sigma_mm): a coordinate of σ 0 is held, one of σ > 0 is a prior of that σ, weighted
  // as an image observation of σ0 px (σ0 of the previous adjustment): the points and their σ are
  // then in the control points' frame, as a photogrammetric network's. kAuto: kControl when at
  // least 3 control points off one line are observed, else kMinimal.
  enum class DatumKind { kAuto, kMinimal, kControl };
  DatumKind datum = DatumKind::kAuto;
  // Start a 3-D target field as a planar one (the homographies of X, Y with Z ignored, as before
  // porthole knew 3-D fields), not by DLT: only to compare the two starts. A planar field starts
  // so anyway.
  bool planar_start = false;
  // Circular targets: the centre of a dot's image is not the image of its centre (coded/
  // ellipse.h). With the correction on, each observation is compared with the centre a perfect
  // ellipse-centre detector would measure for the dot (radius dot_radius_mm, in the dot's plane:
  // normal to its TargetNormals, −Z unless a field file says otherwise) imaged through the current camera — the ellipse fitted to 32 points
  // of its projected rim, coded::ImagedCircleCentre — not with the projection of its centre.
  // The offset (dot-image centre − projected centre) is held fixed within each Ceres solve and
  // recomputed from the new estimate after it, until it moves by less than 1e-5 px (a fixed point
  // of the full model's normal equations up to ∂offset/∂parameters, a few 1e-3 of the offset).
  // kAuto: on for coded targets (their dot radius is the spec's), off for every other target.
  enum class CentreCorrection { kAuto, kOn, kOff };
  CentreCorrection centre_correction = CentreCorrection::kAuto;
  // Stepwise dropping of distortion parameters with |p|/σp below significance_t. 2 ≈ 95 %
  // two-sided for the large redundancy of a calibration.
  bool drop_insignificant = false;
  double significance_t = 2.0;
  // Ceres iteration cap per adjustment; a calibration converges in 5–20.
  int max_iterations = 100;
  // Threads for Ceres (the machine is shared: default 1).
  int num_threads = 1;
  // Covariance, σ, correlation and significance. Off only to time the adjustment alone (the
  // benchmark); sigma and correlation are then NaN and covariance_ok false.
  bool statistics = true;
  // Ceres's Covariance (sparse QR over all unknowns) instead of the reduced camera system from
  // the analytic Jacobians (Brown). Always used with a free target, a robust loss or a model
  // without analytic Jacobians; here the reference the fast path is tested against.
  bool ceres_covariance = false;
  // Progress messages (long runs), e.g. printed on stderr by the CLI. May be empty.
  std::function<void(const std::string&)> progress;
  // A result whose RMS reprojection is above this (px) is "poor", not "ok" (PoorFitStatus).
  double max_ok_rms_px = kMaxOkRmsPx;

  FreeMask FreeOrDefault() const { return free ? *free : DefaultFree(model); }
};

struct ImageResult {
  std::string image;
  int n_points = 0;     // points used
  int n_rejected = 0;   // points rejected as outliers
  double rms_px = 0;    // sqrt(mean |r|²) over its used points
  Eigen::Vector3d rotation_rad = Eigen::Vector3d::Zero();  // cam_from_target angle-axis
  Eigen::Vector3d translation_mm = Eigen::Vector3d::Zero();
};

struct Significance {
  int index = 0;     // parameter index in the model's order
  double t = 0;      // |p| / σp
  bool significant = false;
};

struct DroppedParameter {
  int index = 0;     // parameter index in the model's order
  double value = 0;  // its estimate when it was dropped
  double sigma = 0;  // and its σ
  double t = 0;      // |value| / sigma
};

struct CalibrationResult {
  camera::Camera camera;  // model, sensor (the images' size, the pitch), adjusted parameters
  FreeMask free;          // after stepwise dropping
  // σ0²-scaled covariance of the camera parameters (n×n, the model's order); rows and columns of
  // fixed parameters are 0. Units: products of the parameters' units.
  Eigen::MatrixXd covariance;
  std::vector<double> sigma;  // NaN for fixed parameters
  Eigen::MatrixXd correlation;  // NaN rows/columns for fixed parameters
  bool covariance_ok = false;
  double sigma0_px = 0;
  double rms_px = 0;
  int n_images = 0;
  int n_points = 0;      // points used
  int n_rejected = 0;    // points rejected
  int n_unknowns = 0;    // u
  int redundancy = 0;    // 2n − u
  int iterations = 0;    // Ceres iterations, all adjustments
  double seconds = 0;    // wall time
  std::vector<ImageResult> images;
  std::vector<Significance> significance;  // free distortion parameters, after dropping
  std::vector<DroppedParameter> dropped;   // in the order dropped
  std::vector<Eigen::Vector3d> target_points_mm;  // adjusted if target_free, else nominal; by id
  // target_free: each point's σ (mm, per coordinate, from the same covariance as the camera's),
  // 0 for the datum's fixed coordinates, NaN for ids not observed; empty otherwise.
  std::vector<Eigen::Vector3d> target_sigma_mm;
  // target_free: the datum — a minimal one (ids; coordinate `axis` of c: 0 X, 1 Y, 2 Z; all −1
  // otherwise) or the control points (their ids, observed, in `control`).
  struct Datum {
    int a = -1, b = -1, c = -1, axis = -1;
    std::vector<int> control;
    bool Set() const { return a >= 0 || !control.empty(); }
  } datum;
  double dot_radius_mm = 0;      // the dots' radius the centres were corrected for; 0: no correction
  double max_centre_offset_px = 0;  // largest |dot-image centre − projected centre| applied
  double start_focal_px = 0;  // the start camera's focal length (Zhang, DLT, fisheye candidate or initial)
  double start_rms_px = NAN;  // RMS reprojection (px) of the start camera from the start poses
  std::string message;   // "ok", "poor: …" (PoorFitStatus) or what went wrong (e.g. singular covariance)
};

// Coded targets: removes from each image the detections of IDs the target does not carry (its
// field file lists fewer targets than were detected, or the detections are of another sheet);
// returns how many were removed and says so on `progress` (may be empty). Other targets: nothing
// is removed (Calibrate refuses ids beyond the target). Calibrate does this itself; the refractive
// calibration's callers do it first.
int KeepTargetPoints(const TargetSpec& target, std::vector<ImageDetections>* detections,
                     const std::function<void(const std::string&)>& progress = {});

// "auto", "minimal" or "control" (CalibrationOptions::datum); throws InvalidInput(field) otherwise.
CalibrationOptions::DatumKind ParseDatumKind(const std::string& text, const std::string& field = "datum");

// Calibrates from the detections of `target` in images of one camera. Images with fewer than 4
// points are skipped (listed in the progress messages). Throws InvalidInput (field "images")
// when fewer than 3 images remain or the redundancy is not positive.
CalibrationResult Calibrate(const std::vector<ImageDetections>& detections,
                            const TargetSpec& target, const CalibrationOptions& options = {});

}  // namespace porthole::calib
