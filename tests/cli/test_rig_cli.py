"""A stereo rig through the CLI (issue 26): `porthole calibrate --detections L --detections R --model
opencv` against OpenCV's own `cv2.stereoCalibrate` on the same points (the real peer, Debian's
python3-opencv, run to convergence: 200 iterations, eps 1e-12): the relative pose R, T and both
cameras' intrinsics agree within 1e-4 relative (the distortion within 1e-4 of its value or 1e-7
absolute). The synthetic rig (two 4288 x 2848 px cameras 300 mm apart, 5 deg convergence, 15
frames of a 16 x 12 chessboard at 0.8-1.8 m, 0.3 px noise) is projected by cv2.projectPoints, not by
porthole. Bad rig input is refused in one line."""
import json
import math

import numpy as np
import pytest

from conftest import run, run_bad

cv2 = pytest.importorskip("cv2")

TARGET = "chessboard:16x12:50"
COLS, ROWS, SQUARE = 16, 12, 50.0
W, H = 4288, 2848
K = [np.array([[2000.0, 0, 2150], [0, 2002, 1420], [0, 0, 1]]),
     np.array([[1990.0, 0, 2130], [0, 1991, 1430], [0, 0, 1]])]
D = [np.array([-0.08, 0.05, 2e-4, -1e-4, 0.0]), np.array([-0.07, 0.04, -1e-4, 2e-4, 0.0])]
R1, _ = cv2.Rodrigues(np.array([0.0, 5 * math.pi / 180, 0.0]))  # turned 5 deg towards camera 0
T1 = -R1 @ np.array([300.0, 0, 0])  # camera 1's centre 300 mm right of camera 0's


def board():
    return np.array([[c * SQUARE, r * SQUARE, 0.0] for r in range(ROWS) for c in range(COLS)])


def frames(n=15, seed=5, noise=0.3):
    """Per frame: the ids seen by both cameras and their pixels in each (OpenCV's stereoCalibrate
    needs every point in both)."""
    rng = np.random.default_rng(seed)
    pts = board()
    centre = pts.mean(axis=0)
    out = []
    while len(out) < n:
        rvec = rng.uniform(-1, 1, 3) * np.array([0.6, 0.6, 0.3])
        r, _ = cv2.Rodrigues(rvec)
        aim = np.array([150 + 250 * rng.uniform(-1, 1), 200 * rng.uniform(-1, 1), 800 + 1000 * rng.uniform()])
        t = aim - r @ centre
        uv = []
        for k in range(2):
            rk, tk = (r, t) if k == 0 else (R1 @ r, R1 @ t + T1)
            p, _ = cv2.projectPoints(pts, cv2.Rodrigues(rk)[0], tk, K[k], D[k])
            uv.append(p.reshape(-1, 2) + rng.normal(0, noise, (len(pts), 2)))
        inside = np.all([(u[:, 0] > 0) & (u[:, 0] < W - 1) & (u[:, 1] > 0) & (u[:, 1] < H - 1) for u in uv], axis=0)
        if inside.sum() >= 20:
            ids = np.nonzero(inside)[0]
            out.append((ids, uv[0][ids], uv[1][ids]))
    return out


def write_detections(path, data, k):
    images = [{"image": f"f{i:03d}.png", "width_px": W, "height_px": H, "ids": [int(x) for x in ids],
               "points_px": (uv0 if k == 0 else uv1).tolist()} for i, (ids, uv0, uv1) in enumerate(data)]
    path.write_text(json.dumps({"target": TARGET, "images": images}))


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    d = tmp_path_factory.mktemp("rig")
    data = frames()
    for k, name in enumerate(("left.json", "right.json")):
        write_detections(d / name, data, k)
    return d, data


