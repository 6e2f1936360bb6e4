"""Proves `porthole simulate` prints the water and air calibrations in the conventions' keys and
units, reproduces the paper's Section 2.3 claims end to end, and writes sweeps and maps."""
import csv
import json
import os

import pytest

from conftest import read_table, run, run_bad

KEYS = ["c_mm", "x0_mm", "y0_mm", "K1", "K2", "K3", "P1", "P2", "rms_um"]


def test_default_system_prints_water_and_air():
    out = run("simulate", "--json").json()
    for medium in ("water", "air"):
        for k in KEYS:
            assert isinstance(out[medium][k], float), (medium, k)
    assert out["units"]["K1"] == "mm^-2" and out["units"]["P1"] == "mm^-1"
    assert out["lens"] == "nikkor-24mm-f2.8d" and out["port"]["name"] == "nimar-ni320"
    assert abs(out["medium"]["index"] - 1.341) < 1e-3  # seawater, 546 nm (Quan-Fry)
    # The pupil sits ahead of the dome centre: pincushion under water (K1 falls), c grows.
    assert out["water"]["K1"] < out["air"]["K1"]
    assert 1.005 < out["water"]["c_mm"] / out["air"]["c_mm"] < 1.03
    assert out["water"]["rms_um"] < 1.0


def test_concentric_dome_is_identity():
    out = run("simulate", "--json", "--port", "nimar-ni320-nominal", "--c", "25").json()
    for medium in ("water", "air"):
        assert abs(out[medium]["c_mm"] - 25) < 1e-8
        for k in ("x0_mm", "y0_mm", "K1", "K2", "K3", "P1", "P2"):
            assert abs(out[medium][k]) < 1e-10, (medium, k)
        assert out[medium]["rms_um"] < 1e-6


def test_pupil_offsets_give_pincushion_barrel_and_decentring():
    def change(offset):
        o = run("simulate", "--json", "--port", "nimar-ni320-nominal", "--ep-offset", offset).json()
        return o["change"]
    assert change("0,0,5")["K1"] < -1e-6      # ahead of the centre: pincushion
    assert change("0,0,-5")["K1"] > 1e-6      # behind: barrel
    lateral = change("1,0,0")
    assert abs(lateral["P1"]) > 1e-6 and abs(lateral["P2"]) < 1e-4 * abs(lateral["P1"])


def test_in_air_calibration_is_carried_to_water():
    # The paper's Table 6 in-air column as the user's calibration (fresh water: a pool).
    t6 = {r["parameter"]: r for r in read_table("menna2016_table6.csv")}
    air = {k: float(t6[k]["air_value"]) for k in ("c_mm", "x0_mm", "y0_mm", "K1", "K2")}
    out = run("simulate", "--json", "--water", "freshwater", "--no-k3",
              "--air-calibration", json.dumps(air)).json()
    pred = out["predicted_water"]
    ratio = pred["c_mm"] / air["c_mm"]
    paper = float(t6["c_mm"]["water_value"]) / float(t6["c_mm"]["air_value"])
    # 0.5 mm of pupil uncertainty moves the ratio by 0.0016 (docs/simulate.md).
    assert abs(ratio - paper) < 0.0032, (ratio, paper)
    assert pred["K1"] < air["K1"]  # less barrel under water, as measured


def test_sweep_and_map_files(tmp_path):
    sweep = tmp_path / "sweep.csv"
    mapf = tmp_path / "map.json"
    out = run("simulate", "--json", "--sweep", "z", "--offsets", "-4,0,4",
              "--sweep-out", sweep, "--map", mapf, "--grid-cols", "9", "--grid-rows", "7").json()
    assert [r["offset_mm"] for r in out["sweep"]] == [-4, 0, 4]
    with open(sweep) as f:
        rows = list(csv.DictReader(line for line in f if not line.startswith("#")))
    dc = [float(r["dc_mm"]) for r in rows]
    assert dc[0] < dc[1] < dc[2]  # further ahead of the centre: the view narrows, c grows
    grid = json.loads(mapf.read_text())
    assert len(grid) == 63
    corner = grid[0]
    assert abs(corner["difference"]["dx_um"] - (corner["water"]["dx_um"] - corner["air"]["dx_um"])) < 1e-9


def test_text_output_and_help():
    res = run("simulate")
    assert "water (fitted)" in res.out and "c water/air" in res.out
    assert "--ep-offset" in run("simulate", "--help").out


def test_bad_input_is_one_line(tmp_path):
    assert "--ep-offset" in run_bad("simulate", "--ep-offset", "1,2")
    assert "--air-calibration" in run_bad("simulate", "--air-calibration", '{"c_mm": 25.8, "k1": 1}')
    assert "--focus-distance" in run_bad("simulate", "--focus-distance", "50")
    assert "--offsets" in run_bad("simulate", "--offsets", "1,2")
    target = tmp_path / "missing" / "m.csv"
    run_bad("simulate", "--map", target)
    assert not os.path.exists(target)


