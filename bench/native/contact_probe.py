#!/usr/bin/env python3
"""Self Contact on meshes with handles nobody chose for them (docs/contact.md).

    python3 bench/native/contact_probe.py build MESHES_DIR build/results/probe [--volume none global infill] \
        [--live build/addon/arap_deform]

For every .off mesh of the folder: the lowest fifth along its longest axis
fixed, the top tenth the handle, which is pushed 0.6 of that length into the
body ("push") and moved half the length sideways as well ("fold"). Each is
solved by arap-deform with --contact none and self (and each --volume given),
and the written meshes are measured by arap-mesh-measure. Per case: crossing
triangle pairs at rest, without and with contact; how far the handle got
(contact_reached); whether the fixed vertices stayed exactly at rest; the
warning arap-deform printed. Pairs crossing with contact that do not cross at
rest are listed in OUT/probe.json. With --live (the folder holding the
native module; needs numpy), each case with Self Contact is also dragged as
Live drags it: warm solves with a 16 ms budget, the handle moved over 30
updates, then held until the pose settles (at most 300 updates); the pose is
measured every fifth update and at the end, and the share of its move the
handle got is reported. Writes OUT/probe.md (and stdout). Plain Python 3.
"""

import argparse
import glob
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from volume_table import by_height, read_off, run, write_indices  # noqa: E402


def moves(vertices):
    """(axis, {name: translation}) for a mesh: along its longest axis, and sideways along the next longest."""
    extent = [max(v[a] for v in vertices) - min(v[a] for v in vertices) for a in range(3)]
    axis = max(range(3), key=lambda a: extent[a])
    side = max((a for a in range(3) if a != axis), key=lambda a: extent[a])
    push, fold = [0.0] * 3, [0.0] * 3
    push[axis] = fold[axis] = -0.6 * extent[axis]
    fold[side] = 0.5 * extent[axis]
    return axis, {"push": push, "fold": fold}


def write_off(path, positions, faces):
    with open(path, "w") as f:
        f.write("OFF\n%d %d 0\n" % (len(positions), len(faces)))
        f.writelines("%.17g %.17g %.17g\n" % tuple(p) for p in positions)
        f.writelines("%d %s\n" % (len(t), " ".join(str(v) for v in t)) for t in faces)


def live_drag(native, build, mesh, vertices, faces, fixed, handle, translation, volume, at_rest, scratch):
    """Live's warm solves along the drag: (share of the move the handle got, pairs crossing that did not at rest)."""
    import numpy as np
    rest = np.array(vertices)
    constrained = np.array(fixed + handle, np.int64)
    move = np.array(translation)
    solver = native.Solver()
    solver.bind(rest, np.array(faces, np.int32), constrained, contact="self", volume=volume)
    solver.configure(init="warm", time_budget_ms=16.0)
    new = set()
    for update in range(330):
        targets = rest[constrained].copy()
        targets[len(fixed):] += min(1.0, (update + 1) / 30.0) * move
        stats = solver.solve(targets)
        done = update >= 29 and stats.converged
        if update % 5 == 4 or done:
            write_off(scratch, solver.positions(), faces)
            new |= intersecting_pairs(build, mesh, scratch) - at_rest
        if done:
            break
    got = (solver.positions()[handle] - rest[handle]).mean(axis=0)
    return float(got @ move / (move @ move)), sorted(new)


def intersecting_pairs(build, rest, posed):
    """The triangle pairs (f, g), f < g, that cross in `posed`, by arap-mesh-measure."""
    measured = json.loads(run([os.path.join(build, "arap-mesh-measure"), rest, posed, "--list-intersections"]))
    return {tuple(p) for p in measured["intersecting_pairs"]}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("build")
    parser.add_argument("meshes")
    parser.add_argument("out")
    parser.add_argument("--volume", nargs="*", default=["none"], choices=["none", "global", "infill"])
    parser.add_argument("--live", metavar="MODULE_DIR", help="also drag each case as Live does (needs numpy)")
    args = parser.parse_args()
    native = None
    if args.live:
        sys.path.insert(0, args.live)
        import _arap_native as native
    os.makedirs(args.out, exist_ok=True)
    rows, results = [], []
    for mesh in sorted(glob.glob(os.path.join(args.meshes, "*.off"))):
        name = os.path.splitext(os.path.basename(mesh))[0]
        vertices, faces = read_off(mesh)
        axis, translations = moves(vertices)
        fixed, handle = by_height(vertices, axis, 0.2, 0.1)
        inputs = [mesh]
        for kind, indices in (("fixed", fixed), ("handle", handle)):
            path = os.path.join(args.out, "%s.%s.txt" % (name, kind))
            write_indices(path, indices)
            inputs += ["--" + kind, path]
        at_rest = intersecting_pairs(args.build, mesh, mesh)
        for move, translation in translations.items():
            for volume in args.volume:
                case = {"mesh": name, "move": move, "volume": volume, "rest": len(at_rest)}
                for contact in ("none", "self"):
                    out = os.path.join(args.out, "%s_%s_%s_%s.off" % (name, move, volume, contact))
                    report = out + ".report.json"
                    done = subprocess.run(
                        [os.path.join(args.build, "arap-deform")] + inputs +
                        ["--translate", ",".join("%.9g" % t for t in translation), "--volume", volume,
                         "--contact", contact, "--quiet", "--output", out, "--report", report],
                        capture_output=True, text=True)
                    if done.returncode != 0:
                        raise SystemExit("%s %s %s %s: %s" % (name, move, volume, contact, done.stderr.strip()))
                    with open(report) as f:
                        stats = json.load(f)
                    pairs = intersecting_pairs(args.build, mesh, out)
                    posed, _ = read_off(out)
                    case[contact] = {
                        "crossings": len(pairs), "new_crossings": sorted(pairs - at_rest),
                        "reached": stats.get("contact_reached", 1.0),
                        "fixed_exact": all(posed[v] == vertices[v] for v in fixed),
                        "warning": " ".join(line for line in done.stderr.splitlines() if "warning" in line)}
                live = "–"
                if native:
                    got, new = live_drag(native, args.build, mesh, vertices, faces, fixed, handle, translation, volume,
                                         at_rest, os.path.join(args.out, "live.off"))
                    case["live"] = {"handle_got": got, "new_crossings": new}
                    live = "%.2f, %d new" % (got, len(new))
                results.append(case)
                self_ = case["self"]
                rows.append("| %s | %s | %s | %d / %d / %d (%d new) | %.2f | %s | %s | %s |" % (
                    name, move, volume, case["rest"], case["none"]["crossings"], self_["crossings"],
                    len(self_["new_crossings"]), self_["reached"], "yes" if self_["fixed_exact"] else "NO", live,
                    self_["warning"].replace("arap-deform: warning: ", "")[:60]))
                print(rows[-1], flush=True)
    with open(os.path.join(args.out, "probe.json"), "w") as f:
        json.dump(results, f, indent=1)
    table = ["| mesh | move | volume | crossings: rest / none / self (new) | reached | fixed exact | Live: got, crossings "
             "| warning |", "|---|---|---|---|---|---|---|---|"] + rows
    with open(os.path.join(args.out, "probe.md"), "w") as f:
        f.write("\n".join(table) + "\n")


if __name__ == "__main__":
    main()