def test_rig_matches_cv2_stereo_calibrate(rig):
    d, data = rig
    j = run("calibrate", "--detections", d / "left.json", "--detections", d / "right.json", "--model", "opencv",
            "--reject-k", "0", "--json", "--quiet").json()["rig"]
    obj = [board()[ids].astype(np.float32) for ids, _, _ in data]
    img = [[uv.astype(np.float32).reshape(-1, 1, 2) for uv in (uv0, uv1)] for _, uv0, uv1 in data]
    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-12)
    start = []
    for k in range(2):
        _, kk, dd, _, _ = cv2.calibrateCamera(obj, [i[k] for i in img], (W, H), None, None,
                                              flags=cv2.CALIB_FIX_K3, criteria=crit)
        start += [kk, dd]
    rms, k0, d0, k1, d1, r, t, _, _ = cv2.stereoCalibrate(
        obj, [i[0] for i in img], [i[1] for i in img], start[0], start[1], start[2], start[3], (W, H),
        flags=cv2.CALIB_USE_INTRINSIC_GUESS | cv2.CALIB_FIX_K3, criteria=crit)
    cams = j["cameras"]
    ours_r, _ = cv2.Rodrigues(np.array(cams[1]["cam_from_rig"]["rotation_rad"]))
    ours_t = np.array(cams[1]["cam_from_rig"]["translation_mm"])
    dr = np.linalg.norm(ours_r - r)
    dt = np.linalg.norm(ours_t - t.ravel()) / np.linalg.norm(t)
    print(f"rig vs cv2.stereoCalibrate: |R - R_cv| {dr:.2e}, |T - T_cv|/|T| {dt:.2e}, OpenCV RMS {rms:.5f} px, "
          f"porthole sigma0 {j['sigma0_px']:.5f} px; baseline {cams[1]['baseline_mm']:.3f} +- "
          f"{cams[1]['baseline_sigma_mm']:.3f} mm (true 300), convergence {cams[1]['convergence_deg']:.4f} deg (true 5)")
    assert dr < 1e-4 and dt < 1e-4
    worst = 0.0
    for cam, kk, dd in ((cams[0], k0, d0), (cams[1], k1, d1)):
        c = cam["camera"]
        for ours, theirs in ((c["fx_px"], kk[0, 0]), (c["fy_px"], kk[1, 1]), (c["cx_px"], kk[0, 2]),
                             (c["cy_px"], kk[1, 2])):
            worst = max(worst, abs(ours / theirs - 1))
            assert ours == pytest.approx(theirs, rel=1e-4)
        for key, theirs in zip(("k1", "k2", "p1", "p2"), dd.ravel()[:4]):
            assert c[key] == pytest.approx(theirs, rel=1e-4, abs=1e-7), key
    print(f"intrinsics: worst relative difference {worst:.2e}")
    # OpenCV's RMS is sqrt(sum |r|^2 / n) over both cameras' points, as porthole's rms_px.
    assert j["rms_px"] == pytest.approx(rms, rel=1e-4)
    assert j["n_cameras"] == 2 and j["n_frames"] == 15 and j["status"] == "ok"


def test_rig_text_and_out_file(rig, tmp_path):
    d, _ = rig
    out = tmp_path / "rig.json"
    t = run("calibrate", "--detections", d / "left.json", "--detections", d / "right.json", "--model", "opencv",
            "--out", out, "--quiet").out
    assert "rig of 2 cameras" in t and "cam_from_rig right.json" in t and "baseline mm" in t
    assert json.loads(out.read_text())["rig"]["cameras"][1]["name"] == "right.json"
    # The rig file is a calibration: another command will not overwrite it without --force.
    line = run_bad("calibrate", "--detections", d / "left.json", "--out", out, "--quiet")
    assert "--out" in line, line


