# SPDX-License-Identifier: GPL-3.0-or-later
"""The README's demo: pose a mesh with the installed add-on, headless, and render it.

    blender --background -noaudio --python-exit-code 1 --python tools/demo_pose.py -- OUT_DIR

Uses the add-on as installed in the user's Blender (no --factory-startup), so it
also checks that the set-up command installed and enabled it. Writes
OUT_DIR/demo_posed.blend and OUT_DIR/demo_before_after.png (rest on the left,
posed on the right).
"""

import importlib
import math
import os
import sys

import bpy
import numpy as np
from mathutils import Euler, Vector


def out_dir():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    path = os.path.abspath(argv[0] if argv else ".")
    os.makedirs(path, exist_ok=True)
    return path


def require_addon():
    """The installed add-on's api module; exits with a message when it is missing."""
    enabled = [a.module for a in bpy.context.preferences.addons if a.module.endswith("arap_deform")]
    if not enabled:
        print("ERROR: the ARAP Deform add-on is not installed and enabled: run `bash setup.sh` first")
        sys.exit(1)
    return importlib.import_module(enabled[0] + ".api")


def make_column():
    """A capped cylinder standing on the ground, 20 loops high, with quads."""
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.mesh.primitive_cylinder_add(vertices=32, radius=0.35, depth=3.0, location=(0, 0, 1.5))
    obj = bpy.context.active_object
    bpy.ops.object.mode_set(mode='EDIT')
    bpy.ops.mesh.select_all(action='DESELECT')
    bpy.ops.mesh.select_mode(type='EDGE')
    bpy.ops.object.mode_set(mode='OBJECT')
    for e in obj.data.edges:  # the vertical edges
        a, b = (obj.data.vertices[i].co for i in e.vertices)
        e.select = abs(a.z - b.z) > 1.0
    bpy.ops.object.mode_set(mode='EDIT')
    bpy.ops.mesh.subdivide(number_cuts=29)
    bpy.ops.object.mode_set(mode='OBJECT')
    bpy.ops.object.shade_smooth()
    return obj


def add_groups(api, obj):
    z = np.array([v.co.z for v in obj.data.vertices])
    height = z.max() - z.min()
    api.create_group(obj, "fixed", np.flatnonzero(z < z.min() + 0.15 * height))
    api.create_group(obj, "top", np.flatnonzero(z > z.max() - 0.08 * height))
    api.set_fixed(obj, "fixed")
    bpy.ops.object.empty_add(type='ARROWS', location=(0, 0, 3.0))
    empty = bpy.context.active_object
    empty.name = "TopHandle"
    api.add_handle(obj, "top", empty)
    return empty


def render(path, camera_x):
    scene = bpy.context.scene
    scene.render.engine = 'BLENDER_WORKBENCH'
    scene.display.shading.light = 'STUDIO'
    scene.display.shading.color_type = 'SINGLE'
    scene.render.resolution_x, scene.render.resolution_y = 480, 540
    if scene.world is None:
        scene.world = bpy.data.worlds.new("Demo")
    scene.world.color = (0.32, 0.34, 0.38)
    scene.render.filepath = path
    scene.camera.location = (camera_x, -7.5, 2.2)
    bpy.ops.render.render(write_still=True)


def side_by_side(left, right, path):
    a, b = bpy.data.images.load(left), bpy.data.images.load(right)
    w, h = a.size
    pa = np.array(a.pixels[:], np.float32).reshape(h, w, 4)
    pb = np.array(b.pixels[:], np.float32).reshape(h, w, 4)
    both = bpy.data.images.new("before_after", 2 * w, h)
    both.pixels[:] = np.concatenate([pa, pb], axis=1).ravel()
    both.filepath_raw = path
    both.file_format = 'PNG'
    both.save()


def main():
    out = out_dir()
    api = require_addon()
    obj = make_column()
    empty = add_groups(api, obj)
    bpy.ops.object.camera_add(rotation=(math.radians(80), 0, 0))
    bpy.context.scene.camera = bpy.context.active_object

    before = os.path.join(out, "demo_before.png")
    render(before, 0.6)
    # Swing the handle sideways and down, and turn it, like bending an arm.
    empty.location = Vector((1.4, 0.0, 2.35))
    empty.rotation_euler = Euler((0.0, math.radians(70), 0.0))
    bpy.context.view_layer.update()
    result = api.deform(obj)
    print("Posed '%s': %d vertices, %d iterations, energy %.4g -> %.4g, solve %.1f ms"
          % (obj.name, len(obj.data.vertices), len(result.energies), result.initial_energy, result.energy,
             result.solve_ms))
    after = os.path.join(out, "demo_after.png")
    render(after, 0.6)
    picture = os.path.join(out, "demo_before_after.png")
    side_by_side(before, after, picture)
    blend = os.path.join(out, "demo_posed.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    print("Wrote %s and %s" % (blend, picture))


main()
