"""porthole report: every figure in the page and as PNG and SVG, the numbers those of the paper (Table 5, Table 6) and of the libraries, one number for each quantity (equal to `porthole plan`'s), the port drawn where the tracer has glass, sigma bands equal to Monte Carlo, output whole or absent, fast, and the page seen in headless Chromium at 1280 and 700 px with every figure loaded, legible, nothing overflowing and no console errors."""
import json
import math
import os
import re
import sys
import time
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from conftest import read_table, run, run_bad

sys.path.insert(0, os.path.dirname(__file__))
import chromium_check  # noqa: E402

FIGURES = ["port-rays", "virtual-image", "min-wd", "dof", "field-curvature", "dome-vs-flat", "predicted",
           "tolerance", "maps", "residual-map"]
COMPARE_FIGURES = ["compare-curves", "compare-maps"]
SENSOR = {"width_px": 4288, "height_px": 2848, "pixel_pitch_mm": 0.0055}


def table6_calibrations():
    """The paper's Table 6 (value, sigma) as the air and water calibration dictionaries."""
    cals = {k: {"camera": {}, "sigma": {}, "sensor": SENSOR} for k in ("air", "water")}
    for row in read_table("menna2016_table6.csv"):
        for k in cals:
            if row[f"{k}_value"]:
                cals[k]["camera"][row["parameter"]] = float(row[f"{k}_value"])
                cals[k]["sigma"][row["parameter"]] = float(row[f"{k}_std"])
    return cals


@pytest.fixture(scope="module")
def default_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("rep") / "report"
    t0 = time.monotonic()
    res = run("report", "--out", out)
    return out, time.monotonic() - t0, res


@pytest.fixture(scope="module")
def table6_files(tmp_path_factory):
    """The paper's Table 6 as two calibration JSON files (in air, under water)."""
    d = tmp_path_factory.mktemp("t6")
    cals = table6_calibrations()
    paths = {}
    for k, v in cals.items():
        paths[k] = d / f"{k}.json"
        paths[k].write_text(json.dumps(v))
    return paths


def leftovers(parent):
    return [p for p in os.listdir(parent) if ".tmp-" in p]


def test_every_figure_in_page_png_svg(default_report):
    out, _, res = default_report
    assert res.out.strip() == f"report: {out}/index.html ({len(FIGURES)} figures, " + res.out.split("figures, ")[1].strip()
    html = (out / "index.html").read_text()
    assert "<script" not in html  # plain HTML and CSS
    assert html.count("<svg") == len(FIGURES)
    for fid in FIGURES:
        assert f'data-figure="{fid}"' in html, fid
        png = (out / "figures" / f"{fid}.png").read_bytes()
        assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10000, fid
        root = ET.parse(out / "figures" / f"{fid}.svg").getroot()
        assert root.tag.endswith("svg") and len(list(root.iter())) > 50, fid
        script = (out / "figures" / f"{fid}.gp").read_text()
        assert f'data = "{fid}.dat"' in script and "pngcairo" in script and "svg" in script
        assert (out / "figures" / f"{fid}.dat").stat().st_size > 100
    report = json.loads((out / "report.json").read_text())
    assert [f["id"] for f in report["figures"]] == FIGURES
    # Inline SVGs get their ids prefixed so that figures do not share definitions.
    assert html.count("id='gpPt0'") == 0 and "id='port-rays-gpPt0'" in html


def test_virtual_image_rows_reproduce_table5(tmp_path, paper_table5):
    """The nominal NI320 with the paper's water: the report's Table 5 rows are the paper's."""
    out = tmp_path / "r"
    run("report", "--port", "nimar-ni320-nominal", "--water-index", "1.341", "--out", out)
    rows = json.loads((out / "report.json").read_text())["virtual_image"]["rows"]
    assert len(rows) == len(paper_table5)
    for r in rows:
        key = "inf" if r["wd_mm"] == "inf" else str(int(r["wd_mm"]))
        d, v = paper_table5[key]
        assert abs(r["d_s2ep_mm"] - d) <= 0.2 and abs(r["vwd_mm"] - v) <= 0.2, r
    html = (out / "index.html").read_text()
    assert "288.5" in html  # the virtual image of infinity, Table 5's last row


