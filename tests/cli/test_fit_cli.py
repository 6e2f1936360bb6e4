"""Proves `synth-scan`, `fit` and `assemble` recover known synthetic geometry and the paper's Table 4
through the CLI, and that bad input gives one line, exit 2 and no output file."""
import json
import math
import os

import numpy as np
import pytest

from conftest import DATA, read_table, run, run_bad

# The paper's Table 3 outer sphere (the synth-scan defaults).
OUTER_C = np.array([-0.4, -1.0, 21.5])
OUTER_R = 83.4


def synth(path, *args):
    run("synth-scan", path, *args)
    return str(path)


def fit_json(*args):
    return run("fit", *args, "--json").json()


@pytest.mark.parametrize("robust", [False, True])
def test_170k_point_hemisphere_must_show(tmp_path, robust):
    # Issue 5: R 83.4 mm, ~170,000 points, sigma 0.05 mm (20 % gross outliers in robust mode):
    # centre within 0.01 mm, radius within 0.005 mm.
    extra = ["--outliers", "0.2"] if robust else []
    scan = synth(tmp_path / "dome.ply", "--points", 170000, "--noise", 0.05, "--seed", 7, *extra)
    j = fit_json("sphere", scan, *(["--robust"] if robust else []))
    assert j["usable"] and j["n_points"] == 170000
    assert np.linalg.norm(np.array(j["center_mm"]) - OUTER_C) < 0.01
    assert abs(j["radius_mm"] - OUTER_R) < 0.005
    if robust:
        assert abs(j["n_inliers"] - 0.8 * 170000) < 0.01 * 170000
    assert j["rms_mm"] == pytest.approx(0.05 * math.sqrt(3), rel=0.8)  # 3D noise, radial part ~σ


def test_30_degree_cap_and_reported_sigma(tmp_path):
    scan = synth(tmp_path / "cap.xyz", "--points", 20000, "--half-angle", 30, "--noise", 0.05,
                 "--center", "5,-3,10", "--radius", 60, "--seed", 2)
    j = fit_json("sphere", scan)
    err = np.abs(np.array(j["center_mm"]) - [5, -3, 10])
    assert j["usable"]
    assert np.all(err < 5 * np.array(j["sigma_center_mm"]) + 1e-4), (err, j["sigma_center_mm"])
    assert abs(j["radius_mm"] - 60) < 5 * j["sigma_radius_mm"] + 1e-4


def test_residuals_file_matches_the_fit(tmp_path):
    scan = synth(tmp_path / "d.ply", "--points", 3000, "--noise", 0.05, "--ascii")
    out = tmp_path / "r.xyz"
    j = run("fit", "sphere", scan, "--residuals", out, "--json").json()
    assert out.read_text().splitlines()[0] == "x y z residual"
    res = np.loadtxt(out, skiprows=1)  # 6 decimals: 1 µm
    assert res.shape == (3000, 4)
    r = np.linalg.norm(res[:, :3] - j["center_mm"], axis=1) - j["radius_mm"]
    assert np.allclose(res[:, 3], r, atol=3e-6)
    assert math.sqrt(np.mean(res[:, 3]**2)) == pytest.approx(j["rms_mm"], rel=1e-3)
    ply = tmp_path / "r.ply"
    run("fit", "sphere", scan, "--residuals", ply)
    head = ply.read_bytes()[:400].decode("latin-1")
    assert "element vertex 3000" in head and "property double residual" in head


def rotation(ax, ay, az):
    cx, sx, cy, sy, cz, sz = (f(a) for a in (ax, ay, az) for f in (math.cos, math.sin))
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rz @ ry @ rx


def ring(center, radius, n, rot=np.eye(3)):
    a = np.linspace(0, 2 * math.pi, n, endpoint=False)
    local = np.stack([radius * np.cos(a), radius * np.sin(a), np.zeros(n)], axis=1)
    return center + local @ rot.T


def save_csv(path, pts):
    np.savetxt(path, pts, delimiter=",", header="x,y,z", comments="")
    return str(path)


def test_plane_and_circle_fit(tmp_path):
    rng = np.random.default_rng(4)
    rot = rotation(0.3, -0.2, 1.0)
    c = np.array([10.0, -20.0, 30.0])
    pts = ring(c, 25.0, 36, rot) + rng.normal(0, 0.01, (36, 3))
    j = fit_json("circle", save_csv(tmp_path / "ring.csv", pts))
    assert np.linalg.norm(np.array(j["center_mm"]) - c) < 0.02
    assert abs(j["radius_mm"] - 25) < 0.01
    assert abs(abs(np.dot(j["normal"], rot[:, 2])) - 1) < 1e-5
    p = fit_json("plane", save_csv(tmp_path / "ring.csv", pts))
    assert abs(abs(np.dot(p["normal"], rot[:, 2])) - 1) < 1e-5
    assert abs(np.dot(p["normal"], c) - p["offset_mm"]) < 0.01


