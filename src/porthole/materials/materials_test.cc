// Proves that every index model reproduces its published check values, that the models agree with
// each other and with physics where they overlap, and that bad or out-of-range input is refused.
#include "porthole/materials/materials.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <set>
#include <string>

#include "porthole/core/error.h"

namespace porthole::materials {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

Conditions At(double lambda_nm, double t_c = 20.0, double s_psu = 35.0, double p_dbar = 0.0,
              bool extrapolate = false) {
  Conditions c;
  c.lambda_nm = lambda_nm;
  c.temperature_c = t_c;
  c.salinity_psu = s_psu;
  c.pressure_dbar = p_dbar;
  c.extrapolate = extrapolate;
  return c;
}

// Runs Index() and returns the field of the InvalidInput it throws ("" if it does not throw).
std::string FieldOfError(std::string_view medium, const Conditions& c) {
  try {
    Index(medium, c);
  } catch (const InvalidInput& e) {
    return e.field();
  }
  return "";
}

// ---- Water and seawater: published check values ----

TEST(QuanFry, SeawaterAtThePaperConditionsIsAbout1341) {
  // Quan & Fry 1995 at 20 °C, 35 ‰, 546.07 nm: 1.3409; the paper's Table 5 (Menna et al. 2016)
  // needs a water index of about 1.341 (docs/conventions.md).
  EXPECT_NEAR(QuanFry(20.0, 35.0, 546.07), 1.3409, 1e-4);
  EXPECT_NEAR(Index("seawater"), 1.341, 2e-4);  // default conditions are the paper's
}

TEST(FreshWater, AllThreeModelsGiveTheStandardSodiumDValueAt20C) {
  // n_D of pure water at 20 °C and 589.3 nm is 1.33299 (ICUMSA 1974 refractometer scale, zero
  // Brix). Three independent fits (Austin & Halikas data for Quan–Fry, Tilton & Taylor for
  // Millard–Seaver, the IAPWS data set) must all reproduce it.
  const Conditions c = At(589.3, 20.0, 0.0);
  EXPECT_NEAR(Index("freshwater", c), 1.33299, 3e-5);
  EXPECT_NEAR(Index("water-iapws", c), 1.33299, 3e-5);
  EXPECT_NEAR(Index("seawater-millard-seaver", c), 1.33299, 3e-5);
}

TEST(Iapws, ReproducesTheReleaseCheckValues) {
  // IAPWS R9-97, Table 3 (absolute index, to 1e-8).
  EXPECT_NEAR(IapwsR997Absolute(298.15, 997.047435, 0.5893), 1.33285819, 1e-8);
  EXPECT_NEAR(IapwsR997Absolute(298.15, 997.047435, 0.2265), 1.39277824, 1e-8);
  EXPECT_NEAR(IapwsR997Absolute(773.15, 30.4758534, 0.5893), 1.00949307, 1e-8);
}

TEST(Iapws, IndexIsRelativeToCiddorStandardAir) {
  const double n_abs = IapwsR997Absolute(298.15, WaterDensityTanaka2001(25.0), 0.5893);
  EXPECT_DOUBLE_EQ(Index("water-iapws", At(589.3, 25.0)), n_abs / CiddorStandardAir(589.3));
  // Standard air: n − 1 ≈ 2.77e-4 in the visible (Ciddor 1996), so relative < absolute.
  EXPECT_GT(CiddorStandardAir(589.3) - 1.0, 2.7e-4);
  EXPECT_LT(CiddorStandardAir(589.3) - 1.0, 2.8e-4);
}

TEST(Tanaka2001, ReproducesThePublishedDensityTable) {
  // Tanaka et al. 2001, Metrologia 38:301, Table of SMOW density at 101 325 Pa (kg/m³).
  EXPECT_NEAR(WaterDensityTanaka2001(0.0), 999.8428, 1e-4);
  EXPECT_NEAR(WaterDensityTanaka2001(4.0), 999.9750, 1e-4);
  EXPECT_NEAR(WaterDensityTanaka2001(20.0), 998.2067, 1e-4);
  EXPECT_NEAR(WaterDensityTanaka2001(25.0), 997.0470, 1e-4);
  EXPECT_NEAR(WaterDensityTanaka2001(40.0), 992.2152, 1e-4);
  // The maximum is at −a1 = 3.983035 °C, where ρ = a5.
  EXPECT_NEAR(WaterDensityTanaka2001(3.983035), 999.974950, 1e-9);
  // IAPWS-95 at 25 °C, 0.1 MPa (the density of the R9-97 check value) agrees to 5e-4 kg/m³.
  EXPECT_NEAR(WaterDensityTanaka2001(25.0), 997.047435, 5e-4);
}

// docs/materials.md: "Quan–Fry and IAPWS agree within 4e-5 over 0–30 °C and 400–700 nm" (the two
// fits of independent data sets; 3.5e-5 at worst).
TEST(QuanFryVsIapws, FreshWaterAgreesWithin4e5InTheCommonRange) {
  for (double t = 0.0; t <= 30.0; t += 5.0) {
    for (double lambda = 400.0; lambda <= 700.0; lambda += 25.0) {
      const Conditions c = At(lambda, t, 0.0);
      EXPECT_NEAR(Index("freshwater", c), Index("water-iapws", c), 4e-5)
          << "T " << t << " lambda " << lambda;
    }
  }
}

TEST(MillardSeaver, PureWaterAgreesWithIapwsWithin3e5) {
  // Region I of Millard–Seaver fits Tilton & Taylor 1938 to 0.12 ppm; IAPWS R9-97 fits the same
  // data. This also decides the disputed T3L digit: with T3L = −1.705881e-10 the 30 °C difference
  // would be 4e-5.
  for (double t = 0.0; t <= 30.0; t += 5.0) {
    for (double lambda = 500.0; lambda <= 700.0; lambda += 25.0) {
      EXPECT_NEAR(MillardSeaver(t, 0.0, 0.0, lambda), Index("water-iapws", At(lambda, t)), 3e-5)
          << "T " << t << " lambda " << lambda;
    }
  }
}

TEST(MillardSeaver, SeawaterAgreesWithQuanFryAtSurfacePressure) {
  // Independent fits (Mehu & Johannin-Gilles vs Austin & Halikas data) agree to ~1e-4.
  for (double t = 0.0; t <= 30.0; t += 10.0) {
    for (double s = 0.0; s <= 35.0; s += 17.5) {
      EXPECT_NEAR(MillardSeaver(t, s, 0.0, 546.07), QuanFry(t, s, 546.07), 1e-4)
          << "T " << t << " S " << s;
    }
  }
}

TEST(MillardSeaver, PressureCoefficientIsThatOfWater) {
  // dn/dP of water is about 1.4–1.7e-6 per dbar: Lorentz–Lorenz with the isothermal
  // compressibility of water (4.6e-10 Pa⁻¹ at 20 °C, 5.1e-10 at 0 °C) gives 1.7–1.9e-6 per dbar,
  // an upper bound (the Lorentz–Lorenz function of water grows slightly with compression). A wrong
  // unit (bar or kg/cm²) would be off by 10×. Evaluated over the first 100 dbar.
  for (double t = 0.0; t <= 30.0; t += 10.0) {
    for (double s : {0.0, 35.0}) {
      const double dndp = (Index("seawater-millard-seaver", At(589.3, t, s, 100.0)) -
                           Index("seawater-millard-seaver", At(589.3, t, s, 0.0))) /
                          100.0;
      EXPECT_GT(dndp, 1.35e-6) << "T " << t << " S " << s;
      EXPECT_LT(dndp, 1.7e-6) << "T " << t << " S " << s;
    }
  }
  const double cold =
      (MillardSeaver(2.0, 35.0, 100.0, 546.07) - MillardSeaver(2.0, 35.0, 0.0, 546.07)) / 100.0;
  EXPECT_GT(cold, 1.5e-6);  // cold seawater, as in the deep ocean
  EXPECT_LT(cold, 1.7e-6);
}

TEST(Seawater, PressureTermIsAddedToQuanFry) {
  const Conditions deep = At(546.07, 5.0, 35.0, 4000.0);
  const double expected = QuanFry(5.0, 35.0, 546.07) + MillardSeaver(5.0, 35.0, 4000.0, 546.07) -
                          MillardSeaver(5.0, 35.0, 0.0, 546.07);
  EXPECT_DOUBLE_EQ(Index("seawater", deep), expected);
  EXPECT_GT(Index("seawater", deep), Index("seawater", At(546.07, 5.0, 35.0, 0.0)) + 5e-3);
  EXPECT_DOUBLE_EQ(Index("seawater", At(546.07, 5.0, 35.0, 0.0)), QuanFry(5.0, 35.0, 546.07));
}

// ---- Trends ----

TEST(Trends, SeawaterIsDenserOpticallyThanFreshWater) {
  for (double t = 0.0; t <= 30.0; t += 5.0) {
    for (double lambda = 400.0; lambda <= 700.0; lambda += 50.0) {
      EXPECT_GT(Index("seawater", At(lambda, t, 35.0)), Index("freshwater", At(lambda, t)) + 5e-3);
    }
  }
}

TEST(Trends, WaterIndexFallsWithTemperatureAbove4C) {
  for (const char* medium : {"seawater", "freshwater", "water-iapws", "seawater-millard-seaver"}) {
    for (double t = 5.0; t < 30.0; t += 1.0) {
      EXPECT_LT(Index(medium, At(546.07, t + 1.0)), Index(medium, At(546.07, t)))
          << medium << " T " << t;
    }
  }
}

TEST(Trends, NormalDispersionEverywhereInRange) {
  for (const MediumInfo& m : ListMedia()) {
    if (std::isnan(m.lambda_min_nm)) continue;  // air
    const double step = (m.lambda_max_nm - m.lambda_min_nm) / 40.0;
    for (double lambda = m.lambda_min_nm; lambda + step <= m.lambda_max_nm; lambda += step) {
      EXPECT_LT(Index(m.name, At(lambda + step)), Index(m.name, At(lambda)))
          << m.name << " at " << lambda << " nm";
    }
  }
}

// ---- Glasses and crystals: catalogue and published values (relative to air) ----

TEST(Glasses, NBk7MatchesTheSchottCatalogue) {
  EXPECT_NEAR(Index("n-bk7", At(587.56)), 1.51680, 2e-5);  // n_d
  EXPECT_NEAR(Index("n-bk7", At(546.07)), 1.51872, 2e-5);  // n_e
  EXPECT_NEAR(Index("n-bk7", At(486.13)), 1.52238, 2e-5);  // n_F
  EXPECT_NEAR(Index("n-bk7", At(656.27)), 1.51432, 2e-5);  // n_C
}

TEST(Glasses, FusedSilicaMatchesMalitson1965) {
  EXPECT_NEAR(Index("fused-silica", At(587.56)), 1.45846, 2e-5);  // Malitson's n_d
}

TEST(Glasses, PlasticsMatchPublishedSodiumValues) {
  // Sultanova et al. 2009: n_D of PMMA 1.4905, of polycarbonate 1.5846 (data sheets: 1.585).
  EXPECT_NEAR(Index("pmma", At(589.3)), 1.4905, 1e-4);
  EXPECT_NEAR(Index("acrylic", At(589.3)), Index("pmma", At(589.3)), 0.0);
  EXPECT_NEAR(Index("polycarbonate", At(589.3)), 1.585, 5e-4);
}

TEST(Glasses, SapphireOrdinaryRayMatchesMalitsonDodge) {
  // Ordinary index 1.76804 at 590 nm (tabulated, Valley Design sapphire data after Malitson);
  // about 1.7681 at the sodium D line.
  EXPECT_NEAR(Index("sapphire-o", At(590.0)), 1.76804, 3e-5);
  EXPECT_NEAR(Index("sapphire-o", At(589.3)), 1.7681, 1e-4);
}

// ---- Air and constants ----

TEST(Air, IsExactlyOneAtAnyWavelength) {
  for (double lambda : {200.0, 546.07, 10000.0}) EXPECT_EQ(Index("air", At(lambda)), 1.0);
}

TEST(Constant, NumberStringIsAConstantIndex) {
  EXPECT_EQ(Index("1.341"), 1.341);
  EXPECT_EQ(Index("1.49", At(900.0, 80.0)), 1.49);  // no range: conditions are irrelevant
  EXPECT_EQ(Index("1"), 1.0);
  EXPECT_EQ(ModelOf("1.341"), "constant");
  for (const char* bad : {"0.99", "-1.5", "nan", "inf", "1.3x", "", "unobtainium"}) {
    try {
      Index(bad);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const InvalidInput& e) {
      EXPECT_EQ(e.field(), "medium") << bad;
    }
  }
}

TEST(Names, AreCaseInsensitiveAndListed) {
  EXPECT_EQ(Index("SeaWater"), Index("seawater"));
  std::set<std::string> names;
  for (const MediumInfo& m : ListMedia()) {
    EXPECT_TRUE(names.insert(m.name).second) << "duplicate " << m.name;
    EXPECT_FALSE(m.description.empty());
    EXPECT_FALSE(ModelOf(m.name).empty());
  }
  for (const char* name :
       {"air", "seawater", "freshwater", "water-iapws", "seawater-millard-seaver", "n-bk7",
        "fused-silica", "pmma", "polycarbonate", "sapphire-o"}) {
    EXPECT_EQ(names.count(name), 1u) << name;
  }
}

// ---- Ranges, extrapolation and bad input ----

TEST(Ranges, OutOfRangeInputNamesTheField) {
  EXPECT_EQ(FieldOfError("seawater", At(350.0)), "lambda_nm");
  EXPECT_EQ(FieldOfError("seawater", At(546.07, 35.0)), "temperature_c");
  EXPECT_EQ(FieldOfError("seawater", At(546.07, -1.0)), "temperature_c");
  EXPECT_EQ(FieldOfError("seawater", At(546.07, 20.0, 44.0)), "salinity_psu");  // beyond Millard-Seaver's 43
  EXPECT_EQ(FieldOfError("seawater", At(450.0, 20.0, 38.0)), "lambda_nm");  // the 35-43 term is 500-700 nm
  EXPECT_EQ(FieldOfError("seawater", At(546.07, 20.0, 35.0, 12000.0)), "pressure_dbar");
  EXPECT_EQ(FieldOfError("seawater", At(546.07, 20.0, 35.0, -5.0)), "pressure_dbar");
  // With pressure the Millard–Seaver term restricts the wavelength to 500–700 nm.
  EXPECT_EQ(FieldOfError("seawater", At(450.0, 20.0, 35.0, 0.0)), "");
  EXPECT_EQ(FieldOfError("seawater", At(450.0, 20.0, 35.0, 100.0)), "lambda_nm");
  EXPECT_EQ(FieldOfError("freshwater", At(546.07, 20.0, 99.0)), "");  // salinity not used
  EXPECT_EQ(FieldOfError("water-iapws", At(546.07, 45.0)), "temperature_c");
  EXPECT_EQ(FieldOfError("water-iapws", At(1200.0)), "lambda_nm");
  EXPECT_EQ(FieldOfError("water-iapws", At(546.07, 20.0, 0.0, 10.0)), "pressure_dbar");
  EXPECT_EQ(FieldOfError("seawater-millard-seaver", At(450.0)), "lambda_nm");
  EXPECT_EQ(FieldOfError("seawater-millard-seaver", At(546.07, 20.0, 44.0)), "salinity_psu");
  EXPECT_EQ(FieldOfError("n-bk7", At(250.0)), "lambda_nm");
  EXPECT_EQ(FieldOfError("n-bk7", At(546.07, 99.0, 99.0, 99999.0)), "");  // glass: only λ
  EXPECT_EQ(FieldOfError("pmma", At(400.0)), "lambda_nm");
}

TEST(Ranges, MessageStatesTheRange) {
  try {
    Index("seawater", At(350.0));
    FAIL();
  } catch (const InvalidInput& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("lambda_nm"), std::string::npos) << what;
    EXPECT_NE(what.find("400..700"), std::string::npos) << what;
  }
}

