"""Proves `porthole detect` and `porthole calibrate` end to end on OpenCV's sample chessboards
(Debian opencv-doc): the JSON shape the issue asks for, pixel-pitch handling, OpenCV YAML export,
bad images skipped, and a clear refusal (exit 2) when too few images hold the target."""
import glob
import gzip
import json
import os
import shutil

import pytest

from conftest import run, run_bad

SAMPLE_DIRS = ["/usr/share/doc/opencv-doc/examples/data", "/usr/share/opencv4/samples/data"]
KEYS = ["c_mm", "x0_mm", "y0_mm", "K1", "K2", "K3", "P1", "P2", "B1", "B2"]
TARGET = "chessboard:9x6:25"


def copy_samples(dest):
    """left01..left14.jpg as Debian installs them (plain or gzipped) into dest; returns the count."""
    for d in SAMPLE_DIRS:
        files = sorted(glob.glob(os.path.join(d, "left[0-9][0-9].jpg*")))
        for f in files:
            name = os.path.basename(f)
            if name.endswith(".gz"):
                with gzip.open(f, "rb") as src, open(os.path.join(dest, name[:-3]), "wb") as out:
                    shutil.copyfileobj(src, out)
            else:
                shutil.copy(f, dest)
        if files:
            return len(files)
    return 0


@pytest.fixture(scope="module")
def samples(tmp_path_factory):
    d = tmp_path_factory.mktemp("left")
    if copy_samples(d) < 13:
        pytest.fail("OpenCV sample chessboards missing: run scripts/install-deps (opencv-doc)")
    return d


@pytest.fixture(scope="module")
def detections(samples, tmp_path_factory):
    out = tmp_path_factory.mktemp("det")
    res = run("detect", "--images", samples, "--target", TARGET, "--out-dir", out, "--quiet")
    assert "13 of 13 images hold the target" in res.out
    return out


def test_calibrate_images_json_shape(samples, tmp_path):
    j = run("calibrate", "--images", samples, "--target", TARGET, "--json", "--opencv-yaml", tmp_path / "c.yml").json()
    for block in ("camera", "sigma"):
        assert list(j[block].keys()) == KEYS
        for k in ("K3", "B1", "B2"):  # not adjusted by default
            assert j[block][k] is None
    assert j["pixels_are_mm"] is True and "pixels" in j["note"]
    assert j["correlation"]["parameters"] == ["c_mm", "x0_mm", "y0_mm", "K1", "K2", "P1", "P2"]
    m = j["correlation"]["matrix"]
    assert all(abs(m[i][i] - 1) < 1e-9 for i in range(7))
    assert all(abs(m[i][k] - m[k][i]) < 1e-9 and abs(m[i][k]) <= 1 + 1e-9 for i in range(7) for k in range(7))
    # OpenCV's own calibration of these images (left_intrinsics.yml in opencv-doc, older detector):
    # fx = 535.9 px, principal point (342.3, 235.6) px, a barrel lens (k1 < 0, so K1 > 0 here).
    assert j["camera"]["c_mm"] == pytest.approx(535.9, rel=0.015)
    assert j["camera"]["x0_mm"] + 319.5 == pytest.approx(342.3, abs=5)
    assert 239.5 - j["camera"]["y0_mm"] == pytest.approx(235.6, abs=5)
    assert j["camera"]["K1"] > 0
    assert 0 < j["sigma0_px"] < 0.5 and 0 < j["rms_px"] < 0.5
    assert j["n_images"] == 13 and len(j["images"]) == 13
    # docs/calibration.md: "The default CLI run (5σ0 rejection) rejects none of the 702 corners: σ0
    # 0.128 px, RMS 0.176 px. The OpenCV YAML export refits with 0.035 px RMS (0.23 px max)".
    assert (j["n_points"], j["n_rejected"]) == (702, 0)
    assert (round(j["sigma0_px"], 3), round(j["rms_px"], 3)) == (0.128, 0.176)
    # "K1/K2 near -0.9 is usual (-0.91 on the OpenCV samples)"
    names = j["correlation"]["parameters"]
    assert round(m[names.index("K1")][names.index("K2")], 2) == -0.91
    refit = j["opencv_yaml"]
    assert (round(refit["refit_rms_px"], 3), round(refit["refit_max_px"], 2)) == (0.035, 0.23)


