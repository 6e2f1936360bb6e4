"""Proves `porthole render` from the command line: a PNG and its ground truth appear together, the
ground truth is readable by the commands that follow (its camera by compare's reader, its points
where OpenCV's detector finds the corners), a set is laid out for `detect`, and bad scenes get one
line, exit 2 and no file at all."""
import json
import math
import os

import pytest

from conftest import run, run_bad

SMALL = ["--pixel-pitch-mm", "0.029", "--spp", "4", "--quiet"]  # an 814 x 540 px D300


def test_render_writes_the_image_and_its_ground_truth(tmp_path):
    png = tmp_path / "board.png"
    summary = run("render", "--out", png, "--tilt", "15,-10", "--roll", "5", "--distance", "1200", "--color", "rgb",
                  "--bit-depth", "16", "--json", *SMALL).json()
    assert summary["points"] == 54 and summary["truth"].endswith("board.json")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    truth = json.loads((tmp_path / "board.json").read_text())
    assert truth["image"] == "board.png" and truth["bit_depth"] == 16 and truth["color"] == "rgb"
    assert [b["channel"] for b in truth["bands"]] == ["blue", "green", "red"]
    # Sea water disperses: the blue index above the red one.
    assert truth["bands"][0]["n_water"] > truth["bands"][2]["n_water"]
    assert len(truth["points"]) == 54 and all(len(p["px"]) == 3 for p in truth["points"])
    assert truth["focus"]["on"] == "target" and truth["camera"]["model"] == "brown"
    # The detector finds the corners where the ground truth puts them.
    det = run("detect", "--images", tmp_path, "--target", truth["target"], "--json", "--quiet").json()
    found = det["images"][0]
    gt = {p["id"]: p["px"][1] for p in truth["points"]}
    # One numbering for render and detect (docs/calibration.md): detected id k is rendered id k.
    err = [math.dist(uv, gt[i]) for i, uv in zip(found["ids"], found["points_px"])]
    assert max(err) < 0.3


@pytest.mark.parametrize("roll", ["0", "90", "180", "-90"])
def test_detect_numbers_the_corners_as_render_does_at_any_roll(tmp_path, roll):
    # OpenCV's chessboard search starts from either end of the board; the colour of the square past
    # corner 0 decides (a 9 x 6 board is not symmetric under a half turn), so the ids agree at every roll.
    png = tmp_path / "board.png"
    run("render", "--out", png, f"--roll={roll}", "--tilt", "10,5", "--distance", "1200", "--json", *SMALL)
    truth = json.loads((tmp_path / "board.json").read_text())
    det = run("detect", "--images", tmp_path, "--target", truth["target"], "--json", "--quiet").json()
    found = det["images"][0]
    gt = {p["id"]: p["px"][1] for p in truth["points"]}
    assert len(found["ids"]) == 54
    assert max(math.dist(uv, gt[i]) for i, uv in zip(found["ids"], found["points_px"])) < 0.3


def test_edge_samples_and_vignetting_are_recorded(tmp_path):
    png = tmp_path / "v.png"
    summary = run("render", "--out", png, "--distance", "1500", "--edge-spp", "64", "--vignetting", "natural",
                  "--vignetting-pa", "-0.2,0,0", "--json", *SMALL).json()
    assert 0 < summary["refined_fraction"] < 0.2
    truth = json.loads((tmp_path / "v.json").read_text())
    assert truth["edge_samples_per_pixel"] == 64 and truth["refined_fraction"] == summary["refined_fraction"]
    assert truth["vignetting"] == {"natural": True, "pa": [-0.2, 0, 0]}


def test_a_set_is_ready_for_detect(tmp_path):
    out = tmp_path / "set"
    run("render", "--set", "3", "--out", out, "--target", "chessboard:7x5:40", "--f-number", "inf", *SMALL)
    for medium in ("water", "air"):
        names = sorted(os.listdir(out / medium))
        assert names == [f"pose_{i:03d}.{ext}" for i in range(3) for ext in ("json", "png")]
    water = json.loads((out / "water" / "pose_001.json").read_text())
    air = json.loads((out / "air" / "pose_001.json").read_text())
    assert water["pose"] == air["pose"] and water["medium"] == "water" and air["medium"] == "air"
    assert water["focus"]["focus_distance_mm"] == air["focus"]["focus_distance_mm"]
    det = run("detect", "--images", out / "water", "--target", "chessboard:7x5:40", "--json", "--quiet").json()
    assert len(det["images"]) == 3