def test_numbers_are_the_libraries(default_report):
    """The report's plan and simulation are those `porthole plan` and `porthole simulate` print."""
    out, _, _ = default_report
    rep = json.loads((out / "report.json").read_text())
    plan = run("plan", "--subject-distance", "1000", "--json").json()
    for key in ("min_wd_mm", "d_s2ep_infinity_mm", "closest_d_s2ep_mm"):
        assert rep["plan"][key] == pytest.approx(plan[key], rel=1e-9), key
    assert rep["plan"]["dof"] == plan["dof"]
    sim = run("simulate", "--json").json()
    assert rep["simulation"]["c_ratio_water_air"] == pytest.approx(sim["c_ratio_water_air"], rel=1e-6)
    assert rep["simulation"]["water"]["K1"] == pytest.approx(sim["water"]["K1"], rel=1e-4)
    # DOF rows: the water depth of field exceeds the air one at every distance (a dome, Section 4).
    for row in rep["depth_of_field"]:
        if row["water"]["total_mm"] != "inf" and row["air"]["total_mm"] != "inf":
            assert row["water"]["total_mm"] > row["air"]["total_mm"], row


def test_comparison_of_table6(tmp_path, table6_files):
    """With the paper's two calibrations: Figs. 14 and 15 and the parameter table with sigma."""
    out = tmp_path / "r"
    run("report", "--air-calibration", table6_files["air"], "--water-calibration", table6_files["water"],
        "--out", out)
    rep = json.loads((out / "report.json").read_text())
    assert [f["id"] for f in rep["figures"]] == FIGURES + COMPARE_FIGURES
    rows = {r["parameter"]: r for r in rep["comparison"]["parameters"]}
    # Published: c 25.801 +- 0.006 in air, 26.208 +- 0.002 under water.
    assert rows["c_mm"]["diff_b_minus_a"] == pytest.approx(0.407, abs=1e-9)
    assert rows["c_mm"]["z"] == pytest.approx(0.407 / (0.006**2 + 0.002**2) ** 0.5, rel=1e-6)
    assert rep["comparison"]["significant"] is True
    # The prediction starts from the in-air calibration: its c is the paper's 25.801 plus the change.
    pred = rep["simulation"]["predicted_water"]["c_mm"]
    change = rep["simulation"]["change"]["c_mm"]
    assert pred == pytest.approx(25.801 + change, abs=1e-9)
    html = (out / "index.html").read_text()
    assert html.count("<svg") == len(FIGURES) + 2 and "25.8010 ± 0.006" in html
    for fid in COMPARE_FIGURES:
        assert (out / "figures" / f"{fid}.png").stat().st_size > 10000
        assert (out / "figures" / f"{fid}.svg").stat().st_size > 10000


@pytest.mark.parametrize("args", [
    ["--port", "no-such-port"],
    ["--aperture", "100"],
    ["--subject-distance", "-5"],
    ["--water-index", "0.5"],
])
def test_bad_input_leaves_nothing(tmp_path, args):
    out = tmp_path / "r"
    line = run_bad("report", *args, "--out", out)
    assert not out.exists() and leftovers(tmp_path) == [], line


def test_water_calibration_needs_air(tmp_path, table6_files):
    out = tmp_path / "r"
    line = run_bad("report", "--water-calibration", table6_files["water"], "--out", out)
    assert "--water-calibration" in line and not out.exists() and leftovers(tmp_path) == []


def test_unwritable_out_leaves_nothing(tmp_path):
    afile = tmp_path / "file"
    afile.write_text("x")
    assert "--out" in run_bad("report", "--out", afile / "report")  # the parent is a file
    assert "--out" in run_bad("report", "--out", tmp_path / "missing" / "report")
    assert "--out" in run_bad("report", "--out", "/proc/porthole-report")  # not writable, even as root
    assert not os.path.exists("/proc/porthole-report")
    assert sorted(os.listdir(tmp_path)) == ["file"]


def test_existing_out_needs_force_and_is_replaced_whole(tmp_path):
    out = tmp_path / "r"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    assert "not empty" in run_bad("report", "--out", out, "--force")  # not a report: never replaced
    assert (out / "notes.txt").read_text() == "mine" and leftovers(tmp_path) == []
    (out / "notes.txt").unlink()
    run("report", "--out", out)  # an empty directory
    assert "--force" in run_bad("report", "--out", out)
    (out / "stale.txt").write_text("mine")  # not part of a report: the folder is not replaced (issue 24)
    assert "stale.txt" in run_bad("report", "--out", out, "--force")
    assert (out / "stale.txt").read_text() == "mine"
    (out / "stale.txt").unlink()
    run("report", "--out", out, "--force", "--aperture", "11")
    assert leftovers(tmp_path) == []
    assert json.loads((out / "report.json").read_text())["plan"]["f_number"] == 11


