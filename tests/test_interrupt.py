"""Ctrl-C inside the compiled kernels: the call stops, raises KeyboardInterrupt, and the process lives on."""

import subprocess
import sys
import textwrap

import pytest

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
