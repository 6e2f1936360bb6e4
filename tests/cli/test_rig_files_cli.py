"""Rig files users have (issue 26) through `porthole convert` and `porthole measure --rig`, each checked
by the real client where Debian has one:
- OpenCV stereo YAML/XML: written files read by cv2.FileStorage and taken by cv2.stereoRectify; a file
  cv2.FileStorage wrote itself (no unit) read back with --length-unit;
- VIAME's .npz: np.load sees cameraMatrixL/R (3x3), distCoeffsL/R (1x5), R (3x3), T (3x1), all float64,
  with the rig's values -- the layout VIAME's tools/calibrate_cameras.py --npz writes (np.savez of
  cv2.stereoCalibrate's outputs, VIAME/VIAME 05ee7881) -- and VIAME camtrawl's reading
  (StereoCalibration.from_npzfile: cv2.Rodrigues(R), T raveled, mm) gives the rig's pose; files numpy
  wrote (np.savez as VIAME does, np.savez_compressed) are read back;
- ROS camera_info: Debian's python3-camera-calibration-parsers (ROS's own parser) reads each file: K,
  D, R, P as written, R1/R2 those of cv2.stereoRectify, P2's Tx = -f' * baseline in metres;
- Kalibr camchain: no Debian package: read with PyYAML's safe_load as Kalibr's ConfigReader.py does
  (ethz-asl/kalibr 0b8b9e8e, aslam_offline_calibration/kalibr/python/kalibr_common/ConfigReader.py) and
  held to its checks (float intrinsics, int resolution, 4 radtan coefficients, T_cn_cnm1 4x4 in metres);
- each format back to a rig JSON equals the original (1e-12 relative), and `measure --rig` on each
  gives the same 3-D points as on the rig JSON;
- bad input: not a rig, a missing key (named), an unstated or unknown unit, an ambiguous .yaml: one
  line, exit 2.
The rig is calibrated by porthole from synthetic detections projected by cv2.projectPoints
(test_rig_cli.py's generator)."""
import json
import math

import numpy as np
import pytest
import yaml

from conftest import run, run_bad
from test_rig_cli import TARGET, W, H, frames, write_detections

cv2 = pytest.importorskip("cv2")

