"""A photogrammetric project from PhotoModeler (issue 26, "Rig files users have"): its text export and
DBAT's control-point file become porthole detections and a target field through `porthole convert
--to detections`, and `porthole calibrate` on them gives the camera DBAT's published self-calibration
of the same project gives (tests/data/README.md: dbat_camcal_*), within DBAT's sigma.

The user's path, end to end:
    porthole convert dbat_camcal_pmexport.txt dbat_camcal_fixed.txt det.json --to detections \\
        --field-out field.txt
    porthole calibrate --detections det.json --field field.txt --free-target \\
        --pixel-pitch-mm 0.0031910798 --centre-correction off
Bad input: one line, exit 2."""
import csv
import json
import math
import os
import re

import pytest

from conftest import DATA, read_table, run, run_bad

EXPORT = os.path.join(DATA, "dbat_camcal_pmexport.txt")
CONTROL = os.path.join(DATA, "dbat_camcal_fixed.txt")
W, H = 2272, 1704      # DBAT's report: image width and height, px
PIXEL_H_MM = 0.0031911  # DBAT's report: pixel height (its pixel size; the width is this x (1 + aspect))


@pytest.fixture(scope="module")
def converted(tmp_path_factory):
    d = tmp_path_factory.mktemp("pm")
    det, field = d / "det.json", d / "field.txt"
    res = run("convert", EXPORT, CONTROL, det, "--to", "detections", "--field-out", field, "--json")
    return d, det, field, res.json()


def export_marks():
    """The export's marks read here, independently of porthole: lines of six numbers after the
    third blank line that follows the photo list (DBAT's loadpm)."""
    with open(EXPORT) as f:
        lines = f.read().split("\n")
    blanks = [i for i, line in enumerate(lines) if not line.strip()]
    # Photo blocks hold a blank covariance line every 6 lines; the list ends with two blanks in a row
    # (end of photos, empty control block), then the object points, then the marks.
    end = next(b for b in blanks if b + 1 in blanks)
    after_points = next(b for b in blanks if b > end + 1)
    marks = []
    for line in lines[after_points + 1:]:
        if not line.strip():
            break
        n, pid, x, y, _, _ = line.split()
        marks.append((int(n), int(pid), float(x), float(y)))
    return marks


def test_export_becomes_detections_and_field(converted):
    d, det, field, j = converted
    # DBAT's report of this project: 21 photos, 4148 image observations (2074 points x 2),
    # 96 free points (288 OP parameters) + 4 fixed control points.
    assert j["n_images"] == 21 and j["n_image_points"] == 2074, j
    assert j["n_points"] == 100 and j["n_control_points"] == 4, j
    assert (j["width_px"], j["height_px"]) == (W, H)
    data = json.loads(det.read_text())
    assert data["target"] == "coded:12:1:aicon"
    assert len(data["images"]) == 21
    assert sum(len(im["ids"]) for im in data["images"]) == 2074
    # Every mark is the export's less half a pixel (PhotoModeler's origin is the image's corner).
    marks = export_marks()
    assert len(marks) == 2074
    got = {}
    for k, im in enumerate(data["images"]):
        for pid, (u, v) in zip(im["ids"], im["points_px"]):
            got[(k, pid)] = (u, v)
    for n, pid, x, y in marks:
        u, v = got[(n, pid)]
        assert abs(u - (x - 0.5)) < 1e-9 and abs(v - (y - 0.5)) < 1e-9, (n, pid)
    # The field: 100 points in mm, the 4 control points held (sigma 0: camcal-fixed.txt gives none).
    rows = [line.split("#")[0].split() for line in field.read_text().splitlines() if line.split("#")[0].strip()]
    assert len(rows) == 100
    controls = [line for line in field.read_text().splitlines() if line.endswith(" control")]
    assert [c.split()[0] for c in controls] == ["1001", "1002", "1003", "1004"]
    assert controls[1].startswith("1002 1000.000000 1000.000000 0.000000")
    assert "--pixel-pitch-mm 0.0031911033 --centre-correction off" in j["next"], j["next"]


