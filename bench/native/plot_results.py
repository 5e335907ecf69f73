#!/usr/bin/env python3
"""Plots of arap-bench's results.json, written next to it:

  time_per_iteration.png  median ms per iteration against vertex count (log-log),
                          ours (first weights, per thread count) and CGAL, procedural shapes
                          as lines, mesh files as points (bars span the quartiles)
  time_split.png          our per-iteration time split (rotation / rhs / solve) by size
  energy_<mesh>.png       energy against global solves and against ms, ours (cotan-clamped,
                          plain and Anderson if run) and CGAL, for every mesh file and the
                          largest procedural meshes CGAL ran on
  time_to_band.png        from band.json beside it (arap-bench --time-to-band): CPU ms from a
                          cold start into the 1e-3 band per mesh and method (log scale)

usage: python3 plot_results.py results/results.json
"""
import json
import re
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def shape_of(mesh):
    """'sphere' for the procedural 'sphere-4k', None for a file."""
    if mesh["source"] != "procedural":
        return None
    return re.sub(r"-[0-9]+[kM]?$", "", mesh["name"])


def run_label(run):
    label = f"ours {run['weights']}"
    if run["anderson"]:
        label += f" +AA{run['anderson']}"
    return label + f", {run['threads']} thr"


def plot_time(doc, out):
    fig, ax = plt.subplots(figsize=(8, 5.5))
    series = {}  # label -> [(V, median, min, max)]
    for mesh in doc["meshes"]:
        shape = shape_of(mesh)
        group = shape if shape else "files"
        for run in mesh["runs"]:
            # the weights cost the same: plot the first weights, plain, at every thread count
            if run["weights"] != mesh["runs"][0]["weights"] or run["anderson"]:
                continue
            t = run["iteration_ms"]
            series.setdefault((group, run_label(run)), []).append((mesh["vertices"], t["median"], t["p25"], t["p75"]))
        cgal = mesh.get("cgal") or {}
        if "iteration_ms" in cgal:
            t = cgal["iteration_ms"]
            series.setdefault((group, "CGAL ORIGINAL_ARAP"), []).append(
                (mesh["vertices"], t["median"], t["p25"], t["p75"]))
    for (group, label), pts in sorted(series.items()):
        pts.sort()
        v, med, lo, hi = zip(*pts)
        err = [[m - l for m, l in zip(med, lo)], [h - m for m, h in zip(med, hi)]]
        line = "none" if group == "files" else "--" if "CGAL" in label else "-"
        ax.errorbar(v, med, yerr=err, fmt="o", ms=3, capsize=2, linestyle=line, label=f"{label} ({group})")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("vertices")
    ax.set_ylabel("ms per iteration (median, bars: quartiles)")
    ax.set_title("ARAP time per iteration")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "time_per_iteration.png", dpi=120)
    plt.close(fig)


def plot_split(doc, out):
    rows = []
    for mesh in doc["meshes"]:
        if shape_of(mesh) is None:
            continue
        run = mesh["runs"][0]
        rows.append((shape_of(mesh), mesh["vertices"], run["rotation_ms_per_iteration"], run["rhs_ms_per_iteration"],
                     run["solve_ms_per_iteration"]))
    if not rows:
        return
    shapes = sorted({r[0] for r in rows})
    fig, axes = plt.subplots(1, len(shapes), figsize=(6 * len(shapes), 4.5), squeeze=False)
    for ax, shape in zip(axes[0], shapes):
        pts = sorted(r[1:] for r in rows if r[0] == shape)
        v = [p[0] for p in pts]
        total = [p[1] + p[2] + p[3] for p in pts]
        bottom = [0.0] * len(pts)
        for i, name in enumerate(["rotation (local step)", "right-hand side", "triangular solves"]):
            share = [100 * p[i + 1] / t for p, t in zip(pts, total)]
            ax.fill_between(v, bottom, [b + s for b, s in zip(bottom, share)], label=name, alpha=0.8)
            bottom = [b + s for b, s in zip(bottom, share)]
        ax.set_xscale("log")
        ax.set_ylim(0, 100)
        ax.set_xlabel("vertices")
        ax.set_ylabel("% of an iteration")
        ax.set_title(f"{shape}: {doc['meshes'][0]['runs'][0]['weights']}, {doc['settings']['threads'][0]} thread(s)")
        ax.legend(fontsize=8, loc="lower left")
    fig.tight_layout()
    fig.savefig(out / "time_split.png", dpi=120)
    plt.close(fig)


