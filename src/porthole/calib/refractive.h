// Explicit refractive calibration: a bundle adjustment whose camera is a lens model of the list
// (camera/models.h) behind a port (refraction/refraction.h), in water. It measures the housing
// from the images: a dome's entrance-pupil position relative to the dome, or a flat port's normal
// and pupil-to-glass distance.
//
// Contract:
//  - Observations: pixels of target points (observations.h), one camera, one port.
//  - Model: pixel = M::Project(lens, ForwardDirection(shell, port, R·X + t)): the exact forward
//    projection through the port; the residual is projected − observed, px (maximum likelihood
//    for Gaussian pixel noise), derivatives by Jets through the projection (implicit-function
//    step for the iteration, refraction.h).
//  - Circular targets (coded): with options.lens.centre_correction (as Calibrate; auto = on for
//    coded targets) each observation is compared not with the projection of the dot's centre but
//    with the centre a perfect ellipse-centre detector measures for the dot imaged THROUGH THE
//    PORT and the lens: the ellipse fitted to 32 points of its rim (dot radius from the spec, in the
//    dot's plane, normal to its TargetNormals) each projected as above (coded::ImagedCircleCentre).
//    The offset (that centre − the projected centre) is held fixed within each Ceres solve and
//    recomputed after it, until no observation moves by 1e-5 px; the residual's Jets are those of
//    the point projection (the offset's own derivative is left out). lens.dot_radius_mm and
//    lens.max_centre_offset_px report it (0: off).
//  - Unknowns: the port's three parameters (refraction::PortParams: dome ep_in_dome_mm x, y, z;
//    flat n_x, n_y, distance_mm) unless fixed, every image's cam_from_target pose, and the lens:
//      kFree   the free set of options.lens (DefaultFree of the model unless given);
//      kFixed  the in-air calibration `air`, held fixed;
//      kPrior  `air` as a Gaussian prior with its full covariance: of the lens alone
//              (kLensBare) on every parameter it adjusted except the focal length(s), which are
//              free (a refocus on the virtual image changes them); made through the port in air
//              (kThroughPort, the default) on the central camera that the lens behind the port in
//              air gives, so on the lens and the port together (housed_prior.h); the image
//              residuals are then weighted by 1/σ0 of a first pass so the prior and the images
//              have their stated weights (so too with shell priors).
//    The shell (radii, inner-centre offset, thickness) and the indices come from the port system;
//    optionally adjusted too (refraction::ShellParams): a factor on the water index
//    (free_water_index, no prior) and the shell values the port file states a σ for (free_shell,
//    ports::ShellSigma: each a Gaussian prior of that σ about the file's value).
//  - Start: a central calibration of the same images with the same model (calib::Calibrate) gives
//    the poses; the lens starts from `air` or, without it, from that calibration with the
//    distortion zeroed and, behind a flat port, the focal length divided by the water index; then a
//    1-D search over the axial port parameter (dome ep_z: predicted ± 4, ± 8 mm; flat distance:
//    predicted × 0.5 … 2), each candidate adjusted for 4 iterations, the best adjusted fully.
//  - Statistics: σ0 = sqrt(Σ r²/(2n − u)) with r the (weighted) residuals, the lens+port
//    covariance σ0²·(JᵀJ)⁻¹ marginal over the poses (Ceres Covariance), σ and correlations; a χ²
//    test of the estimated port against the predicted one (the port file and pupil) with
//    Σ_est + Σ_predicted, Σ_predicted = diag(predicted_sigma²); BIC of this model against the
//    central calibration of the same images, BIC = n·ln(RSS/n) + k·ln(n) over the n image
//    coordinates (k: free lens + port + pose parameters).
// Bad input throws InvalidInput naming the field: as Calibrate, plus an intrinsics mode that needs
// `air` without one, an air calibration of another model or sensor, a port the pupil is not in,
// a network whose port parameters are not determined (singular covariance), or --free-shell with
// a port file that states no σ.
#pragma once

#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "porthole/calib/calibrate.h"
#include "porthole/calib/result_json.h"
#include "porthole/ports/port.h"
#include "porthole/refraction/refraction.h"

