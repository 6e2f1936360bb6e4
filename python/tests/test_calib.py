"""Proves the calib bindings: a known camera is recovered from synthetic detections within 3 sigma,
the chi2 comparison accepts the same camera and rejects a changed one, and bad input raises
ValueError naming the field."""
import math

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
