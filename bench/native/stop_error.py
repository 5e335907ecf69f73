#!/usr/bin/env python3
"""How far from the converged pose does a solve stop? (docs/performance.md, "Where the stop ends")

    /usr/bin/python3 bench/native/stop_error.py build [--sizes 10000] [--shapes bar,sphere,tube]
        [--modes none,infill,global] [--methods quasi-newton,local-global,anderson]
    /usr/bin/python3 bench/native/stop_error.py build --stops build-old --modes infill
    /usr/bin/python3 bench/native/stop_error.py build --timing build-old,build --sizes 10000,100000,250000

Each procedural mesh made by arap-make-mesh (bar, bumpy sphere, and the
cylinder without its caps as an open tube; lowest fifth fixed, top 5% the
handle, pulled sideways by 0.3 of the height) is solved cold with the default
options, then warm after the handle moved 5% of the longest side further (the
last step of a drag). Each stop is compared with the converged pose of the
same problem from the same start (quasi-Newton at tolerance 1e-13, up to
20000 iterations): printed is the largest distance of a vertex between the
two as a share of the rest bounding box's diagonal, the iterations, and
whether the solve said `converged`. --stops BUILD: the stops made by another
build's module (e.g. the one before a change), against this build's converged
poses (the energy is the same; only where the iteration goes may differ).

--timing BUILDS: iterations and the median CPU time (time.process_time) of
--repeats cold + warm pairs for each build folder's module, the builds taking
turns in subprocesses (the machine may be busy). Needs numpy.
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
from volume_settle import bend_problem  # noqa: E402
from volume_table import read_obj  # noqa: E402


def make_mesh(build, shape, vertices, folder):
    made = "cylinder" if shape == "tube" else shape
    path = os.path.join(folder, "%s%d.obj" % (made, vertices))
    if not os.path.exists(path):
        subprocess.run([os.path.join(build, "arap-make-mesh"), made, "--vertices", str(vertices), "--output", path],
                       check=True, capture_output=True)
    rest, faces = read_obj(path)
    rest, faces = np.array(rest, dtype=np.float64), np.array(faces, dtype=np.int64)
    if shape == "tube":  # the cylinder's two cap centres (its last vertices) and their triangles removed
        keep = len(rest) - 2
        faces = faces[(faces < keep).all(axis=1)]
        rest = rest[:keep]
    return rest, faces.astype(np.int32)


def converged_from(solver, start, targets, warm):
    """The limit of the solve of `targets` from `start` (None: cold)."""
    solver.configure(method="quasi-newton", tolerance=1e-13, max_iterations=20000)
    if start is None:
        solver.forget_solution()
        solver.configure(init="naive")
    else:
        solver.set_positions(start)
        solver.configure(init="warm")
    solver.solve(targets)
    return solver.positions()


def stops(arap, rest, faces, mode, method):
    """The cold solve's and the warm solve's after a step: (stats, positions) each."""
    constrained, pose, further = bend_problem(rest)
    solver = arap.Solver()
    solver.bind(rest, faces, constrained, volume=mode)
    solver.configure(method=method, tolerance=1e-6, max_iterations=1000, init="naive")
    cold = solver.solve(pose)
    cold_pose = solver.positions()
    solver.configure(init="warm")
    warm = solver.solve(further)
    return (cold.iterations, cold.converged), cold_pose, (warm.iterations, warm.converged), solver.positions()


def stops_of(build, stops_build, shape, size, mode, method, folder):
    """stops() with the module of `stops_build` (a subprocess) or of this process."""
    if stops_build == build:
        rest, faces = make_mesh(build, shape, size, folder)
        return stops(import_module(build), rest, faces, mode, method)
    out = os.path.join(folder, "stops.npz")
    subprocess.run([sys.executable, __file__, stops_build, "--stops-worker",
                    "%s,%d,%s,%s,%s,%s" % (shape, size, mode, method, folder, out)], check=True)
    z = np.load(out)
    return tuple(z["cold"]), z["cold_pose"], tuple(z["warm"]), z["warm_pose"]


def stop_errors(arap, build, stops_build, shape, size, folder, mode, methods):
    rest, faces = make_mesh(build, shape, size, folder)
    constrained, pose, further = bend_problem(rest)
    diag = np.linalg.norm(rest.max(axis=0) - rest.min(axis=0))
    solver = arap.Solver()
    solver.bind(rest, faces, constrained, volume=mode)
    rows = []
    for method in methods:
        cold, cold_pose, warm, warm_pose = stops_of(build, stops_build, shape, size, mode, method, folder)
        cold_limit = converged_from(solver, None, pose, False)
        warm_limit = converged_from(solver, cold_pose, further, True)
        err = lambda a, b: np.linalg.norm(a - b, axis=1).max() / diag  # noqa: E731
        rows.append((method, err(cold_pose, cold_limit), cold[0], bool(cold[1]),
                     err(warm_pose, warm_limit), warm[0], bool(warm[1])))
    return rows


def timing(arap, rest, faces, mode, repeats):
    constrained, pose, further = bend_problem(rest)
    solver = arap.Solver()
    solver.bind(rest, faces, constrained, volume=mode)
    out = []
    for _ in range(repeats):
        solver.forget_solution()
        solver.configure(init="naive")
        start = time.process_time()
        first = solver.solve(pose)
        cold = time.process_time() - start
        solver.configure(init="warm")
        start = time.process_time()
        step = solver.solve(further)
        out.append((first.iterations, cold, step.iterations, time.process_time() - start))
    return out


def import_module(build):
    sys.path.insert(0, os.path.join(build, "addon", "arap_deform"))
    import _arap_native as arap
    return arap


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("build", help="the build folder (arap-make-mesh, addon/arap_deform/_arap_native)")
    parser.add_argument("--sizes", default="10000")
    parser.add_argument("--shapes", default="bar,sphere,tube")
    parser.add_argument("--modes", default="none,infill,global")
    parser.add_argument("--methods", default="quasi-newton,local-global,anderson")
    parser.add_argument("--timing", default="", help="build folders compared (CPU time, iterations)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--stops", default="", help="the build folder whose module makes the stops "
                        "(default: the first argument's; the converged poses are always the first argument's)")
    parser.add_argument("--worker", default="", help=argparse.SUPPRESS)
    parser.add_argument("--stops-worker", default="", help=argparse.SUPPRESS)
    args = parser.parse_args()

    if args.stops_worker:  # stops(): shape, size, mode, method, mesh folder, output file
        shape, size, mode, method, folder, out = args.stops_worker.split(",")
        rest, faces = make_mesh(args.build, shape, int(size), folder)
        cold, cold_pose, warm, warm_pose = stops(import_module(args.build), rest, faces, mode, method)
        np.savez(out, cold=np.array(cold), cold_pose=cold_pose, warm=np.array(warm), warm_pose=warm_pose)
        return

    if args.worker:  # one timing run: shape, size, mode, mesh folder
        shape, size, mode, folder = args.worker.split(",")
        rest, faces = make_mesh(args.build, shape, int(size), folder)
        print(json.dumps(timing(import_module(args.build), rest, faces, mode, 1)))
        return

    with tempfile.TemporaryDirectory() as folder:
        if args.timing:
            builds = args.timing.split(",")
            print("| mesh | V | mode | " + " | ".join("%s: cold it / CPU s, warm it / CPU s" % b for b in builds) + " |")
            print("|---|---:|---|" + "---|" * len(builds))
            for shape in args.shapes.split(","):
                for size in (int(s) for s in args.sizes.split(",")):
                    for mode in args.modes.split(","):
                        runs = {b: [] for b in builds}
                        for _ in range(args.repeats):
                            for b in builds:
                                out = subprocess.run([sys.executable, __file__, b, "--worker",
                                                      "%s,%d,%s,%s" % (shape, size, mode, folder)],
                                                     check=True, capture_output=True, text=True).stdout
                                runs[b] += json.loads(out)
                        cells = []
                        for b in builds:
                            r = runs[b]
                            cells.append("%d / %.2f, %d / %.2f" % (r[0][0], statistics.median(x[1] for x in r),
                                                                   r[0][2], statistics.median(x[3] for x in r)))
                        print("| %s | %d | %s | %s |" % (shape, size, mode, " | ".join(cells)), flush=True)
            return

        arap = import_module(args.build)
        print("| mesh | V | mode | method | cold: error / diag, it, converged | warm: error / diag, it, converged |")
        print("|---|---:|---|---|---|---|")
        for shape in args.shapes.split(","):
            for size in (int(s) for s in args.sizes.split(",")):
                n = len(make_mesh(args.build, shape, size, folder)[0])
                for mode in args.modes.split(","):
                    methods = [m for m in args.methods.split(",") if not (mode != "none" and m == "anderson")]
                    for row in stop_errors(arap, args.build, args.stops or args.build, shape, size, folder, mode,
                                           methods):
                        print("| %s | %d | %s | %s | %.2e, %d, %s | %.2e, %d, %s |" % ((shape, n, mode) + row),
                              flush=True)


if __name__ == "__main__":
    main()
