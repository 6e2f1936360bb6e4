"""Proves that errors speak the front end's words (issue 23): a library rule that names another
setting (`extrapolate`, `allow_adapter`) and a field every command shares (the water's temperature)
reach the CLI as its flags and Python as its keywords, never as the library's field names."""
import os
import re
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


def python_error(call):
    """The ValueError text of `call` (Python source) in a fresh interpreter with the built module."""
    code = f"import porthole\ntry:\n    {call}\nexcept ValueError as e:\n    print(e)\n"
    env = dict(os.environ, PYTHONPATH=os.environ["PORTHOLE_PY_DIR"])
    out = subprocess.run(["/usr/bin/python3", "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert out.returncode == 0, out.stderr
    return out.stdout.strip()


@pytest.mark.skipif(not os.environ.get("PORTHOLE_PY_DIR"), reason="the Python module is not built")
def test_python_names_its_keyword():
    text = python_error("porthole.plan(camera='sony-a7iv', lens='nikkor-24mm-f2.8d')")
    assert "would fit it: set allow_adapter=True" in text, text
    assert "--allow-adapter" not in text and "`" not in text


# --- The library names fields, never a CLI flag (issue 25) -------------------------------------
SRC = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "src", "porthole")
FLAG = re.compile(r"(?<![\w-])--[a-z][a-z0-9]*(?:-[a-z0-9]+)*")


def string_literals(text):
    """(line, contents) of each C++ string literal in `text`, comments skipped (raw strings too)."""
    i, n, line = 0, len(text), 1
    while i < n:
        c = text[i]
        if c == "\n":
            line += 1
            i += 1
        elif text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            line += text.count("\n", i, j)
            i = j + 2
        elif text.startswith('R"', i) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            m = re.match(r'R"([^(]*)\(', text[i:])
            end = text.find(")" + m.group(1) + '"', i)
            yield line, text[i + m.end():end]
            line += text.count("\n", i, end)
            i = end + len(m.group(1)) + 2
        elif c in "\"'":
            j = i + 1
            while text[j] != c:
                j += 2 if text[j] == "\\" else 1
            if c == '"':
                yield line, text[i + 1:j]
            i = j + 1
        else:
            i += 1


def test_the_scanner_finds_a_flag():
    # The check below must be able to fail: a flag in a literal is found, one in a comment is not,
    # nor a CSS custom property.
    code = ('// --comment-flag\nthrow InvalidInput("--images", "give `free`");\n'
            'auto s = R"(x --raw-flag)"; auto css = ":root { --ink:#000 }";\n')
    found = [(line, m.group(0)) for line, s in string_literals(code) for m in FLAG.finditer(s)
             if ":root" not in s]
    assert found == [(2, "--images"), (3, "--raw-flag")]


def test_no_string_literal_in_the_library_names_a_cli_flag():
    if not os.path.isdir(SRC):
        pytest.skip("the source tree is not beside the tests")
    hits = []
    for folder, _, files in os.walk(SRC):
        for name in files:
            if not name.endswith((".cc", ".h")) or "test" in name:
                continue  # tests may run the CLI
            path = os.path.join(folder, name)
            with open(path, encoding="utf-8") as f:
                text = f.read()
            for line, s in string_literals(text):
                if ":root" in s or "var(--" in s:
                    continue  # the report page's CSS custom properties
                hits += [f"{os.path.relpath(path, SRC)}:{line}: {m.group(0)}" for m in FLAG.finditer(s)]
    assert not hits, "library strings that name CLI flags (name the field in `backquotes`):\n" + "\n".join(hits)


def test_a_library_field_reaches_each_front_end_in_its_words():
    # coded::Sheet throws on its field `paper`: the CLI says --paper.
    line = run_bad("target-sheet", "/tmp/porthole-never-written.svg", "--paper", "A9")
    assert line.startswith("porthole: error: --paper: expected A5"), line
    # fit::Assemble throws on `dome_centered` with a rule naming `dome_rear`: both become flags.
    line = run_bad("assemble", "--housing-flange", "0,0,100,0,0,1", "--outer", "0,0,150,50",
                   "--inner", "0,0,150,45", "--dome-centered", "--pupil-offset", "30")
    assert line == "porthole: error: --dome-centered: needs --dome-rear", line


@pytest.mark.skipif(not os.environ.get("PORTHOLE_PY_DIR"), reason="the Python module is not built")
def test_python_says_its_keywords_for_the_same_rule():
    text = python_error("porthole.assemble(housing_flange=[0,0,100,0,0,1], outer=[0,0,150,50], "
                        "inner=[0,0,150,45], dome_centered=True, pupil_to_flange_mm=30)")
    assert text == "dome_centered: needs dome_rear", text
