"""Proves what a new user met in issue 12, at the CLI: a wide lens behind an 8-inch dome (the glass,
not the lens, sets the closest distance), the extension ring that centres the pupil, warnings for
values in the wrong unit (one stderr line, run goes on), the Mediterranean's salinity, output
folders created when missing and outputs checked before long work, and --json / --pixel-pitch-mm
accepted where the issue asked."""
import json
import math
import os
import re

import pytest

from conftest import run, run_bad

DOME8 = """name = "dome-8in"
description = "8-inch concentric test dome"
source = "test"
type = "dome"
frame = "cam"
material = "pmma"
entrance_pupil_mm = [0.0, 0.0, 40.0]
[outer]
center_mm = [0.0, 0.0, 0.0]
radius_mm = {outer}
[inner]
center_mm = [0.0, 0.0, 0.0]
radius_mm = {inner}
"""

WIDE16 = """name = "wide-16mm"
description = "16 mm test lens"
source = "test"
mount = "nikon-f"
focal_length_mm = 16.0
f_number_min = 2.8
f_number_max = 22.0
min_focus_mm = 150.0
pupil = [ { focus_mm = inf, d_ep2f_mm = 40.0 } ]
"""


@pytest.fixture
def wide(tmp_path):
    (tmp_path / "dome8.toml").write_text(DOME8.format(outer=101.6, inner=93.6))
    (tmp_path / "wide16.toml").write_text(WIDE16)
    return tmp_path


def warnings(err):
    return [line for line in err.splitlines() if line.startswith("porthole: warning: ")]


def test_wide_lens_behind_8in_dome_says_the_glass_sets_the_closest_distance(wide):
    res = run("plan", "--port", wide / "dome8.toml", "--lens", wide / "wide16.toml")
    assert "the glass" in res.out and "not needed" in res.out
    assert "dioptre close-up  WD 0 to inf" not in res.out
    j = run("plan", "--port", wide / "dome8.toml", "--lens", wide / "wide16.toml", "--json").json()
    assert j["min_wd_set_by"] == "glass" and j["min_wd_mm"] == 0
    assert j["pupil_to_outer_mm"] == pytest.approx(101.6, abs=1e-9)
    assert all(r["needed"] is False for r in j["closeup"])
    # The paper's system: the lens's minimum focus sets it, close-ups are needed.
    p = run("plan", "--json").json()
    assert p["min_wd_set_by"] == "lens" and all(r["needed"] for r in p["closeup"])


def test_flat_wide_lens_has_no_total_internal_reflection_warning(wide):
    j = run("flat", "--lens", wide / "wide16.toml", "--json").json()
    assert not any("total internal reflection" in w for w in j["warnings"])
    assert j["fov"]["water_traced"]["diagonal_deg"] < j["max_fov_deg"]
    ta = math.radians(j["fov"]["air"]["diagonal_deg"] / 2)
    tg = math.asin(math.sin(ta) / j["port"]["glass_index"])
    assert j["corner_outer_radius_mm"] == pytest.approx(20 * math.tan(ta) + 10 * math.tan(tg), abs=1e-9)


def test_extension_ring_advice_in_text_and_json():
    j = run("plan", "--port", "nimar-ni320", "--wd", "1000", "--json").json()
    c = j["pupil_centring"]
    assert c["axial_offset_mm"] == pytest.approx(26.9 - 21.5, abs=0.1)  # Table 4
    assert c["lateral_offset_mm"] == pytest.approx(math.hypot(0.4, 1.0), abs=1e-9)
    assert abs(c["residual_mm"]) < 1e-6
    text = run("plan", "--port", "nimar-ni320", "--wd", "1000").out
    assert f"add a {c['extension_mm']:.1f} mm extension ring" in text
    assert run("plan", "--port", "flat-acrylic-10mm", "--json").json()["pupil_centring"] is None


@pytest.mark.parametrize("args,field", [
    (["plan", "--coc", "11"], "--coc"),
    (["plan", "--pixel-pitch-mm", "5.5"], "--pixel-pitch-mm"),
    (["flat", "--pixel-pitch", "5.5"], "--pixel-pitch-mm"),
    (["simulate", "--pixel-pitch-mm", "5.5"], "--pixel-pitch-mm"),
])
def test_values_in_the_wrong_unit_warn_once_and_run(args, field):
    res = run(*args)
    w = warnings(res.err)
    assert len(w) == 1 and w[0].startswith(f"porthole: warning: {field}: "), res.err
    assert res.out  # the run went on


def test_dome_radii_in_metres_warn(tmp_path):
    (tmp_path / "m.toml").write_text(DOME8.format(outer=0.1016, inner=0.0936))
    res = run("virtual-image", "--port", tmp_path / "m.toml", "--json")
    w = warnings(res.err)
    assert len(w) == 2 and all("radius_mm" in line for line in w), res.err
    # Plausible values say nothing.
    assert warnings(run("plan", "--coc", "0.015").err) == []