def test_point_tables_give_the_same_detections(converted, tmp_path):
    """PhotoModeler's CSV point tables of the same marks (either order, with --image-size) give the
    export's detections to its 4 decimals, the 3-D table's control points marked."""
    d, det, field, j = converted
    t2 = os.path.join(DATA, "dbat_prague2016_cam_2dpts.txt")
    t3 = os.path.join(DATA, "dbat_prague2016_cam_3dpts.txt")
    line = run_bad("convert", t2, t3, tmp_path / "t.json", "--to", "detections", "--field-out", tmp_path / "tf.txt")
    assert "holds no image size" in line and "--image-size" in line, line
    line = run_bad("convert", t2, tmp_path / "t.json", "--to", "detections", "--field-out", tmp_path / "tf.txt",
                   "--image-size", "2272x1704")
    assert "come in pairs" in line, line
    tj = run("convert", t3, t2, tmp_path / "t.json", "--to", "detections", "--field-out", tmp_path / "tf.txt",
             "--image-size", "2272x1704", "--json").json()
    assert (tj["n_images"], tj["n_image_points"], tj["n_points"], tj["n_control_points"]) == (21, 2074, 100, 4)
    assert tj["camera"] is None and "PITCH_MM" in tj["next"]
    a = json.loads(det.read_text())["images"]
    b = json.loads((tmp_path / "t.json").read_text())["images"]
    assert [im["image"] for im in b] == [f"photo {k}" for k in range(1, 22)]
    worst = 0
    for ia, ib in zip(a, b):
        pa = dict(zip(ia["ids"], ia["points_px"]))
        assert sorted(pa) == sorted(ib["ids"])
        for pid, (u, v) in zip(ib["ids"], ib["points_px"]):
            worst = max(worst, abs(u - pa[pid][0]), abs(v - pa[pid][1]))
    assert 0 < worst <= 5e-5 + 1e-9


def pm_orientations(report):
    """Each photo's exterior orientation from PhotoModeler's status report: (omega, phi, kappa) in
    degrees, (Xc, Yc, Zc) in metres, by photo number (from 1)."""
    found = re.findall(r"Photo (\d+): \S+\s+Omega\s+Value: (\S+) deg.*?Phi\s+Value: (\S+) deg.*?Kappa\s+Value: (\S+) deg"
                       r".*?Xc\s+Value: (\S+)\s.*?Yc\s+Value: (\S+)\s.*?Zc\s+Value: (\S+)\s", report, re.S)
    return {int(f[0]): [float(x) for x in f[1:]] for f in found}


def rotation(omega, phi, kappa):
    """PhotoModeler's camera rotation (the one that reproduces its solution: any other order or sign
    misses by hundreds of pixels): R = Rz(-kappa) Ry(-phi) Rx(-omega), world -> camera with x right, y
    up and the camera looking along -z."""
    def rx(a):
        return [[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]]

    def ry(a):
        return [[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]]

    def rz(a):
        return [[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]]

    def mul(a, b):
        return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
    o, p, k = (math.radians(x) for x in (omega, phi, kappa))
    return mul(rz(-k), mul(ry(-p), rx(-o)))