def test_pitch_scales_millimetres(detections):
    px = run("calibrate", "--detections", detections, "--json", "--quiet").json()
    mm = run("calibrate", "--detections", detections, "--pixel-pitch-mm", "0.0055", "--json",
             "--quiet").json()
    assert mm["pixels_are_mm"] is False
    assert mm["camera"]["c_mm"] == pytest.approx(0.0055 * px["camera"]["c_mm"], rel=1e-5)
    assert mm["camera"]["K1"] == pytest.approx(px["camera"]["K1"] / 0.0055**2, rel=1e-4)
    assert mm["sigma"]["c_mm"] == pytest.approx(0.0055 * px["sigma"]["c_mm"], rel=1e-3)
    assert mm["rms_px"] == pytest.approx(px["rms_px"], rel=1e-6)


def test_opencv_yaml_export_and_table(detections, tmp_path):
    yml = tmp_path / "cam.yml"
    res = run("calibrate", "--detections", detections, "--opencv-yaml", yml, "--quiet")
    assert "parameter" in res.out and "sigma0" in res.out and "millimetres are pixels" in res.out
    text = yml.read_text()
    assert text.startswith("%YAML:1.0") and "distortion_coefficients" in text
    assert "refit RMS" in res.out


def test_bad_images_are_skipped(samples, tmp_path):
    for f in sorted(os.listdir(samples))[:4]:
        shutil.copy(os.path.join(samples, f), tmp_path)
    (tmp_path / "broken.jpg").write_bytes(b"not an image")
    (tmp_path / "blank.pgm").write_bytes(b"P5\n64 48\n255\n" + bytes([128]) * 64 * 48)
    res = run("calibrate", "--images", tmp_path, "--target", TARGET, "--json")
    j = res.json()
    assert j["n_images"] == 4
    reasons = {s["image"]: s["reason"] for s in j["skipped"]}
    assert reasons["blank.pgm"] == "no target found" and set(reasons) == {"broken.jpg", "blank.pgm"}
    assert reasons["broken.jpg"].startswith("not an image (")  # says why (issue 24), not just "unreadable"
    assert "broken.jpg: skipped (not an image (" in res.err


def test_too_few_images_is_refused(samples, tmp_path):
    shutil.copy(os.path.join(samples, sorted(os.listdir(samples))[0]), tmp_path)
    res = run("calibrate", "--images", tmp_path, "--target", TARGET, check=False)
    assert res.code == 2 and res.out == ""
    assert res.err.strip().splitlines()[-1].startswith("porthole: error: --images: 1 image(s)")


def test_bad_options(samples):
    assert "--target" in run_bad("calibrate", "--images", samples, "--target", "chessboard:9x6")
    assert "--free" in run_bad("calibrate", "--images", samples, "--target", TARGET, "--free", "c,k1")
    assert "--target" in run_bad("calibrate", "--images", samples)
    assert "--pixel-pitch-mm" in run_bad("calibrate", "--images", samples, "--target", TARGET,
                                         "--pixel-pitch-mm", "0")
    assert "--images" in run_bad("detect", "--images", "/nonexistent", "--target", TARGET)


def test_compare_paper_table6(tmp_path):
    """The paper's Table 6 (tests/data/menna2016_table6.csv) in air vs under water."""
    from conftest import read_table
    air = {"camera": {}, "sigma": {}, "sensor": {"width_px": 4288, "height_px": 2848, "pixel_pitch_mm": 0.0055}}
    water = json.loads(json.dumps(air))
    for row in read_table("menna2016_table6.csv"):
        for cal, col in ((air, "air"), (water, "water")):
            if row[col + "_value"]:
                cal["camera"][row["parameter"]] = float(row[col + "_value"])
                cal["sigma"][row["parameter"]] = float(row[col + "_std"])
    (tmp_path / "air.json").write_text(json.dumps(air))
    (tmp_path / "water.json").write_text(json.dumps(water))
    j = run("compare", tmp_path / "air.json", tmp_path / "water.json", "--json", "--csv-dir", tmp_path).json()
    c = next(p for p in j["parameters"] if p["parameter"] == "c_mm")
    assert c["diff_b_minus_a"] == pytest.approx(0.407, abs=1e-9)
    assert c["z"] == pytest.approx(0.407 / (0.006**2 + 0.002**2) ** 0.5, rel=1e-9)
    p1 = next(p for p in j["parameters"] if p["parameter"] == "P1")
    assert p1["a"] is None and p1["sigma_diff"] == pytest.approx(1.2e-6)
    assert j["dof"] == 5 and j["significant"] is True  # c, x0, y0, K1, K2: P1, P2 adjusted under water only
    assert [p["parameter"] for p in j["left_out"]] == ["P1", "P2"] and p1["z"] is None
    r10 = min(j["curves"], key=lambda p: abs(p["r_mm"] - 10))
    r = r10["r_mm"]
    assert r10["radial_a_um"] == pytest.approx(1e3 * (1.842e-4 * r**3 - 3.030e-7 * r**5), rel=1e-9)
    assert len(j["map"]) == j["map_cols"] * j["map_rows"]
    assert (tmp_path / "curves.csv").read_text().startswith("r_mm,")
    assert (tmp_path / "map.csv").read_text().startswith("u_px,")


