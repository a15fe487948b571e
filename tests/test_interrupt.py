"""Ctrl-C inside the compiled kernels: the call stops, raises KeyboardInterrupt, and the process lives on."""

import re
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from .helpers import interrupt

CHILD = textwrap.dedent("""
    import os, signal, sys, threading, time
    import numpy as np
    import rangemesh

    r, c = np.mgrid[0:{n}, 0:{n}]
    depth = 100.0 + 10.0 * np.sin(r / 37.0) * np.cos(c / 23.0) + (r * c) % 7
    method = sys.argv[1]
    kw = dict(vertices={vertices}) if method == "refine" else dict(tiles=(40, 40), samples=(60, 60))
    print("ready", flush=True)
    sent = []
    threading.Timer({delay}, lambda: (sent.append(time.perf_counter()),
                                       os.kill(os.getpid(), signal.SIGINT))).start()
    try:
        rangemesh.triangulate(depth, method=method, **kw)
        print("finished", flush=True)
    except KeyboardInterrupt:
        print(f"interrupted after {{time.perf_counter() - sent[0]:.3f}} s", flush=True)
    # the process is still sound: another call works
    m = rangemesh.triangulate(depth[:50, :50], method="refine", vertices=20)
    print("again", len(m.vertices), flush=True)
""")


@pytest.mark.slow
@pytest.mark.parametrize("method", ["refine", "paper"])
def test_ctrl_c_stops_a_long_call_and_the_next_call_works(method):
    # a call of several seconds; the signal comes while a kernel runs
    code = CHILD.format(n=2500, vertices=400_000, delay=1.0)
    p = subprocess.run([sys.executable, "-c", code, method], capture_output=True, text=True,
                       timeout=600)
    lines = p.stdout.split("\n")
    assert p.returncode == 0, p.stderr[-2000:]
    assert lines[0] == "ready"
    assert lines[1].startswith("interrupted after"), p.stdout  # not "finished"
    assert lines[2] == "again 20"
    assert "Traceback" not in p.stderr


# effort="best" on a 1200 x 1200 image: 20,000 vertices collapsed from 80,000. The dense mesh
# alone is timed first; the signal comes at 1.5 times that (plus 0.5 s) into the call, during
# the collapses, which take about five times as long as the dense mesh.
BEST = textwrap.dedent("""
    import os, signal, threading, time
    import numpy as np
    import rangemesh

    r, c = np.mgrid[0:1200, 0:1200]
    depth = 100.0 + 10.0 * np.sin(r / 37.0) * np.cos(c / 23.0) + (r * c) % 7
    t = time.perf_counter()
    rangemesh.triangulate(depth, vertices=80_000)
    dense = time.perf_counter() - t
    sent = []
    threading.Timer(1.5 * dense + 0.5, lambda: (sent.append(time.perf_counter()),
                                                 os.kill(os.getpid(), signal.SIGINT))).start()
    t = time.perf_counter()
    try:
        rangemesh.triangulate(depth, vertices=20_000, effort="best")
        print(f"finished in {time.perf_counter() - t:.3f} s (dense {dense:.3f} s)", flush=True)
    except KeyboardInterrupt:
        print(f"interrupted after {time.perf_counter() - sent[0]:.3f} s", flush=True)
    m = rangemesh.triangulate(depth[:50, :50], vertices=20, effort="best")
    print("again", len(m.vertices), flush=True)
""")


@pytest.mark.slow
def test_ctrl_c_stops_the_collapses_of_effort_best():
    p = subprocess.run([sys.executable, "-c", BEST], capture_output=True, text=True, timeout=600)
    lines = p.stdout.split("\n")
    assert p.returncode == 0, p.stderr[-2000:]
    assert lines[0].startswith("interrupted after"), p.stdout  # not "finished"
    assert float(re.search(r"after ([0-9.]+) s", lines[0]).group(1)) < 0.5
    assert lines[1] == "again 20"


# Two Python threads meshing at once; SIGINT comes while both are in the kernels. Each line of
# output is one round: what the main thread's call did, what the worker's did, and whether the
# worker was still meshing when the signal was sent.
TWO_THREADS = textwrap.dedent("""
    import os, signal, threading, time
    import numpy as np
    import rangemesh

    n = {n}
    depth = (np.add.outer(np.sin(np.arange(n) / 37.0), np.cos(np.arange(n) / 23.0)) * 10 + 100
             + np.random.default_rng(0).random((n, n)) * 0.5)
    quiet = rangemesh.triangulate(depth, max_error=0.05)  # undisturbed, on the main thread
    print("ready", flush=True)

    def kill_now(alive):
        alive.append(worker.is_alive())
        os.kill(os.getpid(), signal.SIGINT)

    for _ in range({rounds}):
        got, alive, started = {{}}, [], threading.Event()

        def mesh_in_worker():
            started.set()
            try:
                got["mesh"] = rangemesh.triangulate(depth, max_error=0.05)
            except BaseException as e:  # noqa: BLE001 - what the worker saw is the result
                got["error"] = type(e).__name__

        worker = threading.Thread(target=mesh_in_worker)
        try:
            worker.start()
            started.wait()
            time.sleep(0.2)  # the worker inside its kernels
            threading.Timer(0.3, kill_now, (alive,)).start()
            rangemesh.triangulate(depth, max_error=0.05)
            main = "finished"
        except KeyboardInterrupt:
            main = "KeyboardInterrupt"
        worker.join()
        if "error" in got:
            seen = got["error"]
        else:
            same = (np.array_equal(got["mesh"].faces, quiet.faces)
                    and np.array_equal(got["mesh"].vertices, quiet.vertices))
            seen = "same mesh" if same else "another mesh"
        print(main, "|", seen, "|", "worker alive" if alive == [True] else f"worker alive: {{alive}}",
              flush=True)
""")