def test_photomodelers_own_solution_reproduces_its_residuals_through_the_import(tmp_path):
    """PhotoModeler's solution of the prague2016 calibration (its camera on line 4 of the export, each
    photo's orientation from its report, the 3-D points of the export) projected in porthole's
    conventions -- the imported detections, the camera as convert converts it (x0, y0 from the centre,
    y up, K and P unchanged) -- gives PhotoModeler's own residuals (its 2-D table: projected less
    measured, x right and y up) to 0.018 px RMS, the mean within 0.01 px (the export's points have 5
    decimals in metres). The export's pixels taken as porthole's (no half-pixel shift) leave a 0.51 px
    mean in x and y."""
    export = os.path.join(DATA, "dbat_prague2016_cam_pmexport.txt")
    det, field = tmp_path / "w.json", tmp_path / "w.txt"
    j = run("convert", export, det, "--to", "detections", "--field-out", field, "--json").json()
    cam = j["camera"]
    eo = pm_orientations(open(os.path.join(DATA, "dbat_prague2016_cam_pmreport.txt")).read())
    assert len(eo) == 21
    points = {}
    for line in field.read_text().splitlines():
        words = line.split("#")[0].split()
        if words:
            points[int(words[0])] = [float(w) / 1000 for w in words[1:4]]  # mm -> the report's metres
    pm_res = {}
    with open(os.path.join(DATA, "dbat_prague2016_cam_2dpts.txt")) as f:
        for row in csv.reader(line for line in f if line[:1].isdigit()):
            pm_res[(int(row[1]), int(row[0]))] = (float(row[4]), float(row[5]))
    pitch, c, x0, y0 = cam["pixel_pitch_mm"], cam["c_mm"], cam["x0_mm"], cam["y0_mm"]
    K1, K2, K3, P1, P2 = (cam[k] for k in ("K1", "K2", "K3", "P1", "P2"))

    def residual(u, v, X, Y, Z):
        """projected less measured, in pixels, x right and y up (PhotoModeler's residuals are in the
        image mm frame's axes, not the pixels')"""
        # docs/conventions.md: image mm from porthole pixels, the correction, the collinearity.
        xb = (u - (W - 1) / 2) * pitch - x0
        yb = -(v - (H - 1) / 2) * pitch - y0
        r2 = xb * xb + yb * yb
        radial = K1 * r2 + K2 * r2 * r2 + K3 * r2 ** 3
        dx = xb * radial + P1 * (r2 + 2 * xb * xb) + 2 * P2 * xb * yb
        dy = yb * radial + P2 * (r2 + 2 * yb * yb) + 2 * P1 * xb * yb
        return (c * X / Z - (xb + dx)) / pitch, (-c * Y / Z - (yb + dy)) / pitch

    diffs, unshifted = [], []
    for k, im in enumerate(json.loads(det.read_text())["images"]):
        omega, phi, kappa, xc, yc, zc = eo[k + 1]
        R = rotation(omega, phi, kappa)
        for pid, (u, v) in zip(im["ids"], im["points_px"]):
            d = [points[pid][i] - (xc, yc, zc)[i] for i in range(3)]
            q = [sum(R[i][m] * d[m] for m in range(3)) for i in range(3)]
            # porthole's camera frame (x right, y down, z forward) from PhotoModeler's (y up, -z forward).
            X, Y, Z = q[0], -q[1], -q[2]
            ru, rv = pm_res[(k + 1, pid)]
            res = residual(u, v, X, Y, Z)
            diffs.append((res[0] - ru, res[1] - rv))
            res = residual(u + 0.5, v + 0.5, X, Y, Z)  # the export's pixels taken as porthole's
            unshifted.append((res[0] - ru, res[1] - rv))
    assert len(diffs) == 2074

    def stats(ds):
        rms = math.sqrt(sum(a * a + b * b for a, b in ds) / len(ds))
        return rms, sum(a for a, _ in ds) / len(ds), sum(b for _, b in ds) / len(ds)
    rms, mean_u, mean_v = stats(diffs)
    assert round(rms, 3) == 0.018, rms
    assert abs(mean_u) < 0.01 and abs(mean_v) < 0.01, (mean_u, mean_v)
    rms, mean_u, mean_v = stats(unshifted)
    assert round(mean_u, 2) == -0.51 and round(mean_v, 2) == 0.51, (mean_u, mean_v)


def reference():
    return {r["parameter"]: (float(r["value"]), float(r["sigma"])) for r in read_table("dbat_camcal_reference.csv")}


# porthole's figures against DBAT's (difference / DBAT's sigma), measured: c 0.20, u0 -0.56, v0 0.17,
# K1 0.72, K2 -0.41, K3 0.31, P1 0.18, P2 -0.46; B1 against DBAT's aspect parameter 1.07 (not quite the
# same parameter: DBAT scales x after the distortion correction, porthole adds B1 x-bar to it).
LIMITS = {"B1": 1.5}
# The same figures as docs/interop.md states them (difference / sigma, 2 decimals).
DOC_FIGURES = {"c_mm": 0.20, "u0_px": -0.56, "v0_px": 0.17, "K1": 0.72, "K2": -0.41, "K3": 0.31, "P1": 0.18,
               "P2": -0.46, "B1": 1.07}