TEST(Ranges, ExtrapolateAllowsUseOutsideTheRange) {
  Conditions c = At(350.0, 35.0, 30.0, 0.0, /*extrapolate=*/true);
  const double n = Index("seawater", c);
  EXPECT_TRUE(std::isfinite(n));
  EXPECT_DOUBLE_EQ(n, QuanFry(35.0, 30.0, 350.0));
  EXPECT_GT(Index("n-bk7", At(250.0, 20, 35, 0, true)), Index("n-bk7", At(300.0)));
  EXPECT_GT(Index("seawater", At(450.0, 20.0, 35.0, 100.0, true)), Index("seawater", At(450.0)));
  EXPECT_NO_THROW(Index("seawater-millard-seaver", At(450.0, 20.0, 35.0, 0.0, true)));
}

// Issue 12: `--salinity 38` (the Mediterranean, where the paper worked) failed because Quan–Fry stops
// at 35 ‰. Above 35 the seawater index continues by the Millard–Seaver salinity term (valid to
// 43 ‰): continuous at 35, within 1e-4 of the independent Millard–Seaver model itself (as at
// 35 ‰), rising with salinity at Millard–Seaver's rate, with a note saying so.
TEST(Ranges, MediterraneanSalinityUsesTheMillardSeaverSalinityTerm) {
  for (double t : {13.0, 20.0, 26.0}) {
    for (double lambda : {500.0, 546.07, 650.0}) {
      const double at35 = Index("seawater", At(lambda, t, 35.0));
      EXPECT_NEAR(Index("seawater", At(lambda, t, 35.0 + 1e-9)), at35, 1e-12);
      double prev = at35;
      for (double s : {36.0, 38.0, 40.0, 43.0}) {
        const double n = Index("seawater", At(lambda, t, s));
        EXPECT_NEAR(n, MillardSeaver(t, s, 0, lambda), 1e-4) << t << " " << lambda << " " << s;
        EXPECT_NEAR(n - at35, MillardSeaver(t, s, 0, lambda) - MillardSeaver(t, 35.0, 0, lambda), 1e-12);
        EXPECT_GT(n, prev);
        prev = n;
      }
    }
  }
  // The Mediterranean (38 ‰, 20 °C, e line): about 1.9e-4 per ‰ above the 35 ‰ value.
  const double med = Index("seawater", At(546.07, 20.0, 38.0));
  EXPECT_NEAR((med - Index("seawater", At(546.07, 20.0, 35.0))) / 3, 1.9e-4, 0.2e-4);
  EXPECT_TRUE(SeawaterNote("seawater", At(546.07, 20.0, 38.0)).has_value());
  EXPECT_FALSE(SeawaterNote("seawater", At(546.07, 20.0, 35.0)).has_value());
  EXPECT_FALSE(SeawaterNote("freshwater", At(546.07, 20.0, 38.0)).has_value());
}

