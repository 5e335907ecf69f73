# SPDX-License-Identifier: GPL-3.0-or-later
"""The picture of docs/rig.md's panel: a rigged tube (three bones) posed in Pose Mode with Auto on, the ARAP
sidebar showing its bone handles, taken by Blender's own screenshot in a real window (on Blender 4.2+, which
can pick the sidebar's tab from Python; on older ones click the ARAP tab, and Escape closes the splash):

    LIBGL_ALWAYS_SOFTWARE=1 xvfb-run -a -s "-screen 0 1280x800x24" blender --factory-startup -noaudio \\
        --python bench/blender/rig_screenshot.py -- build/addon docs/rig_panel.png
"""

import math
import os
import sys

import bpy
from mathutils import Euler

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import bench_addon as U  # noqa: E402

ARGS = sys.argv[sys.argv.index("--") + 1:]
ADDON_DIR, OUT = ARGS[0], os.path.abspath(ARGS[1])


def view3d():
    for window in bpy.context.window_manager.windows:
        for area in window.screen.areas:
            if area.type == 'VIEW_3D':
                return window, area, next(r for r in area.regions if r.type == 'WINDOW')
    raise SystemExit("no 3D viewport")


def set_up():
    U.load_addon(ADDON_DIR)
    api = U.addon("api")
    U.clear_scene()
    obj, rig = U._tests.rigged_tube(cuts=40, segments=24)
    api.handles_from_armature(obj)
    api.set_auto(obj, True)
    window, area, region = view3d()
    area.spaces.active.show_region_ui = True
    area.spaces.active.overlay.show_bones = True
    view = area.spaces.active.region_3d
    view.view_location = (0.0, 0.5, 0.8)
    view.view_distance = 10.0
    view.view_rotation = Euler((math.radians(80), 0.0, math.radians(60))).to_quaternion()
    bpy.context.view_layer.objects.active = rig
    with bpy.context.temp_override(window=window, area=area, region=region):
        bpy.ops.object.mode_set(mode='POSE')
    for name, angles in (("B1", (math.radians(70), 0.0, 0.0)), ("B2", (0.0, math.radians(60), 0.0))):
        bone = rig.pose.bones[name]
        bone.rotation_mode = 'XYZ'
        bone.rotation_euler = angles
        bone.bone.select = name == "B2"
    rig.data.bones.active = rig.data.bones["B2"]
    sidebar = next(r for r in area.regions if r.type == 'UI')
    if hasattr(sidebar, "active_panel_category"):
        sidebar.active_panel_category = "ARAP"
    bpy.app.timers.register(shoot, first_interval=6.0)


def shoot():
    window, area, region = view3d()
    with bpy.context.temp_override(window=window, area=area, region=region):
        bpy.ops.screen.screenshot(filepath=OUT)
    print("wrote", OUT, flush=True)
    bpy.ops.wm.quit_blender()


bpy.app.timers.register(set_up, first_interval=1.0)
