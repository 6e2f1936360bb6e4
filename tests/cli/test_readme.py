"""Proves the README runs as written (issue 12): every command line of README.md's code blocks —
except `make demo` / `make test`, which build and run this test — is run in order in one bash
session (so `cd` and `export` carry over), from the source tree, with HOME in a temporary folder
(the README works in ~/porthole-try, filled by scripts/sample-data). Each line must exit 0."""
import os
import re
import subprocess

from conftest import BIN

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


def readme_commands():
    """The command lines of README.md's indented code blocks, continuation lines joined."""
    commands, pending = [], ""
    with open(os.path.join(ROOT, "README.md")) as f:
        for line in f:
            if not line.startswith("    ") and not pending:
                continue
            text = line.rstrip("\n").strip()
            pending += text
            if pending.endswith("\\"):
                pending = pending[:-1].rstrip() + " "
                continue
            if pending and not pending.startswith("make "):
                commands.append(pending)
            pending = ""
    return commands


def test_readme_lists_the_commands_it_should():
    cmds = readme_commands()
    assert any(c.startswith("scripts/sample-data") for c in cmds)
    for word in ("report", "virtual-image", "trace", "plan", "flat", "materials", "synth-scan", "fit",
                 "assemble", "presets", "simulate", "calibrate", "compare", "detect", "render", "target-sheet",
                 "undistort"):
        assert any(re.match(rf"porthole {word}\b", c) for c in cmds), word
    assert any("import porthole" in c for c in cmds)


def test_every_readme_line_runs(tmp_path):
    script = ["set -euo pipefail"]
    py_dir = os.environ.get("PORTHOLE_PY_DIR")
    for k, cmd in enumerate(readme_commands()):
        if not py_dir and "python3" in cmd:
            continue  # a build without the Python module (make test-sanitize): its lines cannot run
        script.append(f"echo {k}: {shlex_quote(cmd)} >&2")
        script.append(cmd)
    env = dict(os.environ)
    env["HOME"] = str(tmp_path)
    # The README's export line puts $PWD/build first; these are the build under test, as a fallback
    # when it was configured elsewhere.
    bin_dir = os.path.dirname(os.path.abspath(BIN)) if os.sep in BIN else ""
    env["PATH"] = env.get("PATH", "") + (os.pathsep + bin_dir if bin_dir else "")
    if py_dir:
        env["PYTHONPATH"] = py_dir
    proc = subprocess.run(["bash", "-c", "\n".join(script)], cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=5000 if os.environ.get("PORTHOLE_SANITIZED") else 500)  # ASan: many times slower
    tail = "\n".join(proc.stderr.splitlines()[-15:])
    assert proc.returncode == 0, f"README line failed (exit {proc.returncode}):\n{tail}"
    try_dir = tmp_path / "porthole-try"
    for produced in ("my-report/index.html", "fan.json", "cap.ply", "as-built.toml", "my-dome.toml", "sweep.csv",
                     "air.json", "water.json", "water.yml", "curves/curves.csv", "air-pinhole/cameras.txt",
                     "air-pinhole/transforms.json"):
        assert (try_dir / produced).exists(), produced
    assert len(list((try_dir / "detections").glob("*.json"))) >= 10


def shlex_quote(s):
    import shlex
    return shlex.quote(s)
