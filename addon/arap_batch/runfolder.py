# SPDX-License-Identifier: GPL-3.0-or-later
"""The folder of a sharded run, and how it becomes one report.

    <report>.slurm/
      files.txt      the inputs, sorted, one a line: `arap-batch --files-from files.txt --shard K/N`
                     takes lines K, K+N, K+2N, ... (shard())
      run.json       {"shards": N, "submitted": ISO time, "mode": {...}, "run": {...}}
      shard-K.json   task K's report, written when the task ends
      shard-K.jsonl  one line per file as task K finishes it (--results-log): what a task
                     that was killed outright still leaves
      task-K.log     task K's output

Any scheduler that runs `arap-batch --shard K/N` once for each K can use it;
`arap-batch merge-reports <folder>` turns it into one report.
"""

import datetime
import glob
import json
import os

from . import reports

LIST, RUN = "files.txt", "run.json"


def shard(items, k, n):
    """The K-th of N slices of the sorted items: every N-th from the K-th (neighbours, often
    alike in cost, go to different shards)."""
    return sorted(items)[k::n]


def report_path(folder, k):
    return os.path.join(folder, "shard-%d.json" % k)


def results_path(folder, k):
    return os.path.join(folder, "shard-%d.jsonl" % k)


def prepare(folder, inputs, n, mode, run, submitted):
    """Write the file list and run.json; remove what an earlier run left here."""
    os.makedirs(folder, exist_ok=True)
    for pattern in ("shard-*.json", "shard-*.jsonl", "task-*.log", "*.tmp"):
        for old in glob.glob(os.path.join(folder, pattern)):
            os.remove(old)
    with open(os.path.join(folder, LIST), "w", encoding="utf-8") as f:
        f.writelines(p + "\n" for p in sorted(inputs))
    reports.write(os.path.join(folder, RUN), {"shards": n, "submitted": submitted.isoformat(timespec="milliseconds"),
                                              "mode": mode, "run": run})


def update_run(folder, run):
    """Record what became known after submitting (the job id) in run.json."""
    _inputs, plan = load_plan(folder)
    plan["run"] = run
    reports.write(os.path.join(folder, RUN), plan)


def is_run_folder(path):
    return os.path.isfile(os.path.join(path, LIST)) and os.path.isfile(os.path.join(path, RUN))


def load_plan(folder):
    """(inputs, run.json) of a run folder."""
    try:
        with open(os.path.join(folder, RUN), encoding="utf-8") as f:
            plan = json.load(f)
        with open(os.path.join(folder, LIST), encoding="utf-8") as f:
            inputs = [line.rstrip("\n") for line in f if line.strip()]
    except (OSError, ValueError) as exc:
        raise reports.ReportError("cannot read the run folder %s: %s" % (folder, exc)) from None
    return inputs, plan


class ResultsLog:
    """Follows a growing --results-log file: complete lines only, each read once."""

    def __init__(self, path):
        self.path, self.offset = path, 0

    def new_records(self):
        try:
            with open(self.path, "rb") as f:
                f.seek(self.offset)
                data = f.read()
        except OSError:
            return []
        end = data.rfind(b"\n") + 1
        self.offset += end
        out = []
        for line in data[:end].splitlines():
            try:
                out.append(json.loads(line))
            except ValueError:
                pass
        return out


def collect(folder, states=None, label=None, interrupted=False, elapsed=None):
    """One report from a run folder.

    states: {K: scheduler state} of the tasks when known ("COMPLETED", "CANCELLED", "TIMEOUT", ...);
    label(K) names task K in reasons ("Slurm task 7_1"). A file gets its record from task K's
    report, else from its results log, else it failed with "no result". Unless `interrupted`
    (the user stopped the run), files a stopped task did not reach count as failed.
    """
    inputs, plan = load_plan(folder)
    n, mode = plan["shards"], plan["mode"]
    states = states or {}
    label = label or (lambda k: "task %d" % k)
    submitted = reports.parse_time(plan["submitted"])
    records, end = {}, submitted
    for k in range(n):
        state = states.get(k)
        found = {rec["input"]: reports.file_record(rec) for rec in ResultsLog(results_path(folder, k)).new_records()
                 if "input" in rec}
        try:
            part = reports.load(report_path(folder, k)) if os.path.isfile(report_path(folder, k)) else None
        except reports.ReportError:
            part = None         # unreadable: what its results log says still counts
        if part:
            found.update((rec["input"], reports.file_record(rec)) for rec in part["files"])
            end = max(end, reports.parse_time(part["started"]) + datetime.timedelta(seconds=part["elapsed_s"]))
        for inp in shard(inputs, k, n):
            rec = found.get(inp)
            if rec is None:     # the task left no word of this file
                rec = reports.unprocessed(inp, "no result from %s%s" % (label(k), " (%s)" % state if state else ""),
                                          "interrupted" if interrupted else "failed")
            elif rec["status"] == "interrupted":    # the task was stopped before this file
                if state:
                    rec["reason"] = "%s %s: %s" % (label(k), state, rec["reason"])
                if not interrupted:
                    rec["status"] = "failed"
            records[inp] = rec
    files = [records[i] for i in sorted(records)]
    if elapsed is None:
        elapsed = (end - submitted).total_seconds()
    return reports.build(files, mode, plan["run"], submitted, elapsed, interrupted)