def test_page_in_headless_chromium(default_report, tmp_path):
    """Chromium renders index.html at 1280 and 700 px: every figure drawn and legible, no element
    overflowing its box (wide tables scroll inside their own container), no console message, no
    failed load."""
    if chromium_check.find_chromium() is None:
        message = ("CHROMIUM IS MISSING: the rendering check of porthole report did NOT run. "
                   "scripts/install-deps installs Debian's 'chromium'.")
        print(message, file=sys.stderr)
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)
    out, _, _ = default_report
    result = chromium_check.check(str(out / "index.html"), str(tmp_path / "page.png"), widths=(1280, 700))
    assert result["problems"] == []  # console, loads and overflows at both widths
    for view in result["views"]:
        width = view["width_px"]
        assert [f["id"] for f in view["figures"]] == FIGURES, width
        for f in view["figures"]:
            assert f["loaded"], (width, f)
            # Figure text on screen: 16 px in a 960 px drawing, at most 960 px wide; on a 700 px
            # screen about 11 px (the smallest a phone reader reads without zooming).
            assert f["min_font_px"] >= (15.5 if width == 1280 else 10.5), (width, f)
            assert f["svg_width_px"] <= f["figure_width_px"] + 0.5, (width, f)
        png = open(view["screenshot"], "rb").read()
        assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 200000
        assert view["page_height_px"] > 5000
        # Every container that scrolls sideways is a table wrapper, and only on the narrow screen.
        assert all(s["element"].endswith("div.scroll") for s in view["scrollers"]), view["scrollers"]
        if width == 1280:
            assert view["scrollers"] == []
        print(f"{width} px: page {view['page_height_px']:.0f} px tall; scrolling tables: "
              f"{[(s['element'], s['content_px'], s['box_px']) for s in view['scrollers']]}; figure text "
              f"{min(f['min_font_px'] for f in view['figures']):.1f} px")


def test_chromium_check_sees_broken_pages(tmp_path):
    """The check can fail: a console error, a missing image and an empty figure are all reported."""
    if chromium_check.find_chromium() is None:
        pytest.skip("CHROMIUM IS MISSING (see test_page_in_headless_chromium)")
    page = tmp_path / "broken.html"
    page.write_text('<html><body><figure data-figure="empty"><p>no drawing</p></figure>'
                    '<figure data-figure="img"><img src="missing.png"></figure>'
                    '<div id="narrow" style="width:300px"><p style="white-space:nowrap">' + "a long line " * 40 +
                    '</p></div><div class="scroll" style="overflow-x:auto;width:300px"><table><tr><td '
                    'style="white-space:nowrap">' + "a wide table " * 40 + '</td></tr></table></div>'
                    '<script>console.error("boom")</script></body></html>')
    result = chromium_check.check(str(page), str(tmp_path / "b.png"), widths=(1280, 700))
    assert any("boom" in p for p in result["problems"])
    assert any("missing.png" in p or "ERR_FILE_NOT_FOUND" in p for p in result["problems"])
    for view in result["views"]:
        assert [f["loaded"] for f in view["figures"]] == [False, False]
        # The line wider than its 300 px box overflows (and, at 700 px, the window); the table in
        # a scrolling container does not, and is listed as scrolling.
        assert any(o.startswith("div#narrow > p") for o in view["overflows"]), view["overflows"]
        assert not any("table" in o for o in view["overflows"]), view["overflows"]
        assert [s["element"] for s in view["scrollers"]] == ["div.scroll"]
    assert any(p.startswith("700 px: overflow:") and "window" in p for p in result["problems"])


def page_text(html):
    """The page's text without tags and with entities of the numbers undone."""
    return re.sub(r"<[^>]+>", " ", html).replace("&quot;", '"')