TEST(Ranges, ExtrapolatingPastASellmeierPoleIsRefused) {
  // PMMA's single resonance is at sqrt(0.011313) µm = 106 nm; below it n² < 0.
  EXPECT_EQ(FieldOfError("pmma", At(100.0, 20, 35, 0, true)), "lambda_nm");
}

TEST(Ranges, NaNIsAlwaysRefused) {
  for (bool extrapolate : {false, true}) {
    EXPECT_EQ(FieldOfError("seawater", At(kNaN, 20, 35, 0, extrapolate)), "lambda_nm");
    EXPECT_EQ(FieldOfError("seawater", At(546.07, kNaN, 35, 0, extrapolate)), "temperature_c");
    EXPECT_EQ(FieldOfError("seawater", At(546.07, 20, kNaN, 0, extrapolate)), "salinity_psu");
    EXPECT_EQ(FieldOfError("seawater", At(546.07, 20, 35, kNaN, extrapolate)), "pressure_dbar");
    EXPECT_EQ(FieldOfError("n-bk7", At(546.07, kNaN, 35, 0, extrapolate)), "temperature_c");
    EXPECT_EQ(FieldOfError("air", At(kNaN, 20, 35, 0, extrapolate)), "lambda_nm");
  }
  EXPECT_EQ(FieldOfError("seawater", At(-500.0, 20, 35, 0, true)), "lambda_nm");
}

