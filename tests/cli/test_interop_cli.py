"""`porthole convert` against the real clients of each format (docs/interop.md):
- COLMAP 3.8 (`colmap model_converter`) reads the cameras.txt porthole writes and writes it back, as TXT
  with the parameters unchanged and as cameras.bin, which porthole reads back to the same camera;
- mrcal (python3-mrcal) loads the .cameramodel and mrcal.project agrees with porthole's projection to
  <= 1e-6 px on a grid of rays over the image;
- OpenCV (cv2.FileStorage + cv2.projectPoints) reads the YAML and agrees to <= 1e-6 px;
- a Brown calibration (the paper's Table 6, in air) written to COLMAP is a refit with RMS < 0.01 px;
- malformed files: exit 2, one line naming the file and the field, no output file."""
import json
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

from conftest import run, run_bad

if os.environ.get("PORTHOLE_PY_DIR"):
    sys.path.insert(0, os.environ["PORTHOLE_PY_DIR"])

SENSOR = dict(width_px=4288, height_px=2848, pixel_pitch_mm=0.0055)
OPENCV = {"fx_px": 4690.25, "fy_px": 4692.5, "cx_px": 2150.3, "cy_px": 1420.7, "k1": -0.1, "k2": 0.05,
          "p1": 1e-4, "p2": -2e-4, "k3": -0.01, "k4": 0.02, "k5": 0.005, "k6": 0.001}
KB = {"fx_px": 1909, "fy_px": 1911, "cx_px": 2150, "cy_px": 1418, "k1": -0.0405, "k2": 0.0006, "k3": -0.0001,
      "k4": 0.00002}
TABLE6_AIR = {"c_mm": 25.801, "x0_mm": -0.026, "y0_mm": -0.144, "K1": 1.842e-4, "K2": -3.030e-7}


def write_calib(path, model, params):
    path.write_text(json.dumps({"model": model, "camera": params, "sensor": SENSOR}))
    return path


def rays_over_image(cam):
    """Rays through a 21 x 15 grid of pixels spanning the whole frame, by porthole's unproject."""
    import porthole
    u, v = np.meshgrid(np.linspace(0, SENSOR["width_px"] - 1, 21), np.linspace(0, SENSOR["height_px"] - 1, 15))
    uv = np.stack([u.ravel(), v.ravel()], 1)
    return porthole.unproject(cam, uv, **SENSOR) * 1000.0


def colmap_params(path):
    lines = [l.split() for l in path.read_text().splitlines() if l.strip() and not l.startswith("#")]
    assert len(lines) == 1
    return lines[0][1], [int(lines[0][2]), int(lines[0][3])], [float(x) for x in lines[0][4:]]


@pytest.mark.skipif(shutil.which("colmap") is None, reason="colmap not installed (scripts/install-deps)")
@pytest.mark.parametrize("model,params,colmap_model", [("opencv", OPENCV, "FULL_OPENCV"),
                                                       ("kannala-brandt", KB, "OPENCV_FISHEYE")])
def test_colmap_model_converter_reads_and_writes_back_unchanged(tmp_path, model, params, colmap_model):
    src = write_calib(tmp_path / "calib.json", model, params)
    sparse = tmp_path / "sparse"
    sparse.mkdir()
    run("convert", src, sparse)  # a directory: its cameras.txt
    (sparse / "images.txt").write_text("")
    (sparse / "points3D.txt").write_text("")
    name, size, ours = colmap_params(sparse / "cameras.txt")
    assert name == colmap_model and size == [SENSOR["width_px"], SENSOR["height_px"]]
    # COLMAP's principal point is porthole's + 0.5 px; the rest is parameter for parameter.
    expected = list(params.values())
    expected[2] += 0.5
    expected[3] += 0.5
    assert ours == pytest.approx(expected, rel=1e-15, abs=1e-15)
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen")
    for out_type in ("TXT", "BIN"):
        out = tmp_path / out_type
        out.mkdir()
        subprocess.run(["colmap", "model_converter", "--input_path", sparse, "--output_path", out,
                        "--output_type", out_type], check=True, capture_output=True, env=env, timeout=120)
    name2, size2, theirs = colmap_params(tmp_path / "TXT" / "cameras.txt")
    assert (name2, size2) == (name, size) and theirs == ours  # unchanged to the last digit
    # COLMAP's cameras.bin, read by porthole, is the same camera.
    back = run("convert", tmp_path / "BIN" / "cameras.bin", tmp_path / "back.json", "--json").json()
    assert back["in_model"] == colmap_model and back["exact"]
    got = json.loads((tmp_path / "back.json").read_text())
    assert got["model"] == model
    assert list(got["camera"].values()) == pytest.approx(list(params.values()), rel=1e-14, abs=1e-12)