def plot_energy(mesh, out):
    cgal = mesh.get("cgal") or {}
    runs = [r for r in mesh["runs"] if r["weights"] == "cotan-clamped" and not r["timing_only"]]
    if "energy" not in cgal or not runs:
        return False
    reference = min(r["reference_energy"] for r in runs)
    fig, (by_it, by_ms) = plt.subplots(1, 2, figsize=(11, 4.5))

    def draw(label, solves, ms, energy, style):
        by_it.plot(solves, energy, style, ms=3, label=label)
        by_ms.plot(ms, energy, style, ms=3, label=label)

    for r in runs:
        # the first guess is one global solve; iteration k is the (k+1)-th
        solves = [1] + [k + 2 for k in range(len(r["energy"]))]
        ms = [r["init_ms"] + r["first_local_ms"]] + r["elapsed_ms"]
        draw(run_label(r), solves, ms, [r["initial_energy"]] + r["energy"], "-")
    draw("CGAL ORIGINAL_ARAP", list(range(1, len(cgal["energy"]) + 1)), cgal["elapsed_ms"], cgal["energy"], "o--")
    for ax in (by_it, by_ms):
        ax.axhline(reference, color="gray", lw=0.8, ls=":", label=f"ours after {runs[0]['iterations']} iterations")
        ax.set_xscale("log")
        ax.grid(True, which="both", alpha=0.3)
        ax.set_ylabel("ARAP energy (cotan-clamped weights)")
        ax.legend(fontsize=8)
    by_it.set_xlabel("global solves (ours: first guess + iterations; CGAL: iterations)")
    by_ms.set_xlabel("ms since the start of the solve (CGAL: of deform)")
    fig.suptitle(f"{mesh['name']} ({mesh['vertices']} vertices)")
    fig.tight_layout()
    fig.savefig(out / f"energy_{mesh['name']}.png", dpi=110)
    plt.close(fig)
    return True


def plot_band(band, out):
    meshes = [m for m in band["meshes"] if m["vertices"] >= 5000] or band["meshes"]
    series = [("local-global", "tab:gray"), ("anderson-5", "tab:orange"), ("quasi-newton", "tab:blue"),
              ("CGAL", "tab:green")]
    fig, ax = plt.subplots(figsize=(8, 0.9 + 0.8 * len(meshes)))
    height = 0.8 / len(series)
    for k, (name, color) in enumerate(series):
        ms, hatch = [], []
        for m in meshes:
            run = m.get("cgal") if name == "CGAL" else next(r for r in m["runs"] if r["method"] == name)
            value = None
            if run:
                value = run.get("cpu_ms_to_band") or run.get("cpu_ms_budget")
            ms.append(value or 0.0)
            hatch.append(bool(run) and not run.get("cpu_ms_to_band"))
        ys = [i + (k - 1.5) * height for i in range(len(meshes))]
        bars = ax.barh(ys, ms, height=height, color=color, label=name)
        for bar, h in zip(bars, hatch):
            if h:  # not in the band within the budget: the budget's time, a lower bound
                bar.set_hatch("//")
    ax.set_yticks(range(len(meshes)))
    ax.set_yticklabels([f"{m['name']} ({m['vertices']:,})" for m in meshes])
    ax.set_xscale("log")
    ax.set_xlabel("CPU ms from a cold start into E <= E* + 1e-3 |E*| (hatched: not there within the budget)")
    ax.legend(loc="lower right")
    ax.grid(True, axis="x", which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "time_to_band.png", dpi=120)
    plt.close(fig)


def main():
    path = Path(sys.argv[1] if len(sys.argv) > 1 else "results/results.json")
    out = path.parent
    if (out / "band.json").exists():
        plot_band(json.loads((out / "band.json").read_text()), out)
    if not path.exists():
        print(f"plots written to {out}")
        return
    doc = json.loads(path.read_text())
    plot_time(doc, out)
    plot_split(doc, out)
    # energy plots: every mesh file, and the largest procedural mesh of each shape CGAL ran on
    largest = {}
    for mesh in doc["meshes"]:
        if shape_of(mesh) and "energy" in (mesh.get("cgal") or {}):
            largest[shape_of(mesh)] = mesh["name"]
    for mesh in doc["meshes"]:
        if shape_of(mesh) is None or largest.get(shape_of(mesh)) == mesh["name"]:
            plot_energy(mesh, out)
    print(f"plots written to {out}")


if __name__ == "__main__":
    main()
