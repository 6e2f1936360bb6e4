"""Proves porthole.render() is `porthole render --out NAME.png` (issue 25): the same options give the same
ground truth as the CLI's (every point's pixel in every band within 1e-9 px, read from both files) and
the same PNG byte for byte (also with vignetting, seeded noise and a pupil off the axis); OpenCV's
detector (porthole.detect) finds the corners where the truth puts them; a pitch outside any camera's
range warns as the CLI does; six renders of the lens alone (port='none', a pinhole) calibrate to the
truth's principal distance within 3 sigma; bad options raise one-line ValueErrors naming the keyword
and write nothing."""
import json
import math
import os
import subprocess

import numpy as np
import pytest

import porthole

BIN = os.environ.get("PORTHOLE_BIN", "porthole")
SMALL = dict(pixel_pitch_mm=0.029, samples_per_pixel=4)  # an 814 x 540 px D300, as tests/cli/test_render_cli.py


def test_render_matches_the_cli(tmp_path):
    r = porthole.render(tmp_path / "py.png", distance_mm=1200, tilt_deg=(10, 5), roll_deg=3, **SMALL)
    assert isinstance(r, porthole.RenderResult)
    assert r.image == str(tmp_path / "py.png") and r.truth == str(tmp_path / "py.json")
    summary = json.loads(subprocess.run(
        [BIN, "render", "--out", tmp_path / "cli.png", "--distance", "1200", "--tilt", "10,5", "--roll", "3",
         "--pixel-pitch-mm", "0.029", "--spp", "4", "--quiet", "--json"], check=True, capture_output=True).stdout)
    assert r.points == summary["points"] == 54 and r.warnings == []
    for key in ("width_px", "height_px", "left_out_partial", "left_out_occluded", "blocked_fraction", "refined_fraction"):
        assert getattr(r, key) == summary[key], key
    py = json.loads((tmp_path / "py.json").read_text())
    cli = json.loads((tmp_path / "cli.json").read_text())
    assert r.ground_truth.to_dict() == py
    assert len(py["points"]) == len(cli["points"]) == 54 and len(py["bands"]) == 3
    for a, b in zip(py["points"], cli["points"]):
        assert a["id"] == b["id"] and np.max(np.abs(np.subtract(a["px"], b["px"]))) <= 1e-9
    assert py["camera"] == cli["camera"] and py["focus"] == cli["focus"] and py["pose"] == cli["pose"]
    assert (tmp_path / "py.png").read_bytes() == (tmp_path / "cli.png").read_bytes()
    # The detector finds the corners where the ground truth puts them (the e line's pixel).
    found = porthole.detect(tmp_path / "py.png", py["target"]).images[0]
    truth = {p["id"]: p["px"][1] for p in py["points"]}
    err = [math.dist(uv, truth[i]) for i, uv in zip(found.ids, found.points_px)]
    assert len(err) == 54 and max(err) < 0.3, max(err)  # measured 0.187 px


def test_vignetting_noise_and_pupil_as_the_cli(tmp_path):
    """The lens's vignetting, the sensor's noise (seeded) and a pupil moved off the axis, as the CLI's
    --vignetting natural --vignetting-pa --noise --ep: the same truth and the same PNG byte for byte."""
    r = porthole.render(tmp_path / "py.png", distance_mm=1500, natural_vignetting=True, vignetting_pa=(-0.2, 0, 0),
                        noise_e=(5000, 5), ep_mm=(2, -1, 30), seed=7, **SMALL)
    subprocess.run([BIN, "render", "--out", tmp_path / "cli.png", "--distance", "1500", "--vignetting", "natural",
                    "--vignetting-pa", "-0.2,0,0", "--noise", "5000,5", "--ep", "2,-1,30", "--seed", "7",
                    "--pixel-pitch-mm", "0.029", "--spp", "4", "--quiet"], check=True, capture_output=True)
    py, cli = (json.loads((tmp_path / f"{n}.json").read_text()) for n in ("py", "cli"))
    assert py["vignetting"] == cli["vignetting"] == {"natural": True, "pa": [-0.2, 0, 0]}
    assert py["focus"]["ep_in_housing_mm"] == cli["focus"]["ep_in_housing_mm"] == [2, -1, 30]
    assert py["noise"] == cli["noise"] and py["seed"] == cli["seed"] == 7
    assert r.ground_truth.to_dict() == py and len(py["points"]) == 54
    for a, b in zip(py["points"], cli["points"]):
        assert a["id"] == b["id"] and np.max(np.abs(np.subtract(a["px"], b["px"]))) <= 1e-9
    assert (tmp_path / "py.png").read_bytes() == (tmp_path / "cli.png").read_bytes()


