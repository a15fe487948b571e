"""rangemesh.timing: the one helper every stage's seconds are taken with."""

import ast
from pathlib import Path

import numpy as np
import pytest

import rangemesh
from rangemesh import timing
from rangemesh.timing import timed


@pytest.fixture
def clock(monkeypatch):
    """A clock that reads 10, 12.5, 13, ... seconds: each call the next value."""
    ticks = iter([10.0, 12.5, 13.0, 19.0, 20.0, 20.25])
    monkeypatch.setattr(timing, "perf_counter", lambda: next(ticks))


def test_a_block_adds_its_seconds_to_its_entry(clock):
    seconds = {"sampling": 1.0}
    with timed(seconds, "sampling"):  # entered at 12.5 (10 was the constructor's), left at 13
        pass
    assert seconds == {"sampling": 1.5}
    with timed(seconds, "seam"):  # (19) 20 -> 20.25, a new entry
        pass
    assert seconds == {"sampling": 1.5, "seam": 0.25}


def test_a_block_that_raises_is_timed_too(clock):
    seconds = {}
    with pytest.raises(KeyError), timed(seconds, "flipping"):
        raise KeyError("x")
    assert seconds == {"flipping": 0.5}


def test_a_clock_without_a_block_reads_the_seconds_since_its_start(clock):
    c = timed()  # started at 10
    assert c.elapsed == 2.5 and c.elapsed == 3.0


def test_no_module_reads_the_clock_itself():
    # issue 43: 34 hand-written perf_counter() timings in 7 modules; they go through timing.py.
    # refine/insertion.py is another branch's to change (its timings are left for it), and
    # live/pacing.py's clock is the pace of a stream, injected by its tests, not a timing
    package = Path(rangemesh.__file__).parent
    left = {"refine/insertion.py", "live/pacing.py", "timing.py"}
    readers = []
    for path in sorted(package.rglob("*.py")):
        rel = path.relative_to(package).as_posix()
        names = {n.attr if isinstance(n, ast.Attribute) else n.id
                 for n in ast.walk(ast.parse(path.read_text()))
                 if isinstance(n, (ast.Attribute, ast.Name))}
        if names & {"perf_counter", "monotonic", "process_time"} and rel not in left:
            readers.append(rel)
    # memory.py: /proc/meminfo's age (time.monotonic), not a timing
    assert readers == ["memory.py"], "time a block with rangemesh.timing.timed (or its now)"


def test_every_stage_of_a_wrapped_paper_stream_is_timed():
    r, c = np.mgrid[0:24, 0:32]
    frames = [100.0 + r + 0.5 * c] * 2
    for mesh in rangemesh.mesh_stream(frames, method="paper", tiles=2, samples=5, wrap=True):
        s = mesh.stats.seconds
        assert list(s) == ["prepare", "sampling", "triangulation", "flipping", "seam", "total"]
        assert all(v >= 0.0 for v in s.values())
        assert s["total"] >= sum(v for k, v in s.items() if k != "total")