def test_one_quantity_one_number(default_report):
    """The virtual image of infinity and the field of view are each one number across the page, the
    figures and report.json, and equal to what `porthole plan` computes for the same focus."""
    out, _, _ = default_report
    rep = json.loads((out / "report.json").read_text())
    html = (out / "index.html").read_text()
    text = page_text(html)
    inf = rep["virtual_image_of_infinity"]
    row = rep["virtual_image"]["rows"][-1]
    assert row["wd_mm"] == "inf"
    for key in ("d_s2ep_mm", "vwd_mm", "focus_scale_fd_mm"):
        assert inf[key] == row[key], key  # the same number, not a recomputation
    d = inf["d_s2ep_mm"]
    # plan's own focus solver for a target practically at infinity (WD 10^9 mm) agrees: the image
    # moves by ~d²/(n·WD) ≈ 6e-5 mm from infinity; farther, the paraxial image about the chief ray
    # (ports, a limit of real rays) loses digits (WD 10^12 mm: 2e-3 mm).
    far = run("plan", "--wd", "1e9", "--json").json()
    assert far["virtual_image"]["d_s2ep_mm"] == pytest.approx(d, abs=2e-4)
    assert far["virtual_image"]["vwd_mm"] == pytest.approx(inf["vwd_mm"], abs=2e-4)
    assert far["focus"]["focus_distance_mm"] == pytest.approx(inf["focus_scale_fd_mm"], abs=5e-4)
    # plan's d_s2ep_infinity_mm is that one number (the lens focused on the image: issue 12's
    # acceptance is 0.05 mm; the two commands solve the same focus, so they agree far closer).
    plan = run("plan", "--subject-distance", "1000", "--json").json()
    assert plan["d_s2ep_infinity_mm"] == pytest.approx(d, abs=0.05)
    assert plan["d_s2ep_infinity_mm"] == pytest.approx(d, abs=1e-9)
    assert plan["infinity_image_focus_distance_mm"] == pytest.approx(inf["focus_scale_fd_mm"], abs=1e-9)
    # The same point seen from the pupil at the focus-scale infinity: the two differ exactly by the
    # pupil's move (one point in the housing).
    at_inf = inf["with_focus_scale_at_infinity"]
    # (To 0.01 mm, against a 1.9 mm move of the pupil: the NI320's centres sit 0.4 mm off the axis,
    # so the chief ray about which the paraxial image is taken, and the image, shift by ~0.002 mm.)
    assert inf["ep_z_in_housing_mm"] - at_inf["ep_z_in_housing_mm"] > 1.5
    assert at_inf["ep_z_in_housing_mm"] + at_inf["d_s2ep_mm"] == pytest.approx(inf["image_z_in_housing_mm"], abs=0.01)
    assert inf["ep_z_in_housing_mm"] + d == pytest.approx(inf["image_z_in_housing_mm"], abs=1e-9)
    # On the page: the summary card, the Table 5 row and the figure caption show that one number.
    shown = f"{d:.1f}"
    assert re.search(r"Virtual image of infinity\s*" + re.escape(shown) + " mm", text), shown
    assert re.search(r"∞\s+" + re.escape(shown) + r"\s", text), "Table 5 row"
    caption = next(f["caption"] for f in rep["figures"] if f["id"] == "virtual-image")
    assert f"within {shown} mm of the pupil" in caption
    dat = (out / "figures" / "virtual-image.dat").read_text().split("# index 2:")[1]
    values = [ln for ln in dat.splitlines()[1:] if ln and not ln.startswith("#")][0]
    assert float(values.split()[0]) == pytest.approx(d, abs=1e-4)  # 7 digits in data files
    # Its view from the pupil at the focus-scale infinity is not shown as a number on the page.
    other = f"{at_inf['d_s2ep_mm']:.1f}"
    assert other != shown and not re.search(r"(?<![\d.])" + re.escape(other) + r"(?![\d])", text), other
    # The field of view: the plan's for the same focus (the target's), stated with its c.
    fov = rep["field_of_view"]
    assert fov["air"] == plan["fov"]["air"] and fov["water"] == plan["fov"]["water"]
    assert fov["principal_distance_mm"] == plan["principal_distance_mm"]
    c = f"c = {plan['principal_distance_mm']:.2f} mm"
    assert f"{plan['fov']['water']['horizontal_deg']:.1f}°" in text and c in text
    assert f"{plan['fov']['air']['horizontal_deg']:.1f}" in text


