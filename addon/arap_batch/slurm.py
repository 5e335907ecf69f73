# SPDX-License-Identifier: GPL-3.0-or-later
"""--scheduler slurm: an arap-batch run as one Slurm array job.

run() writes <report>.sbatch, the job script (task K runs `arap-batch --shard K/N`
with the run's options over the frozen file list) and the run folder
<report>.slurm/ (runfolder.py), submits the script with sbatch, follows the
tasks' results logs for the progress bar until every task has written its
report or left the queue, and turns the folder into one report. Ctrl-C (or
SIGTERM) cancels the array with scancel and waits for its tasks to stop.
Only the client commands are used: sbatch, squeue, scancel, scontrol (sacct
when the cluster keeps accounting).
"""

import os
import re
import shlex
import shutil
import signal
import subprocess
import threading
import time

from . import reports, runfolder

CLIENTS = ("sbatch", "squeue", "scancel", "scontrol")


class SlurmError(Exception):
    """Nothing could be submitted (exit status 2)."""


def check_clients():
    missing = [c for c in CLIENTS if shutil.which(c) is None]
    if missing:
        raise SlurmError("--scheduler slurm needs Slurm's client commands on this machine; not found: %s "
                         "(Debian: apt-get install slurm-client)" % ", ".join(missing))


def artifacts(report_path, rerun=False):
    """(job script, run folder) beside the report; a rerun gets <stem>.rerunK.* so nothing is overwritten."""
    stem = report_path.removesuffix(".json")
    if rerun:
        k = 1
        while os.path.exists("%s.rerun%d.sbatch" % (stem, k)):
            k += 1
        stem = "%s.rerun%d" % (stem, k)
    return stem + ".sbatch", stem + ".slurm"


def _directive(option, value):
    value = str(value)
    return "#SBATCH %s=%s" % (option, '"%s"' % value if re.search(r"\s", value) else value)


def script_text(script, folder, report, n, files, launcher, task_options, cpus, partition=None, time_limit=None,
                extra=(), merge_first=()):
    """The array job script: readable, and submittable again as it is."""
    q = shlex.quote
    merge = " ".join(q(x) for x in list(merge_first) + [folder])
    lines = ["#!/bin/sh",
             "# arap-batch on Slurm: %d file(s) in %d task(s), written by `arap-batch --scheduler slurm`." % (files, n),
             "#",
             "#   sbatch %s                 run every task (again)" % q(script),
             "#   sbatch --array=K %s       run task K again" % q(script),
             "#   arap-batch merge-reports %s --report %s" % (merge, q(report)),
             "#                                  one report from the tasks' reports",
             "#",
             "# Task K poses files K, K+%d, K+%d, ... of files.txt (sorted; counted from 0) in its own" % (n, 2 * n),
             "# Blender worker(s) (arap-batch --shard K/%d) and writes shard-K.json (its report), shard-K.jsonl" % n,
             "# (one line per finished file) and task-K.log in the run folder. Each output is written to a",
             "# temporary file and renamed into place, and inputs are never written (unless --in-place):",
             "# running a task twice, or stopping it half-way, leaves only whole files.",
             _directive("--job-name", "arap-batch"),
             _directive("--array", "0-%d" % (n - 1)),
             _directive("--cpus-per-task", cpus),
             _directive("--output", os.path.join(folder, "task-%a.log"))]
    if partition:
        lines.append(_directive("--partition", partition))
    if time_limit:
        lines.append(_directive("--time", time_limit))
    for opt in extra:   # "--comment=a b" -> #SBATCH --comment="a b"; "-A proj" as it is
        name, eq, value = opt.partition("=")
        lines.append(_directive(name, value) if opt.startswith("--") and eq else "#SBATCH " + opt)
    lines += ["",
              "run=%s" % q(folder),
              'k="${SLURM_ARRAY_TASK_ID:?submit this script with sbatch}"',
              'exec python3 %s --files-from "$run/files.txt" --shard "$k/%d" \\' % (q(launcher), n)]
    lines += ["    %s \\" % q(o) for o in task_options]
    lines += ['    --report "$run/shard-$k.json" --results-log "$run/shard-$k.jsonl"', ""]
    return "\n".join(lines)


