"""`porthole measure` through the CLI (issue 27), on a stereo rig calibrated by `porthole calibrate`
from synthetic detections projected by OpenCV (test_rig_cli's rig: two 4288 x 2848 px cameras 300 mm
apart, 5 deg convergence, 0.3 px noise):
- against the real peer, OpenCV's `cv2.triangulatePoints` (on points undistorted by
  `cv2.undistortPointsIter` to 1e-14) with the same calibrated rig: the same 3-D points within 1e-6 mm
  on image points projected through that rig by `cv2.projectPoints`;
- the board's 750 mm edges (15 squares of 50 mm) measured in 15 frames of fresh 0.3 px points: every
  error within 4 sigma and the RMS of error/sigma within [0.5, 1.5];
- a CSV `frame,camera,id,u_px,v_px` gives the same points as detection files; JSON and text agree;
- bad input gets one line and exit 2: a point seen by one camera only (named by id), a camera not in
  the rig, a CSV with a bad line (file and line named), a length between ids not measured, a
  single camera's calibration as the rig, detection files that are not one per camera."""
import json
import math

import numpy as np
import pytest

from conftest import run, run_bad
from test_rig_cli import D, H, K, R1, T1, TARGET, W, board, frames, write_detections

cv2 = pytest.importorskip("cv2")


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    d = tmp_path_factory.mktemp("measure")
    data = frames()
    for k, name in enumerate(("left.json", "right.json")):
        write_detections(d / name, data, k)
    run("calibrate", "--detections", d / "left.json", "--detections", d / "right.json", "--model", "opencv",
        "--out", d / "rig.json", "--quiet")
    return d, json.loads((d / "rig.json").read_text())["rig"]


def opencv_of(cam):
    c = cam["camera"]
    k = np.array([[c["fx_px"], 0, c["cx_px"]], [0, c["fy_px"], c["cy_px"]], [0, 0, 1.0]])
    dist = np.array([c[key] or 0.0 for key in ("k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6")])
    r, _ = cv2.Rodrigues(np.array(cam["cam_from_rig"]["rotation_rad"]))
    return k, dist, r, np.array(cam["cam_from_rig"]["translation_mm"])


def write_points(path, frames_uv):
    """frames_uv: list of (frame name, ids, uv0, uv1) → one detection file per camera."""
    for k, name in enumerate(("m_left.json", "m_right.json")):
        images = [{"image": f"{f}.png", "width_px": W, "height_px": H, "ids": [int(i) for i in ids],
                   "points_px": (uv0 if k == 0 else uv1).tolist()} for f, ids, uv0, uv1 in frames_uv]
        (path / name).write_text(json.dumps({"target": TARGET, "images": images}))
    return path / "m_left.json", path / "m_right.json"


def test_points_match_cv2_triangulate_points(rig):
    d, j = rig
    cams = [opencv_of(c) for c in j["cameras"]]
    rng = np.random.default_rng(4)
    x = np.column_stack([rng.uniform(-400, 600, 40), rng.uniform(-300, 300, 40), rng.uniform(900, 3000, 40)])
    uv = []
    for k, dist, r, t in cams:
        p, _ = cv2.projectPoints(x, cv2.Rodrigues(r)[0], t, k, dist)
        uv.append(p.reshape(-1, 2))
    left, right = write_points(d, [("p", range(len(x)), uv[0], uv[1])])
    out = run("measure", "--rig", d / "rig.json", "--points", left, "--points", right, "--json").json()["measure"]
    ours = np.array([p["x_mm"] for p in sorted(out["points"], key=lambda p: p["id"])])
    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 100, 1e-14)
    n = [cv2.undistortPointsIter(uv[i].reshape(-1, 1, 2), cams[i][0], cams[i][1], None, None, crit).reshape(-1, 2)
         for i in range(2)]
    p0 = np.hstack([np.eye(3), np.zeros((3, 1))])
    p1 = np.hstack([cams[1][2], cams[1][3].reshape(3, 1)])
    h = cv2.triangulatePoints(p0, p1, n[0].T, n[1].T)
    theirs = (h[:3] / h[3]).T
    print(f"vs cv2.triangulatePoints: max {np.abs(ours - theirs).max():.3g} mm; vs truth max "
          f"{np.abs(ours - x).max():.3g} mm")
    assert np.abs(ours - x).max() < 1e-6
    assert np.abs(theirs - x).max() < 1e-6
    assert all(not p["mismatched"] for p in out["points"])


