#!/usr/bin/env python3
"""Does the pose depend on the tessellation? (docs/volume.md, "The same pose at every resolution")

    /usr/bin/python3 bench/native/resolution.py build SCENARIOS [--modes none,infill] [--factors 1,2,3]

Each case (the reference scenarios of the folder SCENARIOS, and the procedural
bar, capped cylinder, bumpy sphere and open tube of volume_table.py) is solved
as it is and with every triangle split at its edge midpoints once (x4 the
triangles) and twice (x16): the shape does not change, only its tessellation.
A midpoint joins the fixed set or a handle when both ends of its edge are in
it. Each is solved through the native module from the rest shape to a tight
tolerance (the model's pose, not where a stop rule ends), with the handles'
displacement times each factor. Printed per case: the largest distance of an
original vertex from where the unsplit mesh put it, as a percentage of the rest
bounding box's diagonal, and the iterations. Needs numpy.

    /usr/bin/python3 bench/native/resolution.py build SCENARIOS --subsurf blender [--factors 1]

compares each case with itself after Blender's Subdivision Surface modifier (level 1, applied by
bench/blender/subdivision_surface.py) instead: the surface moves slightly, so "rest" gives how far the original
vertices moved at rest, before any pose.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from volume_table import procedural_cases, read_obj, read_off  # noqa: E402


def triangulated(faces):
    return np.array([(f[0], f[k], f[k + 1]) for f in faces for k in range(1, len(f) - 1)], dtype=np.int64)


def split_at_midpoints(rest, triangles, groups):
    """Every triangle cut into four at its edge midpoints. The first len(rest) vertices are the original ones.
    `groups`: vertex index arrays (the fixed set, each handle); a midpoint belongs to a group holding both ends."""
    edges = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    unique, inverse = np.unique(edges, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    n = len(rest)
    mid = n + inverse.reshape(3, -1).T  # per triangle: midpoint of edges 01, 12, 20
    a, b, c = triangles.T
    m01, m12, m20 = mid.T
    split = np.concatenate([np.stack([a, m01, m20], 1), np.stack([m01, b, m12], 1),
                            np.stack([m20, m12, c], 1), np.stack([m01, m12, m20], 1)])
    points = np.concatenate([rest, 0.5 * (rest[unique[:, 0]] + rest[unique[:, 1]])])
    grown = []
    for g in groups:
        inside = np.zeros(n, dtype=bool)
        inside[g] = True
        both = inside[unique[:, 0]] & inside[unique[:, 1]]
        grown.append(np.concatenate([g, n + np.nonzero(both)[0]]))
    return points, split, grown


def subdivision_surface(blender, rest, triangles, groups):
    """Like split_at_midpoints, by Blender's Subdivision Surface (its quads cut into triangles); also returns how far
    the original vertices moved, as a fraction of the diagonal."""
    script = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "blender", "subdivision_surface.py")
    with tempfile.TemporaryDirectory() as folder:
        source, target = os.path.join(folder, "in.json"), os.path.join(folder, "out.json")
        with open(source, "w") as f:
            json.dump({"vertices": rest.tolist(), "faces": triangles.tolist(),
                       "groups": [g.tolist() for g in groups]}, f)
        subprocess.run([blender, "--background", "--factory-startup", "--python", script, "--", source, target],
                       check=True, stdout=subprocess.DEVNULL)
        with open(target) as f:
            out = json.load(f)
    return (np.array(out["vertices"], dtype=float), triangulated(out["faces"]),
            [np.array(g, dtype=np.int64) for g in out["groups"]], out["rest_moved"])


def scenario_cases(folder):
    """(name, rest, triangles, fixed, [(handle vertices, translation)]) of every scenario JSON of `folder`."""
    cases = []
    for file in sorted(os.listdir(folder)):
        if not file.endswith(".json") or file.startswith("bar1_x"):
            continue
        with open(os.path.join(folder, file)) as f:
            s = json.load(f)
        mesh = os.path.normpath(os.path.join(folder, s["mesh"]))
        vertices, faces = read_off(mesh) if mesh.endswith(".off") else read_obj(mesh)
        handles = [(np.array(h["vertices"], dtype=np.int64), np.array(h["translate"], dtype=float))
                   for h in s["handles"]]
        cases.append((s.get("name", file[:-5]), np.array(vertices, dtype=float), triangulated(faces),
                      np.array(s.get("fixed", []), dtype=np.int64), handles))
    return cases


def made_cases(build, vertices):
    cases = []
    with tempfile.TemporaryDirectory() as folder:
        for name, mesh, fixed, handle, translate in procedural_cases(build, folder, vertices):
            if name == "crossed_bars":
                continue
            v, f = read_obj(mesh)
            read = [np.array(open(p).read().split(), dtype=np.int64) for p in (fixed, handle)]
            cases.append((name, np.array(v, dtype=float), triangulated(f), read[0],
                          [(read[1], np.array(translate, dtype=float))]))
    return cases


def solve(arap, rest, triangles, fixed, handles, factor, options):
    constrained = np.concatenate([fixed] + [h for h, _ in handles]).astype(np.int64)
    targets = np.concatenate([rest[fixed]] + [rest[h] + factor * t for h, t in handles])
    solver = arap.Solver()
    solver.bind(rest, triangles, constrained, **options)
    solver.configure(init="naive", tolerance=1e-9, max_iterations=20000)
    start = time.process_time()
    stats = solver.solve(targets)
    return solver.positions(), stats.iterations, time.process_time() - start


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("build", help="the build folder (arap-make-mesh, addon/arap_deform/_arap_native)")
    parser.add_argument("scenarios", nargs="?", help="a folder of scenario JSON files")
    parser.add_argument("--modes", default="none,infill", help="volume modes")
    parser.add_argument("--factors", default="1,2,3")
    parser.add_argument("--splits", type=int, default=2, help="how many times to split (1 or 2)")
    parser.add_argument("--subsurf", metavar="BLENDER",
                        help="compare with Blender's Subdivision Surface applied (this Blender) instead of splits")
    parser.add_argument("--procedural-vertices", type=int, default=2000)
    parser.add_argument("--only", help="comma-separated case names")
    parser.add_argument("--option", action="append", default=[], help="NAME=VALUE passed to bind (repeatable)")
    args = parser.parse_args()
    sys.path.insert(0, os.path.join(args.build, "addon", "arap_deform"))
    import _arap_native as arap

    extra = dict(o.split("=", 1) for o in args.option)
    for k, v in extra.items():
        if v.lstrip("-").isdigit():
            extra[k] = int(v)
    cases = (scenario_cases(args.scenarios) if args.scenarios else []) + \
        made_cases(args.build, args.procedural_vertices)
    if args.only:
        cases = [c for c in cases if c[0] in args.only.split(",")]
    splits = ["Subdivision Surface"] if args.subsurf else ["split %d" % s for s in range(1, args.splits + 1)]
    print("| mesh | V | x | mode | " + " | ".join("%s: moved %% diag" % s for s in splits) +
          (" | rest moved %" if args.subsurf else "") +
          " | iterations: " + ", ".join(["base"] + splits) + " |")
    print("|---|---:|---:|---|" + "---:|" * (len(splits) + 1 + bool(args.subsurf)))
    for name, rest, triangles, fixed, handles in cases:
        diagonal = np.linalg.norm(rest.max(axis=0) - rest.min(axis=0))
        levels = [(rest, triangles, fixed, handles)]
        rest_moved = ""
        for _ in splits:
            r, t, f, h = levels[-1]
            groups = [f] + [hv for hv, _ in h]
            if args.subsurf:
                points, tris, grown, moved = subdivision_surface(args.subsurf, r, t, groups)
                rest_moved = " %.2f |" % (100 * moved)
            else:
                points, tris, grown = split_at_midpoints(r, t, groups)
            levels.append((points, tris, grown[0], [(g, tr) for g, (_, tr) in zip(grown[1:], h)]))
        for factor in (float(x) for x in args.factors.split(",")):
            for mode in args.modes.split(","):
                poses = [solve(arap, *lv, factor, dict(extra, volume=mode)) for lv in levels]
                base = poses[0][0]
                moved = [100 * np.linalg.norm(p[0][:len(rest)] - base, axis=1).max() / diagonal for p in poses[1:]]
                print("| %s | %d | %g | %s | %s |%s %s |" % (
                    name, len(rest), factor, mode, " | ".join("%.2f" % m for m in moved), rest_moved,
                    ", ".join(str(p[1]) for p in poses)), flush=True)


if __name__ == "__main__":
    main()
