"""The paper's protocol through the CLI (issue 26): air images shot with the housing on and water
images, both through the as-built NI320 dome, one lens at one focus. `porthole calibrate --images
WATER --air-images AIR --port nimar-ni320` models the air images through the same dome in air and
adjusts both sets together. Checked against independent ray-traced renders (`porthole render --set`,
pupil 0.4, 1.0, 5.4 mm from the dome's outer centre, sharp: --f-number inf): the pupil it finds is
the rendered one within 3 sigma. A housed air calibration (the central calibration of the air images)
given with --air-calibration is modelled as the lens behind the port in air and gives the same port
within sigma; the old reading (taken as the bare lens) needs --air-lens-bare, and is millimetres and
many sigma off."""
import json
import math
import os
import statistics

import pytest

from conftest import run, run_bad

TARGET = "chessboard:9x6:40"
PITCH = ["--pixel-pitch-mm", "0.029"]
RENDERED = (0.4, 1.0, 5.4)  # nimar-ni320: pupil (0, 0, 26.9) minus the outer centre (-0.4, -1.0, 21.5)
KEYS = ("ep_in_dome_x_mm", "ep_in_dome_y_mm", "ep_in_dome_z_mm")


@pytest.fixture(scope="module")
def renders(tmp_path_factory):
    d = tmp_path_factory.mktemp("airwater")
    run("render", "--set", 20, "--out", d / "set", "--spp", 4, *PITCH, "--f-number", "inf", "--quiet")
    truth = json.loads((d / "set" / "air" / "pose_000.json").read_text())
    water = json.loads((d / "set" / "water" / "pose_000.json").read_text())
    assert truth["camera"] == water["camera"] and truth["focus"] == water["focus"]  # one lens, one focus
    return d


def port_of(j):
    return [j["port"]["parameters"][k] for k in KEYS], [j["port"]["sigma"][k] for k in KEYS]


def test_air_and_water_images_together_find_the_rendered_pupil(renders):
    s = renders / "set"
    j = run("calibrate", "--images", s / "water", "--air-images", s / "air", "--target", TARGET, *PITCH,
            "--port", "nimar-ni320", "--json", "--quiet").json()
    p, sigma = port_of(j)
    lateral = math.hypot(p[0] - RENDERED[0], p[1] - RENDERED[1])
    print(f"air + water renders: pupil {p[0]:.3f} {p[1]:.3f} {p[2]:.3f} +- {sigma[0]:.3f} {sigma[1]:.3f} "
          f"{sigma[2]:.3f} mm; lateral error {lateral:.3f} mm, axial {abs(p[2] - RENDERED[2]):.3f} mm")
    for k in range(3):
        assert abs(p[k] - RENDERED[k]) < 3 * sigma[k], KEYS[k]
    assert lateral < 0.2 and abs(p[2] - RENDERED[2]) < 0.3
    air = j["port"]["air"]
    assert air["n_images"] == 20 and len(air["images"]) == 20 and j["n_images"] == 40 and len(j["images"]) == 20
    assert "air and water" in air["lens_from"]
    assert air["rms_px"] < 0.15 and air["water_rms_px"] < 0.15  # both sets fit at the renders' noise
    assert j["port"]["central_prediction"]["available"] is False
    # The same from saved detections (--air-detections).
    run("detect", "--images", s / "air", "--target", TARGET, "--out-dir", renders / "air-det", "--quiet")
    k = run("calibrate", "--images", s / "water", "--air-detections", renders / "air-det", "--target", TARGET,
            *PITCH, "--port", "nimar-ni320", "--json", "--quiet").json()
    assert port_of(k)[0] == pytest.approx(p, abs=1e-9)
    t = run("calibrate", "--images", s / "water", "--air-images", s / "air", "--target", TARGET, *PITCH,
            "--port", "nimar-ni320", "--quiet").out
    assert "air images: 20 through the port in air, adjusted with the water images (one lens)" in t


