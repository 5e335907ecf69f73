# SPDX-License-Identifier: GPL-3.0-or-later
"""arap-batch: pose or bake many .blend files with ARAP Deform in parallel Blender workers.

    arap-batch shots/ extra.blend --output posed/ --frame 12 --jobs 4 --report report.json
    arap-batch shots/ --in-place --bake 1:100 --bake-format pc2
    arap-batch shots/ --output posed/ --scheduler slurm --shards 20 --report runs/report.json
    arap-batch --rerun-failed runs/report.json
    arap-batch merge-reports runs/shard-0.json runs/shard-1.json --report runs/all.json

Every mesh with ARAP settings (a fixed group or handles), or the --objects
named, is posed at --frame (Deform) or baked over --bake START:END (shape keys
or a .pc2 point cache + Mesh Cache modifier). Files are split over --jobs
Blender processes, each handling many files (Blender starts once per worker).

Outputs go to --output DIR under the input's name (or replace the input with
--in-place), always through a temporary file renamed into place: an
interrupted run (Ctrl-C, a crash) leaves finished outputs and every input
intact and no temporary files. Inputs are never written otherwise.

Beyond one machine: --shard K/N does the K-th of N slices of the sorted
inputs (for any farm), merge-reports joins the shards' reports, and
--scheduler slurm runs the slices as one Slurm array job and waits for it.

Exit status: 0 all files ok, 1 some file failed, 2 usage error, 130 interrupted.
Plain Python 3 (standard library only); it needs Blender and a built add-on
(one with its native module: the build's staged add-on, or an installed zip's
folder).

This module is the launcher; the script arap-batch beside the package (in the
source tree's addon/ and in the build tree) only calls main(), as does
`python3 -m arap_batch`.
"""

import argparse
import collections
import glob
import importlib.util
import json
import math
import os
import queue
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import types

from . import reports, runfolder, slurm

try:
    from . import build_paths   # the build tree's copy only: where that build staged the add-on, its Blender
except ImportError:
    build_paths = None

PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__))
# The script that runs main(): beside this package in the source tree (addon/) and in the build tree.
LAUNCHER = os.path.join(os.path.dirname(PACKAGE_DIR), "arap-batch")

PREFIX = "@arap-batch "
WORKER_EXPR = ("import sys; sys.path.insert(0, %r); "
               "from %s import batch_worker; batch_worker.main()")
FILES_PER_SHARD = 25        # default --shards: a task's Blender start-up is paid over this many files
MAX_SHARDS = 1000           # Slurm's default MaxArraySize is 1001
MAX_FRAME = 1048574         # Blender's frames run from -MAX_FRAME to MAX_FRAME
# The solver's max_iterations limit (the native option table's maximum), for checking --max-iterations without
# the native module; blender_tests/test_batch_launcher.py fails when the two differ.
MAX_ITERATIONS = 1000000


def default_addon_dir():
    """The add-on the build staged, else the arap_deform folder beside this package (in the source
    tree, addon/arap_deform: no native module there, parse_args() says so)."""
    if build_paths is not None:
        return build_paths.ADDON_DIR
    return os.path.join(os.path.dirname(PACKAGE_DIR), "arap_deform")


def default_blender():
    if build_paths is not None and build_paths.BLENDER:
        return build_paths.BLENDER
    return shutil.which("blender") or "blender"


def has_native_module(addon_dir):
    return bool(glob.glob(os.path.join(addon_dir, "_arap_native*")))


