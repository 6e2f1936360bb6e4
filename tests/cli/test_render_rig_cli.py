"""Proves `porthole render --rig` / `--baseline` from the command line against an independent
calibration: a rig rendered from a known cam_from_rig, detected and calibrated by `porthole calibrate`
with one --images per camera, gives that cam_from_rig back -- two central OpenCV cameras (300 mm
apart, 5 deg convergence, from a rig JSON), and the same rig with both cameras behind as-built NI320
domes (the pupil 0.4, 1.0, 5.4 mm from the outer centre) with the bare lens's in-air calibration,
rendered with --port none, as its prior, or each camera's calibration made in air with its housing on
(the rig's own air set), taken as such, or that air set itself (--air-images). Each camera's truth is the same target pose seen through
its cam_from_rig; every camera's folder holds the same frame names; bad rigs get one line, exit 2
and no file."""
import json
import math
import os

from conftest import run, run_bad

TARGET = "chessboard:11x8:30"  # odd x even: no 180 deg ambiguity
FAST = ["--spp", "1", "--edge-spp", "64", "--f-number", "inf", "--target", TARGET, "--quiet"]
CONV = math.radians(5)
# cam_from_rig of the second camera: 300 mm to the right of the first, turned 5 deg towards it
# (R = R_y(+5 deg): its axis in the rig frame is (-sin 5, 0, cos 5)); t = -R (300, 0, 0).
TRUE_R = [[math.cos(CONV), 0, math.sin(CONV)], [0, 1, 0], [-math.sin(CONV), 0, math.cos(CONV)]]
TRUE_T = [-300 * math.cos(CONV), 0.0, 300 * math.sin(CONV)]


