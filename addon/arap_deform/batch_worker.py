# SPDX-License-Identifier: GPL-3.0-or-later
"""Batch worker: poses or bakes many .blend files inside one Blender process.

Started by the arap-batch launcher (or by hand):

    blender --background --factory-startup -noaudio --python-exit-code 1 \\
        --python-expr "import sys; sys.path.insert(0, '<folder holding arap_deform>'); \\
                       from arap_deform import batch_worker; batch_worker.main()" -- job.json

job.json:
    {"files": [{"input": "/in/a.blend", "output": "/out/a.blend"}, ...],
     "frame": null | F,               # pose at frame F (null: the file's current frame)
     "bake": null | [START, END],     # bake instead of posing
     "bake_format": "shapekeys" | "pc2",
     "max_iterations": null | N,      # Deform's iteration cap, or the per-frame cap when baking
     "objects": [] | ["Name", ...],   # default: every mesh with ARAP settings
     "results": null | "/path/results.jsonl",
     "launcher_pid": null | PID}      # stop (SIGTERM) when this process dies

Or, for one file (e.g. one farm task), the same settings as flags:

    blender ... --python-expr "..." -- --input a.blend --output out/a.blend \
        [--frame F | --bake START:END [--bake-format pc2]] [--max-iterations N] [--objects NAME ...]

For every file, one JSON line {"event": "start", "input": ...} before it and
one {"event": "result", "input", "output", "status": "ok" | "failed",
"reason", "objects": [...], "ms"} after it, on stdout prefixed by
"@arap-batch " (Blender prints its own lines there too) and appended to
"results" when given. A failing file is reported and the worker goes on;
the exit code is 1 when any file failed, 0 otherwise.

Outputs are saved to a hidden temporary file in the output folder and renamed
over the final name (os.replace), so a killed worker never leaves half a
file under the final name; the input is only replaced when output == input
(--in-place). SIGTERM stops the worker after removing its temporary files.
"""

import json
import os
import signal
import sys
import time
import traceback

import bpy

from .persistence import temp_files

PREFIX = "@arap-batch "


class Interrupted(BaseException):
    """SIGTERM arrived: stop after cleaning up (not caught by `except Exception`)."""


class _Stop:
    requested = False   # SIGTERM seen (also when the exception was swallowed somewhere)
    critical = False    # between renaming an output and reporting it: finish, then stop


class FileFailed(Exception):
    pass


def write_failure(out, exc, free_bytes=None):
    """The reason a result could not be saved. Blender reports a full disk as
    "No such file or directory" (it fails to rename the half-written file), so
    the free space of the output's folder decides what to say."""
    folder = os.path.dirname(out) or "."
    if free_bytes is None:
        try:
            st = os.statvfs(folder)
            free_bytes = st.f_bavail * st.f_frsize
        except OSError:
            free_bytes = None
    said = str(exc).strip().splitlines()[-1] if str(exc).strip() else type(exc).__name__
    if free_bytes is not None and free_bytes < (1 << 20):
        return "no space left on the device of %s (%d bytes free); Blender said: %s" % (folder, free_bytes, said)
    return "cannot write %s: %s" % (out, said)


def _ensure_addon():
    """Register the add-on this module belongs to (once per process)."""
    package = __package__ or "arap_deform"
    if not hasattr(bpy.types.Object, "arap"):
        __import__(package).register()
    return sys.modules[package]


def _emit(record, results_path):
    line = json.dumps(record)
    sys.stdout.write(PREFIX + line + "\n")
    sys.stdout.flush()
    if results_path:
        with open(results_path, "a", encoding="utf-8") as f:
            f.write(line + "\n")


def has_settings(obj):
    return obj.type == 'MESH' and (bool(obj.arap.fixed_group) or len(obj.arap.handles) > 0)


