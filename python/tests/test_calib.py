"""Proves the calib bindings: a known camera is recovered from synthetic detections within 3 sigma,
the chi2 comparison accepts the same camera and rejects a changed one, and bad input raises
ValueError naming the field."""
import math
import os

import numpy as np
import pytest

import porthole

# The paper's in-water calibration (Table 6, UW) on a Nikon D300 (4288 x 2848 px, 5.5 um).
TRUTH = {"c_mm": 26.208, "x0_mm": -0.058, "y0_mm": -0.207, "K1": 1.663e-4, "K2": -2.582e-7,
         "P1": 6.582e-6, "P2": 1.620e-5}
SENSOR = dict(width_px=4288, height_px=2848, pixel_pitch_mm=0.0055)


def calibrate(camera, seed):
    dets = porthole.synthetic_detections(camera, **SENSOR, seed=seed)
    return porthole.calibrate(dets, "chessboard:13x9:40", pixel_pitch_mm=0.0055, reject_k=0)


def test_recovers_known_camera():
    r = calibrate(TRUTH, 2)
    assert r.status == porthole.Status.OK and r.sigma0_px == pytest.approx(0.3, rel=0.05)
    assert r.model == porthole.CameraModel.BROWN
    for k, v in TRUTH.items():
        assert abs(r.params[k] - v) < 3 * r.sigma[k], k
    # Not adjusted: K3 fixed at 0, no sigma; the covariance is over the adjusted parameters only.
    assert r.params["K3"] == 0.0 and math.isnan(r.sigma["B1"]) and "K3" not in r.adjusted
    assert r.covariance.shape == (7, 7) and np.allclose(np.sqrt(np.diag(r.covariance)),
                                                        [r.sigma[k] for k in r.adjusted], rtol=1e-6)


def test_compare_same_and_changed_camera():
    a = calibrate(TRUTH, 2)
    same = porthole.compare(a, calibrate(TRUTH, 3))
    assert same.dof == 7 and same.p_value > 0.01
    changed = porthole.compare(a, calibrate(dict(TRUTH, c_mm=TRUTH["c_mm"] + 0.03), 3))
    assert changed.significant and changed.p_value < 1e-6


def test_bad_input():
    dets = porthole.synthetic_detections(TRUTH, **SENSOR)
    with pytest.raises(ValueError, match="free"):
        porthole.calibrate(dets, "chessboard:13x9:40", free="c,k1")
    with pytest.raises(ValueError, match="target"):
        porthole.calibrate(dets, "chessboard:13x9")
    with pytest.raises(ValueError, match="^detections:"):
        porthole.calibrate(dets[:2], "chessboard:13x9:40")
    with pytest.raises(TypeError):
        porthole.calibrate(dets, "chessboard:13x9:40", pitch=1)


CODED = "coded:12:7:metashape"


def test_calibrate_images_with_a_field_matches_the_cli(tmp_path):
    """calibrate_images(..., field=...) is `porthole calibrate --images --field`: four renders of the
    default coded:12:7:metashape sheet, the field that sheet's field file without its first three
    targets (then ignored); the same camera (1e-9 relative), sigma and field block as the CLI's JSON."""
    from test_notebook import ROOT, cli, cli_json
    camera = os.path.join(ROOT, "tests", "cli", "small-dx.toml")  # the CLI tests' small camera
    images = tmp_path / "images"
    images.mkdir()
    for k, tilt in enumerate(["0,0", "30,0", "0,30", "-25,-25"]):
        cli("render", "--out", images / f"view{k}.png", "--camera", camera, "--target", CODED,
            "--medium", "air", "--distance", 420, "--tilt", tilt, "--f-number", "inf", "--bands", 546.07,
            "--spp", 4, "--quiet")
    cli("target-sheet", tmp_path / "sheet.svg", "--bits", 12, "--radius-mm", 7, "--profile", "metashape",
        "--field", tmp_path / "sheet.txt")
    lines = (tmp_path / "sheet.txt").read_text().splitlines()
    data = [i for i, line in enumerate(lines) if line and not line.startswith("#")]
    field = tmp_path / "field.txt"
    field.write_text("\n".join(line for i, line in enumerate(lines) if i not in data[:3]) + "\n")
    result = porthole.calibrate_images(images, CODED, field=field, free="c,x0,y0,K1")
    ours = result.to_dict()
    theirs = cli_json("calibrate", "--images", images, "--target", CODED, "--field", field, "--free", "c,x0,y0,K1",
                      "--quiet")
    assert ours["field"] == theirs["field"] and ours["field"]["n_points"] == len(data) - 3
    assert ours["n_points"] == theirs["n_points"] > 0
    for key, value in theirs["camera"].items():
        if value is not None:
            assert ours["camera"][key] == pytest.approx(value, rel=1e-9), key
            assert ours["sigma"][key] == pytest.approx(theirs["sigma"][key], rel=1e-6), key
    assert ours["sigma0_px"] == pytest.approx(theirs["sigma0_px"], rel=1e-9)
    # The centre correction (on for coded targets) as the typed result reads it from the JSON.
    assert result.dot_radius_mm == theirs["dot_radius_mm"] == 7
    assert result.max_centre_offset_px == pytest.approx(theirs["max_centre_offset_px"], rel=1e-6)
    assert result.max_centre_offset_px > 0
    with pytest.raises(ValueError, match="field"):
        porthole.calibrate_images(images, "chessboard:9x6:25", field=field)
