"""Shared helpers for the CLI tests: run the porthole binary and read the paper's tables."""
import csv
import json
import os
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


def run(*args, check=True):
    proc = subprocess.run([BIN, *map(str, args)], capture_output=True, text=True, timeout=300)
    res = Result(proc)
    if check and res.code != 0:
        raise AssertionError(f"porthole {' '.join(map(str, args))} exited {res.code}: {res.err}")
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
