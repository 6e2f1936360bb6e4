"""Proves the action cameras work end to end (issue 28): every GoPro preset runs `plan`, `flat`,
`simulate`, `render` and `report` with defaults behind its flat port; a fixed-aperture lens takes its
own aperture and a fixed-focus one gets no focus advice; the fields of view match closed forms (the
lens's projection in air, 2 asin(sin(theta/2)/n) in water) and the published calibrations the presets
come from; lensfun's GoPros resolve; the report picks a comparison dome the lens can focus through."""
import json
import math
import subprocess
import tomllib

import pytest

from conftest import BIN, run, run_bad

PORT = ["--port", "generic-flat-action-housing"]

WIDE = [f"gopro-hero{n}-black" for n in range(5, 13)]
LINEAR = [f"gopro-hero{n}-black-linear" for n in range(5, 13)]
ALL = ["gopro-hero4-black"] + WIDE + LINEAR

# The fields (deg) of the published calibrations the presets are fitted to: gyroflow/lens_profiles,
# GoPro/GoPro_HERO<n> Black_<mode>_*.json ("official": true), their OpenCV fisheye (Kannala-Brandt)
# models evaluated at the frame's edges and corner (H, V, diagonal). HERO6/7 Wide repeat the HERO5's
# numbers, HERO10 the HERO9's, HERO12 is the HERO11's (ASSUMED, no official HERO12 profile).
CALIBRATED_WIDE = {
    5: (122.49, 94.41, 149.38), 6: (122.49, 94.41, 149.38), 7: (122.49, 94.41, 149.38),
    8: (121.66, 93.73, 146.26), 9: (120.63, 92.82, 147.76), 10: (120.63, 92.82, 147.76),
    11: (121.29, 107.58, 155.49), 12: (121.29, 107.58, 155.49),
}
CALIBRATED_LINEAR = {  # H, V of the Linear profiles (the 16:9 one for the HERO7)
    5: (85.6, 69.5), 6: (85.6, 69.5), 7: (85.3, 54.8), 8: (92.8, 76.4), 9: (92.4, 76.1), 10: (92.4, 76.1),
    11: (92.0, 75.7), 12: (92.0, 75.7),
}


def preset(name):
    # The TOML as printed (read directly: a pupil table's "focus_mm = inf" is TOML, not a result).
    return tomllib.loads(subprocess.run([BIN, "presets", name], capture_output=True, text=True, check=True).stdout)


def thin_port(tmp_path):
    """A thin flat port at the pupil: 1 um of glass, its inner face 1 um ahead of the pupil."""
    p = tmp_path / "thin.toml"
    p.write_text('type = "flat"\nframe = "cam"\nmaterial = "n-bk7"\nthickness_mm = 0.001\n'
                 'inner_point_mm = [0.0, 0.0, 0.001]\nsource = "test"\n')
    return str(p)


def test_every_gopro_preset_is_built_in():
    names = run("presets").out
    for name in ALL + ["generic-flat-action-housing"]:
        assert f" {name} " in names, name


@pytest.mark.parametrize("camera", ALL)
def test_plan_flat_simulate_render_report_run_with_defaults(camera, tmp_path):
    body = preset(camera)
    own_f = body["lens"]["f_number_min"]
    assert own_f == body["lens"]["f_number_max"]  # a fixed aperture
    plan = run("plan", "--camera", camera, *PORT, "--json").json()
    assert plan["f_number"] == own_f  # the lens's own aperture, not f/8 (refused before issue 28)
    assert plan["lens"]["fixed_focus"] is True
    run("flat", "--camera", camera, *PORT)
    run("simulate", "--camera", camera, *PORT)
    # A small render: the same sensor in pixels ten times larger, one sample each.
    out = tmp_path / "r.png"
    run("render", "--camera", camera, *PORT, "--out", out, "--quiet", "--spp", "1",
        "--pixel-pitch-mm", body["pixel_pitch_mm"] * 10)
    assert out.exists()
    assert json.loads((tmp_path / "r.json").read_text())["lens"]["f_number"] == own_f
    # The report, every option at its default; the comparison dome is one the lens can focus through.
    rep = run("report", "--camera", camera, *PORT, "--out", tmp_path / "rep")
    assert (tmp_path / "rep" / "index.html").exists()
    data = json.loads((tmp_path / "rep" / "report.json").read_text())
    assert data["inputs"]["f_number"] == own_f
    assert data["other_port"]["port"]["name"] == "generic-dome-230mm-glass"
    # The pupil-offset sweep stops 1 mm short of the window 8 mm ahead (it refused +8 and +10 before).
    assert [row["offset_mm"] for row in data["sweeps"]["z"]] == [-10, -8, -6, -4, -2, 0, 2, 4, 6]
    page = (tmp_path / "rep" / "index.html").read_text()
    assert "Set the focus scale" not in page and "pre-focus" not in page  # fixed focus: no focus advice
    assert "Fixed focus" in page
    lines = [l for l in rep.err.splitlines() if "comparison port" in l]
    assert len(lines) == 1 and "nimar-ni320-nominal" in lines[0], rep.err