@pytest.fixture(scope="module")
def fresh(rig):
    """15 fresh frames of the board seen by the true rig at 0.3 px: m_left.json, m_right.json."""
    d, j = rig
    rng = np.random.default_rng(21)
    pts = board()
    frames_uv = []
    for f in range(15):
        rvec = rng.uniform(-1, 1, 3) * np.array([0.4, 0.4, 0.2])
        r, _ = cv2.Rodrigues(rvec)
        aim = np.array([150 + 150 * rng.uniform(-1, 1), 100 * rng.uniform(-1, 1), 1200 + 1500 * rng.uniform()])
        t = aim - r @ pts.mean(axis=0)
        uv = []
        for k in range(2):  # the true rig (test_rig_cli's), fresh 0.3 px noise
            rk, tk = (r, t) if k == 0 else (R1 @ r, R1 @ t + T1)
            p, _ = cv2.projectPoints(pts, cv2.Rodrigues(rk)[0], tk, K[k], D[k])
            uv.append(p.reshape(-1, 2) + rng.normal(0, 0.3, (len(pts), 2)))
        frames_uv.append((f"m{f:02d}", range(len(pts)), uv[0], uv[1]))
    return write_points(d, frames_uv)


def test_board_edges_within_sigma(rig, fresh):
    d, j = rig
    left, right = fresh
    # Ids 0-15 and 176-191: the board's top and bottom edges, 750 mm; 0-176: 550 mm.
    res = run("measure", "--rig", d / "rig.json", "--points", left, "--points", right, "--sigma-px", "0.3",
              "--length", "0,15", "--length", "176,191", "--length", "0,176", "--json")
    out = res.json()["measure"]
    z = []
    for ln in out["lengths"]:
        true = 550.0 if (ln["id_a"], ln["id_b"]) == (0, 176) else 750.0
        z.append((ln["length_mm"] - true) / ln["sigma_mm"])
        assert ln["sigma_percent"] == pytest.approx(100 * ln["sigma_mm"] / ln["length_mm"])
    z = np.array(z)
    print(f"{len(z)} lengths: max |error|/sigma {np.abs(z).max():.2f}, RMS {math.sqrt((z ** 2).mean()):.2f}")
    assert len(z) == 45
    assert np.abs(z).max() < 4
    assert 0.5 < math.sqrt((z ** 2).mean()) < 1.5
    # The text output says the same lengths.
    text = run("measure", "--rig", d / "rig.json", "--points", left, "--points", right, "--sigma-px", "0.3",
               "--length", "0,15").out
    first = next(ln for ln in out["lengths"] if (ln["id_a"], ln["id_b"]) == (0, 15))
    assert f"{first['length_mm']:.3f}" in text


def test_csv_gives_the_same_points(rig, fresh):
    d, j = rig
    left, right = fresh
    rows = ["frame,camera,id,u_px,v_px"]
    for k, (f, name) in enumerate(((left, j["cameras"][0]["name"]), (right, "1"))):
        for im in json.loads(f.read_text())["images"]:
            frame = im["image"].rsplit(".", 1)[0]
            rows += [f"{frame},{name},{i},{u!r},{v!r}" for i, (u, v) in zip(im["ids"], im["points_px"])]
    (d / "points.csv").write_text("\n".join(rows) + "\n")
    a = run("measure", "--rig", d / "rig.json", "--points", left, "--points", right, "--json").json()["measure"]
    b = run("measure", "--rig", d / "rig.json", "--points", d / "points.csv", "--json").json()["measure"]
    assert len(a["points"]) == len(b["points"]) > 0
    for p, q in zip(a["points"], b["points"]):
        assert (p["frame"], p["id"]) == (q["frame"], q["id"])
        assert p["x_mm"] == q["x_mm"]


