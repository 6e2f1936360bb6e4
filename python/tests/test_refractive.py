"""Proves porthole.calibrate(..., port=...) is the refractive calibration of `porthole calibrate
--port`: the same lens and port (values to 1e-9 relative, sigma to 1e-6) as the CLI's JSON for the
same detections and air calibration, returned as typed results (RefractiveCalibration with a
PortCalibration: floats, PortType, the estimated PortSpec), and errors naming the keyword.
(The sample's right-camera images stand in for water images: this checks the binding, not the
optics; calib_refractive_test checks the estimates on synthetic water images.)"""
import json
import math

import pytest

import porthole
from test_notebook import cli_json, sample  # noqa: F401 (fixture)

TARGET = "chessboard:9x6:25"


@pytest.fixture(scope="module")
def inputs(sample, tmp_path_factory):
    d = tmp_path_factory.mktemp("refractive")
    water = porthole.detect(sample / "water", TARGET)
    (d / "water.json").write_text(json.dumps(water.to_dict()))
    air = porthole.calibrate_images(sample / "air", TARGET)
    air.save(d / "air.json")
    return d, water, air


def test_refractive_calibration_matches_the_cli(inputs):
    d, water, air = inputs
    # The dome with the in-air calibration as a prior; the flat port with the lens free and the
    # water index adjusted (these in-air images put it near 1/1.341: the images say "air").
    for port, extra in (("generic-dome-4in", {"air_calibration": air, "air_lens_bare": True}),
                        ("flat-acrylic-10mm", {"free_water_index": True})):
        ours = porthole.calibrate(water, TARGET, port=port, **extra)
        flags = ["--free-water-index"] if "free_water_index" in extra else [
            "--air-calibration", d / "air.json", "--air-lens-bare"]
        theirs = cli_json("calibrate", "--detections", d / "water.json", "--port", port, "--quiet", *flags)
        assert isinstance(ours, porthole.RefractiveCalibration) and isinstance(ours, porthole.Calibration)
        p = ours.port
        assert isinstance(p, porthole.PortCalibration)
        assert p.type is (porthole.PortType.FLAT if port.startswith("flat") else porthole.PortType.DOME)
        assert p.intrinsics == ("free" if "free_water_index" in extra else "prior")
        t = theirs["port"]
        assert list(p.params) == list(t["parameters"])
        for key, value in t["parameters"].items():
            assert isinstance(p.params[key], float)
            assert p.params[key] == pytest.approx(value, rel=1e-9, abs=1e-12), (port, key)
            assert p.sigma[key] == pytest.approx(t["sigma"][key], rel=1e-6), (port, key)
            assert p.predicted[key] == pytest.approx(t["predicted"][key], rel=1e-12), (port, key)
        for key, value in theirs["camera"].items():
            if value is not None:
                assert ours.params[key] == pytest.approx(value, rel=1e-9), (port, key)
        assert p.chi2 == pytest.approx(t["chi2"], rel=1e-6)
        assert p.model_choice.preferred == t["model_choice"]["preferred"]
        assert p.central_prediction.available is t["central_prediction"]["available"]
        assert p.n_water == pytest.approx(t["shell"]["n_water"], rel=1e-12)
        if "free_water_index" in extra:
            assert p.shell.free == ["water_index_factor"]
            assert p.shell.parameters.water_index_factor == pytest.approx(
                t["shell"]["parameters"]["water_index_factor"], rel=1e-9)
            assert p.shell.sigma.water_index_factor > 0
        # The estimated port is a PortSpec (--port-out's file) and the whole result the CLI's JSON.
        assert ('type = "flat"' if port.startswith("flat") else 'type = "dome"') in p.estimated_port.to_toml()
        assert ours.to_dict()["port"]["parameters"].keys() == t["parameters"].keys()
        assert not math.isnan(ours.sigma0_px)


def test_air_calibration_as_a_file_and_errors_name_the_keyword(inputs):
    d, water, air = inputs
    a = porthole.calibrate(water, TARGET, port="flat-acrylic-10mm", air_calibration=d / "air.json",
                           air_lens_bare=True, intrinsics="fixed", compare_central=False)
    b = porthole.calibrate(water, TARGET, port="flat-acrylic-10mm", air_calibration=air,
                           air_lens_bare=True, intrinsics="fixed", compare_central=False)
    assert a.port.params == b.port.params
    assert a.port.central_prediction.available is False
    with pytest.raises(ValueError, match="^free_port"):
        porthole.calibrate(water, TARGET, port="flat-acrylic-10mm", free_port="ep_x")
    with pytest.raises(ValueError, match="^intrinsics"):
        porthole.calibrate(water, TARGET, port="flat-acrylic-10mm", intrinsics="fixed")
    with pytest.raises(ValueError, match="^free_shell"):
        porthole.calibrate(water, TARGET, port="flat-acrylic-10mm", free_shell=True)
    with pytest.raises(ValueError, match="^port"):
        porthole.calibrate(water, TARGET, port="no-such-port")
    with pytest.raises(TypeError):
        porthole.calibrate(water, TARGET, port="flat-acrylic-10mm", free_index=True)


