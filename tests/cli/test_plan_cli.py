"""Proves `porthole plan` and `porthole flat` give the paper's numbers (Fig. 12 minimum working
distances, Section 4 depth of field, the flat port's 97.2 deg limit) as JSON, and turn bad input
into one clear line and exit code 2."""
import math

import pytest

from conftest import read_table, run, run_bad

PAPER = ["--port", "nimar-ni320-nominal", "--water-index", "1.341"]


def section4():
    return {r["quantity"]: float(r["value_mm"]) for r in read_table("menna2016_section4_dof.csv")}


def test_min_wd_24mm_and_35mm():
    p24 = run("plan", *PAPER, "--lens", "nikkor-24mm-f2.8d", "--json").json()
    assert 680 <= p24["min_wd_mm"] <= 730
    assert p24["min_wd_mm"] <= section4()["min_wd_nikkor_24mm"]  # the paper rounds up to a Table 5 row
    p35 = run("plan", *PAPER, "--lens", "nikkor-35mm-f2d", "--json").json()
    assert 240 <= p35["min_wd_mm"] <= 275
    assert p35["min_wd_mm"] <= section4()["min_wd_nikkor_35mm"]


def test_section4_depth_of_field():
    paper = section4()
    out = run("plan", *PAPER, "--lens", "nikkor-24mm-f2.8d", "--subject-distance", "1000", "--aperture", "8",
              "--coc", "0.015", "--json").json()
    air, water = out["dof"]["air"], out["dof"]["water"]
    assert abs(air["near_mm"] - paper["air_near"]) <= 3
    assert abs(air["far_mm"] - 1255) <= 3  # thin lens; the paper prints 1260
    assert abs(water["virtual_focus_mm"] - paper["water_virtual_focus"]) <= 1
    assert abs(water["virtual_near_mm"] - paper["water_virtual_near"]) <= 1
    assert abs(water["virtual_far_mm"] - paper["water_virtual_far"]) <= 1
    assert abs(water["near_mm"] - paper["water_near"]) <= 0.02 * paper["water_near"]
    assert abs(water["far_mm"] - paper["water_far"]) <= 0.03 * paper["water_far"]
    for block in ("air", "water"):
        b = out["dof"][block]
        assert b["total_mm"] == pytest.approx(b["far_mm"] - b["near_mm"])
    ratio = out["dof"]["ratio_water_to_air"]
    assert ratio == pytest.approx(water["total_mm"] / air["total_mm"])
    assert 1.15 < ratio < 1.4  # the paper says about 1.33 (docs/planning.md explains the difference)
    assert out["focus"]["reachable"] is True and out["focus"]["focus_distance_mm"] > 300
    assert any("infinity" in w for w in out["warnings"])


def test_plan_text_and_as_built_dome():
    text = run("plan", "--wd", "1500").out
    assert "minimum working distance" in text and "set the focus scale to" in text
    out = run("plan", "--wd", "1500", "--json").json()  # as-built dome: the pupil follows the focus
    assert out["port"]["name"] == "nimar-ni320"
    assert 24.6 < out["ep_in_housing_mm"][2] < 26.9
    assert out["fov"]["water"]["diagonal_deg"] > 0 and out["gsd"]["water_mm_per_px"] > 0
    assert out["field_curvature"]["corner_blur_px"] > 0


def test_too_close_needs_a_closeup():
    out = run("plan", *PAPER, "--wd", "300", "--json").json()
    assert out["focus"]["reachable"] is False and out["focus"]["focus_distance_mm"] is None
    assert out["focus"]["closeup_dioptre"] > 0


def test_flat_port_limits():
    out = run("flat", "--water-index", "1.333", "--json").json()
    assert abs(out["max_fov_deg"] - 97.2) <= 0.1
    assert out["apparent_focal_length_mm"] == pytest.approx(1.333 * out["principal_distance_mm"])
    for r in out["rows"][1:]:
        assert r["distortion_factor"] == pytest.approx(r["distortion_factor_traced"], rel=1e-9)
        ta = math.radians(r["theta_air_deg"])
        assert r["distortion_factor"] == pytest.approx(math.sqrt((1.333**2 - math.sin(ta)**2) / math.cos(ta)**2))
    assert out["lateral_colour"]["corner_px"] > 1
    assert "Eq. 1" in run("flat").out


@pytest.mark.parametrize("args,flag", [
    (("plan", "--wd", "-20"), "--wd"),
    (("plan", "--wd", "0"), "--wd"),
    (("plan", "--subject-distance", "40"), "--subject-distance"),
    (("plan", "--aperture", "32"), "--aperture"),
    (("plan", "--aperture", "1.4"), "--aperture"),
    (("plan", "--lens", "no-such-lens-xyz"), "--lens"),
    (("plan", "--lens", "nikkor-99mm"), "--lens"),  # lensfun would loosely match a 50 mm
    (("plan", "--coc", "-1", "--wd", "1000"), "--coc"),
    (("flat", "--port", "nimar-ni320"), "--port"),
])
def test_bad_input_exit_2(args, flag):
    assert flag in run_bad(*args)


# Issue 11: the Nikkor 10.5 mm DX fisheye on the D300 behind the NI320, named as lensfun names it.
# lensfun (liblensfun-data-v1) records it as type "equisolid", crop factor 1.523 (as the D300), so
# its diagonal field in air is 2 * 2 asin(r / 2f) for the D300's half diagonal r.
FISHEYE = ["--camera", "nikon-d300", "--lens", "Nikon AF DX Fisheye-Nikkor 10.5mm f/2.8G ED", "--port", "nimar-ni320"]


