"""Calibrations must be valid and must fit (issues 23 and 24; docs/robustness.md, "Calibrations"):
- every reader refuses what is not a calibration (a negative focal length, an integer that overflows,
  an empty cameras.txt), naming the file and the field; porthole reads its own calibmar output;
- no writer writes what the readers refuse (a Brown refit to OpenCV that cannot hold the camera);
- a calibration of another camera (image size, pixel pitch, a focal length in pixels or of another lens)
  is refused by simulate, report and render with one line naming both values;
- the pixel pitch is taken from the calibration where the body has none (a lensfun body)."""
import json

import pytest

from conftest import run, run_bad

D300 = dict(width_px=4288, height_px=2848, pixel_pitch_mm=0.0055)
TABLE6_AIR = {"c_mm": 25.801, "x0_mm": -0.026, "y0_mm": -0.144, "K1": 1.842e-4, "K2": -3.030e-7}
# OpenCV's sample calibration (opencv-doc's left_intrinsics.yml): a 640 x 480 camera, fx 532 px.
VGA_YAML = """%YAML:1.0
image_width: 640
image_height: 480
camera_matrix: !!opencv-matrix
   rows: 3
   cols: 3
   dt: d
   data: [ 5.3480326845051309e+02, 0., 3.3568643204394891e+02, 0.,
       5.3480326845051309e+02, 2.4066183054066337e+02, 0., 0., 1. ]
distortion_coefficients: !!opencv-matrix
   rows: 5
   cols: 1
   dt: d
   data: [ -2.6637260909660682e-01, -3.8588898922304653e-02,
       1.7831947042852964e-03, -2.8122100441115472e-04,
       2.3839153080878486e-01 ]
"""


def write_json(path, camera, sensor=None, model="brown", **extra):
    path.write_text(json.dumps({"model": model, "camera": camera, "sensor": sensor or D300, **extra}))
    return path


# ---- readers ----

def test_negative_focal_length_in_cameras_txt_is_refused_naming_file_and_field(tmp_path):
    """cameras.txt PINHOLE 640 480 3000 -1000 …: fy -1000 (the mean focal length 1000 > 0 passed before) was
    read and used by compare and render; now every reader refuses it, naming the file and fy."""
    cams = tmp_path / "cameras.txt"
    cams.write_text("1 PINHOLE 640 480 3000 -1000 320 240\n")
    for args in (("convert", cams, tmp_path / "out.json"), ("compare", cams, cams)):
        line = run_bad(*args)
        assert "cameras.txt" in line and "fy_px" in line and "-1000" in line, line
    assert not (tmp_path / "out.json").exists()
    # The same in porthole JSON: named with its line.
    bad = write_json(tmp_path / "neg.json", {"fx_px": 3000, "fy_px": -1000, "cx_px": 320, "cy_px": 240},
                     dict(width_px=640, height_px=480, pixel_pitch_mm=0.006), model="opencv")
    line = run_bad("convert", bad, tmp_path / "out.yml")
    assert "neg.json" in line and "fy_px" in line, line


def test_principal_point_off_the_image_and_folding_distortion_are_refused(tmp_path):
    cams = tmp_path / "cameras.txt"
    cams.write_text("1 PINHOLE 640 480 531 531 900 240\n")  # cx 900 px on a 640 px image
    line = run_bad("convert", cams, tmp_path / "out.json")
    assert "outside the 640 x 480 px image" in line, line
    # k1 = -0.5 at f 500 px: r(1 + k1 r^2) peaks at r = 0.82 (0.54) below the corner's 0.80.
    cams.write_text("1 SIMPLE_RADIAL 640 480 500 320 240 -0.5\n")
    line = run_bad("convert", cams, tmp_path / "out.json")
    assert "folds the frame" in line and "k1" in line, line


def test_an_empty_cameras_txt_says_it_holds_no_camera(tmp_path):
    cams = tmp_path / "cameras.txt"
    cams.write_text("# Camera list with one line of data per camera:\n")
    line = run_bad("convert", cams, tmp_path / "out.json")
    assert "holds no camera" in line and "ids )" not in line, line


