"""Proves that Python warns where the CLI warns (issue 23): for every plausibility range the CLI
checks -- pixel pitch, circle of confusion, focal length, dome radius, flat-port thickness -- porthole.plan()
or porthole.flat() returns the same warning in result.warnings (naming the library field) and emits it as
a porthole.PortholeWarning, and the hint is computed from the value given."""
import os
import re
import subprocess
import warnings

import pytest

import porthole

BIN = os.environ.get("PORTHOLE_BIN", "porthole")
# The part of a warning after its field: "<value> mm is outside the range ... : <hint>".
BODY = re.compile(r"(\S+ mm is outside the range of any physical camera or port .*)$")

DOME = """name = "dome-in-{unit}"
type = "dome"
material = "pmma"
frame = "cam"
entrance_pupil_mm = [0.0, 0.0, 26.9]
[outer]
center_mm = [0, 0, 0]
radius_mm = {outer}
[inner]
center_mm = [0, 0, 0]
radius_mm = {inner}
"""

FLAT = """name = "flat-in-metres"
type = "flat"
material = "pmma"
frame = "cam"
entrance_pupil_mm = [0.0, 0.0, 26.9]
inner_point_mm = [0, 0, 20]
normal = [0, 0, 1]
thickness_mm = {thickness}
"""


def cli_warnings(*args):
    proc = subprocess.run([BIN, *map(str, args)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return [BODY.search(line).group(1) for line in proc.stderr.splitlines()
            if line.startswith("porthole: warning: ") and BODY.search(line)]


def python_warnings(call, **kwargs):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = call(**kwargs)
    emitted = [str(w.message) for w in caught if issubclass(w.category, porthole.PortholeWarning)]
    in_result = [w for w in result.warnings if "is outside the range of any physical" in w]
    assert emitted == in_result, (emitted, in_result)  # emitted exactly as the result holds them
    return in_result


def same_warning(py, cli, field):
    bodies = [BODY.search(w).group(1) for w in py if w.startswith(field + ": ")]
    assert bodies, (field, py)
    assert bodies[0] in cli, (bodies[0], cli)
    return bodies[0]


def test_pixel_pitch_in_um():
    py = python_warnings(porthole.plan, pixel_pitch_mm=5.5)
    body = same_warning(py, cli_warnings("plan", "--pixel-pitch-mm", "5.5"), "pixel_pitch_mm")
    assert body.endswith("5.5 um is 0.0055 mm")
    # The hint follows the value: 4.35 um, not the 5.5 of a fixed text.
    py = python_warnings(porthole.flat, pixel_pitch_mm=4.35)
    body = same_warning(py, cli_warnings("flat", "--pixel-pitch-mm", "4.35"), "pixel_pitch_mm")
    assert body.endswith("4.35 um is 0.00435 mm") and "5.5" not in body


def test_circle_of_confusion_in_um():
    py = python_warnings(porthole.plan, coc_mm=11)
    body = same_warning(py, cli_warnings("plan", "--coc", "11"), "coc_mm")
    assert body.endswith("11 um is 0.011 mm")
    assert python_warnings(porthole.plan, coc_mm=0.015) == []  # plausible: nothing


def test_focal_length_in_um(tmp_path):
    lens = tmp_path / "tele.toml"
    lens.write_text('name = "tele-in-um"\nmount = "nikon-f"\nfocal_length_mm = 2400.0\nf_number_min = 8.0\n'
                    'f_number_max = 32.0\nmin_focus_mm = 20000.0\n'
                    'pupil = [ { focus_mm = inf, d_ep2f_mm = 24.6 } ]\n')
    py = python_warnings(porthole.flat, lens=str(lens))
    same_warning(py, cli_warnings("flat", "--lens", lens), "focal_length_mm")


def test_dome_radius_in_cm(tmp_path):
    port = tmp_path / "dome.toml"
    port.write_text(DOME.format(unit="cm", outer=10.16, inner=9.36))
    py = python_warnings(porthole.plan, port=str(port))
    cli = cli_warnings("plan", "--port", port)
    assert same_warning(py, cli, "port.outer.radius_mm").endswith("10.16 cm is 101.6 mm")
    same_warning(py, cli, "port.inner.radius_mm")


def test_flat_port_thickness_in_metres(tmp_path):
    port = tmp_path / "flat.toml"
    port.write_text(FLAT.format(thickness=0.012))
    py = python_warnings(porthole.flat, port=str(port))
    body = same_warning(py, cli_warnings("flat", "--port", port), "port.thickness_mm")
    assert body.endswith("0.012 m is 12 mm")


def test_plausible_inputs_warn_nothing():
    assert python_warnings(porthole.plan) == []
    assert python_warnings(porthole.flat) == []


def test_simulate_warns_as_the_cli_does(tmp_path):
    # simulate's result carries the same plausibility warnings (the CLI prints the port's on stderr).
    port = tmp_path / "flat.toml"
    port.write_text(FLAT.format(thickness=0.012))
    py = python_warnings(porthole.simulate, port=str(port), grid_cols=9, grid_rows=7)
    cli = cli_warnings("simulate", "--port", port, "--grid-cols", "9", "--grid-rows", "7")
    assert same_warning(py, cli, "port.thickness_mm").endswith("0.012 m is 12 mm")
    assert python_warnings(porthole.simulate, grid_cols=9, grid_rows=7) == []


def test_calibrate_warns_about_a_pitch_in_um():
    # A calibration's pixel pitch typed in um: the CLI warns on stderr, calibrate() in its result.
    cam = {"c_mm": 26.208, "x0_mm": -0.058, "y0_mm": -0.207, "K1": 1.663e-4}
    dets = porthole.synthetic_detections(cam, width_px=4288, height_px=2848, pixel_pitch_mm=0.0055,
                                         target="chessboard:12x9:40", n_images=6, noise_px=0.1)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        c = porthole.calibrate(dets, "chessboard:12x9:40", pixel_pitch_mm=5.5)
    emitted = [str(w.message) for w in caught if issubclass(w.category, porthole.PortholeWarning)]
    assert len(c.warnings) == 1 and emitted == c.warnings
    assert c.warnings[0].startswith("pixel_pitch_mm: 5.5 mm is outside the range")
    assert c.warnings[0].endswith("5.5 um is 0.0055 mm")
    plain = porthole.calibrate(dets, "chessboard:12x9:40", pixel_pitch_mm=0.0055)
    assert plain.warnings == []
