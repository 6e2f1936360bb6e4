"""`porthole undistort` from the command line (issue 28): the images remapped as OpenCV's own
undistortion remaps them (same pinhole, cv2.initUndistortRectifyMap + cv2.remap: mean difference
below 0.5 grey level), bit depth, channels and format kept; --alpha as cv2.getOptimalNewCameraMatrix
(focal length and principal point within 0.3 %); the intrinsics read by OpenCV (cv2.FileStorage),
COLMAP (`colmap model_converter`) and porthole; `colmap feature_extractor` runs on the output images;
a refractive calibration gives the residual figure and JSON; bad input: one line, exit 2."""
import json
import os
import shutil
import sqlite3
import subprocess
import xml.etree.ElementTree as ET

import pytest

from conftest import run, run_bad

cv2 = pytest.importorskip("cv2")
np = pytest.importorskip("numpy")

W, H = 960, 640
K = np.array([[800.0, 0, 482.3], [0, 803.0, 317.1], [0, 0, 1]])
D = np.array([-0.21, 0.06, 0.0012, -0.0007, 0.0])


def write_calibration(path):
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", W)
    fs.write("image_height", H)
    fs.write("camera_matrix", K)
    fs.write("distortion_coefficients", D)
    fs.release()


def texture(seed, channels=3, dtype=np.uint8):
    rng = np.random.default_rng(seed)
    img = rng.random((H, W, channels) if channels > 1 else (H, W)).astype(np.float32)
    img = cv2.GaussianBlur(img, (0, 0), 3)
    img = (img - img.min()) / (img.max() - img.min())
    top = 255 if dtype == np.uint8 else 65535
    return np.clip(20 + img * (top - 40), 0, top).astype(dtype)  # strictly inside (0, top)


@pytest.fixture(scope="module")
def central(tmp_path_factory):
    d = tmp_path_factory.mktemp("central")
    write_calibration(d / "cal.yml")
    (d / "images").mkdir()
    images = {
        "a_rgb8.png": texture(1),
        "b_grey16.png": texture(2, 1, np.uint16),
        "c_rgb8.jpg": texture(3),
        "d_grey16.tif": texture(4, 1, np.uint16),
        "e_rgb16.tif": texture(5, 3, np.uint16),
    }
    for name, img in images.items():
        assert cv2.imwrite(str(d / "images" / name), img)
    res = run("undistort", "--calibration", d / "cal.yml", "--images", d / "images", "--out", d / "out", "--json")
    return d, images, res


def pinhole_k(summary):
    p = summary["pinhole"]
    return np.array([[p["fx_px"], 0, p["cx_px"]], [0, p["fy_px"], p["cy_px"]], [0, 0, 1]])


def test_images_are_remapped_as_opencv_undistorts_them(central):
    d, images, res = central
    summary = res.json()
    assert "[5/5]" in res.err  # one progress line per image
    newk = pinhole_k(summary)
    mx, my = cv2.initUndistortRectifyMap(K, D, None, newk, (W, H), cv2.CV_32FC1)
    for name, src in images.items():
        out = cv2.imread(str(d / "out" / "images" / name), cv2.IMREAD_UNCHANGED)
        assert out is not None and out.dtype == src.dtype and out.shape == src.shape, name
        # The same source image as porthole read it (JPEG: decoded), remapped by OpenCV.
        ref = cv2.remap(cv2.imread(str(d / "images" / name), cv2.IMREAD_UNCHANGED), mx, my, cv2.INTER_LINEAR)
        scale = 255.0 / (65535.0 if src.dtype == np.uint16 else 255.0)
        diff = np.abs(out.astype(float) - ref.astype(float)) * scale
        inner = diff[2:-2, 2:-2]
        lossy = name.endswith(".jpg")  # re-encoded
        assert inner.mean() < (3.0 if lossy else 0.5), (name, inner.mean())  # JPEG: quality 95
        # alpha 0 (the default): no black border.
        assert (out[2:-2, 2:-2] > 0).all(), name


