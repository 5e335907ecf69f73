# .blend files for the batch tests and measurements, built from Blender primitives.
# Each make_* clears the scene, builds, saves a copy to `path` (the open file is unchanged).
import os

import bpy
from mathutils import Matrix

import arap_test_utils as U

api = U.addon("api")


def _save(path):
    bpy.ops.wm.save_as_mainfile(filepath=path, copy=True)
    return path


def posed_bar(vertices=16, cuts=8, dx=0.6):
    """Bar with fixed bottom and a handle on top whose empty moved by dx since the bind."""
    U.clear_scene()
    obj = U.add_cylinder(vertices=vertices, cuts=cuts)
    U.group_where(obj, "bottom", lambda co: co.z < -1.5)
    U.group_where(obj, "top", lambda co: co.z > 1.5)
    api.set_fixed(obj, "bottom")
    empty = U.add_empty("TopEmpty", Matrix.Translation((0, 0, 2.0)))
    api.add_handle(obj, "top", empty)
    empty.location.x += dx
    bpy.context.view_layer.update()
    return obj, empty


def make_good(path, vertices=16, cuts=8, dx=0.6):
    posed_bar(vertices, cuts, dx)
    return _save(path)


def make_animated(path, frames=(1, 5), vertices=16, cuts=8):
    """The handle empty keyframed from x=0.2 at the first frame to x=0.8 at the last."""
    _obj, empty = posed_bar(vertices, cuts, 0.2)
    for f, x in zip(frames, (0.2, 0.8)):
        empty.location.x = x
        empty.keyframe_insert("location", frame=f)
    bpy.context.scene.frame_set(frames[0])
    return _save(path)


def make_missing_empty(path):
    _obj, empty = posed_bar()
    bpy.data.objects.remove(empty)
    return _save(path)


def make_no_settings(path):
    U.clear_scene()
    U.add_cylinder()
    return _save(path)


def make_corrupt(path, size=4096):
    with open(path, "wb") as f:
        f.write(os.urandom(size))
    return path
