"""Proves porthole.render(rig=..., set=N) is `porthole render --rig RIG --set N` (issues 25, 26): one
library call (render::RenderJob) behind both, so the same arguments give every camera's ground truth
equal to the CLI's (every point's pixel in every band within 1e-9 px) and every PNG byte for byte; the
rendered set of two central OpenCV cameras 300 mm apart, turned 5 deg towards each other, detected
(porthole.detect) and calibrated as a rig (porthole.calibrate_rig) gives the baseline and rotation
back; a calibrated rig (RigCalibration) renders as its file does; a single camera's set and a rig of
--baseline behind a port match the CLI too; bad options raise one line naming the keyword."""
import json
import math
import os
import subprocess

import numpy as np
import pytest

import porthole

BIN = os.environ.get("PORTHOLE_BIN", "porthole")
TARGET = "chessboard:11x8:30"  # odd x even: no 180 deg ambiguity
CONV = math.radians(5)
# cam_from_rig of the second camera: 300 mm to the right of the first, turned 5 deg towards it:
# R = R_y(+5 deg), t = -R (300, 0, 0).
TRUE_T = [-300 * math.cos(CONV), 0.0, 300 * math.sin(CONV)]
# Small frames (480 x 320 px), one sample per pixel and 16 near edges, a pinhole: fast on 2 cores.
FAST = dict(target=TARGET, samples_per_pixel=1, edge_samples_per_pixel=16, f_number=math.inf)
FAST_CLI = ["--target", TARGET, "--spp", "1", "--edge-spp", "16", "--f-number", "inf", "--quiet", "--json"]


