#!/usr/bin/env python3
"""Live with and without Self Contact, through the native module (docs/contact.md).

    build/arap-make-mesh bar --vertices 10000 --output bar10k.obj
    /usr/bin/python3 bench/native/contact_live.py build/addon/arap_deform bar10k.obj

Binds the bar (lowest fifth fixed, top 5% the handle) with contact none and
self, in turn, then solves as Live does: warm starts with a time budget per
update (default 33 ms), 60 updates that drag the handle to the fold of
docs/contact.md (half the bar's length sideways, 0.6 of it down), then 60
updates holding it there. Prints the CPU time per update (time.process_time:
the machine may be busy; with --threads above 1, the wall time) while dragging and while holding, and the update at
which the pose settled, and the first update of holding at which the handles stood at the Empty's pose
(contact_reached = 1: in a fold, Live moves them there in checked shares). Needs numpy.
"""

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from volume_table import read_obj  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("module_dir", help="the folder holding _arap_native (build/addon/arap_deform)")
    parser.add_argument("mesh", help="an OBJ bar standing along z")
    parser.add_argument("--budget-ms", type=float, default=33.0)
    parser.add_argument("--runs", type=int, default=2, help="runs of none then self, in turn")
    parser.add_argument("--threads", type=int, default=1,
                        help="the solver's threads; above 1 the time per update is wall time (what the user waits)")
    args = parser.parse_args()
    sys.path.insert(0, args.module_dir)
    import _arap_native as arap

    clock = time.process_time if args.threads == 1 else time.perf_counter
    vertices, faces = read_obj(args.mesh)
    rest, faces = np.array(vertices, dtype=np.float64), np.array(faces, np.int32)
    z = rest[:, 2]
    lo, length = z.min(), z.max() - z.min()
    fixed = np.where(z <= lo + 0.2 * length + 1e-9)[0]
    handle = np.where(z >= lo + 0.95 * length - 1e-9)[0]
    constrained = np.concatenate([fixed, handle]).astype(np.int64)
    fold = np.array([0.5, 0.0, -0.6]) * length
    for _ in range(args.runs):
        for contact in ("none", "self"):
            solver = arap.Solver()
            solver.bind(rest, faces, constrained, contact=contact)
            solver.configure(init="warm", time_budget_ms=args.budget_ms, threads=args.threads)
            cpu, settled, caught_up = [], None, None
            for k in range(120):
                targets = rest[constrained].copy()
                targets[len(fixed):] += min(1.0, (k + 1) / 60) * fold
                start = clock()
                stats = solver.solve(targets)
                cpu.append((clock() - start) * 1e3)
                if k >= 59 and stats.converged and settled is None:
                    settled = k - 59
                if k >= 59 and stats.contact_reached == 1 and caught_up is None:
                    caught_up = k - 59
            cpu = np.array(cpu)
            print("%-4s %s ms per update: drag median %.1f max %.1f; hold median %.1f max %.1f; handles there %s; "
                  "settled %s"
                  % (contact, "CPU" if args.threads == 1 else "wall", np.median(cpu[:60]), cpu[:60].max(), np.median(cpu[60:]), cpu[60:].max(),
                     "after %d updates of holding" % (caught_up + 1) if caught_up is not None else "not within 60",
                     "after %d updates of holding" % (settled + 1) if settled is not None else "not within 60"))


if __name__ == "__main__":
    main()