@pytest.mark.parametrize("extra", [{}, {"k4": 0.0, "k5": 0.0, "k6": 0.0}, {"k3": 0.0, "k4": 0.0, "k5": 0.0, "k6": 0.0}])
def test_mrcal_loads_the_cameramodel_and_projects_as_porthole(tmp_path, extra):
    mrcal = pytest.importorskip("mrcal")
    porthole = pytest.importorskip("porthole")
    params = dict(OPENCV, **extra)
    src = write_calib(tmp_path / "calib.json", "opencv", params)
    res = run("convert", src, tmp_path / "cam.cameramodel", "--json").json()
    assert res["exact"]
    model = mrcal.cameramodel(str(tmp_path / "cam.cameramodel"))
    lensmodel, intrinsics = model.intrinsics()
    assert lensmodel == res["out_model"]
    assert list(model.imagersize()) == [SENSOR["width_px"], SENSOR["height_px"]]
    cam = dict(params, model="opencv")
    pts = rays_over_image(cam)
    theirs = mrcal.project(pts, lensmodel, intrinsics)
    ours = porthole.project(cam, pts, **SENSOR)
    assert np.max(np.abs(theirs - ours)) <= 1e-6


def test_mrcal_and_opencv_agree_with_a_refit_brown_calibration(tmp_path):
    """Brown -> mrcal and OpenCV YAML is a refit: the clients project the refit camera as porthole reads it back."""
    mrcal = pytest.importorskip("mrcal")
    cv2 = pytest.importorskip("cv2")
    porthole = pytest.importorskip("porthole")
    src = write_calib(tmp_path / "brown.json", "brown", TABLE6_AIR)
    for out in ("cam.cameramodel", "cam.yml", "cameras.txt"):
        res = run("convert", src, tmp_path / out, "--json").json()
        assert not res["exact"] and 0 < res["refit_rms_px"] < 0.01
    run("convert", tmp_path / "cam.cameramodel", tmp_path / "back.json")
    back = json.loads((tmp_path / "back.json").read_text())
    cam = dict(back["camera"], model="opencv")
    pts = rays_over_image(cam)
    ours = porthole.project(cam, pts, **SENSOR)
    model = mrcal.cameramodel(str(tmp_path / "cam.cameramodel"))
    assert np.max(np.abs(mrcal.project(pts, *model.intrinsics()) - ours)) <= 1e-6
    fs = cv2.FileStorage(str(tmp_path / "cam.yml"), cv2.FILE_STORAGE_READ)
    k, d = fs.getNode("camera_matrix").mat(), fs.getNode("distortion_coefficients").mat()
    theirs, _ = cv2.projectPoints(pts.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), k, d)
    assert np.max(np.abs(theirs.reshape(-1, 2) - ours)) <= 1e-6


