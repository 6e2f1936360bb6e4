"""`porthole detect` counts what the coded detector skipped (issue 16: "damaged, partial and
look-alike targets are skipped with a count, never a wrong ID"): on a field rendered by
`porthole render --field` with a known content — six coded targets, three plain dots (uncoded
IDs), and one target whose ID the field given to `detect` leaves out — the per-image
`coded_counts` and `uncoded_counts` of `--json`, the table's summary lines, `--out-dir`'s files and
Python's `porthole.detect` all give those numbers."""
import json
import os
import sys

import pytest

from conftest import run

CAMERA = ["--pixel-pitch-mm", "0.0145", "--spp", "4", "--f-number", "inf", "--medium", "air", "--quiet"]
CODED = {1: (0, 0), 2: (60, 0), 3: (120, 0), 4: (0, 60), 5: (60, 60), 6: (120, 60)}
PLAIN = {1001: (30, 30), 1002: (90, 30), 1003: (30, -30)}  # AICON 14-bit has 516 codes: these are uncoded


def write_field(path, ids):
    lines = ["# id x_mm y_mm z_mm"]
    for i, (x, y) in {**CODED, **PLAIN}.items():
        if i in ids:
            lines.append(f"{i} {x} {y} 0")
    path.write_text("\n".join(lines) + "\n")


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    d = tmp_path_factory.mktemp("counts")
    images = d / "images"
    images.mkdir()
    write_field(d / "all.txt", set(CODED) | set(PLAIN))
    write_field(d / "no6.txt", (set(CODED) - {6}) | set(PLAIN))  # target 6 is printed, not listed
    run("render", "--out", images / "face.png", "--target", "coded:14:5", "--field", d / "all.txt",
        "--distance", 700, "--focus", 1000, *CAMERA)
    truth = json.loads((images / "face.json").read_text())
    assert sorted(p["id"] for p in truth["points"]) == sorted(set(CODED) | set(PLAIN))  # all seen whole
    return d


def test_counts_in_json_and_table(scene):
    det = run("detect", "--images", scene / "images", "--target", "coded:14:5", "--field", scene / "no6.txt",
              "--json", "--quiet").json()
    image = det["images"][0]
    c = image["coded_counts"]
    assert c["decoded"] == 6 and c["not_in_target"] == 1  # 6 decoded: 1-5 and 6, which the field lacks
    assert c["no_ring"] == 3  # the plain dots: no ring, skipped by the decoder (matched below)
    assert c["partial"] == c["unclear"] == c["impossible"] == c["duplicate"] == 0
    assert c["candidates"] >= c["decoded"] + c["no_ring"]
    assert image["uncoded_counts"]["matched"] == 3 and image["uncoded_counts"]["in_view"] == 3
    assert sorted(image["ids"]) == [1, 2, 3, 4, 5, 1001, 1002, 1003]
    table = run("detect", "--images", scene / "images", "--target", "coded:14:5", "--field", scene / "no6.txt").out
    assert ("coded candidates skipped: 0 cut by the frame, 3 without a ring (plain dots, look-alikes), 0 unclear, "
            "0 impossible codes, 0 duplicate IDs; 1 decoded IDs not in the field") in table
    assert "uncoded dots: 3 matched of 3 in view" in table


def test_out_dir_files_carry_the_counts(scene, tmp_path):
    run("detect", "--images", scene / "images", "--target", "coded:14:5", "--field", scene / "all.txt",
        "--out-dir", tmp_path, "--quiet")
    one = json.loads((tmp_path / "face.json").read_text())
    assert one["coded_counts"]["decoded"] == 6 and one["coded_counts"]["not_in_target"] == 0
    assert one["uncoded_counts"]["matched"] == 3


def test_python_detect_gives_the_same_counts(scene):
    sys.path.insert(0, os.environ.get("PORTHOLE_PY_DIR", ""))
    porthole = pytest.importorskip("porthole")
    cli = run("detect", "--images", scene / "images", "--target", "coded:14:5", "--field", scene / "no6.txt",
              "--json", "--quiet").json()["images"][0]
    py = porthole.detect(str(scene / "images"), "coded:14:5", field=str(scene / "no6.txt")).images[0]
    assert py.coded_counts == cli["coded_counts"]
    assert py.uncoded_counts == cli["uncoded_counts"]
    assert py.to_dict()["coded_counts"] == cli["coded_counts"]