def test_compare_same_detections_and_yaml(detections, tmp_path):
    run("calibrate", "--detections", detections, "--quiet", "--out", tmp_path / "a.json",
        "--opencv-yaml", tmp_path / "a.yml")
    j = run("compare", tmp_path / "a.json", tmp_path / "a.json", "--json").json()
    assert j["chi2"] == 0 and j["significant"] is False and j["max_diff_um"] == 0
    # Export to OpenCV and back: the same lens within the refit error.
    y = run("compare", tmp_path / "a.json", tmp_path / "a.yml", "--json").json()
    assert y["b_refit_rms_px"] < 0.1
    assert y["max_diff_um"] < 1e3 * 1.0  # < 1 px (pitch 1: um are 1e-3 px)
    assert "B" in run_bad("compare", tmp_path / "a.json", tmp_path / "missing.json")


def test_calibrate_any_model_of_the_list(detections, tmp_path):
    """--model picks any model of the list: the JSON names it and carries its keys; the fisheye and
    OpenCV models fit these (ordinary, mildly barrel) images as well as Brown does."""
    brown = run("calibrate", "--detections", detections, "--json", "--quiet").json()
    assert brown["model"] == "brown"
    for model, keys in [("kannala-brandt", ["fx_px", "fy_px", "cx_px", "cy_px", "k1", "k2", "k3", "k4"]),
                        ("opencv", ["fx_px", "fy_px", "cx_px", "cy_px", "k1", "k2", "p1", "p2", "k3",
                                    "k4", "k5", "k6"])]:
        j = run("calibrate", "--detections", detections, "--model", model, "--json", "--quiet").json()
        assert j["model"] == model and list(j["camera"].keys()) == keys
        assert j["status"] == "ok"
        assert j["camera"]["fx_px"] == pytest.approx(brown["camera"]["c_mm"], rel=0.01)
        assert j["rms_px"] == pytest.approx(brown["rms_px"], rel=0.25)
    # The OpenCV model's YAML is exact, and OpenCV itself reads and projects with it.
    cv2 = pytest.importorskip("cv2")
    import numpy as np
    yml, out = tmp_path / "cv.yml", tmp_path / "cv.json"
    j = run("calibrate", "--detections", detections, "--model", "opencv", "--opencv-yaml", yml,
            "--out", out, "--json", "--quiet").json()
    fs = cv2.FileStorage(str(yml), cv2.FILE_STORAGE_READ)
    k, d = fs.getNode("camera_matrix").mat(), fs.getNode("distortion_coefficients").mat()
    c = j["camera"]
    assert k[0, 0] == c["fx_px"] and k[1, 2] == c["cy_px"] and d.size == 8 and d.ravel()[0] == c["k1"] and d.ravel()[4] == 0 and c["k3"] is None
    pts = np.array([[x, y, 500.0] for x in (-200, 0, 150) for y in (-150, 0, 120)])
    theirs, _ = cv2.projectPoints(pts.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), k, d)
    if not os.environ.get("PORTHOLE_PY_DIR"):
        pytest.skip("the Python module is not built")
    import sys
    sys.path.insert(0, os.environ["PORTHOLE_PY_DIR"])
    import porthole
    cam = dict(c, model="opencv")
    ours = porthole.project(cam, pts, width_px=j["sensor"]["width_px"], height_px=j["sensor"]["height_px"])
    assert np.max(np.abs(ours - theirs.reshape(-1, 2))) < 1e-6


