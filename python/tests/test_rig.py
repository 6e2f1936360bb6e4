"""Proves porthole.calibrate_rig() is the rig calibration of `porthole calibrate --detections A
--detections B` (issue 26): the same cam_from_rig, baseline and intrinsics (1e-9 relative) as the
CLI's JSON for the same detections, as typed results (RigCalibration of RigCamera, each a
Calibration), and errors naming the keyword. The stereo pair is projected by cv2.projectPoints
(tests/cli/test_rig_cli.py compares the CLI with cv2.stereoCalibrate)."""
import json
import math
import tomllib

import numpy as np
import pytest

import porthole
from test_notebook import cli_json

cv2 = pytest.importorskip("cv2")

TARGET = "chessboard:16x12:50"
W, H = 4288, 2848


def stereo(n=12, seed=3):
    rng = np.random.default_rng(seed)
    pts = np.array([[c * 50.0, r * 50.0, 0.0] for r in range(12) for c in range(16)])
    k = np.array([[2000.0, 0, 2150], [0, 2000, 1420], [0, 0, 1]])
    dist = np.array([-0.08, 0.05, 0, 0, 0.0])
    r1, _ = cv2.Rodrigues(np.array([0.0, 5 * math.pi / 180, 0.0]))  # turned 5 deg towards camera 0
    t1 = -r1 @ np.array([300.0, 0, 0])
    cams = [[], []]
    for f in range(n):
        r, _ = cv2.Rodrigues(rng.uniform(-1, 1, 3) * np.array([0.6, 0.6, 0.3]))
        t = np.array([150 + 250 * rng.uniform(-1, 1), 200 * rng.uniform(-1, 1), 800 + 1000 * rng.uniform()])
        t = t - r @ pts.mean(axis=0)
        for c, (rc, tc) in enumerate(((r, t), (r1 @ r, r1 @ t + t1))):
            uv, _ = cv2.projectPoints(pts, cv2.Rodrigues(rc)[0], tc, k, dist)
            uv = uv.reshape(-1, 2) + rng.normal(0, 0.3, (len(pts), 2))
            ok = (uv[:, 0] > 0) & (uv[:, 0] < W - 1) & (uv[:, 1] > 0) & (uv[:, 1] < H - 1)
            cams[c].append({"image": f"f{f:03d}.png", "width_px": W, "height_px": H,
                            "ids": [int(i) for i in np.nonzero(ok)[0]], "points_px": uv[ok].tolist()})
    return cams


def test_calibrate_rig_matches_the_cli(tmp_path):
    cams = stereo()
    files = []
    for c, name in zip(cams, ("left", "right")):
        files.append(tmp_path / f"{name}.json")
        files[-1].write_text(json.dumps({"target": TARGET, "images": c}))
    ours = porthole.calibrate_rig(cams, TARGET, model="opencv", names=["left.json", "right.json"])
    theirs = cli_json("calibrate", "--detections", files[0], "--detections", files[1], "--model", "opencv",
                      "--quiet")["rig"]
    assert isinstance(ours, porthole.RigCalibration) and len(ours.cameras) == 2
    right = ours.cameras[1]
    assert isinstance(right, porthole.RigCamera) and isinstance(right, porthole.Calibration)
    t = theirs["cameras"][1]
    assert right.name == t["name"] == "right.json"
    assert right.rotation_rad == pytest.approx(t["cam_from_rig"]["rotation_rad"], rel=1e-9, abs=1e-12)
    assert right.translation_mm == pytest.approx(t["cam_from_rig"]["translation_mm"], rel=1e-9)
    assert right.baseline_mm == pytest.approx(t["baseline_mm"], rel=1e-9)
    assert right.pose_sigma[3:] == pytest.approx(t["cam_from_rig"]["sigma"]["translation_mm"], rel=1e-6)
    for key, value in t["camera"].items():
        if value is not None:
            assert right.params[key] == pytest.approx(value, rel=1e-9, abs=1e-15), key
    assert ours.sigma0_px == pytest.approx(theirs["sigma0_px"], rel=1e-9)
    assert abs(right.baseline_mm - 300) < 3 * right.baseline_sigma_mm + 0.5
    assert ours.to_dict()["rig"]["n_frames"] == theirs["n_frames"]
    # A free target (target_free=True, as --free-target): the same adjusted points as the CLI's.
    ours = porthole.calibrate_rig(cams, TARGET, model="opencv", names=["left.json", "right.json"], target_free=True)
    theirs = cli_json("calibrate", "--detections", files[0], "--detections", files[1], "--model", "opencv",
                      "--free-target", "--quiet")["rig"]
    mine = ours.to_dict()["rig"]["target_adjusted"]
    assert mine["datum"] == theirs["target_adjusted"]["datum"]
    for a, b in zip(mine["points"], theirs["target_adjusted"]["points"]):
        assert a["xyz_mm"] == pytest.approx(b["xyz_mm"], rel=1e-9, abs=1e-9)


