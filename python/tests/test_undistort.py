"""Proves porthole.undistort() is `porthole undistort` (issue 28): on an OpenCV calibration and two
images, the same pinhole (to the last digit) as the CLI's undistort.json, the same output images byte
for byte, a typed Record; errors raise ValueError naming the keyword (alpha, wd_mm)."""
import json
import os
import subprocess

import numpy as np
import pytest

import porthole

cv2 = pytest.importorskip("cv2")
BIN = os.environ.get("PORTHOLE_BIN", "porthole")


def make_inputs(d):
    k = np.array([[800.0, 0, 482.3], [0, 803.0, 317.1], [0, 0, 1]])
    fs = cv2.FileStorage(str(d / "cal.yml"), cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", 960)
    fs.write("image_height", 640)
    fs.write("camera_matrix", k)
    fs.write("distortion_coefficients", np.array([-0.21, 0.06, 0.0012, -0.0007, 0.0]))
    fs.release()
    (d / "images").mkdir()
    rng = np.random.default_rng(7)
    for i in range(2):
        img = cv2.GaussianBlur((rng.random((640, 960, 3)) * 255).astype(np.uint8), (0, 0), 2)
        cv2.imwrite(str(d / "images" / f"im{i}.png"), img)


def test_undistort_matches_the_cli(tmp_path):
    make_inputs(tmp_path)
    r = porthole.undistort(tmp_path / "cal.yml", tmp_path / "images", tmp_path / "py", alpha=0.5,
                           interpolation="cubic")
    assert isinstance(r, porthole.Record)
    subprocess.run([BIN, "undistort", "--calibration", tmp_path / "cal.yml", "--images", tmp_path / "images",
                    "--out", tmp_path / "cli", "--alpha", "0.5", "--interpolation", "cubic"], check=True,
                   capture_output=True)
    cli = json.loads((tmp_path / "cli" / "undistort.json").read_text())
    assert r.to_dict()["pinhole"] == cli["pinhole"]
    assert r.pinhole.fx_px == cli["pinhole"]["fx_px"]
    for name in ("im0.png", "im1.png"):
        assert (tmp_path / "py" / "images" / name).read_bytes() == (tmp_path / "cli" / "images" / name).read_bytes()
    assert (tmp_path / "py" / "cameras.txt").read_text() == (tmp_path / "cli" / "cameras.txt").read_text()


def test_undistort_errors_name_the_keyword(tmp_path):
    make_inputs(tmp_path)
    with pytest.raises(ValueError, match=r"^alpha:"):
        porthole.undistort(tmp_path / "cal.yml", tmp_path / "images", tmp_path / "o", alpha=2)
    with pytest.raises(ValueError, match=r"^wd_mm:"):
        porthole.undistort(tmp_path / "cal.yml", tmp_path / "images", tmp_path / "o", wd_mm=1000)
    with pytest.raises(ValueError, match=r"^wd_mm:"):
        porthole.undistort(tmp_path / "cal.yml", tmp_path / "images", tmp_path / "o", wd_mm="a:b")
    with pytest.raises(TypeError):
        porthole.undistort(tmp_path / "cal.yml", tmp_path / "images", tmp_path / "o", alpah=0)