def test_three_render_sets_of_forty_put_the_pupil_within_the_issue_bounds(tmp_path):
    """The issue's bound, the pupil within 0.1 mm laterally and 0.3 mm axially, on renders: with 20 + 20
    images sigma is 0.085 mm a lateral axis (the test above), so one set misses 0.1 mm by chance as often
    as not. Three independent render sets (seeds 1-3) of 40 air + 40 water images: each pupil within
    3 sigma of the rendered one, their mean within 0.1 mm laterally and 0.3 mm axially."""
    found = []
    for seed in (1, 2, 3):
        d = tmp_path / f"seed{seed}"
        run("render", "--set", 40, "--seed", seed, "--out", d, "--spp", 4, *PITCH, "--f-number", "inf", "--quiet")
        j = run("calibrate", "--images", d / "water", "--air-images", d / "air", "--target", TARGET, *PITCH,
                "--port", "nimar-ni320", "--json", "--quiet").json()
        p, sigma = port_of(j)
        print(f"40 + 40 renders, seed {seed}: pupil {p[0]:.3f} {p[1]:.3f} {p[2]:.3f} +- {sigma[0]:.3f} "
              f"{sigma[1]:.3f} {sigma[2]:.3f} mm; lateral error {math.hypot(p[0] - RENDERED[0], p[1] - RENDERED[1]):.3f}"
              f" mm, axial {p[2] - RENDERED[2]:+.3f} mm")
        for k in range(3):
            assert abs(p[k] - RENDERED[k]) < 3 * sigma[k], (seed, KEYS[k])
        found.append(p)
    mean = [sum(p[k] for p in found) / 3 for k in range(3)]
    lateral = math.hypot(mean[0] - RENDERED[0], mean[1] - RENDERED[1])
    print(f"mean of the three: {mean[0]:.3f} {mean[1]:.3f} {mean[2]:.3f} mm; lateral error {lateral:.3f} mm, "
          f"axial {mean[2] - RENDERED[2]:+.3f} mm")
    assert lateral < 0.1 and abs(mean[2] - RENDERED[2]) < 0.3


@pytest.mark.skipif(not os.environ.get("PORTHOLE_BY_HAND"), reason="30 render sets, about 6 minutes: run by hand "
                    "with PORTHOLE_BY_HAND=1")
def test_sigma_matches_the_spread_of_thirty_render_sets(tmp_path):
    """The issue's check of the reported sigma on renders: 30 independent render sets (seeds 1-30) of 20 air +
    20 water images through the as-built NI320; per axis of the pupil the mean reported sigma over the spread
    of the estimates about their mean within [1/1.5, 1.5], and no mean error beyond 3 spread / sqrt(30)."""
    runs = 30
    est, sig = [[], [], []], [[], [], []]
    for seed in range(1, runs + 1):
        d = tmp_path / f"seed{seed}"
        run("render", "--set", 20, "--seed", seed, "--out", d, "--spp", 4, *PITCH, "--f-number", "inf", "--quiet")
        p, sigma = port_of(run("calibrate", "--images", d / "water", "--air-images", d / "air", "--target", TARGET,
                               *PITCH, "--port", "nimar-ni320", "--json", "--quiet").json())
        for k in range(3):
            est[k].append(p[k])
            sig[k].append(sigma[k])
    for k in range(3):
        spread = statistics.stdev(est[k])
        ratio = statistics.mean(sig[k]) / spread
        mean_error = statistics.mean(est[k]) - RENDERED[k]
        print(f"{KEYS[k]}: mean error {mean_error:+.4f} mm, spread {spread:.4f} mm, mean sigma "
              f"{statistics.mean(sig[k]):.4f} mm, sigma / spread {ratio:.2f}")
        assert 1 / 1.5 <= ratio <= 1.5, KEYS[k]
        assert abs(mean_error) <= 3 * spread / math.sqrt(runs), KEYS[k]