def test_calibration_on_the_import_matches_dbats_reference_within_its_sigma(converted, tmp_path):
    d, det, field, j = converted
    pitch = j["camera"]["pixel_pitch_mm"]
    assert abs(pitch - PIXEL_H_MM) < 1e-7
    out = tmp_path / "cal.json"
    # DBAT's model of this run: c, xp, yp, aspect, K1-K3, P1, P2 free, no point rejected; here the
    # free network (the minimal datum), the control points' datum in the next test.
    run("calibrate", "--detections", det, "--field", field, "--free-target", "--datum", "minimal",
        "--pixel-pitch-mm", pitch, "--centre-correction", "off", "--free", "c,x0,y0,K1,K2,K3,P1,P2,B1",
        "--reject-k", "0", "--out", out, "--quiet")
    cal = json.loads(out.read_text())
    assert cal["n_points"] == 2074 and cal["n_images"] == 21
    figures = compare(cal["camera"], pitch)
    for name, (diff, sigma) in figures.items():
        assert abs(diff) <= LIMITS.get(name, 1.0) * sigma, (name, diff / sigma, figures)
        assert abs(diff / sigma - DOC_FIGURES[name]) < 0.0051, (name, diff / sigma)
    # Without the control points' datum the network's scale and shape are free: porthole's sigma0 is
    # below DBAT's 0.16148 px (DBAT holds the four corners at their nominal 1 m square).
    assert round(cal["sigma0_px"], 3) == 0.137
    # A sign error in K or P would be tens of sigma off, a principal point mirrored in y hundreds.
    ref = reference()
    p = cal["camera"]
    assert min(abs(-p[k] - ref[k][0]) / ref[k][1] for k in ("K1", "K2", "K3", "P1", "P2")) > 20
    v0_mirrored = p["y0_mm"] / pitch + (H - 1) / 2
    assert abs(v0_mirrored - (ref["yp"][0] / PIXEL_H_MM - 0.5)) / (ref["yp"][1] / PIXEL_H_MM) > 100

    # Without the half-pixel shift (the export's pixels taken as porthole's) the principal point moves
    # by half a pixel: 1.38 sigma (u) and 1.8 sigma (v) from DBAT's.
    data = json.loads(det.read_text())
    for im in data["images"]:
        im["points_px"] = [[u + 0.5, v + 0.5] for u, v in im["points_px"]]
    unshifted = tmp_path / "unshifted.json"
    unshifted.write_text(json.dumps(data))
    run("calibrate", "--detections", unshifted, "--field", field, "--free-target", "--datum", "minimal",
        "--pixel-pitch-mm", pitch,
        "--centre-correction", "off", "--free", "c,x0,y0,K1,K2,K3,P1,P2,B1", "--reject-k", "0",
        "--out", tmp_path / "cal_unshifted.json", "--quiet")
    bad = compare(json.loads((tmp_path / "cal_unshifted.json").read_text())["camera"], pitch)
    assert round(bad["u0_px"][0] / bad["u0_px"][1], 2) == 1.38, bad
    assert round(bad["v0_px"][0] / bad["v0_px"][1], 1) == 1.8, bad