def test_opencv_reads_the_yaml_and_projects_as_porthole(tmp_path):
    cv2 = pytest.importorskip("cv2")
    porthole = pytest.importorskip("porthole")
    src = write_calib(tmp_path / "calib.json", "opencv", OPENCV)
    assert run("convert", src, tmp_path / "cam.yml", "--json").json()["exact"]
    fs = cv2.FileStorage(str(tmp_path / "cam.yml"), cv2.FILE_STORAGE_READ)
    k, d = fs.getNode("camera_matrix").mat(), fs.getNode("distortion_coefficients").mat()
    assert [int(fs.getNode("image_width").real()), int(fs.getNode("image_height").real())] == [4288, 2848]
    cam = dict(OPENCV, model="opencv")
    pts = rays_over_image(cam)
    theirs, _ = cv2.projectPoints(pts.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), k, d)
    assert np.max(np.abs(theirs.reshape(-1, 2) - porthole.project(cam, pts, **SENSOR))) <= 1e-6
    # And porthole reads the YAML back exactly.
    run("convert", tmp_path / "cam.yml", tmp_path / "back.json")
    got = json.loads((tmp_path / "back.json").read_text())["camera"]
    assert got == pytest.approx(OPENCV, rel=1e-15)


def test_malformed_files_one_line_naming_file_and_field(tmp_path):
    bad = tmp_path / "cameras.txt"
    bad.write_text("1 OPENCV 640 480 500 500 320\n")
    line = run_bad("convert", bad, tmp_path / "out.json")
    assert "cameras.txt" in line and "PARAMS" in line
    assert not (tmp_path / "out.json").exists()
    model = tmp_path / "m.cameramodel"
    model.write_text("{'lensmodel': 'LENSMODEL_OPENCV4', 'intrinsics': __import__('os'), 'imagersize': [1, 1]}")
    line = run_bad("convert", model, tmp_path / "out.json")
    assert "m.cameramodel" in line and "not a Python literal" in line
    yml = tmp_path / "c.yml"
    yml.write_text("%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\n")
    assert "camera_matrix" in run_bad("convert", yml, tmp_path / "out.json")
    src = write_calib(tmp_path / "kb.json", "kannala-brandt", KB)
    assert "mrcal" in run_bad("convert", src, tmp_path / "out.cameramodel")
    assert "--to" in run_bad("convert", src, tmp_path / "out.xyz")
    assert not (tmp_path / "out.cameramodel").exists() and not (tmp_path / "out.xyz").exists()


METASHAPE_P1 = ("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<calibration>\n  <projection>frame</projection>\n"
                "  <width>4000</width>\n  <height>3000</height>\n  <f>3000</f>\n  <cx>10</cx>\n  <cy>-20</cy>\n"
                "  <k1>0</k1>\n  <k2>0</k2>\n  <p1>0.001</p1>\n  <p2>0</p2>\n</calibration>\n")


def test_metashape_conventions_checked_by_opencv(tmp_path):
    """Metashape's frame model (manual 1.5, Appendix C): for f = 3000, cx = 10, cy = -20, P1 = 1e-3 the
    point (0.2, 0.1, 1) lands at (2610.39, 1780.12) in Metashape's pixels (top-left pixel centre 0.5,
    0.5), by hand (interop_test). Converted to OpenCV YAML, cv2.projectPoints puts it 0.5 px less on both
    axes: the half-pixel shift and Metashape's P1 = OpenCV's p2, checked by OpenCV itself."""
    cv2 = pytest.importorskip("cv2")
    src = tmp_path / "cal.xml"
    src.write_text(METASHAPE_P1)
    res = run("convert", src, tmp_path / "cam.yml", "--json").json()
    assert res["in_format"] == "metashape" and res["in_model"] == "frame" and res["exact"]
    fs = cv2.FileStorage(str(tmp_path / "cam.yml"), cv2.FILE_STORAGE_READ)
    k, d = fs.getNode("camera_matrix").mat(), fs.getNode("distortion_coefficients").mat()
    uv, _ = cv2.projectPoints(np.array([[[0.2, 0.1, 1.0]]]), np.zeros(3), np.zeros(3), k, d)
    assert uv.ravel() == pytest.approx([2610.39 - 0.5, 1780.12 - 0.5], abs=1e-9)
    # And back to Metashape: the same file numbers.
    run("convert", tmp_path / "cam.yml", tmp_path / "back.xml")
    back = (tmp_path / "back.xml").read_text()
    for tag, value in (("f", 3000), ("cx", 10), ("cy", -20), ("p1", 0.001), ("p2", 0)):
        text = back.split(f"<{tag}>")[1].split(f"</{tag}>")[0]
        assert float(text) == pytest.approx(value, abs=1e-9)