# --- assemble -------------------------------------------------------------------------------

def paper_points():
    return {r["point"]: (np.array([float(r[k]) for k in ("x_mm", "y_mm", "z_mm")]),
                         float(r["radius_mm"]) if r["radius_mm"] else None)
            for r in read_table("menna2016_table4.csv")}


def paper_args():
    t = paper_points()
    (hc, _), (oc, orad), (ic, irad) = (t[k] for k in ("housing_flange_center", "dome_outer_center",
                                                       "dome_inner_center"))
    fmt = lambda *v: ",".join(f"{x:g}" for x in v)  # noqa: E731
    return ["--housing-flange", fmt(*hc, 0, 0, 1), "--outer", fmt(*oc, orad),
            "--inner", fmt(*ic, irad)]


def test_assemble_paper_tables_give_5p4_ahead_1mm_off(tmp_path):
    port = tmp_path / "asbuilt.toml"
    j = run("assemble", *paper_args(), "--lens", "nikkor-24mm-f2.8d", "--focus", 300,
            "-o", port, "--json").json()
    assert j["pupil_ahead_of_outer_mm"] == pytest.approx(5.4, abs=1e-9)   # Section 3.4
    assert 0.9 < j["pupil_off_axis_outer_mm"] < 1.2                       # "about 1 mm"
    assert j["entrance_pupil_mm"] == pytest.approx([0, 0, 26.9])          # Tables 2 and 4
    assert j["thickness_mm"] == pytest.approx(7.7)
    # The as-built port drives virtual-image exactly like the built-in preset of the same dome.
    mine = run("virtual-image", "--port", port, "--wd", "500,inf", "--json").json()
    preset = run("virtual-image", "--port", "nimar-ni320", "--wd", "500,inf", "--json").json()
    assert mine["ep_in_housing_mm"] == pytest.approx([0, 0, 26.9])
    for a, b in zip(mine["rows"], preset["rows"]):
        assert a["d_s2ep_mm"] == pytest.approx(b["d_s2ep_mm"], abs=1e-3)
    text = run("assemble", *paper_args(), "--pupil-offset", 26.9).out
    assert "5.40 mm ahead of the outer centre" in text and "1.08 mm off axis" in text


def test_assemble_from_scans_and_target_fits_in_own_frames(tmp_path):
    """The whole Section 3 chain through the CLI: flange targets measured in a survey frame, the dome
    scanned (outer, inner, rear face) in a scan frame, every part fitted, then assembled."""
    t = paper_points()
    rng = np.random.default_rng(11)
    rs, ts = rotation(0.4, -0.7, 2.0), np.array([300.0, -150.0, 80.0])   # survey_from_housing
    rd, td = rotation(2.5, 0.3, -1.1), np.array([-40.0, 25.0, 600.0])    # scan_from_housing
    survey = lambda p: p @ rs.T + ts  # noqa: E731
    scan = lambda p: p @ rd.T + td  # noqa: E731
    hc = t["housing_flange_center"][0]
    cam = survey(ring(np.zeros(3), 20.0, 24)) + rng.normal(0, 0.005, (24, 3))
    hous = survey(ring(hc, 55.0, 36)) + rng.normal(0, 0.005, (36, 3))
    run("fit", "circle", save_csv(tmp_path / "cam.csv", cam), "--json")
    files = {}
    for name, pts in (("cam", cam), ("hous", hous)):
        files[name] = tmp_path / f"{name}.json"
        files[name].write_text(run("fit", "circle", save_csv(tmp_path / f"{name}.csv", pts),
                                   "--json").out)
    # Rear face: an annulus on the housing flange plane, scanned; a plane fit keeps its centroid.
    a = rng.uniform(0, 2 * math.pi, 4000)
    r = rng.uniform(84, 95, 4000)
    rear = scan(hc + np.stack([r * np.cos(a), r * np.sin(a), np.zeros_like(a)], axis=1))
    files["rear"] = tmp_path / "rear.json"
    files["rear"].write_text(run("fit", "plane", save_csv(tmp_path / "rear.csv", rear),
                                 "--json").out)
    for name, key in (("outer", "dome_outer_center"), ("inner", "dome_inner_center")):
        c, radius = t[key]
        # Scan only the glass ahead of the flange plane: 79 deg half angle for the outer surface.
        ply = synth(tmp_path / f"{name}.ply", "--points", 20000, "--noise", 0.05,
                    "--radius", radius, "--center", ",".join(map(str, scan(c))),
                    "--axis", ",".join(map(str, rd[:, 2])), "--half-angle", 79, "--seed", 5)
        files[name] = tmp_path / f"{name}.json"
        files[name].write_text(run("fit", "sphere", ply, "--json").out)
    # Which way the plane fit's normal points is arbitrary: flip it toward the apex (scan +Z').
    rear_n = json.loads(files["rear"].read_text())["normal"]
    flip = ["--dome-rear-flip"] if np.dot(rear_n, rd[:, 2]) < 0 else []
    j = run("assemble", "--camera-flange", files["cam"], "--housing-flange", files["hous"],
            "--outer", files["outer"], "--inner", files["inner"], "--dome-rear", files["rear"],
            *flip, "--dome-centered", "--x-hint", ",".join(map(str, rs[:, 0])),
            "--dome-x-hint", ",".join(map(str, rd[:, 0])),
            "--lens", "nikkor-24mm-f2.8d", "--focus", 300, "--json").json()
    for key, field in (("camera_flange_center", "camera_flange_center_mm"),
                       ("housing_flange_center", "housing_flange_center_mm"),
                       ("dome_outer_center", "dome_outer_center_mm"),
                       ("dome_inner_center", "dome_inner_center_mm"),
                       ("lens_entrance_pupil", "entrance_pupil_mm")):
        assert np.linalg.norm(np.array(j[field]) - t[key][0]) < 0.05, (field, j[field])
    assert j["pupil_ahead_of_outer_mm"] == pytest.approx(5.4, abs=0.05)
    assert j["pupil_off_axis_outer_mm"] == pytest.approx(math.hypot(0.4, 1.0), abs=0.05)


