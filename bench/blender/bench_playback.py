# Playback of an animated handle: Auto mode next to Blender's Laplacian Deform
# + Hook, on the tube scene (tube_scene.py), same keyframes, same anchors.
#
# Headless (frame_set, as --render-anim and batch scripts change frames):
#   blender --background --factory-startup -noaudio --python-exit-code 1 \
#       --python bench/blender/bench_playback.py -- [--addon-dir BUILD/addon] [--sizes 10000,50000] \
#       [--frames 48] [--output DIR]
# In the viewport (a real window; Xvfb works), Blender's own playback (Spacebar):
#   xvfb-run -a -s "-screen 0 1280x800x24" blender --factory-startup -noaudio \
#       --python bench/blender/bench_playback.py -- --viewport [same options]
#
# In the viewport Auto mode shows previews while a frame's final pose is solved on a second solver, so each
# loop of the range is measured on its own: its frames per second and the share of its frames that showed their
# final pose (--loops, default 3).
#
# Headless, per frame (wall ms, median): the first pass solves each frame
# (from the cold start, to the tolerance), the second replays
# the cached poses; then the path check: the cache dropped, the frames visited
# in a shuffled order, and a bake of the range, against the first pass (worst
# vertex difference / tube height). Viewport: frames per second of playback
# (frame-change times, sync mode "play every frame", scene rate 60 fps).
# Not part of ctest (its name is not test_*.py). Writes blender_playback*.md/.json.
import argparse
import json
import os
import random
import statistics
import sys
import time

import bpy
import numpy as np
from mathutils import Matrix, Vector

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)   # tube_scene, bench_addon
import bench_addon as U  # noqa: E402
from tube_scene import add_group, laplacian_with_hook, make_tube, offsets  # noqa: E402


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="bench_playback.py")
    p.add_argument("--addon-dir", default="")
    p.add_argument("--sizes", default="10000,50000")
    p.add_argument("--frames", type=int, default=48)
    p.add_argument("--iterations", type=int, default=1, help="Laplacian Deform's iterations")
    p.add_argument("--tolerance", type=float, default=None, help="the object's tolerance (default: its setting)")
    p.add_argument("--viewport", action="store_true")
    p.add_argument("--loops", type=int, default=3, help="viewport: loops of the range Auto mode plays")
    p.add_argument("--output", default="results")
    return p.parse_args(argv)




def animated_tube(name, vertices, frames):
    """The tube and its handle Empty, keyframed on a sideways sweep over `frames` frames."""
    obj, fixed, top, h = make_tube(name, vertices)
    start = Vector((0.0, 0.0, h))
    empty = U.add_empty(name + "Handle", Matrix.Translation(start))
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, frames
    for f, dx in zip(range(1, frames + 1), [0.0] + offsets(frames - 1, h)):
        empty.location = start + Vector((dx, 0.0, 0.0))
        empty.keyframe_insert("location", frame=f)
    scene.frame_set(1)
    return obj, fixed, top, h, empty, start


def coords(obj):
    buf = np.empty(len(obj.data.vertices) * 3, np.float32)
    obj.data.vertices.foreach_get("co", buf)
    return buf.reshape(-1, 3).astype(np.float64)


def timed_pass(frames, read=None):
    """Per frame: wall ms and CPU ms (the process, every thread: comparable on a busy machine)."""
    ms, cpu_ms, poses = [], [], {}
    for f in frames:
        t, c = time.perf_counter(), time.process_time()
        bpy.context.scene.frame_set(f)
        ms.append((time.perf_counter() - t) * 1e3)
        cpu_ms.append((time.process_time() - c) * 1e3)
        if read is not None:
            poses[f] = read()
    return ms, cpu_ms, poses


def ours_headless(api, auto, bake, n, frames, tolerance):
    obj, fixed, top, h, empty, _start = animated_tube("ArapTube", n, frames)
    if tolerance is not None:
        obj.arap.tolerance = tolerance
    add_group(obj, "fixed", fixed)
    add_group(obj, "top", top)
    api.set_fixed(obj, "fixed")
    api.add_handle(obj, "top", empty)
    t = time.perf_counter()
    api.set_auto(obj, True)   # binds and poses frame 1
    bind_ms = (time.perf_counter() - t) * 1e3
    order = list(range(2, frames + 1))
    solved, solved_cpu, played = timed_pass(order, lambda: coords(obj))
    print("  Auto, solving: %.1f ms/frame" % med(solved), flush=True)
    cached, cached_cpu, _ = timed_pass(order)
    auto.forget()
    shuffled = order[:]
    random.Random(1).shuffle(shuffled)
    _ms, _cpu, scrubbed = timed_pass(shuffled, lambda: coords(obj))
    worst_scrub = max(np.abs(scrubbed[f] - played[f]).max() for f in order) / h
    print("  scrubbed in a shuffled order: worst difference %.1e of the height" % worst_scrub, flush=True)
    api.set_auto(obj, False)
    baked = bake.bake_shape_keys(obj, 1, frames).positions   # from frame 1, as Auto started there
    worst_bake = max(np.abs(baked[f - 1] - played[f]).max() for f in order) / h
    bake.clear_bake(obj)
    return {"vertices": len(obj.data.vertices), "bind_and_first_ms": bind_ms, "solved_ms": solved,
            "solved_cpu_ms": solved_cpu, "cached_ms": cached, "cached_cpu_ms": cached_cpu, "worst_scrub": worst_scrub,
            "worst_bake": worst_bake}