// ---- Depth to pressure ----

TEST(Depth, UnescoFormulaCheckValue) {
  // Fofonoff & Millard 1983, UNESCO Tech. Pap. Mar. Sci. 44: 10000 dbar at 30° is 9712.653 m.
  EXPECT_NEAR(UnescoDepthM(10000.0, 30.0), 9712.653, 1e-3);
  EXPECT_NEAR(DepthToPressureDbar(9712.653, 30.0), 10000.0, 1e-3);
}

TEST(Depth, ThousandMetresAt45DegreesIsAbout1010Dbar) {
  EXPECT_NEAR(DepthToPressureDbar(1000.0), 1010.0, 1.0);
  EXPECT_EQ(DepthToPressureDbar(0.0), 0.0);
  // UNESCO 1983 table (p. 30): 500 dbar at 45° is 495.34 m.
  EXPECT_NEAR(DepthToPressureDbar(495.34, 45.0), 500.0, 0.01);
}

// docs/materials.md: "the error of ignoring latitude is under 0.3 %": gravity grows by 0.53 % from
// the equator to the pole, so the pressure at a depth is within ±0.27 % of its 45° value.
TEST(Depth, IgnoringLatitudeErrsByLessThan0p3Percent) {
  for (double depth_m : {10.0, 1000.0, 10000.0}) {
    const double at45 = DepthToPressureDbar(depth_m);
    for (double lat : {0.0, 30.0, 60.0, 90.0}) {
      EXPECT_LT(std::abs(DepthToPressureDbar(depth_m, lat) / at45 - 1), 0.003) << depth_m << " m at " << lat;
    }
    EXPECT_GT(std::abs(DepthToPressureDbar(depth_m, 0.0) / at45 - 1), 0.002) << depth_m;  // not trivially 0
  }
}

TEST(Depth, BadInputIsRefused) {
  EXPECT_THROW(DepthToPressureDbar(-1.0), InvalidInput);
  EXPECT_THROW(DepthToPressureDbar(kNaN), InvalidInput);
  EXPECT_THROW(DepthToPressureDbar(13000.0), InvalidInput);
  EXPECT_THROW(DepthToPressureDbar(10.0, 91.0), InvalidInput);
  try {
    DepthToPressureDbar(-1.0);
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "depth_m");
  }
}

}  // namespace
}  // namespace porthole::materials
