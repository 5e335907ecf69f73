#!/usr/bin/env python3
"""Measure the volume modes (docs/volume.md).

    python3 bench/native/volume_table.py build ../shared/scenarios build/results/volume

For every scenario of the folder (bar1_x2 and bar1_x3 are bar1 x2 and x3, so
they are not run twice) and five procedural meshes made with arap-make-mesh
(a bar, a capped cylinder, a bumpy sphere squashed, an open tube, two crossed
bars that pass through each other), with the handles' displacement times 1, 2
and 3: arap-deform with its defaults and --volume none, global and infill;
then arap-mesh-measure on the written mesh (volume, cross-sections,
self-intersections, distortion: from the files, not from the solver). The CPU
time per iteration is the median over --repeats runs (default 3, run in turn
with the other modes) of the solving thread's CPU time divided by the
iterations, so that the ratios compare runs made side by side. Writes the
markdown table to OUT/volume.md (and stdout) and everything to OUT/volume.json.
Plain Python 3.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys

MODES = ("none", "global", "infill")
FACTORS = (1, 2, 3)


def run(cmd):
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError("%s failed (%d): %s" % (" ".join(cmd), done.returncode, done.stderr.strip()))
    return done.stdout


def scaled_scenario(path, factor, out_dir):
    """The scenario with every handle's displacement times `factor`: p + k (M p + t - p)."""
    with open(path) as f:
        s = json.load(f)
    s["mesh"] = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(path)), s["mesh"]))
    for h in s["handles"]:
        m = h.get("matrix")
        if m is not None:
            identity = [1.0 if i % 5 == 0 else 0.0 for i in range(16)]
            h["matrix"] = [identity[i] + factor * (m[i] - identity[i]) if i < 12 else m[i] for i in range(16)]
        h["translate"] = [factor * x for x in h.get("translate", [0.0, 0.0, 0.0])]
    name = "%s_x%d" % (s["name"], factor)
    target = os.path.join(out_dir, name + ".json")
    with open(target, "w") as f:
        json.dump(s, f)
    return name, target, s["mesh"]


def read_obj(path):
    vertices, faces = [], []
    with open(path) as f:
        for line in f:
            parts = line.split()
            if parts and parts[0] == "v":
                vertices.append(parts[1:4])
            elif parts and parts[0] == "f":
                faces.append([int(p.split("/")[0]) - 1 for p in parts[1:]])
    return vertices, faces


def read_off(path):
    words = open(path).read().split()
    if words[0] != "OFF":
        raise SystemExit("%s: not an OFF file" % path)
    nv, nf = int(words[1]), int(words[2])
    at = 4
    vertices = [tuple(float(w) for w in words[at + 3 * i: at + 3 * i + 3]) for i in range(nv)]
    at += 3 * nv
    faces = []
    for _ in range(nf):
        k = int(words[at])
        faces.append(tuple(int(w) for w in words[at + 1: at + 1 + k]))
        at += 1 + k
    return vertices, faces


def write_obj(path, vertices, faces):
    with open(path, "w") as f:
        for v in vertices:
            f.write("v %s %s %s\n" % tuple(v))
        for face in faces:
            f.write("f %s\n" % " ".join(str(i + 1) for i in face))


def write_indices(path, indices):
    with open(path, "w") as f:
        f.write(" ".join(str(i) for i in indices) + "\n")


def by_height(vertices, axis, low, high):
    """(fixed, handle): the lowest `low` and highest `high` fraction of the extent along `axis`."""
    h = [float(v[axis]) for v in vertices]
    lo, hi = min(h), max(h)
    eps = 1e-9 * max(hi - lo, 1.0)
    fixed = [i for i, x in enumerate(h) if x <= lo + low * (hi - lo) + eps]
    handle = [i for i, x in enumerate(h) if x >= hi - high * (hi - lo) - eps]
    return fixed, handle


