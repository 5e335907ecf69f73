# Measurement (not a test): a 100-frame bake of a ~10k-vertex bar whose top
# follows a keyframed empty. Prints time per frame, iterations, the largest
# frame-to-frame vertex jump against the handle's own motion, and how
# stationary every frame is (max |dE/dp| on free vertices, relative to the
# first frame's naive guess).
#
#   BLENDER_USER_SCRIPTS=<build>/blender_tests/user_scripts blender --background --factory-startup \
#       -noaudio --python-exit-code 1 --python bench/blender/bake_measure.py -- [DZ TWIST]
#
# DZ: the top's height change over the shot (default -0.3: compresses the bar,
# which buckles); TWIST: turn about z in radians (default 0.3).
import os
import sys
import time

import bpy
import numpy as np
from mathutils import Matrix

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)   # tube_scene, bench_addon
import bench_addon as U  # noqa: E402

U.enable_addon()
api, bake = U.addon("api", "bake")

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
dz, twist = (float(argv[0]), float(argv[1])) if len(argv) == 2 else (-0.3, 0.3)

U.clear_scene()
obj = U.add_cylinder(vertices=80, cuts=123)
top = U.group_where(obj, "top", lambda co: co.z > 1.7)
U.group_where(obj, "bottom", lambda co: co.z < -1.7)
api.set_fixed(obj, "bottom")
empty = U.add_empty("Handle", Matrix.Translation((0, 0, 2.0)))
api.add_handle(obj, "top", empty)
for f in (1, 25, 50, 75, 100):
    t = (f - 1) / 99.0
    empty.location = (0.3 + 1.2 * np.sin(2 * np.pi * t), 0.4 * t, 2.0 + dz * t)
    empty.rotation_euler = (0.0, 0.6 * np.sin(2 * np.pi * t), twist * t)
    empty.keyframe_insert("location", frame=f)
    empty.keyframe_insert("rotation_euler", frame=f)
bpy.context.scene.frame_set(1)
print("%d vertices, top z change %.2f, twist %.2f rad" % (len(obj.data.vertices), dz, twist))

t0, c0 = time.perf_counter(), time.process_time()
r = bake.bake_shape_keys(obj, 1, 100)
wall, cpu = time.perf_counter() - t0, time.process_time() - c0
print("bake (shape keys): %.1f s wall, %.1f s CPU (the process); per frame %.0f ms median (max %.0f), "
      "iterations/frame mean %.0f max %d, write %.0f ms"
      % (wall, cpu, np.median(r.ms), max(r.ms), np.mean(r.iterations), max(r.iterations), r.write_ms))
print("frames stopped by the iteration cap:", [f for f, c in zip(r.frames, r.converged) if not c])

p = r.positions.astype(np.float64)
ratios = []
for i in range(1, len(p)):
    handle = np.linalg.norm(p[i][top] - p[i - 1][top], axis=1).max()
    jump = np.linalg.norm(p[i] - p[i - 1], axis=1).max()
    ratios.append((jump / handle, r.frames[i], jump, handle))
worst = max(ratios)
print("max jump / handle motion: %.3f at frame %d (jump %.4f, handle %.4f); median %.3f"
      % (worst + (float(np.median([x[0] for x in ratios])),)))

m = bake.bake_shape_keys(obj, 1, 100, measure_gradient=True)
print("identical to the first bake: %s" % np.array_equal(m.positions, r.positions))
print("stationarity: first frame's naive guess |grad| %.3g, worst frame %.3g (ratio %.2g), median %.2g"
      % (m.gradient_reference, max(m.gradients), max(m.gradients) / m.gradient_reference,
         float(np.median(m.gradients)) / m.gradient_reference))
sys.stdout.flush()
os._exit(0)