# --- bad input -------------------------------------------------------------------------------

def test_degenerate_point_sets_are_rejected(tmp_path):
    three = save_csv(tmp_path / "three.csv", np.eye(3))
    assert "points" in run_bad("fit", "sphere", three)
    flat = np.array([[x, y, 5.0] for x in range(5) for y in range(5)])
    assert "coplanar" in run_bad("fit", "sphere", save_csv(tmp_path / "flat.csv", flat))
    line = np.array([[x, 2 * x, 3 * x] for x in range(10)], dtype=float)
    run_bad("fit", "sphere", save_csv(tmp_path / "line.csv", line))
    run_bad("fit", "circle", save_csv(tmp_path / "line.csv", line))
    same = np.ones((10, 3))
    assert "equal" in run_bad("fit", "sphere", save_csv(tmp_path / "same.csv", same))


def test_malformed_files_leave_no_output(tmp_path):
    good = synth(tmp_path / "d.ply", "--points", 1000)
    data = open(good, "rb").read()
    truncated = tmp_path / "trunc.ply"
    truncated.write_bytes(data[: len(data) - 7])
    out = tmp_path / "res.ply"
    assert "byte" in run_bad("fit", "sphere", truncated, "--residuals", out)
    assert not out.exists()
    bad_csv = tmp_path / "bad.csv"
    bad_csv.write_text("1,2,3\n4,5,6\n7,eight,9\n1,1,1\n2,2,7\n")
    assert "line 3" in run_bad("fit", "plane", bad_csv, "--residuals", out)
    nan_csv = tmp_path / "nan.csv"
    nan_csv.write_text("1,2,3\n4,5,6\nnan,1,9\n1,1,1\n2,2,7\n")
    run_bad("fit", "sphere", nan_csv, "--residuals", out)
    assert not out.exists()
    assert not [p for p in os.listdir(tmp_path) if p.startswith("res")]  # no temp files either
    # An existing output is left untouched by a failing run.
    out.write_text("keep")
    run_bad("fit", "sphere", truncated, "--residuals", out)
    assert out.read_text() == "keep"
    # synth-scan with an impossible option writes nothing.
    run_bad("synth-scan", tmp_path / "x.ply", "--outliers", 1.5)
    assert not (tmp_path / "x.ply").exists()


def test_assemble_bad_input(tmp_path):
    out = tmp_path / "port.toml"
    truncated = tmp_path / "outer.json"
    truncated.write_text('{"shape": "sphere", "center_mm": [0, 0,')
    args = paper_args()
    i = args.index("--outer")
    bad = args[:i + 1] + [str(truncated)] + args[i + 2:]
    assert "not valid JSON at byte" in run_bad("assemble", *bad, "--pupil-offset", 26.9, "-o", out)
    circle = tmp_path / "c.json"
    circle.write_text(json.dumps({"shape": "circle", "center_mm": [0, 0, 1], "normal": [0, 0, 1],
                                  "radius_mm": 3}))
    bad = args[:i + 1] + [str(circle)] + args[i + 2:]
    assert "where a sphere fit is expected" in run_bad("assemble", *bad, "--pupil-offset", 26.9)
    assert "--outer" in run_bad("assemble", *args[:i + 1], "1,2,3", *args[i + 2:],
                                "--pupil-offset", 26.9, "-o", out)
    assert "--pupil-offset" in run_bad("assemble", *args, "--pupil-offset", 150, "-o", out)
    assert "--lens" in run_bad("assemble", *args, "-o", out)
    assert "--focus" in run_bad("assemble", *args, "--lens", "nikkor-24mm-f2.8d", "--focus", 100)
    assert "--output" in run_bad("assemble", *args, "--pupil-offset", 26.9,
                                 "-o", tmp_path / "no" / "dir.toml")
    assert not out.exists()
