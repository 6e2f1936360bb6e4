"""Proves `porthole target-sheet` end to end: the SVG's circles and ring arcs lie where the target
field file says (parsed back), and two real renderers — librsvg (rsvg-convert) for the SVG, poppler
(pdftoppm) for the PDF — draw sheets on which `porthole detect --target coded:...` finds every
target with its printed ID, at the field's position to a small fraction of a pixel; both polarities,
both profiles. Bad options exit 2 with one line and write nothing. `porthole render` draws coded
sheets in both polarities that the detector reads at the JSON's dot_centres (issue 16)."""
import json
import math
import os
import shutil
import subprocess
import xml.etree.ElementTree as ET

import pytest

from conftest import run, run_bad

SVG_NS = "{http://www.w3.org/2000/svg}"
DPI = 150  # 5.9 px/mm: a 2.5 mm dot is 29.5 px across


def read_field(path):
    out = {}
    with open(path) as f:
        for line in f:
            line = line.split("#")[0].split()
            if line:
                out[int(line[0])] = tuple(map(float, line[1:]))
    return out


def test_svg_geometry_matches_the_field(tmp_path):
    sheet = tmp_path / "s.svg"
    res = run("target-sheet", sheet, "--bits", 14, "--radius-mm", 3, "--json").json()
    field = read_field(tmp_path / "s.field.txt")
    assert res["targets"] == len(field) and res["first_id"] == 1
    root = ET.parse(sheet).getroot()
    assert root.get("width") == "210mm" and root.get("height") == "297mm"
    groups = [g for g in root.iter(SVG_NS + "g") if g.get("id", "").startswith("t")]
    assert len(groups) == len(field)
    for g in groups:
        tid = int(g.get("id")[1:])
        x, y, z = field[tid]
        assert z == 0
        c = g.find(SVG_NS + "circle")
        assert abs(float(c.get("cx")) - x) < 1e-4 and abs(float(c.get("cy")) - y) < 1e-4
        assert float(c.get("r")) == 3
        assert g.find(SVG_NS + "text").text == str(tid)
        for p in g.findall(SVG_NS + "path"):
            w = p.get("d").replace("M", "").replace("A", "").replace("L", "").replace("Z", "").split()
            pts = [(float(w[0]), float(w[1])), (float(w[7]), float(w[8])), (float(w[9]), float(w[10])),
                   (float(w[16]), float(w[17]))]
            radii = [math.hypot(px - x, py - y) for px, py in pts]
            assert max(abs(r - e) for r, e in zip(radii, [9, 9, 6, 6])) < 2e-4  # AICON ring 2r–3r
    assert "100 mm" in sheet.read_text()


def render_and_detect(tmp_path, kind, args, target):
    sheet = tmp_path / f"sheet.{kind}"
    run("target-sheet", sheet, *args)
    images = tmp_path / "images"
    images.mkdir()
    if kind == "svg":
        subprocess.run(["rsvg-convert", "-d", str(DPI), "-p", str(DPI), "-b", "white", str(sheet),
                        "-o", str(images / "sheet.png")], check=True)
    else:
        subprocess.run(["pdftoppm", "-r", str(DPI), "-gray", "-png", "-singlefile", str(sheet),
                        str(images / "sheet")], check=True)
    det = run("detect", "--images", images, "--target", target, "--json", "--quiet").json()
    field = read_field(tmp_path / "sheet.field.txt")
    return det, field


@pytest.mark.parametrize("kind,args,target", [
    ("svg", ["--radius-mm", 2.5], "coded:14:2.5"),
    ("pdf", ["--radius-mm", 2.5, "--white-on-black"], "coded:14:2.5:aicon"),
    ("svg", ["--radius-mm", 2.5, "--profile", "metashape", "--bits", 12, "--white-on-black"], "coded:12:2.5:metashape"),
    ("pdf", ["--radius-mm", 2.5, "--profile", "metashape"], "coded:14:2.5:metashape"),
])
def test_real_renderers_draw_sheets_the_detector_reads_whole(tmp_path, kind, args, target):
    if shutil.which("rsvg-convert" if kind == "svg" else "pdftoppm") is None:
        pytest.fail("rsvg-convert / pdftoppm missing: run scripts/install-deps (librsvg2-bin, poppler-utils)")
    det, field = render_and_detect(tmp_path, kind, args, target)
    assert len(det["images"]) == 1, det["skipped"]
    img = det["images"][0]
    assert sorted(img["ids"]) == sorted(field), (len(img["ids"]), len(field))
    # Pixel u covers [u, u+1) of the renderer's raster: its centre is at (u + 0.5) / (DPI / 25.4) mm.
    scale = DPI / 25.4
    worst = max(math.hypot(u - (field[i][0] * scale - 0.5), v - (field[i][1] * scale - 0.5))
                for i, (u, v) in zip(img["ids"], img["points_px"]))
    print(f"{kind} {target}: {len(field)} targets decoded, worst centre {worst:.4f} px from the field")
    assert worst < 0.05