def test_every_command_reads_every_format(tmp_path):
    """compare, simulate --air-calibration and report read a calibration of any format (one loader,
    interop::ReadCalibrationFile): here the paper's Table 6 in-air calibration written as Metashape XML,
    COLMAP and OpenCV YAML (refits of the Brown camera, RMS < 0.01 px) and read back as Brown."""
    src = write_calib(tmp_path / "air.json", "brown", TABLE6_AIR)
    for out in ("air.xml", "cameras.txt", "air.yml"):
        assert run("convert", src, tmp_path / out, "--json").json()["refit_rms_px"] < 0.01
    base = run("simulate", "--air-calibration", src, "--json").json()
    for out in ("air.xml", "cameras.txt", "air.yml"):
        j = run("simulate", "--air-calibration", tmp_path / out, "--json").json()
        assert 0 < j["air_calibration_refit_rms_px"] < 0.01, out
        # The prediction from the refit calibration: c within 1e-4 mm of the one from the JSON.
        assert j["predicted_water"]["c_mm"] == pytest.approx(base["predicted_water"]["c_mm"], abs=1e-4), out
        c = run("compare", src, tmp_path / out, "--pixel-pitch-mm", "0.0055", "--json").json()
        assert c["b_refit_rms_px"] < 0.01 and c["max_diff_um"] < 1.0, out  # < 0.2 px of 5.5 µm
        # The file holds no σ: unknown, not 0 -- no z and no chi2.
        assert all(r["sigma_b"] is None and r["z"] is None for r in c["parameters"] if r["b"] is not None), out
        assert c["chi2"] is None and "no significance test" in c["covariance"], out


CALIBMAR_DOME = """model: OPENCV
# fx, fy, cx, cy, k1, k2, p1, p2
parameters: [1500.5, 1501.25, 960.5, 540.5, -0.1, 0.05, 0.0001, -0.0002]
# params_est_std_dev: 0.8, 0.7, 0.5, 0.4, 0.001, 0.002, 1e-05, 2e-05
non_svp_model: DOMEPORT
# Cx, Cy, Cz, int_radius, int_thick, na, ng, nw
non_svp_parameters: [0.002, -0.001, 0.003, 0.1, 0.008, 1, 1.5, 1.334]
width: 1920
height: 1080
# overall_rms: 0.21
# target: chessboard, 10, 7, 0.04
"""


def test_calibmar_housing_to_port_and_back(tmp_path):
    """calibmar's calibration.yaml: the camera with its sigma, and its DOMEPORT as a porthole port TOML that
    `plan` reads (cam frame, mm); the port back into calibmar's file gives the same housing."""
    src = tmp_path / "calibration.yaml"
    src.write_text(CALIBMAR_DOME)
    res = run("convert", src, tmp_path / "cal.json", "--port-out", tmp_path / "dome.toml", "--json").json()
    assert res["in_format"] == "calibmar" and res["housing"] == "DOMEPORT" and res["water_index"] == 1.334
    assert res["in_rms_px"] == 0.21 and res["exact"]
    cal = json.loads((tmp_path / "cal.json").read_text())
    assert cal["camera"]["cx_px"] == 960.0 and cal["sigma"]["cx_px"] == pytest.approx(0.5)
    toml = (tmp_path / "dome.toml").read_text()
    assert 'frame = "cam"' in toml and "radius_mm = 100" in toml and "center_mm = [2, -1, 3]" in toml
    plan = run("plan", "--port", tmp_path / "dome.toml", "--water-index", "1.334", "--json").json()
    assert plan is not None
    run("convert", tmp_path / "cal.json", tmp_path / "back.yaml", "--to", "calibmar", "--port",
        tmp_path / "dome.toml", "--water-index", "1.334")
    back = (tmp_path / "back.yaml").read_text()
    housing = [float(x) for x in back.split("non_svp_parameters: [")[1].split("]")[0].split(",")]
    assert housing == pytest.approx([0.002, -0.001, 0.003, 0.1, 0.008, 1, 1.5, 1.334], rel=1e-12)
    assert "DOMEPORT is concentric" in run_bad("convert", tmp_path / "cal.json", tmp_path / "x.yaml", "--to",
                                               "calibmar", "--port", "nimar-ni320")
    assert not (tmp_path / "x.yaml").exists()
    bad = tmp_path / "bad.yaml"
    bad.write_text(CALIBMAR_DOME.replace("DOMEPORT", "SPHEREPORT"))
    line = run_bad("convert", bad, tmp_path / "y.json")
    assert "bad.yaml" in line and "non_svp_model" in line


