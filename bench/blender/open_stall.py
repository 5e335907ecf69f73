# How long opening a .blend saved with Auto mode on holds Blender's thread, in a real window (Xvfb works):
#
#   LIBGL_ALWAYS_SOFTWARE=1 xvfb-run -a -s "-screen 0 1280x800x24" blender --factory-startup -noaudio \
#       --python bench/blender/open_stall.py -- [--addon-dir BUILD/addon] [--vertices 1000000] [--output DIR]
#
# The tube scene (tube_scene.py), its handle Empty moved aside, Auto on and never posed, is saved and opened
# again in the same Blender; from then on every call of Auto mode's update (handlers and timer: all the add-on
# does on Blender's thread) is timed until the pose has settled. Printed, and written to
# DIR/open_stall_<vertices>.json: the longest call and the calls' sum (ms), the time from the open to the first
# pose shown and to the settled, final pose (s). The file's own loading is Blender's and not counted.
import argparse
import json
import os
import sys
import tempfile
import time

import bpy
import numpy as np
from mathutils import Matrix, Vector

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)   # tube_scene, bench_addon
import bench_addon as U  # noqa: E402
from tube_scene import add_group, make_tube  # noqa: E402

TIMEOUT_S = 900


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="open_stall.py")
    p.add_argument("--addon-dir", default="")
    p.add_argument("--vertices", type=int, default=1000000)
    p.add_argument("--output", default="results")
    return p.parse_args(argv)


class Run:
    def __init__(self, args, api, auto):
        self.args, self.api, self.auto = args, api, auto
        self.calls = []          # (start, ms) of each update_scene call after the open
        self.opened = None
        self.first_pose = None
        self.rest = None
        self.path = os.path.join(tempfile.mkdtemp(), "auto_open.blend")

    def make(self):
        U.clear_scene()
        obj, fixed, top, h = make_tube("Tube", self.args.vertices)
        add_group(obj, "fixed", fixed)
        add_group(obj, "top", top)
        empty = U.add_empty("TubeHandle", Matrix.Translation(Vector((0.0, 0.0, h))))
        self.api.set_fixed(obj, "fixed")
        self.api.add_handle(obj, "top", empty)
        empty.location.x += 0.1 * h
        bpy.context.view_layer.update()
        obj.arap["auto"] = True   # on, never posed: the file holds the rest shape
        self.rest = U.coords(obj).copy()
        self.vertices = len(obj.data.vertices)
        bpy.ops.wm.save_as_mainfile(filepath=self.path)

    def timed(self, update_scene):
        def wrapper(*args, **kwargs):
            start = time.perf_counter()
            try:
                return update_scene(*args, **kwargs)
            finally:
                if self.opened is not None:
                    self.calls.append((start, (time.perf_counter() - start) * 1e3))
        return wrapper

    def open(self):
        self.auto.update_scene = self.timed(self.auto.update_scene)
        self.opened = time.perf_counter()
        bpy.ops.wm.open_mainfile(filepath=self.path)
        return None

    def poll(self):
        obj = bpy.data.objects.get("Tube")
        now = time.perf_counter()
        if obj is not None and self.first_pose is None and len(obj.data.vertices) == len(self.rest):
            if np.abs(U.coords(obj) - self.rest).max() > 1e-6:
                self.first_pose = now
        status = self.auto.status(obj) if obj is not None else ""
        if int(now - self.opened) != int(now - self.opened - 0.05):
            print("  %.0f s: %r" % (now - self.opened, status), flush=True)
        if not status.startswith("settled") and now - self.opened < TIMEOUT_S:
            return 0.05
        ms = [c[1] for c in self.calls]
        result = {"blender": bpy.app.version_string, "vertices": self.vertices, "status": status,
                  "calls": len(ms), "longest_ms": max(ms, default=0.0), "sum_ms": sum(ms),
                  "first_pose_s": None if self.first_pose is None else self.first_pose - self.opened,
                  "settled_s": now - self.opened}
        print("open stall:", json.dumps(result), flush=True)
        os.makedirs(self.args.output, exist_ok=True)
        with open(os.path.join(self.args.output, "open_stall_%d.json" % self.args.vertices), "w") as f:
            json.dump(result, f, indent=1)
        bpy.ops.wm.quit_blender()
        return None


def main():
    args = parse_args()
    U.load_addon(args.addon_dir)
    api, auto = U.addon("api", "auto")
    run = Run(args, api, auto)
    run.make()
    bpy.app.timers.register(run.open, first_interval=1.0)
    bpy.app.timers.register(run.poll, first_interval=1.5, persistent=True)


main()