def test_intrinsics_are_read_by_opencv_colmap_and_porthole(central, tmp_path):
    d, _, res = central
    s = res.json()
    p = s["pinhole"]
    fs = cv2.FileStorage(str(d / "out" / "camera.yml"), cv2.FILE_STORAGE_READ)
    km = fs.getNode("camera_matrix").mat()
    dist = fs.getNode("distortion_coefficients").mat()
    assert np.allclose(km, pinhole_k(s), rtol=0, atol=1e-9) and not dist.any()
    assert int(fs.getNode("image_width").real()) == W and int(fs.getNode("image_height").real()) == H
    # COLMAP: a sparse model of our cameras.txt, converted by COLMAP itself.
    line = [l for l in (d / "out" / "cameras.txt").read_text().splitlines() if not l.startswith("#")][0].split()
    assert line[:4] == ["1", "PINHOLE", str(W), str(H)]
    vals = [float(v) for v in line[4:]]
    assert vals == pytest.approx([p["fx_px"], p["fy_px"], p["cx_px"] + 0.5, p["cy_px"] + 0.5], abs=1e-9)
    if shutil.which("colmap") is None:
        pytest.skip("colmap not installed")
    sparse = tmp_path / "sparse"
    sparse.mkdir()
    shutil.copy(d / "out" / "cameras.txt", sparse / "cameras.txt")
    (sparse / "images.txt").write_text("")
    (sparse / "points3D.txt").write_text("")
    conv = tmp_path / "conv"
    conv.mkdir()
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen")
    subprocess.run(["colmap", "model_converter", "--input_path", sparse, "--output_path", conv, "--output_type", "TXT"],
                   check=True, capture_output=True, env=env, timeout=120)
    back = [l for l in (conv / "cameras.txt").read_text().splitlines() if not l.startswith("#")][0].split()
    assert back[:4] == ["1", "PINHOLE", str(W), str(H)]
    assert [float(v) for v in back[4:]] == pytest.approx(vals, rel=1e-6)
    # Metashape XML and OpenCV YAML read back by porthole's own reader: the same pinhole.
    for f in ("camera.xml", "camera.yml"):
        c = run("convert", d / "out" / f, tmp_path / (f + ".json"), "--json").json()
        got = json.loads((tmp_path / (f + ".json")).read_text())
        cam = got["camera"]
        assert cam["fx_px"] == pytest.approx(p["fx_px"], rel=1e-6), (f, c)
        assert cam["cy_px"] == pytest.approx(p["cy_px"], abs=1e-6), f
    root = ET.parse(d / "out" / "camera.xml").getroot()
    assert root.tag == "calibration"
    # nerfstudio: COLMAP's pixel convention (ns-process-data copies COLMAP's cx), frames with file_path.
    t = json.loads((d / "out" / "transforms.json").read_text())
    assert t["camera_model"] == "OPENCV" and (t["w"], t["h"]) == (W, H)
    assert t["cx"] == pytest.approx(p["cx_px"] + 0.5) and t["fl_y"] == pytest.approx(p["fy_px"])
    assert [f["file_path"] for f in t["frames"]] == [f"images/{n}" for n in sorted(os.listdir(d / "images"))]


def test_colmap_extracts_features_from_the_output(central, tmp_path):
    d, _, res = central
    if shutil.which("colmap") is None:
        pytest.skip("colmap not installed")
    p = res.json()["pinhole"]
    db = tmp_path / "db.db"
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen")
    params = f"{p['fx_px']},{p['fy_px']},{p['cx_px'] + 0.5},{p['cy_px'] + 0.5}"
    subprocess.run(["colmap", "feature_extractor", "--database_path", db, "--image_path", d / "out" / "images",
                    "--ImageReader.camera_model", "PINHOLE", "--ImageReader.single_camera", "1",
                    "--ImageReader.camera_params", params, "--SiftExtraction.use_gpu", "0",
                    "--SiftExtraction.num_threads", "2"], check=True, capture_output=True, env=env, timeout=300)
    con = sqlite3.connect(db)
    rows = con.execute("select name, rows from keypoints join images using (image_id)").fetchall()
    con.close()
    # COLMAP 3.8 (FreeImage) skips the 16-bit RGB TIFF; it reads the others, 8 and 16 bit.
    assert {n for n, _ in rows} >= {"a_rgb8.png", "b_grey16.png", "c_rgb8.jpg", "d_grey16.tif"}
    assert min(r for _, r in rows) > 100