def test_scale_bar(rig, fresh):
    """The board's top edge (ids 0-15, 750 mm) as a scale bar in the 15 fresh frames: the rig holds;
    told 752 mm, the check says it does not (a warning line, the verdict in the JSON)."""
    d, j = rig
    left, right = fresh
    res = run("measure", "--rig", d / "rig.json", "--points", left, "--points", right, "--sigma-px", "0.3",
              "--scale-bar", "0,15,750")
    assert "the rig calibration holds" in res.out and "range_mm" in res.out, res.out
    out = run("measure", "--rig", d / "rig.json", "--points", left, "--points", right, "--sigma-px", "0.3",
              "--scale-bar", "0,15,750", "--json").json()["measure"]["scale_bar"]
    assert out["n_frames"] == 15 and out["consistent"]
    assert sum(b["n"] for b in out["by_range"]) == 15
    errors = [f["error_mm"] for f in out["frames"]]
    assert out["mean_error_mm"] == pytest.approx(np.mean(errors), abs=1e-9)
    print(f"scale bar 750 mm: mean error {out['mean_error_mm']:+.3f} mm, z {out['z']:.2f}")
    wrong = run("measure", "--rig", d / "rig.json", "--points", left, "--points", right, "--sigma-px", "0.3",
                "--scale-bar", "0,15,752")
    assert "does not hold" in wrong.out and "porthole: warning:" in wrong.err
    assert run_bad("measure", "--rig", d / "rig.json", "--points", left, "--points", right,
                   "--scale-bar", "0,15").startswith("porthole: error: --scale-bar: '0,15': give A,B,LENGTH_MM")


def test_bad_input_is_refused(rig, tmp_path):
    d, j = rig
    names = [c["name"] for c in j["cameras"]]
    csv = tmp_path / "p.csv"
    csv.write_text(f"frame,camera,id,u_px,v_px\nf1,{names[0]},7,100.5,200\nf1,{names[1]},7,90,201\n"
                   f"f1,{names[0]},8,300,200\n")
    line = run_bad("measure", "--rig", d / "rig.json", "--points", csv)
    assert f"id 8: seen by {names[0]} only (" in line and "p.csv:4)" in line and "--skip-unpaired" in line, line
    csv.write_text("frame,camera,id,u_px,v_px\nf1,middle,7,100,200\n")
    line = run_bad("measure", "--rig", d / "rig.json", "--points", csv)
    assert "p.csv:2: no camera middle in the rig" in line and names[0] in line, line
    csv.write_text(f"f1,{names[0][:-1]},7,100,200\n")  # a name typed slightly wrong: refused, the nearest named
    line = run_bad("measure", "--rig", d / "rig.json", "--points", csv)
    assert f"did you mean {names[0]}?" in line, line
    csv.write_text(f"frame,camera,id,u_px,v_px\nf1,{names[0]},7,100,200\nf1,{names[1]},7,abc,200\n")
    line = run_bad("measure", "--rig", d / "rig.json", "--points", csv)
    assert "p.csv:3" in line, line
    uv = []
    for k, dist, r, t in (opencv_of(c) for c in j["cameras"]):  # a point 2 m in front of the rig
        p, _ = cv2.projectPoints(np.array([[150.0, 0, 2000]]), cv2.Rodrigues(r)[0], t, k, dist)
        uv.append(p.reshape(2))
    csv.write_text(f"f1,{names[0]},7,{uv[0][0]},{uv[0][1]}\nf1,{names[1]},7,{uv[1][0]},{uv[1][1]}\n")
    assert run("measure", "--rig", d / "rig.json", "--points", csv, "--json").json()["measure"]["points"][0]["ok"]
    line = run_bad("measure", "--rig", d / "rig.json", "--points", csv, "--length", "7,9")
    assert "--length: 7,9: id 9 is not measured" in line, line
    csv.write_text(f"f1,{names[0]},7,100,200\nf1,{names[1]},7,4000,200\n")  # rays meeting behind the cameras
    line = run_bad("measure", "--rig", d / "rig.json", "--points", csv)
    assert "no point could be triangulated" in line, line
    single = tmp_path / "one.json"
    run("calibrate", "--detections", d / "left.json", "--model", "opencv", "--out", single, "--quiet")
    line = run_bad("measure", "--rig", single, "--points", csv)
    assert "not a rig" in line, line
    line = run_bad("measure", "--rig", d / "rig.json", "--points", csv, "--sigma-px", "0")
    assert "--sigma-px" in line, line
    line = run_bad("measure", "--rig", d / "rig.json", "--points", d / "left.json")
    assert "one per camera" in line, line
    # The two cameras' files of different targets: the same id would be another point.
    other = tmp_path / "other.json"
    other.write_text((d / "right.json").read_text().replace(TARGET, "chessboard:9x6:25"))
    line = run_bad("measure", "--rig", d / "rig.json", "--points", d / "left.json", "--points", other)
    assert "chessboard:9x6:25" in line or "target" in line, line