def laplacian_headless(n, frames, iterations):
    obj, fixed, top, h, empty, start = animated_tube("LapTube", n, frames)
    bind_ms = laplacian_with_hook(obj, fixed, top, empty, start, iterations)
    ms, cpu_ms, _ = timed_pass(list(range(2, frames + 1)))
    return {"vertices": len(obj.data.vertices), "bind_ms": bind_ms, "frame_ms": ms, "frame_cpu_ms": cpu_ms}


def med(values):
    return statistics.median(values)


def headless(args, api, auto, bake):
    rows = []
    for n in [int(x) for x in args.sizes.split(",") if x]:
        U.clear_scene()
        ours = ours_headless(api, auto, bake, n, args.frames, args.tolerance)
        U.clear_scene()
        lap = laplacian_headless(n, args.frames, args.iterations)
        U.clear_scene()
        row = {"target_vertices": n, "ours": ours, "laplacian": lap}
        rows.append(row)
        print("%7d vertices: Auto solving %s | cached %s | Laplacian Deform + Hook %s | path: scrub %.1e, "
              "bake %.1e of the height" % (ours["vertices"], cell(ours["solved_ms"], ours["solved_cpu_ms"]),
                                            cell(ours["cached_ms"], ours["cached_cpu_ms"]),
                                            cell(lap["frame_ms"], lap["frame_cpu_ms"]),
                                            ours["worst_scrub"], ours["worst_bake"]), flush=True)
    write(args, "blender_playback", rows, "\n".join([
        "Per frame, medians: CPU ms of the process (wall ms, frames per second from wall time).\n",
        "| V | Auto, solving | Auto, cached | LapDeform + Hook | Auto solving / LapDeform (CPU) "
        "| worst scrub / bake difference |",
        "|---:|---:|---:|---:|---:|---:|"] + [
        "| %d | %s | %s | %s | %.2f | %.1e / %.1e |" % (
            r["ours"]["vertices"], cell(r["ours"]["solved_ms"], r["ours"]["solved_cpu_ms"]),
            cell(r["ours"]["cached_ms"], r["ours"]["cached_cpu_ms"]),
            cell(r["laplacian"]["frame_ms"], r["laplacian"]["frame_cpu_ms"]),
            med(r["ours"]["solved_cpu_ms"]) / med(r["laplacian"]["frame_cpu_ms"]),
            r["ours"]["worst_scrub"], r["ours"]["worst_bake"])
        for r in rows]))


def cell(wall_ms, cpu_ms):
    return "%.1f ms CPU (%.1f ms, %.0f fps)" % (med(cpu_ms), med(wall_ms), 1e3 / med(wall_ms))


def write(args, name, rows, table):
    os.makedirs(args.output, exist_ok=True)
    with open(os.path.join(args.output, name + ".json"), "w") as f:
        json.dump({"blender": bpy.app.version_string, "frames": args.frames, "rows": rows}, f, indent=1)
    with open(os.path.join(args.output, name + ".md"), "w") as f:
        f.write("# Playback, Auto mode vs Laplacian Deform + Hook (Blender %s, %d frames)\n\n%s\n"
                % (bpy.app.version_string, args.frames, table))
    print("wrote", os.path.join(args.output, name + ".md"), flush=True)