def test_bad_options_write_nothing(tmp_path):
    for args, field in [(["x.png"], "out"), (["x.svg", "--profile", "gom"], "--profile"),
                        (["x.svg", "--bits", 16], "--bits"), (["x.svg", "--radius-mm", 40], "--radius-mm"),
                        (["x.svg", "--count", 5000], "--count"), (["x.svg", "--first-id", 600], "--first-id"),
                        (["x.svg", "--paper", "B9"], "--paper"), (["x.pdf", "--paper", "100x100"], "--paper")]:
        args = [tmp_path / args[0], *args[1:]]
        line = run_bad("target-sheet", *args)
        assert field in line, line
    assert list(tmp_path.iterdir()) == []
    for spec in ["coded:16:2.5", "coded:14:-1", "coded:14:2.5:gom", "coded:14", "coded:14:90"]:
        line = run_bad("detect", "--images", tmp_path, "--target", spec)
        assert "--target" in line, line


# The D300's sensor cut to 720 x 480 px (tests; the Python tests render with it too).
SMALL_CAMERA = open(os.path.join(os.path.dirname(__file__), "small-dx.toml")).read()


@pytest.mark.parametrize("polarity", [[], ["--white-on-black"]])
def test_render_draws_coded_sheets_with_the_dot_centre_truth(tmp_path, polarity):
    # `porthole render --target coded:...` draws the default sheet; `porthole detect` reads every
    # target of the truth with its ID (and may read a target the truth leaves out because the frame
    # cuts the band round its ring: render asks 0.5 dot radii of it, the detector samples 0.35), at
    # the JSON's dot_centres (the ellipse of each traced rim) within
    # 0.03 px at 16 spp, and the dot centres differ from the images of the centres (points) by the
    # eccentricity, tenths of a pixel at this tilt.
    camera = tmp_path / "small.toml"
    camera.write_text(SMALL_CAMERA)
    images = tmp_path / "images"
    images.mkdir()
    run("render", "--out", images / "coded.png", "--camera", camera, "--target", "coded:12:7:metashape",
        "--medium", "air", "--distance", 420, "--tilt", "35,20", "--f-number", "inf", "--bands", 546.07,
        "--bit-depth", 16, "--quiet", *polarity)
    truth = json.loads((images / "coded.json").read_text())
    dots = {d["id"]: d["px"][0] for d in truth["dot_centres"]}
    points = {p["id"]: p["px"][0] for p in truth["points"]}
    assert sorted(dots) == sorted(points) and min(dots) == 1
    det = run("detect", "--images", images, "--target", "coded:12:7:metashape", "--json", "--quiet").json()
    img = det["images"][0]
    assert set(dots) <= set(img["ids"])
    assert set(img["ids"]) - set(dots) <= set(truth["left_out"]["partial"])
    assert len(dots) >= 10
    worst = max(math.dist(p, dots[i]) for i, p in zip(img["ids"], img["points_px"]) if i in dots)
    bias = max(math.dist(dots[i], points[i]) for i in dots)
    print(f"render coded {polarity}: {len(dots)} targets, worst centre {worst:.4f} px from dot_centres; "
          f"largest eccentricity {bias:.3f} px")
    assert worst < 0.03
    assert bias > 0.1


def test_centre_correction_needs_a_coded_target(tmp_path):
    det = tmp_path / "d.json"
    det.write_text(json.dumps({"target": "chessboard:9x6:40", "images": [], "skipped": []}))
    line = run_bad("calibrate", "--detections", det, "--target", "chessboard:9x6:40", "--centre-correction", "on")
    assert line.startswith("porthole: error: --centre-correction:"), line


