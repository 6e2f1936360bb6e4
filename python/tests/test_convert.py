"""Proves porthole.convert() is `porthole convert` (issue 25) and that what it writes is what the real
clients read: OpenCV (cv2.FileStorage + cv2.projectPoints) reads its YAML and projects as porthole to
<= 1e-6 px; COLMAP 3.8 (`colmap model_converter`) reads the cameras.txt of two inputs; a stereo file cv2
writes itself (T in metres) comes in as a rig (the CLI's JSON and file) whose K, D, R and T are cv2's, and goes back out as
cv2 reads it; a Brown calibration written to OpenCV YAML is a refit (RMS < 0.01 px) reported as the
CLI reports it; bad input raises one-line ValueErrors naming the keyword and writes nothing."""
import json
import os
import shutil
import subprocess
import warnings

import numpy as np
import pytest

import porthole

cv2 = pytest.importorskip("cv2")
BIN = os.environ.get("PORTHOLE_BIN", "porthole")

SENSOR = dict(width_px=4288, height_px=2848, pixel_pitch_mm=0.0055)
OPENCV = {"fx_px": 4690.25, "fy_px": 4692.5, "cx_px": 2150.3, "cy_px": 1420.7, "k1": -0.1, "k2": 0.05,
          "p1": 1e-4, "p2": -2e-4, "k3": -0.01, "k4": 0.02, "k5": 0.005, "k6": 0.001}
KB = {"fx_px": 1909, "fy_px": 1911, "cx_px": 2150, "cy_px": 1418, "k1": -0.0405, "k2": 0.0006, "k3": -0.0001,
      "k4": 0.00002}
TABLE6_AIR = {"c_mm": 25.801, "x0_mm": -0.026, "y0_mm": -0.144, "K1": 1.842e-4, "K2": -3.030e-7}  # the paper's Table 6


def write_calib(path, model, params):
    path.write_text(json.dumps({"model": model, "camera": params, "sensor": SENSOR}))
    return path


def rays_over_image(cam):
    """Rays through a 21 x 15 grid of pixels spanning the frame (porthole's unproject), mm."""
    u, v = np.meshgrid(np.linspace(0, SENSOR["width_px"] - 1, 21), np.linspace(0, SENSOR["height_px"] - 1, 15))
    return porthole.unproject(cam, np.stack([u.ravel(), v.ravel()], 1), **SENSOR) * 1000.0


def cv2_projects(path, pts):
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    k, d = fs.getNode("camera_matrix").mat(), fs.getNode("distortion_coefficients").mat()
    fs.release()
    uv, _ = cv2.projectPoints(pts.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), k, d)
    return uv.reshape(-1, 2)


def test_opencv_yaml_read_by_cv2(tmp_path):
    src = write_calib(tmp_path / "calib.json", "opencv", OPENCV)
    r = porthole.convert(src, tmp_path / "cam.yml")
    assert isinstance(r, porthole.ConvertResult)
    assert r.exact and r.out_format == "opencv-yaml" and r.in_format == "json" and r.refit_rms_px == 0
    assert r.out_files == [str(tmp_path / "cam.yml")] and r.warnings == []
    cam = dict(OPENCV, model="opencv")
    pts = rays_over_image(cam)
    assert np.max(np.abs(cv2_projects(tmp_path / "cam.yml", pts) - porthole.project(cam, pts, **SENSOR))) <= 1e-6


def test_brown_refit_reported_as_the_cli_reports_it(tmp_path):
    src = write_calib(tmp_path / "brown.json", "brown", TABLE6_AIR)
    r = porthole.convert([src], tmp_path / "py.yml")
    assert not r.exact and 0 < r.refit_rms_px < 0.01 and r.refit_max_px >= r.refit_rms_px
    cli = json.loads(subprocess.run([BIN, "convert", src, tmp_path / "cli.yml", "--json"], check=True,
                                    capture_output=True, text=True).stdout)
    py = r.to_dict()
    assert py.pop("out_files") == [str(tmp_path / "py.yml")] and py.pop("warnings") == []
    assert py.pop("out") == str(tmp_path / "py.yml") and cli.pop("out") == str(tmp_path / "cli.yml")
    assert py == cli
    assert (tmp_path / "py.yml").read_bytes() == (tmp_path / "cli.yml").read_bytes()
    # cv2 projects the refit camera as porthole reads it back.
    back = porthole.convert(tmp_path / "py.yml", tmp_path / "back.json", pixel_pitch_mm=0.0055)
    assert back.exact and back.in_format == "opencv-yaml"
    cam = dict(json.loads((tmp_path / "back.json").read_text())["camera"], model="opencv")
    pts = rays_over_image(cam)
    assert np.max(np.abs(cv2_projects(tmp_path / "py.yml", pts) - porthole.project(cam, pts, **SENSOR))) <= 1e-6


