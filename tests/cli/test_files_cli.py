"""Proves that no command loses a user's file (issue 24, reproducers 1-5; issue 23's overwrite rule and
path printing): outputs write into devices and FIFOs and through symlinks without replacing them, never
replace an input or a file another command wrote for another purpose, replace an existing file only with
--force, never mix two render sets, clean up only their own temporaries, and print non-UTF-8 names in
JSON without failing. Devices and FIFOs are made in a temporary folder, never a system path."""
import json
import os
import stat
import threading

import pytest

from conftest import run, run_bad

SMALL = ["--pixel-pitch-mm", "0.029", "--spp", "1", "--quiet", "--f-number", "inf"]  # an 814 x 540 px D300
# A Brown calibration of that small D300 (porthole calibration JSON, as calibrate --out writes).
CAL = {"camera": {"c_mm": 24.0, "x0_mm": 0.0, "y0_mm": 0.0, "K1": 1e-4},
       "sensor": {"width_px": 814, "height_px": 540, "pixel_pitch_mm": 0.029}, "note": "the user's calibration"}


def write_cal(path):
    path.write_text(json.dumps(CAL, indent=1) + "\n")
    return path.read_text()


def test_a_device_is_written_into_not_replaced(tmp_path):
    """Reproducer 1: `convert` to the null device as root replaced the device by a regular file."""
    if os.geteuid() != 0:
        pytest.skip("mknod needs root")
    cal = tmp_path / "cal.json"
    write_cal(cal)
    dev = tmp_path / "null.json"
    try:
        os.mknod(dev, stat.S_IFCHR | 0o666, os.makedev(1, 3))
    except PermissionError:
        pytest.skip("mknod refused here")
    run("convert", cal, dev)
    st = os.stat(dev)
    assert stat.S_ISCHR(st.st_mode) and st.st_rdev == os.makedev(1, 3)
    assert sorted(os.listdir(tmp_path)) == ["cal.json", "null.json"]  # no temporary left


def test_a_fifo_is_written_into_not_replaced(tmp_path):
    """Reproducer 1: a FIFO output was replaced by a regular file (the reader never saw the data)."""
    cal = tmp_path / "cal.json"
    write_cal(cal)
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    got = []
    reader = threading.Thread(target=lambda: got.append(open(fifo).read()), daemon=True)
    reader.start()
    res = run("convert", cal, fifo, check=False)
    reader.join(timeout=20)
    assert res.code == 0, res.err
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode), "the FIFO was replaced"
    assert got and json.loads(got[0])["camera"]["c_mm"] == 24.0


def test_a_symlink_is_written_through_to_its_target(tmp_path):
    """Reproducer 1: writing to a symlink replaced the link instead of writing through it."""
    (tmp_path / "real").mkdir()
    target = tmp_path / "real" / "cal.json"
    target.write_text(json.dumps({"camera": {"c_mm": 20.0}, "sensor": CAL["sensor"]}))
    link = tmp_path / "link.json"
    link.symlink_to("real/cal.json")
    cal = tmp_path / "in.json"
    write_cal(cal)
    assert "--force" in run_bad("convert", cal, link)  # an existing file: kept without --force
    run("convert", cal, link, "--force")
    assert os.path.islink(link) and os.readlink(link) == "real/cal.json"
    assert json.loads(target.read_text())["camera"]["c_mm"] == 24.0
    assert sorted(os.listdir(tmp_path / "real")) == ["cal.json"]


def test_an_input_is_never_replaced(tmp_path):
    cal = tmp_path / "cal.json"
    text = write_cal(cal)
    for extra in ([], ["--force"]):
        assert "input" in run_bad("convert", cal, cal, *extra)
    (tmp_path / "alias.json").symlink_to("cal.json")
    assert "input" in run_bad("convert", cal, tmp_path / "alias.json", "--force")
    assert cal.read_text() == text


