"""Proves Python's calibrate and calibrate_refractive run the CLI's one-camera steps (calib/job.h,
issue 25): without pixel_pitch_mm the refractive calibration takes the pitch its in-air porthole JSON
states, as `porthole calibrate --port --air-calibration` does (issue 23), giving the CLI's port and
lens; the datum needs target_free, as the CLI's --datum needs --free-target; the notes of the JSON
name keywords, never flags."""
import json

import pytest

import porthole
from test_notebook import cli_json, sample  # noqa: F401 (fixture)

TARGET = "chessboard:9x6:25"
PITCH = 0.0055  # the sample's camera (scripts/sample-data)


def strings(value):
    if isinstance(value, str):
        yield value
    elif isinstance(value, dict):
        for v in value.values():
            yield from strings(v)
    elif isinstance(value, list):
        for v in value:
            yield from strings(v)


def test_the_air_calibrations_pitch_is_taken_as_the_cli_takes_it(sample, tmp_path):
    water = porthole.detect(sample / "water", TARGET)
    (tmp_path / "water.json").write_text(json.dumps(water.to_dict()))
    air = porthole.calibrate_images(sample / "air", TARGET, pixel_pitch_mm=PITCH)
    air.save(tmp_path / "air.json")
    ours = porthole.calibrate(water, TARGET, port="generic-dome-4in", air_calibration=tmp_path / "air.json",
                              air_lens_bare=True)
    assert ours.pixel_pitch_mm == pytest.approx(PITCH, rel=1e-12)
    theirs = cli_json("calibrate", "--detections", tmp_path / "water.json", "--port", "generic-dome-4in",
                      "--air-calibration", tmp_path / "air.json", "--air-lens-bare", "--quiet")
    assert theirs["sensor"]["pixel_pitch_mm"] == pytest.approx(PITCH, rel=1e-12)
    for key, value in theirs["port"]["parameters"].items():
        assert ours.port.params[key] == pytest.approx(value, rel=1e-9, abs=1e-12), key
    for key, value in theirs["camera"].items():
        if value is not None:
            assert ours.params[key] == pytest.approx(value, rel=1e-9), key
    raw = porthole._porthole.calibrate_refractive(water.to_dict()["images"], TARGET, "generic-dome-4in",
                                                  air_calibration=str(tmp_path / "air.json"), air_lens_bare=True)[0]
    note = raw["port"]["air_calibration"]
    assert "the bare lens (air_lens_bare=)" in note and "exact" in note
    assert not any("--" in s or "`" in s for s in strings(raw)), [s for s in strings(raw) if "--" in s or "`" in s]


def test_a_datum_needs_target_free(sample):
    water = porthole.detect(sample / "water", TARGET)
    with pytest.raises(ValueError, match="datum: is the datum of a free target: give it with target_free"):
        porthole.calibrate(water, TARGET, datum="minimal")


def test_calibrate_images_is_the_jobs_search(sample, tmp_path):
    # calibrate_images(folder) hands the folder to the job (as `porthole calibrate --images`) rather than
    # composing detect() and calibrate(): the same calibration as that composition, air and behind a port.
    thin = porthole.calibrate_images(sample / "air", TARGET, pixel_pitch_mm=PITCH)
    composed = porthole.calibrate(porthole.detect(sample / "air", TARGET, for_calibration=True), TARGET,
                                  pixel_pitch_mm=PITCH)
    print(f"c_mm {thin.params['c_mm']:.6f} (composed {composed.params['c_mm']:.6f}), rms {thin.rms_px:.4f} px")
    assert thin.n_images == composed.n_images > 0 and thin.n_points == composed.n_points
    for key, value in composed.params.items():
        assert thin.params[key] == pytest.approx(value, rel=1e-12, abs=1e-18), key
    assert thin.to_dict()["images_source"]["kind"] == "directory"  # the job's record of its search
    files = sorted((sample / "air").iterdir())  # a list of files: searched by the job too
    listed = porthole.calibrate_images(files, TARGET, pixel_pitch_mm=PITCH)
    assert listed.n_images == thin.n_images
    for key, value in composed.params.items():
        assert listed.params[key] == pytest.approx(value, rel=1e-12, abs=1e-18), key
    thin.save(tmp_path / "air.json")
    port = dict(port="generic-dome-4in", air_calibration=tmp_path / "air.json", air_lens_bare=True)
    water = porthole.calibrate_images(sample / "water", TARGET, **port)
    composed = porthole.calibrate(porthole.detect(sample / "water", TARGET, for_calibration=True), TARGET, **port)
    assert isinstance(water, porthole.RefractiveCalibration)
    for key, value in composed.port.params.items():
        assert water.port.params[key] == pytest.approx(value, rel=1e-12, abs=1e-15), key
    # Errors name calibrate_images' keywords; calibrate() of detections takes no search options.
    with pytest.raises(ValueError, match="^images: "):
        porthole.calibrate_images(tmp_path / "missing", TARGET)
    with pytest.raises(ValueError, match="^images: no image files given"):
        porthole.calibrate_images([], TARGET)
    with pytest.raises(ValueError, match="^every: for a folder or a video, not a list of files"):
        porthole.calibrate_images(files, TARGET, every=2)
    with pytest.raises(ValueError, match="^every: searches images"):
        porthole.calibrate(composed_detections := porthole.detect(sample / "air", TARGET), TARGET, every=2)
    assert composed_detections.images