def test_an_mrcal_integer_that_overflows_is_refused(tmp_path):
    """99999999999999999999 in an mrcal file was read as 9.22e18 (strtoll saturates)."""
    model = tmp_path / "cam.cameramodel"
    model.write_text("{ 'lensmodel': 'LENSMODEL_PINHOLE', 'intrinsics': [ 99999999999999999999, 500, 319.5, 239.5 ],"
                     " 'imagersize': [ 640, 480 ] }\n")
    line = run_bad("convert", model, tmp_path / "out.json")
    assert "cam.cameramodel" in line and "does not fit in 64 bits" in line, line


def test_porthole_reads_its_own_calibmar_output(tmp_path):
    """An opencv calibration with sigma for the adjusted parameters and p1, p2 not adjusted: calibmar's
    # params_est_std_dev got 'nan' for p1 and p2, which porthole then refused to read. Now 0 (fixed), and
    the file reads back with the same sigma."""
    sigma = {"fx_px": 0.5, "fy_px": 0.6, "cx_px": 0.3, "cy_px": 0.4, "k1": 1e-3, "k2": 2e-3}
    src = write_json(tmp_path / "cal.json",
                     {"fx_px": 531, "fy_px": 532, "cx_px": 319.5, "cy_px": 239.5, "k1": -0.1, "k2": 0.01,
                      "p1": None, "p2": None},
                     dict(width_px=640, height_px=480, pixel_pitch_mm=0.006), model="opencv", sigma=sigma)
    out = tmp_path / "calibration.yaml"
    run("convert", src, out, "--to", "calibmar")
    text = out.read_text()
    assert "nan" not in text.lower(), text
    std = [float(x) for x in text.split("# params_est_std_dev:")[1].splitlines()[0].split(",")]
    assert std == pytest.approx([0.5, 0.6, 0.3, 0.4, 1e-3, 2e-3, 0, 0])
    back = tmp_path / "back.json"
    run("convert", out, back)
    j = json.loads(back.read_text())
    for k, v in sigma.items():
        assert j["sigma"][k] == pytest.approx(v, rel=1e-12), k
    assert j["sigma"]["p1"] is None and j["camera"]["p1"] is None
    # A calibmar file with "nan" (an unknown sigma) is read: sigma unknown, not a refusal.
    out.write_text(text.replace("# params_est_std_dev: 0.5,", "# params_est_std_dev: nan,"))
    j = run("convert", out, tmp_path / "nan.json", "--json").json()
    assert j["sigma"] == "unknown"


def test_an_opencv_to_brown_refusal_names_the_file(tmp_path):
    """A rational opencv calibration has no Brown equivalent: simulate's refusal names the file."""
    src = write_json(tmp_path / "rational.json",
                     {"fx_px": 4690, "fy_px": 4692, "cx_px": 2150, "cy_px": 1420, "k1": -0.1, "k4": 0.02},
                     model="opencv")
    line = run_bad("simulate", "--air-calibration", src)
    assert "rational.json" in line and "Brown" in line, line


# ---- writers ----

def test_convert_refuses_a_refit_that_cannot_hold_the_camera(tmp_path):
    """A Brown camera of 10 mm with a strong barrel correction (K1 0.01: 77 deg at the corner) has no
    OpenCV k1 k2 p1 p2 k3 equivalent over the frame; convert wrote the refit anyway (fx -875.9 px at RMS
    181.5 px for such a camera). Now it is an error naming OUT, and nothing is written."""
    src = write_json(tmp_path / "wide.json", {"c_mm": 10.0, "K1": 0.01})
    for out in ("wide.yml", "cameras.txt", "wide.cameramodel", "wide.xml"):
        line = run_bad("convert", src, tmp_path / out)
        assert out in line and "refit" in line, line
        assert not (tmp_path / out).exists(), out
    # The paper's calibration converts (RMS < 0.01 px): the bound is no obstacle to a real camera.
    src = write_json(tmp_path / "air.json", TABLE6_AIR)
    assert run("convert", src, tmp_path / "air.yml", "--json").json()["refit_rms_px"] < 0.01


