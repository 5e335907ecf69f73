# The tube scene of the Blender-side benchmarks (bench_live.py, bench_playback.py):
# an open tube of quads, its bottom fifth fixed and its top 5 % on an Empty,
# for ARAP and for Blender's Laplacian Deform + Hook with the same anchors
# (bench_addon.py loads the add-on, clears the scene and adds Empties).
import math

import bpy
import numpy as np
from mathutils import Matrix, Vector


def make_tube(name, vertices, radius=0.5, height=4.0):
    """Open tube of quads: s segments around, r + 1 rings, s (r + 1) ~ `vertices`, near-square cells."""
    s = max(8, int(round(math.sqrt(vertices * 2 * math.pi * radius / height))))
    r = max(2, int(round(vertices / s)) - 1)
    t = np.linspace(0, 2 * math.pi, s, endpoint=False)
    z = np.linspace(0, height, r + 1)
    co = np.empty((r + 1, s, 3), np.float32)
    co[..., 0] = radius * np.cos(t)[None, :]
    co[..., 1] = radius * np.sin(t)[None, :]
    co[..., 2] = z[:, None]
    ring, seg = np.meshgrid(np.arange(r), np.arange(s), indexing="ij")
    a = ring * s + seg
    b = ring * s + (seg + 1) % s
    quads = np.stack([a, b, b + s, a + s], axis=-1).reshape(-1, 4).astype(np.int32)

    me = bpy.data.meshes.new(name)
    me.vertices.add(s * (r + 1))
    me.vertices.foreach_set("co", co.ravel())
    me.loops.add(quads.size)
    me.loops.foreach_set("vertex_index", quads.ravel())
    me.polygons.add(len(quads))
    me.polygons.foreach_set("loop_start", np.arange(0, quads.size, 4, dtype=np.int32))
    me.polygons.foreach_set("loop_total", np.full(len(quads), 4, np.int32))
    me.update(calc_edges=True)
    me.validate()
    obj = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(obj)
    z = co.reshape(-1, 3)[:, 2]
    fixed = np.nonzero(z <= 0.2 * height + 1e-6)[0]
    top = np.nonzero(z >= 0.95 * height - 1e-6)[0]
    return obj, fixed, top, height


def add_group(obj, name, indices):
    g = obj.vertex_groups.new(name=name)
    g.add([int(i) for i in indices], 1.0, 'REPLACE')
    return g


def offsets(frames, height):
    """Sideways handle offsets, a smooth sweep out to 0.3 h and back."""
    return [0.3 * height * math.sin(math.pi * (k + 1) / (frames + 1)) for k in range(frames)]


def move(empty, start, dx):
    empty.location = start + Vector((dx, 0.0, 0.0))


def laplacian_with_hook(obj, fixed, top, empty, start, iterations):
    """Hook (top follows `empty`, bound at `start`) + Laplacian Deform anchored on
    fixed + top, bound now; returns the bind time in ms."""
    import time
    add_group(obj, "top", top)
    add_group(obj, "anchors", np.concatenate([fixed, top]))
    hook = obj.modifiers.new("Hook", 'HOOK')
    hook.object = empty
    hook.vertex_group = "top"
    hook.matrix_inverse = Matrix.Translation(-start)  # the empty's bind pose (object at the origin)
    lap = obj.modifiers.new("LaplacianDeform", 'LAPLACIANDEFORM')
    lap.vertex_group = "anchors"
    lap.iterations = iterations
    bpy.context.view_layer.objects.active = obj
    bpy.context.view_layer.update()
    t = time.perf_counter()
    with bpy.context.temp_override(object=obj, active_object=obj):
        bpy.ops.object.laplaciandeform_bind(modifier=lap.name)
    bpy.context.view_layer.update()  # the bind happens at this evaluation
    return (time.perf_counter() - t) * 1e3
