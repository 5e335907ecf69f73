#!/usr/bin/env python3
"""Measure the choices behind the defaults (docs/design.md, "Defaults, and why").

    python3 bench/native/defaults_table.py build/arap-deform ../shared/scenarios > defaults.md

For every scenario: (1) the first guesses, with cotangent weights: energy after
1, 10 and 200 iterations and the iterations needed to come within 1e-3
(relative to the first-iteration energy) of plain ARAP's 200-iteration energy
from the naive start, plain and with Anderson acceleration; (2) the weights:
the weight-free distortion measure and flipped triangles after 200 iterations.
Plain Python 3, runs arap-deform and reads its --report.
"""

import json
import os
import subprocess
import sys
import tempfile

GUESSES = ("naive", "laplacian", "differential")
WEIGHTS = ("cotan", "cotan-clamped", "uniform")


def run(cli, scenario, tmp, **flags):
    report = os.path.join(tmp, "report.json")
    args = [cli, "--scenario", scenario, "--iterations", "200", "--tolerance", "0", "--quiet",
            "--output", os.path.join(tmp, "out.off"), "--report", report]
    for key, value in flags.items():
        args += ["--" + key, str(value)]
    subprocess.run(args, check=True)
    with open(report) as f:
        return json.load(f)


def band(energies, target, first):
    """1-based iteration at which the energy is within 1e-3 * |first| of target; None if never."""
    for k, e in enumerate(energies):
        if e - target <= 1e-3 * abs(first):
            return k + 1
    return None


def main():
    if len(sys.argv) != 3:
        print(__doc__)
        sys.exit(2)
    cli, folder = sys.argv[1], sys.argv[2]
    scenarios = sorted(os.path.join(folder, f) for f in os.listdir(folder) if f.endswith(".json"))
    guess_rows, weight_rows = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for path in scenarios:
            name = os.path.splitext(os.path.basename(path))[0]
            plain = {g: run(cli, path, tmp, init=g, weights="cotan") for g in GUESSES}
            target = plain["naive"]["energy"][-1]
            for g in GUESSES:
                e = plain[g]["energy"]
                fast = run(cli, path, tmp, init=g, weights="cotan", anderson=5)["energy"]
                reached = [band(e, target, e[0]), band(fast, target, fast[0])]
                shown = " / ".join(str(r) if r else "never" for r in reached)
                guess_rows.append("| %s | %s | %.6g | %.6g | %.6g | %s |" % (name, g, e[0], e[9], e[-1], shown))
            cells = []
            for w in WEIGHTS:
                r = run(cli, path, tmp, init="naive", weights=w)
                cells.append("%.4f (%d)" % (r["distortion"], r["flipped_triangles"]))
            weight_rows.append("| %s | %s |" % (name, " | ".join(cells)))
    print("| scenario | first guess | E after 1 | E after 10 | E after 200 | iterations to the band (plain / Anderson 5) |")
    print("|---|---|---|---|---|---|")
    print("\n".join(guess_rows))
    print()
    print("| scenario | %s |" % " | ".join(WEIGHTS))
    print("|---|---|---|---|")
    print("\n".join(weight_rows))


if __name__ == "__main__":
    main()