def test_render_keeps_the_calibration_beside_its_png(tmp_path):
    """Reproducer 2: `render --camera-model d300cal.json --out d300cal.png` overwrote the calibration."""
    cal = tmp_path / "d300cal.json"
    text = write_cal(cal)
    for extra in ([], ["--force"]):
        err = run_bad("render", "--camera-model", cal, "--out", tmp_path / "d300cal.png", *extra, *SMALL)
        assert "input" in err, err
    # Not an input, but a calibration: kept without --force, and even with it (another purpose).
    assert "a porthole calibration" in run_bad("render", "--out", tmp_path / "d300cal.png", *SMALL)
    err = run_bad("render", "--out", tmp_path / "d300cal.png", "--force", *SMALL)
    assert "not a render ground truth" in err, err
    assert cal.read_text() == text
    assert sorted(os.listdir(tmp_path)) == ["d300cal.json"]
    # A render's own ground truth is replaced with --force.
    run("render", "--out", tmp_path / "board.png", *SMALL)
    assert "--force" in run_bad("render", "--out", tmp_path / "board.png", *SMALL)
    run("render", "--out", tmp_path / "board.png", "--distance", "1500", "--force", *SMALL)
    assert json.loads((tmp_path / "board.json").read_text())["pose"]["translation_mm"][2] == pytest.approx(1500)


def test_detect_keeps_the_renders_ground_truth(tmp_path):
    """Reproducer 3: `detect --images DIR --out-dir DIR` on a rendered set replaced its pose_NNN.json."""
    out = tmp_path / "set"
    run("render", "--set", "1", "--out", out, "--target", "chessboard:7x5:40", *SMALL)
    truth = (out / "water" / "pose_000.json").read_text()
    for extra in ([], ["--force"]):
        err = run_bad("detect", "--images", out / "water", "--target", "chessboard:7x5:40", "--out-dir", out / "water",
                      "--quiet", *extra)
        assert "render ground truth" in err, err
    assert (out / "water" / "pose_000.json").read_text() == truth
    run("detect", "--images", out / "water", "--target", "chessboard:7x5:40", "--out-dir", tmp_path / "det", "--quiet")
    assert "--force" in run_bad("detect", "--images", out / "water", "--target", "chessboard:7x5:40",
                                "--out-dir", tmp_path / "det", "--quiet")
    run("detect", "--images", out / "water", "--target", "chessboard:7x5:40", "--out-dir", tmp_path / "det",
        "--quiet", "--force")


def ports_of(folder):
    return sorted((name, json.loads((folder / name).read_text())["port"]["name"])
                  for name in os.listdir(folder) if name.endswith(".json"))


def test_two_render_sets_never_mix(tmp_path):
    """Reproducer 4: a second `render --set` into the same folder mixed flat-port and dome poses."""
    out = tmp_path / "renders"
    run("render", "--set", "3", "--out", out, "--port", "nimar-ni320", "--target", "chessboard:7x5:40", *SMALL)
    (out / "notes.txt").write_text("the user's")
    before = ports_of(out / "water")
    err = run_bad("render", "--set", "2", "--out", out, "--port", "flat-acrylic-10mm", "--target", "chessboard:7x5:40",
                  *SMALL)
    assert "--force" in err, err
    assert ports_of(out / "water") == before
    run("render", "--set", "2", "--out", out, "--port", "flat-acrylic-10mm", "--target", "chessboard:7x5:40",
        "--force", *SMALL)
    for medium in ("water", "air"):
        assert sorted(os.listdir(out / medium)) == ["pose_000.json", "pose_000.png", "pose_001.json", "pose_001.png"]
        assert {port for _, port in ports_of(out / medium)} == {"flat-acrylic-10mm"}
    assert (out / "notes.txt").read_text() == "the user's"  # not the set's: left alone


def test_cleanup_removes_only_its_own_temporaries(tmp_path):
    """Reproducer 5: `.x.json.tmpl` (a folder) and `.x.json.tmp_notes` were deleted by `convert a.json x.json`."""
    cal = tmp_path / "a.json"
    write_cal(cal)
    (tmp_path / ".x.json.tmpl").mkdir()
    (tmp_path / ".x.json.tmpl" / "keep.txt").write_text("mine")
    (tmp_path / ".x.json.tmp_notes").write_text("mine")
    stale = tmp_path / ".x.json.tmp.4242.0123456789abcdef"  # a killed run's, by its exact name
    stale.write_text("half")
    run("convert", cal, tmp_path / "x.json")
    assert (tmp_path / ".x.json.tmpl" / "keep.txt").read_text() == "mine"
    assert (tmp_path / ".x.json.tmp_notes").read_text() == "mine"
    assert not stale.exists()