def test_with_the_control_points_held_the_adjustment_is_dbats(converted, tmp_path):
    """Issue 26: "each point free, fixed, or a control point with its σ; the datum chosen by the user
    or automatic". With the four control points held (DBAT's camcal-fixed.txt: all coordinates fixed)
    porthole's adjustment has DBAT's unknowns — 9 camera, 126 orientation, 288 object-point
    coordinates, 423 — on its 4148 observations, and its sigma0 comes within 4 % of DBAT's 0.16148 px
    (the free network above has 0.137); the camera stays within DBAT's sigma, and the points lie in
    the control frame."""
    d, det, field, j = converted
    pitch = j["camera"]["pixel_pitch_mm"]
    out = tmp_path / "cal.json"
    # --datum auto takes the control points (4 observed, off one line) without being told.
    run("calibrate", "--detections", det, "--field", field, "--free-target", "--pixel-pitch-mm", pitch,
        "--centre-correction", "off", "--free", "c,x0,y0,K1,K2,K3,P1,P2,B1", "--reject-k", "0",
        "--out", out, "--quiet")
    cal = json.loads(out.read_text())
    assert cal["target_adjusted"]["datum"]["control"] == [1001, 1002, 1003, 1004]
    assert cal["n_unknowns"] == 423 and 2 * cal["n_points"] == 4148 and cal["redundancy"] == 4148 - 423
    print(f"control datum: sigma0 {cal['sigma0_px']:.5f} px against DBAT's 0.16148")
    # Within 5 % of DBAT's (measured 3.8 % below: the affinity terms differ, porthole's B1 against
    # DBAT's pixel aspect), and nearer DBAT's than the free network's 0.137.
    assert abs(cal["sigma0_px"] / 0.16148 - 1) < 0.05
    assert round(cal["sigma0_px"], 4) == 0.1553
    figures = compare(cal["camera"], pitch)
    print("control datum: camera minus DBAT's, in DBAT's sigma: " +
          ", ".join(f"{k} {v[0] / v[1]:+.2f}" for k, v in figures.items()))
    for name, (diff, sigma) in figures.items():
        assert abs(diff) <= LIMITS.get(name, 1.0) * sigma, (name, diff / sigma, figures)
    # Nearer DBAT's camera than the free network is (its worst 0.72 sigma, K1): 0.32 sigma at worst (c).
    assert max(abs(d / s) for k, (d, s) in figures.items() if k != "B1") < 0.35
    # The control points sit where the file puts them (held: sigma 0), the others carry a sigma.
    points = {p["id"]: p for p in cal["target_adjusted"]["points"]}
    assert points[1001]["xyz_mm"] == [0.0, 1000.0, 0.0] and points[1001]["sigma_mm"] == [0.0, 0.0, 0.0]
    assert all(min(p["sigma_mm"]) > 0 for i, p in points.items() if i < 1001)
    same = run("calibrate", "--detections", det, "--field", field, "--free-target", "--datum", "control",
               "--pixel-pitch-mm", pitch, "--centre-correction", "off", "--free", "c,x0,y0,K1,K2,K3,P1,P2,B1",
               "--reject-k", "0", "--json", "--quiet").json()
    assert same["sigma0_px"] == cal["sigma0_px"]
    # Control points with a sigma are priors: a tiny sigma holds them as fixing does, a huge one leaves
    # the network as free as the minimal datum (its shape from the images alone).
    minimal = run("calibrate", "--detections", det, "--field", field, "--free-target", "--datum", "minimal",
                  "--pixel-pitch-mm", pitch, "--centre-correction", "off", "--free", "c,x0,y0,K1,K2,K3,P1,P2,B1",
                  "--reject-k", "0", "--json", "--quiet").json()
    for sigma_mm, expect in ((1e-6, cal), (1e4, minimal)):
        soft = tmp_path / f"soft{sigma_mm:g}.txt"
        soft.write_text(field.read_text().replace("# sigma_mm 0 0 0 control", f"# sigma_mm {sigma_mm:g} {sigma_mm:g} "
                                                                            f"{sigma_mm:g} control"))
        assert soft.read_text().count(f"{sigma_mm:g} control") == 4
        r = run("calibrate", "--detections", det, "--field", soft, "--free-target", "--pixel-pitch-mm", pitch,
                "--centre-correction", "off", "--free", "c,x0,y0,K1,K2,K3,P1,P2,B1", "--reject-k", "0", "--json",
                "--quiet").json()
        assert r["redundancy"] == 4148 + 12 - 435  # 12 prior coordinates, 300 point coordinates
        print(f"control points of sigma {sigma_mm:g} mm: sigma0 {r['sigma0_px']:.5f} px, "
              f"c {r['camera']['c_mm']:.5f} mm (held: {cal['sigma0_px']:.5f}, {cal['camera']['c_mm']:.5f}; "
              f"minimal: {minimal['sigma0_px']:.5f}, {minimal['camera']['c_mm']:.5f})")
        assert abs(r["sigma0_px"] / expect["sigma0_px"] - 1) < 2e-3, (sigma_mm, r["sigma0_px"], expect["sigma0_px"])
        assert abs(r["camera"]["c_mm"] - expect["camera"]["c_mm"]) < 0.05 * reference()["c"][1]
    # Asked for without control points, or without a free target: one line, exit 2.
    plain = tmp_path / "plain.txt"
    plain.write_text("\n".join(line.split("#")[0] for line in field.read_text().splitlines()) + "\n")
    line = run_bad("calibrate", "--detections", det, "--field", plain, "--free-target", "--datum", "control",
                   "--pixel-pitch-mm", pitch, "--centre-correction", "off", "--quiet")
    assert "--datum" in line and "control points" in line, line
    line = run_bad("calibrate", "--detections", det, "--field", field, "--datum", "minimal",
                   "--pixel-pitch-mm", pitch, "--centre-correction", "off", "--quiet")
    assert line == "porthole: error: --datum: is the datum of a free target: give it with --free-target", line


