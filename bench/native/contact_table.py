#!/usr/bin/env python3
"""Measure self-contact (docs/contact.md).

    python3 bench/native/contact_table.py build SCENARIOS_DIR build/results/contact

The cases of volume_table.py (every scenario of the folder and the procedural
meshes, handles' displacement times 1, 2 and 3), each solved by arap-deform
with --contact none and --contact self, with --volume none and infill. The
written meshes are measured by arap-mesh-measure (crossing triangle pairs,
distortion, volume: from the files, not from the solver). The solve's CPU time
(to convergence) is the median over --repeats runs made in turn, so that the
ratio compares runs made side by side. Writes OUT/contact.md and OUT/contact.json.
Plain Python 3.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from volume_table import all_cases, measure, save_results, write_table  # noqa: E402

RUNS = (("none", "none"), ("none", "self"), ("infill", "none"), ("infill", "self"))  # (volume, contact)
REPORTED = ("iterations", "converged", "contact_free_iterations", "contact_rounds", "contact_reached", "contact_pairs", "contact_steps_cut",
            "vertices")


def solve(build, inputs, volume, contact, out_dir, name, timeout):
    """The written mesh and the report, or (None, None) when the solve took longer than `timeout` seconds."""
    out = os.path.join(out_dir, "%s_%s_%s.off" % (name, volume, contact))
    report = os.path.join(out_dir, "%s_%s_%s.report.json" % (name, volume, contact))
    try:
        subprocess.run([os.path.join(build, "arap-deform")] + inputs + [
            "--volume", volume, "--contact", contact, "--quiet", "--output", out, "--report", report],
            capture_output=True, text=True, timeout=timeout, check=True)
    except subprocess.TimeoutExpired:
        return None, None
    with open(report) as f:
        return out, json.load(f)


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("build")
    parser.add_argument("scenarios")
    parser.add_argument("out")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--only", nargs="*", help="names of the cases to run (default all)")
    parser.add_argument("--surface-only", action="store_true", help="skip the --volume infill runs")
    parser.add_argument("--timeout", type=float, default=600, help="seconds a solve may take (default 600)")
    parser.add_argument("--procedural-vertices", type=int, default=2000,
                        help="about how many vertices the procedural meshes have (default 2000)")
    parser.add_argument("--table", action="store_true", help="only write the table again from OUT/contact.json")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    if args.table:
        with open(os.path.join(args.out, "contact.json")) as f:
            write_table(json.load(f), args.out, "contact", table)
        return
    runs = RUNS[:2] if args.surface_only else RUNS
    results = []
    for name, k, inputs, rest in all_cases(args.build, args.scenarios, args.out, args.procedural_vertices):
        if args.only and name.rsplit("_x", 1)[0] not in args.only:
            continue
        row = {"case": name.rsplit("_x", 1)[0], "factor": k}
        cpu = {r: [] for r in runs}
        for repeat in range(args.repeats):
            for volume, contact in runs:
                out, report = solve(args.build, inputs, volume, contact, args.out, name, args.timeout)
                if report is None:
                    cpu[(volume, contact)].append(float("inf"))
                    row.setdefault("%s/%s" % (volume, contact), {"timeout": args.timeout})
                    continue
                cpu[(volume, contact)].append(report["solve_cpu_ms"])
                if repeat == 0:
                    row["%s/%s" % (volume, contact)] = {
                        "report": {key: report.get(key) for key in REPORTED},
                        "measure": measure(args.build, rest, out)}
        for volume, contact in runs:
            row["%s/%s" % (volume, contact)]["solve_cpu_ms"] = statistics.median(cpu[(volume, contact)])
        results.append(row)
        print("measured %s" % name, file=sys.stderr)
    save_results(results, args.out, "contact", table)


def table(results):
    lines = ["| mesh | × | crossings: rest / none / self | distortion: none, self × | CPU ms: none, self × "
             "| reached | infill: crossings none / self, volume self |",
             "|---|---|---|---|---|---|---|"]
    for r in results:
        a, b = r["none/none"], r["none/self"]
        if "timeout" in b:
            lines.append("| %s | %d | – | – | > %g s | – | – |" % (r["case"], r["factor"], b["timeout"]))
            continue
        ma, mb = a["measure"], b["measure"]
        d = ma["distortion"]
        infill = "–"
        if "infill/self" in r and "timeout" not in r["infill/self"]:
            ia, ib = r["infill/none"]["measure"], r["infill/self"]["measure"]
            infill = "%d / %d, %.1f%%" % (ia["self_intersections"], ib["self_intersections"], 100 * ib["volume_ratio"])
        lines.append("| %s | %d | %d / %d / %d | %.3f, %.2f× | %.3g, %.2f× | %.2f | %s |" % (
            r["case"], r["factor"], ma["rest_self_intersections"], ma["self_intersections"], mb["self_intersections"],
            d, mb["distortion"] / d if d else 1, a["solve_cpu_ms"], b["solve_cpu_ms"] / a["solve_cpu_ms"],
            b["report"]["contact_reached"], infill))
    return "\n".join(lines)


if __name__ == "__main__":
    main()
