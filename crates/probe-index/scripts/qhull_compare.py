#!/usr/bin/env python3
"""Times probe-index's Delaunay build against scipy.spatial.Delaunay (Qhull) on the same points.

Writes N seeded uniform points in the unit cube (float32, so both sides see identical values)
to a file, builds the `delaunay_timing` example in release mode, then alternates the two
builds REPEATS times so both run under the same machine load. Prints each run, the medians,
the ratio (ours / Qhull) and the load average before and after.

    python3 crates/probe-index/scripts/qhull_compare.py [--points 100000] [--repeats 7] [--seed 1]

Needs numpy and scipy (`pip install scipy`). Run it from anywhere inside the workspace.
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np
from scipy.spatial import Delaunay


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=100_000)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()

    crate = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    subprocess.run(
        ["cargo", "build", "--release", "-q", "-p", "probe-index", "--example", "delaunay_timing"],
        cwd=crate,
        check=True,
    )
    target = subprocess.run(
        ["cargo", "metadata", "--format-version", "1", "--no-deps"],
        cwd=crate,
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    import json

    binary = os.path.join(json.loads(target)["target_directory"], "release", "examples", "delaunay_timing")

    rng = np.random.default_rng(args.seed)
    points32 = rng.random((args.points, 3)).astype(np.float32)
    points64 = points32.astype(np.float64)
    with tempfile.NamedTemporaryFile(suffix=".f32", delete=False) as f:
        points32.tofile(f)
        path = f.name

    load_before = os.getloadavg()
    ours, qhull = [], []
    ours_tets = qhull_tets = None
    try:
        for run in range(args.repeats):
            start = time.perf_counter()
            tri = Delaunay(points64)
            qhull.append(time.perf_counter() - start)
            qhull_tets = len(tri.simplices)
            del tri

            out = subprocess.run([binary, path, "1"], check=True, capture_output=True, text=True).stdout
            line = next(l for l in out.splitlines() if l.startswith("run="))
            fields = dict(kv.split("=") for kv in line.split())
            ours.append(float(fields["seconds"]))
            ours_tets = int(fields["tetrahedra"])
            print(f"run {run}: probe-index {ours[-1]:.4f} s, qhull {qhull[-1]:.4f} s", flush=True)
    finally:
        os.unlink(path)
    load_after = os.getloadavg()

    m_ours = statistics.median(ours)
    m_qhull = statistics.median(qhull)
    print(f"points={args.points} seed={args.seed} repeats={args.repeats}")
    print(f"tetrahedra: probe-index {ours_tets}, qhull {qhull_tets}")
    print(f"median probe-index {m_ours:.4f} s, median qhull {m_qhull:.4f} s, ratio {m_ours / m_qhull:.3f}")
    print(f"load average before {load_before[0]:.2f}, after {load_after[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