def test_water_minus_air_one_way(tmp_path, table6_files):
    """Differences are water − air everywhere: page, captions, figure scripts."""
    out = tmp_path / "r"
    run("report", "--air-calibration", table6_files["air"], "--water-calibration", table6_files["water"],
        "--out", out)
    files = [out / "index.html", out / "report.json"] + sorted((out / "figures").glob("*.gp"))
    for f in files:
        body = f.read_text()
        assert "air − water" not in body and "air - water" not in body, f
    assert "water − air" in (out / "figures" / "compare-maps.gp").read_text()


ROOT = os.path.join(os.path.dirname(__file__), "..", "..")


def test_port_figure_follows_rim(tmp_path):
    """The glass drawn is the glass the tracer uses: a dome cut at rim_z_mm ends there, on its
    spheres (before, the figure always drew a hemisphere)."""
    base = open(os.path.join(ROOT, "presets", "ports", "nimar-ni320.toml")).read()
    outer_c = (-0.4, -1.0, 21.5)  # the preset's outer sphere: centre (housing frame) and radius
    outer_r = 83.4
    for rim in (45.0, 5.0, None):
        toml = base.replace('name = "nimar-ni320"', 'name = "rim-test"')
        if rim is not None:
            toml = toml.replace("[outer]", f"rim_z_mm = {rim}\n\n[outer]")
        port = tmp_path / f"rim-{rim}.toml"
        port.write_text(toml)
        out = tmp_path / f"r-{rim}"
        run("report", "--port", port, "--out", out)
        dat = (out / "figures" / "port-rays.dat").read_text()
        block = dat.split("# index 0:")[1].split("# index 1:")[0].splitlines()[1:]
        pts = np.array([[float(v) for v in ln.split()] for ln in block if ln and not ln.startswith("#")])
        z, x = pts[:, 0], pts[:, 1]
        # On the outer sphere's section by y = 0.
        assert np.allclose((z - outer_c[2]) ** 2 + (x - outer_c[0]) ** 2 + outer_c[1] ** 2, outer_r**2, rtol=1e-5)
        expected = outer_c[2] if rim is None else rim  # unset: a hemisphere
        assert z.min() == pytest.approx(expected, abs=1e-4), rim
        assert z[0] == pytest.approx(expected, abs=1e-4) and z[-1] == pytest.approx(expected, abs=1e-4)


def sigma_files(d, air_cov):
    """Two calibrations with the paper's Table 6 values: the air one with `air_cov` ("full": a full
    covariance over K1 K2 K3 P1 P2 with strong K correlations; "none": no sigma at all), the water
    one with sigma only (a diagonal covariance)."""
    cals = table6_calibrations()
    air = cals["air"]
    # The paper did not adjust K3, P1, P2 in air; values of the size it found under water (test data).
    for k, v, sg in (("K3", 2.0e-10, 3.0e-11), ("P1", 8.0e-6, 1.0e-6), ("P2", 1.5e-5, 8.0e-7)):
        air["camera"][k], air["sigma"][k] = v, sg
    keys = [k for k in air["camera"]]
    sig = np.array([air["sigma"][k] for k in keys])
    corr = np.eye(len(keys))
    idx = {k: i for i, k in enumerate(keys)}
    for a, b, rho in (("K1", "K2", -0.96), ("K2", "K3", -0.97), ("K1", "K3", 0.90), ("P1", "P2", 0.3)):
        corr[idx[a], idx[b]] = corr[idx[b], idx[a]] = rho
    cov = corr * np.outer(sig, sig)
    assert np.all(np.linalg.eigvalsh(corr) > 0)
    del air["sigma"]
    if air_cov == "full":
        air["covariance"] = {"parameters": keys, "matrix": cov.tolist()}
    paths = {}
    for k, v in cals.items():
        paths[k] = d / f"{k}.json"
        paths[k].write_text(json.dumps(v))
    return paths, air, cals["water"], cov, keys