def write_rig(path):
    """Two central OpenCV cameras (the rig JSON of `porthole calibrate`, as tests/cli/test_render_rig_cli.py
    writes it, at half its resolution)."""
    def camera(name, params, rotation_rad, translation_mm):
        keys = ["fx_px", "fy_px", "cx_px", "cy_px", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"]
        return {"name": name, "model": "opencv", "camera": dict(zip(keys, params + [0, 0, 0, 0])),
                "sensor": {"width_px": 480, "height_px": 320, "pixel_pitch_mm": 0.0098},
                "cam_from_rig": {"rotation_rad": rotation_rad, "translation_mm": translation_mm}}
    path.write_text(json.dumps({"rig": {"cameras": [
        camera("cam0", [550, 550.2, 240.6, 159.3, -0.08, 0.05, 2e-4, -1e-4], [0, 0, 0], [0, 0, 0]),
        camera("cam1", [547.5, 547.6, 239.0, 161.0, -0.07, 0.04, -1e-4, 2e-4], [0, CONV, 0], TRUE_T)]}}))
    return path


WORST = [0.0]  # the largest pixel difference between Python's truth and the CLI's over the module


def cli(*args):
    return json.loads(subprocess.run([BIN, "render", *map(str, args)], check=True, capture_output=True).stdout)


def assert_same_image(py, cli_png):
    """A render of Python (a RenderedImage or RenderResult's files) and the CLI's at cli_png: the same
    ground truth (points to 1e-9 px, everything else equal) and the same PNG bytes."""
    a = json.loads(open(py.truth).read())
    b = json.loads(cli_png.with_suffix(".json").read_text())
    assert py.ground_truth.to_dict() == a
    assert len(a["points"]) == len(b["points"]) > 0
    worst = 0.0
    for p, q in zip(a["points"], b["points"]):
        assert p["id"] == q["id"]
        worst = max(worst, float(np.max(np.abs(np.subtract(p["px"], q["px"])))))
    assert worst <= 1e-9, worst
    WORST[0] = max(WORST[0], worst)
    assert {k: v for k, v in a.items() if k != "points"} == {k: v for k, v in b.items() if k != "points"}
    assert open(py.image, "rb").read() == cli_png.read_bytes()


def test_a_rig_set_is_the_clis_and_calibrates_back(tmp_path):
    rig = write_rig(tmp_path / "rig.json")
    r = porthole.render(tmp_path / "py", rig=rig, set=8, **FAST)
    summary = cli("--rig", rig, "--set", 8, "--out", tmp_path / "cli", *FAST_CLI)
    assert isinstance(r, porthole.RenderSet) and r.warnings == []
    assert list(r.cameras) == summary["cameras"] == ["cam0", "cam1"] and r.frames == summary["frames"] == 8
    # Bare cameras: the air set only, every frame seen by both cameras under one name.
    assert len(r.renders) == 16 and {x.medium for x in r.renders} == {"air"}
    assert [x.frame for x in r.of("cam0")] == [x.frame for x in r.of("cam1")] == [f"pose_{i:03d}" for i in range(8)]
    assert all(isinstance(x, porthole.RenderedImage) for x in r.renders)
    for x in r.renders:
        assert x.image == str(tmp_path / "py" / "air" / x.camera / f"{x.frame}.png")
        assert_same_image(x, tmp_path / "cli" / "air" / x.camera / f"{x.frame}.png")
        assert x.ground_truth.rig.camera == x.camera
    # The CLI's --json is the result's, less the files' folder and the time taken.
    ours = [{k: v for k, v in e.items() if k not in ("image", "truth", "seconds")} for e in r.to_dict()["images"]]
    theirs = [{k: v for k, v in e.items() if k not in ("image", "truth", "seconds")} for e in summary["images"]]
    assert ours == theirs

    # Detected and calibrated as a rig: the baseline and the convergence back.
    found = [porthole.detect(tmp_path / "py" / "air" / cam, TARGET) for cam in ("cam0", "cam1")]
    assert [len(f.images) for f in found] == [8, 8]
    cal = porthole.calibrate_rig(found, TARGET, model="opencv", pixel_pitch_mm=0.0098)
    right = cal.cameras[1]
    dt = math.dist(right.translation_mm, TRUE_T)
    dr = math.degrees(math.dist(right.rotation_rad, [0, CONV, 0]))
    print(f"rig rendered by porthole.render: baseline {right.baseline_mm:.4f} mm (truth 300, sigma "
          f"{right.baseline_sigma_mm:.4f}), translation {dt:.4f} mm and rotation {dr:.5f} deg from the truth, "
          f"RMS {cal.rms_px:.3f} px")
    assert cal.status == porthole.Status.OK
    assert abs(right.baseline_mm - 300) < 0.5 and dt < 0.5 and dr < 0.05

    # The calibrated rig (a RigCalibration) renders as a rig: cam1's truth carries its cam_from_rig.
    again = porthole.render(tmp_path / "again", rig=cal, distance_mm=1200, **FAST)
    assert [x.camera for x in again.renders] == [c.name for c in cal.cameras]
    t1 = again.renders[1].ground_truth.rig.cam_from_rig
    assert np.allclose(t1.translation_mm, right.translation_mm, atol=1e-9)
    assert np.allclose(t1.rotation_rad, right.rotation_rad, atol=1e-12)


def test_a_set_and_a_baseline_rig_behind_a_port_are_the_clis(tmp_path):
    small = dict(pixel_pitch_mm=0.029, samples_per_pixel=1, f_number=math.inf)
    small_cli = ["--pixel-pitch-mm", "0.029", "--spp", "1", "--f-number", "inf", "--quiet", "--json"]
    # One camera, two poses in water and in air, one focus for the set.
    # The set's middle distance is closer than the lens focuses under water: the CLI's note, a PortholeWarning.
    with pytest.warns(porthole.PortholeWarning, match="^the lens cannot focus on the set's middle distance"):
        r = porthole.render(tmp_path / "set", set=2, **small)
    summary = cli("--set", 2, "--out", tmp_path / "cli_set", *small_cli)
    assert r.poses == summary["poses"] == 2 and r.focus_distance_mm == summary["focus_distance_mm"]
    assert [(x.camera, x.medium, x.frame) for x in r.renders] == [
        ("", m, f"pose_{i:03d}") for i in range(2) for m in ("water", "air")]
    for x in r.renders:
        assert_same_image(x, tmp_path / "cli_set" / x.medium / f"{x.frame}.png")
    # Two of the camera behind the NI320, 300 mm apart, turned 5 deg: one frame in water.
    b = porthole.render(tmp_path / "base", baseline_mm=300, convergence_deg=5, port="nimar-ni320", **small)
    cli("--baseline", 300, "--convergence", 5, "--port", "nimar-ni320", "--out", tmp_path / "cli_base", *small_cli)
    assert [x.camera for x in b.renders] == ["cam0", "cam1"] and b.frames == 1
    for x in b.renders:
        assert x.ground_truth.port.name == "nimar-ni320" and x.medium == "water"
        assert_same_image(x, tmp_path / "cli_base" / x.camera / "render.png")


def test_bad_rig_options_raise_one_line_naming_the_keyword(tmp_path):
    rig = write_rig(tmp_path / "rig.json")
    single = tmp_path / "single.json"
    single.write_text(json.dumps({k: v for k, v in json.loads(rig.read_text())["rig"]["cameras"][0].items()
                                  if k != "name"}))
    out = tmp_path / "out"
    cases = [(dict(rig=rig, baseline_mm=300), "rig: give a rig file or baseline_mm=, not both"),
             (dict(convergence_deg=5), "convergence_deg: goes with baseline_mm="),
             (dict(baseline_mm=-1), "baseline_mm: must be > 0"),
             (dict(rig=single), "rig"),
             (dict(rig=rig, shift_mm=(-700, 0)), "outside"),
             (dict(rig=rig, set=-2), "set: must be 1 to 10000 (0: one image)"),
             (dict(rig=rig, set=2, distances_mm=(900, 500)), "distances_mm")]
    for kwargs, start in cases:
        with pytest.raises(ValueError) as e:
            porthole.render(out, **FAST, **kwargs)
        text = str(e.value)
        assert start in text and "\n" not in text and "--" not in text, text
        assert not out.exists()
    # A second set into the same folder: refused without force (naming it), replaced with it.
    porthole.render(out, rig=rig, set=1, **FAST)
    with pytest.raises(ValueError, match="^out: .* not empty .*force= removes"):
        porthole.render(out, rig=rig, set=1, **FAST)
    again = porthole.render(out, rig=rig, set=1, force=True, seed=2, **FAST)
    assert sorted(os.listdir(out / "air" / "cam1")) == ["pose_000.json", "pose_000.png"]
    assert again.renders[0].ground_truth.seed == 2


def test_a_rig_behind_its_own_ports_is_the_clis(tmp_path):
    """A rig file whose cameras sit behind their own domes (the shell and the pupil's place in it, as
    `porthole calibrate --port` writes them): cam0's port a preset (its glass's dispersion), cam1's a
    name porthole does not know (its glass taken from port=, with the note the CLI prints)."""
    rig = json.loads(write_rig(tmp_path / "rig.json").read_text())
    for cam, name in zip(rig["rig"]["cameras"], ("nimar-ni320", "someones-dome")):
        cam["port"] = {"kind": "dome", "name": name,
                       "shell": {"n_glass": 1.52, "n_water": 1.341, "outer_radius_mm": 110.0, "inner_radius_mm": 100.0,
                                 "inner_from_outer_mm": [0.0, 0.0, 1.3], "rim_from_outer_z_mm": 0.0},
                       "parameters": {"ep_in_dome_x_mm": 0.4, "ep_in_dome_y_mm": 1.0, "ep_in_dome_z_mm": 5.4}}
    (tmp_path / "ported.json").write_text(json.dumps(rig))
    with pytest.warns(porthole.PortholeWarning, match="someones-dome"):
        r = porthole.render(tmp_path / "py", rig=rig, distance_mm=1500, **FAST)
    out = subprocess.run([BIN, "render", "--rig", tmp_path / "ported.json", "--distance", "1500", "--out",
                          tmp_path / "cli", *FAST_CLI[:-2]], check=True, capture_output=True, text=True)
    assert [x.camera for x in r.renders] == ["cam0", "cam1"]
    for x in r.renders:
        assert x.medium == "water" and x.ground_truth.rig.port == "the camera's own"
        assert_same_image(x, tmp_path / "cli" / x.camera / "render.png")
    note = "camera cam1's port 'someones-dome' is no preset or port file here: its glass taken as"
    glass = porthole.load_port("nimar-ni320").material  # port='s (the default port's), as the CLI's --port
    assert 'material = "' + glass + '"' in r.renders[1].ground_truth.port.toml
    assert [w for w in r.warnings if note in w] == [f"rig: {note} {glass} (port's)"]
    assert f"porthole: note: --rig: {note}" in out.stderr
    print(f"largest truth difference Python - CLI over this module: {WORST[0]:g} px")