def test_refocused_air_images_of_one_focus_find_a_factor_of_one(renders):
    """--air-refocused gives the air images their own focal length (a factor on the water images'): on
    renders of one focus the factor is 1 within 3 sigma and the pupil is still the rendered one."""
    s = renders / "set"
    j = run("calibrate", "--images", s / "water", "--air-images", s / "air", "--target", TARGET, *PITCH,
            "--port", "nimar-ni320", "--air-refocused", "--json", "--quiet").json()
    air = j["port"]["air"]
    p, sigma = port_of(j)
    print(f"refocused air renders: focal scale {air['focal_scale']:.5f} +- {air['focal_scale_sigma']:.5f}; pupil "
          f"{p[0]:.3f} {p[1]:.3f} {p[2]:.3f} +- {sigma[0]:.3f} {sigma[1]:.3f} {sigma[2]:.3f} mm")
    assert air["refocused"] is True
    assert abs(air["focal_scale"] - 1) < 3 * air["focal_scale_sigma"] and air["focal_scale_sigma"] < 0.002
    for k in range(3):
        assert abs(p[k] - RENDERED[k]) < 3 * sigma[k], KEYS[k]
    # Without air images there is no second focus.
    bad = run_bad("calibrate", "--images", s / "water", "--target", TARGET, *PITCH, "--port", "nimar-ni320",
                  "--air-refocused")
    assert "--air-refocused" in bad and "--air-images" in bad


def test_a_housed_air_calibration_is_not_the_bare_lens(renders):
    s = renders / "set"
    housed = renders / "housed.json"
    run("calibrate", "--images", s / "air", "--target", TARGET, *PITCH, "--out", housed, "--quiet")
    args = ["calibrate", "--images", s / "water", "--target", TARGET, "--port", "nimar-ni320",
            "--air-calibration", housed, "--json", "--quiet"]
    # Taken as what it is by default: made through the port in air (the lens behind the port).
    h = run(*args).json()
    ph, sh = port_of(h)
    joint = run("calibrate", "--images", s / "water", "--air-images", s / "air", "--target", TARGET, *PITCH,
                "--port", "nimar-ni320", "--json", "--quiet").json()
    pj, sj = port_of(joint)
    print(f"housed air calibration through the port: pupil {ph[0]:.3f} {ph[1]:.3f} {ph[2]:.3f} "
          f"+- {sh[0]:.3f} {sh[1]:.3f} {sh[2]:.3f} mm; against air + water images "
          + " ".join(f"{(ph[k] - pj[k]) / sj[k]:+.2f}" for k in range(3)) + " sigma; central fit RMS "
          f"{h['port']['air']['housed_central_fit_rms_px']:.4f} px")
    for k in range(3):
        assert abs(ph[k] - pj[k]) < sj[k], KEYS[k]  # the same port within sigma
        assert abs(ph[k] - RENDERED[k]) < 3 * sh[k], KEYS[k]
    assert h["port"]["air"]["air_calibration_taken_as"] == "through_port"
    assert "made through the port" in h["port"]["air"]["lens_from"]
    assert "through the port in air" in h["port"]["air_calibration"]
    assert h["port"]["air"]["housed_central_fit_rms_px"] < 0.05
    t = run(*args[:-2], "--quiet").out
    assert "made through the port in air (the housing on)" in t, t
    # Held fixed it would be taken as the lens: refused.
    line = run_bad(*args, "--intrinsics", "fixed")
    assert "--intrinsics" in line and "--air-lens-bare" in line, line
    # Said to be the bare lens, it is taken as such: the old behaviour, and its bias.
    j = run(*args, "--air-lens-bare").json()
    p, sigma = port_of(j)
    off = math.dist(p, RENDERED)
    print(f"housed air calibration taken as the bare lens: pupil {p[0]:.3f} {p[1]:.3f} {p[2]:.3f} "
          f"+- {sigma[0]:.3f} {sigma[1]:.3f} {sigma[2]:.3f} mm, {off:.2f} mm from the rendered one")
    assert off > 1.0
    assert max(abs(p[k] - RENDERED[k]) / sigma[k] for k in range(3)) > 5
    assert "--air-lens-bare" in j["port"]["air_calibration"]
    assert "without the housing" in j["port"]["air"]["lens_from"]
    assert j["port"]["air"]["air_calibration_taken_as"] == "lens_bare"


