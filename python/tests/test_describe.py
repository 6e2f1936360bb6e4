"""The one port JSON (issue 25, ports/describe.h): PortSystem.describe() is the `port` block the CLI
prints (`porthole virtual-image --json`) for every shape of the port list, and its geometry is the
preset file's (read here with tomllib), moved to the housing frame when the file is in the cam frame
(the pupil at (0, 0, 26.9) mm)."""
import tomllib
from pathlib import Path

import pytest

import porthole
from test_notebook import cli_json

PRESETS = Path(__file__).resolve().parents[2] / "presets" / "ports"
EP = [0.0, 0.0, 26.9]


@pytest.mark.parametrize("name", ["nimar-ni320", "flat-acrylic-10mm", "generic-cylinder-acrylic-4in"])
def test_describe_is_the_clis_port_block_and_the_files_geometry(name):
    ours = porthole.place(name).describe()
    theirs = cli_json("virtual-image", "--port", name)["port"]
    assert ours == theirs
    toml = tomllib.loads((PRESETS / f"{name}.toml").read_text())
    shift = EP if toml["frame"] == "cam" else [0.0, 0.0, 0.0]
    moved = lambda p: pytest.approx([a + b for a, b in zip(p, shift)], abs=1e-12)
    assert ours["type"] == toml["type"] and ours["name"] == name and ours["material"] == toml["material"]
    if toml["type"] == "dome":
        for side in ("outer", "inner"):
            assert ours[side]["center_mm"] == moved(toml[side]["center_mm"])
            assert ours[side]["radius_mm"] == toml[side]["radius_mm"]
    elif toml["type"] == "flat":
        assert ours["inner_point_mm"] == moved(toml["inner_point_mm"])
        assert ours["normal"] == pytest.approx(toml["normal"], abs=1e-15)
        assert ours["thickness_mm"] == toml["thickness_mm"]
    else:
        assert ours["axis_point_mm"] == moved(toml["axis_point_mm"])
        assert ours["axis"] == pytest.approx(toml["axis"], abs=1e-15)
        assert (ours["inner_radius_mm"], ours["outer_radius_mm"]) == (toml["inner_radius_mm"], toml["outer_radius_mm"])


def test_the_port_json_holds_every_field_of_the_file(tmp_path):
    """The port JSON's shape fields are the port file's (ports::GeometryJson reads the shape's Fields): a dome's
    rim_z_mm, which the JSON once left out, moved to the housing frame with the pupil."""
    f = tmp_path / "rim-dome.toml"
    f.write_text('name = "rim-dome"\ntype = "dome"\nframe = "cam"\nmaterial = "n-bk7"\nrim_z_mm = -5.0\n'
                 '[outer]\ncenter_mm = [0, 0, 0]\nradius_mm = 83.4\n[inner]\ncenter_mm = [0, 0, 0]\nradius_mm = 75.7\n')
    ours = porthole.place(str(f)).describe()
    assert ours["rim_z_mm"] == pytest.approx(-5.0 + EP[2], abs=1e-12)
    assert ours["outer"] == {"center_mm": pytest.approx(EP, abs=1e-12), "radius_mm": 83.4}
    assert ours == cli_json("virtual-image", "--port", f)["port"]
    # Without a rim the key is left out (an unset optional), as the file leaves it out.
    assert "rim_z_mm" not in porthole.place("nimar-ni320").describe()