def _targets(scene, names):
    if names:
        missing = [n for n in names if scene.objects.get(n) is None]
        if missing:
            raise FileFailed("object(s) not found in the scene: %s" % ", ".join(missing))
        objs = [scene.objects[n] for n in names]
        bad = [o.name for o in objs if not has_settings(o)]
        if bad:
            raise FileFailed("no ARAP settings (fixed group or handles) on: %s" % ", ".join(bad))
        return objs
    objs = [o for o in scene.objects if has_settings(o)]
    if not objs:
        raise FileFailed("no mesh object has ARAP settings (fixed group or handles)")
    return objs


def _pose(obj, job, scene, out_path, written):
    """Deform or bake one object; returns its record. Raises FileFailed."""
    from . import api, errors
    from .solver import bake
    rec = {"name": obj.name}
    try:
        if job.get("bake"):
            start, end = job["bake"]
            if job.get("bake_format") == "pc2":
                folder, name = os.path.split(out_path)
                stem = name.removesuffix(".blend")
                pc2 = os.path.join(folder, "%s_%s.pc2" % (stem, bpy.path.clean_name(obj.name)))
                # Relative to the open file; save_as_mainfile(relative_remap=True) rebases it.
                r = bake.bake_pc2(obj, bpy.path.relpath(pc2), start, end, scene=scene,
                                  max_iterations=job.get("max_iterations"))
                written.append(pc2)
                rec["pc2"] = pc2
            else:
                r = bake.bake_shape_keys(obj, start, end, scene=scene, max_iterations=job.get("max_iterations"))
            rec.update(frames=len(r.frames), energies=r.energies, iterations=r.iterations,
                       ms=round(r.total_ms, 2), warnings=r.warnings)
        else:
            r = api.deform(obj, max_iterations=job.get("max_iterations"), scene=scene)
            rec.update(energies=r.energies, energy=r.energy, iterations=r.iterations,
                       ms=round(r.bind_ms + r.solve_ms + r.io_ms, 2), warnings=r.warnings)
    except Exception as exc:  # noqa: BLE001 - every error of one object fails its file
        message = errors.user_error(exc) or "%s: %s" % (type(exc).__name__, exc)
        raise FileFailed("object '%s': %s" % (obj.name, message)) from exc
    return rec


def process(entry, job):
    """Open, pose/bake and save one file; returns the result record."""
    inp, out = entry["input"], entry["output"]
    rec = {"event": "result", "input": inp, "output": out, "status": "failed", "reason": "", "objects": []}
    t0 = time.perf_counter()
    tmp = temp_files.temp_path(out)
    written = []
    try:
        if not os.path.exists(inp):
            raise FileFailed("input file not found")
        if not os.path.isfile(inp):
            raise FileFailed("the input is not a regular file (a device, FIFO or socket)")
        try:
            bpy.ops.wm.open_mainfile(filepath=inp, load_ui=False)
        except RuntimeError as exc:
            raise FileFailed("cannot open: %s" % str(exc).strip().splitlines()[-1]) from None
        scene = bpy.context.scene
        objs = _targets(scene, job.get("objects"))
        if job.get("frame") is not None:
            scene.frame_set(int(job["frame"]))
        for obj in objs:
            if obj.mode != 'OBJECT':
                bpy.context.view_layer.objects.active = obj
                bpy.ops.object.mode_set(mode='OBJECT')
            rec["objects"].append(_pose(obj, job, scene, out, written))
        try:
            bpy.ops.wm.save_as_mainfile(filepath=tmp, copy=True, relative_remap=True)
        except RuntimeError as exc:
            raise FileFailed(write_failure(out, exc)) from None
        _Stop.critical = True   # main() reports this file before honouring SIGTERM
        os.replace(tmp, out)
        rec["status"] = "ok"
    except FileFailed as exc:
        rec["reason"] = str(exc)
    except Exception as exc:  # noqa: BLE001 - a bug or an unexpected Blender error: report, go on
        rec["reason"] = "%s: %s" % (type(exc).__name__, exc)
        traceback.print_exc()
    finally:
        for path in [tmp, tmp + "@"] + (written if rec["status"] != "ok" else []):
            if os.path.exists(path):
                os.remove(path)
    rec["ms"] = round((time.perf_counter() - t0) * 1e3, 1)
    return rec