def test_convert_asks_for_force_like_report(tmp_path):
    """Issue 23: `convert` overwrote an existing file silently where `report` asks for --force."""
    cal = tmp_path / "a.json"
    write_cal(cal)
    run("convert", cal, tmp_path / "b.yml")
    before = (tmp_path / "b.yml").read_text()
    assert "exists: --force replaces it" in run_bad("convert", cal, tmp_path / "b.yml")
    assert (tmp_path / "b.yml").read_text() == before
    run("convert", cal, tmp_path / "b.yml", "--force")


def test_set_paths_are_printed_joined(tmp_path):
    """Issue 23: `render --set … --out renders/` printed `renders//water`."""
    res = run("render", "--set", "1", "--out", str(tmp_path / "renders") + "/", "--target", "chessboard:7x5:40",
              *[a for a in SMALL if a != "--quiet"])
    assert "//" not in res.err, res.err
    assert f"{tmp_path}/renders/water and {tmp_path}/renders/air" in res.err, res.err


def test_non_utf8_names_print_as_json(tmp_path):
    """Issue 24: a file name with byte 0xff broke --json after the output was written (exit 2)."""
    cal = tmp_path / "a.json"
    write_cal(cal)
    out = os.fsdecode(os.fsencode(str(tmp_path)) + b"/x\xff.json")
    res = run("convert", cal, out, "--json")
    assert "\ufffd" in res.json()["out"]
    png = os.fsdecode(os.fsencode(str(tmp_path)) + b"/b\xff.png")
    res = run("render", "--out", png, "--json", *SMALL)
    assert res.json()["image"].endswith("b\ufffd.png")
    assert json.loads((tmp_path / os.fsdecode(b"b\xff.json")).read_text(errors="replace"))["image"] == "b\ufffd.png"


def test_non_utf8_names_in_a_report(tmp_path):
    """Issue 24: a calibration whose file name holds byte 0xff broke `report` (report.json could not be
    written); the name is shown with U+FFFD in report.json and index.html, both valid UTF-8."""
    name = os.fsdecode(os.fsencode(str(tmp_path)) + b"/air\xff.json")
    with open(name, "w") as f:  # the paper's in-air calibration of the D300 + 24 mm (Table 6)
        json.dump({"camera": {"c_mm": 25.801, "x0_mm": -0.026, "y0_mm": -0.144, "K1": 1.842e-4, "K2": -3.030e-7},
                   "sensor": {"width_px": 4288, "height_px": 2848, "pixel_pitch_mm": 0.0055}}, f)
    run("report", "--out", tmp_path / "rep", "--air-calibration", name)
    page = (tmp_path / "rep" / "index.html").read_bytes().decode("utf-8")  # strict: valid UTF-8
    report = json.loads((tmp_path / "rep" / "report.json").read_bytes().decode("utf-8"))
    assert "air\ufffd.json" in page
    assert "air\ufffd.json" in json.dumps(report, ensure_ascii=False)


def test_non_utf8_image_names_in_a_calibration(tmp_path):
    """Issue 24: an image whose name holds byte 0xff made `calibrate --out --json` fail ("input JSON:
    invalid UTF-8 byte") with nothing written; the name is written with U+FFFD."""
    out = tmp_path / "set"
    run("render", "--set", "4", "--out", out, "--target", "chessboard:7x5:40", *SMALL)
    air = os.fsencode(str(out / "air"))
    os.rename(air + b"/pose_000.png", air + b"/p\xff.png")
    res = run("calibrate", "--images", os.fsdecode(air), "--target", "chessboard:7x5:40", "--pixel-pitch-mm", "0.029",
              "--out", tmp_path / "cal.json", "--json", "--quiet")
    names = [im["image"] for im in res.json()["images"]]
    assert any(n.endswith("p\ufffd.png") for n in names), names
    assert any(im["image"].endswith("p\ufffd.png") for im in json.loads((tmp_path / "cal.json").read_text())["images"])