def test_mrcal_extrinsics_survive_a_round_trip_through_porthole(tmp_path):
    """A .cameramodel written by mrcal itself, with extrinsics rt_fromref, read and written by porthole: mrcal
    loads the result with the same rt_fromref and intrinsics; a COLMAP file with two cameras gives one by id."""
    mrcal = pytest.importorskip("mrcal")
    rt = np.array([0.1, -0.2, 0.3, 10.0, 20.0, -30.0])
    intr = np.array([500.0, 501.0, 320.0, 240.0, -0.1, 0.01, 1e-4, -2e-4])
    mrcal.cameramodel(intrinsics=("LENSMODEL_OPENCV4", intr), imagersize=(640, 480),
                      extrinsics_rt_fromref=rt).write(str(tmp_path / "in.cameramodel"))
    run("convert", tmp_path / "in.cameramodel", tmp_path / "out.cameramodel")
    back = mrcal.cameramodel(str(tmp_path / "out.cameramodel"))
    assert np.array_equal(back.extrinsics_rt_fromref(), rt)
    assert np.array_equal(back.intrinsics()[1], intr)
    two = tmp_path / "cameras.txt"
    two.write_text("1 PINHOLE 640 480 500 501 320.5 240.5\n7 SIMPLE_PINHOLE 800 600 700 400.5 300.5\n")
    assert "--camera-id" in run_bad("convert", two, tmp_path / "c.json")
    run("convert", two, tmp_path / "c.json", "--camera-id", "7")
    assert json.loads((tmp_path / "c.json").read_text())["sensor"]["width_px"] == 800


def cv_read(path, k_key="camera_matrix", d_key="distortion_coefficients"):
    import cv2
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    assert fs.isOpened(), path
    k, d = fs.getNode(k_key).mat(), fs.getNode(d_key).mat()
    size = [int(fs.getNode("image_width").real()), int(fs.getNode("image_height").real())]
    fisheye = int(fs.getNode("fisheye_model").real())
    fs.release()
    return k, d, size, fisheye


@pytest.mark.parametrize("ext,to", [("yml", None), ("xml", "opencv-xml")])
def test_opencv_filestorage_pinhole_and_fisheye_read_by_cv2(tmp_path, ext, to):
    """porthole writes OpenCV FileStorage YAML and XML; cv2.FileStorage reads it, and cv2.projectPoints
    (opencv model) and cv2.fisheye.projectPoints (kannala-brandt) agree with porthole's projection to
    <= 1e-6 px over a 21 x 15 grid of rays through the image; porthole reads its file back exactly."""
    cv2 = pytest.importorskip("cv2")
    porthole = pytest.importorskip("porthole")
    extra = ["--to", to] if to else []
    for model, params in (("opencv", OPENCV), ("kannala-brandt", KB)):
        src = write_calib(tmp_path / f"{model}.json", model, params)
        out = tmp_path / f"{model}.{ext}"
        res = run("convert", src, out, *extra, "--json").json()
        assert res["exact"] and res["out_format"] == (to or "opencv-yaml")
        k, d, size, fisheye = cv_read(out)
        assert size == [SENSOR["width_px"], SENSOR["height_px"]] and fisheye == (model == "kannala-brandt")
        cam = dict(params, model=model)
        pts = rays_over_image(cam)
        ours = porthole.project(cam, pts, **SENSOR)
        if model == "opencv":
            theirs, _ = cv2.projectPoints(pts.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), k, d)
        else:
            theirs, _ = cv2.fisheye.projectPoints(pts.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), k, d)
        assert np.max(np.abs(theirs.reshape(-1, 2) - ours)) <= 1e-6, model
        back = run("convert", out, tmp_path / "back.json", "--json", "--force").json()
        assert back["in_format"] == (to or "opencv-yaml")
        got = json.loads((tmp_path / "back.json").read_text())
        assert got["model"] == model and got["camera"] == pytest.approx(params, rel=1e-15)