def test_a_pixel_pitch_per_camera_as_the_cli(tmp_path):
    cams = stereo()
    files = []
    for c, name in zip(cams, ("left", "right")):
        files.append(tmp_path / f"{name}.json")
        files[-1].write_text(json.dumps({"target": TARGET, "images": c}))
    ours = porthole.calibrate_rig(cams, TARGET, model="brown", pixel_pitch_mm=[0.0055, 0.0044])
    theirs = cli_json("calibrate", "--detections", files[0], "--detections", files[1], "--model", "brown",
                      "--pixel-pitch-mm", "0.0055,0.0044", "--quiet")["rig"]
    for cam, t, pitch in zip(ours.cameras, theirs["cameras"], (0.0055, 0.0044)):
        assert t["sensor"]["pixel_pitch_mm"] == pitch
        assert cam.params["c_mm"] == pytest.approx(t["camera"]["c_mm"], rel=1e-9)
    # c in pixels is the same lens whatever the pitch: c_mm / pitch of each camera near 2000 px.
    assert ours.cameras[1].params["c_mm"] / 0.0044 == pytest.approx(2000, rel=0.01)
    with pytest.raises(ValueError, match="^pixel_pitch_mm: 3 pitches for 2 cameras"):
        porthole.calibrate_rig(cams, TARGET, model="brown", pixel_pitch_mm=[0.0055, 0.0044, 0.0043])


def test_rig_errors_name_the_keyword():
    cams = stereo(n=6)
    with pytest.raises(ValueError, match="^model"):
        porthole.calibrate_rig(cams, TARGET, model=["opencv", "opencv", "brown"])
    with pytest.raises(ValueError, match="^cameras"):
        porthole.calibrate_rig(cams[:1], TARGET, model="opencv")
    with pytest.raises(ValueError, match="^air_lens_bare"):
        porthole.calibrate_rig(cams, TARGET, model="opencv", port="nimar-ni320", air_lens_bare=True)
    with pytest.raises(ValueError, match=r"^ep_mm: only with port \(cameras behind ports\)"):
        porthole.calibrate_rig(cams, TARGET, model="opencv", ep_mm=[0, 0, 25])


