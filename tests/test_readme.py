"""Every example of README.md and the user's pages of docs/ runs as written and prints what it says.

- A ```python block runs as a script. Each ``print(...)  # text`` line states what it prints:
  the script's output lines must be those texts, in order.
- A ```bash (or unmarked) block runs line by line in bash, with this interpreter's
  ``rangemesh`` first on PATH; the quick start's ``pip install`` lines are left out. A command
  must exit with 0, and every "quoted" text in its comment must appear in what it printed.

Each block runs in its own folder beside a ``shared/data`` of links to the shared data files,
so the README's ``../shared/data/...`` paths resolve and nothing is written into the data.
"""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
# the pages whose examples a user copies: the README and the guides of the documentation site
PAGES = [README] + [ROOT / "docs" / name for name in ("index.md", "getting-started.md", "sensors.md")]

FENCE = re.compile(r"^```(\w*)\n(.*?)^```", re.S | re.M)
PRINT = re.compile(r"^\s*print\(.*\)\s*#\s?(?P<out>.*?)\s*$")
COMMENT = re.compile(r"\s{2,}#\s")


def blocks(text):
    """(language, code) of each fenced block; an unmarked block is shell."""
    return [(lang or "bash", code) for lang, code in FENCE.findall(text)
            if (lang or "bash") in ("python", "bash")]


def shell_lines(code):
    """The block's commands, continuation lines joined; comment-only and pip lines left out."""
    joined = code.replace("\\\n", " ")
    lines = [line.strip() for line in joined.splitlines()]
    return [line for line in lines if line and not line.startswith(("#", "pip install"))]


def expected_prints(code):
    return [m["out"] for m in map(PRINT.match, code.splitlines()) if m]


def quoted(line):
    """The "texts" a command's comment says it prints."""
    parts = COMMENT.split(line, maxsplit=1)
    return re.findall(r'"([^"]+)"', parts[1]) if len(parts) == 2 else []


EXAMPLES = blocks(README.read_text(encoding="utf-8"))
EVERY = [(page.stem, lang, code) for page in PAGES for lang, code in blocks(page.read_text(encoding="utf-8"))]
PYTHON = [(page, code) for page, lang, code in EVERY if lang == "python"]
SHELL = [(page, code) for page, lang, code in EVERY if lang == "bash" and shell_lines(code)]


@pytest.fixture(scope="module")
def beside_data(shared_data, tmp_path_factory):
    """A folder whose ``shared/data`` mirrors the shared data with links, one per file."""
    root = tmp_path_factory.mktemp("readme")
    for src in shared_data.rglob("*"):
        if src.is_file():
            dst = root / "shared" / "data" / src.relative_to(shared_data)
            dst.parent.mkdir(parents=True, exist_ok=True)
            dst.symlink_to(src)
    return root


def env():
    e = dict(os.environ)
    e["PATH"] = str(Path(sys.executable).parent) + os.pathsep + e.get("PATH", "")
    e.pop("PYTHONPATH", None)
    return e


def workdir(root, name):
    d = root / name
    d.mkdir()
    return d


def test_readme_has_examples():
    assert len(PYTHON) >= 3
    assert sum(len(shell_lines(code)) for _, code in SHELL) >= 10
    assert {page for page, _ in PYTHON} >= {"README", "index", "getting-started", "sensors"}
    # every printed line states what it prints
    for _, code in PYTHON:
        prints = [line for line in code.splitlines() if line.lstrip().startswith("print(")]
        assert len(prints) == len(expected_prints(code)), prints


def test_readme_and_docstrings_state_the_orthographic_axes_the_code_uses():
    # issue 41: the README said x = column, y = row; eq. 4 of the paper, X = kx*r, Y = ky*c
    import numpy as np

    import rangemesh
    from rangemesh.camera import Orthographic, backproject
    from rangemesh.cli import build_parser

    from .golden import crops

    text = (ROOT / "docs" / "getting-started.md").read_text(encoding="utf-8")
    said = re.search(r"`Orthographic\(kx, ky, kz\)`[^)]*?x = (row|column), y = (row|column)", text)
    assert said, "the guide states Orthographic's axes"
    # by hand: pixel row 4, column 1, depth 7 with kx = 1, ky = 10, kz = 1
    by_axis = {"row": 4.0, "column": 10.0}
    want = [by_axis[said[1]], by_axis[said[2]], 7.0]
    assert backproject([4], [1], [7.0], Orthographic(1, 10, 1)).tolist() == [want]
    doc = Orthographic.__doc__
    assert "X = kx*r, Y = ky*c" in doc and f"x along the {said[1]}s" in doc.replace("\n", " ")
    scale_help = next(a.help for a in build_parser()._subparsers._group_actions[0]
                      .choices["mesh"]._actions if "--scale" in a.option_strings)
    assert "X=kx*r, Y=ky*c" in scale_help and "r = row" in scale_help
    # a real mesh with the default camera: x is each vertex's row, y its column
    mesh = rangemesh.triangulate(crops()["chair"][0], vertices=200)
    axis = {"row": 0, "column": 1}
    assert np.array_equal(mesh.vertices[:, 0], mesh.pixels[:, axis[said[1]]])
    assert np.array_equal(mesh.vertices[:, 1], mesh.pixels[:, axis[said[2]]])


def test_ci_runs_the_quick_start():
    """CI installs and tests with the README's own quick-start command."""
    quick = next(code for lang, code in EXAMPLES if "pip install" in code)
    command = 'pip install -e ".[test]" && python -m pytest'
    assert command in quick
    ci = README.parent / ".ci" / "run"
    if ci.exists():
        assert command in ci.read_text(encoding="utf-8").splitlines()


@pytest.mark.slow
@pytest.mark.parametrize("index", range(len(PYTHON)), ids=lambda i: f"{PYTHON[i][0]}-python-{i + 1}")
def test_python_block(index, beside_data):
    code = PYTHON[index][1]
    cwd = workdir(beside_data, f"python-{index + 1}")
    (cwd / "example.py").write_text(code, encoding="utf-8")
    p = subprocess.run([sys.executable, "example.py"], cwd=cwd, env=env(),
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    printed = [line.rstrip() for line in p.stdout.splitlines()]
    assert printed == expected_prints(code), code


@pytest.mark.slow
@pytest.mark.parametrize("index", range(len(SHELL)), ids=lambda i: f"{SHELL[i][0]}-shell-{i + 1}")
def test_shell_block(index, beside_data):
    cwd = workdir(beside_data, f"shell-{index + 1}")
    for line in shell_lines(SHELL[index][1]):
        p = subprocess.run(["bash", "-c", line], cwd=cwd, env=env(),
                           capture_output=True, text=True, timeout=300)
        assert p.returncode == 0, f"{line}\n{p.stderr}"
        out = p.stdout + p.stderr
        for text in quoted(line):  # as a whole figure: "1443" is not the start of "14430"
            assert re.search(re.escape(text) + r"(?!\d|\.\d)", out), f"{line}\nexpected {text!r} in:\n{out}"
        for name in re.findall(r"writes (\S+\.\w+)", COMMENT.split(line, maxsplit=1)[-1]):
            assert (cwd / name.rstrip(";,.")).exists(), f"{line}: no {name}"
