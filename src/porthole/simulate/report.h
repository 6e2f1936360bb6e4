// JSON and CSV forms of the simulation's results (field names carry their units,
// docs/conventions.md; Brown coefficients keep their photogrammetric names with a `units` object).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "porthole/simulate/simulate.h"

namespace porthole::simulate {

using Json = nlohmann::ordered_json;

// c_mm, x0_mm, y0_mm, K1, K2, K3, P1, P2 (B1, B2 are held at 0 and left out).
Json FittedParamsJson(const camera::BrownParams& p);
// FittedParamsJson + rms_um, max_um, num_points, num_failed, converged, pose.
Json FitJson(const BrownFit& fit);
// A fitted model of the camera list: its parameters under their JSON keys (units in the keys),
// rms_px, max_px, num_points, num_failed, converged, pose.
Json CameraFitJson(const CameraFit& fit);
// Units of every key FitJson and FittedParamsJson write.
Json FitUnitsJson();

// Radial distances (image mm) at which profiles are reported: 1 mm steps to the frame corner.
std::vector<double> ProfileRadiiMm(const camera::Sensor& sensor);

// What a prediction takes its in-air calibration to be (issue 26: one meaning for every command):
// a calibration made with the housing on, through the port in air, as the paper's.
inline constexpr const char* kAirCalibrationTakenAs =
    "made with the housing on: the camera through the port in air, as the paper calibrated; predicted "
    "water = it + (water fit - air fit). A calibration of the lens alone is not what this predicts from.";

// {focus, camera, water, air, change, c_ratio, radial_profile, [predicted_water,
// air_calibration_taken_as], units}.
Json PredictionJson(const Prediction& p);

// Sweep rows: offset, water and air fits, Δc, c ratio, radial profile change at the listed
// radii, P1/P2 of the water fit.
Json SweepJson(const std::vector<SweepRow>& rows, int axis, const std::vector<double>& radii_mm);
std::string SweepCsv(const std::vector<SweepRow>& rows, int axis,
                     const std::vector<double>& radii_mm);

Json DistanceErrorsJson(const std::vector<DistanceError>& rows);
std::string DistanceErrorsCsv(const std::vector<DistanceError>& rows);

// The map on the fit grid: one row per grid point with x_mm, y_mm, u_px, v_px, then the water,
// air and difference correction vectors (dx_um, dy_um, length_um) and the water residual_um.
Json MapJson(const std::vector<MapPoint>& map);
std::string MapCsv(const std::vector<MapPoint>& map);

}  // namespace porthole::simulate