def test_bad_scenes_fail_cleanly(tmp_path):
    png = tmp_path / "x.png"
    assert "behind the camera" in run_bad("render", "--out", png, "--distance", "-500", *SMALL)
    assert "outside the image" in run_bad("render", "--out", png, "--shift", "900,0", "--distance", "1200", *SMALL)
    assert "into the port" in run_bad("render", "--out", png, "--distance", "60", "--focus", "1000", *SMALL)
    assert "--spp" in run_bad("render", "--out", png, "--pixel-pitch-mm", "0.029", "--spp", "5")
    assert "--bit-depth" in run_bad("render", "--out", png, "--bit-depth", "12", *SMALL)
    assert "--out" in run_bad("render", "--out", tmp_path / "x.jpg", *SMALL)
    assert "--noise" in run_bad("render", "--out", png, "--noise", "0,3", *SMALL)
    # A dome whose glass starts beyond its own vertex: no ray can leave the housing.
    port = tmp_path / "blind.toml"
    port.write_text('name = "blind"\ntype = "dome"\nframe = "cam"\nmaterial = "n-bk7"\nrim_z_mm = 95\n'
                    '[outer]\ncenter_mm = [0, 0, 0]\nradius_mm = 100\n[inner]\ncenter_mm = [0, 0, 0]\nradius_mm = 92\n')
    assert "--port" in run_bad("render", "--out", png, "--port", port, "--distance", "1200", "--focus", "1000", *SMALL)
    assert "--distances" in run_bad("render", "--set", "2", "--out", tmp_path / "set", "--distances", "900,500", *SMALL)
    assert "--f-number" in run_bad("render", "--out", png, "--f-number", "0", *SMALL)
    assert "--edge-spp" in run_bad("render", "--out", png, "--edge-spp", "50", *SMALL)
    assert "--vignetting" in run_bad("render", "--out", png, "--vignetting", "cos4", *SMALL)
    assert "--vignetting-pa" in run_bad("render", "--out", png, "--vignetting-pa", "-2,0,0", *SMALL)
    assert list(tmp_path.glob("x.*")) == [] and not (tmp_path / "set").exists()


def test_a_field_with_raised_targets(tmp_path):
    # A coded field file: four targets on the board, one raised 30 mm toward the camera on a plate
    # right over target 1 (face on, it hides it), an uncoded dot (id 600: AICON 14-bit has 516 codes).
    field = tmp_path / "field.txt"
    field.write_text("# id x y z (mm)\n1 0 0 0\n2 0 0 -30\n3 80 0 0\n4 0 60 0\n5 80 60 -20\n600 40 30 0\n")
    png = tmp_path / "f.png"
    summary = run("render", "--out", png, "--target", "coded:14:3", "--field", field, "--distance", "600",
                  "--focus", "1000", "--f-number", "inf", "--json", *SMALL).json()
    assert summary["points"] == 5 and summary["left_out_occluded"] == 1 and summary["left_out_partial"] == 0
    truth = json.loads((tmp_path / "f.json").read_text())
    assert sorted(p["id"] for p in truth["points"]) == [2, 3, 4, 5, 600]
    assert truth["left_out"] == {"partial": [], "occluded": [1]}
    assert {p["id"]: p["target_mm"] for p in truth["points"]}[2] == [0, 0, -30]
    assert sorted(d["id"] for d in truth["dot_centres"]) == [2, 3, 4, 5, 600]
    det = run("detect", "--images", tmp_path, "--target", "coded:14:3", "--json", "--quiet").json()
    assert sorted(det["images"][0]["ids"]) == [2, 3, 4, 5]
    bad = tmp_path / "bad.txt"
    bad.write_text("1 0 0\n")
    assert "--field" in run_bad("render", "--out", tmp_path / "b.png", "--target", "coded:14:3", "--field", bad, *SMALL)
    assert "--field" in run_bad("render", "--out", tmp_path / "b.png", "--field", field, *SMALL)  # a chessboard
    assert list(tmp_path.glob("b.*")) == []
    # Partial views are for coded targets only.
    assert "--partial" in run_bad("render", "--set", "2", "--out", tmp_path / "set", "--partial", "0.5", *SMALL)
    assert not (tmp_path / "set").exists()


def test_a_set_of_partial_views_of_a_coded_sheet(tmp_path):
    # Close enough that the sheet overflows the frame: each pose shows at least 60 % of its targets
    # whole, the rest are left out of the truth; `detect` reads every target of the truth, and of the
    # others only some the frame cuts close to (the truth asks half a dot radius of band round the
    # ring inside the frame, the detector samples 0.35 of it).
    out = tmp_path / "set"
    run("render", "--set", "2", "--out", out, "--target", "coded:14:3", "--partial", "0.6", "--distances", "300,400",
        "--f-number", "inf", *SMALL)
    det = run("detect", "--images", out / "water", "--target", "coded:14:3", "--json", "--quiet").json()
    assert len(det["images"]) == 2
    for image in det["images"]:
        truth = json.loads((out / "water" / os.path.basename(image["image"])).with_suffix(".json").read_text())
        assert truth["left_out"]["partial"], "not a partial view"
        assert 0.6 * 70 <= len(truth["points"]) < 70
        kept = {p["id"] for p in truth["points"]}
        assert kept <= set(image["ids"])
        assert set(image["ids"]) - kept <= set(truth["left_out"]["partial"])