def test_a_rig_with_air_images_through_its_ports_matches_the_cli(tmp_path):
    """Issue 26: calibrate_rig(..., port=..., air_detections=[...]) is `calibrate --detections W0
    --detections W1 --port P --air-detections A0,A1`: each camera's air images (rendered by porthole.render
    with the housing on, through the as-built NI320) modelled through its dome in air and adjusted with
    the rig; the same cam_from_rig and pupils as the CLI (1e-9 relative), the pupils within 3 sigma of the
    rendered (0.4, 1.0, 5.4) mm, each camera's air set reported."""
    target = "chessboard:11x8:30"
    porthole.render(tmp_path / "rig", set=8, baseline_mm=300, convergence_deg=5, port="nimar-ni320",
                    pixel_pitch_mm=0.029, target=target, samples_per_pixel=1, edge_samples_per_pixel=16,
                    f_number=math.inf, focus_distance_mm=1500, ep_mm=[0, 0, 26.9], bands_nm=[546.07])
    det = {(m, c): porthole.detect(tmp_path / "rig" / m / c, target) for m in ("water", "air") for c in ("cam0", "cam1")}
    files = {}
    for (m, c), d in det.items():
        files[m, c] = tmp_path / f"{m}_{c}.json"
        files[m, c].write_text(json.dumps(d.to_dict()))
    ours = porthole.calibrate_rig([det["water", "cam0"], det["water", "cam1"]], target, pixel_pitch_mm=0.029,
                                  port="nimar-ni320", air_detections=[det["air", "cam0"], det["air", "cam1"]])
    port_out = [tmp_path / "cam0-port.toml", tmp_path / "cam1-port.toml"]
    theirs = cli_json("calibrate", "--detections", files["water", "cam0"], "--detections", files["water", "cam1"],
                      "--pixel-pitch-mm", "0.029", "--port", "nimar-ni320", "--air-detections",
                      f"{files['air', 'cam0']},{files['air', 'cam1']}", "--port-out",
                      f"{port_out[0]},{port_out[1]}", "--quiet")["rig"]
    # --port-out: each camera's estimated port as a port TOML, which every command reads; the pupil
    # (where the preset puts it) minus its outer centre is that camera's estimated ep_in_dome, and
    # Python's estimated_port is the same port (1e-9 relative).
    for k, (cam, f) in enumerate(zip(theirs["cameras"], port_out)):
        assert cam["port"]["port_out"] == str(f)
        written = tomllib.loads(f.read_text())
        assert written["name"] == "nimar-ni320-as-calibrated" and written["type"] == "dome"
        ep, outer = written["entrance_pupil_mm"], written["outer"]["center_mm"]
        p = [cam["port"]["parameters"][key] for key in ("ep_in_dome_x_mm", "ep_in_dome_y_mm", "ep_in_dome_z_mm")]
        assert [a - b for a, b in zip(ep, outer)] == pytest.approx(p, abs=1e-9)
        mine = tomllib.loads(ours.cameras[k].estimated_port.to_toml())
        for side in ("outer", "inner"):
            assert mine[side]["center_mm"] == pytest.approx(written[side]["center_mm"], rel=1e-9, abs=1e-9)
            assert mine[side]["radius_mm"] == written[side]["radius_mm"]
        assert porthole.place(str(f)).type is porthole.PortType.DOME  # read back by the port reader
    right = ours.cameras[1]
    assert right.translation_mm == pytest.approx(theirs["cameras"][1]["cam_from_rig"]["translation_mm"], rel=1e-9)
    assert abs(right.baseline_mm - 300) < 0.5
    keys = ("ep_in_dome_x_mm", "ep_in_dome_y_mm", "ep_in_dome_z_mm")
    for cam, t in zip(ours.to_dict()["rig"]["cameras"], theirs["cameras"]):
        p = [cam["port"]["parameters"][k] for k in keys]
        assert p == pytest.approx([t["port"]["parameters"][k] for k in keys], rel=1e-9)
        sigma = [cam["port"]["sigma"][k] for k in keys]
        for v, s, true in zip(p, sigma, (0.4, 1.0, 5.4)):  # 8 frames: the bound is the estimate's own 3 sigma
            assert abs(v - true) < 3 * s, (p, sigma)
        assert cam["port"]["air"]["n_images"] == t["port"]["air"]["n_images"] == 8
    with pytest.raises(ValueError, match="^air_detections"):  # one camera's air images for two cameras
        porthole.calibrate_rig([det["water", "cam0"], det["water", "cam1"]], target, pixel_pitch_mm=0.029,
                               port="nimar-ni320", air_detections=[det["air", "cam0"]])
    # Air images at another focus (air_refocused=True), as --air-refocused: the renders are of one focus, so
    # each camera's factor is 1 within 3 sigma, and equal to the CLI's.
    ours = porthole.calibrate_rig([det["water", "cam0"], det["water", "cam1"]], target, pixel_pitch_mm=0.029,
                                  port="nimar-ni320", air_detections=[det["air", "cam0"], det["air", "cam1"]],
                                  air_refocused=True)
    theirs = cli_json("calibrate", "--detections", files["water", "cam0"], "--detections", files["water", "cam1"],
                      "--pixel-pitch-mm", "0.029", "--port", "nimar-ni320", "--air-detections",
                      f"{files['air', 'cam0']},{files['air', 'cam1']}", "--air-refocused", "--quiet")["rig"]
    for cam, t in zip(ours.to_dict()["rig"]["cameras"], theirs["cameras"]):
        air = cam["port"]["air"]
        print(f"rig renders, refocused air images: focal scale {air['focal_scale']:.5f} +- {air['focal_scale_sigma']:.5f}")
        assert air["refocused"] is True and abs(air["focal_scale"] - 1) < 3 * air["focal_scale_sigma"]
        assert air["focal_scale"] == pytest.approx(t["port"]["air"]["focal_scale"], rel=1e-9)