# A 3-D target field as the paper's pool field in miniature: a 400 x 300 mm board with a 9 x 7 grid
# of targets (Z = 0, ids 1-63) and 16 raised 40-120 mm toward the camera (Z < 0, ids 64-79).
def raised_field():
    field = {}
    for r in range(7):
        for c in range(9):
            field[len(field) + 1] = (50.0 * c, 50.0 * r, 0.0)
    for k in range(16):
        field[len(field) + 1] = (25 + 100 * (k % 4), 25 + 75 * (k // 4), -(40 + 80 * ((k * 7) % 16) / 15))
    return field


def write_field(path, field):
    path.write_text("# a raised board (test)\n# id x_mm y_mm z_mm\n" +
                    "".join(f"{i} {x:.4f} {y:.4f} {z:.4f}\n" for i, (x, y, z) in field.items()))


F_PX, W, H = 2400.0, 1200, 900


def synthetic_field_detections(path, field, n_images=10, noise_px=0.1, seed=5, extra_ids=()):
    """`porthole detect --json` detections of `field` seen by a pinhole camera (f = 2400 px,
    1200 x 900, principal point at the image centre) from n_images views 1000-1200 mm away, tilted
    up to 35 deg, with Gaussian noise: images of the dots' centres (no eccentricity)."""
    import numpy as np
    rng = np.random.default_rng(seed)
    ids = np.array(sorted(field))
    pts = np.array([field[i] for i in ids])
    centre = np.array([200.0, 150.0, -30.0])
    images = []
    for k in range(n_images):
        tilt = math.radians(10 + 25 * rng.random())
        az = 2 * math.pi * k / n_images
        eye = centre + rng.uniform(1000, 1200) * np.array([math.sin(tilt) * math.cos(az), math.sin(tilt) * math.sin(az), -math.cos(tilt)])
        z = (centre - eye) / np.linalg.norm(centre - eye)
        x = np.cross([0.0, 1.0, 0.0], z) if abs(z[1]) < 0.9 else np.array([1.0, 0, 0])
        x /= np.linalg.norm(x)
        roll = rng.uniform(-0.5, 0.5)
        y = np.cross(z, x)
        x, y = math.cos(roll) * x + math.sin(roll) * y, -math.sin(roll) * x + math.cos(roll) * y
        cam = (pts - eye) @ np.array([x, y, z]).T
        uv = F_PX * cam[:, :2] / cam[:, 2:] + [(W - 1) / 2, (H - 1) / 2] + rng.normal(0, noise_px, (len(ids), 2))
        inside = (uv[:, 0] >= 0) & (uv[:, 0] <= W - 1) & (uv[:, 1] >= 0) & (uv[:, 1] <= H - 1)
        assert inside.sum() > 60
        got_ids = [int(i) for i in ids[inside]] + list(extra_ids)
        got_uv = uv[inside].tolist() + [[5.0, 5.0]] * len(extra_ids)
        images.append({"image": f"view{k}.png", "target": "coded:14:2.5:aicon", "width_px": W,
                       "height_px": H, "ids": got_ids, "points_px": got_uv})
    path.write_text(json.dumps({"target": "coded:14:2.5:aicon", "images": images, "skipped": []}))


def test_calibrate_with_a_3d_field_file(tmp_path):
    # `calibrate --field` with a raised field: the DLT start, the rendering camera within 3 sigma,
    # the field (file name and points) in the JSON; an ID outside the field (200, on the default
    # sheet) is ignored with a message, not placed at the origin.
    field = raised_field()
    write_field(tmp_path / "raised.txt", field)
    synthetic_field_detections(tmp_path / "d.json", field, extra_ids=(200,))
    res = run("calibrate", "--detections", tmp_path / "d.json", "--field", tmp_path / "raised.txt",
              "--centre-correction", "off", "--free", "c,x0,y0,K1,K2", "--json")
    assert "DLT focal length" in res.err and "ignored 10 detection(s) of IDs that are not in the field" in res.err, res.err
    j = res.json()
    assert j["field"]["file"] == str(tmp_path / "raised.txt")
    assert j["field"]["n_points"] == 79
    points = {p[0]: p[1:] for p in j["field"]["points"]}
    assert sorted(points) == sorted(field)
    for i, xyz in field.items():
        assert points[i] == pytest.approx(list(xyz), abs=1e-4), i
    cam, sig = j["camera"], j["sigma"]
    print(f"3-D field: c {cam['c_mm']:.3f} px (sigma {sig['c_mm']:.3f}), x0 {cam['x0_mm']:.3f}, y0 {cam['y0_mm']:.3f}; "
          f"sigma0 {j['sigma0_px']:.3f} px")
    assert abs(cam["c_mm"] - F_PX) < 3 * sig["c_mm"]
    assert abs(cam["x0_mm"]) < 3 * sig["x0_mm"] and abs(cam["y0_mm"]) < 3 * sig["y0_mm"]
    assert j["sigma0_px"] == pytest.approx(0.1, rel=0.1)
    assert "target_adjusted" not in j

    # Self-calibration: the raised heights given 3 mm wrong come back to the truth.
    wrong = {i: (x, y, z - 3.0 if z else z) for i, (x, y, z) in field.items()}
    write_field(tmp_path / "wrong.txt", wrong)
    j = run("calibrate", "--detections", tmp_path / "d.json", "--field", tmp_path / "wrong.txt", "--free-target",
            "--centre-correction", "off", "--free", "c,x0,y0,K1,K2", "--json", "--quiet").json()
    adjusted = j["target_adjusted"]
    assert adjusted["datum"]["axis"] == "z" and all(field[i][2] == 0 for i in adjusted["datum"]["fixed"])
    raised = [p for p in adjusted["points"] if field[p["id"]][2] != 0]
    assert len(raised) == 16
    for p in raised:
        assert abs(p["xyz_mm"][2] - field[p["id"]][2]) < 3 * p["sigma_mm"][2], p
        assert p["nominal_mm"][2] == pytest.approx(wrong[p["id"]][2])

    # The refractive calibration takes the field too (plumbing: in-air views behind a flat port).
    j = run("calibrate", "--detections", tmp_path / "d.json", "--field", tmp_path / "raised.txt",
            "--port", "flat-acrylic-10mm", "--centre-correction", "off", "--free", "c,x0,y0",
            "--json", "--quiet").json()
    assert j["field"]["n_points"] == 79 and "port" in j


def test_field_errors_are_one_line(tmp_path):
    field = raised_field()
    write_field(tmp_path / "raised.txt", field)
    synthetic_field_detections(tmp_path / "d.json", field, n_images=3)
    line = run_bad("calibrate", "--images", tmp_path, "--target", "chessboard:9x6:25", "--field", tmp_path / "raised.txt")
    assert line.startswith("porthole: error: --field:") and "coded" in line, line
    line = run_bad("calibrate", "--detections", tmp_path / "d.json", "--field", tmp_path / "missing.txt")
    assert line.startswith("porthole: error: --field:"), line
    (tmp_path / "bad.txt").write_text("1 0 0 0\n1 5 5 5\n")
    line = run_bad("calibrate", "--detections", tmp_path / "d.json", "--field", tmp_path / "bad.txt", "--out", tmp_path / "o.json")
    assert "--field" in line and "line 2" in line, line
    # Five targets off one plane: no image fixes a DLT (6 points) — one line, nothing written.
    five = {i: field[i] for i in (1, 9, 55, 63, 79)}
    write_field(tmp_path / "five.txt", five)
    synthetic_field_detections(tmp_path / "d5.json", field, n_images=4)
    line = run_bad("calibrate", "--detections", tmp_path / "d5.json", "--field", tmp_path / "five.txt",
                   "--out", tmp_path / "o.json", "--quiet")
    assert line.startswith("porthole: error: --images:") and "6 points" in line, line
    assert not (tmp_path / "o.json").exists()


def read_field_out(path):
    """{id: ((x, y, z), comment)} of a field file `calibrate --field-out` wrote."""
    out = {}
    for line in path.read_text().splitlines():
        data, _, comment = line.partition("#")
        if data.strip():
            i, x, y, z = data.split()
            out[int(i)] = ((float(x), float(y), float(z)), comment.strip())
    return out


def test_field_out_writes_the_self_calibrated_field(tmp_path):
    # Heights given 3 mm wrong, and one target (ID 300) that no image sees: --free-target
    # --field-out writes the field back with the measured heights (within 3 sigma of the truth, the
    # sigma in each line's comment), the unseen target as given; the file is a field file again: a
    # calibration with it fixed gives the free-target run's camera.
    field = raised_field()
    synthetic_field_detections(tmp_path / "d.json", field)
    wrong = {i: (x, y, z - 3.0 if z else z) for i, (x, y, z) in field.items()}
    wrong[300] = (500.0, 500.0, -10.0)
    write_field(tmp_path / "wrong.txt", wrong)
    out = tmp_path / "measured.txt"
    common = ["--detections", tmp_path / "d.json", "--centre-correction", "off", "--free", "c,x0,y0,K1,K2"]
    res = run("calibrate", *common, "--field", tmp_path / "wrong.txt", "--free-target", "--field-out", out, "--json",
              "--quiet")
    j = res.json()
    assert j["field_out"] == str(out)
    text = out.read_text()
    assert text.startswith("# porthole target field, self-calibrated") and str(tmp_path / "wrong.txt") in text
    measured = read_field_out(out)
    assert sorted(measured) == sorted(wrong)
    assert measured[300] == ((500.0, 500.0, -10.0), "not observed: as given")
    adjusted = {p["id"]: p for p in j["target_adjusted"]["points"]}
    worst = 0.0
    for i, (xyz, comment) in measured.items():
        if i == 300:
            continue
        assert xyz == pytest.approx(adjusted[i]["xyz_mm"], abs=1e-6)  # the JSON's adjusted points, to 1e-6 mm
        sigma = [float(s) for s in comment.split()[1:4]]
        assert comment.startswith("sigma") and sigma == pytest.approx(adjusted[i]["sigma_mm"], abs=1e-6)
        if field[i][2] != 0:
            worst = max(worst, abs(xyz[2] - field[i][2]) / sigma[2])
    print(f"field-out: 16 raised heights within {worst:.2f} sigma of the truth (given 3 mm wrong)")
    assert worst < 3
    fixed = [i for i, (_, c) in measured.items() if "(datum)" in c]
    assert sorted(fixed) == sorted(j["target_adjusted"]["datum"]["fixed"])
    # The written field, fixed: the same camera as the free-target run, within its sigma.
    k = run("calibrate", *common, "--field", out, "--json", "--quiet").json()
    for key in ("c_mm", "x0_mm", "y0_mm"):
        assert abs(k["camera"][key] - j["camera"][key]) < j["sigma"][key], key
    # Bad input: one line, nothing written.
    assert "--free-target" in run_bad("calibrate", *common, "--field", tmp_path / "wrong.txt", "--field-out",
                                      tmp_path / "x.txt", "--out", tmp_path / "x.json")
    assert not (tmp_path / "x.txt").exists() and not (tmp_path / "x.json").exists()
    # Behind a port the field is adjusted too (issue 26; plumbing: these in-air views behind a flat
    # port): the same file, its datum the same minimal one.
    behind = tmp_path / "behind.txt"
    b = run("calibrate", *common, "--field", tmp_path / "wrong.txt", "--port", "flat-acrylic-10mm",
            "--free-target", "--field-out", behind, "--json", "--quiet").json()
    assert "port" in b and b["field_out"] == str(behind)
    assert sorted(read_field_out(behind)) == sorted(wrong)
    assert b["target_adjusted"]["datum"]["fixed"] == j["target_adjusted"]["datum"]["fixed"]


def test_targets_facing_other_ways(tmp_path):
    # A field line with seven numbers gives the dot's normal (a cage's wall facing +X): calibrate
    # records it (the JSON's field.normals) and --field-out writes it back; render, which draws
    # targets parallel to the board only, refuses the field in one line.
    field = raised_field()
    synthetic_field_detections(tmp_path / "d.json", field)
    lines = [f"{i} {x} {y} {z}" + (" 1 0 0" if i == 70 else "") for i, (x, y, z) in field.items()]
    (tmp_path / "n.txt").write_text("\n".join(lines) + "\n")
    out = tmp_path / "out.txt"
    j = run("calibrate", "--detections", tmp_path / "d.json", "--field", tmp_path / "n.txt", "--centre-correction", "off",
            "--free", "c,x0,y0,K1,K2", "--free-target", "--field-out", out, "--json", "--quiet").json()
    assert j["field"]["normals"] == {"70": [1, 0, 0]}
    back = {int(ln.split()[0]): ln.split("#")[0].split() for ln in out.read_text().splitlines() if not ln.startswith("#")}
    assert [float(v) for v in back[70][4:]] == [1, 0, 0] and len(back[1]) == 4
    line = run_bad("render", "--out", tmp_path / "r.png", "--target", "coded:14:2.5", "--field", tmp_path / "n.txt")
    assert "--field" in line and "target 70 faces (1, 0, 0)" in line
    assert not (tmp_path / "r.png").exists()


def test_field_out_keeps_a_line_break_in_the_source_path_out_of_the_data(tmp_path):
    # The field's path is written into the header comment: a path holding a line break and a data
    # line must not add a target to the written field.
    field = raised_field()
    synthetic_field_detections(tmp_path / "d.json", field)
    odd = tmp_path / "f\n999 1 2 3"
    odd.mkdir()
    write_field(odd / "f.txt", field)
    out = tmp_path / "out.txt"
    run("calibrate", "--detections", tmp_path / "d.json", "--field", odd / "f.txt", "--centre-correction", "off",
        "--free", "c,x0,y0,K1,K2", "--free-target", "--field-out", out, "--quiet")
    assert sorted(read_field_out(out)) == sorted(field)