@pytest.mark.skipif(shutil.which("colmap") is None, reason="colmap not installed (scripts/install-deps)")
def test_two_inputs_into_a_colmap_folder_read_by_colmap(tmp_path):
    srcs = [write_calib(tmp_path / "a.json", "opencv", OPENCV), write_calib(tmp_path / "b.json", "kannala-brandt", KB)]
    sparse = tmp_path / "sparse"
    sparse.mkdir()
    r = porthole.convert(srcs, sparse)  # a directory: its cameras.txt
    assert r.out == str(sparse / "cameras.txt") and r.out_model == "FULL_OPENCV, OPENCV_FISHEYE"
    assert [c.camera_id for c in r.cameras] == [1, 2]
    (sparse / "images.txt").write_text("")
    (sparse / "points3D.txt").write_text("")
    (tmp_path / "TXT").mkdir()
    subprocess.run(["colmap", "model_converter", "--input_path", sparse, "--output_path", tmp_path / "TXT",
                    "--output_type", "TXT"], check=True, capture_output=True)
    lines = [l.split() for l in (tmp_path / "TXT" / "cameras.txt").read_text().splitlines() if l and l[0] != "#"]
    assert sorted((l[0], l[1]) for l in lines) == [("1", "FULL_OPENCV"), ("2", "OPENCV_FISHEYE")]
    fx = {l[0]: float(l[4]) for l in lines}
    assert fx == {"1": OPENCV["fx_px"], "2": KB["fx_px"]}