def test_plan_a_rig(rig):
    """`plan --rig` on the calibrated stereo rig (no ports: no central comparison, said), and `plan
    --baseline` of two cameras behind the NI320 dome: sigma of a 300 mm length grows with range, the
    common field widens, the central model's error is reported; bad combinations refused."""
    d, j = rig
    out = run("plan", "--rig", d / "rig.json", "--ranges", "1000,2000,3000", "--json").json()["rig_plan"]
    rows = out["ranges"]
    assert [r["range_mm"] for r in rows] == [1000, 2000, 3000]
    assert all(r["n_lengths"] > 0 for r in rows)
    assert rows[0]["sigma_median_mm"] < rows[1]["sigma_median_mm"] < rows[2]["sigma_median_mm"]
    assert rows[0]["common_width_mm"] < rows[2]["common_width_mm"]
    assert "the rig calibration" in out["sigma_holds"]
    assert not out["central_model"]["compared"] and any("no camera is behind a port" in n for n in out["notes"])
    text = run("plan", "--baseline", "300", "--convergence", "5", "--port", "nimar-ni320",
               "--ranges", "1000,3000,8000").out
    assert "rig plan: two" in text and "central_|e|" in text, text
    dj = run("plan", "--baseline", "300", "--convergence", "5", "--port", "nimar-ni320", "--ranges", "1000,3000,8000",
             "--json").json()["rig_plan"]
    assert dj["central_model"]["compared"] and dj["sigma_holds"] == "image noise only"
    r = dj["ranges"]
    assert r[0]["sigma_median_mm"] < r[1]["sigma_median_mm"] < r[2]["sigma_median_mm"]
    assert all(x["central_abs_median_mm"] is not None for x in r)
    print("described NI320 rig: sigma", [round(x["sigma_median_mm"], 3) for x in r], "central |e|",
          [round(x["central_abs_median_mm"], 3) for x in r])
    assert run_bad("plan", "--rig", d / "rig.json", "--wd", "1000").startswith("porthole: error: --wd:")
    assert run_bad("plan", "--sigma-px", "0.5").startswith("porthole: error: --sigma-px: plans a rig")
    assert "--ranges" in run_bad("plan", "--rig", d / "rig.json", "--ranges", "1000,-5")
    assert "--baseline" in run_bad("plan", "--baseline", "-3")


