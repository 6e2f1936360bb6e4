"""Proves porthole.measure() is `porthole measure` (issue 27): on a rig from calibrate_rig() (a
stereo pair projected by cv2.projectPoints), the same points and lengths with the same sigma (1e-9
relative) as the CLI's JSON for the same rig file and detections, from detections per camera or from
(frame, camera, id, u_px, v_px) tuples; typed results (Measurement of MeasuredPoint and
MeasuredLength); errors naming the keyword."""
import json

import numpy as np
import pytest

import porthole
from test_notebook import cli_json
from test_rig import TARGET, stereo


def test_measure_matches_the_cli(tmp_path):
    cams = stereo()
    rig = porthole.calibrate_rig(cams, TARGET, model="opencv", names=["left.json", "right.json"])
    (tmp_path / "rig.json").write_text(json.dumps(rig.to_dict()))
    files = []
    for c, name in zip(cams, ("left", "right")):
        files.append(tmp_path / f"{name}.json")
        files[-1].write_text(json.dumps({"target": TARGET, "images": c}))
    ours = porthole.measure(rig, cams, lengths=[(0, 15)], sigma_px=0.3, skip_unpaired=True)
    theirs = cli_json("measure", "--rig", tmp_path / "rig.json", "--points", files[0], "--points", files[1],
                      "--length", "0,15", "--sigma-px", "0.3", "--skip-unpaired")["measure"]
    assert isinstance(ours, porthole.Measurement)
    assert len(ours.points) == len(theirs["points"]) > 100
    for p, q in zip(ours.points, theirs["points"]):
        assert isinstance(p, porthole.MeasuredPoint)
        assert (p.frame, p.id) == (q["frame"], q["id"])
        assert p.x_mm == pytest.approx(q["x_mm"], rel=1e-9)
        assert p.sigma_mm == pytest.approx(q["sigma_mm"], rel=1e-9)
        assert p.covariance_mm2.shape == (3, 3)
    assert len(ours.lengths) == len(theirs["lengths"]) > 5
    for a, b in zip(ours.lengths, theirs["lengths"]):
        assert isinstance(a, porthole.MeasuredLength)
        assert a.length_mm == pytest.approx(b["length_mm"], rel=1e-9)
        assert a.sigma_mm == pytest.approx(b["sigma_mm"], rel=1e-9)
        assert abs(a.length_mm - 750) < 5 * a.sigma_mm  # 15 squares of 50 mm
    # The scale-bar check: as the CLI's.
    bar = porthole.measure(rig, cams, sigma_px=0.3, skip_unpaired=True, scale_bar=(0, 15, 750.0)).scale_bar
    cli_bar = cli_json("measure", "--rig", tmp_path / "rig.json", "--points", files[0], "--points", files[1],
                       "--sigma-px", "0.3", "--skip-unpaired", "--scale-bar", "0,15,750")["measure"]["scale_bar"]
    assert bar.mean_error_mm == pytest.approx(cli_bar["mean_error_mm"], rel=1e-9)
    assert bar.consistent == cli_bar["consistent"]
    with pytest.warns(porthole.PortholeWarning, match="does not hold"):
        porthole.measure(rig, cams, sigma_px=0.3, skip_unpaired=True, scale_bar=(0, 15, 760.0))
    # The same points as tuples, camera by name and by index.
    tuples = [(im["image"].rsplit(".", 1)[0], name, i, u, v)
              for name, c in zip(("left.json", "1"), cams) for im in c[:2]
              for i, (u, v) in zip(im["ids"], im["points_px"])]
    again = porthole.measure(tmp_path / "rig.json", tuples, sigma_px=0.3, skip_unpaired=True)
    first = {(p.frame, p.id): p for p in ours.points}
    assert len(again.points) > 50
    for p in again.points:
        assert p.x_mm == pytest.approx(first[(p.frame, p.id)].x_mm, rel=1e-12)


def test_errors_name_the_keyword(tmp_path):
    cams = stereo(n=6)
    rig = porthole.calibrate_rig(cams, TARGET, model="opencv")
    im = cams[0][0]
    one = [(im["image"], "camera0", im["ids"][0], *im["points_px"][0])]
    with pytest.raises(ValueError, match="^points: .*seen by camera0 only.*`?skip_unpaired`? skips"):
        porthole.measure(rig, one)
    with pytest.raises(ValueError, match="^points: .*no camera middle in the rig"):
        porthole.measure(rig, [(im["image"], "middle", 0, 10.0, 10.0)])
    with pytest.raises(ValueError, match="^sigma_px"):
        porthole.measure(rig, one, sigma_px=-1)
    with pytest.raises(ValueError, match="^lengths: 100000,9: id 100000 is not measured"):
        porthole.measure(rig, cams, lengths=[(100000, 9)], skip_unpaired=True)


