"""Shared helpers for the CLI tests: run the porthole binary and read the paper's tables.

Every run through run() (and so run_bad()) has its stdout checked by check_output(): no printed NaN,
no "f/0.0", no empty value and no infinity other than a distance that is infinite by definition (an
object or focus at infinity, a depth of field reaching it) -- never an RMS, a sigma, a chi2, a focal
length or a ratio (issue 23, "No silently wrong answer"). Text and JSON alike."""
import csv
import json
import math
import os
import re
import subprocess

import pytest

BIN = os.environ.get("PORTHOLE_BIN", "porthole")
DATA = os.environ.get("PORTHOLE_TEST_DATA_DIR", os.path.join(os.path.dirname(__file__), "..", "data"))


class Result:
    def __init__(self, proc):
        self.code = proc.returncode
        self.out = proc.stdout
        self.err = proc.stderr

    def json(self):
        return json.loads(self.out)


# ---- The acceptance check over every command's output ----

# JSON keys whose value may be "inf": distances (and what is measured at them) that are infinite by
# definition -- an object, focus or depth-of-field limit at infinity, the width of the scene there, a
# working-distance range that reaches it. Anything else infinite (an RMS, a sigma, chi2, a focal
# length, a ratio) is an error.
# Behind a flat port the virtual image of infinity is at infinity (d_s2ep_infinity_mm, and the focus
# on it); a port without power (flat) has its focal points at infinity (efl_*, back/front_focal_mm of
# `virtual-image`: the port's, never a camera's fitted focal length or c).
INFINITE_DISTANCE_KEY = re.compile(
    r"^(wd_mm|wd|subject_distance_mm|object_distance_mm|focus_distance_mm|focus_mm|fd_mm|"
    r"(virtual_)?(far|total)(_wd)?_mm|max_wd_mm|min_wd_mm|d_s2ep_mm|vwd_mm|d_s2ep_real_mm|vwd_real_mm|"
    r"d_s2ep_infinity_mm|infinity_image_focus_distance_mm|focal_line_(near|far)_d_s2ep_mm|"
    r"efl_air_mm|efl_water_mm|back_focal_mm|front_focal_mm|"
    r"hyperfocal_mm|thin_mm|traced_mm|coverage_(thin|traced)_mm|object_height_mm|distance_mm)$")
# Text: an infinity is allowed where the words around it say it is a distance at infinity.
INFINITE_DISTANCE_TEXT = re.compile(
    r"(WD\s+\S+\s+to\s+|to\s+|--wd\s+|WD\s*=?\s*|focus(ed)? (at|on) |from\s+)-?(inf|infinity)\b"
    r"|^\s*(inf|infinity)\s"  # a table row for an object at infinity
    r"|\binfinity\b(?! mm)")   # the word "infinity" itself (never "infinity mm" for a value)
TEXT_PROBLEMS = [
    (re.compile(r"\bnan\b", re.I), "NaN"),
    (re.compile(r"f/0(\.0*)?(?![\d.])"), "f/0.0"),
    (re.compile(r"\(x-|x0\.00 of|\(x(nan|inf)"), "a ratio that is not a number"),
    (re.compile(r">=\s*-?inf"), "an infinite threshold"),
    (re.compile(r"(scale|[:=])\s+-?\s*(mm|px|um|deg)\b"), "an empty value"),
]


def _json_problems(value, path, out):
    if isinstance(value, dict):
        for k, v in value.items():
            _json_problems(v, path + [str(k)], out)
    elif isinstance(value, list):
        for i, v in enumerate(value):
            _json_problems(v, path + [str(i)], out)
    elif isinstance(value, float) and not math.isfinite(value):
        out.append(f"{'.'.join(path)} = {value}")
    elif isinstance(value, str):
        key = next((p for p in reversed(path) if not p.isdigit()), "")
        low = value.strip().lower()
        if low in ("nan", "-nan"):
            out.append(f"{'.'.join(path)} = {value!r}")
        elif low in ("inf", "-inf", "infinity", "-infinity") and not INFINITE_DISTANCE_KEY.match(key):
            out.append(f"{'.'.join(path)} = {value!r} (not a distance at infinity)")
        elif value == "":
            out.append(f"{'.'.join(path)} is empty")
        elif "f/0.0" in value or re.search(r"f/0(?![\d.])", value):
            out.append(f"{'.'.join(path)} says {value!r}")


def output_problems(out):
    """What in one command's stdout is printed nonsense (a list of findings; empty: clean)."""
    problems = []
    stripped = out.lstrip()
    data = None
    if stripped[:1] in ("{", "["):
        try:
            data = json.loads(out)
        except ValueError:
            data = None
    if data is not None:
        _json_problems(data, [], problems)
        return problems
    for line in out.splitlines():
        for pattern, what in TEXT_PROBLEMS:
            if pattern.search(line):
                problems.append(f"{what}: {line.strip()!r}")
        for m in re.finditer(r"(?<![\w.-])-?inf(inity)?\b", line):
            allowed = any(a.start() <= m.start() < a.end() for a in INFINITE_DISTANCE_TEXT.finditer(line))
            if not allowed:
                problems.append(f"an infinity that is not a distance at infinity: {line.strip()!r}")
                break
    return problems


def check_output(args, out):
    if "--help" in map(str, args) or "-h" in map(str, args):
        return  # a help text names inputs ("'inf' allowed"), not results
    problems = output_problems(out)
    assert not problems, f"porthole {' '.join(map(str, args))} printed nonsense:\n  " + "\n  ".join(problems)


def run(*args, check=True):
    proc = subprocess.run([BIN, *map(str, args)], capture_output=True, text=True, timeout=300)
    res = Result(proc)
    if check and res.code != 0:
        raise AssertionError(f"porthole {' '.join(map(str, args))} exited {res.code}: {res.err}")
    check_output(args, res.out)
    return res


def run_bad(*args):
    """A run that must fail cleanly: exit 2, one line on stderr, nothing on stdout."""
    res = run(*args, check=False)
    assert res.code == 2, (res.code, res.err)
    assert res.out == "", res.out
    lines = res.err.strip().splitlines()
    assert len(lines) == 1, res.err
    assert lines[0].startswith("porthole: error: "), lines[0]
    return lines[0]


def read_table(name):
    with open(os.path.join(DATA, name)) as f:
        rows = [line for line in f if not line.startswith("#")]
    return list(csv.DictReader(rows))


@pytest.fixture
def paper_table5():
    return {r["wd_mm"]: (float(r["d_s2ep_mm"]), float(r["vwd_mm"])) for r in read_table("menna2016_table5.csv")}
