// Refractive indices of the media a housing meets: air, water, seawater, port glasses and plastics.
//
// Contract (docs/conventions.md): every index is relative to air at the same wavelength; the air
// inside a housing has n = 1 exactly. Absolute models (IAPWS R9-97) are divided by the Ciddor 1996
// index of standard air (15 °C, 101 325 Pa, dry, 450 ppm CO2). Units: wavelength nm, temperature
// °C, salinity ‰ (PSU), gauge pressure dbar (0 at the surface).
//
// Outside a model's published validity range Index() throws InvalidInput naming the field
// (lambda_nm, temperature_c, salinity_psu, pressure_dbar) unless Conditions::extrapolate is set.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace porthole::materials {

// Default design wavelength: the e line (546.07 nm), as in the paper's optical software.
inline constexpr double kDefaultLambdaNm = 546.07;

struct Conditions {
  double lambda_nm = kDefaultLambdaNm;  // wavelength in air (as glass catalogues and Quan–Fry)
  double temperature_c = 20.0;          // water temperature
  double salinity_psu = 35.0;           // used by seawater models only
  double pressure_dbar = 0.0;           // gauge; depth in m ≈ dbar (see DepthToPressureDbar)
  bool extrapolate = false;             // allow use outside the published validity range
};

// Index of `medium` relative to air at c.lambda_nm.
// Names (case-insensitive), see ListMedia() for the full list with sources and ranges:
//   "air"; "seawater" (Quan–Fry 1995 with c.salinity_psu, plus the Millard–Seaver 1990 pressure
//   term when c.pressure_dbar > 0); "freshwater" (the same with salinity 0); "water-iapws"
//   (IAPWS R9-97, density from temperature at 1 atm); "seawater-millard-seaver";
//   glasses "n-bk7", "fused-silica", "pmma" (acrylic), "polycarbonate", "sapphire-o";
//   or a number such as "1.49" for a constant index.
// Throws InvalidInput("medium", ...) for an unknown name.
double Index(std::string_view medium, const Conditions& c = {});

struct MediumInfo {
  std::string name;         // as accepted by Index()
  std::string description;  // one line, with the model's source
  double lambda_min_nm, lambda_max_nm;
  double temperature_min_c, temperature_max_c;  // NaN where temperature is not an input
  double salinity_min_psu, salinity_max_psu;    // NaN where salinity is not an input
  double pressure_max_dbar;                     // NaN where pressure is not an input
};
std::vector<MediumInfo> ListMedia();

// Depth (m) to gauge pressure (dbar): the UNESCO 1983 / Saunders 1981 formula at a latitude
// (degrees); at 45° 1000 m ≈ 1010 dbar. Documented in docs/materials.md.
double DepthToPressureDbar(double depth_m, double latitude_deg = 45.0);

}  // namespace porthole::materials
