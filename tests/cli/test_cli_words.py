"""Proves that errors speak the front end's words (issue 23): a library rule that names another
setting (`extrapolate`, `allow_adapter`) and a field every command shares (the water's temperature)
reach the CLI as its flags and Python as its keywords, never as the library's field names."""
import os
import subprocess
import sys

import pytest

from conftest import run_bad


def test_water_out_of_range_names_the_flags():
    line = run_bad("materials", "seawater", "--temperature", "45")
    assert "--temperature: 45 is outside the valid range" in line
    assert "set --extrapolate to use it anyway" in line
    assert "temperature_c" not in line and "(--extrapolate)" not in line and "`" not in line


def test_plan_names_the_adapter_flag():
    line = run_bad("plan", "--camera", "sony-a7iv", "--lens", "nikkor-24mm-f2.8d")
    assert "an adapter 28.5 mm long would fit it: set --allow-adapter" in line
    assert "allow_adapter" not in line and "`" not in line


@pytest.mark.skipif(not os.environ.get("PORTHOLE_PY_DIR"), reason="the Python module is not built")
def test_python_names_its_keyword():
    code = ("import porthole\n"
            "try:\n"
            "    porthole.plan(camera='sony-a7iv', lens='nikkor-24mm-f2.8d')\n"
            "except ValueError as e:\n"
            "    print(e)\n")
    env = dict(os.environ, PYTHONPATH=os.environ["PORTHOLE_PY_DIR"])
    out = subprocess.run(["/usr/bin/python3", "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert out.returncode == 0, out.stderr
    assert "would fit it: set allow_adapter=True" in out.stdout, out.stdout
    assert "--allow-adapter" not in out.stdout and "`" not in out.stdout
