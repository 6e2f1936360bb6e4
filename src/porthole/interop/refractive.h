// Refractive housings of other tools (docs/interop.md, "Refractive COLMAP and calibmar"):
//  - the FLATPORT / DOMEPORT parameters of refractive COLMAP (the COLMAP-Underwater fork,
//    colmap/sensor/models_refrac.{h,cc}) and calibmar (MDSKiel/calibmar), in metres, in COLMAP's
//    camera frame (origin at the projection centre = porthole's entrance pupil; X right, Y down,
//    Z forward, as porthole's cam frame):
//      FLATPORT  Nx Ny Nz int_dist int_thick na ng nw: the inner interface n·x = int_dist, n the
//                unit normal toward the scene; the outer one int_thick further;
//      DOMEPORT  Cx Cy Cz int_radius int_thick na ng nw: one centre for the inner sphere (radius
//                int_radius) and the outer one (int_radius + int_thick) — concentric only;
//    with na, ng, nw the indices of the housing air, the glass and the water;
//  - porthole's port (ports/port.h, as its TOML: catalogue::ParsePortToml / catalogue::PortToToml), in mm, with
//    indices relative to air (so ng/na, nw/na) and the water index given apart (--water-index);
//  - calibmar's calibration.yaml: `model`, `parameters` (COLMAP's model and order, COLMAP's pixel
//    convention), `non_svp_model` (NONE, FLATPORT, DOMEPORT), `non_svp_parameters`, `width`,
//    `height`, and in comments `# params_est_std_dev:`, `# non_svp_est_std_dev:`,
//    `# overall_rms:`, `# target:` (calibmar src/calibmar/core/report.cpp, GenerateCalibrationYaml);
//    its reader and writer, and its σ ↔ covariance, are calibmar.cc (the format calibmar of interop.h).
#pragma once

#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "porthole/interop/interop.h"
#include "porthole/ports/port.h"

namespace porthole::interop {

// A refractive housing as a porthole port in the cam frame (mm), the glass as a constant index
// ng/na, and the water index nw/na (*n_water). Throws InvalidInput(field, …) on a bad model,
// a non-unit or zero normal, non-positive sizes or indices below 1.
ports::PortSpec PortFromRefractive(const RefractiveHousing& h, const std::string& field, double* n_water);

// A porthole port as refractive COLMAP's housing: a housing-frame port is taken relative to its
// own entrance_pupil_mm; a dome must be concentric (one centre) and a hemisphere's rim is not
// kept. n_glass and n_water relative to air (na = 1). Throws InvalidInput(field, …).
RefractiveHousing RefractiveFromPort(const ports::PortSpec& port, double n_glass, double n_water,
                                     const std::string& field);

// The housing's 1σ as a port TOML [sigma] table in the port's units (cam frame, mm; indices relative
// to the housing air), holding the σ the file gives (calibmar's "# non_svp_est_std_dev"): a dome's
// center_mm = [σCx, σCy, σCz], inner_radius_mm, thickness_mm; a flat port's normal = [σNx, σNy, σNz],
// distance_mm (of the inner interface from the pupil), thickness_mm; both n_glass (σ of ng/na) and
// n_water (σ of nw/na). A vector is written when all three of its σ are known. Empty when no σ is
// known. catalogue::ParsePortToml reads and checks the table; porthole's optics do not use it.
std::string HousingSigmaToml(const RefractiveHousing& h);

struct CalibmarFile {
  ColmapCamera camera;                // model, width, height, parameters (COLMAP's convention)
  std::vector<double> camera_sigma;  // "# params_est_std_dev" (empty: none)
  std::optional<RefractiveHousing> housing;
  double overall_rms_px = NAN;       // "# overall_rms"
  std::string target;                // "# target" (as written)
};

// Reads calibmar's calibration.yaml. Throws InvalidInput("<field>: <key>", rule).
CalibmarFile ParseCalibmarYaml(std::string_view text, const std::string& field);
// Writes it as calibmar does (its ImportFromYaml reads it back).
std::string CalibmarYaml(const CalibmarFile& f);

// COLMAP's σ of `c`'s parameters as porthole's covariance (diagonal in COLMAP's order; a
// single-focal model's f is both fx and fy, fully correlated), in porthole's order for the model
// FromColmap gives (a NaN σ: unknown, its parameter adjusted); and back (the σ of the COLMAP
// parameters from a porthole covariance: 0 for a parameter not adjusted; empty when any variance is
// unknown, so that no "nan" is ever written).
Eigen::MatrixXd ColmapSigmaToCovariance(const ColmapCamera& c, const std::vector<double>& sigma);
std::vector<double> CovarianceToColmapSigma(const ColmapCamera& c, const Eigen::MatrixXd& covariance);

}  // namespace porthole::interop