# ---- a calibration of another camera ----

def test_simulate_refuses_a_calibration_of_another_camera(tmp_path):
    """The issue's reproducer: OpenCV's 640 x 480 sample (fx 535 px) given to simulate for the default D300 +
    24 mm printed c -0.26 mm, RMS 'inf' and c ratio 0.736 with exit 0."""
    vga = tmp_path / "left.yml"
    vga.write_text(VGA_YAML)
    line = run_bad("simulate", "--air-calibration", vga)
    assert "--air-calibration" in line and "640 x 480" in line and "4288 x 2848" in line, line
    # A calibration in pixels (made without --pixel-pitch-mm: pitch 1, c_mm 4454.5) gave "water c 4566.9 mm".
    p = 0.0055  # Table 6 in pixel units: c, x0, y0 in px, K1 in px^-2, K2 in px^-4
    in_px = {"c_mm": 4454.5, "x0_mm": -0.026 / p, "y0_mm": -0.144 / p, "K1": 1.842e-4 * p**2, "K2": -3.030e-7 * p**4}
    px = write_json(tmp_path / "px.json", in_px, dict(width_px=4288, height_px=2848, pixel_pitch_mm=1.0))
    line = run_bad("simulate", "--air-calibration", px)
    assert "pixel pitch 1 mm" in line and "0.0055 mm" in line, line
    # Another pixel pitch (6.0 um for the D300's 5.5).
    other = write_json(tmp_path / "pitch.json", TABLE6_AIR, dict(width_px=4288, height_px=2848, pixel_pitch_mm=0.006))
    line = run_bad("simulate", "--air-calibration", other)
    assert "0.006 mm" in line and "0.0055 mm" in line, line
    # Inline c_mm 1e-300 gave c -2.82 mm; c of another lens (50 mm on the 24 mm).
    for c in ("1e-300", "50"):
        line = run_bad("simulate", "--air-calibration", '{"c_mm": %s}' % c)
        assert line.startswith("porthole: error: --air-calibration") and "focal length" in line, line
        assert "20.4 to" in line, line
    # The paper's own calibration is accepted.
    run("simulate", "--air-calibration", json.dumps(TABLE6_AIR), "--json")


def test_report_and_render_refuse_a_calibration_of_another_camera(tmp_path):
    vga = tmp_path / "left.yml"
    vga.write_text(VGA_YAML)
    line = run_bad("report", "--air-calibration", vga, "--out", tmp_path / "r")
    assert "640 x 480" in line and "4288 x 2848" in line, line
    assert not (tmp_path / "r").exists()
    line = run_bad("render", "--camera-model", vga, "--out", tmp_path / "x.png")
    assert "--camera-model" in line and "640 x 480" in line, line
    assert not (tmp_path / "x.png").exists()


def test_a_lensfun_body_takes_the_pixel_pitch_of_the_calibration(tmp_path):
    """Issue 23's rough edge: a lensfun body has no pixel pitch; the air calibration holds one, so
    --pixel-pitch-mm is not asked for again (the Nikon D7000: 4928 x 3264 px, 4.78 um)."""
    cal = write_json(tmp_path / "d7000.json", TABLE6_AIR, dict(width_px=4928, height_px=3264, pixel_pitch_mm=0.00478))
    args = ("simulate", "--camera", "Nikon D7000", "--lens", "nikkor-24mm-f2.8d")
    line = run_bad(*args)  # without a calibration: the pitch is needed
    assert "--pixel-pitch-mm" in line, line
    res = run(*args, "--air-calibration", cal, "--json")
    assert "0.00478 mm" in res.err
    assert res.json()["predicted_water"]["c_mm"] == pytest.approx(25.8, abs=0.5)