@pytest.mark.parametrize("alpha", ["0", "0.5", "1"])
def test_alpha_has_the_meaning_of_get_optimal_new_camera_matrix(central, tmp_path, alpha):
    d, _, _ = central
    s = run("undistort", "--calibration", d / "cal.yml", "--images", d / "images", "--out", tmp_path / "o",
            "--alpha", alpha, "--interpolation", "nearest", "--json").json()
    ours = pinhole_k(s)
    ref, _ = cv2.getOptimalNewCameraMatrix(K, D, (W, H), float(alpha))
    # OpenCV samples a 9 x 9 grid and undistorts it iteratively (5 steps); porthole the frame's edges
    # every 1 % exactly: the same rectangle within 0.3 %.
    assert ours[0, 0] == pytest.approx(ref[0, 0], rel=3e-3)
    assert ours[1, 1] == pytest.approx(ref[1, 1], rel=3e-3)
    assert ours[0, 2] == pytest.approx(ref[0, 2], abs=2.0)
    assert ours[1, 2] == pytest.approx(ref[1, 2], abs=2.0)
    out = cv2.imread(str(tmp_path / "o" / "images" / "a_rgb8.png"), cv2.IMREAD_UNCHANGED)
    black = (out == 0).all(axis=2).mean()
    assert (black == 0) if alpha == "0" else (black > 0.01)  # alpha 1: every source pixel kept, border black


def test_keep_focal_and_interpolations(central, tmp_path):
    d, _, _ = central
    for interp in ("linear", "cubic", "lanczos", "nearest"):
        s = run("undistort", "--calibration", d / "cal.yml", "--images", d / "images", "--out", tmp_path / interp,
                "--keep-focal", "--interpolation", interp, "--json").json()
        assert s["pinhole"]["fx_px"] == pytest.approx(K[0, 0], rel=0.01) and s["options"]["interpolation"] == interp
        assert s["options"]["field"] == "keep_focal"
    # nearest keeps the source's values (16 bit): every output value is one of the input's (or 0).
    src = cv2.imread(str(d / "images" / "b_grey16.png"), cv2.IMREAD_UNCHANGED)
    out = cv2.imread(str(tmp_path / "nearest" / "images" / "b_grey16.png"), cv2.IMREAD_UNCHANGED)
    assert out.dtype == np.uint16 and set(np.unique(out)) <= set(np.unique(src)) | {0}


def refractive_calibration(d):
    """A D300 + 24 mm behind the as-built NI320 (its shell from the preset), as `calibrate --port` writes."""
    run("render", "--out", d / "board.png", "--pixel-pitch-mm", "0.029", "--spp", "1", "--quiet", "--distance", "1200")
    truth = json.loads((d / "board.json").read_text())
    cal = dict(truth["camera"])
    cal["port"] = {"kind": "dome",
                   "shell": {"n_glass": 1.5187, "n_water": 1.3409, "outer_radius_mm": 83.4, "inner_radius_mm": 75.7,
                             "inner_from_outer_mm": [0, -0.5, -1.2], "rim_from_outer_z_mm": 0},
                   "parameters": {"ep_in_dome_x_mm": 0.4, "ep_in_dome_y_mm": 1.0, "ep_in_dome_z_mm": 5.3}}
    (d / "refr.json").write_text(json.dumps(cal))
    (d / "images").mkdir()
    shutil.move(d / "board.png", d / "images" / "board.png")
    return d / "refr.json", d / "images"