def test_cv2s_own_stereo_file_becomes_a_rig_and_goes_back(tmp_path):
    """A stereo file cv2.FileStorage writes (stereoCalibrate's names, T in metres, no unit stated)."""
    k1 = np.array([[1500.5, 0, 960.25], [0, 1501.5, 540.75], [0, 0, 1]])
    k2 = np.array([[1490.0, 0, 955.5], [0, 1491.0, 545.5], [0, 0, 1]])
    d1 = np.array([[-0.11, 0.05, 1e-4, -2e-4, -0.01]])
    d2 = np.array([[-0.09, 0.04, -1e-4, 3e-4, 0.002]])
    r, _ = cv2.Rodrigues(np.array([0.01, -0.02, 0.005]))
    t = np.array([[-0.1201], [0.0015], [0.002]])
    own = tmp_path / "cv2.yml"
    fs = cv2.FileStorage(str(own), cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", 1920)
    fs.write("image_height", 1080)
    for n, m in (("K1", k1), ("D1", d1), ("K2", k2), ("D2", d2), ("R", r), ("T", t)):
        fs.write(n, m)
    fs.release()
    with pytest.raises(ValueError) as e:
        porthole.convert(own, tmp_path / "rig.json")
    assert "\n" not in str(e.value) and "unit" in str(e.value) and "mm, cm, m" in str(e.value), str(e.value)
    assert not (tmp_path / "rig.json").exists()
    rig = porthole.convert(own, tmp_path / "rig.json", length_unit="m")
    assert rig.in_format == "opencv-stereo" and rig.out_format == "json" and rig.n_cameras == 2
    assert rig.pitch == "none: pixels are mm" and rig.exact
    cli = json.loads(subprocess.run([BIN, "convert", own, tmp_path / "cli.json", "--length-unit", "m", "--json"],
                                    check=True, capture_output=True, text=True).stdout)
    py = rig.to_dict()
    assert py.pop("warnings") == [] and py["out"] == str(tmp_path / "rig.json") and cli["out"] == str(tmp_path / "cli.json")
    for d in (py, cli):
        d.pop("out"), d.pop("out_files")
    assert py == cli  # the CLI's --json, the rig's cameras and notes included
    assert (tmp_path / "rig.json").read_bytes() == (tmp_path / "cli.json").read_bytes()
    cams = json.loads((tmp_path / "rig.json").read_text())["rig"]["cameras"]
    assert [cams[0]["camera"][k] for k in ("fx_px", "fy_px", "cx_px", "cy_px")] == [1500.5, 1501.5, 960.25, 540.75]
    assert cams[1]["camera"]["k1"] == -0.09
    back = porthole.convert(tmp_path / "rig.json", tmp_path / "back.yml", to="opencv-stereo", pixel_pitch_mm=0.005)
    assert back.out_files == [str(tmp_path / "back.yml")]
    fs = cv2.FileStorage(str(tmp_path / "back.yml"), cv2.FILE_STORAGE_READ)
    got = {n: fs.getNode(n).mat() for n in ("K1", "D1", "K2", "D2", "R", "T")}
    assert fs.getNode("T_unit").string() == "mm"
    fs.release()
    assert np.abs(got["K1"] - k1).max() < 1e-12 and np.abs(got["K2"] - k2).max() < 1e-12
    assert np.abs(got["D1"].ravel()[:5] - d1.ravel()).max() < 1e-15
    assert np.abs(got["R"] - r).max() < 1e-12 and np.abs(got["T"].ravel() - 1000 * t.ravel()).max() < 1e-9


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
"""


def test_calibmar_housing_to_a_port_and_back(tmp_path):
    """calibmar's DOMEPORT (metres) as a porthole port (port_out; load_port reads it: a 100 mm inner radius
    2, -1, 3 mm from the pupil), and that port (a PortSpec) with water_index back into calibmar's file: the
    same eight housing parameters to 1e-12."""
    src = tmp_path / "calibration.yaml"
    src.write_text(CALIBMAR_DOME)
    r = porthole.convert(src, tmp_path / "cal.json", port_out=tmp_path / "dome.toml")
    assert r.in_format == "calibmar" and r.housing == "DOMEPORT" and r.water_index == 1.334 and r.in_rms_px == 0.21
    assert r.out_files == [str(tmp_path / "cal.json"), str(tmp_path / "dome.toml")]
    port = porthole.load_port(str(tmp_path / "dome.toml"))
    toml = port.to_toml()
    assert "radius_mm = 100" in toml and "center_mm = [2, -1, 3]" in toml
    assert "give water_index=" in (tmp_path / "dome.toml").read_text()  # the keyword, in Python's words
    back = porthole.convert(tmp_path / "cal.json", tmp_path / "back.yaml", to="calibmar", port=port, water_index=1.334)
    assert back.housing_written and back.out_format == "calibmar"
    text = (tmp_path / "back.yaml").read_text()
    housing = [float(x) for x in text.split("non_svp_parameters: [")[1].split("]")[0].split(",")]
    assert housing == pytest.approx([0.002, -0.001, 0.003, 0.1, 0.008, 1, 1.5, 1.334], rel=1e-12)


def test_bad_input_raises_one_line_naming_the_keyword(tmp_path):
    src = write_calib(tmp_path / "calib.json", "opencv", OPENCV)
    cases = [
        (dict(inputs=tmp_path / "missing.json", out=tmp_path / "x.yml"), "inputs"),
        (dict(inputs=src, out=tmp_path / "x.yml", port="nimar-ni320"), "port: only calibmar"),
        (dict(inputs=src, out=tmp_path / "x.yml", water_index=1.33), "water_index: goes with port="),
        (dict(inputs=src, out=tmp_path / "x.yml", length_unit="m"), "length_unit: is for rig files (inputs= is not one)"),
        (dict(inputs=src, out=tmp_path / "x.yml", port_out=tmp_path / "p.toml"), "port_out: inputs= has no housing"),
        (dict(inputs=[src, src], out=tmp_path / "x.yml"), "out: 2 inputs: only COLMAP"),
        (dict(inputs=src, out=tmp_path / "x.yml", to="nonsense"), "to:"),
        (dict(inputs=src, out=tmp_path / "x.yml", pixel_pitch_mm=-1), "pixel_pitch_mm: must be > 0"),
        (dict(inputs=src, out=src, force=True), "is an input of this command"),
    ]
    for kwargs, start in cases:
        with pytest.raises(ValueError) as e:
            porthole.convert(**kwargs)
        text = str(e.value)
        assert start in text and "\n" not in text and "--" not in text, text
        assert not (tmp_path / "x.yml").exists() and not (tmp_path / "p.toml").exists()
    with pytest.raises(TypeError):
        porthole.convert(src, tmp_path / "x.yml", pixel_pitch=0.005)  # a misspelt keyword


def test_an_implausible_pixel_pitch_warns(tmp_path):
    src = write_calib(tmp_path / "calib.json", "opencv", OPENCV)
    porthole.convert(src, tmp_path / "cam.yml")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r = porthole.convert(tmp_path / "cam.yml", tmp_path / "back.json", pixel_pitch_mm=5.5)
    assert len(r.warnings) == 1 and r.warnings[0].startswith("pixel_pitch_mm: 5.5 mm is outside")
    assert [w.category for w in caught] == [porthole.PortholeWarning]