namespace porthole::calib {

enum class IntrinsicsMode { kFree, kFixed, kPrior };
// "free" | "fixed" | "prior"; throws InvalidInput(field).
IntrinsicsMode ParseIntrinsicsMode(const std::string& s, const std::string& field);
std::string ToString(IntrinsicsMode m);
// "ep_x,ep_z" (names of refraction::PortParams(kind)), "all" or "none" → which port parameters
// are free.
std::array<bool, refraction::kPortNumParams> ParsePortFree(refraction::PortKind kind,
                                                          const std::string& list,
                                                          const std::string& field);

struct RefractiveOptions {
  // The lens model, its free set (kFree), pitch, outlier rejection, iterations, threads, progress.
  CalibrationOptions lens;
  // The port placed in front of the pupil with the water and glass indices: the shell, and the
  // PREDICTED port parameters (refraction::ParamsOf) the estimate is tested against.
  ports::PortSystem port;
  IntrinsicsMode intrinsics = IntrinsicsMode::kFree;
  // An in-air calibration (same model; its sensor is checked against the images'), and what it is
  // of. A calibration made in air with the housing on sees the lens through the port in air, and
  // a thick or decentred dome still refracts there (it is a weak meniscus lens): taken as the bare
  // lens it biases the port (issue 26). kThroughPort (the paper's protocol, the default): with
  // kPrior, a prior on the lens AND the port (housed_prior.h: the calibration is the central camera
  // that fits the lens behind the port in air; every parameter it adjusted, the focal length(s)
  // too: one focus), with kFree a start; kFixed is refused (it is not the lens). kLensBare: made
  // without the housing, the lens alone (kFixed, kPrior as above).
  enum class AirCalibrationOf { kThroughPort, kLensBare };
  std::optional<CalibrationRecord> air;
  AirCalibrationOf air_of = AirCalibrationOf::kThroughPort;
  // The paper's protocol: images of the target taken in air through the same port (the housing on,
  // the focus unchanged), each modelled as the lens behind the port with air outside (index 1; the
  // water index factor does not apply), adjusted together with the water images: one lens, one
  // port, each image its own pose. Not with `air` (two sources of the same lens).
  std::vector<ImageDetections> air_detections;
  // The air images were taken at another focus (the lens refocused between the sets): they get
  // their own focal length(s), the water images' times a factor adjusted with the rest (start 1).
  // Only with air_detections.
  bool air_refocused = false;
  // Which port parameters are adjusted (the others stay at the predicted value).
  std::array<bool, refraction::kPortNumParams> port_free{true, true, true};
  // 1σ of the predicted port parameters (the χ² test): dome pupil position 0.5 mm per axis (a
  // flange survey and the lens's pupil position); flat normal components 0.005 (0.3°) and
  // distance 1 mm. Unset: those defaults for the port's kind.
  std::optional<std::array<double, refraction::kPortNumParams>> predicted_sigma;
  double alpha = 0.05;  // significance level of the χ² tests
  // Compare the simulate prediction of c, x0, y0 with the estimate's (CentralPrediction; ~25
  // simulate fits of a 13 × 9 grid).
  bool compare_central = true;
  // The 1-D search of the axial port parameter at the start (4 iterations per candidate). Off
  // starts from the prediction alone: when it is known to be close (Monte-Carlo runs).
  bool search = true;
  // Adjust a factor on the water index (refraction::ShellParams[0]; start 1, no prior). Its σ and
  // correlations (with c and the axial port parameter) say whether the images determine it.
  bool free_water_index = false;
  // Adjust the shell values the port file states a σ > 0 for (its [sigma] table, port.spec.sigma):
  // each a Gaussian prior of that σ about the file's value — a dome's radii (outer_radius_mm;
  // inner_radius_mm, or thickness_mm on outer − inner radius), its inner centre relative to the
  // outer one per axis (inner_offset_mm), a flat port's thickness (thickness_mm). The others stay
  // fixed at the file's value.
  bool free_shell = false;
};

// The name of row k of the joint covariance [lens (model order), port (refraction::PortParams),
// shell (refraction::ShellParams)]: the JSON key with `json`, else the short name.
std::string JointParamName(camera::CameraModelId model, refraction::PortKind kind, int k, bool json);

// Prediction vs measurement of the water calibration's central c, x0, y0 (a Brown lens only).
// The refractive model has no central c in water: its lens is the in-air model behind the port.
// What is compared is simulate's water fit (simulate::SimulateFit: a central Brown model fitted
// to rays traced through the port from a grid over the frame, object planes at the network's
// range) run twice with the same fit options:
//  - predicted: the PREDICTED port (the port file and pupil) with the in-air calibration's lens;
//  - estimated: the ESTIMATED port with the estimated lens (the refractive calibration's
//    equivalent central camera over this network's range).
// Their difference d = estimated − predicted is tested by χ² = dᵀ Σ_d⁻¹ d on 3 dof, Σ_d = J Σ_x Jᵀ
// with J = ∂(c, x0, y0)/∂(lens, port) by central differences of the fit (steps of one σ: the fit
// is a least-squares solution, not a closed form) and Σ_x the covariance of (estimated −
// predicted) lens and port parameters: the joint covariance, plus diag(predicted_sigma²) over the
// free port parameters, plus the in-air covariance of the lens unless it is fixed (then both
// share it), minus the cross-covariance the prior puts between the estimate and the in-air
// calibration (linear model: Cov(x̂, μ) = Σ_post·Σ_air[idx]⁻¹·Σ_air[idx, ·]). The central
// calibration of the same images (its own c, x0, y0 and σ) is reported beside them.
struct CentralPrediction {
  bool available = false;
  std::string why_not;                // when not available
  std::vector<double> distances_mm;   // object planes of the fits (the network's range)
  // c_mm, x0_mm, y0_mm (camera/brown.h units and axes).
  std::array<double, 3> predicted{}, estimated{}, central{};
  std::array<double, 3> predicted_sigma{}, estimated_sigma{}, central_sigma{};
  double chi2 = NAN, p_value = NAN;
  int dof = 3;
  bool differs = false;  // p_value < alpha
};

struct RefractiveResult {
  // The lens: model, sensor, parameters, free set, covariance/σ/correlation of the lens
  // parameters, σ0, RMS, counts, per-image poses and RMS (CalibrationResult's meaning). With air
  // images the counts and σ0 are of both sets, lens.images the water images alone.
  CalibrationResult lens;
  // The air images (RefractiveOptions::air_detections), per image; the RMS of each set (NaN
  // without air images).
  std::vector<ImageResult> air_images;
  double air_rms_px = NAN, water_rms_px = NAN;
  // With air_refocused: the air images' focal length(s) over the water images', and its σ (NaN
  // otherwise).
  double air_focal_scale = NAN, air_focal_scale_sigma = NAN;
  IntrinsicsMode intrinsics = IntrinsicsMode::kFree;
  refraction::PortKind kind = refraction::PortKind::kDome;
  std::array<double, refraction::kPortNumParams> port{}, port_sigma{}, predicted{},
      predicted_sigma{};
  std::array<bool, refraction::kPortNumParams> port_free{};
  // The shell's values (refraction::ShellParams: the water index factor, then the geometry) as
  // adjusted, their σ (NaN where fixed), the port file's values (factor 1) and which were adjusted;
  // the water index used (factor × the materials model's).
  refraction::ShellArray shell{}, shell_sigma{}, shell_predicted{};
  std::array<bool, refraction::kShellNumParams> shell_free{};
  double n_water = NAN;
  // Joint covariance and correlation of [lens parameters (model order), port parameters, shell
  // values] (JointParamName): the marginal over the poses; NaN/0 for fixed parameters as in
  // CalibrationResult.
  Eigen::MatrixXd covariance, correlation;
  // χ² test of port − predicted over the free port parameters.
  double chi2 = NAN, p_value = NAN;
  int dof = 0;
  bool port_differs = false;  // p_value < alpha
  // Flat port: the angle (deg) between the estimated and the predicted normal, and its σ.
  double normal_tilt_from_predicted_deg = NAN;
  // Model choice against the central calibration of the same images (same model, its default
  // free set; with air images, two central calibrations: one per set, as usual practice): its RMS,
  // both BICs, and the preferred model ("refractive" or "central").
  double central_rms_px = NAN, central_bic = NAN, bic = NAN;
  // With an in-air calibration made through the port: the RMS (px, 2-D) of the central fit of the
  // lens behind the estimated port in air (housed_prior.h): the part of the housed bundle no
  // central camera holds. NaN otherwise.
  double housed_fit_rms_px = NAN;
  int central_k = 0, k = 0;
  std::string preferred;
  // The simulate prediction of the water calibration's c, x0, y0 against the estimate's.
  CentralPrediction central_prediction;
  ports::PortSpec estimated_port;  // housing frame, pupil where the port system put it
  std::string message;             // "ok" or what went wrong
};

RefractiveResult CalibrateRefractive(const std::vector<ImageDetections>& detections,
                                     const TargetSpec& target, const RefractiveOptions& options);

// Network advice: the σ a network will give the port parameters (and the lens), before any data —
// the covariance of the adjustment evaluated at the design: noise-free pixels of the target
// points projected through the PREDICTED port (options.port) by the design lens at the given
// poses, every pixel weighted by 1/sigma0_px (the noise expected: 0.3 px by default), the
// intrinsics mode's free set and prior as CalibrateRefractive uses them; covariance
// (JᵀJ)⁻¹ marginal over the poses (Ceres Covariance). Points whose pixel falls outside the frame
// or cannot be projected are not seen.
struct RefractivePlan {
  camera::CameraModelId model = camera::CameraModelId::kBrown;
  refraction::PortKind kind = refraction::PortKind::kDome;
  double sigma0_px = 0.3;
  int n_images = 0, n_points = 0;
  bool determined = false;  // false: singular (the σ below are NaN)
  std::array<double, refraction::kPortNumParams> port_sigma{};  // NaN for fixed parameters
  std::array<bool, refraction::kPortNumParams> port_free{};
  std::vector<double> lens_sigma;  // model order; NaN for fixed parameters
  refraction::ShellArray shell_sigma{};  // NaN for fixed values
  std::array<bool, refraction::kShellNumParams> shell_free{};
  Eigen::MatrixXd covariance, correlation;  // [lens, port, shell] as RefractiveResult
  double min_range_mm = 0, max_range_mm = 0;  // the target centres' distances from the pupil
  std::string warning;  // "" or what is weak (one range; not determined)
};

// The plan for cam_from_target `poses` (rotation_rad, translation_mm of ImageResult) of `target`
// seen by `lens` (the design lens: the in-air calibration, or a nominal camera of
// options.lens.model). Throws InvalidInput for no poses, a lens of another model than
// options.lens.model, sigma0_px ≤ 0 or a port the pupil is not in.
RefractivePlan PlanRefractive(const std::vector<ImageResult>& poses, const TargetSpec& target,
                              const camera::Camera& lens, const RefractiveOptions& options,
                              double sigma0_px = 0.3);
// The plan for the images given: their poses from a central calibration of the detections, the
// lens the refractive calibration would start from (the in-air calibration, or that central
// calibration with its distortion zeroed and, behind a flat port, f / n_water). Throws as
// Calibrate and PlanRefractive.
RefractivePlan PlanRefractiveFromImages(const std::vector<ImageDetections>& detections,
                                        const TargetSpec& target,
                                        const RefractiveOptions& options, double sigma0_px = 0.3);
// {"plan": {...}}: sigma0_px, counts, port sigma by key, lens sigma by key, correlations beyond
// 0.9, ranges, warning.
nlohmann::ordered_json PlanToJson(const RefractivePlan& plan);

// The calibration JSON (CalibrationToJson of the lens) with a `port` block: kind, intrinsics,
// parameters {key: value}, sigma, predicted, predicted_sigma, correlation with the lens
// parameters, chi2, dof, p_value, differs, model_choice {central_rms_px, central_bic, bic,
// preferred}, the estimated port's geometry in the housing frame, and `shell` {free, parameters,
// sigma, from_port_file, n_water, correlation} of the shell values.
nlohmann::ordered_json RefractiveToJson(const RefractiveResult& r, const TargetSpec& target,
                                        const RefractiveOptions& options);

}  // namespace porthole::calib
