# Live with Self Contact as the viewport runs it: LiveSession.update() on a
# timer (the solves on the worker's native thread, Blender's thread only reading
# the Empty and writing finished poses), on a bar folded into itself.
#
#   build/arap-make-mesh bar --vertices 10000 --output bar10k.obj
#   blender --background --factory-startup -noaudio --python-exit-code 1 \
#       --python bench/blender/contact_live_viewport.py -- BUILD/addon bar10k.obj [--threads 1] [--runs 2]
#
# The bar stands along z: lowest fifth fixed, top 5 % on an Empty. Once a tick
# (Live Interval, 1/30 s), the Empty moves 1/60 of the fold of docs/contact.md
# (half the bar's length sideways, 0.6 of it down), then it holds still, and
# update() runs as the modal operator's timer runs it. Per setting (Self
# Contact off, on; in turn, --runs times):
#   main ms     Blender's thread per update (median, max): what the viewport waits for
#   poses/s     poses shown per second during the drag
#   there s     from the Empty's last move until a pose shows the handle at the Empty (within 1e-4 of the fold)
#   settled s   from the Empty's last move until Live settled (at most 20 s)
# Not a test (no assertions): a measurement.
import argparse
import os
import statistics
import sys
import time

import bpy
import numpy as np
from mathutils import Matrix

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)   # tube_scene, bench_addon
import bench_addon as U  # noqa: E402
sys.path.insert(0, U.BENCH_NATIVE)   # volume_table
from tube_scene import add_group  # noqa: E402
from volume_table import read_obj  # noqa: E402

DRAG_TICKS = 60
HOLD_S = 20.0


def posed_bar(api, path, contact, threads):
    vertices, faces = read_obj(path)
    vertices = [tuple(float(x) for x in v) for v in vertices]
    mesh = bpy.data.meshes.new("Bar")
    mesh.from_pydata(vertices, [], faces)
    mesh.update()
    obj = bpy.data.objects.new("Bar", mesh)
    bpy.context.scene.collection.objects.link(obj)
    z = np.array(vertices)[:, 2]
    lo, length = z.min(), z.max() - z.min()
    add_group(obj, "fixed", np.where(z <= lo + 0.2 * length + 1e-9)[0])
    top = np.where(z >= lo + 0.95 * length - 1e-9)[0]
    add_group(obj, "top", top)
    empty = U.add_empty("Handle", Matrix.Translation((0.0, 0.0, z.max())))
    bpy.context.view_layer.update()
    api.set_fixed(obj, "fixed")
    api.add_handle(obj, "top", empty)
    obj.arap.contact = contact
    obj.arap.threads = threads
    return obj, empty, top, np.array([0.5, 0.0, -0.6]) * length


def run(api, path, contact, threads):
    U.clear_scene()
    obj, empty, top, fold = posed_bar(api, path, contact, threads)
    rest_top = U.coords(obj)[top].mean(axis=0)
    start = empty.matrix_world.copy()
    session = api.start_session(obj, bpy.context.scene)
    tick = obj.arap.live_interval
    main_ms, shown = [], 0
    there = settled = None
    t_next = time.perf_counter()
    last_move = None
    k = 0
    while True:
        if k < DRAG_TICKS:
            empty.matrix_world = Matrix.Translation(tuple(fold * (k + 1) / DRAG_TICKS)) @ start
            if k == DRAG_TICKS - 1:
                last_move = time.perf_counter()
        t = time.perf_counter()
        stats = session.update()
        main_ms.append((time.perf_counter() - t) * 1e3)
        if stats is not None:
            if k < DRAG_TICKS:
                shown += 1
            moved = session.positions().reshape(-1, 3)[top].mean(axis=0) - rest_top
            if last_move is not None and there is None and np.abs(moved - fold).max() <= 1e-4 * np.abs(fold).max():
                there = time.perf_counter() - last_move
        if last_move is not None and session.settled:
            settled = time.perf_counter() - last_move
            break
        if last_move is not None and time.perf_counter() - last_move > HOLD_S:
            break
        k += 1
        t_next += tick
        time.sleep(max(0.0, t_next - time.perf_counter()))
    session.cancel()
    return {"main_ms": statistics.median(main_ms), "main_max": max(main_ms),
            "poses_per_s": shown / (DRAG_TICKS * tick), "there_s": there, "settled_s": settled}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("addon_dir")
    ap.add_argument("mesh", help="an OBJ bar standing along z (arap-make-mesh bar)")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--runs", type=int, default=2)
    args = ap.parse_args(sys.argv[sys.argv.index("--") + 1:])
    U.load_addon(args.addon_dir)
    api = U.addon("api")
    print("| Self Contact | main ms median / max | poses/s dragging | there s | settled s |")
    print("|---|---:|---:|---:|---:|")
    for _ in range(args.runs):
        for contact in (False, True):
            r = run(api, args.mesh, contact, args.threads)
            fmt = lambda v: "%.2f" % v if v is not None else "not within %g" % HOLD_S  # noqa: E731
            print("| %s | %.1f / %.1f | %.1f | %s | %s |"
                  % ("on" if contact else "off", r["main_ms"], r["main_max"], r["poses_per_s"], fmt(r["there_s"]),
                     fmt(r["settled_s"])), flush=True)


if __name__ == "__main__":
    main()