def addon_temp_files(addon_dir):
    """The add-on's temp_files.py (plain Python, no bpy): the launcher looks for what a dead worker
    left by the rule the workers name their temporary files with."""
    spec = importlib.util.spec_from_file_location("arap_batch_addon_temp_files",
                                                  os.path.join(addon_dir, "persistence", "temp_files.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def quoted(text):
    """A value for a one-line message: at most 40 characters of it, quoted and escaped."""
    return repr(text[:40]) + ("..." if len(text) > 40 else "")


# Numbers as users write them: ASCII digits, an optional sign, no spaces; floats in decimal notation
# (float() would also take ' 1', '1_0', 'nan', 'inf', and int() non-ASCII digits).
WHOLE = re.compile(r"[+-]?[0-9]{1,18}", re.ASCII)
DECIMAL = re.compile(r"[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]{1,4})?", re.ASCII)


def whole_number(text, low, high=None):
    """The integer `text` spells if it lies in [low, high] (high None: no limit), else None."""
    if not WHOLE.fullmatch(text):
        return None
    v = int(text)
    return v if low <= v and (high is None or v <= high) else None


def whole(low, high=None):
    """An argparse type: an integer from `low` (to `high`); '-0' is 0."""
    def parse(text):
        v = whole_number(text, low, high)
        if v is None:
            limits = "of at least %d" % low if high is None else "from %d to %d" % (low, high)
            raise argparse.ArgumentTypeError("wants a whole number %s, got %s" % (limits, quoted(text)))
        return v
    return parse


def seconds(text):
    """An argparse type: a finite positive number of seconds."""
    v = float(text) if DECIMAL.fullmatch(text) else math.nan
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError("wants a positive number of seconds, got %s" % quoted(text))
    return v


def frame_range(text):
    """START:END of --bake as [START, END] (frames in Blender's range, START <= END), else None."""
    parts = text.split(":")
    frames = [whole_number(t, -MAX_FRAME, MAX_FRAME) for t in parts]
    if len(parts) != 2 or None in frames or frames[0] > frames[1]:
        return None
    return frames


# The options taking numbers (all their spellings): a value after them that starts with '-' and is not
# an option of one letter is theirs ('--timeout -inf' would otherwise be "expected one argument").
NUMERIC_OPTIONS = {"--jobs": "--jobs", "-j": "--jobs", "--frame": "--frame", "--bake": "--bake",
                   "--max-iterations": "--max-iterations", "--iterations": "--iterations", "--timeout": "--timeout",
                   "--shard": "--shard",
                   "--shards": "--shards"}


def attach_numeric_values(argv):
    """argv with '--timeout -inf' as '--timeout=-inf' (for every option of NUMERIC_OPTIONS)."""
    out, i = [], 0
    while i < len(argv) and argv[i] != "--":
        flag = NUMERIC_OPTIONS.get(argv[i])
        value = argv[i + 1] if flag and i + 1 < len(argv) else ""
        if value.startswith("-") and not value.startswith("--") and not re.fullmatch(r"-[A-Za-z]", value):
            out.append("%s=%s" % (flag, argv[i + 1]))
            i += 2
        else:
            out.append(argv[i])
            i += 1
    return out + argv[i:]


class OneLineParser(argparse.ArgumentParser):
    """Usage errors as one line on stderr, exit status 2 (as arap-deform)."""

    def error(self, message):
        self.exit(2, "%s: %s (see --help)\n" % (self.prog, message))


def build_parser():
    p = OneLineParser(prog="arap-batch", description=__doc__.split("\n\n")[0],
                      formatter_class=argparse.RawDescriptionHelpFormatter,
                      epilog="Exit status: 0 all ok, 1 a file failed, 2 usage error, 130 interrupted. "
                             "`arap-batch merge-reports --help`: merging reports.")
    p.add_argument("inputs", nargs="*", metavar="FILE_OR_DIR", help=".blend files, or folders searched for them")
    p.add_argument("--files-from", metavar="LIST",
                   help="also the .blend files listed in LIST, one a line (a listed file that is missing fails alone)")
    p.add_argument("--output", "-o", metavar="DIR", help="folder for the results (created if needed)")
    p.add_argument("--in-place", action="store_true", help="replace each input with its result")
    p.add_argument("--jobs", "-j", type=whole(1), metavar="N",
                   help="Blender worker processes (default: %d, the cores here; with --scheduler slurm: "
                        "per task, default 1)" % (os.cpu_count() or 1))
    mode = p.add_mutually_exclusive_group()
    mode.add_argument("--frame", type=whole(-MAX_FRAME, MAX_FRAME), metavar="F",
                      help="pose at this frame (default: each file's frame)")
    mode.add_argument("--bake", metavar="START:END", help="bake this frame range instead of posing one frame")
    p.add_argument("--bake-format", choices=("shapekeys", "pc2"),
                   help="shape keys per frame, or a .pc2 next to the output (default: shapekeys)")
    p.add_argument("--max-iterations", "--iterations", type=whole(1, MAX_ITERATIONS), metavar="N",
                   help="Deform's iteration cap (default: each object's Max Iterations), or the per-frame cap when "
                        "baking; --iterations is accepted as the short form")
    p.add_argument("--objects", nargs="+", action="extend", metavar="NAME",
                   help="only these objects (default: every mesh with ARAP settings)")
    p.add_argument("--report", metavar="FILE", help="write a JSON report here")
    p.add_argument("--results-log", metavar="FILE",
                   help="write one JSON line per finished file to FILE as the run goes (for watching it)")
    p.add_argument("--blender", metavar="PATH", help="Blender (default: %s)" % default_blender())
    p.add_argument("--addon-dir", metavar="DIR",
                   help="the arap_deform add-on folder (default: %s)" % default_addon_dir())
    p.add_argument("--timeout", type=seconds, metavar="SEC", help="fail a file that takes longer than this")
    p.add_argument("--shard", metavar="K/N",
                   help="only the K-th (from 0) of N slices of the sorted inputs: every N-th file from the K-th")
    p.add_argument("--rerun-failed", metavar="REPORT",
                   help="run again the files that failed (or were not reached) in REPORT, with its settings; "
                        "REPORT (or --report) is updated")
    g = p.add_argument_group("on a cluster")
    g.add_argument("--scheduler", choices=("local", "slurm"),
                   help="local: Blender workers on this machine (default); slurm: a Slurm array job whose "
                        "task K runs --shard K/N (needs --report; the job script is written beside it)")
    g.add_argument("--shards", type=whole(1), metavar="N",
                   help="array tasks (default: one per %d files, at most %d)" % (FILES_PER_SHARD, MAX_SHARDS))
    g.add_argument("--partition", metavar="P", help="Slurm partition (sbatch --partition)")
    g.add_argument("--time", metavar="T", help="time limit of each task (sbatch --time, e.g. 1:00:00)")
    g.add_argument("--sbatch-option", action="append", default=[], metavar="OPT",
                   help="one more #SBATCH line, e.g. --sbatch-option=--account=proj (repeatable)")
    g.add_argument("--no-wait", action="store_true",
                   help="submit, print the job id and how to merge the reports, and exit")
    return p


def parse_args(argv):
    p = build_parser()
    a = p.parse_args(attach_numeric_values(argv))
    a.base_report, a.listed = None, None
    if a.rerun_failed:
        rerun_from_report(p, a)
    elif not a.inputs and not a.files_from:
        p.error("give .blend files or folders (or --files-from LIST, or --rerun-failed REPORT)")
    a.scheduler = a.scheduler or "local"
    a.bake_format = a.bake_format or "shapekeys"
    a.blender = a.blender or default_blender()
    a.addon_dir = os.path.abspath(a.addon_dir or default_addon_dir())

    if a.in_place == bool(a.output):
        p.error("give exactly one of --output DIR and --in-place")
    if a.jobs is None:
        a.jobs = 1 if a.scheduler == "slurm" else os.cpu_count() or 1
    check_numbers(p, a)
    a.bake_range = None
    if a.bake:
        a.bake_range = frame_range(a.bake)
        if a.bake_range is None:
            p.error("--bake wants START:END with START <= END, whole frames from %d to %d, e.g. 1:100 (got %s)"
                    % (-MAX_FRAME, MAX_FRAME, quoted(a.bake)))
    check_cluster_options(p, a)
    if not os.path.isfile(os.path.join(a.addon_dir, "batch_worker.py")):
        p.error("the add-on folder %s has no batch_worker.py: pass --addon-dir" % a.addon_dir)
    if not has_native_module(a.addon_dir):
        p.error("the add-on folder %s has no native module (_arap_native): pass --addon-dir with a built "
                "add-on, e.g. build/addon/arap_deform after `cmake -S . -B build && cmake --build build`, or run "
                "build/arap-batch" % a.addon_dir)
    if shutil.which(a.blender) is None:
        p.error("Blender not found: %s (pass --blender PATH)" % a.blender)
    check_destinations(p, a)
    if a.listed == []:
        a.files = []        # --rerun-failed: nothing to do
        return a
    a.files = collect(p, a)
    if a.shard_kn:
        a.files = runfolder.shard(a.files, *a.shard_kn)
    if a.scheduler == "slurm":
        a.shards = min(a.shards or min(math.ceil(len(a.files) / FILES_PER_SHARD), MAX_SHARDS), len(a.files))
    return a


def check_numbers(p, a):
    """The numbers --rerun-failed took from a report pass the checks of the options' own."""
    for flag, value, ok in (("--jobs", a.jobs, lambda v: type(v) is int and v >= 1),
                            ("--frame", a.frame, lambda v: type(v) is int and abs(v) <= MAX_FRAME),
                            ("--max-iterations", a.max_iterations,
                             lambda v: type(v) is int and 1 <= v <= MAX_ITERATIONS),
                            ("--timeout", a.timeout,
                             lambda v: type(v) in (int, float) and math.isfinite(v) and v > 0)):
        if value is not None and not ok(value):
            p.error("%s from %s is not valid: %s" % (flag, a.rerun_failed, quoted(str(value))))


def check_cluster_options(p, a):
    a.shard_kn = None
    if a.shard:
        m = re.fullmatch(r"([0-9]{1,18})/([0-9]{1,18})", a.shard, re.ASCII)
        if not m or not int(m.group(1)) < int(m.group(2)):
            p.error("--shard wants K/N with 0 <= K < N, e.g. 0/4 for the first of four (got %s)" % quoted(a.shard))
        a.shard_kn = (int(m.group(1)), int(m.group(2)))
    if a.scheduler == "slurm":
        if a.shard:
            p.error("--shard is what each Slurm task runs: with --scheduler slurm use --shards N")
        if not a.report:
            p.error("--scheduler slurm needs --report FILE (the job script and the tasks' reports go beside it)")
        if not os.path.isdir(os.path.dirname(os.path.abspath(a.report))):
            p.error("the folder of --report %s does not exist" % a.report)
        return
    given = [o for o, v in (("--shards", a.shards), ("--partition", a.partition), ("--time", a.time),
                            ("--sbatch-option", a.sbatch_option), ("--no-wait", a.no_wait)) if v]
    if given:
        p.error("%s only go with --scheduler slurm" % ", ".join(given))


def rerun_from_report(p, a):
    """--rerun-failed REPORT: the files that are not ok there, with its settings (what decides an
    output) and, unless given again, its way of running (scheduler, Blender, timeout; and --jobs
    and the Slurm options when the scheduler stays the same)."""
    given = [o for o, v in (("FILE_OR_DIR", a.inputs), ("--files-from", a.files_from), ("--output", a.output),
                            ("--in-place", a.in_place), ("--frame", a.frame is not None), ("--bake", a.bake),
                            ("--bake-format", a.bake_format), ("--max-iterations", a.max_iterations),
                            ("--objects", a.objects), ("--shard", a.shard)) if v]
    if given:
        p.error("--rerun-failed takes the files and settings from the report: drop %s" % ", ".join(given))
    try:
        base = reports.load(a.rerun_failed)
    except reports.ReportError as exc:
        p.error(str(exc))
    mode, run = base["mode"], base.get("run") or {}
    if "output_dir" not in mode:
        p.error("%s comes from an older arap-batch that did not record the output folder: "
                "run its failed files again by name" % a.rerun_failed)
    a.output, a.in_place = mode["output_dir"], mode["in_place"]
    a.frame, a.bake_format, a.objects = mode["frame"], mode["bake_format"], mode["objects"]
    a.max_iterations = mode.get("max_iterations", mode.get("iterations"))   # "iterations": an older report
    a.bake = "%d:%d" % tuple(mode["bake"]) if mode["bake"] else None
    a.scheduler = a.scheduler or run.get("scheduler")
    same = a.scheduler == run.get("scheduler")      # else --jobs and the Slurm options do not carry over
    for name in ("timeout", "blender", "addon_dir") + (("jobs", "partition", "time") if same else ()):
        if getattr(a, name) is None:
            setattr(a, name, run.get(name))
    if same and a.scheduler == "slurm":
        a.sbatch_option = a.sbatch_option or run.get("sbatch_options") or []
    a.listed = reports.not_ok_inputs(base)
    a.report = a.report or a.rerun_failed
    a.base_report = base


def read_list(p, path):
    try:
        with open(path, encoding="utf-8") as f:
            return [line.strip() for line in f if line.strip() and not line.lstrip().startswith("#")]
    except (OSError, UnicodeDecodeError) as exc:
        p.error("cannot read --files-from %s: %s" % (path, exc))


def writable_folder(path):
    """The folder that would receive `path`'s entries: path itself if it is a
    folder, else its nearest existing ancestor (makedirs creates the rest)."""
    path = os.path.abspath(path)
    while not os.path.exists(path):
        path = os.path.dirname(path)
    return path


def check_destinations(p, a):
    """Usage errors before any work for outputs and reports that cannot be written."""
    if a.output:
        if os.path.exists(a.output) and not os.path.isdir(a.output):
            p.error("--output %s exists and is not a folder" % a.output)
        folder = writable_folder(a.output)
        if not os.path.isdir(folder) or not os.access(folder, os.W_OK | os.X_OK):
            p.error("--output %s cannot be written (%s is not a writable folder)" % (a.output, folder))
    if a.report:
        folder = os.path.dirname(os.path.abspath(a.report))
        if os.path.isdir(a.report):
            p.error("--report %s is a folder: name a file" % a.report)
        if not os.path.isdir(folder):
            p.error("--report %s: the folder %s does not exist" % (a.report, folder))
        if not os.access(folder, os.W_OK | os.X_OK):
            p.error("--report %s: the folder %s is not writable" % (a.report, folder))


def collect(p, a):
    """[(input, output)] in a stable order; usage errors for missing or clashing paths.

    Files listed by --files-from (or taken from a report by --rerun-failed) are taken as
    they are: one that has gone missing fails on its own ("input file not found")."""
    out_dir = os.path.abspath(a.output) if a.output else None
    inputs = []
    for arg in a.inputs:
        path = os.path.abspath(arg)
        if os.path.isdir(path):
            for root, dirs, names in os.walk(path):
                dirs[:] = sorted(d for d in dirs if os.path.join(root, d) != out_dir and not d.startswith("."))
                inputs += [os.path.join(root, n) for n in sorted(names)
                           if n.endswith(".blend") and not n.startswith(".")]
        elif os.path.isfile(path):
            inputs.append(path)
        elif os.path.exists(path):
            p.error("%s is not a regular file or folder (a device, FIFO or socket)" % arg)
        else:
            p.error("no such file or folder: %s" % arg)
    listed = a.listed or (read_list(p, a.files_from) if a.files_from else [])
    inputs += [os.path.abspath(path) for path in listed]
    inputs = list(dict.fromkeys(inputs))
    if not inputs:
        p.error("no .blend files found in: %s" % " ".join(a.inputs + ([a.files_from] if a.files_from else [])))
    files, seen = [], {}
    for inp in inputs:
        out = inp if a.in_place else os.path.join(out_dir, os.path.basename(inp))
        if not a.in_place and os.path.realpath(out) == os.path.realpath(inp):
            p.error("%s would be overwritten by its output: choose another --output or use --in-place" % inp)
        if out in seen:
            p.error("%s and %s would both be written to %s" % (seen[out], inp, out))
        seen[out] = inp
        files.append((inp, out))
    return files


def worker_env():
    """The environment of a worker: without what ties it to this launcher's Python.

    Blender's embedded Python finds its standard library through PATH; when
    this script runs under a pyenv shim or a virtualenv, their bin folders
    come first and Blender would pick up that Python's library (and no numpy).
    """
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1")
    env.pop("PYTHONHOME", None)
    env.pop("VIRTUAL_ENV", None)
    own = os.path.dirname(os.path.abspath(sys.executable))
    if own not in ("/usr/bin", "/bin", "/usr/local/bin"):
        env["PATH"] = os.pathsep.join(d for d in env.get("PATH", "").split(os.pathsep)
                                      if d and os.path.abspath(d) != own and "/.pyenv/" not in d + "/")
    return env


class Worker:
    """One Blender process working through a list of files."""

    def __init__(self, wid, files, args, tmpdir, events, temp_files):
        self.wid = wid
        self.pending = list(files)      # [(input, output)] not yet reported
        self.args = args
        self.tmpdir = tmpdir
        self.events = events
        self.temp_files = temp_files    # the add-on's naming rule of temporary files (sweep())
        self.proc = None
        self.current = None             # input being processed
        self.started_at = None
        self.started_any = False
        self.log = collections.deque(maxlen=20)
        self.generation = 0

    def start(self):
        self.generation += 1
        job = {"files": [{"input": i, "output": o} for i, o in self.pending], "frame": self.args.frame,
               "bake": self.args.bake_range, "bake_format": self.args.bake_format,
               "max_iterations": self.args.max_iterations, "objects": self.args.objects or [],
               "launcher_pid": os.getpid()}
        path = os.path.join(self.tmpdir, "job-%d-%d.json" % (self.wid, self.generation))
        with open(path, "w", encoding="utf-8") as f:
            json.dump(job, f)
        addon = os.path.abspath(self.args.addon_dir)
        expr = WORKER_EXPR % (os.path.dirname(addon), os.path.basename(addon))
        cmd = [self.args.blender, "--background", "--factory-startup", "-noaudio", "--python-exit-code", "1",
               "--python-expr", expr, "--", path]
        env = worker_env()
        # Own session: a terminal's Ctrl-C reaches only the launcher, which stops workers itself.
        self.proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                     env=env, start_new_session=True, text=True, errors="replace", bufsize=1)
        self.current, self.started_any = None, False
        self.log.clear()
        threading.Thread(target=self._read, args=(self.proc, self.generation), daemon=True).start()

    def _read(self, proc, generation):
        for line in proc.stdout:
            self.events.put((self, generation, line.rstrip("\n")))
        proc.stdout.close()
        self.events.put((self, generation, None))

    def signal(self, sig):
        if self.proc is not None and self.proc.poll() is None:
            try:
                os.killpg(self.proc.pid, sig)
            except ProcessLookupError:
                pass

    def sweep(self):
        """Remove temporary files this worker's process may have left."""
        if self.proc is None:
            return
        for folder in {os.path.dirname(o) for _i, o in self.args.files}:
            for path in self.temp_files.left_by(folder, self.proc.pid):
                try:
                    os.remove(path)
                except OSError:
                    pass


class Progress:
    """A bar with files done, failures and ETA on a terminal; one plain line per file otherwise;
    and a JSON line per file in the --results-log file, when there is one."""

    def __init__(self, total, tty, log=None):
        self.total, self.tty, self.log = total, tty, log
        self.done = self.failed = 0
        self.t0 = time.monotonic()
        if tty:
            self.draw()

    def eta(self):
        if not self.done:
            return "?"
        left = (time.monotonic() - self.t0) / self.done * (self.total - self.done)
        return "%d:%02d" % divmod(int(left + 0.5), 60)

    def draw(self):
        width = 30
        fill = width * self.done // self.total
        sys.stdout.write("\r[%s%s] %d/%d files, %d failed, ETA %s\033[K" % (
            "#" * fill, "." * (width - fill), self.done, self.total, self.failed, self.eta()))
        sys.stdout.flush()

    def file_done(self, rec):
        self.done += 1
        self.failed += rec["status"] != "ok"
        if self.log:
            self.log.write(json.dumps(reports.file_record(rec)) + "\n")
            self.log.flush()
        if self.tty:
            if rec["status"] != "ok":
                sys.stdout.write("\r\033[KFAILED %s: %s\n" % (rec["input"], rec["reason"]))
            self.draw()
            return
        if rec["status"] == "ok":
            line = "[%d/%d] ok     %s -> %s (%.0f ms)" % (self.done, self.total, rec["input"], rec["output"],
                                                           rec.get("ms") or 0)
        else:
            line = "[%d/%d] FAILED %s: %s" % (self.done, self.total, rec["input"], rec["reason"])
        sys.stdout.write(line + "\n")
        sys.stdout.flush()

    def close(self):
        if self.tty:
            sys.stdout.write("\n")


def crash_reason(worker):
    code = worker.proc.returncode
    how = "killed by signal %d" % -code if code is not None and code < 0 else "exit code %s" % code
    tail = [l for l in worker.log if l.strip()][-3:]
    return "worker crashed (%s)%s" % (how, ": " + " | ".join(tail) if tail else "")


def run(args):
    out_dirs = {os.path.dirname(o) for _i, o in args.files}
    for d in out_dirs:
        os.makedirs(d, exist_ok=True)
    n = min(args.jobs, len(args.files))
    events = queue.Queue()
    tmpdir = tempfile.mkdtemp(prefix="arap-batch-")
    results = {}
    progress = Progress(len(args.files), sys.stdout.isatty(), args.results_file)
    interrupted = threading.Event()
    previous = signal.signal(signal.SIGINT, lambda *_: interrupted.set())
    signal.signal(signal.SIGTERM, lambda *_: interrupted.set())
    outputs = dict(args.files)

    def record(rec):
        rec.setdefault("objects", [])
        rec.setdefault("ms", None)
        rec["output"] = outputs[rec["input"]] if rec["status"] == "ok" else None
        results[rec["input"]] = rec
        progress.file_done(rec)

    # Round-robin split: neighbouring (similar) files go to different workers.
    temp_files = addon_temp_files(args.addon_dir)
    workers = [Worker(k, args.files[k::n], args, tmpdir, events, temp_files) for k in range(n)]
    t0 = time.monotonic()
    try:
        for w in workers:
            w.start()
        alive = set(workers)
        stop_deadline = None
        while alive:
            if interrupted.is_set() and stop_deadline is None:
                # Ctrl-C: workers remove their temporary file and exit; results that
                # arrive meanwhile are still recorded, nothing is restarted.
                stop_deadline = time.monotonic() + 10.0
                for x in alive:
                    x.signal(signal.SIGTERM)
            if stop_deadline is not None and time.monotonic() > stop_deadline:
                for x in alive:
                    x.signal(signal.SIGKILL)
            try:
                w, gen, line = events.get(timeout=0.2)
            except queue.Empty:
                w = None
            if w is not None and gen == w.generation:
                if line is None:
                    w.proc.wait()
                    w.sweep()
                    if stop_deadline is None and w.proc.returncode in (143, -signal.SIGTERM):
                        # A SIGTERM sent to the whole process tree (a scheduler cancelling the
                        # task) may reach the worker first: give ours a moment to arrive too
                        # before calling this a crash.
                        interrupted.wait(2.0)
                    if stop_deadline is not None or interrupted.is_set():
                        alive.discard(w)
                        continue
                    if w.current is not None:
                        record({"input": w.current, "status": "failed", "reason": crash_reason(w)})
                        w.pending = [f for f in w.pending if f[0] != w.current]
                    elif w.pending and not w.started_any:
                        # Died before its first file: restarting would fail the same way.
                        for inp, _o in w.pending:
                            record({"input": inp, "status": "failed",
                                    "reason": "worker failed to start: " + crash_reason(w)})
                        w.pending = []
                    if w.pending:
                        w.start()
                    else:
                        alive.discard(w)
                elif line.startswith(PREFIX):
                    msg = json.loads(line[len(PREFIX):])
                    if msg.get("event") == "start":
                        w.current, w.started_at, w.started_any = msg["input"], time.monotonic(), True
                    elif msg.get("event") == "result" and msg["input"] == w.current:
                        msg.pop("event")
                        record(msg)
                        w.pending = [f for f in w.pending if f[0] != w.current]
                        w.current = None
                else:
                    w.log.append(line)
            if args.timeout and stop_deadline is None:
                for x in alive:
                    if x.current is not None and time.monotonic() - x.started_at > args.timeout:
                        record({"input": x.current, "status": "failed",
                                "reason": "timed out after %g s" % args.timeout})
                        x.pending = [f for f in x.pending if f[0] != x.current]
                        x.current = None
                        x.signal(signal.SIGKILL)   # its reader reports EOF, then it restarts
    finally:
        stop(workers)
        shutil.rmtree(tmpdir, ignore_errors=True)
        signal.signal(signal.SIGINT, previous)
    progress.close()
    return results, interrupted.is_set(), time.monotonic() - t0


def stop(workers, grace=10.0):
    """SIGTERM (workers remove their temporary file), then SIGKILL; sweep leftovers."""
    live = [w for w in workers if w.proc is not None and w.proc.poll() is None]
    for w in live:
        w.signal(signal.SIGTERM)
    deadline = time.monotonic() + grace
    for w in live:
        try:
            w.proc.wait(max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            w.signal(signal.SIGKILL)
            w.proc.wait()
    for w in workers:
        w.sweep()


def run_local(args):
    """The files on this machine; (report, how it ran)."""
    started = reports.utc_now()
    results, interrupted, elapsed = run(args) if args.files else ({}, False, 0.0)
    files = [reports.file_record(results.get(inp) or reports.unprocessed(inp, "not processed (interrupted)",
                                                                          "interrupted"))
             for inp, _out in args.files]
    report = reports.build(files, args.mode, args.run_info, started, elapsed, interrupted,
                           shard=list(args.shard_kn) if args.shard_kn else None)
    return report, "%d job(s)" % min(args.jobs, len(files))


def run_slurm(args):
    """The files as one Slurm array job; (report, or None with --no-wait; how it ran)."""
    for d in {os.path.dirname(o) for _i, o in args.files}:
        os.makedirs(d, exist_ok=True)
    opts = ["--in-place"] if args.in_place else ["--output=" + os.path.abspath(args.output)]
    if args.frame is not None:
        opts.append("--frame=%d" % args.frame)
    if args.bake_range:
        opts.append("--bake=%d:%d" % tuple(args.bake_range))
    opts.append("--bake-format=" + args.bake_format)
    if args.max_iterations:
        opts.append("--max-iterations=%d" % args.max_iterations)
    opts += ["--objects=" + name for name in args.objects or []]
    opts += ["--jobs=%d" % args.jobs, "--blender=" + args.blender, "--addon-dir=" + args.addon_dir]
    if args.timeout:
        opts.append("--timeout=%g" % args.timeout)
    plan = types.SimpleNamespace(
        report=os.path.abspath(args.report), inputs=sorted(i for i, _o in args.files), shards=args.shards,
        mode=args.mode, run=args.run_info, task_options=opts, launcher=os.path.realpath(LAUNCHER), cpus=args.jobs,
        partition=args.partition, time=args.time, sbatch_options=args.sbatch_option, no_wait=args.no_wait,
        rerun=args.base_report is not None,
        merge_first=[os.path.abspath(args.rerun_failed)] if args.base_report is not None else [])
    return slurm.run(plan, lambda total: Progress(total, sys.stdout.isatty(), args.results_file))


def merge_main(argv):
    p = OneLineParser(
        prog="arap-batch merge-reports",
        description="One report from the reports of a run's shards (shard-K.json from --shard K/N), a run folder "
                    "(<report>.slurm/ of --scheduler slurm), or a run and its reruns. A file named by several "
                    "takes its record from the last one given.",
        epilog="Exit status: 0 all ok, 1 a file failed or a shard's report is missing, 2 usage error.")
    p.add_argument("sources", nargs="+", metavar="REPORT_OR_RUN_FOLDER")
    p.add_argument("--report", required=True, metavar="FILE", help="the merged report (may be one of the sources)")
    a = p.parse_args(argv)
    loaded = []
    try:
        for src in a.sources:
            if os.path.isdir(src):
                if not runfolder.is_run_folder(src):
                    p.error("%s is not a run folder (no files.txt and run.json in it)" % src)
                loaded.append(slurm.collect_folder(src))
            else:
                loaded.append(reports.load(src))
        report = reports.merge(loaded, a.sources)
    except reports.ReportError as exc:
        p.error(str(exc))
    reports.write(a.report, report)
    return reports.print_summary(report, "merged from %d report(s)" % len(loaded))


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["merge-reports"]:
        return merge_main(argv[1:])
    args = parse_args(argv)
    if args.base_report is not None and not args.files:
        print("Nothing to rerun: every file in %s is ok." % args.rerun_failed)
        return 0
    args.mode = {"frame": args.frame, "bake": args.bake_range, "bake_format": args.bake_format,
                 "max_iterations": args.max_iterations, "objects": args.objects, "in_place": args.in_place,
                 "output_dir": os.path.abspath(args.output) if args.output else None}
    args.run_info = {"scheduler": args.scheduler, "jobs": args.jobs, "timeout": args.timeout,
                     "blender": args.blender, "addon_dir": args.addon_dir}
    if args.shard_kn and args.report and os.path.exists(args.report):
        os.remove(args.report)      # a farm task run again: never leave the last run's report to be merged
    args.results_file = open(args.results_log, "w", encoding="utf-8") if args.results_log else None
    try:
        if args.scheduler == "slurm":
            try:
                report, how = run_slurm(args)
            except slurm.SlurmError as exc:
                print("arap-batch: error: %s" % exc, file=sys.stderr)
                return 2
            if report is None:
                return 0
        else:
            report, how = run_local(args)
    finally:
        if args.results_file:
            args.results_file.close()
    rerun = None
    if args.base_report is not None:    # fold the rerun into the report it came from
        rerun = report
        report = reports.merge([args.base_report, rerun], [args.rerun_failed, "the rerun"], rerun["interrupted"])
        report["started"] = args.base_report["started"]
        report["elapsed_s"] = round(args.base_report["elapsed_s"] + rerun["elapsed_s"], 3)
    if args.report:
        reports.write(args.report, report)
    code = reports.print_summary(rerun or report, how)
    if rerun:
        print("%s after the rerun: %d file(s), %d ok, %d failed" % (args.report, len(report["files"]), report["ok"],
                                                                  report["failed"]))
        code = reports.exit_code(report)
    return code