def test_plan_rig_matches_the_cli(tmp_path):
    ours = porthole.plan_rig(baseline_mm=300, convergence_deg=5, port="nimar-ni320", ranges_mm=[1000, 3000])
    theirs = cli_json("plan", "--baseline", "300", "--convergence", "5", "--port", "nimar-ni320",
                      "--ranges", "1000,3000")["rig_plan"]
    # The same JSON (numbers within 1e-9 relative, or 1e-6 absolute: the central calibration's last
    # digits vary between processes (threaded sums), and its length errors of a few um are differences
    # of lengths near 300 mm, so 1e-9 of those lengths is what they can agree to).
    def same(a, b):
        if isinstance(a, dict):
            assert a.keys() == b.keys()
            for k in a:
                same(a[k], b[k])
        elif isinstance(a, list):
            assert len(a) == len(b)
            for x, y in zip(a, b):
                same(x, y)
        elif isinstance(a, float):
            assert a == pytest.approx(b, rel=1e-9, abs=1e-6)
        else:
            assert a == b
    same(ours.to_dict(), theirs)
    assert ours.central_model.compared
    cams = stereo(n=8)
    rig = porthole.calibrate_rig(cams, TARGET, model="opencv")
    with pytest.warns(porthole.PortholeWarning, match="no camera is behind a port"):
        plan = porthole.plan_rig(rig=rig, ranges_mm=[1500])
    assert "the rig calibration" in plan.sigma_holds
    with pytest.raises(ValueError, match="^rig: give a rig"):
        porthole.plan_rig()
    with pytest.raises(ValueError, match="^central_range_mm"):
        porthole.plan_rig(baseline_mm=300, central_range_mm=-1)


def test_one_camera_and_a_plane_as_the_cli(tmp_path):
    cams = stereo(n=8)
    one = porthole.calibrate(cams[0], TARGET, model="opencv")
    (tmp_path / "one.json").write_text(json.dumps(one.to_dict()))
    im = cams[0][0]
    pts = [("f", 0, i, u, v) for i, (u, v) in zip(im["ids"][:5], im["points_px"][:5])]
    (tmp_path / "p.csv").write_text("".join(f"{f},{c},{i},{u!r},{v!r}\n" for f, c, i, u, v in pts))
    ours = porthole.measure(one.to_dict(), pts, range_mm=1500, plane_sigma_mm=5, sigma_px=0.3,
                            lengths=[(im["ids"][0], im["ids"][4])])
    theirs = cli_json("measure", "--rig", tmp_path / "one.json", "--points", tmp_path / "p.csv", "--range-mm", "1500",
                      "--plane-sigma-mm", "5", "--sigma-px", "0.3", "--length", f"{im['ids'][0]},{im['ids'][4]}")
    assert ours.to_dict()["measure"]["points"] == theirs["measure"]["points"]
    assert ours.lengths[0].sigma_mm == pytest.approx(theirs["measure"]["lengths"][0]["sigma_mm"], rel=1e-12)
    assert all(p.x_mm[2] == pytest.approx(1500) for p in ours.points)
    with pytest.raises(ValueError, match="^plane: give"):
        porthole.measure(one.to_dict(), pts, plane=[0, 0, 1])
    with pytest.raises(ValueError, match="^camera: goes with plane"):
        porthole.measure(one.to_dict(), pts, camera="0")


def test_laser_pair_as_the_cli(tmp_path):
    cams = stereo(n=8)
    one = porthole.calibrate(cams[0], TARGET, model="opencv")
    (tmp_path / "one.json").write_text(json.dumps(one.to_dict()))
    im = cams[0][0]
    pts = [("f", 0, i, u, v) for i, (u, v) in zip(im["ids"][:6], im["points_px"][:6])]
    (tmp_path / "p.csv").write_text("".join(f"{f},{c},{i},{u!r},{v!r}\n" for f, c, i, u, v in pts))
    a, b = im["ids"][0], im["ids"][5]
    ours = porthole.measure(one.to_dict(), pts, laser_pair=(a, b, 250.0), sigma_px=0.3)
    theirs = cli_json("measure", "--rig", tmp_path / "one.json", "--points", tmp_path / "p.csv", "--laser-pair",
                      f"{a},{b},250", "--sigma-px", "0.3")["measure"]
    assert ours.to_dict()["measure"]["laser_ranges"] == theirs["laser_ranges"]
    assert ours.to_dict()["measure"]["points"] == theirs["points"]
    with pytest.raises(ValueError, match="^plane: give one of"):
        porthole.measure(one.to_dict(), pts, laser_pair=(a, b, 250.0), range_mm=1000)