def test_fig14_sigma_bands_are_monte_carlo(tmp_path):
    """The Fig. 14 bands are the calibration covariance propagated to the profiles: equal to the
    spread of profiles drawn from that covariance (Monte Carlo, 40 000 draws), and absent, with the
    caption saying so, when a calibration has no covariance."""
    paths, air, water, cov, keys = sigma_files(tmp_path, "full")
    out = tmp_path / "r"
    run("report", "--air-calibration", paths["air"], "--water-calibration", paths["water"], "--out", out)
    dat = (out / "figures" / "compare-curves.dat").read_text()
    rows = np.array([[float(v) for v in ln.split()] for ln in dat.splitlines() if ln and not ln.startswith("#")])
    r = rows[:, 0]
    rng = np.random.default_rng(12)
    draws = rng.multivariate_normal([air["camera"][k] for k in keys], cov, size=40000)
    col = {k: draws[:, i] for i, k in enumerate(keys)}
    radial = 1000 * (np.outer(col["K1"], r**3) + np.outer(col["K2"], r**5) + np.outer(col["K3"], r**7))
    decentring = 1000 * np.outer(np.hypot(col["P1"], col["P2"]), r**2)
    inner = r > 0.5
    # 40 000 draws: the sample σ is within ~1 % of the true σ (4 standard errors ≈ 1.4 %).
    assert np.allclose(rows[inner, 7], radial.std(axis=0)[inner], rtol=0.015)
    assert np.allclose(rows[inner, 9], decentring.std(axis=0)[inner], rtol=0.03)  # linearised
    # The water calibration has σ only: its band is the diagonal propagation, exactly.
    ws = water["sigma"]
    expected = 1000 * np.sqrt((ws["K1"] * r**3) ** 2 + (ws["K2"] * r**5) ** 2 + (ws.get("K3", 0) * r**7) ** 2)
    assert np.allclose(rows[:, 8], expected, rtol=3e-6, atol=1e-9)  # 7 digits in the data file
    caption = next(f["caption"] for f in json.loads((out / "report.json").read_text())["figures"]
                   if f["id"] == "compare-curves")
    assert "full covariance" in caption and "σ only" in caption
    gp = (out / "figures" / "compare-curves.gp").read_text()
    assert gp.count("air ±1σ") == 2 and gp.count("water ±1σ") == 2

    paths, *_ = sigma_files(tmp_path, "none")
    out = tmp_path / "r2"
    run("report", "--air-calibration", paths["air"], "--water-calibration", paths["water"], "--out", out)
    dat = (out / "figures" / "compare-curves.dat").read_text()
    rows = [ln.split() for ln in dat.splitlines() if ln and not ln.startswith("#")]
    assert all(row[7] == "NaN" and row[9] == "NaN" for row in rows)
    caption = next(f["caption"] for f in json.loads((out / "report.json").read_text())["figures"]
                   if f["id"] == "compare-curves")
    assert "in-air calibration has no covariance, so it has no band" in caption
    assert "air ±1σ" not in (out / "figures" / "compare-curves.gp").read_text()


def test_fisheye_report_reads_the_fisheye_fit(tmp_path):
    """A fisheye lens: the simulation, its sweeps and maps are the Kannala-Brandt fit's, the same
    numbers `porthole simulate` prints, finite everywhere (a Brown view of it would be all zero)."""
    out = tmp_path / "fisheye"
    lens = "nikkor-10.5mm-f2.8g-fisheye"
    run("report", "--lens", lens, "--port", "nimar-ni320-nominal", "--out", out)
    rep = json.loads((out / "report.json").read_text())
    sim = run("simulate", "--lens", lens, "--port", "nimar-ni320-nominal", "--json").json()
    assert rep["simulation"]["model"] == "kannala-brandt"
    assert rep["simulation"]["c_ratio_water_air"] == pytest.approx(sim["c_ratio_water_air"], rel=1e-9)
    # About the centre of the concentric dome the z sweep changes the focal ratio, oddly in the offset.
    rows = {r["offset_mm"]: r for r in rep["sweeps"]["z"]}
    assert rows[0]["c_ratio_water_air"] == pytest.approx(1, abs=1e-6)
    assert (rows[4]["c_ratio_water_air"] - 1) * (rows[-4]["c_ratio_water_air"] - 1) < 0
    assert all(math.isfinite(r["dr_change_um_at_10mm"]) for r in rep["sweeps"]["z"])
    assert max(p["difference"]["length_um"] for p in rep["distortion_map"]) < 0.05
    page = (out / "index.html").read_text()
    assert "kannala-brandt parameters fitted" in page and "equisolid" in page
    for name in ("predicted", "maps", "tolerance", "residual-map"):
        assert (out / "figures" / f"{name}.png").stat().st_size > 1000