def test_fisheye_behind_dome_field_of_view_and_rim():
    out = run("plan", *FISHEYE, "--json").json()
    assert out["lens"]["projection"] == "equisolid" and out["lens"]["projection_estimated"] is False
    r = 0.5 * math.hypot(4288 * 0.0055, 2848 * 0.0055)  # 14.16 mm (the 14.17 rounds the sensor up)
    air = 4 * math.degrees(math.asin(r / (2 * 10.5)))
    assert out["fov"]["air"]["diagonal_deg"] == pytest.approx(air, abs=1e-6)
    assert abs(out["fov"]["air"]["diagonal_deg"] - 169.8) <= 1.0  # the acceptance
    assert out["fov"]["air"]["horizontal_deg"] == pytest.approx(4 * math.degrees(math.asin(4288 * 0.0055 / 42)))
    # In water: the edges pass the dome; the corners see its rim (the hemisphere ends at the outer
    # centre's plane, 23 mm ahead of the estimated pupil).
    assert out["fov"]["water"]["horizontal_deg"] > 100
    cut = out["field_cut"]
    assert cut["what"] == "the corners"
    # Closed form, ignoring the dome's 1.5 mm decentring: the inner sphere (R 75.7 mm, centre 1.2 mm
    # behind the rim plane z = 21.5 mm) ends at a circle of radius sqrt(75.7^2 - 1.2^2) on the rim plane.
    z_ep = out["ep_in_housing_mm"][2]
    rim_deg = math.degrees(math.atan2(math.sqrt(75.7**2 - 1.2**2), 21.5 - z_ep))
    assert abs(cut["clear_angle_deg"] - rim_deg) < 0.5
    assert cut["clear_radius_mm"] == pytest.approx(2 * 10.5 * math.sin(math.radians(cut["clear_angle_deg"]) / 2))
    # The frame's area outside the image circle of that radius (numerical integration over x).
    w, h, rc, n = 4288 * 0.0055, 2848 * 0.0055, cut["clear_radius_mm"], 4000
    outside = sum(max(0.0, h - 2 * min(math.sqrt(max(rc**2 - x**2, 0)), h / 2)) * w / n
                  for x in (-w / 2 + (i + 0.5) * w / n for i in range(n)))
    assert cut["blocked_fraction"] == pytest.approx(outside / (w * h), abs=0.005)
    text = run("plan", *FISHEYE).out
    assert "equisolid fisheye" in text and "cut off by the dome's rim" in text and "the corners" in text


def test_fisheye_flat_port_is_cut_at_the_critical_angle():
    out = run("flat", "--lens", "nikkor-10.5mm-f2.8g-fisheye", "--json").json()
    assert out["fov"]["water_traced"]["diagonal_deg"] < out["max_fov_deg"]
    # Parallel faces: n_w sin(theta_w) = sin(theta_a) for the corner's equisolid angle in air.
    ta = 2 * math.asin(0.5 * math.hypot(4288 * 0.0055, 2848 * 0.0055) / 21)
    tw = math.degrees(2 * math.asin(math.sin(ta) / out["water"]["index"]))
    assert out["fov"]["water_traced"]["diagonal_deg"] == pytest.approx(tw, abs=1e-6)
    assert any("critical angle" in w for w in out["warnings"])


def test_fixed_lens_camera_everywhere():
    p = run("plan", "--camera", "gopro-hero4-black", "--port", "flat-acrylic-10mm", "--aperture", "2.8", "--json").json()
    assert p["lens"]["name"] == "gopro-hero4-black-wide" and p["lens"]["projection"] == "equidistant"
    assert p["lens"]["projection_estimated"] is True
    # GoPro's published Wide field: 122.6 x 94.4 deg, 149.2 deg diagonal (the preset's source).
    assert abs(p["fov"]["air"]["horizontal_deg"] - 122.6) < 2 and abs(p["fov"]["air"]["diagonal_deg"] - 149.2) < 4
    assert run("flat", "--camera", "olympus-tg6", "--json").json()["lens"]["name"] == "olympus-tg6-4.5mm"
    s = run("simulate", "--camera", "olympus-tg6", "--port", "flat-acrylic-10mm", "--json").json()
    assert s["camera_body"] == "olympus-tg6" and s["model"] == "brown"
    assert "fixed lens" in run_bad("plan", "--camera", "olympus-tg6", "--lens", "nikkor-24mm-f2.8d")


def test_adapted_lens():
    # A Nikon F lens on a Sony E body: refused without an adapter, moved forward by 28.5 mm with one
    # (behind a dome centred on the pupil, which then focuses alike).
    sony = ["--camera", "Sony ILCE-7M3", "--pixel-pitch", "0.00598"]
    assert "--lens" in run_bad("plan", *sony, "--lens", "nikkor-24mm-f2.8d")
    native = run("plan", *PAPER, "--lens", "nikkor-24mm-f2.8d", "--coc", "0.011", "--json").json()
    adapted = run("plan", *PAPER, *sony, "--lens", "nikkor-24mm-f2.8d", "--allow-adapter", "--coc", "0.011",
                  "--json").json()
    assert adapted["ep_in_housing_mm"][2] == pytest.approx(native["ep_in_housing_mm"][2] + 46.5 - 18.0, abs=1e-6)