def opencv_camera(name, params, rotation_rad, translation_mm):
    keys = ["fx_px", "fy_px", "cx_px", "cy_px", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"]
    return {"name": name, "model": "opencv", "camera": dict(zip(keys, params + [0, 0, 0, 0])),
            "sensor": {"width_px": 960, "height_px": 640, "pixel_pitch_mm": 0.0245},
            "cam_from_rig": {"rotation_rad": rotation_rad, "translation_mm": translation_mm}}


def write_rig(path):
    rig = {"rig": {"cameras": [
        opencv_camera("cam0", [1100, 1100.5, 481.2, 318.7, -0.08, 0.05, 2e-4, -1e-4], [0, 0, 0], [0, 0, 0]),
        opencv_camera("cam1", [1095, 1095.3, 478.0, 322.1, -0.07, 0.04, -1e-4, 2e-4], [0, CONV, 0], TRUE_T)]}}
    path.write_text(json.dumps(rig))
    return path


def rotation(rvec):
    """Rodrigues: the matrix of an angle-axis vector, R = cos a I + (1 - cos a) k k^T + sin a [k]x."""
    a = math.sqrt(sum(x * x for x in rvec))
    if a == 0:
        return [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
    k = [x / a for x in rvec]
    c, s = math.cos(a), math.sin(a)
    cross = [[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]]
    return [[(c if i == j else 0) + (1 - c) * k[i] * k[j] + s * cross[i][j] for j in range(3)] for i in range(3)]


def matmul(a, b):
    return [[sum(a[i][m] * b[m][j] for m in range(3)) for j in range(3)] for i in range(3)]


def angle_deg(r_a, r_b):
    """The angle of r_a r_b^T, deg."""
    m = matmul(r_a, [list(col) for col in zip(*r_b)])
    return math.degrees(math.acos(max(-1.0, min(1.0, (m[0][0] + m[1][1] + m[2][2] - 1) / 2))))


def pupils_of(cal):
    """Each camera's pupil in its dome (ep_in_dome x, y, z mm) from a rig calibration's JSON."""
    return [[c["port"]["parameters"][k] for k in ("ep_in_dome_x_mm", "ep_in_dome_y_mm", "ep_in_dome_z_mm")]
            for c in cal["rig"]["cameras"]]


def rig_errors(cal):
    c1 = cal["rig"]["cameras"][1]["cam_from_rig"]
    dt = math.dist(c1["translation_mm"], TRUE_T)
    dr = angle_deg(rotation(c1["rotation_rad"]), TRUE_R)
    return dt, dr, c1


def test_a_rendered_central_rig_calibrates_back_to_its_cam_from_rig(tmp_path):
    rig = write_rig(tmp_path / "rig.json")
    out = tmp_path / "set"
    summary = run("render", "--rig", rig, "--set", 10, "--out", out, "--json", *FAST).json()
    assert summary["cameras"] == ["cam0", "cam1"] and summary["frames"] == 10
    # Bare cameras (the rig gives no port): the air set only; one frame name in both folders.
    assert sorted(os.listdir(out)) == ["air"]
    names = [sorted(os.listdir(out / "air" / cam)) for cam in ("cam0", "cam1")]
    assert names[0] == names[1] and len(names[0]) == 20
    # Each camera's truth: the same rig pose through its cam_from_rig.
    t0 = json.loads((out / "air" / "cam0" / "pose_003.json").read_text())
    t1 = json.loads((out / "air" / "cam1" / "pose_003.json").read_text())
    assert t0["rig"]["rig_from_target"] == t1["rig"]["rig_from_target"]
    assert t1["rig"]["camera"] == "cam1" and t1["port"] is None and t1["camera"]["model"] == "opencv"
    for p0, p1 in zip(t0["points"], t1["points"]):  # cam1_mm = R cam0_mm + t (cam0 is the rig frame)
        expect = [sum(TRUE_R[i][j] * p0["cam_mm"][j] for j in range(3)) + TRUE_T[i] for i in range(3)]
        assert math.dist(expect, p1["cam_mm"]) < 1e-6
    cal = tmp_path / "cal.json"
    run("calibrate", "--images", out / "air" / "cam0", "--images", out / "air" / "cam1", "--target", TARGET,
        "--model", "opencv", "--out", cal, "--quiet")
    dt, dr, c1 = rig_errors(json.loads(cal.read_text()))
    print(f"central rig: translation {dt:.4f} mm, rotation {dr:.5f} deg from the truth; "
          f"sigma t {c1['sigma']['translation_mm']}")
    assert dt < 0.2 and dr < 0.01


def test_a_rig_behind_as_built_domes_calibrates_back_with_its_ports(tmp_path):
    # Two D300 + 24 mm (pixels 0.029 mm: an 813 x 540 frame) behind the as-built NI320, the pupil at
    # (0, 0, 26.9) in the housing: (0.4, 1.0, 5.4) mm from the dome's outer centre; one band (the
    # calibration's wavelength), one focus for every set.
    common = ["--pixel-pitch-mm", "0.029", "--focus", "1500", "--ep", "0,0,26.9", "--bands", "546.07", *FAST]
    run("render", "--baseline", 300, "--convergence", 5, "--port", "nimar-ni320", "--set", 10, "--out",
        tmp_path / "rig", *common)
    assert sorted(os.listdir(tmp_path / "rig")) == ["air", "water"]
    assert sorted(os.listdir(tmp_path / "rig" / "water")) == ["cam0", "cam1"]
    truth = json.loads((tmp_path / "rig" / "water" / "cam1" / "pose_000.json").read_text())
    assert truth["medium"] == "water" and truth["port"]["name"] == "nimar-ni320"
    assert abs(truth["rig"]["cam_from_rig"]["rotation_rad"][1] - CONV) < 1e-12
    # The bare lens in air (--port none), the same focus: its calibration is each lens's prior.
    run("render", "--port", "none", "--set", 10, "--out", tmp_path / "bare", *common)
    assert sorted(os.listdir(tmp_path / "bare")) == ["air"]
    lens = tmp_path / "lens.json"
    run("calibrate", "--images", tmp_path / "bare" / "air", "--target", TARGET, "--pixel-pitch-mm", "0.029",
        "--out", lens, "--quiet")
    cal = tmp_path / "rig.json"
    run("calibrate", "--images", tmp_path / "rig" / "water" / "cam0", "--images", tmp_path / "rig" / "water" / "cam1",
        "--target", TARGET, "--pixel-pitch-mm", "0.029", "--port", "nimar-ni320",
        "--air-calibration", f"{lens},{lens}", "--air-lens-bare", "--out", cal, "--quiet")
    rig = json.loads(cal.read_text())
    dt, dr, _ = rig_errors(rig)
    pupils = pupils_of(rig)
    print(f"dome rig: translation {dt:.4f} mm, rotation {dr:.5f} deg from the truth; pupils {pupils}")
    assert dt < 0.2 and dr < 0.01
    for p in pupils:
        assert math.hypot(p[0] - 0.4, p[1] - 1.0) < 0.1 and abs(p[2] - 5.4) < 0.3

    # The users' way: the bare lenses calibrated as a pair in air, that rig's file given as the
    # water rig's --air-calibration (opencv lenses, as the air pair's); OpenCV's stereo
    # YAML of the same pair holds no covariance for the priors and is refused, saying so.
    run("render", "--baseline", 300, "--convergence", 5, "--port", "none", "--set", 10, "--out",
        tmp_path / "bare_rig", *common)
    stereo, pair = tmp_path / "air_pair.yml", tmp_path / "air_pair.json"
    run("calibrate", "--images", tmp_path / "bare_rig" / "air" / "cam0", "--images", tmp_path / "bare_rig" / "air" / "cam1",
        "--target", TARGET, "--pixel-pitch-mm", "0.029", "--model", "opencv", "--stereo-out", stereo, "--out", pair,
        "--quiet")
    cal2 = tmp_path / "rig2.json"
    run("calibrate", "--images", tmp_path / "rig" / "water" / "cam0", "--images", tmp_path / "rig" / "water" / "cam1",
        "--target", TARGET, "--pixel-pitch-mm", "0.029", "--port", "nimar-ni320",
        "--model", "opencv", "--air-calibration", pair, "--air-lens-bare", "--out", cal2, "--quiet")
    rig2 = json.loads(cal2.read_text())
    dt2, dr2, _ = rig_errors(rig2)
    pupils2 = pupils_of(rig2)
    print(f"dome rig, air lenses from the air pair's rig file: translation {dt2:.4f} mm, rotation {dr2:.5f} deg; pupils {pupils2}")
    assert dt2 < 0.2 and dr2 < 0.01
    for p, q in zip(pupils2, pupils):
        assert math.hypot(p[0] - 0.4, p[1] - 1.0) < 0.1 and abs(p[2] - 5.4) < 0.3
    # The paper's protocol in a rig: each camera calibrated in air with its housing on (the rig's own
    # air set, through the same domes), those calibrations given as they are (no --air-lens-bare):
    # each is modelled as its lens behind its dome in air.
    housed = []
    for k in (0, 1):
        housed.append(tmp_path / f"housed{k}.json")
        run("calibrate", "--images", tmp_path / "rig" / "air" / f"cam{k}", "--target", TARGET, "--pixel-pitch-mm",
            "0.029", "--out", housed[k], "--quiet")
    cal3 = tmp_path / "rig3.json"
    run("calibrate", "--images", tmp_path / "rig" / "water" / "cam0", "--images", tmp_path / "rig" / "water" / "cam1",
        "--target", TARGET, "--pixel-pitch-mm", "0.029", "--port", "nimar-ni320",
        "--air-calibration", f"{housed[0]},{housed[1]}", "--out", cal3, "--quiet")
    rig3 = json.loads(cal3.read_text())
    dt3, dr3, _ = rig_errors(rig3)
    pupils3 = pupils_of(rig3)
    print(f"dome rig, housed air calibrations: translation {dt3:.4f} mm, rotation {dr3:.5f} deg; pupils {pupils3}")
    assert dt3 < 0.2 and dr3 < 0.01
    for p, c in zip(pupils3, rig3["rig"]["cameras"]):
        assert math.hypot(p[0] - 0.4, p[1] - 1.0) < 0.1 and abs(p[2] - 5.4) < 0.3
        assert c["port"]["air_calibration_taken_as"] == "through_port"
    # The same air images given themselves (--air-images, one folder per camera in rig order): each
    # camera's air set modelled through its own dome in air and adjusted with the rig.
    air_dirs = ",".join(str(tmp_path / "rig" / "air" / f"cam{k}") for k in (0, 1))
    rig4 = run("calibrate", "--images", tmp_path / "rig" / "water" / "cam0", "--images",
               tmp_path / "rig" / "water" / "cam1", "--target", TARGET, "--pixel-pitch-mm", "0.029", "--port",
               "nimar-ni320", "--air-images", air_dirs, "--json", "--quiet").json()
    dt4, dr4, _ = rig_errors(rig4)
    pupils4 = pupils_of(rig4)
    print(f"dome rig with air images: translation {dt4:.4f} mm, rotation {dr4:.5f} deg; pupils {pupils4}")
    assert dt4 < 0.2 and dr4 < 0.01
    for p, c in zip(pupils4, rig4["rig"]["cameras"]):
        assert math.hypot(p[0] - 0.4, p[1] - 1.0) < 0.1 and abs(p[2] - 5.4) < 0.3
        assert c["port"]["air"]["n_images"] == 10 and c["port"]["air"]["rms_px"] < 0.15  # --set 10
    # One air folder for two cameras, or air images without ports: one line, naming the flag.
    water = ["calibrate", "--images", tmp_path / "rig" / "water" / "cam0", "--images", tmp_path / "rig" / "water" / "cam1",
             "--target", TARGET, "--pixel-pitch-mm", "0.029", "--quiet"]
    line = run_bad(*water, "--port", "nimar-ni320", "--air-images", tmp_path / "rig" / "air" / "cam0")
    assert "--air-images" in line and "1 given for 2 cameras" in line, line
    line = run_bad(*water, "--air-images", air_dirs)
    assert "--air-images" in line and "--port" in line, line
    # A pair file for a rig of three cameras names the counts.
    line = run_bad("calibrate", *[a for k in (0, 1, 0) for a in ("--images", tmp_path / "rig" / "water" / f"cam{k}")],
                   "--target", TARGET, "--pixel-pitch-mm", "0.029", "--port", "nimar-ni320",
                   "--air-calibration", pair, "--air-lens-bare", "--out", tmp_path / "never.json")
    assert "holds 2 cameras, the rig 3" in line, line
    line = run_bad("calibrate", "--images", tmp_path / "rig" / "water" / "cam0", "--images",
                   tmp_path / "rig" / "water" / "cam1", "--target", TARGET, "--pixel-pitch-mm", "0.029",
                   "--port", "nimar-ni320", "--air-calibration", stereo, "--air-lens-bare", "--out", tmp_path / "never.json")
    assert "holds no covariance" in line and not (tmp_path / "never.json").exists(), line


def test_bad_rigs_get_one_line_and_no_file(tmp_path):
    rig = write_rig(tmp_path / "rig.json")
    out = tmp_path / "out"
    line = run_bad("render", "--rig", rig, "--baseline", 300, "--out", out, *FAST)
    assert "--rig" in line and "not both" in line
    assert "--convergence" in run_bad("render", "--convergence", 5, "--out", out, *FAST)
    assert "--baseline" in run_bad("render", "--baseline", -1, "--out", out, *FAST)
    # A target outside the second camera's frame: refused before any folder exists.
    line = run_bad("render", "--rig", rig, "--out", out, "--shift", "-700,0", "--distance", 1000, *FAST)
    assert "outside" in line
    bad = json.loads(rig.read_text())
    bad["rig"]["cameras"][1]["name"] = "../up"
    (tmp_path / "bad.json").write_text(json.dumps(bad))
    assert "folder name" in run_bad("render", "--rig", tmp_path / "bad.json", "--out", out, *FAST)
    bad["rig"]["cameras"][1]["name"] = "cam0"
    (tmp_path / "bad.json").write_text(json.dumps(bad))
    assert "two cameras" in run_bad("render", "--rig", tmp_path / "bad.json", "--out", out, *FAST)
    assert not out.exists()
    # A single camera's calibration is no rig.
    single = tmp_path / "single.json"
    single.write_text(json.dumps({k: v for k, v in bad["rig"]["cameras"][0].items() if k != "name"}))
    assert "not a rig" in run_bad("render", "--rig", single, "--out", out, *FAST)
    # A second set into the same folder: refused without --force, the earlier set replaced with it.
    run("render", "--rig", rig, "--set", 1, "--out", out, "--pixel-pitch-mm", "0.029", *FAST)
    assert "not empty" in run_bad("render", "--rig", rig, "--set", 1, "--out", out, *FAST)
    run("render", "--rig", rig, "--set", 1, "--out", out, "--force", "--seed", 2, *FAST)
    assert sorted(os.listdir(out / "air" / "cam1")) == ["pose_000.json", "pose_000.png"]
