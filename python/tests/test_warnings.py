"""Proves that Python warns where the CLI warns (issues 23, 25): for every plausibility range the CLI
checks -- pixel pitch, circle of confusion, focal length, dome radius, flat-port thickness -- porthole.plan()
or porthole.flat() returns the same warning in result.warnings (naming the library field) and emits it as
a porthole.PortholeWarning, and the hint is computed from the value given. Then every range x every
front-end call with a Python equivalent (plan, flat, simulate, report, render, plan_rig, calibrate,
calibrate with a port, calibrate_rig, place for virtual-image and trace, convert): Python's warnings and
the CLI's stderr warnings are the same texts after the field, each once. `porthole compare
--pixel-pitch-mm` has no Python equivalent (compare() takes calibrations, not files read at a pitch);
report's and plan_rig's focal length and report's dome radius are not compared (those calls refuse the
lenses and domes that make them implausible)."""
import json
import math
import os
import re
import subprocess
import warnings

import numpy as np
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


# ---- Every range x every front-end call (issue 25) ----

TELE = ('name = "tele-in-um"\nmount = "nikon-f"\nfocal_length_mm = 2400.0\nf_number_min = 8.0\n'
        'f_number_max = 32.0\nmin_focus_mm = 20000.0\npupil = [ { focus_mm = inf, d_ep2f_mm = 24.6 } ]\n')
# The hint each implausible value must get (worked out by hand from the value and the unit).
HINT = {"pixel_pitch_mm": "a pixel pitch in um? 5.5 um is 0.0055 mm",
        "coc_mm": "a circle of confusion in um? 11 um is 0.011 mm",
        "focal_length_mm": "a focal length in um? 2400 um is 2.4 mm",
        "port.outer.radius_mm": "a radius in cm? 10.16 cm is 101.6 mm",
        "port.inner.radius_mm": "a radius in cm? 9.36 cm is 93.6 mm",
        "port.thickness_mm": "a thickness in m? 0.012 m is 12 mm"}
# A dome typed in um instead: 50 m across, for the calls that need the lens focused through it (at 100 m).
_IMPLAUSIBLE = "is outside the range of any physical camera or port"
HINT_UM = dict(HINT, **{"port.outer.radius_mm": "a radius in um? 50000 um is 50 mm",
                        "port.inner.radius_mm": "a radius in um? 49990 um is 49.99 mm"})


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    d = tmp_path_factory.mktemp("implausible")
    # Both domes concentric with the pupil (a calibration's rays pass them straight).
    (d / "dome.toml").write_text(DOME.format(unit="cm", outer=10.16, inner=9.36))
    (d / "dome_um.toml").write_text(DOME.format(unit="um", outer=50000, inner=49990))
    (d / "flat.toml").write_text(FLAT.format(thickness=0.012))
    (d / "tele.toml").write_text(TELE)
    return d


