"""Images per second of `rangemesh.mesh_many` with 1 and 2 workers on VGA frames.

    python benchmarks/batch.py [--frames 300]

Generates --frames 640x480 depth frames (uint16 millimetres, a box on a tilted
plane with noise and holes, different per frame) as .npy files, then meshes
them all through a local Dask cluster of 1 and of 2 worker processes. Cluster
start-up is timed apart from the meshing. Each task reads the frame, meshes
it (8x8 tiles, 10x10 samples), evaluates it and writes a binary PLY.
"""

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from rangemesh import scenes
from rangemesh.batch import mesh_many


def make_frames(folder: Path, n: int):
    rng = np.random.default_rng(0)
    for i in range(n):
        sc = scenes.box((480, 640), height=300.0 + 5 * (i % 20), noise=2.0, seed=i)
        d = (sc.depth * 10).astype(np.uint16)
        holes = rng.random(d.shape) < 0.02
        d[holes] = 0
        np.save(folder / f"frame_{i:04d}.npy", d)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=300)
    args = ap.parse_args(argv)
    from dask.distributed import LocalCluster

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "in").mkdir()
        make_frames(tmp / "in", args.frames)
        print("| workers | cluster start s | meshing s | images/s | median s per image | failed |")
        print("|---:|---:|---:|---:|---:|---:|")
        rates = {}
        for workers in (1, 2):
            t0 = time.perf_counter()
            with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                              dashboard_address=None, silence_logs=40) as cluster:
                t1 = time.perf_counter()
                # warm every worker (Numba cache load) on a few frames, then time the rest
                warm = sorted((tmp / "in").glob("*.npy"))[: 2 * workers]
                mesh_many(warm, tmp / f"warm{workers}", scheduler=cluster.scheduler_address,
                          tiles=8, background=0, method="paper")
                t2 = time.perf_counter()
                res = mesh_many([tmp / "in"], tmp / f"out{workers}",
                                scheduler=cluster.scheduler_address, tiles=8, background=0, method="paper")
                t3 = time.perf_counter()
            done = [r for r in res if r.status == "meshed"]
            rates[workers] = len(done) / (t3 - t2)
            med = float(np.median([r.seconds for r in done]))
            print(f"| {workers} | {t1 - t0:.1f} | {t3 - t2:.1f} | {rates[workers]:.1f} | {med:.3f} "
                  f"| {len(res) - len(done)} |")
        print(f"\nspeed-up with 2 workers: {rates[2] / rates[1]:.2f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
