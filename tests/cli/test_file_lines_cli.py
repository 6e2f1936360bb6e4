"""Proves every TOML and JSON input names the file and the line of a bad value (issue 12): for each
kind of file porthole reads, a value of the wrong type on a known line N gives one error line with
"file:N:" and the key. nlohmann::json keeps no positions for values, so JSON lines come from
porthole's own scan of the text (core/input.h, JsonPathLine)."""
import json

from conftest import run_bad
from test_fit_cli import paper_args


def lines_with(text, needle):
    """1-based line numbers of `text` that contain `needle`."""
    return [i + 1 for i, line in enumerate(text.splitlines()) if needle in line]


def write(path, text):
    path.write_text(text)
    return path


CALIBRATION = {
    "model": "brown",
    "camera": {"c_mm": 25.801, "x0_mm": -0.026, "y0_mm": -0.144, "K1": 1.842e-4, "K2": -3.03e-7},
    "sigma": {"c_mm": 0.006, "x0_mm": 0.002, "y0_mm": 0.003, "K1": 1.2e-6, "K2": 7.4e-9},
    "sensor": {"width_px": 4288, "height_px": 2848, "pixel_pitch_mm": 0.0055},
}


def test_calibration_json_wrong_type_names_its_line(tmp_path):
    bad = json.loads(json.dumps(CALIBRATION))
    bad["camera"]["K1"] = "large"
    text = json.dumps(bad, indent=2)
    f = write(tmp_path / "air.json", text)
    (n,) = lines_with(text, '"K1": "large"')
    good = write(tmp_path / "good.json", json.dumps(CALIBRATION, indent=2))
    # Read by compare and report (calib/result_json.cc) ...
    line = run_bad("compare", good, f)
    assert f"{f}:{n}:" in line and "camera.K1" in line, line
    # ... and by simulate (camera/json.cc).
    line = run_bad("simulate", "--air-calibration", f)
    assert f"{f}:{n}:" in line and "camera.K1" in line, line
    # A pixel count that is not a whole number: the line of sensor.width_px.
    bad = json.loads(json.dumps(CALIBRATION))
    bad["sensor"]["width_px"] = 4288.5
    text = json.dumps(bad, indent=2)
    f = write(tmp_path / "w.json", text)
    (n,) = lines_with(text, '"width_px"')
    line = run_bad("compare", good, f)
    assert f"{f}:{n}:" in line and "width_px" in line, line


def test_brown_json_names_its_line(tmp_path):
    # The hand-written form (docs/camera-model.md): a negative sigma on line 4.
    text = '{\n  "c_mm": 25.8,\n  "K1": 1.8e-4,\n  "sigma": {"c_mm": -0.1}\n}\n'
    f = write(tmp_path / "brown.json", text)
    line = run_bad("simulate", "--air-calibration", f)
    assert f"{f}:4:" in line and "sigma.c_mm" in line, line
    text = '{\n  "c_mm": 25.8,\n  "k1": 1.8e-4\n}\n'  # a typo: unknown key on line 3
    f = write(tmp_path / "typo.json", text)
    line = run_bad("simulate", "--air-calibration", f)
    assert f"{f}:3:" in line and "k1" in line, line


def test_detections_json_names_its_line(tmp_path):
    images = [{"image": f"im{i}.png", "width_px": 640, "height_px": 480, "ids": [0, 1],
               "points_px": [[10.0, 20.0], [30.0, 40.0]]} for i in range(4)]
    images[2]["points_px"][1] = [30.0, "forty"]
    text = '{"target": "chessboard:9x6:25", "images": [\n' + ",\n".join(json.dumps(im) for im in images) + "\n]}\n"
    f = write(tmp_path / "dets.json", text)
    (n,) = lines_with(text, '"forty"')
    line = run_bad("calibrate", "--detections", f)
    assert f"{f}:{n}:" in line and "points_px[1]" in line, line
    # The same with the images one per file in a folder.
    folder = tmp_path / "dets"
    folder.mkdir()
    for i, im in enumerate(images):
        write(folder / f"{i}.json", json.dumps(im, indent=1))
    line = run_bad("calibrate", "--detections", folder)
    (n,) = lines_with((folder / "2.json").read_text(), '"forty"')
    assert f"2.json:{n - 2}:" in line and "points_px[1]" in line, line  # the pair opens two lines up


def test_fit_json_names_its_line(tmp_path):
    text = json.dumps({"shape": "sphere", "center_mm": [0.0, 0.0, 84.0], "radius_mm": "83.4",
                       "usable": True}, indent=2)
    f = write(tmp_path / "outer.json", text)
    (n,) = lines_with(text, '"radius_mm"')
    args = paper_args()
    i = args.index("--outer")
    line = run_bad("assemble", *args[:i + 1], f, *args[i + 2:], "--pupil-offset", 26.9, "-o", tmp_path / "p.toml")
    assert f"{f}:{n}:" in line and "radius_mm" in line, line


def test_port_toml_names_its_line(tmp_path):
    base = ['name = "p"', 'type = "flat"', 'frame = "cam"', 'material = "pmma"', "thickness_mm = 10.0",
            "inner_point_mm = [0.0, 0.0, 20.0]"]
    for key, value, n in (("type", '"cube"', 2), ("frame", '"sideways"', 3), ("material", '"cheese"', 4),
                          ("thickness_mm", '"ten"', 5)):
        lines = [f"{key} = {value}" if line.startswith(key + " ") else line for line in base]
        f = write(tmp_path / f"{key}.toml", "\n".join(lines) + "\n")
        line = run_bad("flat", "--port", f)
        assert f"{f}:{n}:" in line and key in line, line
