"""Proves porthole.simulate() gives the same physics as the library from Python: identity behind a
concentric dome, pincushion for a pupil ahead of the centre, the paper's in-air calibration carried
to water, sweeps and maps, and ValueError naming the field."""
import pytest

import porthole


def test_concentric_dome_is_identity():
    out = porthole.simulate(port="nimar-ni320-nominal", c_mm=25.0)
    for medium in ("water", "air"):
        fit = getattr(out, medium)
        assert fit.c_mm == pytest.approx(25.0, abs=1e-8)
        assert abs(fit.K1) < 1e-12 and fit.rms_um < 1e-6


def test_pupil_ahead_gives_pincushion_and_sweep():
    out = porthole.simulate(port="nimar-ni320-nominal", ep_offset_mm=(0, 0, 5), sweep_axis="x",
                            offsets_mm=[0.0, 1.0], with_map=True, grid_cols=9, grid_rows=7)
    assert out.change.K1 < -1e-6
    assert abs(out.sweep[1].water.P1) > abs(out.sweep[0].water.P1) + 1e-7
    assert len(out.map) == 63


def test_paper_air_calibration_predicts_less_barrel():
    air = {"c_mm": 25.801, "x0_mm": -0.026, "y0_mm": -0.144, "K1": 1.842e-4, "K2": -3.030e-7}
    out = porthole.simulate(air_calibration=air, water="freshwater", fit_k3=False)
    pred = out.predicted_water
    assert 1.01 < pred.c_mm / air["c_mm"] < 1.02  # Table 6: 1.0158
    assert pred.K1 < air["K1"]


def test_errors_name_the_field():
    with pytest.raises(ValueError, match="air_calibration.k1"):
        porthole.simulate(air_calibration={"c_mm": 25.8, "k1": 1e-4})
    with pytest.raises(ValueError, match="sweep_axis"):
        porthole.simulate(sweep_axis="w")
    with pytest.raises(TypeError):
        porthole.simulate(fucus_distance_mm=1000)