def test_an_air_calibration_rig_file_as_the_cli(tmp_path):
    """Issue 25: calibrate_rig(air_calibration=RIG_FILE) reads the rig file camera by camera as
    `calibrate --air-calibration RIG_FILE` does (calib::CalibrateRigJob; before, Python took the one
    file as one camera's calibration and refused the count): the same cam_from_rig and pupils (1e-6
    mm) as the CLI's JSON, each lens's prior from its camera of the file. One rig file with a
    pitch per camera is refused naming the keyword, as the CLI refuses it."""
    cams = stereo(n=8)
    files = []
    for c, name in zip(cams, ("left", "right")):
        files.append(tmp_path / f"{name}.json")
        files[-1].write_text(json.dumps({"target": TARGET, "images": c}))
    in_air = porthole.calibrate_rig(cams, TARGET, model="opencv")
    rig_file = tmp_path / "in-air-rig.json"
    rig_file.write_text(json.dumps(in_air.to_dict()))
    ours = porthole.calibrate_rig(cams, TARGET, model="opencv", port="nimar-ni320", air_calibration=rig_file,
                                  names=["left.json", "right.json"])
    theirs = cli_json("calibrate", "--detections", files[0], "--detections", files[1], "--model", "opencv",
                      "--port", "nimar-ni320", "--air-calibration", rig_file, "--quiet")["rig"]
    # In-air frames modelled behind a dome are a weakly determined fit: its last digits follow the
    # solver's memory layout (two runs of one binary differ by up to 1e-7 relative), so equal to
    # 1e-6 mm, four orders below the pupils' sigma (~0.04 mm).
    keys = ("ep_in_dome_x_mm", "ep_in_dome_y_mm", "ep_in_dome_z_mm")
    for cam, t in zip(ours.to_dict()["rig"]["cameras"], theirs["cameras"]):
        assert cam["cam_from_rig"]["translation_mm"] == pytest.approx(t["cam_from_rig"]["translation_mm"], rel=0,
                                                                      abs=1e-6)
        assert [cam["port"]["parameters"][k] for k in keys] == pytest.approx(
            [t["port"]["parameters"][k] for k in keys], rel=0, abs=1e-6)
        assert all(s > 1e-3 for s in (cam["port"]["sigma"][k] for k in keys))
    with pytest.raises(ValueError, match="^air_calibration: one rig file with a pitch per camera"):
        porthole.calibrate_rig(cams, TARGET, model="opencv", pixel_pitch_mm=[0.0055, 0.0044], port="nimar-ni320",
                               air_calibration=rig_file)


def test_datum_and_free_port_are_refused():
    # calibrate_refractive()'s free_port: a rig does not take it (it was ignored by the CLI's rig): a one-line
    # ValueError naming the keyword. datum is a free target's, as calibrate()'s.
    cams = stereo(n=4)
    with pytest.raises(ValueError) as e:
        porthole.calibrate_rig(cams, TARGET, model="opencv", free_port="none", port="nimar-ni320")
    assert str(e.value) == "free_port: not with a rig (several cameras) yet", str(e.value)
    with pytest.raises(ValueError, match="^datum: is the datum of a free target: give it with target_free"):
        porthole.calibrate_rig(cams, TARGET, model="opencv", datum="minimal")
    r = porthole.calibrate_rig(cams, TARGET, model="opencv", target_free=True, datum="minimal")
    assert r.to_dict()["rig"]["target_adjusted"]["datum"]["fixed"]
