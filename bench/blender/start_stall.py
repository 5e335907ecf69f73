# How long starting Live or Deform from the viewport holds Blender's thread: reading the mesh (its groups,
# triangles and coordinates); the bind runs on a thread of its own and is not counted.
#
#   blender --background --factory-startup -noaudio --python bench/blender/start_stall.py -- \
#       [--addon-dir BUILD/addon] [--sizes 250000,1000000] [--repeats 2]
#
# The tube scene (tube_scene.py); per size and repeat, the time of LiveSession(bind_on_thread=True) (what the Live
# operator's invoke does) and of DeformJob(bind_on_thread=True).start() with no bound solver kept (the modal
# Deform's), wall ms.
import argparse
import os
import sys
import time

import bpy
from mathutils import Matrix, Vector

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)   # tube_scene, bench_addon
import bench_addon as U  # noqa: E402
from tube_scene import add_group, make_tube  # noqa: E402


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="start_stall.py")
    p.add_argument("--addon-dir", default="")
    p.add_argument("--sizes", default="250000,1000000")
    p.add_argument("--repeats", type=int, default=2)
    return p.parse_args(argv)


def main():
    args = parse_args()
    U.load_addon(args.addon_dir)
    api, live, deform_job, solver_cache = U.addon("api", "live", "deform_job", "solver_cache")
    for n in [int(x) for x in args.sizes.split(",") if x]:
        U.clear_scene()
        obj, fixed, top, h = make_tube("Tube", n)
        add_group(obj, "fixed", fixed)
        add_group(obj, "top", top)
        empty = U.add_empty("TubeHandle", Matrix.Translation(Vector((0.0, 0.0, h))))
        api.set_fixed(obj, "fixed")
        api.add_handle(obj, "top", empty)
        bpy.context.view_layer.update()
        for _ in range(args.repeats):
            t = time.perf_counter()
            session = live.LiveSession(obj, bpy.context.scene, bind_on_thread=True)
            live_ms = (time.perf_counter() - t) * 1e3
            session.binding.wait()
            session.cancel()
            solver_cache.clear()
            t = time.perf_counter()
            job = deform_job.DeformJob(obj, bpy.context.scene, bind_on_thread=True)
            job.start()
            deform_ms = (time.perf_counter() - t) * 1e3
            job.binding.wait()
            job.stop()
            print("start stall, Blender %s, %d vertices: Live %.0f ms, Deform %.0f ms"
                  % (bpy.app.version_string, len(obj.data.vertices), live_ms, deform_ms), flush=True)
    sys.stdout.flush()
    os._exit(0)


main()
