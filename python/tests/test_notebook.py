"""Proves the Python package serves a notebook (issue 12): typed results (floats with math.inf,
numpy arrays, enums), the version and docstrings, errors naming the Python keyword, and a whole
calibration done from Python — detect, calibrate from images, sphere and dome fits, the virtual-image
table, the report — each checked against closed forms, synthetic truth or the CLI's own JSON."""
import inspect
import json
import math
import os
import re
import subprocess
import sys

import numpy as np
import pytest

import porthole

BIN = os.environ.get("PORTHOLE_BIN", "porthole")
ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
DATA = os.environ.get("PORTHOLE_TEST_DATA_DIR", os.path.join(ROOT, "tests", "data"))


def cli(*args):
    proc = subprocess.run([BIN, *map(str, args)], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout


def cli_json(*args):
    return json.loads(cli(*args, "--json"))


def walk(value, path="result"):
    """Every leaf of a typed result, with its path."""
    if isinstance(value, porthole.Record):
        for name in value.fields():
            yield from walk(getattr(value, name), f"{path}.{name}")
    elif isinstance(value, porthole.Table):
        for name, col in value.columns().items():
            yield from walk(col, f"{path}.{name}")
    elif isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            yield from walk(v, f"{path}[{i}]")
    else:
        yield path, value


# --- types ------------------------------------------------------------------------------------

def test_version_is_the_cli_version():
    assert re.fullmatch(r"\d+\.\d+\.\d+", porthole.__version__)
    assert cli("--version").split()[-1] == porthole.__version__


def test_every_public_function_and_class_has_a_docstring():
    missing = []
    for name in porthole.__all__:
        obj = getattr(porthole, name)
        if callable(obj) and not (obj.__doc__ or "").strip():
            missing.append(name)
        if inspect.isclass(obj):
            for attr, member in vars(obj).items():
                if not attr.startswith("_") and (callable(member) or isinstance(member, property)):
                    if not (member.__doc__ or "").strip():
                        missing.append(f"{name}.{attr}")
    assert not missing, missing


def test_infinity_is_math_inf_never_a_string():
    p = porthole.plan(port="nimar-ni320", subject_distance_mm=1000)
    raw = json.dumps(p.to_dict())
    assert '"inf"' in raw  # the CLI's JSON writes infinity as "inf" ...
    leaves = list(walk(p))
    assert not [path for path, v in leaves if isinstance(v, str) and v in ("inf", "-inf")]
    # ... and the object holds floats: the far limit of the depth of field at the hyperfocal focus.
    infinite = [path for path, v in leaves if isinstance(v, float) and math.isinf(v)]
    infinite += [path for path, v in leaves if isinstance(v, np.ndarray) and v.dtype.kind == "f" and np.isinf(v).any()]
    assert infinite
    t = porthole.virtual_image_table(port="nimar-ni320-nominal", water_index=1.341)
    assert t.wd_mm[-1] == math.inf and isinstance(t.d_s2ep_mm, np.ndarray)
    f = porthole.flat()
    assert isinstance(f.max_fov_deg, float)


def test_statuses_and_kinds_are_enums():
    dome = porthole.place("nimar-ni320")
    assert dome.type is porthole.PortType.DOME and porthole.load_port("flat-acrylic-10mm").type is porthole.PortType.FLAT
    # A ray aimed beyond the dome's rim comes back OUTSIDE_APERTURE, one along the axis OK.
    o = np.tile(dome.ep_in_housing_mm, (2, 1))
    d = np.array([[0, 0, 1], [1, 0, -0.2]], float)
    out = dome.trace_out(o, d)
    assert porthole.RayStatus(out.status[0]) is porthole.RayStatus.OK
    assert porthole.RayStatus(out.status[1]) is not porthole.RayStatus.OK
    assert [m.name for m in porthole.camera_models()] == [m.value for m in porthole.CameraModel]
    # Both enums are built from the C++ lists (no line per shape or model in Python): str-valued,
    # found by value, named in upper case with '_' for '-'.
    assert porthole.port_shapes() == [t.value for t in porthole.PortType]
    assert porthole.port_shapes()[:3] == ["dome", "flat", "cylinder"]  # a new shape comes after these
    assert porthole.PortType("cylinder") is porthole.PortType.CYLINDER and porthole.PortType.DOME == "dome"
    assert porthole.CameraModel("kannala-brandt") is porthole.CameraModel.KANNALA_BRANDT
    assert isinstance(porthole.CameraModel.BROWN, str) and porthole.PortType.__module__ == "porthole._results"


def test_results_are_typed_objects_with_numpy_arrays():
    s = porthole.simulate(port="nimar-ni320-nominal", ep_offset_mm=(0, 0, 5), grid_cols=9, grid_rows=7)
    assert isinstance(s, porthole.Simulation) and isinstance(s.water.c_mm, float)
    prof = s.radial_profile
    assert isinstance(prof, porthole.Table) and isinstance(prof.columns()[prof.fields()[0]], np.ndarray)
    # The dict the CLI prints is kept: to_dict() is `porthole simulate --json`.
    cli_out = cli_json("simulate", "--port", "nimar-ni320-nominal", "--ep-offset", "0,0,5", "--grid-cols", 9,
                       "--grid-rows", 7)
    assert s.to_dict()["water"]["c_mm"] == pytest.approx(cli_out["water"]["c_mm"], rel=1e-12)


# --- errors -----------------------------------------------------------------------------------

def keywords(f):
    """Keyword names of a function, from its signature line."""
    line = (f.__doc__ or "").split("\n")[0]
    return set(re.findall(r"(\w+):", line))


@pytest.mark.parametrize("call, kwargs", [
    (porthole.plan, dict(f_number=64)),
    (porthole.plan, dict(lens="no-such-lens")),
    (porthole.plan, dict(camera="no-such-camera")),
    (porthole.plan, dict(port="no-such-port")),
    (porthole.plan, dict(lens="Nikon AF-S DX Nikkor 18-300mm f/3.5-6.3G ED VR")),
    (porthole.flat, dict(wd_mm=-5)),
    (porthole.simulate, dict(focus_distance_mm=-1)),
    (porthole.simulate, dict(sweep_axis="w")),
    (porthole.index, dict(medium="seawater", lambda_nm=1500)),
    (porthole.fit_sphere, dict(points=np.zeros((3, 3)))),
    (porthole.fit_sphere, dict(points=np.eye(3) * 5 + 1, threshold_mm=0)),
    (porthole.analyze_dome, dict(outer_points=np.random.default_rng(1).normal(size=(50, 3)), inner_points=np.zeros((2, 3)))),
    (porthole.detect, dict(images="/no/such/folder", target="chessboard:9x6:25")),
    (porthole.detect, dict(images=[], target="chessboard:9x6:25")),
    (porthole.report, dict(out="/proc/no-such-dir/x", f_number=8)),
    (porthole.plan, dict(water="milk")),
    (porthole.place, dict(port="nimar-ni320", water="milk")),
    (porthole.calibrate, dict(detections=[], target="chessboard:9x6:25", pixel_pitch_mm=-1)),
    (porthole.synthetic_detections, dict(camera={"c_mm": 26}, width_px=0, height_px=2848, pixel_pitch_mm=0.0055)),
    (porthole.simulate, dict(air_calibration={"camera": {"c_mm": "x"}})),
])
def test_errors_name_the_python_keyword(call, kwargs):
    with pytest.raises(ValueError) as e:
        call(**kwargs)
    field = str(e.value).split(":")[0]
    assert field.split(".")[0].split("[")[0] in keywords(call), (str(e.value), keywords(call))


# --- a calibration from a notebook --------------------------------------------------------------

@pytest.fixture(scope="module")
def sample(tmp_path_factory):
    d = tmp_path_factory.mktemp("sample")
    subprocess.run([sys.executable, os.path.join(ROOT, "scripts", "sample-data"), str(d)], check=True,
                   capture_output=True)
    return d


@pytest.fixture(scope="module")
def cli_detections(sample):
    """`porthole detect --out-dir` on the sample's air images: one JSON file per image."""
    out = sample / "cli-detections"
    cli("detect", "--images", sample / "air", "--target", "chessboard:9x6:25", "--out-dir", out, "--quiet")
    return out


def test_detect_matches_the_cli(sample, cli_detections):
    ours = porthole.detect(sample / "air", "chessboard:9x6:25")
    assert isinstance(ours, porthole.DetectionSet) and len(ours) >= 10
    theirs = {}
    for f in cli_detections.glob("*.json"):
        d = json.loads(f.read_text())
        theirs[d["image"]] = d
    assert sorted(theirs) == sorted(d.image for d in ours)
    for d in ours:
        t = theirs[d.image]
        assert d.ids.dtype.kind == "i" and d.points_px.shape == (len(t["ids"]), 2)
        np.testing.assert_array_equal(d.ids, t["ids"])
        np.testing.assert_allclose(d.points_px, t["points_px"], atol=1e-9)


def render_board(h, size=(960, 720), cols=10, rows=7, square_px=40):
    """An 8-bit chessboard image warped by homography h (board px -> image px), and the true image
    positions of its (cols-1) x (rows-1) inner corners, row-major."""
    cv2 = pytest.importorskip("cv2")
    s = 8  # supersampling: the board drawn at 8x and the warp integrates it
    board = np.full(((rows + 2) * square_px * s, (cols + 2) * square_px * s), 255, np.uint8)
    for r in range(rows):
        for c in range(cols):
            if (r + c) % 2 == 0:
                y, x = (r + 1) * square_px * s, (c + 1) * square_px * s
                board[y:y + square_px * s, x:x + square_px * s] = 0
    # Drawn and warped at s times the resolution, then averaged over s x s blocks (area sampling).
    # Pixel centres: hi-res x_hi = s x + (s - 1) / 2 for image and board pixels alike.
    up = np.array([[s, 0, (s - 1) / 2], [0, s, (s - 1) / 2], [0, 0, 1]], float)
    hi = cv2.warpPerspective(board, up @ h @ np.linalg.inv(up), (size[0] * s, size[1] * s), flags=cv2.INTER_LINEAR,
                             borderValue=255)
    img = cv2.resize(hi, size, interpolation=cv2.INTER_AREA)
    corners = []
    for r in range(1, rows):
        for c in range(1, cols):
            p = h @ np.array([(c + 1) * square_px - 0.5, (r + 1) * square_px - 0.5, 1.0])
            corners.append(p[:2] / p[2])
    return img, np.array(corners)


def test_detect_finds_rendered_corners(tmp_path):
    cv2 = pytest.importorskip("cv2")
    h = np.array([[1.4, 0.15, 140.0], [-0.08, 1.3, 90.0], [1e-4, 2e-4, 1.0]])
    img, truth = render_board(h)
    cv2.imwrite(str(tmp_path / "board.png"), img)
    found = porthole.detect([tmp_path / "board.png"], "chessboard:9x6:30")
    assert len(found) == 1 and not found.skipped
    d = found.images[0]
    assert (d.width_px, d.height_px) == (960, 720)
    # The nearest true corner of each found one (a 9x6 board reads the same turned by 180 degrees).
    err = np.min(np.linalg.norm(d.points_px[:, None, :] - truth[None, :, :], axis=2), axis=1)
    assert len(err) == len(truth)
    print(f"rendered board: corner error max {err.max():.3f} px, rms {np.sqrt((err ** 2).mean()):.3f} px")
    assert err.max() < 0.1


def test_calibrate_from_images_matches_the_cli(sample, cli_detections, tmp_path):
    ours = porthole.calibrate_images(sample / "air", "chessboard:9x6:25", pixel_pitch_mm=0.0055)
    assert isinstance(ours, porthole.Calibration) and ours.status is porthole.Status.OK
    theirs = cli_json("calibrate", "--detections", cli_detections, "--target", "chessboard:9x6:25",
                      "--pixel-pitch-mm", "0.0055", "--quiet")
    for key, value in theirs["camera"].items():
        if value is None:
            assert ours.params[key] == 0.0 and math.isnan(ours.sigma[key])
        else:
            assert ours.params[key] == pytest.approx(value, rel=1e-9, abs=1e-15), key
            assert ours.sigma[key] == pytest.approx(theirs["sigma"][key], rel=1e-6), key
    assert ours.rms_px == pytest.approx(theirs["rms_px"], rel=1e-9)
    # The calibration saved from Python is read by the CLI (compare: itself, no difference).
    ours.save(tmp_path / "air.json")
    same = cli_json("compare", tmp_path / "air.json", tmp_path / "air.json")
    assert same["significant"] is False
    assert porthole.load_calibration(tmp_path / "air.json").params == ours.params


def sphere_points(center, radius, n, sigma, seed, cap_deg=80):
    """n points on a spherical cap (about +Z, half-angle cap_deg) with Gaussian radial noise sigma."""
    rng = np.random.default_rng(seed)
    z = rng.uniform(math.cos(math.radians(cap_deg)), 1, n)
    phi = rng.uniform(0, 2 * math.pi, n)
    r = np.sqrt(1 - z ** 2)
    u = np.stack([r * np.cos(phi), r * np.sin(phi), z], 1)
    return np.asarray(center) + u * (radius + rng.normal(0, sigma, n))[:, None]


def test_fit_sphere_recovers_truth_and_matches_the_cli(tmp_path):
    pts = sphere_points((1.0, -2.0, 30.0), 160.0, 4000, 0.05, seed=3)
    s = porthole.fit_sphere(pts)
    assert s.status is porthole.Status.OK and isinstance(s.center_mm, np.ndarray)
    assert abs(s.radius_mm - 160.0) < 4 * s.sigma_radius_mm
    assert np.all(np.abs(s.center_mm - (1.0, -2.0, 30.0)) < 4 * s.sigma_center_mm)
    assert s.sigma0_mm == pytest.approx(0.05, rel=0.05) and s.residuals_mm.shape == (4000,)
    np.savetxt(tmp_path / "cap.xyz", pts, fmt="%.9f")
    theirs = cli_json("fit", "sphere", tmp_path / "cap.xyz")
    from_file = porthole.fit_sphere(tmp_path / "cap.xyz")
    assert from_file.radius_mm == pytest.approx(theirs["radius_mm"], rel=1e-12)
    np.testing.assert_allclose(from_file.center_mm, theirs["center_mm"], rtol=1e-12, atol=1e-12)
    assert from_file.sigma_radius_mm == pytest.approx(theirs["sigma_radius_mm"], rel=1e-9)


def test_analyze_dome_recovers_the_shell():
    # The paper's Table 3: outer 160.3 mm, inner 152.6 mm, centres 1.3 mm apart.
    outer = sphere_points((0, 0, 0), 160.3, 3000, 0.05, seed=4)
    inner = sphere_points((0.0, 1.3, 0.0), 152.6, 3000, 0.05, seed=5)
    d = porthole.analyze_dome(outer, inner, nominal_outer_radius_mm=160, nominal_thickness_mm=7.5)
    assert d.status is porthole.Status.OK
    assert abs(d.thickness_mm - 7.7) < 4 * d.sigma_thickness_mm
    assert abs(d.center_distance_mm - 1.3) < 4 * d.sigma_center_distance_mm
    assert d.min_wall_mm == pytest.approx(d.thickness_mm - d.center_distance_mm, abs=1e-12)
    assert d.outer_radius_deviation_mm == pytest.approx(d.outer.radius_mm - 160, abs=1e-12)


def test_assemble_gives_table4_and_the_cli(tmp_path):
    # The paper's Table 4 (housing frame) and Table 3 radii: Section 3.4 says the pupil lies 5.4 mm
    # ahead of the dome centre and about 1 mm off its axis.
    outer, inner, flange = (-0.4, -1.0, 21.5, 83.4), (-0.4, -1.5, 20.3, 75.7), (-0.4, -1.0, 34.3, 0, 0, 1)
    a = porthole.assemble(outer=outer, inner=inner, housing_flange=flange, lens="nikkor-24mm-f2.8d", focus_mm=300)
    assert isinstance(a, porthole.HousingAssembly) and isinstance(a.entrance_pupil_mm, np.ndarray)
    assert a.pupil_ahead_of_outer_mm == pytest.approx(5.4, abs=1e-9)
    assert 0.9 < a.pupil_off_axis_outer_mm < 1.2 and a.thickness_mm == pytest.approx(7.7)
    np.testing.assert_allclose(a.entrance_pupil_mm, [0, 0, 26.9], atol=1e-12)  # Table 2: D_EP2F 26.9 mm
    assert a.port.type is porthole.PortType.DOME
    # The CLI on the same numbers: the same JSON and the same as-built port file.
    fmt = lambda v: ",".join(f"{x:g}" for x in v)  # noqa: E731
    theirs = cli_json("assemble", "--outer", fmt(outer), "--inner", fmt(inner), "--housing-flange", fmt(flange),
                      "--lens", "nikkor-24mm-f2.8d", "--focus", 300, "-o", tmp_path / "p.toml", "--name", "as-built")
    assert set(theirs) - set(a.fields()) == {"lens", "focus_mm", "port_file"}  # the CLI echoes its options
    for key, value in theirs.items():
        if key not in a.fields():
            continue
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            assert getattr(a, key) == pytest.approx(value, rel=1e-12, abs=1e-12), key
        elif isinstance(value, list):
            np.testing.assert_allclose(getattr(a, key), value, rtol=1e-12, atol=1e-12)
    assert a.port.to_toml() == (tmp_path / "p.toml").read_text()
    # The as-built port plans as the CLI's plan of the file it wrote.
    assert porthole.plan(port=a.port, wd_mm=1000).to_dict() == cli_json("plan", "--port", tmp_path / "p.toml",
                                                                        "--wd", 1000)
    # A sphere fit can be given directly; a missing pupil names its keyword.
    fit = porthole.fit_sphere(sphere_points(outer[:3], outer[3], 2000, 0.0, seed=6))
    b = porthole.assemble(outer=fit, inner=inner, housing_flange=flange, pupil_to_flange_mm=26.9)
    assert b.outer_radius_mm == pytest.approx(83.4, abs=1e-6)
    with pytest.raises(ValueError, match="^pupil_to_flange_mm:"):
        porthole.assemble(outer=outer, inner=inner, housing_flange=flange)
    with pytest.raises(ValueError, match="^inner:"):
        porthole.assemble(outer=outer, inner=(0, 0, 0, 90), housing_flange=flange, pupil_to_flange_mm=26.9)


def test_virtual_image_table_is_table5_and_the_cli():
    t = porthole.virtual_image_table(port="nimar-ni320-nominal", water_index=1.341)
    with open(os.path.join(DATA, "menna2016_table5.csv")) as f:
        rows = [r.split(",") for r in f if r[0].isdigit() or r.startswith("inf")]
    for wd, d, v in ((float(r[0]), float(r[1]), float(r[2])) for r in rows):
        i = int(np.where(t.wd_mm == wd)[0][0])
        assert abs(t.d_s2ep_mm[i] - d) <= 0.2 and abs(t.vwd_mm[i] - v) <= 0.2, wd
    theirs = cli_json("virtual-image", "--port", "nimar-ni320-nominal", "--water-index", "1.341")
    for i, row in enumerate(theirs["rows"]):
        for key in ("d_s2ep_mm", "vwd_mm", "d_s2ep_real_mm", "spherical_aberration_mm", "magnification"):
            assert getattr(t, key)[i] == pytest.approx(float(row[key]), rel=1e-12, abs=1e-12), key
    assert t.focal.efl_water_mm == pytest.approx(float(theirs["focal"]["efl_water_mm"]), rel=1e-12)


def test_report_from_python_is_the_cli_report(sample, tmp_path):
    cal = porthole.load_calibration(sample / "paper-air.json")
    s = porthole.report(tmp_path / "py", air_calibration=cal)
    assert isinstance(s, porthole.ReportSummary) and os.path.exists(s.index_html)
    cli_out = cli_json("report", "--air-calibration", sample / "paper-air.json", "--out", tmp_path / "cli")
    assert list(s.figures) == cli_out["figures"]
    with open(s.report_json) as f:
        ours = json.load(f)
    with open(cli_out["report_json"]) as f:
        theirs = json.load(f)
    # Every number of the page is the CLI's (the options echoed differ: Python says it was called).
    ours.pop("inputs"), theirs.pop("inputs")
    assert json.dumps(ours, sort_keys=True) == json.dumps(theirs, sort_keys=True)
    assert cal.params["c_mm"] == 25.801  # the paper's Table 6, in air


# --- installation -----------------------------------------------------------------------------

def test_make_install_puts_the_package_where_python3_finds_it(tmp_path):
    build = os.environ.get("PORTHOLE_BUILD_DIR")
    if not build:
        pytest.skip("PORTHOLE_BUILD_DIR not set (run by ctest)")
    home = tmp_path / "home"
    env = dict(os.environ, HOME=str(home))
    env.pop("PYTHONPATH", None)
    # ~/.local is the user base: python3 finds the user site without PYTHONPATH.
    subprocess.run(["cmake", "--install", build, "--prefix", str(home / ".local")], check=True, env=env,
                   capture_output=True)
    found = subprocess.run(["/usr/bin/python3", "-c", "import porthole; print(porthole.__file__, porthole.__version__)"],
                           cwd=tmp_path, env=env, capture_output=True, text=True, check=True).stdout.split()
    assert found[0].startswith(str(home / ".local")) and found[1] == porthole.__version__
    assert os.access(home / ".local" / "bin" / "porthole", os.X_OK)
    # The default prefix /usr/local maps to a directory on python3's own path.
    d = subprocess.run(["/usr/bin/python3", os.path.join(ROOT, "python", "install_dir.py"), "/usr/local"],
                       capture_output=True, text=True, check=True).stdout.strip()
    path = subprocess.run(["/usr/bin/python3", "-c", "import sys; print('\\n'.join(sys.path))"], env=env,
                          capture_output=True, text=True, check=True).stdout.split()
    assert d in path
