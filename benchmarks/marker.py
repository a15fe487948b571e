"""The ROS Marker of a mesh (``rangemesh batch REC -o meshes.mcap``) against the meshing it follows.

    RANGEMESH_THREADS=1 taskset -c 0 python benchmarks/marker.py [--repeat 15]

On the shared RealSense bag's two 640x480 depth frames, at the default target
and at 2 % of the valid pixels as vertices (the target's cap), times
(``time.process_time``, medians of --repeat rounds, interleaved) of:

* meshing: ``rangemesh.triangulate(depth, camera=..., background=0)``;
* the marker: `rangemesh.recordings.writing.marker_bytes` (the CDR bytes
  written from the mesh's arrays);
* the marker as rosbags message objects, a ``Point`` per corner, serialised by
  ``serialize_cdr`` (the reference of tests/test_recordings.py, what
  ``marker_bytes`` did before its fast path).

Prints a Markdown table; the share is the marker's time over meshing's.
"""

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

import rangemesh
from rangemesh.recordings import mesh_bag
from rangemesh.recordings.writing import marker_bytes

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from tests.test_recordings import marker_by_rosbags  # noqa: E402

BAG = "rosbag/librealsense_d435_single_depth_color_640x480.bag"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=15)
    args = ap.parse_args(argv)
    from rosbags.highlevel import AnyReader

    path = Path(os.environ.get("RANGEMESH_DATA", ROOT.parent / "shared" / "data")) / BAG
    with AnyReader([path]) as r:
        conns = [c for c in r.connections if c.topic.endswith("Depth_0/image/data")]
        depths = [np.frombuffer(r.deserialize(d, c.msgtype).data.tobytes(), "<u2").reshape(480, 640)
                  for c, _, d in r.messages(connections=conns)]
    frames = list(mesh_bag(path))  # stamps, frame ids and the camera as batch reads them
    cam = frames[0][2].camera
    share = int(0.02 * min(int((d > 0).sum()) for d in depths))
    for label, opts in [("default target", {}), (f"vertices={share} (2 % of the valid pixels)",
                                                  {"vertices": share})]:
        times = {"meshing": [], "marker_bytes": [], "rosbags objects": []}
        for _ in range(args.repeat):
            for (stamp, frame_id, _), depth in zip(frames, depths, strict=True):
                t0 = time.process_time()
                mesh = rangemesh.triangulate(depth, camera=cam, background=0, **opts)
                t1 = time.process_time()
                fast = marker_bytes(mesh, stamp, frame_id)
                t2 = time.process_time()
                slow = marker_by_rosbags(mesh, stamp, frame_id)
                t3 = time.process_time()
                assert fast == slow
                for k, t in zip(times, (t1 - t0, t2 - t1, t3 - t2), strict=True):
                    times[k].append(t)
        sizes = [(len(m.vertices), len(m.faces)) for m in
                 (rangemesh.triangulate(d, camera=cam, background=0, **opts) for d in depths)]
        print(f"\nRealSense 640x480, {label}: (vertices, triangles) {sizes}, "
              f"{args.repeat} rounds x 2 frames")
        print("| step | median ms | share of meshing |\n|---|---|---|")
        mesh_ms = statistics.median(times["meshing"]) * 1e3
        for k, v in times.items():
            ms = statistics.median(v) * 1e3
            print(f"| {k} | {ms:.2f} | {ms / mesh_ms:.1%} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
