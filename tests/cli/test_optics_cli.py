"""Proves the optics commands (virtual-image, trace, presets) reproduce the paper's Table 5, give
well-formed JSON/CSV, and turn bad input into one clear line and exit code 2 with no output."""
import json
import math
import os
import tomllib

import pytest

from conftest import run, run_bad

TABLE5_WD = ["200", "300", "400", "500", "750", "1000", "3000", "5000", "10000", "inf"]


def wd_key(v):
    return "inf" if v == "inf" else str(int(v))


def test_virtual_image_reproduces_table5_with_paper_water(paper_table5):
    out = run("virtual-image", "--port", "nimar-ni320-nominal", "--water-index", "1.341", "--json").json()
    rows = out["rows"]
    assert [wd_key(r["wd_mm"]) for r in rows] == TABLE5_WD
    for r in rows:
        d, v = paper_table5[wd_key(r["wd_mm"])]
        assert abs(r["d_s2ep_mm"] - d) <= 0.2, r
        assert abs(r["vwd_mm"] - v) <= 0.2, r


def test_virtual_image_default_water_within_0p3(paper_table5):
    out = run("virtual-image", "--port", "nimar-ni320-nominal", "--json").json()
    assert abs(out["water"]["index"] - 1.341) < 5e-4  # Quan-Fry, 20 degC, 35 PSU, 546.07 nm
    for r in out["rows"]:
        d, v = paper_table5[wd_key(r["wd_mm"])]
        assert abs(r["d_s2ep_mm"] - d) <= 0.3 and abs(r["vwd_mm"] - v) <= 0.3, r


def test_virtual_image_real_rays_and_units():
    out = run("virtual-image", "--wd", "1000,inf", "--json").json()  # the as-built dome
    assert out["port"]["name"] == "nimar-ni320"
    assert out["is_central"] is False
    for r in out["rows"]:
        assert set(r) >= {"wd_mm", "d_s2ep_mm", "vwd_mm", "d_s2ep_real_mm", "spherical_aberration_mm"}
        assert abs(r["spherical_aberration_mm"]) < 1.0
    assert out["focal"]["efl_air_mm"] < 0  # a dome is a diverging lens


def test_flat_port_virtual_image_is_apparent_depth():
    out = run("virtual-image", "--port", "flat-acrylic-10mm", "--water-index", "1.333", "--glass-index", "1.49",
              "--wd", "1000,inf", "--json").json()
    r = out["rows"][0]
    assert r["d_s2ep_mm"] == pytest.approx(20 + 10 / 1.49 + 1000 / 1.333, abs=1e-6)
    assert out["rows"][1]["d_s2ep_mm"] == "inf"


def test_trace_csv_and_json_obey_snell():
    csv_text = run("trace", "--rays", "5", "--half-angle", "40", "--water-index", "1.341").out
    lines = csv_text.strip().splitlines()
    assert lines[0] == "ray,angle_air_deg,status,point,x_mm,y_mm,z_mm,medium"
    assert len(lines) == 1 + 5 * 4  # pupil, inner, outer, end in water
    j = run("trace", "--rays", "3", "--half-angle", "60", "--port", "flat-acrylic-10mm",
            "--water-index", "1.333", "--format", "json").json()
    for r in j["rays"]:
        assert r["status"] == "ok"
        # Through parallel plates: sin(air) = n_w sin(water).
        assert math.sin(math.radians(r["angle_air_deg"])) == pytest.approx(
            1.333 * math.sin(math.radians(r["angle_water_deg"])), abs=1e-12)


def test_trace_writes_file_atomically(tmp_path):
    target = tmp_path / "fan.csv"
    run("trace", "-o", target)
    assert target.read_text().startswith("ray,")
    run_bad("trace", "-o", tmp_path / "missing-dir" / "fan.csv")
    assert not (tmp_path / "missing-dir").exists()


def test_presets_list_and_print_round_trip(tmp_path):
    listing = run("presets", "--json").json()["presets"]
    names = {p["name"] for p in listing}
    assert {"nimar-ni320", "nimar-ni320-nominal", "flat-acrylic-10mm"} <= names
    text = run("presets", "nimar-ni320").out
    doc = tomllib.loads(text)
    assert doc["outer"]["center_mm"] == [-0.4, -1.0, 21.5] and doc["inner"]["radius_mm"] == 75.7
    # The printed preset, edited and passed back as a file, is accepted.
    f = tmp_path / "my-dome.toml"
    f.write_text(text.replace("nimar-ni320", "my-dome"))
    assert run("virtual-image", "--port", f, "--json").json()["port"]["name"] == "my-dome"


@pytest.mark.parametrize("cmd", ["", "virtual-image", "trace", "presets", "materials"])
def test_help_everywhere(cmd):
    res = run(*([cmd] if cmd else []), "--help")
    assert "Usage" in res.out or "usage" in res.out.lower()


DOME = """type = "dome"
frame = "cam"
[outer]
center_mm = [0, 0, 0]
radius_mm = {ro}
[inner]
center_mm = [0, 0, 0]
radius_mm = {ri}
"""


def test_bad_input_one_line_exit_2(tmp_path):
    bad_radii = tmp_path / "bad.toml"
    bad_radii.write_text(DOME.format(ro=75.7, ri=83.4))
    assert "inner.radius_mm" in run_bad("virtual-image", "--port", bad_radii)
    assert "entrance_pupil_mm" in run_bad("virtual-image", "--port", "nimar-ni320", "--ep", "0,0,200")
    flat = tmp_path / "flat.toml"
    flat.write_text('type = "flat"\nframe = "cam"\nthickness_mm = -10\ninner_point_mm = [0, 0, 20]\n')
    assert "thickness_mm" in run_bad("virtual-image", "--port", flat)
    assert "--water-index" in run_bad("virtual-image", "--water-index", "nan")
    assert "--ep" in run_bad("virtual-image", "--ep", "0,nan,26")
    assert "unknown preset" in run_bad("virtual-image", "--port", "no-such-dome")
    malformed = tmp_path / "broken.toml"
    malformed.write_text('type = "dome"\n[outer\nradius_mm = 3\n')
    assert "broken.toml:2" in run_bad("virtual-image", "--port", malformed)
    assert "--wd" in run_bad("virtual-image", "--wd", "-5")
    assert "lambda" in run_bad("virtual-image", "--lambda", "1500")  # outside Quan-Fry's 400-700 nm
    run_bad("virtual-image", "--no-such-flag")
    run_bad("trace", "--rays", "0")
