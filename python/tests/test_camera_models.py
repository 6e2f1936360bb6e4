"""Proves the camera-model list against OpenCV, a real client: porthole's opencv model projects as
cv2.projectPoints (k1 k2 p1 p2 k3 k4 k5 k6) and its kannala-brandt model as cv2.fisheye.projectPoints,
to 1e-6 px; and a synthetic Kannala-Brandt calibration seen to 80 deg off axis reaches the same RMS
(within 1 %) as cv2.fisheye.calibrate on the same points."""
import math

import numpy as np
import pytest

import porthole

cv2 = pytest.importorskip("cv2")

SENSOR = dict(width_px=4288, height_px=2848, pixel_pitch_mm=0.0055)


def points_over_field(max_deg, n=400, seed=1):
    rng = np.random.default_rng(seed)
    theta = np.radians(max_deg) * np.sqrt(rng.uniform(0, 1, n))
    phi = rng.uniform(0, 2 * math.pi, n)
    rng_mm = rng.uniform(300, 3000, n)
    return np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], 1) * rng_mm[:, None]


def test_model_list_is_exposed():
    names = [m.name for m in porthole.camera_models()]
    assert names[:3] == ["brown", "opencv", "kannala-brandt"]
    assert names == [m.value for m in porthole.CameraModel]  # the enum is the whole list
    kb = porthole.camera_models()[2]
    assert kb.fisheye and kb.parameters.key[:4] == ["fx_px", "fy_px", "cx_px", "cy_px"]


def test_opencv_model_projects_as_cv2_projectPoints():
    cam = {"model": "opencv", "fx_px": 4690, "fy_px": 4692, "cx_px": 2150, "cy_px": 1420, "k1": -0.1,
           "k2": 0.05, "p1": 1e-4, "p2": -2e-4, "k3": -0.01, "k4": 0.02, "k5": 0.005, "k6": 0.001}
    pts = points_over_field(28)
    ours = porthole.project(cam, pts, **SENSOR)
    k = np.array([[cam["fx_px"], 0, cam["cx_px"]], [0, cam["fy_px"], cam["cy_px"]], [0, 0, 1]], float)
    d = np.array([cam[x] for x in ["k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"]], float)
    theirs, _ = cv2.projectPoints(pts.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), k, d)
    assert np.max(np.abs(ours - theirs.reshape(-1, 2))) < 1e-6


def test_kannala_brandt_projects_as_cv2_fisheye():
    cam = {"model": "kannala-brandt", "fx_px": 1909, "fy_px": 1911, "cx_px": 2150, "cy_px": 1418,
           "k1": -0.0405, "k2": 0.0006, "k3": -0.0001, "k4": 0.00002}
    pts = points_over_field(89)
    ours = porthole.project(cam, pts, **SENSOR)
    k = np.array([[cam["fx_px"], 0, cam["cx_px"]], [0, cam["fy_px"], cam["cy_px"]], [0, 0, 1]], float)
    d = np.array([cam[x] for x in ["k1", "k2", "k3", "k4"]], float)
    theirs, _ = cv2.fisheye.projectPoints(pts.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), k, d)
    assert np.max(np.abs(ours - theirs.reshape(-1, 2))) < 1e-6
    # And back: the rays of those pixels are the points' directions.
    rays = porthole.unproject(cam, ours, **SENSOR)
    assert np.max(np.abs(rays - pts / np.linalg.norm(pts, axis=1)[:, None])) < 1e-12


def test_fisheye_calibration_matches_cv2_fisheye_calibrate():
    truth = {"model": "kannala-brandt", "fx_px": 1909, "fy_px": 1911, "cx_px": 2150, "cy_px": 1418,
             "k1": -0.0405, "k2": 0.0006, "k3": -0.0001, "k4": 0.00002}
    dets = porthole.synthetic_detections(truth, **SENSOR, target="chessboard:13x9:40", n_images=20,
                                         noise_px=0.3, seed=7, max_tilt_deg=50, max_off_axis_deg=85,
                                         fill=0.35)
    ours = porthole.calibrate(dets, "chessboard:13x9:40", model="kannala-brandt", reject_k=0)
    assert ours.status == porthole.Status.OK and ours.model == porthole.CameraModel.KANNALA_BRANDT
    # The views reach 80 deg off axis.
    max_deg = 0
    for d in dets:
        if len(d.points_px):
            rays = porthole.unproject(truth, d.points_px, **SENSOR)
            max_deg = max(max_deg, math.degrees(math.acos(rays[:, 2].min())))
    assert max_deg >= 80
    # OpenCV on exactly the images porthole used (it skips boards whose points fix no pose).
    used = {im.image for im in ours.images}
    obj, img = [], []
    for d in dets:
        if d.image not in used:
            continue
        ids = d.ids
        cols = 13
        xy = np.stack([(ids % cols + 1) * 40.0, (ids // cols + 1) * 40.0, np.zeros(len(ids))], 1)
        obj.append(xy.reshape(-1, 1, 3))
        img.append(d.points_px.reshape(-1, 1, 2))
    k0 = np.array([[1900.0, 0, 2143.5], [0, 1900.0, 1423.5], [0, 0, 1]], float)
    flags = cv2.fisheye.CALIB_RECOMPUTE_EXTRINSIC | cv2.fisheye.CALIB_FIX_SKEW | cv2.fisheye.CALIB_USE_INTRINSIC_GUESS
    criteria = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-12)
    rms, k, d, _, _ = cv2.fisheye.calibrate(obj, img, (4288, 2848), k0, np.zeros(4), flags=flags,
                                            criteria=criteria)
    print(f"porthole RMS {ours.rms_px:.5f} px, cv2.fisheye RMS {rms:.5f} px; "
          f"fx {ours.params['fx_px']:.3f} vs {k[0, 0]:.3f}")
    assert ours.rms_px == pytest.approx(rms, rel=0.01)
    assert ours.params["fx_px"] == pytest.approx(k[0, 0], abs=3 * ours.sigma["fx_px"])