def _run(cmd, timeout=60):
    """A Slurm client command, in its own session: a terminal's Ctrl-C reaches only the launcher
    (which then cancels the job), never an sbatch half-way through submitting it."""
    try:
        return subprocess.run(cmd, stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=timeout,
                              start_new_session=True)
    except (OSError, subprocess.TimeoutExpired) as exc:
        return subprocess.CompletedProcess(cmd, 1, "", str(exc))


def submit(script):
    """sbatch the script; the job id."""
    p = _run(["sbatch", "--parsable", script])
    if p.returncode != 0:
        raise SlurmError("sbatch refused the job: %s" % (p.stderr.strip() or "exit code %d" % p.returncode))
    job = p.stdout.strip().split(";")[0]
    if not job.isdigit():
        raise SlurmError("sbatch printed no job id: %r" % p.stdout)
    return job


def cancel(job):
    """scancel a job (all its tasks) or one task ("7_1")."""
    return _run(["scancel", job]).returncode == 0


def _task_ids(text):
    """Array task ids from Slurm's notation: "3", "0-3", "[1,4-6%2]"."""
    out = []
    for part in text.strip("[]").split("%")[0].split(","):
        lo, _, hi = part.partition("-")
        if lo.isdigit() and (not hi or hi.isdigit()):
            out += range(int(lo), int(hi or lo) + 1)
    return out


def task_label(job):
    """How reasons name task K of the job: "Slurm task 812_3" (what scancel and squeue accept)."""
    return lambda k: "Slurm task %s_%d" % (job, k)


def queued_tasks(job):
    """{K: state} of the array's tasks still in the queue (pending, running, completing);
    None when squeue cannot tell (controller unreachable)."""
    p = _run(["squeue", "--noheader", "--array", "--jobs=" + job, "--format=%K %T"])
    if p.returncode != 0:
        return {} if "Invalid job id" in p.stderr else None
    out = {}
    for line in p.stdout.splitlines():
        ids, _, state = line.strip().partition(" ")
        for k in _task_ids(ids):
            out[k] = state.strip()
    return out


def final_states(job):
    """{K: state} of the array's tasks once they have left the queue: scontrol (kept for
    MinJobAge seconds), else sacct (clusters with accounting). States are Slurm's:
    COMPLETED, FAILED (exit code not 0: some file failed), CANCELLED, TIMEOUT, NODE_FAIL, ..."""
    out = {}
    p = _run(["scontrol", "--oneliner", "show", "job", job])
    if p.returncode == 0:
        for line in p.stdout.splitlines():
            fields = dict(f.split("=", 1) for f in line.split() if "=" in f)
            if fields.get("ArrayJobId") == job:
                for k in _task_ids(fields.get("ArrayTaskId", "")):
                    out[k] = fields.get("JobState", "")
    if not out:
        p = _run(["sacct", "--noheader", "--parsable2", "--allocations", "--jobs=" + job, "--format=JobID,State"])
        for line in p.stdout.splitlines() if p.returncode == 0 else []:
            jid, _, state = line.partition("|")
            if jid.startswith(job + "_"):
                for k in _task_ids(jid[len(job) + 1:]):
                    out[k] = state.split()[0] if state else ""   # "CANCELLED by 0" -> CANCELLED
    return out


class Stop:
    """SIGINT/SIGTERM while waiting: the first asks to cancel, the next to stop waiting for that."""

    def __init__(self):
        self.count = 0
        self.event = threading.Event()

    def __call__(self, *_):
        self.count += 1
        self.event.set()


def follow(job, folder, n, progress, stop, poll=2.0, max_poll=30.0, grace=10.0):
    """Until every task has written its report or left the queue (or `stop`): feed each
    finished file to the progress display. squeue is asked with a growing interval (2 s
    up to 30 s); a task gone from the queue without a report is given `grace` seconds for
    its report to appear (shared file systems cache directory listings)."""
    logs = [runfolder.ResultsLog(runfolder.results_path(folder, k)) for k in range(n)]
    pending = set(range(n))
    delay, next_poll, gone_since = poll, time.monotonic() + poll, None
    while pending and not stop.event.is_set():
        for log in logs:
            for rec in log.new_records():
                progress.file_done(rec)
        pending = {k for k in pending if not os.path.isfile(runfolder.report_path(folder, k))}
        now = time.monotonic()
        if pending and now >= next_poll:
            queued = queued_tasks(job)
            if queued is not None and not pending & set(queued):
                gone_since = gone_since or now
                if now - gone_since >= grace:
                    break
                next_poll = now + 1.0
            else:
                gone_since = None
                delay = min(delay * 1.5, max_poll)
                next_poll = now + delay
        stop.event.wait(0.25 if len(pending) <= 64 else 1.0)    # fewer looks at a shared file system
    for log in logs:
        for rec in log.new_records():
            progress.file_done(rec)


