#!/usr/bin/env python3
"""The cold solve and the settle after a step, with each volume mode (docs/performance.md).

    /usr/bin/python3 bench/native/volume_settle.py build --sizes 100000,250000

For each procedural mesh made by arap-make-mesh (bar and bumpy sphere, lowest
fifth fixed, top 5% the handle, pulled sideways by 0.3 of the height), through
the native module with the default options and --modes: a cold solve to the
pose, then the handle moved 5% of the longest side further and settled warm
(the last step of a drag, as Live and Auto mode solve). Prints iterations and
the median CPU time (time.process_time, the machine may be busy) of --repeats
such pairs, and each mode's ratio to the first mode's. Needs numpy.
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from volume_table import read_obj  # noqa: E402


def make_mesh(build, shape, vertices, folder):
    path = os.path.join(folder, "%s%d.obj" % (shape, vertices))
    subprocess.run([os.path.join(build, "arap-make-mesh"), shape, "--vertices", str(vertices), "--output", path],
                   check=True, capture_output=True)
    rest, faces = read_obj(path)
    return np.array(rest, dtype=np.float64), np.array(faces, dtype=np.int32)


def bend_problem(rest):
    """The bend of these benchmarks: the lowest fifth fixed, the top 5% the handle, pulled sideways by 0.3 of the
    height (`pose`), then 5% of the longest side further (`further`). Returns (constrained, pose, further)."""
    z = rest[:, 2]
    lo, height = z.min(), z.max() - z.min()
    fixed = np.where(z <= lo + 0.2 * height + 1e-9)[0]
    handle = np.where(z >= lo + 0.95 * height - 1e-9)[0]
    constrained = np.concatenate([fixed, handle]).astype(np.int64)
    pose = rest[constrained].copy()
    pose[len(fixed):, 0] += 0.3 * height
    further = pose.copy()
    further[len(fixed):, 0] += 0.05 * (rest.max(axis=0) - rest.min(axis=0)).max()
    return constrained, pose, further


def measure(arap, rest, faces, mode, repeats):
    constrained, pose, further = bend_problem(rest)
    solver = arap.Solver()
    solver.bind(rest, faces, constrained, volume=mode)
    cold, settle = [], []
    for _ in range(repeats):
        solver.forget_solution()
        solver.configure(init="naive")
        start = time.process_time()
        first = solver.solve(pose)
        cold.append(time.process_time() - start)
        solver.configure(init="warm")
        start = time.process_time()
        step = solver.solve(further)
        settle.append(time.process_time() - start)
    return first, statistics.median(cold), step, statistics.median(settle)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("build", help="the build folder (arap-make-mesh, addon/arap_deform/_arap_native)")
    parser.add_argument("--sizes", default="100000,250000")
    parser.add_argument("--shapes", default="bar,sphere")
    parser.add_argument("--modes", default="none,infill", help="volume modes; ratios are to the first")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    sys.path.insert(0, os.path.join(args.build, "addon", "arap_deform"))
    import _arap_native as arap

    modes = args.modes.split(",")
    print("| mesh | V | " + " | ".join("%s: cold it / CPU s, settle it / CPU s" % m for m in modes) +
          " | " + " | ".join("%s / %s: cold, settle" % (m, modes[0]) for m in modes[1:]) + " |")
    print("|---|---:|" + "---|" * (2 * len(modes) - 1))
    with tempfile.TemporaryDirectory() as folder:
        for shape in args.shapes.split(","):
            for size in (int(s) for s in args.sizes.split(",")):
                rest, faces = make_mesh(args.build, shape, size, folder)
                rows = [measure(arap, rest, faces, m, args.repeats) for m in modes]
                cells = ["%d / %.2f, %d / %.2f" % (f.iterations, c, s.iterations, t) for f, c, s, t in rows]
                ratios = ["%.2f, %.2f" % (r[1] / rows[0][1], r[3] / rows[0][3]) for r in rows[1:]]
                print("| %s | %d | %s | %s |" % (shape, len(rest), " | ".join(cells), " | ".join(ratios)), flush=True)


if __name__ == "__main__":
    main()