def test_bad_air_input_is_refused_in_one_line(renders, tmp_path):
    s = renders / "set"
    base = ["calibrate", "--images", s / "water", "--target", TARGET, *PITCH, "--quiet"]
    assert "--air-images" in run_bad(*base, "--air-images", s / "air")  # no --port
    assert "--air-lens-bare" in run_bad(*base, "--port", "nimar-ni320", "--air-lens-bare")
    line = run_bad(*base, "--port", "nimar-ni320", "--air-images", s / "air", "--plan-only")
    assert "--plan-only" in line and "air images" in line, line
    # Air images of another camera (another frame size): one camera takes both sets.
    det = json.loads(run("detect", "--images", s / "air", "--target", TARGET, "--json", "--quiet").out)
    for im in det["images"]:
        im["width_px"] *= 2
        im["height_px"] *= 2
    other = tmp_path / "other.json"
    other.write_text(json.dumps(det))
    line = run_bad(*base, "--port", "nimar-ni320", "--air-detections", other)
    assert "--air-detections" in line and "one camera" in line, line
    empty = tmp_path / "empty"
    empty.mkdir()
    assert "--air-images" in run_bad(*base, "--port", "nimar-ni320", "--air-images", empty)


def test_simulate_says_what_its_air_calibration_is():
    """One meaning of --air-calibration for every command (issue 26): simulate predicts from a
    calibration made with the housing on, and says so in its text and JSON."""
    table6 = '{"c_mm":25.801,"x0_mm":-0.026,"y0_mm":-0.144,"K1":1.842e-4,"K2":-3.030e-7}'
    j = run("simulate", "--air-calibration", table6, "--json").json()
    assert j["air_calibration_taken_as"].startswith("made with the housing on")
    t = run("simulate", "--air-calibration", table6).out
    assert "in-air calibration taken as made with the housing on" in t
    assert "air_calibration_taken_as" not in run("simulate", "--json").json()  # no calibration, no claim


def test_a_free_target_behind_the_port(renders, tmp_path):
    """--free-target with --port (issue 26): the target's points adjusted with the lens and the port, the
    datum the minimal one (7 coordinates at the nominal values). The rendered board is the nominal one:
    every point within 0.15 mm of it, the pupil the rendered one within 3 sigma; the points and their
    sigma in the JSON's target_adjusted, the datum said in the text."""
    s = renders / "set"
    out = tmp_path / "free.json"
    r = run("calibrate", "--images", s / "water", "--air-images", s / "air", "--target", TARGET, *PITCH,
            "--port", "nimar-ni320", "--free-target", "--out", out)
    j = json.loads(out.read_text())
    p, sigma = port_of(j)
    points = j["target_adjusted"]["points"]
    moved = max(math.dist(q["xyz_mm"], q["nominal_mm"]) for q in points)
    print(f"free target behind the port: pupil {p[0]:.3f} {p[1]:.3f} {p[2]:.3f} +- {sigma[0]:.3f} {sigma[1]:.3f} "
          f"{sigma[2]:.3f} mm; {len(points)} points, the largest {moved:.3f} mm from the nominal")
    for k in range(3):
        assert abs(p[k] - RENDERED[k]) < 3 * sigma[k], KEYS[k]
    assert len(points) == 54 and moved < 0.15
    assert "free target: 54 points adjusted" in r.out
    datum = j["target_adjusted"]["datum"]
    held = set(datum["fixed"]) | {datum["one_coordinate"]}
    assert all(0 < q["sigma_mm"][2] < 0.1 for q in points if q["id"] not in held)
    assert all(q["sigma_mm"] == [0, 0, 0] for q in points if q["id"] in datum["fixed"])
    # Planning takes no images to adjust.
    bad = run_bad("calibrate", "--images", s / "water", "--target", TARGET, *PITCH, "--port", "nimar-ni320",
                  "--free-target", "--plan-only")
    assert "--free-target" in bad and "--plan-only" in bad