def procedural_cases(build, out_dir, vertices=2000):
    """(name, mesh, fixed file, handle file, translation at x1) of the procedural meshes, about `vertices` each."""
    make = os.path.join(build, "arap-make-mesh")
    cases = []

    def made(name, *args):
        mesh = os.path.join(out_dir, name + ".obj")
        run([make] + list(args) + ["--output", mesh])
        return read_obj(mesh)

    def add(name, vertices, faces, translate, fixed=None, handle=None):
        mesh = os.path.join(out_dir, name + ".obj")
        write_obj(mesh, vertices, faces)
        if fixed is None:
            fixed, handle = by_height(vertices, 2, 0.2, 0.05)
        write_indices(os.path.join(out_dir, name + ".fixed.txt"), fixed)
        write_indices(os.path.join(out_dir, name + ".handle.txt"), handle)
        cases.append((name, mesh, os.path.join(out_dir, name + ".fixed.txt"),
                      os.path.join(out_dir, name + ".handle.txt"), translate))

    bar_v, bar_f = made("bar", "bar", "--vertices", str(vertices))
    add("bar", bar_v, bar_f, (2.0, 0.0, -1.0))
    cyl_v, cyl_f = made("cylinder", "cylinder", "--vertices", str(vertices))
    add("cylinder", cyl_v, cyl_f, (2.0, 0.0, -1.0))
    sph_v, sph_f = made("sphere", "sphere", "--vertices", str(vertices))
    add("sphere", sph_v, sph_f, (0.0, 0.0, -0.4))
    # The cylinder without its caps (and their centre vertices): an open tube.
    centres = {len(cyl_v) - 2, len(cyl_v) - 1}
    keep = [i for i in range(len(cyl_v)) if i not in centres]
    index = {old: new for new, old in enumerate(keep)}
    tube_f = [[index[i] for i in face] for face in cyl_f if not centres.intersection(face)]
    add("open_tube", [cyl_v[i] for i in keep], tube_f, (2.0, 0.0, -1.0))
    # A second bar across the first, through it: two parts whose surfaces cross (a self-intersecting
    # input). The upright one is bent; the crossing one is held at both ends.
    across = [(float(z) - 2.0, float(y), 3.0 - float(x)) for x, y, z in bar_v]  # turned 90 degrees about y
    vertices = bar_v + [tuple("%.17g" % c for c in p) for p in across]
    faces = bar_f + [[i + len(bar_v) for i in face] for face in bar_f]
    fixed, handle = by_height(bar_v, 2, 0.2, 0.05)
    ends, _ = by_height(across, 0, 0.05, 0.0)
    _, other_end = by_height(across, 0, 0.0, 0.05)
    fixed += [i + len(bar_v) for i in sorted(set(ends + other_end))]
    add("crossed_bars", vertices, faces, (2.0, 0.0, -1.0), fixed, handle)
    return cases


def all_cases(build, scenarios, out, procedural_vertices=2000):
    """(name, factor, arap-deform inputs, rest mesh) of every case: the scenarios of the folder (bar1_x2 and
    bar1_x3 are bar1 x2 and x3, so they are not run twice) and the procedural meshes, each times 1, 2 and 3."""
    cases = []
    for file in sorted(os.listdir(scenarios)):
        if not file.endswith(".json") or file.startswith("bar1_x"):
            continue
        for k in FACTORS:
            name, path, mesh = scaled_scenario(os.path.join(scenarios, file), k, out)
            cases.append((name, k, ["--scenario", path], mesh))
    for name, mesh, fixed, handle, translate in procedural_cases(build, out, procedural_vertices):
        for k in FACTORS:
            t = ",".join("%.17g" % (k * x) for x in translate)
            cases.append(("%s_x%d" % (name, k), k, [mesh, "--fixed", fixed, "--handle", handle, "--translate", t],
                          mesh))
    return cases


def measure(build, rest_mesh, posed_mesh):
    return json.loads(run([os.path.join(build, "arap-mesh-measure"), rest_mesh, posed_mesh]))