def all_cli_warnings(*args):
    """The body of every plausibility warning the CLI prints on stderr, in order."""
    proc = subprocess.run([BIN, *map(str, args)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return [BODY.search(line).group(1) for line in proc.stderr.splitlines()
            if line.startswith("porthole: warning: ") and BODY.search(line)]


def same_warnings(py, cli, fields, hints=HINT):
    """Python's warnings name `fields` (the library's, after any "<file>: " the CLI also prints), each
    with its hint, and say what the CLI says: the same bodies, as many times."""
    named = {f: [w for w in py if re.search(r"(^|: )" + re.escape(f) + ": ", w)] for f in fields}
    assert all(len(v) == 1 for v in named.values()), (named, py)
    for f, (w,) in named.items():
        assert w.endswith(hints[f]), (f, w)
    assert sorted(BODY.search(w).group(1) for w in py) == sorted(cli), (py, cli)
    assert len(py) == len(fields), py


PITCH = ["pixel_pitch_mm"]
COC = ["coc_mm"]
FOCAL = ["focal_length_mm"]
DOME_R = ["port.outer.radius_mm", "port.inner.radius_mm"]
THICK = ["port.thickness_mm"]


@pytest.mark.parametrize("port,fields", [("dome.toml", DOME_R), ("flat.toml", THICK)])
def test_plan_every_range(inputs, port, fields):
    py = python_warnings(porthole.plan, pixel_pitch_mm=5.5, coc_mm=11, lens=str(inputs / "tele.toml"),
                         port=str(inputs / port))
    cli = all_cli_warnings("plan", "--pixel-pitch-mm", "5.5", "--coc", "11", "--lens", inputs / "tele.toml",
                           "--port", inputs / port)
    same_warnings(py, cli, PITCH + COC + FOCAL + fields)


def test_flat_every_range(inputs):
    py = python_warnings(porthole.flat, pixel_pitch_mm=5.5, lens=str(inputs / "tele.toml"),
                         port=str(inputs / "flat.toml"))
    cli = all_cli_warnings("flat", "--pixel-pitch-mm", "5.5", "--lens", inputs / "tele.toml",
                           "--port", inputs / "flat.toml")
    same_warnings(py, cli, PITCH + FOCAL + THICK)


# The 2400 mm lens focuses no closer than 20 m: at 100 m, through the flat port.
BEHIND = [("dome_um.toml", {"focus_distance_mm": 1e5}, DOME_R),
          ("flat.toml", {"lens": "tele.toml", "focus_distance_mm": 1e5}, FOCAL + THICK)]


def keywords(inputs, extra):
    return {k: str(inputs / v) if k == "lens" else v for k, v in extra.items()}


def flags(inputs, extra, names):
    out = []
    for k, v in extra.items():
        out += [names[k], inputs / v if k == "lens" else v]
    return out


@pytest.mark.parametrize("port,extra,fields", BEHIND)
def test_simulate_every_range(inputs, port, extra, fields):
    py = python_warnings(porthole.simulate, pixel_pitch_mm=5.5, port=str(inputs / port), grid_cols=9, grid_rows=7,
                         **keywords(inputs, extra))
    cli = all_cli_warnings("simulate", "--pixel-pitch-mm", "5.5", "--port", inputs / port, "--grid-cols", "9",
                           "--grid-rows", "7",
                           *flags(inputs, extra, {"lens": "--lens", "focus_distance_mm": "--focus-distance"}))
    same_warnings(py, cli, PITCH + fields, HINT_UM)


def test_report_every_range(inputs, tmp_path):
    # The report's focal-length and dome-radius ranges are not compared: it refuses a lens longer than
    # 191 mm (one of its sections puts a subject 191.52 mm from the pupil), and a dome with a radius out
    # of range (a subject 43 m away lies inside the 50 m dome; no lens focuses through the 10 mm one).
    port, extra, fields = "flat.toml", {"subject_distance_mm": 1e5}, THICK
    py = python_warnings(porthole.report, out=str(tmp_path / "py"), pixel_pitch_mm=5.5, port=str(inputs / port),
                         **keywords(inputs, extra))
    cli = all_cli_warnings("report", "--out", tmp_path / "cli", "--pixel-pitch-mm", "5.5", "--port", inputs / port,
                           *flags(inputs, extra, {"subject_distance_mm": "--subject-distance"}))
    same_warnings(py, cli, PITCH + fields, HINT_UM)


@pytest.mark.parametrize("port,extra,fields", BEHIND)
def test_render_every_range(inputs, tmp_path, port, extra, fields):
    # The pitch's range is test_render.py's (a pitch in um makes a sensor metres wide to render).
    extra = dict(extra)
    extra["distance_mm"] = extra.pop("focus_distance_mm")  # focused on the target
    py = python_warnings(porthole.render, out=str(tmp_path / "py.png"), pixel_pitch_mm=0.029, samples_per_pixel=1,
                         port=str(inputs / port), **keywords(inputs, extra))
    cli = all_cli_warnings("render", "--out", tmp_path / "cli.png", "--pixel-pitch-mm", "0.029", "--spp", "1",
                           "--port", inputs / port, "--quiet",
                           *flags(inputs, extra, {"lens": "--lens", "distance_mm": "--distance"}))
    same_warnings(py, cli, fields, HINT_UM)


@pytest.mark.parametrize("port,fields", [("dome.toml", DOME_R), ("flat.toml", THICK)])
def test_place_warns_as_virtual_image_and_trace(inputs, port, fields):
    # place() is the Python side of `porthole virtual-image` and `trace` (virtual_image_table() calls it).
    py = python_warnings(porthole.place, port=str(inputs / port))
    for command in ("virtual-image", "trace"):
        same_warnings(py, all_cli_warnings(command, "--port", inputs / port), fields)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        porthole.virtual_image_table(port=str(inputs / port))
    assert [str(w.message) for w in caught if issubclass(w.category, porthole.PortholeWarning)] == py
    assert python_warnings(porthole.place, port="nimar-ni320") == []


TARGET = "chessboard:12x9:40"
CAM = {"c_mm": 26.208, "x0_mm": -0.058, "y0_mm": -0.207, "K1": 1.663e-4}


@pytest.fixture(scope="module")
def detections(tmp_path_factory):
    dets = porthole.synthetic_detections(CAM, width_px=4288, height_px=2848, pixel_pitch_mm=0.0055,
                                         target=TARGET, n_images=6, noise_px=0.1)
    path = tmp_path_factory.mktemp("dets") / "cam.json"
    path.write_text(json.dumps({"target": TARGET, "images": [d.to_dict() for d in dets]}))
    return dets, path


@pytest.mark.parametrize("port,extra,fields", BEHIND)
def test_plan_rig_every_range(inputs, port, extra, fields):
    # A rig described by its baseline: the camera's and port's warnings (the notes are no plausibility
    # warnings). Its focal-length range is not compared: the described rig refuses a lens longer than a
    # subject 1.1 m from the pupil.
    fields = [f for f in fields if f != "focal_length_mm"]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r = porthole.plan_rig(baseline_mm=300, pixel_pitch_mm=5.5, port=str(inputs / port), central_range_mm=0,
                              ranges_mm=[1e5 + 1000])
    py = [w for w in r.warnings if _IMPLAUSIBLE in w]
    assert [str(w.message) for w in caught if _IMPLAUSIBLE in str(w.message)] == py
    cli = all_cli_warnings("plan", "--baseline", "300", "--pixel-pitch-mm", "5.5", "--port", inputs / port,
                           "--central-range", "0", "--ranges", str(1e5 + 1000))
    same_warnings(py, cli, PITCH + fields, HINT_UM)


def test_calibrate_every_range(detections):
    dets, path = detections
    py = python_warnings(porthole.calibrate, detections=dets, target=TARGET, pixel_pitch_mm=5.5)
    cli = all_cli_warnings("calibrate", "--detections", path, "--pixel-pitch-mm", "5.5", "--quiet")
    same_warnings(py, cli, PITCH)


def test_calibrate_behind_a_port_every_range(detections, inputs):
    # A dome concentric with the pupil (radii in cm): the rays pass it straight, the in-air detections fit.
    dets, path = detections
    py = python_warnings(porthole.calibrate, detections=dets, target=TARGET, pixel_pitch_mm=5.5,
                         port=str(inputs / "dome.toml"))
    cli = all_cli_warnings("calibrate", "--detections", path, "--pixel-pitch-mm", "5.5", "--port",
                           inputs / "dome.toml", "--quiet")
    same_warnings(py, cli, PITCH + DOME_R)


def rotation(rvec):
    """Rodrigues' formula: the rotation matrix of an axis-angle vector."""
    theta = np.linalg.norm(rvec)
    k = rvec / theta
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(theta) * kx + (1 - math.cos(theta)) * kx @ kx


def rig_detections(n=10, seed=4):
    """Two pinhole cameras 300 mm apart (f 2000 px, 4288 x 2848 px) seeing a 12 x 9 chessboard of 40 mm
    squares in n frames, 0.2 px noise: each camera's detections, frames named alike."""
    rng = np.random.default_rng(seed)
    pts = np.array([[c * 40.0, r * 40.0, 0.0] for r in range(9) for c in range(12)])  # the target's points
    k = np.array([[2000.0, 0, 2143.5], [0, 2000, 1423.5], [0, 0, 1]])
    r1, t1 = rotation(np.array([0, 0.08, 0])), np.array([-300.0, 0, 0])
    cams = [[], []]
    for f in range(n):
        r = rotation(rng.uniform(-1, 1, 3) * np.array([0.5, 0.5, 0.2]) + np.array([1e-9, 0, 0]))
        t = np.array([150 + 100 * rng.uniform(-1, 1), 100 * rng.uniform(-1, 1), 1200 + 400 * rng.uniform()])
        t = t - r @ pts.mean(axis=0)
        for c, (rc, tc) in enumerate(((r, t), (r1 @ r, r1 @ t + t1))):
            x = (rc @ pts.T).T + tc
            uv = (k @ (x / x[:, 2:3]).T).T[:, :2] + rng.normal(0, 0.2, (len(pts), 2))
            ok = (uv[:, 0] > 0) & (uv[:, 0] < 4287) & (uv[:, 1] > 0) & (uv[:, 1] < 2847)
            cams[c].append({"image": f"f{f:03d}.png", "width_px": 4288, "height_px": 2848,
                            "ids": [int(i) for i in np.nonzero(ok)[0]], "points_px": uv[ok].tolist()})
    return cams


def test_calibrate_rig_every_range(inputs, tmp_path):
    cams = rig_detections()
    files = []
    for c, name in zip(cams, ("left", "right")):
        files.append(tmp_path / f"{name}.json")
        files[-1].write_text(json.dumps({"target": TARGET, "images": c}))
    py = python_warnings(porthole.calibrate_rig, cameras=cams, target=TARGET, pixel_pitch_mm=5.5,
                         port=str(inputs / "dome.toml"))
    cli = all_cli_warnings("calibrate", "--detections", files[0], "--detections", files[1], "--pixel-pitch-mm",
                           "5.5", "--port", inputs / "dome.toml", "--quiet")
    same_warnings(py, cli, PITCH + DOME_R)
    # Plausible inputs: nothing (each camera's own record of its pitch is not said again).
    assert python_warnings(porthole.calibrate_rig, cameras=cams, target=TARGET, pixel_pitch_mm=0.0055) == []


def test_convert_every_range(detections, tmp_path):
    dets, _ = detections
    cal = porthole.calibrate(dets, TARGET, pixel_pitch_mm=0.0055, model="opencv")
    (tmp_path / "cal.json").write_text(json.dumps(cal.to_dict()))
    porthole.convert(tmp_path / "cal.json", tmp_path / "cam.yml")
    py = python_warnings(porthole.convert, inputs=str(tmp_path / "cam.yml"), out=str(tmp_path / "py.json"),
                         pixel_pitch_mm=5.5)
    cli = all_cli_warnings("convert", tmp_path / "cam.yml", tmp_path / "cli.json", "--pixel-pitch-mm", "5.5")
    same_warnings(py, cli, PITCH)