@pytest.mark.slow
def test_ctrl_c_stops_only_the_main_threads_call():
    # F2: the kernels' interrupt flag was process-wide, so a worker thread's call raised
    # KeyboardInterrupt too; Python raises it in the main thread only
    rounds = 3
    p = subprocess.run([sys.executable, "-c", TWO_THREADS.format(n=600, rounds=rounds)],
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr[-2000:]
    lines = p.stdout.splitlines()
    assert lines[0] == "ready", p.stdout
    assert lines[1:] == ["KeyboardInterrupt | same mesh | worker alive"] * rounds, p.stdout


# Sample tiles on two threads, over and over until SIGINT: the first half of the tile rows (the
# calling thread's) one pixel tall each, the second half (the started thread's) the rest of the
# image, a poll a tile. The grid tells where the call stopped: "partial" (some tiles written, not
# the last) only when the started thread stopped the call; "whole" or "none" when the signal came
# between calls, or when the call ran to its end (the calling thread had long finished its tiles).
SKEWED_TILES = textwrap.dedent("""
    import os, signal, threading
    import numpy as np
    from rangemesh import _core

    h, w, tiles, rs, zs = 3000, 2000, 100, 8, 8
    f = np.random.default_rng(2).uniform(0.5, 2.0, (h, w))
    thin = np.arange(tiles // 2 + 1)
    rows = np.concatenate([thin, np.linspace(thin[-1], h - 1, tiles // 2 + 1).round()[1:]]).astype(np.int64)
    cols = np.array([0, w - 1], np.int64)
    grid = np.full(((rs - 1) * tiles + 1, zs, 2), -1, np.int32)
    for _ in range(5):
        threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGINT)).start()
        try:
            while True:
                grid.fill(-1)
                _core.sample_tiles(f, rows, cols, rs, zs, grid, 2)
        except KeyboardInterrupt:
            written = grid[:, :, 0] >= 0
            partial = written.any() and not written[-1].any()
            outcome = "whole" if written.all() else "partial" if partial else "none"
        print(outcome, flush=True)
        if outcome == "partial":
            break
""")


@pytest.mark.slow
def test_ctrl_c_stops_the_threads_a_main_thread_kernel_starts():
    # the flag reaches the native threads of a main-thread call (polled_thread): here the calling
    # thread's tiles are done at once and it waits in join, so only the started thread can stop
    # the call before its end
    p = subprocess.run([sys.executable, "-c", SKEWED_TILES], capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr[-2000:]
    assert "partial" in p.stdout.split(), p.stdout


def test_every_kernel_thread_is_started_by_polled_thread():
    # a thread made by std::thread directly would not heed Ctrl-C; interrupt.hpp makes the
    # others (polled_thread, and free_later's, which polls nothing)
    core = Path(__file__).resolve().parents[1] / "src" / "rangemesh" / "_core"
    direct = []
    for path in sorted(core.rglob("*.[ch]pp")):
        if path.name == "interrupt.hpp":
            continue
        for k, line in enumerate(path.read_text().splitlines(), 1):
            code = line.split("//")[0]
            if re.search(r"std::thread\s*[({]|std::thread\s+\w+\s*[({]|std::(async|jthread)\b", code):
                direct.append(f"{path.relative_to(core)}:{k}: {line.strip()}")
    assert direct == [], "\n".join(direct)


# ---------------------------------------------------------------- from the hostile-input reports


_DELAUNAY_LOOP = textwrap.dedent("""
    import numpy as np, sys
    from rangemesh.paper.triangulation import triangulate_points
    pts = np.unique(np.random.default_rng(0).integers(0, 1500, (250_000, 2)), axis=0)
    triangulate_points(pts[:100])
    print("ready", flush=True)
    while True:
        triangulate_points(pts)
""")


# D16 of the 2026-11-21 hostile-input report
def test_sigint_during_the_delaunay_never_crashes(tmp_path):
    """Ctrl-C lands inside the Delaunay kernel most of the time; before the fix some of
    these runs ended in a segmentation fault (exit -11) or SystemError."""
    script = tmp_path / "loop.py"
    script.write_text(_DELAUNAY_LOOP)
    for delay in (0.05, 0.2, 0.45, 0.7, 1.1):
        proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True)
        assert proc.stdout.readline().strip() == "ready"
        import time

        time.sleep(delay)
        err = interrupt(proc)
        # an uncaught KeyboardInterrupt ends Python by SIGINT itself (returncode -2)
        assert proc.returncode == -signal.SIGINT, err
        assert err.rstrip().endswith("KeyboardInterrupt"), err
        assert "SystemError" not in err and "Fatal Python error" not in err


# the 2026-11-25 hostile-input report
@pytest.mark.slow
def test_ctrl_c_while_the_command_line_loads_is_130_and_one_line():
    import subprocess
    import sys
    import textwrap

    # a Ctrl-C that lands while `rangemesh.cli` (NumPy, the kernels) is being imported
    code = textwrap.dedent("""
        import sys
        class Interrupting:
            def find_spec(self, name, path=None, target=None):
                if name == "rangemesh.cli":
                    raise KeyboardInterrupt
        sys.meta_path.insert(0, Interrupting())
        from rangemesh._launch import main
        sys.exit(main())
    """)
    p = subprocess.run([sys.executable, "-c", code, "demo", "-o", "x.ply"], capture_output=True,
                       text=True, timeout=120)
    assert p.returncode == 130
    assert p.stderr.strip().splitlines() == ["rangemesh: interrupted (SIGINT) while starting"]