@pytest.mark.parametrize("ext", ["xml", "yml"])
def test_porthole_reads_what_cv2_filestorage_writes(tmp_path, ext):
    """Files written by cv2.FileStorage itself, in both key spellings (camera_matrix /
    distortion_coefficients / image_width, image_height and cameraMatrix / distCoeffs / imageSize), and
    cv::fisheye's K, D: porthole reads the same numbers, and picks the fisheye model for K, D."""
    cv2 = pytest.importorskip("cv2")
    k = np.array([[4690.25, 0, 2150.3], [0, 4692.5, 1420.7], [0, 0, 1]])
    d5 = np.array([[-0.1, 0.05, 1e-4, -2e-4, -0.01]])
    kf = np.array([[1909.0, 0, 2150], [0, 1911, 1418], [0, 0, 1]])
    d4 = np.array([[-0.0405], [0.0006], [-0.0001], [0.00002]])
    layouts = {
        "snake": (lambda fs: (fs.write("image_width", 4288), fs.write("image_height", 2848),
                              fs.write("camera_matrix", k), fs.write("distortion_coefficients", d5)), "opencv"),
        "camel": (lambda fs: (fs.write("imageSize", (4288, 2848)), fs.write("cameraMatrix", k),
                              fs.write("distCoeffs", d5)), "opencv"),
        "fisheye": (lambda fs: (fs.write("image_width", 4288), fs.write("image_height", 2848),
                                fs.write("K", kf), fs.write("D", d4)), "kannala-brandt"),
    }
    for name, (fill, model) in layouts.items():
        path = tmp_path / f"{name}.{ext}"
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
        fill(fs)
        fs.release()
        res = run("convert", path, tmp_path / "out.json", "--json", "--force").json()
        assert res["in_format"] == ("opencv-xml" if ext == "xml" else "opencv-yaml"), name
        got = json.loads((tmp_path / "out.json").read_text())
        assert got["model"] == model and got["sensor"]["width_px"] == 4288, name
        kk, dd = (k, d5) if model == "opencv" else (kf, d4)
        c = got["camera"]
        assert [c["fx_px"], c["fy_px"], c["cx_px"], c["cy_px"]] == [kk[0, 0], kk[1, 1], kk[0, 2], kk[1, 2]], name
        names = ["k1", "k2", "p1", "p2", "k3"] if model == "opencv" else ["k1", "k2", "k3", "k4"]
        assert [c[n] for n in names] == list(dd.ravel()), name