KEYS = ("fx_px", "fy_px", "cx_px", "cy_px", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6")


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    d = tmp_path_factory.mktemp("rigfiles")
    data = frames(n=12, seed=11)
    for k, name in enumerate(("left.json", "right.json")):
        write_detections(d / name, data, k)
    base = ("calibrate", "--detections", d / "left.json", "--detections", d / "right.json", "--model", "opencv", "--quiet")
    run(*base, "--out", d / "rig.json")  # the default free set: k3-k6 fixed at 0
    # A rig whose lenses have a k3 (radtan has none): calibrated with k3 free, then k3 set to -0.002 in
    # both cameras (the synthetic truth has k3 = 0, so its estimate is noise: up to -0.013 here, which
    # no radtan refit holds within 1 px at the corners).
    run(*base, "--free", "fx,fy,cx,cy,k1,k2,p1,p2,k3", "--out", d / "rig_k3.json")
    k3 = json.loads((d / "rig_k3.json").read_text())
    for cam in k3["rig"]["cameras"]:
        cam["camera"]["k3"] = -0.002
    (d / "rig_k3.json").write_text(json.dumps(k3))
    return d, json.loads((d / "rig.json").read_text())["rig"]


def params(cam):
    return np.array([cam["camera"].get(k) or 0.0 for k in KEYS])


def pose(cam):
    r, _ = cv2.Rodrigues(np.array(cam["cam_from_rig"]["rotation_rad"]))
    return r, np.array(cam["cam_from_rig"]["translation_mm"])


def same_rig(a, b, tol=1e-12):
    assert len(a["cameras"]) == len(b["cameras"])
    for ca, cb in zip(a["cameras"], b["cameras"]):
        pa, pb = params(ca), params(cb)
        assert np.all(np.abs(pa - pb) <= tol * np.maximum(1.0, np.abs(pa))), (pa, pb)
        ra, ta = pose(ca)
        rb, tb = pose(cb)
        assert np.abs(ra - rb).max() <= tol
        assert np.linalg.norm(ta - tb) <= tol * max(1.0, np.linalg.norm(ta))
        assert (ca["sensor"]["width_px"], ca["sensor"]["height_px"]) == (cb["sensor"]["width_px"], cb["sensor"]["height_px"])


def relative(rj):
    r0, t0 = pose(rj["cameras"][0])
    r1, t1 = pose(rj["cameras"][1])
    r = r1 @ r0.T
    return r, t1 - r @ t0


@pytest.mark.parametrize("to,name", [("opencv-stereo", "s.yml"), ("opencv-stereo-xml", "s.xml"), ("viame-npz", "s.npz"),
                                     ("ros-camera-info", "ros"), ("kalibr", "camchain.yaml")])
def test_round_trip_to_rig_json(rig, tmp_path, to, name):
    d, rj = rig
    out = tmp_path / name
    j = run("convert", d / "rig.json", out, "--to", to, "--json").json()
    assert j["exact"] and j["out_format"] == to and j["n_cameras"] == 2 and j["sigma"].startswith("dropped")
    ins = [out / "left.json.yaml", out / "right.json.yaml"] if to == "ros-camera-info" else [out]
    back = tmp_path / "back.json"
    t = run("convert", *ins, back, "--pixel-pitch-mm", "1").out
    assert "no sigma" in t
    same_rig(rj, json.loads(back.read_text())["rig"])


def test_opencv_stereo_read_by_cv2_and_cv2s_own_file_read_back(rig, tmp_path):
    d, rj = rig
    f = tmp_path / "s.yml"
    run("convert", d / "rig.json", f, "--to", "opencv-stereo")
    fs = cv2.FileStorage(str(f), cv2.FILE_STORAGE_READ)
    k1, d1, k2, d2, r, t = (fs.getNode(n).mat() for n in ("K1", "D1", "K2", "D2", "R", "T"))
    assert fs.getNode("T_unit").string() == "mm"
    fs.release()
    rr, tt = relative(rj)
    assert np.abs(r - rr).max() < 1e-15 and np.abs(t.ravel() - tt).max() < 1e-12
    r1, r2, p1, p2, _, _, _ = cv2.stereoRectify(k1, d1, k2, d2, (W, H), r, t)
    assert -p2[0, 3] / p2[0, 0] == pytest.approx(np.linalg.norm(tt), rel=1e-9)
    # A file cv2.FileStorage writes itself (stereoCalibrate's names, T in metres, no unit stated).
    own = tmp_path / "cv2.yml"
    fs = cv2.FileStorage(str(own), cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", W)
    fs.write("image_height", H)
    for n, m in (("K1", k1), ("D1", d1), ("K2", k2), ("D2", d2), ("R", r), ("T", t / 1000)):
        fs.write(n, m)
    fs.release()
    line = run_bad("convert", own, tmp_path / "x.json")
    assert "unit" in line and "mm, cm, m" in line, line
    run("convert", own, tmp_path / "own.json", "--length-unit", "m")
    back = json.loads((tmp_path / "own.json").read_text())["rig"]
    same_rig(rj, back, tol=1e-12)


def test_npz_read_by_numpy_as_viame_does(rig, tmp_path):
    d, rj = rig
    f = tmp_path / "stereo.npz"
    run("convert", d / "rig.json", f)
    z = np.load(f)
    shapes = {"cameraMatrixL": (3, 3), "cameraMatrixR": (3, 3), "distCoeffsL": (1, 5), "distCoeffsR": (1, 5),
              "R": (3, 3), "T": (3, 1)}
    for key, shape in shapes.items():
        assert z[key].shape == shape and z[key].dtype == np.float64, key
    assert str(z["T_unit"]) == "mm"
    for side, cam in (("L", rj["cameras"][0]), ("R", rj["cameras"][1])):
        p = params(cam)
        k = z["cameraMatrix" + side]
        assert [k[0, 0], k[1, 1], k[0, 2], k[1, 2], k[0, 1]] == [p[0], p[1], p[2], p[3], 0.0]
        assert z["distCoeffs" + side].ravel().tolist() == p[4:9].tolist()
    # VIAME camtrawl's StereoCalibration.from_npzfile: om = Rodrigues(R), T raveled, in millimetres.
    rr, tt = relative(rj)
    om = cv2.Rodrigues(z["R"])[0].ravel()
    assert np.abs(cv2.Rodrigues(om)[0] - rr).max() < 1e-12
    assert np.abs(z["T"].ravel() - tt).max() < 1e-12
    # Files numpy writes (stored and deflated), without porthole's T_unit and image size.
    for save in (np.savez, np.savez_compressed):
        g = tmp_path / f"{save.__name__}.npz"
        save(g, **{k: z[k] for k in shapes})
        line = run_bad("convert", g, tmp_path / "g.json")
        assert "image size" in line, line
        line = run_bad("convert", g, tmp_path / "g.json", "--image-size", f"{W}x{H}")
        assert "mm, cm, m" in line, line
        run("convert", g, tmp_path / "g.json", "--image-size", f"{W}x{H}", "--length-unit", "mm", "--force")
        same_rig(rj, json.loads((tmp_path / "g.json").read_text())["rig"])


def test_ros_camera_info_read_by_ros_parser(rig, tmp_path):
    parsers = pytest.importorskip("camera_calibration_parsers")
    d, rj = rig
    out = tmp_path / "ros"
    run("convert", d / "rig.json", out, "--to", "ros-camera-info")
    infos = []
    for cam in rj["cameras"]:
        got = parsers.readCalibration(str(out / f"{cam['name']}.yaml"))
        assert got is not None, cam["name"]
        name, ci = got
        assert name == cam["name"] and (ci.width, ci.height) == (W, H)
        p = params(cam)
        assert ci.distortion_model == "plumb_bob"
        assert list(ci.K) == [p[0], 0, p[2], 0, p[1], p[3], 0, 0, 1]
        assert list(ci.D) == p[4:9].tolist()
        infos.append(ci)
    rr, tt = relative(rj)
    k = [np.array(ci.K).reshape(3, 3) for ci in infos]
    dd = [np.array(ci.D) for ci in infos]
    r1, r2, _, _, _, _, _ = cv2.stereoRectify(k[0], dd[0], k[1], dd[1], (W, H), rr, tt / 1000)
    assert np.abs(np.array(infos[0].R).reshape(3, 3) - r1).max() < 1e-12
    assert np.abs(np.array(infos[1].R).reshape(3, 3) - r2).max() < 1e-12
    p2 = np.array(infos[1].P).reshape(3, 4)
    assert -p2[0, 3] / p2[0, 0] == pytest.approx(np.linalg.norm(tt) / 1000, rel=1e-9)  # metres
    assert list(infos[0].P)[3] == 0.0


def test_kalibr_camchain_passes_kalibrs_reader_checks(rig, tmp_path):
    d, rj = rig
    f = tmp_path / "camchain.yaml"
    t = run("convert", d / "rig.json", f, "--to", "kalibr").out
    assert "pinhole-radtan exact" in t
    chain = yaml.safe_load(f.read_text())
    assert sorted(chain) == ["cam0", "cam1"]
    for key in ("cam0", "cam1"):
        c = chain[key]
        assert c["camera_model"] == "pinhole" and c["distortion_model"] == "radtan"
        assert len(c["intrinsics"]) == 4 and all(isinstance(v, float) for v in c["intrinsics"])
        assert len(c["distortion_coeffs"]) == 4
        assert c["resolution"] == [W, H] and all(isinstance(v, int) for v in c["resolution"])
        assert isinstance(c["rostopic"], str)
    tcn = np.array(chain["cam1"]["T_cn_cnm1"])
    assert tcn.shape == (4, 4) and tcn[3].tolist() == [0.0, 0.0, 0.0, 1.0]
    rr, tt = relative(rj)
    assert np.abs(tcn[:3, :3] - rr).max() < 1e-15
    assert np.abs(tcn[:3, 3] - tt / 1000).max() < 1e-15  # metres
    # With k3 adjusted, radtan (k1 k2 p1 p2) cannot hold the camera: a refit, its RMS printed.
    t = run("convert", d / "rig_k3.json", tmp_path / "k.yaml", "--to", "kalibr").out
    assert "pinhole-radtan refit over the image: RMS" in t, t
    m = run("convert", d / "rig_k3.json", tmp_path / "k2.yaml", "--to", "kalibr", "--json").json()
    assert not m["exact"]
    rms = max(c["refit_rms_px"] for c in m["cameras"])
    print(f"Kalibr radtan refit of the opencv rig (k3 = -0.002): RMS {rms:.4f} px")
    assert 0 < rms < 1


def write_points(path, uv0, uv1):
    for k, name in enumerate(("m_left.json", "m_right.json")):
        images = [{"image": "p.png", "width_px": W, "height_px": H, "ids": list(range(len(uv0))),
                   "points_px": (uv0 if k == 0 else uv1).tolist()}]
        (path / name).write_text(json.dumps({"target": TARGET, "images": images}))
    return path / "m_left.json", path / "m_right.json"


def test_measure_reads_every_rig_file(rig, tmp_path):
    d, rj = rig
    pts = np.array([[100.0, 50, 1200], [-80, 20, 1500], [300, -100, 900]])
    uv = []
    for cam in rj["cameras"]:
        p = params(cam)
        r, t = pose(cam)
        kk = np.array([[p[0], 0, p[2]], [0, p[1], p[3]], [0, 0, 1]])
        uv.append(cv2.projectPoints(pts, cv2.Rodrigues(r)[0], t, kk, p[4:12])[0].reshape(-1, 2))
    left, right = write_points(tmp_path, uv[0], uv[1])
    ref = run("measure", "--rig", d / "rig.json", "--points", left, "--points", right, "--json").json()["measure"]
    ref_x = np.array([p["x_mm"] for p in sorted(ref["points"], key=lambda p: p["id"])])
    assert np.abs(ref_x - pts).max() < 1e-6
    for to, name in (("opencv-stereo", "s.yml"), ("opencv-stereo-xml", "s.xml"), ("viame-npz", "s.npz"),
                     ("kalibr", "c.yaml")):
        f = tmp_path / name
        run("convert", d / "rig.json", f, "--to", to)
        # A rig file of another tool has no sigma0: measure asks for the image points' sigma.
        assert "--sigma-px" in run_bad("measure", "--rig", f, "--points", left, "--points", right)
        res = run("measure", "--rig", f, "--points", left, "--points", right, "--sigma-px", "0.3", "--json")
        out = res.json()["measure"]
        x = np.array([p["x_mm"] for p in sorted(out["points"], key=lambda p: p["id"])])
        assert np.abs(x - ref_x).max() < 1e-6, (to, np.abs(x - ref_x).max())
        text = run("measure", "--rig", f, "--points", left, "--points", right, "--sigma-px", "0.3").out
        assert "holds no covariance" in text, text
    # A file without its unit, and a ROS camera_info (one camera): refused, saying what to do.
    z = np.load(tmp_path / "s.npz")
    np.savez(tmp_path / "viame.npz", **{k: z[k] for k in z.files if k != "T_unit"})
    line = run_bad("measure", "--rig", tmp_path / "viame.npz", "--points", left, "--points", right, "--sigma-px", "0.3")
    assert "mm, cm, m" in line and "convert" in line, line
    run("convert", d / "rig.json", tmp_path / "ros", "--to", "ros-camera-info")
    line = run_bad("measure", "--rig", tmp_path / "ros" / "left.json.yaml", "--points", left, "--points", right)
    assert "one camera" in line and "convert" in line, line


def test_bad_rig_files_are_refused(rig, tmp_path):
    d, rj = rig
    # Not a rig: a single camera's calibration to a rig format.
    one = tmp_path / "one.json"
    run("calibrate", "--detections", d / "left.json", "--model", "opencv", "--out", one, "--quiet")
    line = run_bad("convert", one, tmp_path / "x.yaml", "--to", "kalibr")
    assert "not a rig" in line, line
    # A missing key is named.
    f = tmp_path / "s.yml"
    run("convert", d / "rig.json", f, "--to", "opencv-stereo")
    text = f.read_text()
    (tmp_path / "nod2.yml").write_text(text.replace("D2:", "DX:"))
    line = run_bad("convert", tmp_path / "nod2.yml", tmp_path / "y.json")
    assert "D2: missing" in line, line
    # An unknown unit, and a unit contradicting the file's T_unit.
    assert "--length-unit" in run_bad("convert", f, tmp_path / "y.json", "--length-unit", "furlong")
    line = run_bad("convert", f, tmp_path / "y.json", "--length-unit", "m")
    assert "T_unit" in line and "mm" in line, line
    # An ambiguous output name.
    line = run_bad("convert", d / "rig.json", tmp_path / "rig.yaml")
    assert "opencv-stereo" in line and "kalibr" in line and "--to" in line, line
    # Three cameras into a pair format; an npz that is not a zip.
    (tmp_path / "bad.npz").write_bytes(b"PK\x03\x04 not a zip at all")
    line = run_bad("convert", tmp_path / "bad.npz", tmp_path / "z.json")
    assert "zip" in line, line
