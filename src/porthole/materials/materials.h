// Refractive indices of the media a housing meets: air, water, seawater, port glasses and plastics.
//
// Contract (docs/conventions.md): every index is relative to air at the same wavelength; the air
// inside a housing has n = 1 exactly. Absolute models (IAPWS R9-97) are divided by the Ciddor 1996
// index of standard air (15 °C, 101 325 Pa, dry, 450 ppm CO2). Units: wavelength nm, temperature
// °C, salinity ‰ (PSU), gauge pressure dbar (0 at the surface). Models, sources and ranges are
// described in docs/materials.md.
//
// Outside a model's published validity range Index() throws InvalidInput naming the field
// (lambda_nm, temperature_c, salinity_psu, pressure_dbar) and the range, unless
// Conditions::extrapolate is set. A NaN or infinite input is always rejected, as is an
// extrapolation for which the model has no real index (e.g. at a Sellmeier pole).
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace porthole::materials {

// Default design wavelength: the e line (546.07 nm), as in the paper's optical software.
inline constexpr double kDefaultLambdaNm = 546.07;

struct Conditions {
  double lambda_nm = kDefaultLambdaNm;  // wavelength in air (as glass catalogues and Quan–Fry)
  double temperature_c = 20.0;          // water temperature (glasses: catalogue values, ignored)
  double salinity_psu = 35.0;           // used by seawater models only
  double pressure_dbar = 0.0;           // gauge; depth in m ≈ dbar (see DepthToPressureDbar)
  bool extrapolate = false;             // allow use outside the published validity range
};

// Index of `medium` relative to air at c.lambda_nm.
// Names (case-insensitive), see ListMedia() for the full list with sources and ranges:
//   "air"; "seawater" (Quan–Fry 1995 with c.salinity_psu, plus the Millard–Seaver 1990 pressure
//   term n_MS(T,S,P,λ) − n_MS(T,S,0,λ) when c.pressure_dbar > 0, which narrows the wavelength
//   range to 500–700 nm); "freshwater" (the same with salinity 0); "water-iapws" (IAPWS R9-97,
//   density from temperature at 1 atm by Tanaka et al. 2001, so pressure_dbar must be 0);
//   "seawater-millard-seaver"; glasses "n-bk7", "fused-silica", "pmma" (alias "acrylic"),
//   "polycarbonate", "sapphire-o"; or a number such as "1.49" for a constant index (finite, ≥ 1).
// Inputs a medium does not depend on are ignored (but must not be NaN).
// Throws InvalidInput("medium", ...) for an unknown name or a bad constant.
double Index(std::string_view medium, const Conditions& c = {});

// Short name of the model behind `medium` ("Quan–Fry 1995", "Schott Sellmeier", "constant", ...),
// for reports. Throws InvalidInput("medium", ...) like Index().
std::string ModelOf(std::string_view medium);

// The note to show a user when `medium` at `c` is not the plain model ModelOf() names: for
// "seawater" above 35 ‰, that Quan–Fry is continued by the Millard–Seaver salinity term.
// nullopt otherwise.
std::optional<std::string> SeawaterNote(std::string_view medium, const Conditions& c);

struct MediumInfo {
  std::string name;                             // as accepted by Index()
  std::string description;                      // one line, with the model's source
  double lambda_min_nm, lambda_max_nm;          // NaN where the index does not depend on λ (air)
  double temperature_min_c, temperature_max_c;  // NaN where temperature is not an input
  double salinity_min_psu, salinity_max_psu;    // NaN where salinity is not an input
  double pressure_max_dbar;  // NaN where pressure is not an input; 0 where only 1 atm is modelled
};
std::vector<MediumInfo> ListMedia();

// Depth (m, ≥ 0) to gauge pressure (dbar) at a latitude (degrees, −90..90): the inverse, by Newton
// iteration to 1e-9 dbar, of the UNESCO 1983 depth formula (Fofonoff & Millard 1983, UNESCO Tech.
// Pap. Mar. Sci. 44, after Saunders & Fofonoff 1976; standard ocean 0 °C, 35 ‰, no geopotential
// anomaly), see UnescoDepthM(). At 45° 1000 m ≈ 1010 dbar. Documented in docs/materials.md.
// Throws InvalidInput("depth_m" | "latitude_deg", ...) for a NaN, negative or > 12000 m depth or a
// latitude outside −90..90.
double DepthToPressureDbar(double depth_m, double latitude_deg = 45.0);

// ---- The models themselves. No range checks here (Index() does them); units as stated. ----

// Quan & Fry 1995, Applied Optics 34(18):3477, Eq. 1 (fit to Austin & Halikas 1976): index of
// seawater relative to air. t_c in °C, s_psu in ‰, lambda_nm in nm. Valid 0–30 °C, 0–35 ‰,
// 400–700 nm, 1 atm.
double QuanFry(double t_c, double s_psu, double lambda_nm);

// Millard & Seaver 1990, Deep-Sea Research 37(12):1909, 27-term algorithm (Table 1): index of
// seawater relative to air. t_c in °C, s_psu in ‰ (PSS-78), p_dbar gauge pressure in dbar,
// lambda_nm in nm (evaluated in µm as in the paper). Valid 0–30 °C, 0–43 ‰, 0–11000 dbar,
// 500–700 nm.
double MillardSeaver(double t_c, double s_psu, double p_dbar, double lambda_nm);

// IAPWS R9-97 (Harvey, Gallagher & Levelt Sengers 1998, J. Phys. Chem. Ref. Data 27:761): the
// ABSOLUTE index (relative to vacuum) of water from t_k (K), rho_kg_m3 (kg/m³) and lambda_um
// (µm). Valid 261.15–773.15 K, 0–1060 kg/m³, 0.2–1.1 µm.
double IapwsR997Absolute(double t_k, double rho_kg_m3, double lambda_um);

// Ciddor 1996, Applied Optics 35(9):1566, Eq. 1: absolute index of standard air (15 °C,
// 101 325 Pa, dry, 450 ppm CO2) at lambda_nm (nm). Valid 300–1690 nm (Ciddor's range).
double CiddorStandardAir(double lambda_nm);

// Tanaka et al. 2001, Metrologia 38:301, Eq. 1 with the SMOW coefficients: density (kg/m³) of
// air-free water at 101 325 Pa from t_c (°C). Valid 0–40 °C.
double WaterDensityTanaka2001(double t_c);

// Sellmeier dispersion n² = 1 + Σ B_i λ² / (λ² − C_i), λ in µm, C_i in µm². Unused terms have
// B_i = 0. Returns NaN where n² ≤ 0 (no real index).
struct SellmeierCoefficients {
  double b[3];
  double c_um2[3];
};
double Sellmeier(const SellmeierCoefficients& k, double lambda_nm);

// UNESCO 1983 depth (m) of gauge pressure p_dbar (dbar) at latitude_deg (Fofonoff & Millard 1983,
// function DEPTH; check value 9712.653 m at 10000 dbar, 30°). No input checks.
double UnescoDepthM(double p_dbar, double latitude_deg);

}  // namespace porthole::materials
