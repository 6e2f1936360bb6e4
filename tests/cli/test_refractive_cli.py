"""Proves `porthole calibrate --port` reads its in-air calibration through the one loader of every
command (interop::ReadCalibrationFile): the same calibration as porthole JSON, OpenCV YAML, COLMAP
and mrcal gives the same refractive result; a file without sigma is refused for the prior (one
line, exit 2); --free-water-index and --free-shell reach the output; bad input (no water images, a
port the rays cannot cross, a network that cannot see what is asked) is one line and exit 2.
(The OpenCV sample chessboards stand in for water images: this checks the plumbing;
calib_refractive_test checks the estimates on synthetic water images.)"""
import json

import pytest

from conftest import run, run_bad
from test_calib_cli import TARGET, detections, samples  # noqa: F401 (fixtures)

PORT = "flat-acrylic-10mm"


@pytest.fixture(scope="module")
def air_files(detections, tmp_path_factory):
    """The samples' calibration with the opencv model (8 parameters: exact in every format) as
    porthole JSON, then converted by `porthole convert` to OpenCV YAML, COLMAP and mrcal."""
    d = tmp_path_factory.mktemp("air")
    files = {"json": d / "air.json"}
    run("calibrate", "--detections", detections, "--model", "opencv", "--out", files["json"], "--quiet")
    for name, out in (("opencv-yaml", d / "air.yml"), ("colmap", d / "cameras.txt"),
                      ("mrcal", d / "air.cameramodel")):
        run("convert", files["json"], out)
        files[name] = out
    return files


def refractive(detections, air, *extra):
    return run("calibrate", "--detections", detections, "--model", "opencv", "--port", PORT,
               "--air-calibration", air, "--air-lens-bare", "--json", "--quiet", *extra).json()


def test_air_calibration_in_every_format_gives_the_same_result(detections, air_files):
    base = refractive(detections, air_files["json"], "--intrinsics", "fixed")
    assert "exact" in base["port"]["air_calibration"]
    for name in ("opencv-yaml", "colmap", "mrcal"):
        other = refractive(detections, air_files[name], "--intrinsics", "fixed")
        assert "exact" in other["port"]["air_calibration"], name
        for key, value in base["port"]["parameters"].items():
            assert other["port"]["parameters"][key] == pytest.approx(value, rel=1e-9, abs=1e-12), (name, key)
        for key, value in base["camera"].items():
            if value is not None:
                assert other["camera"][key] == pytest.approx(value, rel=1e-9), (name, key)
        assert other["sigma0_px"] == pytest.approx(base["sigma0_px"], rel=1e-9), name


def test_a_prior_needs_sigma(detections, air_files):
    """The default with --air-calibration is the prior; YAML, COLMAP and mrcal hold no sigma: refused,
    saying what to do. porthole JSON holds the covariance: accepted."""
    for name in ("opencv-yaml", "colmap", "mrcal"):
        line = run_bad("calibrate", "--detections", detections, "--model", "opencv", "--port", PORT,
                       "--air-calibration", air_files[name], "--air-lens-bare")
        assert "--air-calibration" in line and "--intrinsics fixed" in line and "sigma" in line, line
    # Made through the port (no --air-lens-bare) it cannot be held fixed: the line says free instead.
    line = run_bad("calibrate", "--detections", detections, "--model", "opencv", "--port", PORT,
                   "--air-calibration", air_files["opencv-yaml"])
    assert "--intrinsics free" in line and "--intrinsics fixed" not in line and "sigma" in line, line
    j = refractive(detections, air_files["json"])
    assert j["port"]["intrinsics"] == "prior"
    # A chessboard: no centre correction, stated as such (calib_real_test checks coded targets).
    assert j["dot_radius_mm"] == 0 and j["max_centre_offset_px"] == 0


def test_water_index_and_shell_reach_the_output(detections, tmp_path):
    j = run("calibrate", "--detections", detections, "--port", PORT, "--free-water-index",
            "--json", "--quiet").json()
    shell = j["port"]["shell"]
    assert shell["free"] == ["water_index_factor"]
    assert shell["sigma"]["water_index_factor"] > 0
    assert shell["n_water"] == pytest.approx(j["port"]["n_water"] * shell["parameters"]["water_index_factor"])
    assert "c_mm" in shell["correlation"]["water_index_factor"]
    # A port file with the glass thickness's sigma: --free-shell adjusts it, the table shows it.
    spec = run("presets", PORT).out + "\n[sigma]\nthickness_mm = 0.2\n"
    port = tmp_path / "flat.toml"
    port.write_text(spec)
    out = tmp_path / "as-calibrated.toml"
    t = run("calibrate", "--detections", detections, "--port", port, "--free-shell", "--port-out", out,
            "--quiet").out
    assert "thickness_mm" in t and "file" in t
    assert "[sigma]" not in out.read_text()  # the prior is not passed on as data
    # Without sigma in the port file, --free-shell is refused before any work.
    line = run_bad("calibrate", "--detections", detections, "--port", PORT, "--free-shell")
    assert "--free-shell" in line and "sigma" in line


def test_bad_input_is_one_line_exit_2(detections, tmp_path):
    # No water images: an empty folder, a folder of files without the target.
    empty = tmp_path / "empty"
    empty.mkdir()
    run_bad("calibrate", "--images", empty, "--target", TARGET, "--port", PORT, "--quiet")
    # A port the rays cannot cross to the targets: a flat port 50 m ahead of the pupil.
    far = tmp_path / "far.toml"
    far.write_text('type = "flat"\nthickness_mm = 10\ninner_point_mm = [0, 0, 50000]\n')
    line = run_bad("calibrate", "--detections", detections, "--port", far, "--quiet")
    assert "--port" in line
    # A degenerate network: the water index with the pupil at the centre of a concentric dome
    # (no ray is bent) and the port held.
    line = run_bad("calibrate", "--detections", detections, "--port", "nimar-ni320-nominal",
                   "--free-water-index", "--free-port", "none", "--quiet")
    assert "not determined" in line, line