def test_refractive_writes_the_residual_figure_and_json(tmp_path):
    cal, images = refractive_calibration(tmp_path)
    res = run("undistort", "--calibration", cal, "--images", images, "--out", tmp_path / "out", "--wd", "500:3000")
    assert "residual (px)" in res.out and "WD   5000 mm" in res.out
    png = (tmp_path / "out" / "residual.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    s = json.loads((tmp_path / "out" / "undistort.json").read_text())
    assert s["source"]["refractive"] and s["options"]["wd_mm"] == [500, 3000]
    assert [r["wd_mm"] for r in s["residual"]] == [500, 1000, 2000, 5000]
    for r in s["residual"]:
        assert len(r["error_px"]) == r["grid"]["cols"] * r["grid"]["rows"]
        assert 0 <= r["rms_px"] <= r["max_px"] < 1  # the as-built dome: a pinhole fits it well
    assert 50 < s["options"]["vertex_z_mm"] < 100
    # One distance: the map is exact there.
    one = run("undistort", "--calibration", cal, "--images", images, "--out", tmp_path / "one", "--wd", "1000",
              "--json").json()
    at = {r["wd_mm"]: r for r in one["residual"]}
    assert at[1000]["max_px"] < 1e-3 and at[500]["max_px"] > at[1000]["max_px"]


def test_bad_input_is_one_line_and_exit_2(central, tmp_path):
    d, _, _ = central
    cal, imgs = d / "cal.yml", d / "images"
    out = tmp_path / "o"
    base = ["undistort", "--images", imgs, "--out", out]
    assert "--calibration" in run_bad("undistort", "--calibration", tmp_path / "missing.yml", "--images", imgs, "--out", out)
    assert "--alpha" in run_bad(*base, "--calibration", cal, "--alpha", "1.5")
    assert "--alpha" in run_bad(*base, "--calibration", cal, "--alpha", "-0.1")
    assert "--wd" in run_bad(*base, "--calibration", cal, "--wd", "1000")  # central: no working distance
    assert "--interpolation" in run_bad(*base, "--calibration", cal, "--interpolation", "bicubic")
    assert "--keep-focal" in run_bad(*base, "--calibration", cal, "--alpha", "0.5", "--keep-focal")
    assert "--images" in run_bad("undistort", "--calibration", cal, "--images", tmp_path / "none", "--out", out)
    # An image of another size: refused before anything is written.
    odd = tmp_path / "odd"
    odd.mkdir()
    cv2.imwrite(str(odd / "a.png"), texture(1)[:, :-2])
    assert "960x640" in run_bad("undistort", "--calibration", cal, "--images", odd, "--out", out)
    assert not (out / "images" / "a.png").exists()
    # Outputs exist: only with --force.
    assert "--force" in run_bad("undistort", "--calibration", cal, "--images", imgs, "--out", d / "out")
    (tmp_path / "r").mkdir()
    rcal, rimg = refractive_calibration(tmp_path / "r")
    for wd in (None, "abc", "3000:500", "0", "-5", "1:2:3"):
        args = ["undistort", "--calibration", rcal, "--images", rimg, "--out", tmp_path / "ro"]
        if wd is not None:
            args += [f"--wd={wd}"]
        assert "--wd" in run_bad(*args), wd
    assert not (tmp_path / "ro" / "undistort.json").exists()
    # No gnuplot for the residual figure: refused before any image is written.
    assert "--gnuplot" in run_bad("undistort", "--calibration", rcal, "--images", rimg, "--out", tmp_path / "ro",
                                  "--wd", "1000", "--gnuplot", "no-such-gnuplot")
    assert not (tmp_path / "ro" / "images" / "board.png").exists()


def homography_rms(det, truth_dir):
    """RMS (px) of the detected corners about the best homography from the board: 0 for a pinhole
    image of a plane, whatever the camera's pose and intrinsics."""
    res = []
    for img in det["images"]:
        truth = json.loads((truth_dir / (os.path.splitext(img["image"])[0] + ".json")).read_text())
        board = {q["id"]: q["target_mm"][:2] for q in truth["points"]}
        src = np.array([board[i] for i in img["ids"]], dtype=np.float64)
        dst = np.array(img["points_px"], dtype=np.float64)
        h, _ = cv2.findHomography(src, dst, 0)
        proj = cv2.perspectiveTransform(src.reshape(-1, 1, 2), h).reshape(-1, 2)
        res.extend(np.linalg.norm(proj - dst, axis=1))
    assert len(res) >= 5 * 54
    return float(np.sqrt(np.mean(np.square(res))))


def test_a_refractive_calibration_from_calibrate_port_undistorts_its_renders(tmp_path):
    """The real chain: renders through the as-built NI320 (an ideal lens: the distortion is the dome's
    own), `calibrate --port`'s JSON, `undistort`: a plane's corners in the undistorted images lie on a
    homography (a pinhole's image of a plane) within 0.03 px RMS (0.015 px measured), against 0.047 px
    in the renders: read as calibrate writes it, the refractive model takes the dome's bending out."""
    run("render", "--set", "6", "--out", tmp_path / "rs", "--spp", "1", "--edge-spp", "64", "--f-number", "inf",
        "--pixel-pitch-mm", "0.029", "--quiet")
    run("calibrate", "--images", tmp_path / "rs" / "water", "--air-images", tmp_path / "rs" / "air", "--target",
        "chessboard:9x6:40", "--pixel-pitch-mm", "0.029", "--port", "nimar-ni320", "--out", tmp_path / "cal.json",
        "--quiet")
    s = run("undistort", "--calibration", tmp_path / "cal.json", "--images", tmp_path / "rs" / "water", "--out",
            tmp_path / "out", "--wd", "500:3000", "--json").json()
    assert s["source"]["refractive"]
    before = run("detect", "--images", tmp_path / "rs" / "water", "--target", "chessboard:9x6:40", "--json",
                 "--quiet").json()
    after = run("detect", "--images", tmp_path / "out" / "images", "--target", "chessboard:9x6:40", "--json",
                "--quiet").json()
    rms_before = homography_rms(before, tmp_path / "rs" / "water")
    rms_after = homography_rms(after, tmp_path / "rs" / "water")
    print(f"homography RMS: renders {rms_before:.3f} px, undistorted {rms_after:.3f} px")
    assert rms_after < 0.03 and rms_after < rms_before / 2, (rms_before, rms_after)


def test_rig_undistorts_each_camera_in_its_own_frame(tmp_path):
    """--rig: each camera's images into OUT/<camera>/ with the pinhole its own calibration gives
    (its pose in the rig plays no part); the wrong number of --images folders is refused."""
    from test_rig_cli import frames, write_detections
    data = frames()
    for k, name in enumerate(("left.json", "right.json")):
        write_detections(tmp_path / name, data, k)
    run("calibrate", "--detections", tmp_path / "left.json", "--detections", tmp_path / "right.json", "--model",
        "opencv", "--out", tmp_path / "rig.json", "--quiet")
    rig = json.loads((tmp_path / "rig.json").read_text())["rig"]
    w, h = rig["cameras"][0]["sensor"]["width_px"], rig["cameras"][0]["sensor"]["height_px"]
    x = np.linspace(0, 1, w, dtype=np.float32)[None, :] * np.linspace(0.5, 1, h, dtype=np.float32)[:, None]
    for name in ("l", "r"):
        (tmp_path / name).mkdir()
        cv2.imwrite(str(tmp_path / name / "a.jpg"), (40 + 200 * x).astype(np.uint8))
    out = run("undistort", "--rig", tmp_path / "rig.json", "--images", tmp_path / "l", "--images", tmp_path / "r",
              "--out", tmp_path / "out", "--json").json()
    assert [c["camera"] for c in out["cameras"]] == ["left.json", "right.json"]
    for k, folder in enumerate(("left", "right")):
        assert (tmp_path / "out" / folder / "images" / "a.jpg").exists()
        assert (tmp_path / "out" / folder / "cameras.txt").exists()
        # The same camera alone (its calibration without the rig): the same pinhole.
        alone = {key: rig["cameras"][k][key] for key in ("model", "camera", "sensor")}
        (tmp_path / f"alone{k}.json").write_text(json.dumps(alone))
        single = run("undistort", "--calibration", tmp_path / f"alone{k}.json", "--images",
                     tmp_path / ("l" if k == 0 else "r"), "--out", tmp_path / f"single{k}", "--json").json()
        assert out["cameras"][k]["pinhole"] == single["pinhole"]
    assert "--images" in run_bad("undistort", "--rig", tmp_path / "rig.json", "--images", tmp_path / "l", "--out",
                                 tmp_path / "o2")
    assert run_bad("undistort", "--rig", tmp_path / "rig.json", "--calibration", tmp_path / "alone0.json",
                   "--images", tmp_path / "l", "--out", tmp_path / "o3")
    # The second camera's image of another size: refused before the first camera writes anything.
    (tmp_path / "odd").mkdir()
    cv2.imwrite(str(tmp_path / "odd" / "a.jpg"), (40 + 200 * x[:, :-4]).astype(np.uint8))
    assert "--images" in run_bad("undistort", "--rig", tmp_path / "rig.json", "--images", tmp_path / "l", "--images",
                                 tmp_path / "odd", "--out", tmp_path / "o4")
    assert not (tmp_path / "o4" / "left" / "images" / "a.jpg").exists()
