"""Proves issue 23's "no silently wrong answer" for compare and the printed numbers: a calibration
compared with its own round trip through Metashape XML does not "differ" (the chi2 tests only what
both adjusted and names what it left out) while a changed one still does; a file without a pitch is
refused with the --pixel-pitch-mm to pass; plan and flat print words, not "f/0.0", "x0.00", "x-",
"inf" thresholds or "- mm", for a fisheye, an unlimited in-air depth of field and a lens that cannot
focus behind the port; hints are computed from the value given; the acceptance check itself
(conftest.output_problems) catches each of those on the old texts."""
import json

import pytest

from conftest import output_problems, run, run_bad

TARGET = "chessboard:9x6:25"
PITCH = "0.0022"


@pytest.fixture(scope="module")
def air(tmp_path_factory):
    """The OpenCV samples calibrated in mm (pitch 2.2 um), as the README's air.json."""
    from test_calib_cli import copy_samples
    d = tmp_path_factory.mktemp("rt")
    images = d / "left"
    images.mkdir()
    if copy_samples(images) < 13:
        pytest.fail("OpenCV sample chessboards missing: run scripts/install-deps (opencv-doc)")
    run("calibrate", "--images", images, "--target", TARGET, "--pixel-pitch-mm", PITCH, "--quiet",
        "--out", d / "air.json")
    return d


def test_compare_round_trip_through_metashape_is_consistent(air):
    run("convert", air / "air.json", air / "air.xml", "--to", "metashape")
    run("convert", air / "air.xml", air / "back.json", "--pixel-pitch-mm", PITCH)
    j = run("compare", air / "air.json", air / "back.json", "--json").json()
    assert j["max_diff_um"] < 1.0  # the refit's own error
    # Only the parameters both adjusted are tested; those adjusted in one only are named, with why.
    tested = set(j["tested"])
    adjusted_a = {p["parameter"] for p in j["parameters"] if p["tested"] or p["left_out"] == "adjusted in A only"}
    assert j["dof"] == len(tested) and tested <= adjusted_a
    for p in j["left_out"]:
        assert p["parameter"] not in tested and p["reason"] in ("adjusted in A only", "adjusted in B only")
    assert j["significant"] is False, (j["chi2"], j["dof"], j["left_out"])
    assert j["p_value"] > 0.05
    text = run("compare", air / "air.json", air / "back.json").out
    assert "do not differ significantly" in text and "both calibrations adjusted" in text
    if j["left_out"]:
        names = ", ".join(p["parameter"] for p in j["left_out"])
        assert "left out of chi2: " in text and j["left_out"][0]["parameter"] in text, names

    # A genuinely different calibration still differs: c moved by 10 sigma.
    cal = json.loads((air / "air.json").read_text())
    cal["camera"]["c_mm"] += 10 * cal["sigma"]["c_mm"]
    (air / "moved.json").write_text(json.dumps(cal))
    moved = run("compare", air / "air.json", air / "moved.json", "--json").json()
    assert moved["significant"] is True and moved["p_value"] < 1e-6


def test_compare_says_which_pitch_to_pass(air):
    """A Metashape file holds no pitch: compare names the flag and the value to give it."""
    run("convert", air / "air.json", air / "air2.xml", "--to", "metashape")
    line = run_bad("compare", air / "air.json", air / "air2.xml")
    assert f"--pixel-pitch-mm {float(PITCH):g}" in line, line
    assert "holds no pixel pitch" in line
    ok = run("compare", air / "air.json", air / "air2.xml", "--pixel-pitch-mm", PITCH, "--json").json()
    assert ok["max_diff_um"] < 1.0


