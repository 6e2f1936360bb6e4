"""The fuzz-regression corpus (tests/fuzz/, docs/robustness.md): every valid, hostile and mutated input
file run through the CLI command that reads it. Each run must exit 0 or 2 within its time limit; a
failure is one line `porthole: error: ...` on stderr, nothing on stdout and no output file left
behind (nor any temporary, after success or failure)."""
import concurrent.futures
import os
import shutil
import subprocess

from conftest import BIN

FUZZ = os.path.join(os.path.dirname(__file__), "..", "fuzz")
VALID_CAL = os.path.join(FUZZ, "calib_json", "valid.json")
# Each file's time limit: 20 s, ten times that under ASan + UBSan (make test-sanitize), whose builds
# run several times slower.
LIMIT_S = 200 if os.environ.get("PORTHOLE_SANITIZED") else 20


def command(kind, path, out):
    """The porthole command line that reads `path` (of corpus `kind`) and writes into `out`."""
    if kind == "port":
        return ["plan", "--port", path]
    if kind == "camera":
        return ["plan", "--camera", path]
    if kind == "lens":
        return ["plan", "--lens", path]
    if kind in ("ply", "stl", "obj", "xyz"):
        return ["fit", "sphere", path, "--residuals", os.path.join(out, "residuals.ply")]
    if kind in ("calib_json", "yaml", "metashape", "opencv_xml", "colmap"):
        return ["compare", path, VALID_CAL, "--pixel-pitch-mm", "0.0055", "--csv-dir", out]
    if kind == "detections":
        return ["calibrate", "--detections", path, "--pixel-pitch-mm", "0.0055", "--quiet",
                "--out", os.path.join(out, "calibration.json")]
    if kind == "field":
        images = os.path.join(out, "..", "images")
        os.makedirs(images, exist_ok=True)
        shutil.copy(os.path.join(FUZZ, "images", "valid-board.png"), images)
        return ["detect", "--images", images, "--target", "coded:12:2", "--field", path, "--quiet", "--out-dir", out]
    if kind == "images":
        images = os.path.join(out, "..", "images")
        os.makedirs(images, exist_ok=True)
        shutil.copy(path, images)
        return ["detect", "--images", images, "--target", "chessboard:5x4:20", "--quiet", "--out-dir", out]
    raise AssertionError(kind)


KINDS = ("port", "camera", "lens", "ply", "stl", "obj", "xyz", "calib_json", "yaml", "metashape", "opencv_xml",
         "colmap", "detections", "images", "field")
CASES = sorted((kind, name) for kind in KINDS
               for name in os.listdir(os.path.join(FUZZ, kind)))


def test_corpus_is_there():
    kinds = {k for k, _ in CASES}
    assert kinds >= {"port", "camera", "lens", "ply", "stl", "obj", "xyz", "calib_json", "yaml", "metashape",
                     "opencv_xml", "colmap", "detections", "images", "field"}
    assert len(CASES) >= 468  # docs/robustness.md states the count


def check(kind, name, tmp):
    """Runs one corpus file; returns a description of what went wrong, or None."""
    out = os.path.join(tmp, "out")
    os.makedirs(out)
    args = command(kind, os.path.join(FUZZ, kind, name), out)
    try:
        proc = subprocess.run([BIN, *args], capture_output=True, timeout=LIMIT_S)
    except subprocess.TimeoutExpired:
        return f"ran over {LIMIT_S} s"
    err = proc.stderr.decode("utf-8", "replace")
    if proc.returncode not in (0, 2):
        return f"exit {proc.returncode}: {err[-1000:]}"
    leftovers = [p for p in os.listdir(out) if ".tmp" in p]
    if leftovers:
        return f"temporaries left: {leftovers}"
    if proc.returncode == 2:
        lines = err.splitlines()
        if len(lines) != 1 or not lines[0].startswith("porthole: error: ") or len(lines[0]) > 1200:
            return f"not one error line: {err[-1000:]!r}"
        if proc.stdout:
            return "output on stdout with exit 2"
        if os.listdir(out):
            return f"output left behind after exit 2: {os.listdir(out)}"
    return None


def test_every_corpus_file(tmp_path):
    with concurrent.futures.ThreadPoolExecutor(max_workers=os.cpu_count() or 2) as pool:
        futures = {pool.submit(check, kind, name, str(tmp_path / f"{kind}-{name}")): f"{kind}/{name}"
                   for kind, name in CASES}
        failures = {futures[f]: f.result() for f in futures if f.result()}
    assert not failures, failures