def wait_gone(job, stop, timeout=300.0):
    """After scancel: until the array has left the queue, `timeout`, or another Ctrl-C."""
    seen = stop.count
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and stop.count == seen:
        if queued_tasks(job) == {}:
            return True
        time.sleep(1.0)
    return False


def run(plan, new_progress):
    """Submit, follow and collect one sharded run; (report or None with --no-wait, how it ran).

    plan: report (the merged report's path), inputs [sorted paths], shards, mode, run (what
    the report records), task_options (the options every task gets), launcher, cpus,
    partition, time, sbatch_options, no_wait, rerun, merge_first (reports the run folder is
    merged after, with --no-wait: the report a rerun folds into). new_progress(total): the
    progress display, fed each file's record as a task finishes it.
    """
    check_clients()
    script, folder = artifacts(plan.report, plan.rerun)
    n = plan.shards
    submitted = reports.utc_now()
    run_info = dict(plan.run, scheduler="slurm", shards=n, partition=plan.partition, time=plan.time,
                    sbatch_options=list(plan.sbatch_options), script=script)
    runfolder.prepare(folder, plan.inputs, n, plan.mode, run_info, submitted)
    with open(script, "w", encoding="utf-8") as f:
        f.write(script_text(script, folder, plan.report, n, len(plan.inputs), plan.launcher, plan.task_options,
                            plan.cpus, plan.partition, plan.time, plan.sbatch_options, plan.merge_first))
    os.chmod(script, 0o755)

    stop = Stop()
    previous = [signal.signal(s, stop) for s in (signal.SIGINT, signal.SIGTERM)]
    try:
        t0 = time.monotonic()
        job = submit(script)
        run_info["job_id"] = job
        runfolder.update_run(folder, run_info)
        print("Slurm job %s: %d file(s) in %d task(s); job script %s, task logs %s/task-K.log"
              % (job, len(plan.inputs), n, script, folder), flush=True)
        if plan.no_wait:
            sources = [shlex.quote(s) for s in plan.merge_first + [folder]]   # a rerun folds into its report
            print("Not waiting (--no-wait). Follow it with `squeue --jobs=%s`; when it has left the queue:\n"
                  "  arap-batch merge-reports %s --report %s" % (job, " ".join(sources), shlex.quote(plan.report)))
            return None, "Slurm job %s" % job
        progress = new_progress(len(plan.inputs))
        follow(job, folder, n, progress, stop)
        progress.close()
        interrupted = stop.event.is_set()
        if interrupted:
            print("Interrupted: cancelling Slurm job %s (scancel) and waiting for its tasks to stop "
                  "(Ctrl-C again: stop waiting)" % job, flush=True)
            cancel(job)
            wait_gone(job, stop)
        states = final_states(job)
        report = runfolder.collect(folder, states, task_label(job), interrupted, elapsed=time.monotonic() - t0)
        report["slurm_tasks"] = {str(k): s for k, s in sorted(states.items())}
        return report, "Slurm job %s, %d task(s)" % (job, n)
    finally:
        for s, handler in zip((signal.SIGINT, signal.SIGTERM), previous):
            signal.signal(s, handler)


def collect_folder(folder):
    """`merge-reports <run folder>`: the folder's report, with the tasks' Slurm states while
    Slurm still knows the job (tasks still queued count as not done, and say so)."""
    _inputs, plan = runfolder.load_plan(folder)
    job = (plan.get("run") or {}).get("job_id")
    states = {}
    if job and shutil.which("scontrol"):
        states = final_states(job)
        queued = queued_tasks(job) if shutil.which("squeue") else {}
        states.update(queued or {})
        if queued:
            print("note: Slurm job %s still has %d task(s) in the queue; their files count as not done yet"
                  % (job, len(queued)))
    return runfolder.collect(folder, states, task_label(job) if job else None)
