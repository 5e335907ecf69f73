#!/usr/bin/env python3
"""The bind's cost with each volume mode, and an iteration's (docs/performance.md, "Volume Infill's bind").

    /usr/bin/python3 bench/native/bind_cost.py BUILD [OTHER_BUILD ...] --sizes 10000,100000,250000

For each procedural mesh made by the first build's arap-make-mesh (bar,
sphere, cylinder; lowest fifth fixed, top 5% the handle, pulled sideways by
0.3 of the height), each build's native module binds it with every mode of
--modes in turn, --repeats times (the modes' order alternating), one thread,
and then runs --iterations iterations from the naive start with each mode,
--repeats times (alternating too).
Each build runs in a process of its own, the builds one after the other for
each mesh (old and new side by side). Prints the median CPU time of a bind
(time.process_time: the machine may be busy) per mode, each mode's ratio to
the first (the median of the repeats' ratios), the median CPU per iteration
and the factor's entries.
Needs numpy.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from volume_settle import bend_problem, make_mesh  # noqa: E402


def child(build, mesh_file, modes, repeats, iterations):
    """One build's measurements of one mesh, printed as JSON."""
    sys.path.insert(0, os.path.join(build, "addon", "arap_deform"))
    import _arap_native as arap

    data = np.load(mesh_file)
    rest, faces = data["rest"], data["faces"]
    constrained, pose, _further = bend_problem(rest)
    bind = {m: [] for m in modes}
    for r in range(repeats):
        for mode in (modes if r % 2 == 0 else modes[::-1]):
            solver = arap.Solver()
            start = time.process_time()
            solver.bind(rest, faces, constrained, volume=mode, threads=1)
            bind[mode].append(1e3 * (time.process_time() - start))
            del solver
    out = {"bind_ms": {m: statistics.median(v) for m, v in bind.items()},
           "ratio": {m: statistics.median(b / a for a, b in zip(bind[modes[0]], bind[m])) for m in modes[1:]}}
    solvers = {}
    for mode in modes:
        solvers[mode] = arap.Solver()
        solvers[mode].bind(rest, faces, constrained, volume=mode, threads=1)
        solvers[mode].configure(init="naive", max_iterations=iterations, tolerance=0)
        out.setdefault("factor_nonzeros", {})[mode] = solvers[mode].factor_nonzeros
    per_iteration = {m: [] for m in modes}
    for r in range(repeats):
        for mode in (modes if r % 2 == 0 else modes[::-1]):
            solvers[mode].forget_solution()
            start = time.process_time()
            stats = solvers[mode].solve(pose)
            per_iteration[mode].append(1e3 * (time.process_time() - start) / max(1, stats.iterations))
    out["iteration_ms"] = {m: statistics.median(v) for m, v in per_iteration.items()}
    print(json.dumps(out))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("builds", nargs="*", help="build folders (arap-make-mesh, addon/arap_deform/_arap_native)")
    parser.add_argument("--sizes", default="10000,100000,250000")
    parser.add_argument("--shapes", default="sphere,bar,cylinder")
    parser.add_argument("--modes", default="none,infill", help="volume modes; ratios are to the first")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--iterations", type=int, default=10)
    parser.add_argument("--child", nargs=2, metavar=("BUILD", "MESH_NPZ"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    modes = args.modes.split(",")
    if args.child:
        return child(args.child[0], args.child[1], modes, args.repeats, args.iterations)
    names = [os.path.basename(os.path.dirname(os.path.abspath(b))) or b for b in args.builds]
    print("| mesh | V | build | " + " | ".join("bind %s CPU ms" % m for m in modes) + " | " +
          " | ".join("%s / %s bind" % (m, modes[0]) for m in modes[1:]) + " | " +
          " | ".join("iteration %s ms" % m for m in modes) + " | factor entries " + ", ".join(modes) + " |")
    print("|---|---:|---|" + "---:|" * (3 * len(modes)))
    with tempfile.TemporaryDirectory() as folder:
        for shape in args.shapes.split(","):
            for size in (int(s) for s in args.sizes.split(",")):
                rest, faces = make_mesh(args.builds[0], shape, size, folder)
                mesh_file = os.path.join(folder, "mesh.npz")
                np.savez(mesh_file, rest=rest, faces=faces)
                for name, build in zip(names, args.builds):
                    run = subprocess.run([sys.executable, __file__, "--child", build, mesh_file, "--modes", args.modes,
                                          "--repeats", str(args.repeats), "--iterations", str(args.iterations)],
                                         check=True, capture_output=True, text=True)
                    r = json.loads(run.stdout)
                    print("| %s | %d | %s | %s | %s | %s | %s |" % (
                        shape, len(rest), name, " | ".join("%.0f" % r["bind_ms"][m] for m in modes),
                        " | ".join("%.2f" % r["ratio"][m] for m in modes[1:]),
                        " | ".join("%.1f" % r["iteration_ms"][m] for m in modes),
                        ", ".join("%d" % r["factor_nonzeros"][m] for m in modes)), flush=True)


if __name__ == "__main__":
    main()