def test_bad_rig_input_is_refused(rig, tmp_path):
    d, data = rig
    base = ["calibrate", "--detections", d / "left.json", "--detections", d / "right.json", "--quiet"]
    assert "--model" in run_bad(*base, "--model", "opencv,brown,opencv")
    apart = tmp_path / "apart.json"
    det = json.loads((d / "right.json").read_text())
    for im in det["images"]:
        im["image"] = "other_" + im["image"]
    apart.write_text(json.dumps(det))
    line = run_bad("calibrate", "--detections", d / "left.json", "--detections", apart, "--model", "opencv", "--quiet")
    assert "shares no frame" in line, line
    # Behind ports: one port for all or one per camera; in-air calibrations one per camera (calib_refractive_test
    # Rig.CamerasBehindTheirOwnDomes* checks the numbers).
    assert "--port" in run_bad(*base, "--port", "nimar-ni320,nimar-ni320,nimar-ni320")
    cal = tmp_path / "lens.json"
    run("calibrate", "--detections", d / "left.json", "--model", "opencv", "--out", cal, "--quiet")
    line = run_bad(*base, "--model", "opencv", "--port", "nimar-ni320", "--air-calibration", cal, "--air-lens-bare")
    assert "one per camera" in line, line
    assert "only with --port" in run_bad(*base, "--model", "opencv", "--air-calibration", f"{cal},{cal}",
                                         "--air-lens-bare")
    # OpenCV's one-camera file: a rig's pair goes to the stereo file.
    line = run_bad(*base, "--model", "opencv", "--opencv-yaml", tmp_path / "cam.yaml")
    assert line == ("porthole: error: --opencv-yaml: writes one camera: a rig's first two cameras go to OpenCV's "
                    "stereo file (--stereo-out)"), line
    # --port-out: one file per camera, and only behind ports (python/tests/test_rig.py reads the files); nothing
    # is written when refused.
    one = tmp_path / "one.toml"
    line = run_bad(*base, "--model", "opencv", "--port", "nimar-ni320", "--port-out", one)
    assert line == ("porthole: error: --port-out: 1 file for 2 cameras: one per camera (a comma list, in the order "
                    "of the cameras)"), line
    line = run_bad(*base, "--model", "opencv", "--port-out", f"{one},{tmp_path / 'two.toml'}")
    assert line == "porthole: error: --port-out: only with --port (cameras behind ports)", line
    assert not one.exists() and not (tmp_path / "two.toml").exists()
    line = run_bad(*base, "--model", "opencv", "--ep", "0,0,25")  # every camera's pupil: behind ports
    assert line == "porthole: error: --ep: only with --port (cameras behind ports)", line
    # Air images at another focus (calib_refractive_test Rig.*RefocusedAirImages checks the numbers) need air images.
    line = run_bad(*base, "--model", "opencv", "--port", "nimar-ni320", "--air-refocused")
    assert line.startswith("porthole: error: --air-refocused:") and "--air-images" in line, line


def test_datum_and_free_port_are_refused_in_a_rig(rig, tmp_path):
    # A single camera's --free-port (with --port) was ignored by a rig: refused in one line naming the flag,
    # exit 2, no output file. --datum is a free target's, as a single camera's (it was ignored too).
    d, _ = rig
    out = tmp_path / "rig.json"
    base = ["calibrate", "--detections", d / "left.json", "--detections", d / "right.json", "--model", "opencv"]
    for value in ("none", "all"):
        line = run_bad(*base, "--port", "nimar-ni320", "--free-port", value, "--out", out, "--quiet")
        assert line == "porthole: error: --free-port: not with a rig (several cameras) yet", line
        assert not out.exists()
    line = run_bad(*base, "--datum", "minimal", "--out", out, "--quiet")
    assert line.startswith("porthole: error: --datum: is the datum of a free target: give it with --free-target"), line
    assert not out.exists()
    j = run(*base, "--free-target", "--datum", "minimal", "--json", "--quiet").json()
    assert j["rig"]["target_adjusted"]["datum"]["fixed"]


