"""The compiled core's include layering holds, as import-linter checks the Python layers.

Read from the ``#include`` lines under ``src/rangemesh/_core`` (docs/core.md, "Layout"):

* the top-level headers (``views.hpp``, ``interrupt.hpp``, ``parallel.hpp``, ``simd.hpp``) include
  no folder;
* ``geometry/`` includes only itself and the top-level headers;
* a family (``paper/``, ``refine/``, ``heights/``) includes itself, ``geometry/`` and the
  top-level headers, never another family sideways; the one layer between families is
  ``refine -> heights`` (the whole refine call fits its heights), never the other way;
* nanobind and Python's C API appear only in ``bind/`` and ``module.cpp``.
"""

import re
from pathlib import Path

import pytest

CORE = Path(__file__).resolve().parents[1] / "src" / "rangemesh" / "_core"

FAMILIES = ("paper", "refine", "heights")
# (includer, included): the only include from one family into another
FAMILY_LAYERS = {("refine", "heights")}
BINDING = ("bind",)

INCLUDE = re.compile(r'^\s*#\s*include\s*([<"])([^>"]+)[>"]', re.M)
COMMENT = re.compile(r"//[^\n]*|/\*.*?\*/", re.S)
PYTHON = re.compile(r"\bnanobind\b|\bnb::|\bNB_[A-Z_]+\b|\bPython\.h\b|\bPy[A-Z][A-Za-z]*_\w+")


def part(path: Path, core: Path) -> str:
    """The layer a file under `core` is in: its folder, or "top" for the files beside bind/."""
    rel = path.relative_to(core)
    return rel.parts[0] if len(rel.parts) > 1 else "top"


def violations(core: Path = CORE) -> list:
    """Every include that breaks the layering, and every nanobind or Python use outside bind/."""
    bad = []
    for path in sorted(core.rglob("*")):
        if path.suffix not in (".hpp", ".cpp", ".h", ".cc"):
            continue
        here = part(path, core)
        text = path.read_text()
        name = path.relative_to(core).as_posix()
        binding = here in BINDING or name == "module.cpp"
        if not binding and PYTHON.search(INCLUDE.sub("", COMMENT.sub("", text))):  # includes: below
            bad.append(f"{name}: nanobind or Python outside bind/ and module.cpp")
        for kind, target in INCLUDE.findall(text):
            if kind == "<":
                if not binding and ("nanobind" in target or target == "Python.h"):
                    bad.append(f"{name}: includes <{target}> outside bind/ and module.cpp")
                continue
            resolved = (path.parent / target).resolve()
            try:
                there = part(resolved, core.resolve())
            except ValueError:
                bad.append(f"{name}: includes {target}, outside the core")
                continue
            if binding or there == here or there == "top" and here != "top":
                continue
            if here == "top":
                bad.append(f"{name}: a top-level header includes {target}")
            elif there == "geometry" and here in FAMILIES:
                continue
            elif (here, there) in FAMILY_LAYERS:
                continue
            else:
                bad.append(f"{name}: {here}/ includes {target} ({there}/)")
    return bad


def test_core_includes_keep_their_layers():
    assert violations() == []


def _copy(tmp_path):
    out = tmp_path / "_core"
    for path in CORE.rglob("*"):
        if path.is_file() and path.suffix in (".hpp", ".cpp"):
            dest = out / path.relative_to(CORE)
            dest.parent.mkdir(parents=True, exist_ok=True)
            dest.write_text(path.read_text())
    return out


@pytest.mark.parametrize("where, line, expect", [
    ("heights/pass.cpp", '#include "../refine/keys.hpp"', "heights/ includes ../refine/keys.hpp"),
    ("paper/flipping.cpp", '#include "../refine/plane.hpp"', "paper/ includes ../refine/plane.hpp"),
    ("refine/scan.cpp", '#include "../paper/sampling.hpp"', "refine/ includes ../paper/sampling.hpp"),
    ("geometry/fans.cpp", '#include "../refine/keys.hpp"', "geometry/ includes"),
    ("geometry/fans.cpp", '#include "../bind/numpy.hpp"', "geometry/ includes"),
    ("views.hpp", '#include "geometry/heap.hpp"', "a top-level header includes"),
    ("refine/walls.cpp", "#include <nanobind/nanobind.h>", "includes <nanobind/nanobind.h>"),
    ("heights/fit.cpp", "static int n = nb::len;", "nanobind or Python outside bind/"),
])
def test_a_planted_violation_is_found(tmp_path, where, line, expect):
    core = _copy(tmp_path)
    assert violations(core) == []
    path = core / where
    path.write_text(line + "\n" + path.read_text())
    found = violations(core)
    assert len(found) == 1 and found[0].startswith(where) and expect in found[0], found


def test_a_comment_naming_nanobind_is_no_violation(tmp_path):
    core = _copy(tmp_path)
    path = core / "geometry" / "fans.cpp"
    path.write_text("// no nanobind here: the bindings are in bind/\n" + path.read_text())
    assert violations(core) == []