@pytest.mark.skipif(shutil.which("colmap") is None, reason="colmap not installed (scripts/install-deps)")
def test_several_cameras_into_one_cameras_txt_read_by_colmap(tmp_path):
    """`convert A B C cameras.txt` writes CAMERA_ID 1, 2, 3; colmap model_converter reads it and writes
    every line back unchanged; porthole reads each back by --camera-id, exactly."""
    pinhole = {"fx_px": 700.0, "fy_px": 700.0, "cx_px": 399.5, "cy_px": 299.5}
    srcs = [write_calib(tmp_path / "a.json", "opencv", OPENCV), write_calib(tmp_path / "b.json", "kannala-brandt", KB),
            write_calib(tmp_path / "c.json", "opencv", pinhole)]
    sparse = tmp_path / "sparse"
    sparse.mkdir()
    res = run("convert", *srcs, sparse / "cameras.txt", "--json").json()
    assert res["exact"] and res["out_model"] == "FULL_OPENCV, OPENCV_FISHEYE, SIMPLE_PINHOLE"
    assert [c["camera_id"] for c in res["cameras"]] == [1, 2, 3]
    (sparse / "images.txt").write_text("")
    (sparse / "points3D.txt").write_text("")
    out = tmp_path / "TXT"
    out.mkdir()
    subprocess.run(["colmap", "model_converter", "--input_path", sparse, "--output_path", out, "--output_type", "TXT"],
                   check=True, capture_output=True, env=dict(os.environ, QT_QPA_PLATFORM="offscreen"), timeout=120)

    def lines(p):
        return sorted(l.split() for l in p.read_text().splitlines() if l.strip() and not l.startswith("#"))
    ours, theirs = lines(sparse / "cameras.txt"), lines(out / "cameras.txt")
    assert len(ours) == 3 and [[float(x) for x in l[2:]] for l in theirs] == [[float(x) for x in l[2:]] for l in ours]
    assert [l[:2] for l in theirs] == [l[:2] for l in ours]
    for cid, (model, params) in enumerate((("opencv", OPENCV), ("kannala-brandt", KB), ("opencv", pinhole)), 1):
        run("convert", out / "cameras.txt", tmp_path / "back.json", "--camera-id", cid, "--force")
        got = json.loads((tmp_path / "back.json").read_text())
        assert got["model"] == model
        assert {k: got["camera"][k] for k in params} == pytest.approx(params, rel=1e-15)
    assert "only COLMAP" in run_bad("convert", *srcs[:2], tmp_path / "x.yml")
    assert not (tmp_path / "x.yml").exists()


def test_refractive_colmap_cameras_txt_with_the_housing(tmp_path):
    """calibmar's DOMEPORT into a refractive COLMAP cameras.txt ("... PARAMS[] DOMEPORT p1..p8", the
    COLMAP-Underwater fork's WriteCamerasText), back to a port TOML with the housing's sigma as a
    [sigma] table that `plan` reads; the later "REFRAC DOMEPORT ..." form reads the same; --port puts a
    porthole port into cameras.txt."""
    src = tmp_path / "calibration.yaml"
    src.write_text(CALIBMAR_DOME.replace("non_svp_model: DOMEPORT",
                                         "non_svp_model: DOMEPORT\n# non_svp_est_std_dev: 0.0002, 0.0001, 0.0003"))
    res = run("convert", src, tmp_path / "cameras.txt", "--json").json()
    assert res["housing_written"] and res["out_model"] == "OPENCV + DOMEPORT"
    line = [l for l in (tmp_path / "cameras.txt").read_text().splitlines() if not l.startswith("#")][0].split()
    assert line[1] == "OPENCV" and line[12] == "DOMEPORT"
    assert [float(x) for x in line[13:]] == [0.002, -0.001, 0.003, 0.1, 0.008, 1, 1.5, 1.334]
    res = run("convert", tmp_path / "cameras.txt", tmp_path / "cal.json", "--port-out", tmp_path / "dome.toml",
              "--json").json()
    assert res["housing"] == "DOMEPORT" and res["water_index"] == 1.334
    refrac = tmp_path / "refrac.txt"
    refrac.write_text((tmp_path / "cameras.txt").read_text().replace(" DOMEPORT ", " REFRAC DOMEPORT "))
    run("convert", refrac, tmp_path / "cal2.json", "--port-out", tmp_path / "dome2.toml")
    assert (tmp_path / "dome2.toml").read_text() == (tmp_path / "dome.toml").read_text()
    assert "[sigma]" not in (tmp_path / "dome.toml").read_text()  # cameras.txt holds no sigma
    # The housing's sigma from calibmar's comment (metres), in the port's units (mm).
    run("convert", src, tmp_path / "cal0.json", "--port-out", tmp_path / "sigma.toml")
    toml = (tmp_path / "sigma.toml").read_text()
    assert "[sigma]\ncenter_mm = [0.2, 0.1, 0.3]\n" in toml, toml
    run("plan", "--port", tmp_path / "sigma.toml", "--water-index", "1.334", "--json")
    bad = tmp_path / "bad.toml"
    bad.write_text(toml.replace("center_mm = [0.2,", "center_mm = [-0.2,"))
    assert "sigma.center_mm" in run_bad("plan", "--port", bad, "--water-index", "1.334")
    # A porthole port into cameras.txt.
    run("convert", tmp_path / "cal.json", tmp_path / "again.txt", "--port", tmp_path / "dome.toml",
        "--water-index", "1.334")
    again = [l for l in (tmp_path / "again.txt").read_text().splitlines() if not l.startswith("#")][0].split()
    assert [float(x) for x in again[13:]] == pytest.approx([0.002, -0.001, 0.003, 0.1, 0.008, 1, 1.5, 1.334],
                                                           rel=1e-12)
    # Malformed housing tokens: one line naming the file and the field.
    broken = tmp_path / "broken.txt"
    broken.write_text("1 PINHOLE 640 480 500 500 320 240 DOMEPORT 0 0 0 0.1\n")
    assert "broken.txt" in (l := run_bad("convert", broken, tmp_path / "y.json")) and "REFRAC_PARAMS" in l
    broken.write_text("1 PINHOLE 640 480 500 500 320 240 SPHEREPORT 0 0 0 0.1 0.01 1 1.5 1.33\n")
    assert "REFRAC_MODEL" in run_bad("convert", broken, tmp_path / "y.json")
    assert not (tmp_path / "y.json").exists()