def test_fisheye_is_fitted_with_kannala_brandt():
    # Behind a dome centred on the pupil the equisolid fisheye's rays pass undeviated: water and air
    # give its own projection, whose series 2 sin(t/2) = t - t^3/24 + ... sets k1 = -1/24.
    out = run("simulate", "--lens", "nikkor-10.5mm-f2.8g-fisheye", "--port", "nimar-ni320-nominal", "--json").json()
    assert out["model"] == "kannala-brandt" and out["lens_projection"] == "equisolid"
    for medium in ("water", "air"):
        assert out[medium]["k1"] == pytest.approx(-1 / 24, abs=1e-5)
        assert out[medium]["rms_px"] < 1e-3
    assert "Kannala-Brandt" in run("simulate", "--lens", "nikkor-10.5mm-f2.8g-fisheye").out
    # Concentric: the lens keeps its projection in water, so the radial profile (against it) is 0.
    assert out["c_ratio_water_air"] == pytest.approx(1, abs=1e-6)
    assert max(abs(row["change_um"]) for row in out["radial_profile"]) < 0.05


def test_fisheye_sweep_and_map(tmp_path):
    # Sweeps and maps read the Kannala-Brandt fit. About the centre of a concentric dome the change
    # is odd in the pupil offset, and at offset 0 it vanishes (the lens keeps its projection).
    mapf = tmp_path / "map.csv"
    out = run("simulate", "--lens", "nikkor-10.5mm-f2.8g-fisheye", "--port", "nimar-ni320-nominal", "--json",
              "--sweep", "z", "--offsets", "-1,0,1", "--map", mapf, "--grid-cols", "9", "--grid-rows", "7").json()
    minus, zero, plus = out["sweep"]
    assert abs(zero["c_ratio_water_air"] - 1) < 1e-6
    assert (plus["c_ratio_water_air"] - 1) == pytest.approx(-(minus["c_ratio_water_air"] - 1), rel=0.1)
    assert abs(plus["c_ratio_water_air"] - 1) > 1e-4
    assert "k4" in plus["water"] and "K1" not in plus["water"]  # the fisheye fit, not Brown's
    with open(mapf) as f:
        rows = [line for line in f if line[0].isdigit() or line[0] == "-"]
    assert len(rows) == 63
    assert max(abs(float(r.split(",")[12])) for r in rows) < 0.05  # difference water - air, um


def test_fisheye_air_calibration_is_the_base_of_the_prediction(tmp_path):
    # A Kannala-Brandt calibration in air (COLMAP OPENCV_FISHEYE: its pixel centres sit at +0.5, so
    # porthole's cx, cy are 0.5 less), decentred and distorted. Behind a dome centred on the pupil the
    # rays pass undeviated: the predicted underwater calibration is the calibration itself.
    cal = tmp_path / "cameras.txt"
    cal.write_text("1 OPENCV_FISHEYE 4288 2848 2010.0 2012.0 2156.3 1416.9 -0.0377 0.0003 0.0001 -0.00002\n")
    want = {"fx_px": 2010.0, "fy_px": 2012.0, "cx_px": 2155.8, "cy_px": 1416.4, "k1": -0.0377, "k2": 0.0003, "k3": 0.0001,
            "k4": -0.00002}
    lens = ("--lens", "nikkor-10.5mm-f2.8g-fisheye")
    out = run("simulate", *lens, "--port", "nimar-ni320-nominal", "--air-calibration", cal, "--json").json()
    assert out["air_calibration"]["model"] == "kannala-brandt"
    for k, v in want.items():
        assert out["air_calibration"][k] == pytest.approx(v, abs=1e-12), k
        assert out["predicted_water"][k] == pytest.approx(v, abs=1e-4 if k[0] in "fc" else 1e-7), k
    # Behind the as-built NI320 (pupil 5.4 mm off the centre) the focal length changes under water
    # as the Kannala-Brandt fit of the lens's own projection says (the same within 1e-3).
    built = run("simulate", *lens, "--air-calibration", cal, "--json").json()
    plain = run("simulate", *lens, "--json").json()
    ratio = built["predicted_water"]["fx_px"] / built["air_calibration"]["fx_px"]
    assert abs(ratio - 1) > 0.01
    assert ratio == pytest.approx(plain["water"]["fx_px"] / plain["air"]["fx_px"], abs=1e-3)
    # A Brown calibration cannot describe a fisheye; a fisheye calibration is no rectilinear lens's.
    assert "Kannala-Brandt" in run_bad("simulate", *lens, "--air-calibration", '{"c_mm": 10.5}')
    assert "--air-calibration" in run_bad("simulate", "--air-calibration", cal)


def test_same_camera_and_lens_names_as_plan():
    # A lensfun lens name and a fixed-lens camera work as in `porthole plan`.
    out = run("simulate", "--lens", "Nikon AF DX Fisheye-Nikkor 10.5mm f/2.8G ED", "--json").json()
    assert out["model"] == "kannala-brandt"
    assert run("simulate", "--camera", "gopro-hero4-black", "--port", "flat-acrylic-10mm", "--json").json()["model"] == \
        "kannala-brandt"