def _on_sigterm(_signum, _frame):
    _Stop.requested = True
    if not _Stop.critical:
        raise Interrupted()


def _end_with_launcher(launcher_pid):
    """Linux: have the kernel send SIGTERM when the launcher that started this worker dies.

    A launcher killed outright (SIGKILL: an out-of-memory kill, a farm task's hard stop)
    cannot stop its workers, and a worker in its own session escapes schedulers that
    track a task's processes by parentage (Slurm's proctrack/linuxproc): without this
    it would go on posing files for no one. The signal comes when the direct parent
    dies (the launcher, or a wrapper script given as --blender); elsewhere than Linux
    only the check below is made."""
    try:
        import ctypes
        PR_SET_PDEATHSIG = 1
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
    except Exception:  # noqa: BLE001 - no prctl (macOS, Windows): keep the check only
        pass
    try:
        os.kill(launcher_pid, 0)    # gone already, before the call above?
    except ProcessLookupError:
        _on_sigterm(signal.SIGTERM, None)
    except OSError:
        pass
    _watch_parent()


def _watch_parent():
    """Besides the kernel's signal: a thread that sees the direct parent go (this process is
    re-parented the moment it dies) and sends SIGTERM to the main thread, where the handler
    runs (a sleeping or busy main thread is interrupted as by the kernel's signal). Covers
    what the signal cannot: no prctl, or a parent gone before prctl was called."""
    import threading
    parent, main = os.getppid(), threading.main_thread().ident

    def watch():
        while os.getppid() == parent:
            time.sleep(1.0)
        signal.pthread_kill(main, signal.SIGTERM)

    threading.Thread(target=watch, name="arap-watch-launcher", daemon=True).start()


def parse_job(argv):
    """The job from `job.json` or from --input/--output flags (one file)."""
    if len(argv) == 1 and not argv[0].startswith("-"):
        with open(argv[0], encoding="utf-8") as f:
            return json.load(f)
    import argparse
    p = argparse.ArgumentParser(prog="batch_worker", description="Pose or bake one .blend file "
                                "(blender --background ... -- <job.json> handles many).")
    p.add_argument("--input", required=True)
    p.add_argument("--output", required=True, help="may equal --input (in place)")
    p.add_argument("--frame", type=int)
    p.add_argument("--bake", help="START:END")
    p.add_argument("--bake-format", choices=("shapekeys", "pc2"), default="shapekeys")
    p.add_argument("--max-iterations", "--iterations", type=int)
    p.add_argument("--objects", nargs="+", default=[])
    p.add_argument("--results")
    a = p.parse_args(argv)
    bake = [int(x) for x in a.bake.split(":")] if a.bake else None
    return {"files": [{"input": os.path.abspath(a.input), "output": os.path.abspath(a.output)}],
            "frame": a.frame, "bake": bake, "bake_format": a.bake_format, "max_iterations": a.max_iterations,
            "objects": a.objects, "results": a.results}


def main(argv=None):
    if argv is None:
        argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    try:
        job = parse_job(argv)
    except SystemExit as exc:  # argparse: usage error
        sys.stdout.flush()
        os._exit(exc.code if isinstance(exc.code, int) else 2)
    signal.signal(signal.SIGTERM, _on_sigterm)
    failed = 0
    try:
        if job.get("launcher_pid"):
            _end_with_launcher(job["launcher_pid"])
        _ensure_addon()
        results = job.get("results")
        for entry in job["files"]:
            if _Stop.requested:
                raise Interrupted()
            _emit({"event": "start", "input": entry["input"]}, results)
            rec = process(entry, job)
            _emit(rec, results)
            _Stop.critical = False
            failed += rec["status"] != "ok"
    except Interrupted:
        sys.stdout.flush()
        os._exit(143)
    sys.stdout.flush()
    # os._exit: skip Blender's exit path (it would print and free the last file).
    os._exit(1 if failed else 0)