def test_renders_in_air_calibrate_to_the_truth(tmp_path):
    poses = [((0, 0), (0, 0), 0), ((25, 0), (-80, 40), 5), ((-25, 10), (80, -40), -5), ((0, 30), (0, 60), 10),
             ((10, -30), (40, -60), -10), ((-20, -20), (-60, -50), 3)]
    truths = []
    for i, (tilt, shift, roll) in enumerate(poses):
        r = porthole.render(tmp_path / f"pose_{i}.png", port="none", distance_mm=900, tilt_deg=tilt, shift_mm=shift,
                            roll_deg=roll, f_number=math.inf, **SMALL)
        truths.append(r.ground_truth)
    cal = porthole.calibrate_images(tmp_path, "chessboard:9x6:40", pixel_pitch_mm=0.029)
    c_true = truths[0].camera.camera.c_mm
    assert cal.status == porthole.Status.OK
    # Measured: c 24.6804 mm against the truth's 24.6575 mm (1.1 sigma, sigma 0.021 mm), RMS 0.081 px.
    assert abs(cal.params["c_mm"] - c_true) < 3 * cal.sigma["c_mm"] and cal.rms_px < 0.15, (cal.params, c_true)


def test_warns_where_the_cli_warns(tmp_path):
    """A pixel pitch outside any camera's range (0.05 mm): the CLI's stderr warning, as a PortholeWarning
    naming the keyword."""
    with pytest.warns(porthole.PortholeWarning) as caught:
        r = porthole.render(tmp_path / "py.png", pixel_pitch_mm=0.05, samples_per_pixel=1)
    cli = subprocess.run([BIN, "render", "--out", tmp_path / "cli.png", "--pixel-pitch-mm", "0.05", "--spp", "1",
                          "--quiet"], check=True, capture_output=True, text=True).stderr.strip().splitlines()
    assert cli == ["porthole: warning: --pixel-pitch-mm: " + r.warnings[0].split(": ", 1)[1]]
    assert r.warnings[0].startswith("pixel_pitch_mm: 0.05 mm is outside") and len(r.warnings) == 1
    assert [str(w.message) for w in caught] == r.warnings


def test_bad_options_raise_one_line_naming_the_keyword(tmp_path):
    cases = [(dict(out=tmp_path / "x.jpg"), "out: must name a .png file"),
             (dict(out=tmp_path / "x.png", bit_depth=12), "bit_depth: must be 8 or 16"),
             (dict(out=tmp_path / "x.png", samples_per_pixel=5), "samples_per_pixel"),
             (dict(out=tmp_path / "x.png", medium="oil"), "medium: must be water or air"),
             (dict(out=tmp_path / "x.png", distance_mm=-500), "behind the camera"),
             (dict(out=tmp_path / "x.png", f_number=0), "f_number: must be > 0"),
             (dict(out=tmp_path / "x.png", noise_e=(0, 5)), "noise_e: must be > 0")]
    for kwargs, start in cases:
        with pytest.raises(ValueError) as e:
            porthole.render(**SMALL, **kwargs) if "samples_per_pixel" not in kwargs else \
                porthole.render(pixel_pitch_mm=0.029, **kwargs)
        text = str(e.value)
        assert start in text and "\n" not in text and "--" not in text, text
        assert not (tmp_path / "x.png").exists() and not (tmp_path / "x.json").exists()