LEFT_INTRINSICS = """%YAML:1.0
---
image_width: 640
image_height: 480
camera_matrix: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ 5.3591573396163199e+02, 0., 3.4228315473308373e+02, 0.,
       5.3591573396163199e+02, 2.3557082909788173e+02, 0., 0., 1. ]
distortion_coefficients: !!opencv-matrix
   rows: 5
   cols: 1
   dt: d
   data: [ -2.6637260909660682e-01, -3.8588898922304653e-02,
       1.7831947042852964e-03, -2.8122100441115472e-04,
       2.3839153080878486e-01 ]
"""


# A camera OpenCV's sample calibration fits (640 x 480 px; fx 534.8 px x 0.006 mm = 3.21 mm): simulate
# refuses a calibration of another camera (docs/robustness.md, "Calibrations"), so it needs its own.
VGA_CAMERA = """name = "vga-test-camera"
description = "a 640 x 480 camera with a fixed 3.2 mm lens, for OpenCV's sample calibration"
source = "test"
mount = "fixed"
width_px = 640
height_px = 480
pixel_pitch_mm = 0.006

[lens]
name = "vga-test-lens"
description = "3.2 mm fixed lens"
focal_length_mm = 3.2
f_number_min = 2.8
f_number_max = 2.8
min_focus_mm = 100.0
pupil = [
  { focus_mm = inf, d_ep2f_mm = 10.0 },
]
"""


def test_strong_k3_opencv_yaml_through_simulate(tmp_path):
    """OpenCV's sample calibration with k3 = 0.24 (opencv-doc's left_intrinsics.yml, its camera part), on
    the 640 x 480 camera it is of (on the default D300 it is refused: another camera). simulate refits it
    to Brown, and the Brown fits through the port end with RMS inf (the Brown projection has no inverse
    toward the corners): an impossible result, now one error line naming the fit, where simulate printed
    RMS "inf" with exit 0 (docs/robustness.md, "Calibrations")."""
    src = tmp_path / "left_intrinsics.yml"
    src.write_text(LEFT_INTRINSICS)
    cam = tmp_path / "vga.toml"
    cam.write_text(VGA_CAMERA)
    line = run_bad("simulate", "--camera", cam, "--air-calibration", src, "--json")
    assert line.startswith("porthole: error: fit: the ") and "fit is impossible: its RMS is inf" in line, line
    line = run_bad("simulate", "--air-calibration", src)
    assert "640 x 480" in line and "4288 x 2848" in line, line