def test_a_pixel_pitch_per_camera(rig):
    # Two bodies of different pixel pitch: a pitch scales only the millimetre values of its own
    # camera (Brown's c, x0, y0 are in mm), never the pixels, the poses or the other camera.
    d, _ = rig
    base = ["calibrate", "--detections", d / "left.json", "--detections", d / "right.json", "--model", "brown",
            "--json", "--quiet"]
    one = run(*base, "--pixel-pitch-mm", "0.0055").json()["rig"]["cameras"]
    two = run(*base, "--pixel-pitch-mm", "0.0055,0.0044").json()["rig"]["cameras"]
    for key, v in one[0]["camera"].items():
        if isinstance(v, float):
            assert abs(two[0]["camera"][key] - v) <= 1e-9 * max(abs(v), 1e-9), key
    assert two[1]["sensor"]["pixel_pitch_mm"] == 0.0044
    for key in ("c_mm", "x0_mm", "y0_mm"):
        assert abs(two[1]["camera"][key] / one[1]["camera"][key] - 0.0044 / 0.0055) < 1e-9, key
    t1, t2 = np.array(one[1]["cam_from_rig"]["translation_mm"]), np.array(two[1]["cam_from_rig"]["translation_mm"])
    assert np.abs(t1 - t2).max() < 1e-6
    assert "3 pitches for 2 cameras" in run_bad(*base, "--pixel-pitch-mm", "0.0055,0.0044,0.0043")
    line = run_bad("calibrate", "--detections", d / "left.json", "--pixel-pitch-mm", "0.0055,0.0044", "--quiet")
    assert "2 pitches for one camera" in line, line


@pytest.mark.parametrize("ext", ["yml", "xml"])
def test_stereo_file_is_read_by_opencv(rig, tmp_path, ext):
    """--stereo-out: cv2.FileStorage reads K1 D1 K2 D2 R T (the values of the rig JSON) and
    cv2.stereoRectify takes them: the rectified baseline is the rig's."""
    d, _ = rig
    f = tmp_path / f"stereo.{ext}"
    j = run("calibrate", "--detections", d / "left.json", "--detections", d / "right.json", "--model", "opencv",
            "--stereo-out", f, "--json", "--quiet").json()["rig"]
    fs = cv2.FileStorage(str(f), cv2.FILE_STORAGE_READ)
    k1, d1, k2, d2, r, t = (fs.getNode(n).mat() for n in ("K1", "D1", "K2", "D2", "R", "T"))
    size = (int(fs.getNode("image_width").real()), int(fs.getNode("image_height").real()))
    fs.release()
    assert size == (W, H)
    cams = j["cameras"]
    for cam, kk, dd in ((cams[0], k1, d1), (cams[1], k2, d2)):
        c = cam["camera"]
        assert [kk[0, 0], kk[1, 1], kk[0, 2], kk[1, 2]] == pytest.approx([c["fx_px"], c["fy_px"], c["cx_px"], c["cy_px"]],
                                                                         rel=1e-15)
        assert dd.ravel()[:5] == pytest.approx([c[k] or 0.0 for k in ("k1", "k2", "p1", "p2", "k3")], rel=1e-15)
    ours_r, _ = cv2.Rodrigues(np.array(cams[1]["cam_from_rig"]["rotation_rad"]))
    assert r == pytest.approx(ours_r, abs=1e-14)
    assert t.ravel() == pytest.approx(cams[1]["cam_from_rig"]["translation_mm"], rel=1e-15)
    r1, r2, p1, p2, q, _, _ = cv2.stereoRectify(k1, d1, k2, d2, size, r, t)
    baseline = -p2[0, 3] / p2[0, 0]
    assert baseline == pytest.approx(cams[1]["baseline_mm"], rel=1e-9)
    line = run_bad("calibrate", "--detections", d / "left.json", "--detections", d / "right.json",
                   "--stereo-out", tmp_path / "brown.yml", "--quiet")
    assert "--stereo-out" in line and "opencv" in line, line


