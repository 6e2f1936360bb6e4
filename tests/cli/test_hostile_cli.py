"""Hostile input (issue 10, docs/robustness.md): no text from an input file becomes a command, and bad
files fail with one line and exit 2, leaving no output behind."""
import json
import os

from conftest import run, run_bad


def toml_str(s):
    # A JSON string literal is a TOML basic string (\" \\ \n \uXXXX are the same in both).
    return json.dumps(s)


def gnuplot_code(script):
    """The script without its comments and single-quoted strings (where gnuplot substitutes nothing);
    double-quoted strings are kept, since gnuplot runs `...` inside them."""
    out, i, n = [], 0, len(script)
    while i < n:
        c = script[i]
        if c == "#":
            while i < n and not (script[i] == "\n" and script[i - 1] != "\\"):
                i += 1
        elif c == "'":
            i += 1
            while i < n and not (script[i] == "'" and script[i + 1:i + 2] != "'"):
                i += 2 if script[i] == "'" else 1
            i += 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def hostile_texts(canary):
    """Texts that would run `touch canary` if they reached gnuplot, a shell or a page unescaped."""
    c = str(canary)
    return [
        f'a" ; system "touch {c}" ; print "',            # breaks out of a double-quoted gnuplot string
        f"b' ; system 'touch {c}' ; print '",            # ... out of a single-quoted one
        f"c `touch {c}` d",                               # gnuplot command substitution
        f'd\n system "touch {c}"\n',                     # a new line in a script or a comment
        f'e \\\nsystem "touch {c}"',                     # a comment continued by a backslash
        f"f $(touch {c}) @touch ^_{{}}&~",               # shell substitution, macros, enhanced text
        '<script>alert(1)</script> <img src=x onerror="alert(2)"> &amp;',
    ]


def write_hostile_presets(d, canary):
    texts = hostile_texts(canary)
    joined = " | ".join(texts)
    port = d / "port.toml"
    port.write_text(
        f"name = {toml_str(texts[0] + texts[2])}\ndescription = {toml_str(joined)}\nsource = {toml_str(joined)}\n"
        'type = "dome"\nmaterial = "n-bk7"\nentrance_pupil_mm = [0.0, 0.0, 26.9]\n'
        "[outer]\ncenter_mm = [-0.4, -1.0, 21.5]\nradius_mm = 83.4\n"
        "[inner]\ncenter_mm = [-0.4, -1.5, 20.3]\nradius_mm = 75.7\n")
    other = d / "other.toml"
    other.write_text(
        f"name = {toml_str(texts[1] + texts[3] + texts[4])}\ndescription = {toml_str(joined)}\n"
        f"source = {toml_str(texts[5] + texts[6])}\n"
        'type = "flat"\nmaterial = "pmma"\nthickness_mm = 10\ninner_point_mm = [0, 0, 60]\n')
    camera = d / "camera.toml"
    camera.write_text(
        f"name = {toml_str(texts[5] + texts[6])}\ndescription = {toml_str(joined)}\nsource = {toml_str(joined)}\n"
        "mount = \"nikon-f\"\nwidth_px = 4288\nheight_px = 2848\npixel_pitch_mm = 0.0055\n")
    lens = d / "lens.toml"
    lens.write_text(
        f"name = {toml_str(texts[4] + texts[1])}\ndescription = {toml_str(joined)}\nsource = {toml_str(joined)}\n"
        "mount = \"nikon-f\"\nfocal_length_mm = 24.0\nf_number_min = 2.8\nf_number_max = 22.0\n"
        "min_focus_mm = 300.0\npupil = [ { focus_mm = inf, d_ep2f_mm = 24.6 }, { focus_mm = 300.0, d_ep2f_mm = 26.9 } ]\n")
    return port, other, camera, lens


def test_report_runs_no_command_from_hostile_names(tmp_path):
    canary = tmp_path / "PWNED"
    d = tmp_path / "in `touch PWNED2` $(touch PWNED3) ' \""
    d.mkdir()
    port, other, camera, lens = write_hostile_presets(d, canary)
    out = tmp_path / "report"
    res = run("report", "--port", port, "--compare-port", other, "--camera", camera, "--lens", lens,
              "--out", out, check=False)
    assert not canary.exists(), "a command from a port or camera file ran"
    assert set(os.listdir(tmp_path)) <= {d.name, "report"}, os.listdir(tmp_path)
    assert res.code == 0, res.err
    assert not any("PWNED" in p for p in os.listdir(out / "figures"))
    html = (out / "index.html").read_text()
    # The names are on the page, escaped: no element or attribute comes from them.
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in html
    assert "<script" not in html and "<img" not in html and "onerror=\"" not in html
    for gp in (out / "figures").glob("*.gp"):
        code = gnuplot_code(gp.read_text())
        assert "`" not in code and "touch" not in code and "system" not in code, (gp, code)
    # Gnuplot printed the names as typed (enhanced-text markup escaped) in the SVG.
    svg = (out / "figures" / "dome-vs-flat.svg").read_text()
    assert "touch" in svg


def test_hostile_names_elsewhere_stay_data(tmp_path):
    canary = tmp_path / "PWNED"
    port, _, camera, lens = write_hostile_presets(tmp_path, canary)
    for args in (["virtual-image", "--port", port, "--wd", "500"],
                 ["plan", "--port", port, "--camera", camera, "--lens", lens],
                 ["flat", "--port", tmp_path / "other.toml", "--camera", camera, "--lens", lens]):
        res = run(*args, check=False)
        assert res.code in (0, 2), (args, res.err)
    assert not canary.exists()