def one_camera(d, tmp_path):
    """The left camera calibrated alone (opencv model): its file, K and distortion for cv2."""
    single = tmp_path / "one.json"
    run("calibrate", "--detections", d / "left.json", "--model", "opencv", "--out", single, "--quiet")
    cal = json.loads(single.read_text())["camera"]
    k = np.array([[cal["fx_px"], 0, cal["cx_px"]], [0, cal["fy_px"], cal["cy_px"]], [0, 0, 1.0]])
    dist = np.array([cal[key] or 0.0 for key in ("k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6")])
    return single, k, dist


def test_one_camera_and_a_known_plane(rig, tmp_path):
    """One camera's calibration and a known range (or plane): points projected at 2 m by
    cv2.projectPoints with that calibration come back within 1e-6 mm; the plane given as
    0,0,2,4000 (not unit) is the same plane; bad planes refused."""
    d, j = rig
    single, k, dist = one_camera(d, tmp_path)
    x = np.array([[-400.0, -300, 2000], [0, 0, 2000], [500, 250, 2000]])
    uv, _ = cv2.projectPoints(x, np.zeros(3), np.zeros(3), k, dist)
    csv = tmp_path / "one.csv"
    csv.write_text("".join(f"f,0,{i},{u!r},{v!r}\n" for i, (u, v) in enumerate(uv.reshape(-1, 2))))
    for plane in (["--range-mm", "2000"], ["--plane", "0,0,2,4000"]):
        out = run("measure", "--rig", single, "--points", csv, *plane, "--length", "0,2", "--sigma-px", "0.3",
                  "--json").json()["measure"]
        got = np.array([p["x_mm"] for p in out["points"]])
        assert np.abs(got - x).max() < 1e-6, got
        assert out["lengths"][0]["length_mm"] == pytest.approx(np.linalg.norm(x[2] - x[0]), abs=1e-6)
    with_sigma = run("measure", "--rig", single, "--points", csv, "--range-mm", "2000", "--plane-sigma-mm", "20",
                     "--length", "0,2", "--sigma-px", "0.3", "--json").json()["measure"]["lengths"][0]
    # A range error of 20 mm at 2 m scales a lateral length by 1 %.
    assert with_sigma["sigma_calibration_mm"] >= 0.01 * with_sigma["length_mm"] * 0.99
    assert "--plane: give 4 numbers" in run_bad("measure", "--rig", single, "--points", csv, "--plane", "1,2")
    assert "--camera: goes with --plane" in run_bad("measure", "--rig", d / "rig.json", "--points", csv, "--camera", "0")
    assert "not seen by" in run_bad("measure", "--rig", d / "rig.json", "--points", csv, "--range-mm", "2000",
                                    "--camera", "1")


def test_laser_pair(rig, tmp_path):
    """A laser scaler's two dots (ids 10 and 11, beams 100 mm apart, parallel to the axis) give the
    range: points projected at 2 m by cv2.projectPoints come back within 1e-6 mm, the range in
    `laser_ranges`; a frame without a dot is refused naming it."""
    d, j = rig
    single, k, dist = one_camera(d, tmp_path)
    x = np.array([[-50.0, 30, 2000], [50, 30, 2000], [-400, -300, 2000], [500, 250, 2000]])
    uv, _ = cv2.projectPoints(x, np.zeros(3), np.zeros(3), k, dist)
    csv = tmp_path / "laser.csv"
    csv.write_text("".join(f"f,0,{i},{u!r},{v!r}\n" for i, (u, v) in zip((10, 11, 1, 2), uv.reshape(-1, 2))))
    out = run("measure", "--rig", single, "--points", csv, "--laser-pair", "10,11,100", "--length", "1,2",
              "--sigma-px", "0.3", "--json").json()["measure"]
    assert out["laser_ranges"][0]["range_mm"] == pytest.approx(2000, abs=1e-6)
    got = {p["id"]: p["x_mm"] for p in out["points"]}
    assert np.abs(np.array([got[1], got[2]]) - x[2:]).max() < 1e-6
    print(f"laser range {out['laser_ranges'][0]['range_mm']:.6f} mm, sigma {out['laser_ranges'][0]['sigma_mm']:.2f} mm")
    csv.write_text("".join(f"f,0,{i},{u!r},{v!r}\n" for i, (u, v) in zip((10, 1, 2), uv.reshape(-1, 2)[[0, 2, 3]])))
    assert "--laser-pair: frame f: laser dot id 11 not measured" in run_bad(
        "measure", "--rig", single, "--points", csv, "--laser-pair", "10,11,100")
    assert "--laser-pair: give 3 numbers" in run_bad("measure", "--rig", single, "--points", csv, "--laser-pair", "10,11")