def test_air_detections_through_the_port_match_the_cli(sample, inputs, tmp_path):
    """Issue 26: air detections (the housing on) adjusted with the water ones, as `--air-detections`;
    an air calibration made with the housing on, as `--air-calibration`; bad keywords named."""
    d, water, air = inputs
    air_dets = porthole.detect(sample / "air", TARGET)
    (tmp_path / "air_dets.json").write_text(json.dumps(air_dets.to_dict()))
    ours = porthole.calibrate(water, TARGET, port="generic-dome-4in", air_detections=air_dets, compare_central=False)
    theirs = cli_json("calibrate", "--detections", d / "water.json", "--air-detections", tmp_path / "air_dets.json",
                      "--port", "generic-dome-4in", "--quiet")
    for key, value in theirs["port"]["parameters"].items():
        assert ours.port.params[key] == pytest.approx(value, rel=1e-9, abs=1e-12), key
    assert ours.to_dict()["port"]["air"]["n_images"] == theirs["port"]["air"]["n_images"] == len(air_dets.images)
    # An air calibration made with the housing on (the default reading), as the CLI takes it.
    ours = porthole.calibrate(water, TARGET, port="generic-dome-4in", air_calibration=air)
    theirs = cli_json("calibrate", "--detections", d / "water.json", "--air-calibration", d / "air.json",
                      "--port", "generic-dome-4in", "--quiet")
    for key, value in theirs["port"]["parameters"].items():
        assert ours.port.params[key] == pytest.approx(value, rel=1e-9, abs=1e-12), key
    assert ours.to_dict()["port"]["air"]["air_calibration_taken_as"] == "through_port"
    with pytest.raises(ValueError, match="^intrinsics"):  # held fixed it would be taken as the lens
        porthole.calibrate(water, TARGET, port="generic-dome-4in", air_calibration=air, intrinsics="fixed")
    with pytest.raises(ValueError, match="^air_lens_bare"):
        porthole.calibrate(water, TARGET, port="generic-dome-4in", air_lens_bare=True)
    # A lens refocused between the sets (air_refocused), as `--air-refocused`.
    ours = porthole.calibrate(water, TARGET, port="generic-dome-4in", air_detections=air_dets, air_refocused=True,
                              compare_central=False)
    theirs = cli_json("calibrate", "--detections", d / "water.json", "--air-detections", tmp_path / "air_dets.json",
                      "--port", "generic-dome-4in", "--air-refocused", "--quiet")
    for key in ("focal_scale", "focal_scale_sigma"):
        assert ours.to_dict()["port"]["air"][key] == pytest.approx(theirs["port"]["air"][key], rel=1e-9), key
    with pytest.raises(ValueError, match="^air_refocused"):
        porthole.calibrate(water, TARGET, port="generic-dome-4in", air_refocused=True)


def test_a_free_target_behind_the_port_matches_the_cli(sample, inputs, tmp_path):
    """Issue 26: target_free=True behind a port, as `--free-target --port`: the same port and adjusted
    points (1e-9 relative) and their sigma as the CLI's JSON; a datum without target_free refused."""
    d, water, air = inputs
    air_dets = porthole.detect(sample / "air", TARGET)
    (tmp_path / "air_dets.json").write_text(json.dumps(air_dets.to_dict()))
    ours = porthole.calibrate(water, TARGET, port="generic-dome-4in", air_detections=air_dets, target_free=True,
                              compare_central=False)
    theirs = cli_json("calibrate", "--detections", d / "water.json", "--air-detections", tmp_path / "air_dets.json",
                      "--port", "generic-dome-4in", "--free-target", "--quiet")
    for key, value in theirs["port"]["parameters"].items():
        assert ours.port.params[key] == pytest.approx(value, rel=1e-9, abs=1e-12), key
    mine = ours.to_dict()["target_adjusted"]
    assert mine["datum"] == theirs["target_adjusted"]["datum"] and len(mine["points"]) == 54
    for a, b in zip(mine["points"], theirs["target_adjusted"]["points"]):
        assert a["xyz_mm"] == pytest.approx(b["xyz_mm"], rel=1e-9, abs=1e-9)
        assert a["sigma_mm"] == pytest.approx(b["sigma_mm"], rel=1e-6, abs=1e-12)
    with pytest.raises(ValueError, match="^datum"):
        porthole.calibrate(water, TARGET, port="generic-dome-4in", datum="minimal")