def test_unknown_model_is_one_line_exit_2(detections):
    line = run_bad("calibrate", "--detections", detections, "--model", "pinhole-ish")
    assert "--model" in line and "kannala-brandt" in line


def test_calibration_out_is_read_by_simulate(detections, tmp_path):
    """Every calibration porthole writes is read by every command: simulate --air-calibration
    takes the file calibrate --out writes."""
    out = tmp_path / "air.json"
    run("calibrate", "--detections", detections, "--pixel-pitch-mm", "0.0055", "--out", out, "--quiet")
    # OpenCV's samples are 640 x 480 (c 535 px x 0.0055 = 2.9 mm): simulate takes the calibration for
    # a camera it is of, and refuses it for another (the default D300 + 24 mm), naming both sizes.
    cam = tmp_path / "vga.toml"
    cam.write_text('name = "vga"\ndescription = "640 x 480"\nsource = "test"\nmount = "fixed"\nwidth_px = 640\n'
                   'height_px = 480\npixel_pitch_mm = 0.0055\n\n[lens]\nname = "vga-lens"\ndescription = "2.95 mm"\n'
                   'focal_length_mm = 2.95\nf_number_min = 2.8\nf_number_max = 2.8\nmin_focus_mm = 100.0\n'
                   'pupil = [ { focus_mm = inf, d_ep2f_mm = 10.0 } ]\n')
    j = run("simulate", "--camera", cam, "--air-calibration", out, "--json").json()
    assert j["predicted_water"]["c_mm"] > 0
    line = run_bad("simulate", "--air-calibration", out)
    assert "640 x 480" in line and "4288 x 2848" in line, line