def test_report_shows_the_rig_plan_and_the_scale_bar(rig, fresh, tmp_path):
    """`report --rig RIG --scale-bar-check MEASURE.json` adds the sections "Your rig" and "Scale bar":
    their figures (PNG and SVG) and in report.json the numbers `plan --rig` and `measure --scale-bar`
    give for the same inputs."""
    d, _ = rig
    left, right = fresh
    run("measure", "--rig", d / "rig.json", "--points", left, "--points", right, "--sigma-px", "0.3",
        "--scale-bar", "0,15,750", "--out", tmp_path / "bar.json")
    s = run("report", "--rig", d / "rig.json", "--rig-sigma-px", "0.3", "--scale-bar-check", tmp_path / "bar.json",
            "--out", tmp_path / "r", "--json").json()
    assert s["figures"][-2:] == ["rig-plan", "scale-bar"]
    for fig in ("rig-plan", "scale-bar"):
        assert (tmp_path / "r" / "figures" / f"{fig}.png").stat().st_size > 5000
        assert (tmp_path / "r" / "figures" / f"{fig}.svg").exists()
    page = (tmp_path / "r" / "index.html").read_text()
    assert 'id="rig"' in page and 'id="scale-bar"' in page and "Your rig: lengths before the dive" in page
    rep = json.loads((tmp_path / "r" / "report.json").read_text())
    plan = run("plan", "--rig", d / "rig.json", "--sigma-px", "0.3", "--json").json()["rig_plan"]
    assert [r["sigma_median_mm"] for r in rep["rig_plan"]["ranges"]] == \
        pytest.approx([r["sigma_median_mm"] for r in plan["ranges"]], rel=1e-12)
    bar = json.loads((tmp_path / "bar.json").read_text())["measure"]["scale_bar"]
    assert rep["scale_bar"]["mean_error_mm"] == pytest.approx(bar["mean_error_mm"], rel=1e-12)
    assert [f["error_mm"] for f in rep["scale_bar"]["frames"]] == pytest.approx([f["error_mm"] for f in bar["frames"]])
    assert rep["scale_bar"]["source"] == str(tmp_path / "bar.json")
    # A check without sigma (z null in the file): the page says so, never "z = nan".
    nosig = json.loads((tmp_path / "bar.json").read_text())
    nosig["measure"]["scale_bar"]["z"] = None
    (tmp_path / "nosig.json").write_text(json.dumps(nosig))
    run("report", "--scale-bar-check", tmp_path / "nosig.json", "--out", tmp_path / "r4")
    page4 = (tmp_path / "r4" / "index.html").read_text()
    assert "z = unknown: no sigma" in page4 and "z = nan" not in page4
    # A measure output without a scale-bar check, and a file that is no JSON, are refused in one line.
    run("measure", "--rig", d / "rig.json", "--points", left, "--points", right, "--length", "0,15",
        "--out", tmp_path / "lengths.json")
    assert "--scale-bar-check" in run_bad("report", "--scale-bar-check", tmp_path / "lengths.json",
                                          "--out", tmp_path / "r2")
    (tmp_path / "bad.json").write_text("{ not json")
    assert "--scale-bar-check" in run_bad("report", "--scale-bar-check", tmp_path / "bad.json", "--out", tmp_path / "r3")
    assert not (tmp_path / "r2").exists() and not (tmp_path / "r3").exists()