def test_opencv_stereo_sample_matches_cv2_stereo_calibrate(tmp_path):
    """Real images: OpenCV's own stereo sample (opencv-doc left01-14 / right01-14.jpg, a 9 x 6
    chessboard, the pair its stereo_calib sample calibrates). Each camera's images are linked under one
    frame name per pair (f01.jpg ...: frames are matched by file name), porthole detects and calibrates
    the rig (status ok); then both tools calibrate the pairs both cameras saw from porthole's own
    detections of them: R, T and the intrinsics agree within 1e-4 relative."""
    data = "/usr/share/doc/opencv-doc/examples/data"
    import os
    pairs = [n[4:6] for n in sorted(os.listdir(data)) if n.startswith("left") and n.endswith(".jpg")
             and os.path.exists(os.path.join(data, f"right{n[4:6]}.jpg"))]
    if len(pairs) < 10:
        pytest.skip("opencv-doc sample images not installed (scripts/install-deps)")
    for side in ("left", "right"):
        (tmp_path / side).mkdir()
        for p in pairs:
            os.symlink(os.path.join(data, f"{side}{p}.jpg"), tmp_path / side / f"f{p}.jpg")
    j = run("calibrate", "--images", tmp_path / "left", "--images", tmp_path / "right", "--target",
            "chessboard:9x6:25", "--model", "opencv", "--reject-k", "0", "--json", "--quiet").json()["rig"]
    assert j["status"] == "ok" and j["n_cameras"] == 2
    dets = [run("detect", "--images", tmp_path / side, "--target", "chessboard:9x6:25", "--json", "--quiet").json()
            for side in ("left", "right")]
    by_frame = [{os.path.basename(im["image"]): im for im in d["images"]} for d in dets]
    common = sorted(set(by_frame[0]) & set(by_frame[1]))
    # cv2.stereoCalibrate takes the frames both saw; porthole's rig also uses a frame one camera saw
    # alone. The comparison gives both the frames both saw: porthole from detection files of those.
    assert len(common) >= 10
    for k, side in enumerate(("left", "right")):
        (tmp_path / f"{side}.json").write_text(json.dumps({"target": "chessboard:9x6:25",
                                                         "images": [by_frame[k][n] for n in common]}))
    j = run("calibrate", "--detections", tmp_path / "left.json", "--detections", tmp_path / "right.json",
            "--model", "opencv", "--reject-k", "0", "--json", "--quiet").json()["rig"]
    obj, img = [], [[], []]
    for name in common:
        ids = sorted(set(by_frame[0][name]["ids"]) & set(by_frame[1][name]["ids"]))
        assert len(ids) == 54  # whole boards: the same points in both
        obj.append(np.array([[(i % 9) * 25.0, (i // 9) * 25.0, 0] for i in ids], np.float32))
        for k in range(2):
            pts = dict(zip(by_frame[k][name]["ids"], by_frame[k][name]["points_px"]))
            img[k].append(np.array([pts[i] for i in ids], np.float32).reshape(-1, 1, 2))
    size = (dets[0]["images"][0]["width_px"], dets[0]["images"][0]["height_px"])
    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-12)
    start = []
    for k in range(2):
        _, kk, dd, _, _ = cv2.calibrateCamera(obj, img[k], size, None, None, flags=cv2.CALIB_FIX_K3, criteria=crit)
        start += [kk, dd]
    rms, k0, d0, k1, d1, r, t, _, _ = cv2.stereoCalibrate(obj, img[0], img[1], *start, size,
                                                          flags=cv2.CALIB_USE_INTRINSIC_GUESS | cv2.CALIB_FIX_K3,
                                                          criteria=crit)
    cams = j["cameras"]
    ours_r, _ = cv2.Rodrigues(np.array(cams[1]["cam_from_rig"]["rotation_rad"]))
    dt = np.linalg.norm(np.array(cams[1]["cam_from_rig"]["translation_mm"]) - t.ravel()) / np.linalg.norm(t)
    print(f"OpenCV stereo sample: {len(common)} pairs, baseline {cams[1]['baseline_mm']:.3f} +- "
          f"{cams[1]['baseline_sigma_mm']:.3f} mm, |R - R_cv| {np.linalg.norm(ours_r - r):.1e}, |T - T_cv|/|T| {dt:.1e}, "
          f"RMS {j['rms_px']:.5f} (OpenCV {rms:.5f}) px")
    assert np.linalg.norm(ours_r - r) < 1e-4 and dt < 1e-4
    for cam, kk in ((cams[0], k0), (cams[1], k1)):
        c = cam["camera"]
        assert [c["fx_px"], c["fy_px"], c["cx_px"], c["cy_px"]] == pytest.approx(
            [kk[0, 0], kk[1, 1], kk[0, 2], kk[1, 2]], rel=1e-4)
    assert j["rms_px"] == pytest.approx(rms, rel=1e-4)


def test_many_images_are_summarised_in_the_text(tmp_path):
    """Beyond 30 images (a calibration from video) the text gives the median per-image RMS and the
    five worst images instead of every image; the JSON keeps every one, and the text's figures are
    its."""
    data = frames(n=40, seed=11)
    write_detections(tmp_path / "many.json", data, 0)
    args = ["calibrate", "--detections", tmp_path / "many.json", "--model", "opencv", "--quiet"]
    t = run(*args).out
    j = run(*args, "--json").json()
    rms = sorted((im["rms_px"] for im in j["images"]), reverse=True)
    assert len(rms) == 40
    line = next(l for l in t.splitlines() if l.startswith("per-image RMS"))
    assert line.startswith(f"per-image RMS (px), 40 images: median {rms[20]:.3f}; the 5 worst:"), line
    assert line.count(";") == 6 and f"{rms[0]:.3f}" in line and line.endswith("every image in --json")


def test_a_free_target_in_a_rig(rig):
    """--free-target with a rig (issue 26; calib_refractive_test Rig.AFreeTargetInARigBehindDomes checks the
    numbers): the rig JSON's target_adjusted holds every point seen, its sigma and the datum (the first
    camera's); the rig itself within a few sigma of the held target's (the synthetic board is the nominal
    one), every point within 4 sigma of its nominal position."""
    d, _ = rig
    base = ["calibrate", "--detections", d / "left.json", "--detections", d / "right.json", "--model", "opencv",
            "--json", "--quiet"]
    held = run(*base).json()["rig"]
    free = run(*base, "--free-target").json()["rig"]
    t = free["target_adjusted"]
    assert t["datum"]["fixed"] and len(t["points"]) == 192  # the 16 x 12 board, every corner seen
    worst = max(abs(x - n) / s for p in t["points"] for x, n, s in zip(p["xyz_mm"], p["nominal_mm"], p["sigma_mm"])
                if s > 0)
    print(f"free target in a rig: every point within {worst:.2f} sigma of its nominal position")
    assert worst < 4
    a, b = held["cameras"][1]["cam_from_rig"], free["cameras"][1]["cam_from_rig"]
    for i in range(3):
        assert abs(a["translation_mm"][i] - b["translation_mm"][i]) < 5 * b["sigma"]["translation_mm"][i], i
    assert "target_adjusted" not in held

    # --field-out writes a coded target's field (CalibrateRigJob.WritesTheFreeTargetsAdjustedField): of this
    # chessboard there is none, and nothing is written; without --free-target no point is adjusted.
    out = d / "field.txt"
    line = run_bad(*base, "--free-target", "--field-out", out)
    assert line.startswith("porthole: error: --field-out: a target-field file is for coded targets"), line
    assert "needs --free-target" in run_bad(*base, "--field-out", out)
    assert not out.exists()
