# Per-frame cost of the Live path, measured through live.LiveSession (not a test).
#
#   BLENDER_USER_SCRIPTS=<build>/blender_tests/user_scripts \
#   blender --background --factory-startup -noaudio --python bench/blender/measure_live.py -- [frames] [iterations]
#
# UV spheres of ~10k and ~50k vertices, bottom cap fixed, top cap on an empty
# that moves a little every frame. Prints medians: read (empties -> targets),
# solve (native, warm-started), write (foreach_set + mesh.update()), total.
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


def sphere(segments, rings):
    for ob in list(bpy.data.objects):
        bpy.data.objects.remove(ob)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=segments, ring_count=rings, radius=1.0)
    obj = bpy.context.active_object
    co = np.empty(len(obj.data.vertices) * 3, np.float32)
    obj.data.vertices.foreach_get("co", co)
    z = co.reshape(-1, 3)[:, 2]
    for name, idx in (("bottom", np.flatnonzero(z < -0.8)), ("top", np.flatnonzero(z > 0.8))):
        obj.vertex_groups.new(name=name).add(idx.tolist(), 1.0, 'REPLACE')
    empty = bpy.data.objects.new("E", None)
    bpy.context.scene.collection.objects.link(empty)
    empty.matrix_world = Matrix.Translation((0, 0, 1))
    api = U.addon("api")
    api.set_fixed(obj, "bottom")
    api.add_handle(obj, "top", empty)
    return obj, empty


def measure(segments, rings, frames, iterations):
    api = U.addon("api")
    obj, empty = sphere(segments, rings)
    session = api.start_session(obj, bpy.context.scene, max_iterations=iterations)
    rows = []
    depsgraph_ms = []
    for f in range(frames + 3):
        empty.matrix_world = Matrix.Translation((0.01 * f, 0.0, 1.0 + 0.005 * f))
        st = session.step()
        # Not part of the Live path: what Blender then spends re-evaluating the mesh.
        t0 = time.perf_counter()
        bpy.context.view_layer.update()
        dg = (time.perf_counter() - t0) * 1e3
        if f >= 3:  # skip the cold start and the first warm frames
            rows.append(st)
            depsgraph_ms.append(dg)
    session.cancel()
    med = {k: statistics.median(getattr(r, k) for r in rows)
           for k in ("read_ms", "solve_ms", "write_ms", "main_thread_ms")}   # step() solves on this thread
    print("ARAP_LIVE vertices=%d triangles=%d bind_ms=%.1f frames=%d iterations=%d "
          "median read=%.3f solve=%.3f write=%.3f (io=%.3f) total=%.3f ms; then depsgraph update=%.3f ms"
          % (len(obj.data.vertices), len(session.problem.tris), session.bind_ms, frames, iterations,
             med["read_ms"], med["solve_ms"], med["write_ms"], med["read_ms"] + med["write_ms"], med["main_thread_ms"],
             statistics.median(depsgraph_ms)))


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    frames = int(argv[0]) if argv else 50
    iterations = int(argv[1]) if len(argv) > 1 else 1
    U.enable_addon()
    measure(142, 71, frames, iterations)    # 9,942 vertices
    measure(316, 159, frames, iterations)   # 49,930 vertices


main()