@pytest.mark.parametrize("camera", WIDE + LINEAR)
def test_field_of_view_in_air_and_water_closed_forms(camera, tmp_path):
    """Air: the lens's projection at the frame's edges and corner (stereographic r = 2 f tan(t/2)
    for Wide, rectilinear r = f tan t for Linear); water, behind a thin flat port at the pupil and
    behind the housing's window: 2 asin(sin(theta/2)/n)."""
    body = preset(camera)
    f, pitch = body["lens"]["focal_length_mm"], body["pixel_pitch_mm"]
    half = [body["width_px"] * pitch / 2, body["height_px"] * pitch / 2,
            math.hypot(body["width_px"], body["height_px"]) * pitch / 2]
    stereo = body["lens"]["projection"] == "stereographic"
    air = [4 * math.degrees(math.atan(r / (2 * f))) if stereo else 2 * math.degrees(math.atan(r / f)) for r in half]
    for port in (["--port", thin_port(tmp_path)], PORT):
        plan = run("plan", "--camera", camera, *port, "--json").json()
        n = plan["water"]["index"]
        for key, a in zip(("horizontal_deg", "vertical_deg", "diagonal_deg"), air):
            assert plan["fov"]["air"][key] == pytest.approx(a, abs=1e-6), key
            water = 2 * math.degrees(math.asin(math.sin(math.radians(a / 2)) / n))
            assert plan["fov"]["water"][key] == pytest.approx(water, abs=1e-6), (key, port)


@pytest.mark.parametrize("n", range(5, 13))
def test_presets_reproduce_their_published_calibrations(n):
    """The Wide preset's stereographic fit sees the calibration's field within 1.5 deg across and
    4 deg across the diagonal; the Linear preset (a pinhole) within 0.5 deg."""
    wide = run("plan", "--camera", f"gopro-hero{n}-black", *PORT, "--json").json()["fov"]["air"]
    h, v, d = CALIBRATED_WIDE[n]
    assert abs(wide["horizontal_deg"] - h) < 1.5 and abs(wide["vertical_deg"] - v) < 1.5, wide
    assert abs(wide["diagonal_deg"] - d) < 4.0, wide
    lin = run("plan", "--camera", f"gopro-hero{n}-black-linear", *PORT, "--json").json()["fov"]["air"]
    h, v = CALIBRATED_LINEAR[n]
    assert abs(lin["horizontal_deg"] - h) < 0.5 and abs(lin["vertical_deg"] - v) < 0.5, lin


def test_fixed_focus_gets_no_focus_advice():
    text = run("plan", "--camera", "gopro-hero9-black", *PORT, "--wd", "1000").out
    for advice in ("set the focus scale", "focus scale", "hyperfocal", "pre-focus", "depth of field, mm"):
        assert advice not in text, advice
    assert "fixed focus, nothing to set" in text
    j = run("plan", "--camera", "gopro-hero9-black", *PORT, "--wd", "1000", "--json").json()
    assert j["lens"]["fixed_focus"] is True
    assert not [w for w in j["warnings"] if "pre-focus" in w or "focus scale" in w], j["warnings"]
    nikon = run("plan", "--port", "flat-acrylic-10mm", "--wd", "1000", "--json").json()
    assert nikon["lens"]["fixed_focus"] is False and any("pre-focus" in w for w in nikon["warnings"])
    assert "within the lens's sharp range" in text
    too_close = run("plan", "--camera", "gopro-hero9-black", *PORT, "--wd", "150").out
    assert "NOT SHARP" in too_close and "set the focus scale" not in too_close
    # A lens that focuses still gets its focus scale.
    assert "set the focus scale to" in run("plan", "--port", "flat-acrylic-10mm", "--wd", "1000").out


def test_fixed_aperture_is_the_default_and_other_apertures_are_refused():
    assert run("plan", "--camera", "gopro-hero11-black", *PORT, "--json").json()["f_number"] == 2.5
    line = run_bad("plan", "--camera", "gopro-hero11-black", *PORT, "--aperture", "8")
    assert "--aperture" in line and "f/2.5" in line, line
    # A lens with a range keeps f/8.
    assert run("plan", "--port", "flat-acrylic-10mm", "--json").json()["f_number"] == 8


def test_lensfun_action_camera_is_usable():
    """lensfun's GoPro HERO4 Silver (mount goProHero4, crop factor 7.66) with its own lens entry."""
    plan = run("plan", "--camera", "GoPro HERO4 Silver", "--pixel-pitch-mm", "0.00155", *PORT, "--json").json()
    assert plan["camera"]["found_in"] == "lensfun"
    assert plan["lens"]["name"] == "GoPro HERO4" and plan["lens"]["projection"] == "equisolid"
    assert plan["f_number"] == 2.8
    diag = math.hypot(plan["camera"]["width_px"], plan["camera"]["height_px"]) * 0.00155
    assert diag == pytest.approx(43.2666 / 7.66, abs=0.002)


def test_report_of_a_dome_keeps_the_flat_comparison(tmp_path):
    rep = run("report", "--port", "nimar-ni320-nominal", "--out", tmp_path / "rep")
    assert "comparison port" not in rep.err
    assert "Set the focus scale" in (tmp_path / "rep" / "index.html").read_text()  # a lens that focuses
    data = json.loads((tmp_path / "rep" / "report.json").read_text())
    assert data["other_port"]["port"]["name"] == "flat-acrylic-10mm"