def test_killed_calibrate_leaves_old_output_or_none_and_no_temporaries(samples, detections, tmp_path):
    """SIGKILL at any moment of `calibrate --out` (detection, adjustment, writing) leaves the old
    calibration whole or the new one whole, and the next run removes the dead run's temporary."""
    import signal
    import subprocess
    import time
    from conftest import BIN
    out = tmp_path / "cal.json"
    run("calibrate", "--detections", detections, "--out", out, "--quiet")
    old = json.loads(out.read_text())
    for delay in (0.05, 0.2, 0.5, 1.0, 1.5):
        proc = subprocess.Popen([BIN, "calibrate", "--images", str(samples), "--target", TARGET,
                                 "--model", "kannala-brandt", "--out", str(out), "--force", "--quiet"],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(delay)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        cal = json.loads(out.read_text())  # whole: it parses
        assert cal["model"] in (old["model"], "kannala-brandt"), delay
    run("calibrate", "--detections", detections, "--out", out, "--force", "--quiet")
    assert json.loads(out.read_text())["model"] == old["model"]
    assert [p for p in os.listdir(tmp_path) if ".tmp" in p] == []


def test_refractive_calibration_port_block_and_port_out(detections, tmp_path):
    """`calibrate --port` (issue 14): the JSON gains a `port` block with the estimate, its σ, the
    prediction, χ² and the BIC model choice; --port-out writes a port TOML every command reads.
    (The samples are in-air images of an unknown lens: this checks the plumbing, not the optics;
    calib_refractive_test checks the estimate on synthetic water images.)"""
    port_out = tmp_path / "as-calibrated.toml"
    j = run("calibrate", "--detections", detections, "--port", "generic-dome-4in",
            "--port-out", port_out, "--json", "--quiet").json()
    p = j["port"]
    assert p["kind"] == "dome" and p["intrinsics"] == "free"
    keys = ["ep_in_dome_x_mm", "ep_in_dome_y_mm", "ep_in_dome_z_mm"]
    for block in ("parameters", "sigma", "predicted", "predicted_sigma", "units"):
        assert list(p[block].keys()) == keys, block
    assert all(p["sigma"][k] > 0 for k in keys)
    assert p["dof"] == 3 and 0 <= p["p_value"] <= 1
    assert p["model_choice"]["preferred"] in ("refractive", "central")
    assert p["port_out"] == str(port_out)
    # The written port is read back by the port optics, and its pupil sits where the estimate says.
    vi = run("virtual-image", "--port", port_out, "--json").json()
    assert vi is not None
    text = port_out.read_text()
    assert 'type = "dome"' in text and 'frame = "housing"' in text
    # Text output: the port table and the model choice are stated.
    t = run("calibrate", "--detections", detections, "--port", "flat-acrylic-10mm",
            "--free-port", "distance", "--quiet").out
    assert "distance_mm" in t and "model choice (BIC" in t and "fixed" in t
    # Without an in-air calibration there is no lens to predict c, x0, y0 with: said so.
    assert p["central_prediction"] == {
        "available": False,
        "why_not": "needs --air-calibration, the in-air lens the prediction puts behind the port"}


def test_refractive_central_prediction_block(detections, tmp_path):
    """With --air-calibration the port block compares the simulate prediction of the water c, x0,
    y0 with the estimate's (calib_refractive_test checks the numbers on synthetic water images)."""
    air = tmp_path / "air.json"
    run("calibrate", "--detections", detections, "--out", air, "--quiet")
    j = run("calibrate", "--detections", detections, "--port", "generic-dome-4in",
            "--air-calibration", air, "--air-lens-bare", "--json", "--quiet").json()
    cp = j["port"]["central_prediction"]
    assert cp["available"] is True and cp["dof"] == 3 and 0 <= cp["p_value"] <= 1
    for block in ("predicted", "predicted_sigma", "estimated", "estimated_sigma",
                  "central_calibration", "central_calibration_sigma"):
        assert list(cp[block].keys()) == ["c_mm", "x0_mm", "y0_mm"], block
    assert all(cp["estimated_sigma"][k] > 0 for k in cp["estimated_sigma"])
    assert len(cp["distances_mm"]) == 3
    t = run("calibrate", "--detections", detections, "--port", "generic-dome-4in",
            "--air-calibration", air, "--air-lens-bare", "--quiet").out
    assert "c, x0, y0 estimate vs prediction: chi2" in t


def test_refractive_bad_input_is_one_line_exit_2(detections, tmp_path):
    run_bad("calibrate", "--detections", detections, "--port", "no-such-port")
    run_bad("calibrate", "--detections", detections, "--port-out", tmp_path / "p.toml")
    run_bad("calibrate", "--detections", detections, "--air-calibration", tmp_path / "a.json")
    run_bad("calibrate", "--detections", detections, "--port", "nimar-ni320", "--intrinsics", "fixed")
    run_bad("calibrate", "--detections", detections, "--port", "nimar-ni320", "--free-port", "ep_q")
    run_bad("calibrate", "--detections", detections, "--port", "nimar-ni320", "--opencv-yaml",
            tmp_path / "x.yml")
    run_bad("calibrate", "--detections", tmp_path / "none", "--port", "nimar-ni320")
    # A port the pupil is not in.
    run_bad("calibrate", "--detections", detections, "--port", "nimar-ni320", "--ep", "0,0,200")


def test_refractive_plan_only(detections, tmp_path):
    """`calibrate --port --plan-only` (issue 14, network advice): the σ the images' poses give the
    port at the pixel noise assumed, no adjustment (calib_refractive_test checks the σ against
    Monte Carlo); the σ scale with --plan-sigma-px; bad input is one line, exit 2."""
    out = tmp_path / "plan.json"
    j = run("calibrate", "--detections", detections, "--port", "flat-acrylic-10mm", "--plan-only",
            "--json", "--quiet", "--out", out).json()
    p = j["plan"]
    assert p["kind"] == "flat" and p["determined"] is True and p["sigma0_px"] == 0.3
    assert list(p["port_sigma"].keys()) == ["normal_x", "normal_y", "distance_mm"]
    assert all(v > 0 for v in p["port_sigma"].values())
    assert "port" not in j and out.exists()
    j2 = run("calibrate", "--detections", detections, "--port", "flat-acrylic-10mm", "--plan-only",
             "--plan-sigma-px", "0.6", "--json", "--quiet").json()
    for k, v in p["port_sigma"].items():
        assert abs(j2["plan"]["port_sigma"][k] / v - 2) < 1e-6, k
    t = run("calibrate", "--detections", detections, "--port", "generic-dome-4in", "--plan-only",
            "--quiet").out
    assert "network advice for port generic-dome-4in" in t and "ep_in_dome_z_mm" in t
    run_bad("calibrate", "--detections", detections, "--plan-only")
    run_bad("calibrate", "--detections", detections, "--port", "nimar-ni320", "--plan-only",
            "--plan-sigma-px", "0")
    run_bad("calibrate", "--detections", detections, "--port", "nimar-ni320", "--plan-only",
            "--port-out", tmp_path / "p.toml")