class ViewportRun:
    """Plays each scene in the viewport (timers drive it: the UI must be running)."""

    def __init__(self, args, api, auto):
        self.args, self.api, self.auto = args, api, auto
        self.jobs = [(n, kind) for n in [int(x) for x in args.sizes.split(",") if x] for kind in ("auto", "lap")]
        self.rows, self.times, self.shown = [], [], []

    def view3d(self):
        win = bpy.context.window_manager.windows[0]
        area = next(a for a in win.screen.areas if a.type == 'VIEW_3D')
        return win, area, next(r for r in area.regions if r.type == 'WINDOW')

    def frame_changed(self, scene, _depsgraph=None):
        """After Auto mode's own handler (registered first): whether the frame shows its final pose."""
        final = False
        if self.jobs and self.jobs[0][1] == "auto":
            obj = scene.objects.get("Tube")
            poser = self.auto._posers.get(obj.as_pointer()) if obj is not None else None
            final = poser is not None and poser.written in poser.cache and poser.written[0] == scene.frame_current
        self.times.append(time.perf_counter())
        self.shown.append((scene.frame_current, final))

    def loops(self):
        """The frames shown, split where playback wrapped around: [[(time, frame, final), ...], ...]."""
        loops = [[]]
        for t, (frame, final) in zip(self.times, self.shown):
            if loops[-1] and frame < loops[-1][-1][1]:
                loops.append([])
            loops[-1].append((t, frame, final))
        return loops

    def start(self):
        if not self.jobs:
            return self.finish()
        n, kind = self.jobs[0]
        U.clear_scene()
        obj, fixed, top, h, empty, start = animated_tube("Tube", n, self.args.frames)
        if kind == "auto":
            add_group(obj, "fixed", fixed)
            add_group(obj, "top", top)
            self.api.set_fixed(obj, "fixed")
            self.api.add_handle(obj, "top", empty)
            self.api.set_auto(obj, True)
        else:
            laplacian_with_hook(obj, fixed, top, empty, start, self.args.iterations)
        scene = bpy.context.scene
        scene.render.fps = 60
        scene.sync_mode = 'NONE'   # every frame is shown: the rate is what the evaluation allows
        self.vertices = len(obj.data.vertices)
        win, area, region = self.view3d()
        area.spaces.active.region_3d.view_distance = 9.0
        self.times, self.shown = [], []
        with bpy.context.temp_override(window=win, area=area, region=region):
            bpy.ops.screen.animation_play()
        bpy.app.timers.register(self.stop, first_interval=0.5)
        return None

    def stop(self):
        kind = self.jobs[0][1]
        if kind == "auto":
            enough = len(self.loops()) > self.args.loops   # the last loop complete
            too_long = len(self.times) >= 3 and time.perf_counter() - self.times[0] > 600
        else:
            enough = len(self.times) >= min(self.args.frames, 30)
            too_long = len(self.times) >= 3 and time.perf_counter() - self.times[0] > 60
        if not (enough or too_long):
            return 0.2
        win, area, region = self.view3d()
        with bpy.context.temp_override(window=win, area=area, region=region):
            bpy.ops.screen.animation_cancel(restore_frame=True)
        n, kind = self.jobs.pop(0)
        t = self.times[1:]   # the first change happens before the first frame is drawn
        fps = (len(t) - 1) / (t[-1] - t[0])
        row = {"target_vertices": n, "kind": kind, "vertices": self.vertices, "fps": fps, "frames": len(t)}
        if kind == "auto":
            # Per loop: frames per second (from its first frame to the next loop's), the share shown final.
            loops = self.loops()
            row["loops"] = [{"fps": len(lp) / ((loops[k + 1][0][0] if k + 1 < len(loops) else lp[-1][0]) - lp[0][0]),
                             "final": sum(f for _t, _frame, f in lp) / len(lp), "frames": len(lp)}
                            for k, lp in enumerate(loops[:self.args.loops]) if len(lp) > 1]
            print("viewport auto %d vertices, per loop (fps, share final): %s" % (
                self.vertices, ", ".join("%.1f, %.0f%%" % (lp["fps"], 100 * lp["final"]) for lp in row["loops"])),
                flush=True)
        self.rows.append(row)
        print("viewport %s %d vertices: %.1f fps over %d frames" % (kind, self.vertices, fps, len(t)), flush=True)
        bpy.app.timers.register(self.start, first_interval=0.5)
        return None

    def finish(self):
        by = {(r["target_vertices"], r["kind"]): r for r in self.rows}
        sizes = sorted({r["target_vertices"] for r in self.rows})
        loops = range(self.args.loops)
        write(self.args, "blender_playback_viewport", self.rows, "\n".join(
            ["| V | " + " | ".join("Auto loop %d: fps, frames final" % (k + 1) for k in loops) +
             " | LapDeform + Hook (viewport) |", "|---:|" + "---:|" * (self.args.loops + 1)] +
            ["| %d | %s | %.1f fps |" % (
                by[(n, "auto")]["vertices"],
                " | ".join("%.1f fps, %.0f%%" % (lp["fps"], 100 * lp["final"]) for lp in by[(n, "auto")]["loops"]),
                by[(n, "lap")]["fps"]) for n in sizes]))
        bpy.app.handlers.frame_change_post.remove(self.frame_changed)
        bpy.ops.wm.quit_blender()
        return None


def main():
    args = parse_args()
    U.load_addon(args.addon_dir)
    api, auto, bake = U.addon("api", "auto", "bake")
    if args.viewport:
        run = ViewportRun(args, api, auto)
        bpy.app.handlers.frame_change_post.append(run.frame_changed)
        bpy.app.timers.register(run.start, first_interval=2.0)
        return
    headless(args, api, auto, bake)
    sys.stdout.flush()
    os._exit(0)


main()
