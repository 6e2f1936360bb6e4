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


def test_devices_and_directories_are_not_read_to_the_end(tmp_path):
    (tmp_path / "zero.ply").symlink_to("/dev/zero")
    (tmp_path / "zero.toml").symlink_to("/dev/zero")
    for args in (["plan", "--port", "/dev/zero"], ["plan", "--port", tmp_path / "zero.toml"],
                 ["fit", "sphere", tmp_path / "zero.ply"],
                 ["compare", "/dev/zero", "/dev/zero"], ["fit", "sphere", "/dev/zero"],
                 ["plan", "--port", tmp_path]):
        line = run_bad(*args)
        assert "limit" in line or "not a regular file" in line or "directory" in line or "format" in line, line


def png_bytes(width, height, rows):
    """An 8-bit grey PNG; rows: `height` byte strings of `width` pixels (or fewer, for a truncated one)."""
    import struct
    import zlib

    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(b"".join(b"\0" + r for r in rows))) + chunk(b"IEND", b""))


def write_board_png(path, cols=5, rows=4, square=24):
    """A chessboard of cols x rows inner corners, squares of `square` px, a white margin around."""
    h, w = (rows + 3) * square, (cols + 3) * square
    lines = []
    for y in range(h):
        j = y // square - 1
        lines.append(bytes(30 if 0 <= j <= rows and 0 <= x // square - 1 <= cols and (x // square - 1 + j) % 2 == 0
                           else 225 for x in range(w)))
    path.write_bytes(png_bytes(w, h, lines))


def test_detect_skips_oversize_and_survives_latin1_names(tmp_path):
    images = tmp_path / "images"
    images.mkdir()
    write_board_png(images / "board.png")
    # A Latin-1 "é" (not UTF-8) in a file name, as old cameras and card readers write them.
    latin1 = os.fsdecode(b"caf\xe9.png")
    write_board_png(images / latin1)
    # 20000 x 20000 px declared in 100 bytes: skipped from its header, never decoded.
    (images / "huge.png").write_bytes(png_bytes(20000, 20000, [bytes(100)]))
    out = tmp_path / "out"
    out.mkdir()
    import subprocess
    from conftest import BIN
    # The table names files as they are (bytes): read it without decoding as UTF-8.
    proc = subprocess.run([BIN, "detect", "--images", images, "--target", "chessboard:5x4:20", "--out-dir", out],
                          capture_output=True, timeout=300)
    text, err = proc.stdout.decode("latin-1"), proc.stderr.decode("latin-1")
    assert proc.returncode == 0, err
    assert "huge.png" in text and "too large: 20000 x 20000" in text, text
    assert sorted(os.listdir(out)) == sorted(["board.json", os.fsdecode(b"caf\xe9.json")])
    assert "2 of 3 images" in text
    progress = err.splitlines()
    assert len(progress) == 3 and all(line.startswith("detect: [") for line in progress), err


def test_killed_report_leaves_old_output_or_none_and_no_temporaries(tmp_path):
    import signal
    import subprocess
    import time
    from conftest import BIN
    out = tmp_path / "report"
    run("report", "--out", out)
    for delay in (0.2, 0.6, 1.2, 2.0):
        proc = subprocess.Popen([BIN, "report", "--out", str(out), "--force", "--subject-distance", "1500"],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(delay)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        # The old report whole, or the new one whole.
        assert (out / "index.html").exists() and (out / "report.json").exists()
        assert "porthole_report" in json.loads((out / "report.json").read_text())
        time.sleep(0.3)  # gnuplot, if it was running, died with porthole
        for pid in filter(str.isdigit, os.listdir("/proc")):
            try:
                cwd = os.readlink(f"/proc/{pid}/cwd")
            except OSError:
                continue
            assert not cwd.startswith(str(tmp_path)), f"process {pid} left running in {cwd}"
    # The next run removes what the killed ones left.
    run("report", "--out", out, "--force")
    assert [p for p in os.listdir(tmp_path) if ".tmp" in p] == []