def test_fisheye_plan_prints_no_f0():
    """The fisheye behind a centred dome has no corner blur: every f-number of the lens is sharp."""
    out = run("plan", "--lens", "nikkor-10.5mm-f2.8g-fisheye", "--port", "generic-dome-8in", "--wd", "500").out
    assert "f/0.0" not in out
    j = run("plan", "--lens", "nikkor-10.5mm-f2.8g-fisheye", "--port", "generic-dome-8in", "--wd", "500",
            "--json").json()
    fc = j["field_curvature"]
    assert fc["f_number_for_sharp_corners"] >= j["lens"]["f_number_min"]
    if fc["corner_blur_px"] * j["camera"]["pixel_pitch_mm"] <= j["coc_mm"] and \
            fc["f_number_for_sharp_corners"] == j["lens"]["f_number_min"]:
        assert "at every f-number of the lens" in out


@pytest.mark.parametrize("wd", ["20000", "200000"])
def test_unlimited_depth_of_field_in_air_has_no_ratio(wd):
    """Beyond the hyperfocal distance the in-air depth of field is unlimited: no "x0.00" or "x-"."""
    j = run("plan", "--wd", wd, "--json").json()
    assert j["dof"]["air"]["far_mm"] == "inf"
    assert j["dof"]["ratio_water_to_air"] is None and "unlimited" in j["dof"]["ratio_note"]
    out = run("plan", "--wd", wd).out
    assert "of air)" not in out and "not applicable" in out and "unlimited" in out


def test_lens_that_cannot_focus_behind_the_port(tmp_path):
    """A lens whose closest focus lies beyond the virtual image of infinity: no WD is in reach."""
    lens = tmp_path / "far.toml"
    lens.write_text('name = "far-focus-24"\nmount = "nikon-f"\nfocal_length_mm = 24.0\nf_number_min = 2.8\n'
                    'f_number_max = 22.0\nmin_focus_mm = 1200.0\n'
                    'pupil = [ { focus_mm = inf, d_ep2f_mm = 24.6 }, { focus_mm = 1200.0, d_ep2f_mm = 25.0 } ]\n')
    res = run("plan", "--lens", lens, "--wd", "1000")
    j = run("plan", "--lens", lens, "--wd", "1000", "--json").json()
    assert j["min_wd_mm"] == "inf"
    assert ">= inf" not in res.out and "focus scale - mm" not in res.out
    assert "none: the lens cannot focus on anything behind this port" in res.out
    assert not any("move back" in w for w in j["warnings"])


@pytest.mark.parametrize("value,expected", [("4.35", "4.35 um is 0.00435 mm"), ("5.5", "5.5 um is 0.0055 mm")])
def test_pitch_hint_is_computed_from_the_value(value, expected):
    err = run("plan", "--pixel-pitch-mm", value).err
    assert expected in err, err
    if value != "5.5":
        assert "5.5 um" not in err


def test_the_acceptance_check_catches_the_old_texts():
    """The printed nonsense of the old tree, as the issue quotes it, is caught; the new words pass."""
    for old in ["corner blur 0.0 px at f/8; within the circle of confusion from f/0.0",
                "water, real objects        1000       800      1300       500   (x0.00 of air)",
                "water, real objects        1000       800       inf       inf   (x- of air)",
                "! The lens cannot focus: move back to WD >= inf mm or add a close-up lens",
                "infinity sharp, in air         hyperfocal 6545 mm (focus scale - mm): sharp from 3272 mm",
                "rms = nan px"]:
        assert output_problems(old), old
    for new in ["in air                      20000      6000  infinity unlimited",
                "  with a +1 dioptre close-up  WD 200 to infinity mm",
                "corner blur 0.0 px at f/8; within the circle of confusion at every f-number of the lens (from f/2.8)"]:
        assert output_problems(new) == [], (new, output_problems(new))
    assert output_problems('{"rms_px": "inf"}') and output_problems('{"sigma": NaN}')
    assert output_problems('{"note": ""}') and output_problems('{"c_mm": "inf"}')
    assert output_problems('{"far_mm": "inf", "max_wd_mm": "inf"}') == []