def solve(build, inputs, mode, out_dir, name):
    out = os.path.join(out_dir, "%s_%s.off" % (name, mode))
    report = os.path.join(out_dir, "%s_%s.report.json" % (name, mode))
    run([os.path.join(build, "arap-deform")] + inputs + ["--volume", mode, "--quiet", "--output", out,
                                                         "--report", report])
    with open(report) as f:
        return out, json.load(f)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("build")
    parser.add_argument("scenarios")
    parser.add_argument("out")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--only", nargs="*", help="names of the cases to run (default all)")
    parser.add_argument("--table", action="store_true",
                        help="only write the table again from OUT/volume.json (no solving)")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    if args.table:
        with open(os.path.join(args.out, "volume.json")) as f:
            write_table(json.load(f), args.out, "volume", table)
        return

    cases = all_cases(args.build, args.scenarios, args.out)
    if args.only:
        cases = [c for c in cases if c[0].rsplit("_x", 1)[0] in args.only]

    results = []
    for name, k, inputs, rest in cases:
        row = {"case": name.rsplit("_x", 1)[0], "factor": k}
        cpu = {m: [] for m in MODES}
        for repeat in range(args.repeats):
            for mode in MODES:
                out, report = solve(args.build, inputs, mode, args.out, name)
                cpu[mode].append(report["solve_cpu_ms"] / max(1, report["iterations"]))
                if repeat == 0:
                    row[mode] = {"report": {key: report[key] for key in (
                        "iterations", "converged", "volume_drift", "volume_kept_components",
                        "volume_open_components", "infill_cells", "infill_nodes", "vertices")},
                        "measure": measure(args.build, rest, out)}
        for mode in MODES:
            row[mode]["cpu_ms_per_iteration"] = statistics.median(cpu[mode])
        results.append(row)
        print("measured %s" % name, file=sys.stderr)
    save_results(results, args.out, "volume", table)


def save_results(results, out, name, make_table):
    """OUT/name.json (everything) and OUT/name.md (the table, also printed)."""
    with open(os.path.join(out, name + ".json"), "w") as f:
        json.dump(results, f, indent=1)
    write_table(results, out, name, make_table)


def write_table(results, out, name, make_table):
    markdown = make_table(results)
    with open(os.path.join(out, name + ".md"), "w") as f:
        f.write(markdown + "\n")
    print(markdown)


def table(results):
    lines = ["| mesh | × | closed | volume kept: surface / global / infill | cross-section min: s / g / i "
             "| self-intersections: s / g / i | distortion: s, g ×, i × | iterations: s / g / i "
             "| CPU ms per iteration: s, g ×, i × |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        m = {mode: r[mode]["measure"] for mode in MODES}
        rep = {mode: r[mode]["report"] for mode in MODES}
        base_d = m["none"]["distortion"]
        base_t = r["none"]["cpu_ms_per_iteration"]
        closed = m["none"]["closed_components"]
        open_ = m["none"]["open_components"]
        shape = "yes" if open_ == 0 else ("open" if closed == 0 else "%d of %d" % (closed, closed + open_))
        vol = " / ".join("%.1f%%" % (100 * m[x]["volume_ratio"]) for x in MODES) if closed else "–"
        lines.append("| %s | %d | %s | %s | %s | %s | %.3f, %.2f×, %.2f× | %s | %.3g, %.2f×, %.2f× |" % (
            r["case"], r["factor"], shape, vol,
            " / ".join("%.2f" % m[x]["cross_section_min"] for x in MODES),
            " / ".join(str(m[x]["self_intersections"]) for x in MODES) + (
                " (rest %d)" % m["none"]["rest_self_intersections"] if m["none"]["rest_self_intersections"] else ""),
            base_d, m["global"]["distortion"] / base_d if base_d else 1, m["infill"]["distortion"] / base_d if base_d else 1,
            " / ".join(str(rep[x]["iterations"]) for x in MODES),
            base_t, r["global"]["cpu_ms_per_iteration"] / base_t, r["infill"]["cpu_ms_per_iteration"] / base_t))
    return "\n".join(lines)


if __name__ == "__main__":
    main()
