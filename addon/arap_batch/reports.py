# SPDX-License-Identifier: GPL-3.0-or-later
"""arap-batch reports: one JSON file per run, merged across shards and reruns.

    {"arap_batch": 1, "started": ISO time, "elapsed_s": seconds, "jobs": workers,
     "mode": {"frame", "bake", "bake_format", "max_iterations", "objects", "in_place", "output_dir"},
     "run": {"scheduler": "local" | "slurm", "jobs", "timeout", "blender", "addon_dir", ...},
     "shard": [K, N],                      (a --shard run only)
     "missing_shards": ["K/N", ...],       (a merge that lacked some shard's report)
     "interrupted": bool, "ok": count, "failed": count,
     "files": [{"input", "output", "status": "ok" | "failed" | "interrupted",
                "reason", "objects": [...], "ms"}]}

"mode" decides what a file's output is: reports merge only when it is the
same. "run" says how the files were processed; --rerun-failed reuses it.
"""

import datetime
import json
import os

VERSION = 1
FILE_FIELDS = ("input", "output", "status", "reason", "objects", "ms")


class ReportError(Exception):
    """A report that cannot be read or merged (a usage error: exit status 2)."""


def utc_now():
    return datetime.datetime.now(datetime.timezone.utc)


def parse_time(text):
    return datetime.datetime.fromisoformat(text)


def file_record(rec):
    out = {k: rec.get(k) for k in FILE_FIELDS}
    out["objects"] = out["objects"] or []
    return out


def unprocessed(inp, reason, status="failed"):
    return {"input": inp, "output": None, "status": status, "reason": reason, "objects": [], "ms": None}


def build(files, mode, run, started, elapsed, interrupted, **extra):
    report = {"arap_batch": VERSION, "started": started.isoformat(timespec="milliseconds"),
              "elapsed_s": round(elapsed, 3), "jobs": run.get("jobs"), "mode": mode, "run": run}
    report.update((k, v) for k, v in extra.items() if v is not None)
    report.update(interrupted=interrupted, ok=sum(f["status"] == "ok" for f in files),
                  failed=sum(f["status"] == "failed" for f in files), files=files)
    return report


def write(path, report):
    """Atomically: a reader never sees half a report."""
    tmp = path + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(report, f, indent=1)
    os.replace(tmp, path)


def load(path):
    try:
        with open(path, encoding="utf-8") as f:
            report = json.load(f)
    except (OSError, ValueError) as exc:
        raise ReportError("cannot read the report %s: %s" % (path, exc)) from None
    if not isinstance(report, dict) or "arap_batch" not in report or not isinstance(report.get("files"), list):
        raise ReportError("%s is not an arap-batch report" % path)
    return report


def exit_code(report):
    """0 every file ok, 1 some file failed (or a shard's report is missing), 130 interrupted."""
    if report["interrupted"]:
        return 130
    return 1 if report["failed"] or report.get("missing_shards") else 0


def print_summary(report, how):
    """The closing lines of a run; `how` says what ran it ("2 job(s)", "Slurm job 7, 2 task(s)")."""
    files, elapsed = report["files"], report["elapsed_s"]
    rate = report["ok"] * 60.0 / elapsed if elapsed > 0 else 0.0
    print("%d file(s): %d ok, %d failed%s in %.1f s (%.1f files/min, %s)"
          % (len(files), report["ok"], report["failed"], ", interrupted" if report["interrupted"] else "",
             elapsed, rate, how))
    for f in files:
        if f["status"] == "failed":
            print("  failed: %s: %s" % (f["input"], f["reason"]))
    for shard in report.get("missing_shards") or []:
        print("  missing: the report of shard %s (its files are not in this report)" % shard)
    return exit_code(report)


def not_ok_inputs(report):
    """The inputs to run again: failed, or not processed because the run was interrupted."""
    return [f["input"] for f in report["files"] if f["status"] != "ok"]


def _check_same_mode(reports, names):
    mode = reports[0].get("mode")
    for report, name in zip(reports[1:], names[1:]):
        other = report.get("mode")
        if other != mode:
            keys = sorted(set(mode or {}) | set(other or {}))
            diff = ", ".join("%s %r vs %r" % (k, (mode or {}).get(k), (other or {}).get(k)) for k in keys
                             if (mode or {}).get(k) != (other or {}).get(k))
            raise ReportError("%s and %s come from runs with different settings (%s): they cannot be merged"
                              % (names[0], name, diff))


def merge(reports, names, interrupted=False):
    """One report from several: shards of one run, or a run followed by reruns.

    A file named by several reports takes its record from the last of them, so
    `merge(full, rerun)` folds a rerun in. Files come out sorted by input. Unless
    `interrupted` (the run being merged was stopped by the user), a file that a
    shard could not reach because that shard was stopped counts as failed: the
    merged run is over and the file is still to do.
    """
    _check_same_mode(reports, names)
    by_input, shards = {}, {}
    for report in reports:
        for f in report["files"]:
            by_input[f["input"]] = file_record(f)
        if report.get("shard"):
            k, n = report["shard"]
            shards.setdefault(n, set()).add(k)
    files = [by_input[i] for i in sorted(by_input)]
    if not interrupted:
        for f in files:
            if f["status"] == "interrupted":
                f["status"] = "failed"
    missing = ["%d/%d" % (k, n) for n, seen in sorted(shards.items()) for k in range(n) if k not in seen]
    starts = [parse_time(r["started"]) for r in reports]
    end = max(s + datetime.timedelta(seconds=r["elapsed_s"]) for s, r in zip(starts, reports))
    run = dict(reports[0].get("run") or {"jobs": reports[0].get("jobs")})
    return build(files, reports[0]["mode"], run, min(starts), (end - min(starts)).total_seconds(), interrupted,
                 missing_shards=missing or None)