def compare(p, pitch):
    """porthole's calibration against DBAT's, each figure as (difference, DBAT's sigma)."""
    ref = reference()
    out = {}
    # c: both in mm of the pixel height (DBAT's pixel size for both axes before its aspect term).
    out["c_mm"] = (p["c_mm"] - ref["c"][0], ref["c"][1])
    # Principal point in porthole pixels: DBAT's xp, yp are mm from the corner, y down, in units of
    # the pixel height (res_euler_brown_2.m: scale2 by one pixel size, then the flip and xp, yp),
    # less half a pixel; porthole's x0, y0 are from the centre, y up.
    u0_ref = ref["xp"][0] / PIXEL_H_MM - 0.5
    v0_ref = ref["yp"][0] / PIXEL_H_MM - 0.5
    u0 = p["x0_mm"] / pitch + (W - 1) / 2
    v0 = -p["y0_mm"] / pitch + (H - 1) / 2
    out["u0_px"] = (u0 - u0_ref, ref["xp"][1] / PIXEL_H_MM)
    out["v0_px"] = (v0 - v0_ref, ref["yp"][1] / PIXEL_H_MM)
    for k in ("K1", "K2", "K3", "P1", "P2"):
        out[k] = (p[k] - ref[k][0], ref[k][1])
    out["B1"] = (p["B1"] - ASPECT[0], ASPECT[1])
    return out


ASPECT = (0.000389598, 2.08e-05)  # DBAT's report: "as - off-unit aspect parameter"


def test_bad_exports_are_refused_in_one_line(tmp_path):
    text = open(EXPORT).read().split("\n")

    def variant(n, replacement):
        lines = list(text)
        lines[n - 1] = replacement
        f = tmp_path / f"v{n}_{abs(hash(replacement))}.txt"
        f.write_text("\n".join(lines))
        return f

    cases = [
        (variant(7, "   0    0.455    nan    1.468 -179.839   -1.181  -39.420"), "line 7", "not a finite number"),
        (variant(235, "  21        2 1429.1871 1456.4278  0.10000  0.10000"), "line 235",
         "image point 2 on photo 21, which the photo list does not hold"),
        (variant(135, "       2    0.28573    1.14303   -0.00098   0.000042   0.000041   0.000072"), "line 135",
         "point 2 appears twice"),
        (variant(235, "   0        2 1429.1871"), "line 235", "the line has 3 numbers"),
    ]
    for f, where, what in cases:
        line = run_bad("convert", f, tmp_path / "d.json", "--to", "detections", "--field-out", tmp_path / "f.txt")
        assert f"IN: '{f}' {where}" in line and what in line, line
        assert not (tmp_path / "d.json").exists() and not (tmp_path / "f.txt").exists()
    # Line 2 without the image size (PhotoModeler writes none; DBAT's manual has it appended): --image-size.
    no_size = variant(2, " 0.000500 20")
    line = run_bad("convert", no_size, tmp_path / "d.json", "--to", "detections", "--field-out", tmp_path / "f.txt")
    assert "line 2 holds no image size" in line and "--image-size" in line, line
    j = run("convert", no_size, tmp_path / "d.json", "--to", "detections", "--field-out", tmp_path / "f.txt",
            "--image-size", "2272x1704", "--json").json()
    assert j["n_image_points"] == 2074 and (j["width_px"], j["height_px"]) == (W, H)
    (tmp_path / "d.json").unlink()
    (tmp_path / "f.txt").unlink()
    truncated = tmp_path / "cut.txt"
    truncated.write_text("\n".join(text[:40]))
    line = run_bad("convert", truncated, tmp_path / "d.json", "--to", "detections", "--field-out", tmp_path / "f.txt")
    assert "ends inside photo 5" in line, line
    bad_control = tmp_path / "c.txt"
    bad_control.write_text("7777, X, 0, 0, 0\n")
    line = run_bad("convert", EXPORT, bad_control, tmp_path / "d.json", "--to", "detections", "--field-out",
                   tmp_path / "f.txt")
    assert "control point 7777" in line, line
    line = run_bad("convert", EXPORT, tmp_path / "d.json", "--to", "detections")
    assert "--field-out" in line, line
    line = run_bad("convert", EXPORT, tmp_path / "d.json", "--to", "detections", "--field-out", tmp_path / "f.txt",
                   "--pixel-pitch-mm", "0.0032")
    assert line.startswith("porthole: error: --pixel-pitch-mm: is not for --to detections"), line
    line = run_bad("convert", EXPORT, tmp_path / "d.json", "--field-out", tmp_path / "f.txt")
    assert "--field-out: goes with --to detections" in line, line
    assert not (tmp_path / "d.json").exists() and not (tmp_path / "f.txt").exists()
