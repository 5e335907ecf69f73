#!/usr/bin/env python3
"""Self Contact on meshes with handles nobody chose for them (docs/contact.md).

    python3 bench/native/contact_probe.py build MESHES_DIR build/results/probe [--volume none global infill]

For every .off mesh of the folder: the lowest fifth along its longest axis
fixed, the top tenth the handle, which is pushed 0.6 of that length into the
body ("push") and moved half the length sideways as well ("fold"). Each is
solved by arap-deform with --contact none and self (and each --volume given),
and the written meshes are measured by arap-mesh-measure. Per case: crossing
triangle pairs at rest, without and with contact; how far the handle got
(contact_reached); whether the fixed vertices stayed exactly at rest; the
warning arap-deform printed. Pairs crossing with contact that do not cross at
rest are listed in OUT/probe.json. Writes OUT/probe.md (and stdout). Plain Python 3.
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


def intersecting_pairs(build, rest, posed):
    measured = json.loads(run([os.path.join(build, "arap-mesh-measure"), rest, posed, "--list-intersections"]))
    return measured, {tuple(p) for p in measured["intersecting_pairs"]}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("build")
    parser.add_argument("meshes")
    parser.add_argument("out")
    parser.add_argument("--volume", nargs="*", default=["none"], choices=["none", "global", "infill"])
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    rows, results = [], []
    for mesh in sorted(glob.glob(os.path.join(args.meshes, "*.off"))):
        name = os.path.splitext(os.path.basename(mesh))[0]
        vertices, _ = read_off(mesh)
        axis, translations = moves(vertices)
        fixed, handle = by_height(vertices, axis, 0.2, 0.1)
        inputs = [mesh]
        for kind, indices in (("fixed", fixed), ("handle", handle)):
            path = os.path.join(args.out, "%s.%s.txt" % (name, kind))
            write_indices(path, indices)
            inputs += ["--" + kind, path]
        _, at_rest = intersecting_pairs(args.build, mesh, mesh)
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
                    _, pairs = intersecting_pairs(args.build, mesh, out)
                    posed, _ = read_off(out)
                    case[contact] = {
                        "crossings": len(pairs), "new_crossings": sorted(pairs - at_rest),
                        "reached": stats.get("contact_reached", 1.0),
                        "fixed_exact": all(posed[v] == vertices[v] for v in fixed),
                        "warning": " ".join(line for line in done.stderr.splitlines() if "warning" in line)}
                results.append(case)
                self_ = case["self"]
                rows.append("| %s | %s | %s | %d / %d / %d (%d new) | %.2f | %s | %s |" % (
                    name, move, volume, case["rest"], case["none"]["crossings"], self_["crossings"],
                    len(self_["new_crossings"]), self_["reached"], "yes" if self_["fixed_exact"] else "NO",
                    self_["warning"].replace("arap-deform: warning: ", "")[:60]))
                print(rows[-1], flush=True)
    with open(os.path.join(args.out, "probe.json"), "w") as f:
        json.dump(results, f, indent=1)
    table = ["| mesh | move | volume | crossings: rest / none / self (new) | reached | fixed exact | warning |",
             "|---|---|---|---|---|---|---|"] + rows
    with open(os.path.join(args.out, "probe.md"), "w") as f:
        f.write("\n".join(table) + "\n")


if __name__ == "__main__":
    main()