def test_pixel_pitch_mm_replaces_a_preset_bodys_pitch_keeping_its_size():
    a = run("plan", "--json").json()["camera"]
    b = run("plan", "--pixel-pitch-mm", "0.011", "--json").json()["camera"]
    assert b["pixel_pitch_mm"] == 0.011
    assert b["width_px"] * 0.011 == pytest.approx(a["width_px"] * a["pixel_pitch_mm"], abs=0.011)
    s = run("simulate", "--pixel-pitch-mm", "0.011", "--json").json()["camera"]
    assert (s["width_px"], s["pixel_pitch_mm"]) == (4288 * 0.0055 / 0.011, 0.011)


def test_mediterranean_salinity_runs_with_a_note():
    res = run("virtual-image", "--salinity", "38", "--json")
    assert "porthole: note: salinity 38 PSU" in res.err
    n38 = res.json()["water"]["index"]
    n35 = run("virtual-image", "--json").json()["water"]["index"]
    assert (n38 - n35) / 3 == pytest.approx(1.9e-4, abs=0.2e-4)  # dn/dS of seawater
    assert n38 == pytest.approx(1.3415, abs=5e-5)  # docs/materials.md
    # The error names the flag, not the library's field (issue 23).
    line = run_bad("virtual-image", "--salinity", "44")
    assert "--salinity: 44 is outside" in line and "salinity_psu" not in line


def test_compare_creates_the_csv_folder(tmp_path):
    cal = {"camera": {"c_mm": 25.8, "K1": 1.8e-4}, "sigma": {"c_mm": 0.006, "K1": 1e-6},
           "sensor": {"width_px": 4288, "height_px": 2848, "pixel_pitch_mm": 0.0055}}
    (tmp_path / "a.json").write_text(json.dumps(cal))
    out = tmp_path / "curves" / "deeper"
    run("compare", tmp_path / "a.json", tmp_path / "a.json", "--csv-dir", out)
    assert (out / "curves.csv").read_text().startswith("r_mm,")
    (tmp_path / "file").write_text("x")
    assert "--csv-dir" in run_bad("compare", tmp_path / "a.json", tmp_path / "a.json", "--csv-dir", tmp_path / "file")


def test_detect_creates_the_out_dir(tmp_path):
    from test_calib_cli import copy_samples
    imgs = tmp_path / "imgs"
    imgs.mkdir()
    if copy_samples(imgs) < 1:
        pytest.fail("OpenCV sample chessboards missing: run scripts/install-deps (opencv-doc)")
    for f in sorted(imgs.iterdir())[2:]:
        f.unlink()
    out = tmp_path / "det" / "new"
    run("detect", "--images", imgs, "--target", "chessboard:9x6:25", "--out-dir", out, "--quiet")
    assert len(list(out.glob("*.json"))) == 2


def test_outputs_are_checked_before_long_work(tmp_path):
    assert "--out" in run_bad("calibrate", "--detections", tmp_path, "--out", tmp_path / "no" / "such" / "x.json")
    assert "--sweep-out" in run_bad("simulate", "--sweep", "z", "--sweep-out", tmp_path / "no" / "x.csv")
    assert "--out" in run_bad("trace", "--out", tmp_path)


def test_trace_takes_json():
    j = run("trace", "--json", "--rays", "3").json()
    assert len(j["rays"]) == 3 and j["rays"][1]["status"] == "ok"


def test_every_command_takes_json():
    listing = run("--help").out
    commands = re.findall(r"^  ([a-z][a-z-]+)\s", listing[listing.index("Subcommands"):], re.M)
    assert len(commands) >= 14, listing
    for cmd in commands:
        assert "--json" in run(cmd, "--help").out, cmd


def test_report_and_synth_scan_json(tmp_path):
    j = run("synth-scan", tmp_path / "cap.ply", "--points", "500", "--json").json()
    assert j["points"] == 500 and (tmp_path / "cap.ply").exists()
    r = run("report", "--out", tmp_path / "r", "--json").json()
    assert r["figures"] and os.path.exists(r["index_html"]) and os.path.exists(r["report_json"])


def test_toml_errors_name_the_line_of_the_key(tmp_path):
    text = DOME8.format(outer=101.6, inner=93.6).replace('frame = "cam"', 'frame = "camm"')
    (tmp_path / "d.toml").write_text(text)
    line = text.splitlines().index('frame = "camm"') + 1
    assert f"d.toml:{line}: frame:" in run_bad("virtual-image", "--port", tmp_path / "d.toml")
    text = DOME8.format(outer=101.6, inner=120)
    (tmp_path / "e.toml").write_text(text)
    line = text.splitlines().index("radius_mm = 120") + 1
    assert f"e.toml:{line}: inner.radius_mm:" in run_bad("virtual-image", "--port", tmp_path / "e.toml")
