// Refractive index models; see materials.h for the contract and docs/materials.md for sources.
#include "porthole/materials/materials.h"

#include <fmt/core.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <string>
#include <system_error>

#include "porthole/core/error.h"

namespace porthole::materials {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// ---- Glass and crystal Sellmeier coefficients (λ in µm, C in µm²) ----

// Schott N-BK7, Schott optical glass data sheet (catalogue 2017): n_d = 1.51680, n_e = 1.51872.
constexpr SellmeierCoefficients kNBk7{{1.03961212, 0.231792344, 1.01046945},
                                      {0.00600069867, 0.0200179144, 103.560653}};
// Fused silica, Malitson 1965, J. Opt. Soc. Am. 55(10):1205, Eq. 2 (resonances 0.0684043,
// 0.1162414, 9.896161 µm, squared here). Valid 0.21–3.71 µm, 20 °C.
constexpr SellmeierCoefficients kFusedSilica{
    {0.6961663, 0.4079426, 0.8974794},
    {0.0684043 * 0.0684043, 0.1162414 * 0.1162414, 9.896161 * 9.896161}};
// Sapphire (Al2O3), ordinary ray, Malitson & Dodge 1972, J. Opt. Soc. Am. 62:1405, with the
// Sellmeier form of Dodge 1986 (CRC Handbook of Laser Science and Technology IV, p. 30):
// resonances 0.0726631, 0.1193242, 18.028251 µm. Valid 0.2–5.0 µm, 20 °C.
constexpr SellmeierCoefficients kSapphireO{
    {1.4313493, 0.65054713, 5.3414021},
    {0.0726631 * 0.0726631, 0.1193242 * 0.1193242, 18.028251 * 18.028251}};
// PMMA and polycarbonate, Sultanova, Kasarova & Nikolov 2009, Acta Physica Polonica A 116(4):585,
// one-term Sellmeier n² − 1 = B λ² / (λ² − C). Valid 0.4368–1.052 µm, 20 °C.
constexpr SellmeierCoefficients kPmma{{1.1819, 0.0, 0.0}, {0.011313, 0.0, 0.0}};
constexpr SellmeierCoefficients kPolycarbonate{{1.4182, 0.0, 0.0}, {0.021304, 0.0, 0.0}};

// ---- Validity ranges ----

constexpr double kQfLambdaMin = 400.0, kQfLambdaMax = 700.0;  // Quan & Fry 1995
constexpr double kQfTMin = 0.0, kQfTMax = 30.0;
constexpr double kQfSMin = 0.0, kQfSMax = 35.0;
constexpr double kMsLambdaMin = 500.0, kMsLambdaMax = 700.0;  // Millard & Seaver 1990
constexpr double kMsTMin = 0.0, kMsTMax = 30.0;
constexpr double kMsSMin = 0.0, kMsSMax = 43.0;
constexpr double kMsPMax = 11000.0;
// water-iapws: IAPWS R9-97 covers 200–1100 nm but the Ciddor air index it is divided by is
// published for 300–1690 nm; Tanaka's density covers 0–40 °C (IAPWS itself −12–500 °C).
constexpr double kIapwsLambdaMin = 300.0, kIapwsLambdaMax = 1100.0;
constexpr double kTanakaTMin = 0.0, kTanakaTMax = 40.0;

std::string Lower(std::string_view s) {
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(),
                 [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
  return out;
}

// Throws InvalidInput(field, ...) unless lo <= v <= hi or extrapolate.
void CheckRange(const char* field, double v, double lo, double hi, const char* unit,
                std::string_view what, bool extrapolate) {
  if (extrapolate || (v >= lo && v <= hi)) return;
  throw InvalidInput(field, fmt::format("{} is outside the valid range {}..{} {} of {}; set "
                                        "`extrapolate` to use it anyway",
                                        v, lo, hi, unit, what));
}

// Throws InvalidInput(field, ...) unless the model gave a real index (it may not, extrapolating).
double RequireRealIndex(double n, std::string_view medium, const Conditions& c) {
  if (!std::isfinite(n) || n <= 0.0) {
    throw InvalidInput("lambda_nm", fmt::format("{} has no real index at {} nm (extrapolated "
                                                "beyond its dispersion formula)",
                                                medium, c.lambda_nm));
  }
  return n;
}

// Seawater of salinity s: Quan–Fry, plus the Millard–Seaver pressure term when P > 0.
double SeawaterIndex(const Conditions& c, double s, std::string_view name) {
  const bool x = c.extrapolate;
  const double t = c.temperature_c, p = c.pressure_dbar, lambda = c.lambda_nm;
  CheckRange("temperature_c", t, kQfTMin, kQfTMax, "°C", "Quan-Fry 1995", x);
  // Above Quan–Fry's 35 ‰ (the Mediterranean reaches 38–39 ‰, the Red Sea 40–41 ‰) the salinity
  // term continues by Millard–Seaver, valid to 43 ‰: n = n_QF(T, 35, λ) + n_MS(T, S, 0, λ) −
  // n_MS(T, 35, 0, λ), continuous at 35 ‰ (SeawaterNote() says so to the user).
  CheckRange("salinity_psu", s, kQfSMin, kMsSMax, "PSU", "Quan-Fry 1995 (to 35) continued by Millard-Seaver 1990", x);
  CheckRange("lambda_nm", lambda, kQfLambdaMin, kQfLambdaMax, "nm", "Quan-Fry 1995", x);
  CheckRange("pressure_dbar", p, 0.0, kMsPMax, "dbar", "the Millard-Seaver 1990 pressure term", x);
  double n = 0;
  if (s > kQfSMax) {
    CheckRange("lambda_nm", lambda, kMsLambdaMin, kMsLambdaMax, "nm",
               "the Millard-Seaver 1990 salinity term (used above 35 PSU)", x);
    n = QuanFry(t, kQfSMax, lambda) + MillardSeaver(t, s, 0.0, lambda) - MillardSeaver(t, kQfSMax, 0.0, lambda);
  } else {
    n = QuanFry(t, s, lambda);
  }
  if (p != 0.0) {
    CheckRange("lambda_nm", lambda, kMsLambdaMin, kMsLambdaMax, "nm",
               "the Millard-Seaver 1990 pressure term (used when pressure_dbar > 0)", x);
    n += MillardSeaver(t, s, p, lambda) - MillardSeaver(t, s, 0.0, lambda);
  }
  return RequireRealIndex(n, name, c);
}

struct Entry {
  MediumInfo info;
  std::string model;
  std::function<double(const Conditions&)> index;
};

Entry SellmeierEntry(std::string name, std::string description, std::string model,
                     double lambda_min, double lambda_max, const SellmeierCoefficients& k) {
  MediumInfo info{name, std::move(description), lambda_min, lambda_max, kNaN, kNaN, kNaN, kNaN,
                  kNaN};
  auto index = [name, lambda_min, lambda_max, k](const Conditions& c) {
    CheckRange("lambda_nm", c.lambda_nm, lambda_min, lambda_max, "nm", name, c.extrapolate);
    return RequireRealIndex(Sellmeier(k, c.lambda_nm), name, c);
  };
  return Entry{std::move(info), std::move(model), index};
}

const std::vector<Entry>& Registry() {
  static const std::vector<Entry> registry = [] {
    std::vector<Entry> r;
    r.push_back({{"air", "air inside the housing: n = 1 exactly (all indices are relative to it)",
                  kNaN, kNaN, kNaN, kNaN, kNaN, kNaN, kNaN},
                 "reference (n = 1)",
                 [](const Conditions&) { return 1.0; }});
    r.push_back(
        {{"seawater",
          "Quan & Fry 1995 (Appl. Opt. 34:3477) + Millard & Seaver 1990 pressure term, and its "
          "salinity term above 35 PSU; 500-700 nm when pressure > 0 or salinity > 35",
          kQfLambdaMin, kQfLambdaMax, kQfTMin, kQfTMax, kQfSMin, kMsSMax, kMsPMax},
         "Quan-Fry 1995 (+ Millard-Seaver 1990 pressure term; its salinity term above 35 PSU)",
         [](const Conditions& c) { return SeawaterIndex(c, c.salinity_psu, "seawater"); }});
    r.push_back(
        {{"freshwater",
          "Quan & Fry 1995 at salinity 0 + Millard & Seaver 1990 pressure term; 500-700 nm when "
          "pressure > 0",
          kQfLambdaMin, kQfLambdaMax, kQfTMin, kQfTMax, kNaN, kNaN, kMsPMax},
         "Quan-Fry 1995, S = 0 (+ Millard-Seaver 1990 pressure term)",
         [](const Conditions& c) { return SeawaterIndex(c, 0.0, "freshwater"); }});
    r.push_back(
        {{"water-iapws",
          "IAPWS R9-97 / Ciddor 1996 standard air; density at 1 atm from Tanaka et al. 2001",
          kIapwsLambdaMin, kIapwsLambdaMax, kTanakaTMin, kTanakaTMax, kNaN, kNaN, 0.0},
         "IAPWS R9-97 / Ciddor 1996 air, Tanaka 2001 density",
         [](const Conditions& c) {
           const bool x = c.extrapolate;
           CheckRange("lambda_nm", c.lambda_nm, kIapwsLambdaMin, kIapwsLambdaMax, "nm",
                      "IAPWS R9-97 divided by Ciddor 1996", x);
           CheckRange("temperature_c", c.temperature_c, kTanakaTMin, kTanakaTMax, "°C",
                      "the Tanaka 2001 density", x);
           if (c.pressure_dbar != 0.0) {
             throw InvalidInput("pressure_dbar",
                                "water-iapws is modelled at 1 atm only (pressure 0); use "
                                "freshwater for water under pressure");
           }
           const double rho = WaterDensityTanaka2001(c.temperature_c);
           const double n = IapwsR997Absolute(c.temperature_c + 273.15, rho, c.lambda_nm * 1e-3) /
                            CiddorStandardAir(c.lambda_nm);
           return RequireRealIndex(n, "water-iapws", c);
         }});
    r.push_back({{"seawater-millard-seaver",
                  "Millard & Seaver 1990 (Deep-Sea Res. 37:1909), 27-term algorithm", kMsLambdaMin,
                  kMsLambdaMax, kMsTMin, kMsTMax, kMsSMin, kMsSMax, kMsPMax},
                 "Millard-Seaver 1990",
                 [](const Conditions& c) {
                   const bool x = c.extrapolate;
                   const char* what = "Millard-Seaver 1990";
                   CheckRange("temperature_c", c.temperature_c, kMsTMin, kMsTMax, "°C", what, x);
                   CheckRange("salinity_psu", c.salinity_psu, kMsSMin, kMsSMax, "PSU", what, x);
                   CheckRange("pressure_dbar", c.pressure_dbar, 0.0, kMsPMax, "dbar", what, x);
                   CheckRange("lambda_nm", c.lambda_nm, kMsLambdaMin, kMsLambdaMax, "nm", what, x);
                   return RequireRealIndex(
                       MillardSeaver(c.temperature_c, c.salinity_psu, c.pressure_dbar, c.lambda_nm),
                       "seawater-millard-seaver", c);
                 }});
    r.push_back(SellmeierEntry("n-bk7", "Schott N-BK7, catalogue Sellmeier (20 °C)",
                               "Schott Sellmeier", 300.0, 2500.0, kNBk7));
    r.push_back(SellmeierEntry("fused-silica", "fused silica, Malitson 1965 Sellmeier (20 °C)",
                               "Malitson 1965 Sellmeier", 210.0, 3710.0, kFusedSilica));
    r.push_back(SellmeierEntry("pmma", "PMMA (acrylic), Sultanova et al. 2009 Sellmeier (20 °C)",
                               "Sultanova 2009 Sellmeier", 436.8, 1052.0, kPmma));
    r.push_back(SellmeierEntry("polycarbonate",
                               "polycarbonate, Sultanova et al. 2009 Sellmeier (20 °C)",
                               "Sultanova 2009 Sellmeier", 436.8, 1052.0, kPolycarbonate));
    r.push_back(SellmeierEntry("sapphire-o",
                               "sapphire, ordinary ray, Malitson & Dodge 1972 Sellmeier (20 °C)",
                               "Malitson-Dodge 1972 Sellmeier", 200.0, 5000.0, kSapphireO));
    return r;
  }();
  return registry;
}

const Entry* Find(const std::string& lower_name) {
  const std::string name = lower_name == "acrylic" ? "pmma" : lower_name;
  for (const Entry& e : Registry()) {
    if (e.info.name == name) return &e;
  }
  return nullptr;
}

// Parses a constant index: the whole string is a finite number >= 1. Throws InvalidInput.
double ParseConstant(std::string_view medium) {
  double v = 0.0;
  const char* first = medium.data();
  const char* last = medium.data() + medium.size();
  const auto [ptr, ec] = std::from_chars(first, last, v);
  if (ec != std::errc() || ptr != last || medium.empty()) {
    std::string names;
    for (const Entry& e : Registry()) names += (names.empty() ? "" : ", ") + e.info.name;
    throw InvalidInput("medium", fmt::format("unknown medium '{}'; expected one of {} or a "
                                             "constant index such as 1.341",
                                             medium, names));
  }
  if (!std::isfinite(v) || v < 1.0) {
    throw InvalidInput(
        "medium", fmt::format("a constant index must be a finite number >= 1 (got {})", medium));
  }
  return v;
}

}  // namespace

double QuanFry(double t_c, double s_psu, double lambda_nm) {
  // Quan & Fry 1995, Eq. 1: n = n0 + (n1 + n2 T + n3 T²) S + n4 T² + (n5 + n6 S + n7 T)/λ
  //                             + n8/λ² + n9/λ³, λ in nm.
  constexpr double n0 = 1.31405, n1 = 1.779e-4, n2 = -1.05e-6, n3 = 1.6e-8, n4 = -2.02e-6,
                   n5 = 15.868, n6 = 0.01155, n7 = -0.00423, n8 = -4382.0, n9 = 1.1455e6;
  const double t = t_c, s = s_psu, l = lambda_nm;
  return n0 + (n1 + n2 * t + n3 * t * t) * s + n4 * t * t + (n5 + n6 * s + n7 * t) / l +
         n8 / (l * l) + n9 / (l * l * l);
}

double MillardSeaver(double t_c, double s_psu, double p_dbar, double lambda_nm) {
  // Millard & Seaver 1990, Table 1, four regions summed (their Eq. 5). Coefficients and the
  // pressure unit (dbar) cross-checked against two independent public implementations: Zhang,
  // Hu & He 2009 (Opt. Express 17:5698) betasw_ZHH2009.m, function RIsw_MS ("P: pressure in
  // dbar"), and the `theia` Python package's WaterBaseModel ("pressure: [dbar]"). They differ in
  // four digits: T4 (−2.0883178e-10 here, as Zhang; theia −2.0863178e-10), P1 (1.5868383e-6,
  // Zhang; theia 1.5868363e-6), PT (−9.4834486e-9, Zhang; theia −9.4634486e-9): here Zhang et
  // al.'s values, also given by a third transcription that checked them against the paper's
  // Table 2. For T3L both Zhang and theia give −1.705881e-9 (the third gives −1.705881e-10);
  // −1.705881e-9 also agrees better with IAPWS R9-97 at 30 °C (2e-5 vs 4e-5), see the tests.
  // The dbar unit agrees with physics: P1 = 1.59e-6 per dbar = 1.6e-10 per Pa, the Lorentz–
  // Lorenz estimate from the compressibility of water (4.6e-10 per Pa).
  const double t = t_c, s = s_psu, p = p_dbar;
  const double l = lambda_nm * 1e-3;  // µm
  const double l2 = l * l;
  // Region I: pure water, 1 atm (Tilton & Taylor 1938 data).
  constexpr double A0 = 1.3280657, L2 = -4.5536802e-3, LM2 = 2.5471707e-3, LM4 = 7.501966e-6,
                   LM6 = 2.802632e-6, T1 = -5.2883907e-6, T2 = -3.0738272e-6, T3 = 3.0124687e-8,
                   T4 = -2.0883178e-10, TL = 1.0508621e-5, T2L = 2.1282248e-7, T3L = -1.705881e-9;
  // Region II: salinity, 1 atm (Mehu & Johannin-Gilles 1968).
  constexpr double S0 = 1.9029121e-4, S1LM2 = 2.4239607e-6, S1T = -7.3960297e-7,
                   S1T2 = 8.9818478e-9, S1T3 = 1.2078804e-10, STL = -3.589495e-7;
  // Region III: pressure, pure water (Waxler et al. 1964), p in dbar.
  constexpr double P1 = 1.5868383e-6, P2 = -1.574074e-11, PLM2 = 1.0712063e-8, PT = -9.4834486e-9,
                   PT2 = 1.0100326e-10, P2T2 = 5.8085198e-15;
  // Region IV: pressure × salinity (Stanley's data).
  constexpr double P1S = -1.1177517e-9, PTS = 5.7311268e-11, PT2S = -1.5460458e-12;

  const double n1 = A0 + L2 * l2 + LM2 / l2 + LM4 / (l2 * l2) + LM6 / (l2 * l2 * l2) + T1 * t +
                    T2 * t * t + T3 * t * t * t + T4 * t * t * t * t + TL * t * l +
                    T2L * t * t * l + T3L * t * t * t * l;
  const double n2 = s * (S0 + S1LM2 / l2 + S1T * t + S1T2 * t * t + S1T3 * t * t * t + STL * t * l);
  const double n3 =
      P1 * p + P2 * p * p + PLM2 * p / l2 + PT * p * t + PT2 * p * t * t + P2T2 * p * p * t * t;
  const double n4 = p * s * (P1S + PTS * t + PT2S * t * t);
  return n1 + n2 + n3 + n4;
}

double IapwsR997Absolute(double t_k, double rho_kg_m3, double lambda_um) {
  // IAPWS R9-97, Eq. 1: (n² − 1)/(n² + 2) / ρ̄ = a0 + a1 ρ̄ + a2 T̄ + a3 λ̄² T̄ + a4/λ̄²
  //   + a5/(λ̄² − λ̄UV²) + a6/(λ̄² − λ̄IR²) + a7 ρ̄², with ρ̄ = ρ/1000 kg m⁻³, T̄ = T/273.15 K,
  //   λ̄ = λ/0.589 µm (Table 1 coefficients).
  constexpr double a0 = 0.244257733, a1 = 9.74634476e-3, a2 = -3.73234996e-3, a3 = 2.68678472e-4,
                   a4 = 1.58920570e-3, a5 = 2.45934259e-3, a6 = 0.900704920, a7 = -1.66626219e-2;
  constexpr double kLambdaUv = 0.2292020, kLambdaIr = 5.432937;
  const double rho = rho_kg_m3 / 1000.0, t = t_k / 273.15, l = lambda_um / 0.589;
  const double l2 = l * l;
  const double a =
      rho * (a0 + a1 * rho + a2 * t + a3 * l2 * t + a4 / l2 + a5 / (l2 - kLambdaUv * kLambdaUv) +
             a6 / (l2 - kLambdaIr * kLambdaIr) + a7 * rho * rho);
  // Solve (n² − 1)/(n² + 2) = a for n.
  return std::sqrt((1.0 + 2.0 * a) / (1.0 - a));
}

double CiddorStandardAir(double lambda_nm) {
  // Ciddor 1996, Eq. 1: (n − 1)·1e8 = k1/(k0 − σ²) + k3/(k2 − σ²), σ = 1/λ in µm⁻¹.
  const double sigma2 = std::pow(1000.0 / lambda_nm, 2);
  return 1.0 + (5792105.0 / (238.0185 - sigma2) + 167917.0 / (57.362 - sigma2)) * 1e-8;
}

double WaterDensityTanaka2001(double t_c) {
  // Tanaka et al. 2001, Eq. 1: ρ = a5 [1 − (t + a1)² (t + a2) / (a3 (t + a4))], SMOW values.
  constexpr double a1 = -3.983035, a2 = 301.797, a3 = 522528.9, a4 = 69.34881, a5 = 999.974950;
  const double t = t_c;
  return a5 * (1.0 - (t + a1) * (t + a1) * (t + a2) / (a3 * (t + a4)));
}

double Sellmeier(const SellmeierCoefficients& k, double lambda_nm) {
  const double l2 = std::pow(lambda_nm * 1e-3, 2);
  double n2 = 1.0;
  for (int i = 0; i < 3; ++i) {
    if (k.b[i] != 0.0) n2 += k.b[i] * l2 / (l2 - k.c_um2[i]);
  }
  return n2 > 0.0 ? std::sqrt(n2) : kNaN;
}

double UnescoDepthM(double p_dbar, double latitude_deg) {
  // Fofonoff & Millard 1983 (UNESCO Tech. Pap. Mar. Sci. 44), DEPTH: z = (((c4 p + c3) p + c2) p
  // + c1) p / (g(φ) + ½ γ' p), gravity g(φ) = 9.780318 (1 + 5.2788e-3 sin²φ + 2.36e-5 sin⁴φ).
  const double x = std::pow(std::sin(latitude_deg * std::numbers::pi / 180.0), 2);
  const double gr = 9.780318 * (1.0 + (5.2788e-3 + 2.36e-5 * x) * x) + 1.092e-6 * p_dbar;
  const double p = p_dbar;
  return (((-1.82e-15 * p + 2.279e-10) * p - 2.2512e-5) * p + 9.72659) * p / gr;
}

std::optional<std::string> SeawaterNote(std::string_view medium, const Conditions& c) {
  if (Lower(medium) != "seawater" || !(c.salinity_psu > kQfSMax)) return std::nullopt;
  return fmt::format("salinity {:g} PSU is above Quan-Fry's 35: the seawater index uses Quan-Fry at 35 PSU plus "
                     "the Millard-Seaver 1990 salinity term from 35 to {:g} PSU (valid to 43 PSU, 500-700 nm)",
                     c.salinity_psu, c.salinity_psu);
}

double DepthToPressureDbar(double depth_m, double latitude_deg) {
  RequireFinite("depth_m", depth_m);
  RequireFinite("latitude_deg", latitude_deg);
  if (depth_m < 0.0 || depth_m > 12000.0) {
    throw InvalidInput("depth_m", fmt::format("must be in 0..12000 m (got {})", depth_m));
  }
  if (latitude_deg < -90.0 || latitude_deg > 90.0) {
    throw InvalidInput("latitude_deg", fmt::format("must be in -90..90 (got {})", latitude_deg));
  }
  // Newton on z(p) − depth = 0, from p = 1.01·depth; dz/dp > 0.96 m/dbar on 0..12000 m, so a
  // handful of steps reach 1e-9 dbar.
  double p = 1.01 * depth_m;
  for (int i = 0; i < 50; ++i) {
    const double h = 1e-3;
    const double f = UnescoDepthM(p, latitude_deg) - depth_m;
    const double df =
        (UnescoDepthM(p + h, latitude_deg) - UnescoDepthM(p - h, latitude_deg)) / (2.0 * h);
    const double step = f / df;
    p -= step;
    if (std::abs(step) < 1e-9) return p;
  }
  throw InternalError("DepthToPressureDbar: Newton iteration did not converge");
}

double Index(std::string_view medium, const Conditions& c) {
  RequireFinite("lambda_nm", c.lambda_nm);
  RequireFinite("temperature_c", c.temperature_c);
  RequireFinite("salinity_psu", c.salinity_psu);
  RequireFinite("pressure_dbar", c.pressure_dbar);
  if (c.lambda_nm <= 0.0) throw InvalidInput("lambda_nm", "must be > 0");
  if (const Entry* e = Find(Lower(medium))) return e->index(c);
  return ParseConstant(medium);
}

std::string ModelOf(std::string_view medium) {
  if (const Entry* e = Find(Lower(medium))) return e->model;
  ParseConstant(medium);
  return "constant";
}

std::vector<MediumInfo> ListMedia() {
  std::vector<MediumInfo> out;
  for (const Entry& e : Registry()) out.push_back(e.info);
  return out;
}

}  // namespace porthole::materials
