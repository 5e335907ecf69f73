# Blender side of the GUI suite (Blender with its UI, under Xvfb).
#
#   blender --factory-startup -noaudio --window-geometry 0 0 1280 800 --python gui_session.py -- <out dir>
#
# Sets up a bar (fixed bottom, handle on top driven by an empty), then talks
# to drive_gui.py through files in <out dir>:
#   state.json   written every 0.2 s: vertex hash, top centroid, empty location, Live state, viewport centre
#   cmd_*        commands from the driver: cmd_live (start Live), cmd_select_empty, cmd_auto (Auto mode on), cmd_animate
#                (keyframe the Empty), cmd_redo_settings, cmd_big_deform (a Deform that would run for minutes on a
#                second, finer tube "Big", invoked as a button does), cmd_rig (a third bar in Edit Mode, its
#                bottom selected), cmd_rig_top (its top selected instead), cmd_screenshot, cmd_quit
import hashlib
import os
import sys
import traceback

import bmesh
import bpy
import numpy as np
from mathutils import Matrix

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [HERE, os.path.dirname(HERE)]
import arap_test_utils as U  # noqa: E402
import session_files  # noqa: E402

OUT = sys.argv[sys.argv.index("--") + 1]
# "tick" counts the state writes: the driver waits for it to advance to know
# that Blender's event loop has run (and so handled the input sent before).
STATE = {"ready": False, "errors": [], "tick": 0}


def add_bar(name, around, cuts, x=0.0):
    """An upright cylinder of height 2 at (x, 0, 0), `cuts` times subdivided along its height, with the
    vertex groups "bottom" (z < -0.7) and "top" (z > 0.7)."""
    bpy.ops.mesh.primitive_cylinder_add(vertices=around, depth=2.0, radius=0.3, location=(x, 0.0, 0.0))
    obj = bpy.context.active_object
    obj.name = name
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    side = [e for e in bm.edges if abs(e.verts[0].co.z - e.verts[1].co.z) > 1e-6]
    bmesh.ops.subdivide_edges(bm, edges=side, cuts=cuts, use_grid_fill=False)
    bm.to_mesh(obj.data)
    bm.free()
    for group, pred in (("bottom", lambda z: z < -0.7), ("top", lambda z: z > 0.7)):
        g = obj.vertex_groups.new(name=group)
        g.add([v.index for v in obj.data.vertices if pred(v.co.z)], 1.0, 'REPLACE')
    return obj


def setup():
    U.enable_addon()
    api = U.addon("api")
    for ob in list(bpy.data.objects):
        bpy.data.objects.remove(ob)
    obj = add_bar("Bar", around=16, cuts=12)
    api.set_fixed(obj, "bottom")
    empty = bpy.data.objects.new("TopEmpty", None)
    empty.empty_display_type = 'SPHERE'
    empty.empty_display_size = 0.3
    bpy.context.scene.collection.objects.link(empty)
    empty.matrix_world = Matrix.Translation((0.0, 0.0, 1.0))
    api.add_handle(obj, "top", empty)
    obj.arap.live_max_iterations = 3
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    STATE["top"] = [v.index for v in obj.data.vertices if v.co.z > 0.7]
    STATE["rest_hash"] = coords_hash(obj)
    # Show the sidebar on the ARAP tab so the panel is drawn (and screenshotted).
    win, area, region = session_files.view3d()
    area.spaces.active.show_region_ui = True
    # Close enough that the bar fills the view and its bend reads in the screenshots.
    view = area.spaces.active.region_3d
    view.view_location = (0.0, 0.0, 0.3)
    view.view_distance = 6.0
    # The driver switches tabs with Ctrl+Tab over the sidebar; this hook,
    # appended to the add-on's panel, tells it when the ARAP panel was drawn.
    bpy.types.ARAP_PT_main.append(panel_drawn)
    # A key for Deform (as a user's own keymap entry): operators run from input,
    # unlike bpy.ops calls from a script, are what the redo panel (F9) shows.
    km = bpy.context.window_manager.keyconfigs.addon.keymaps.new(name="3D View", space_type='VIEW_3D')
    km.keymap_items.new("object.arap_deform", 'D', 'PRESS', ctrl=True, alt=True, shift=True)
    # Keys for the set-up buttons in Edit Mode: pressed for real, they make the undo steps a click does.
    km = bpy.context.window_manager.keyconfigs.addon.keymaps.new(name="Mesh", space_type='EMPTY')
    km.keymap_items.new("object.arap_set_fixed_from_selection", 'F', 'PRESS', ctrl=True, alt=True, shift=True)
    km.keymap_items.new("object.arap_add_handle_from_selection", 'H', 'PRESS', ctrl=True, alt=True, shift=True)
    # The extension installs clean: no module of the add-on outside its own name, and on 4.2+ nothing
    # under the warning sign of the Preferences.
    STATE["aliases"] = sorted(U.modules_under_other_names())
    STATE["policy_warnings"] = U.extension_policy_warnings() if bpy.app.version >= (4, 2, 0) else []
    # An undo step for the set-up, so Ctrl+Z can come back to it.
    with bpy.context.temp_override(window=win, area=area, region=region):
        bpy.ops.ed.undo_push(message="ARAP test set-up")
    STATE["ready"] = True


def panel_drawn(_panel, context):
    STATE["panel_drawn"] = True
    STATE["panel_draws"] = STATE.get("panel_draws", 0) + 1
    STATE["panel_active"] = context.active_object.name if context.active_object else None
    mesh = U.addon("panels").panel_object(context)  # None: the panel shows only its "select a mesh" line
    STATE["panel_mesh"] = mesh.name if mesh is not None else None


def coords_hash(obj):
    buf = np.empty(len(obj.data.vertices) * 3, np.float32)
    obj.data.vertices.foreach_get("co", buf)
    return hashlib.sha1(buf.tobytes()).hexdigest()


def start_live():
    win, area, region = session_files.view3d()
    obj = bpy.data.objects["Bar"]
    with bpy.context.temp_override(window=win, area=area, region=region, active_object=obj, object=obj):
        result = bpy.ops.object.arap_live('INVOKE_DEFAULT')
    STATE["live_invoke"] = list(result)
    select_only_the_empty()


def select_only_the_empty():
    """G must move the empty: make it the only selected, active object."""
    empty = bpy.data.objects["TopEmpty"]
    for ob in bpy.context.view_layer.objects:
        ob.select_set(False)
    empty.select_set(True)
    bpy.context.view_layer.objects.active = empty


def auto_on():
    """Auto mode on for the bar; the Empty selected and active for G."""
    bpy.data.objects["Bar"].arap.auto = True
    select_only_the_empty()


def animate_empty():
    """Keyframes on the handle Empty: frame 1 where it is, frame 40 0.8 to the side."""
    empty = bpy.data.objects["TopEmpty"]
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 40
    scene.frame_set(1)
    empty.keyframe_insert("location", frame=1)
    empty.location.x += 0.8
    empty.keyframe_insert("location", frame=40)
    scene.frame_set(1)


def report_redo_panel():
    """What the redo panel (F9) shows: the last operator run from the UI."""
    ops = bpy.context.window_manager.operators
    if len(ops) and ops[-1].bl_idname == "OBJECT_OT_arap_deform":
        p = ops[-1].properties
        STATE["redo"] = {"operator": ops[-1].bl_idname, "max_iterations": p.max_iterations, "tolerance": p.tolerance,
                         "init": p.init}


def screenshot(name):
    win, area, _region = session_files.view3d()
    path = os.path.join(OUT, name)
    with bpy.context.temp_override(window=win, area=area):
        bpy.ops.screen.screenshot(filepath=path)


def big_deform():
    """A finer tube (about 30k vertices), its top pulled aside, with settings that keep Deform busy
    for minutes (the textbook method, tolerance 0, a high cap); Deform invoked as the panel's button
    does."""
    api = U.addon("api")
    if "Big" not in bpy.data.objects:
        big = add_bar("Big", around=128, cuts=240, x=1.5)
        api.set_fixed(big, "bottom")
        empty = bpy.data.objects.new("BigEmpty", None)
        bpy.context.scene.collection.objects.link(empty)
        empty.matrix_world = Matrix.Translation((1.5, 0.0, 1.0))
        api.add_handle(big, "top", empty)
        empty.location.x += 0.6
        big.arap.method, big.arap.tolerance, big.arap.max_iterations = 'LOCAL_GLOBAL', 0.0, 10000
        bpy.context.view_layer.update()
        STATE["big_hash"] = coords_hash(big)
        STATE["big_vertices"] = len(big.data.vertices)
    big = bpy.data.objects["Big"]
    bpy.context.view_layer.objects.active = big
    win, area, region = session_files.view3d()
    with bpy.context.temp_override(window=win, area=area, region=region, active_object=big, object=big):
        STATE["deform_invoke"] = list(bpy.ops.object.arap_deform('INVOKE_DEFAULT'))


def rig_in_edit_mode():
    """A third bar, "Rig", active alone and in Edit Mode with its bottom vertices selected."""
    rig = add_bar("Rig", around=16, cuts=12, x=-1.5)
    for ob in bpy.context.view_layer.objects:
        ob.select_set(ob == rig)
    bpy.context.view_layer.objects.active = rig
    win, area, region = session_files.view3d()
    with bpy.context.temp_override(window=win, area=area, region=region, active_object=rig, object=rig):
        bpy.ops.object.mode_set(mode='EDIT')
    select_rig(lambda z: z < -0.7)


def select_rig(predicate):
    rig = bpy.data.objects["Rig"]
    bm = bmesh.from_edit_mesh(rig.data)
    for v in bm.verts:
        v.select_set(predicate(v.co.z))
    bm.select_flush_mode()
    bmesh.update_edit_mesh(rig.data)


def rig_state():
    rig = bpy.data.objects.get("Rig")
    if rig is None:
        return None
    return {"mode": rig.mode, "fixed_group": rig.arap.fixed_group,
            "handles": [[h.group, h.empty.name if h.empty is not None else None] for h in rig.arap.handles],
            "groups": [g.name for g in rig.vertex_groups],
            "empties": sorted(ob.name for ob in bpy.data.objects if ob.name.startswith("Rig_"))}


def write_state():
    deform_ops, live_ops, sessions, status_overlay = U.addon("deform_ops", "live_ops", "sessions", "status_overlay")
    obj = bpy.data.objects.get("Bar")
    if obj is not None and STATE["ready"]:
        co = np.empty(len(obj.data.vertices) * 3, np.float32)
        obj.data.vertices.foreach_get("co", co)
        co = co.reshape(-1, 3)
        STATE["hash"] = coords_hash(obj)
        STATE["top_centroid"] = co[STATE["top"]].mean(axis=0).tolist()
        STATE["empty_location"] = list(bpy.data.objects["TopEmpty"].matrix_world.translation)
        session = sessions.session_for(obj)
        STATE["live_running"] = session is not None
        STATE["live_status"] = live_ops.live_status_text()
        STATE["overlay"] = status_overlay.lines()
        STATE["deform_running"] = deform_ops.ARAP_OT_deform.running is not None
        big = bpy.data.objects.get("Big")
        if big is not None:
            STATE["big_now_hash"] = coords_hash(big)
        STATE["rig"] = rig_state()
        active = bpy.context.view_layer.objects.active
        STATE["active"] = active.name if active is not None else None
        win, area, region = session_files.view3d()
        STATE["auto"] = obj.arap.auto
        STATE["auto_status"] = obj.arap.auto_status
        STATE["frame"] = bpy.context.scene.frame_current
        STATE["playing"] = bool(win.screen.is_animation_playing)
        poser = U.addon("auto")._posers.get(obj.as_pointer())
        if poser is not None:
            STATE["auto_frames_final"] = list(poser.frames_final()) if poser.finals is not None else None
            # The mesh shows the cached final pose of the frame on screen.
            STATE["auto_shown_final"] = (poser.written is not None and poser.written in poser.cache
                                         and poser.written[0] == bpy.context.scene.frame_current)
        if session is not None and session.last is not None:
            STATE["frame_ms"] = session.last.main_thread_ms
            STATE["energy"] = session.last.energy
        STATE["viewport_centre"] = session_files.viewport_centre(win, region)
        ui = next(r for r in area.regions if r.type == 'UI')
        # Screen x of the sidebar's tab column (right edge) and y of its top.
        STATE["sidebar_tabs"] = [ui.x + ui.width - 12, win.height - (ui.y + ui.height)]
    session_files.write_state(OUT, STATE)


def take(cmd):
    return session_files.take(OUT, cmd)


def tick():
    try:
        if not STATE["ready"]:
            setup()
        if take("cmd_live"):
            start_live()
        if take("cmd_select_empty"):
            select_only_the_empty()
        if take("cmd_auto"):
            auto_on()
        if take("cmd_animate"):
            animate_empty()
        if take("cmd_big_deform"):
            big_deform()
        if take("cmd_rig"):
            rig_in_edit_mode()
        if take("cmd_rig_top"):
            select_rig(lambda z: z > 0.7)
        if take("cmd_redo_settings"):
            obj = bpy.data.objects["Bar"]
            obj.arap.max_iterations, obj.arap.tolerance, obj.arap.init = 37, 1e-5, 'LAPLACIAN'
            bpy.context.view_layer.objects.active = obj
        if STATE.get("ready"):
            report_redo_panel()
        shot = take("cmd_screenshot")
        if shot:
            screenshot(shot)
        if take("cmd_quit"):
            write_state()
            bpy.ops.wm.quit_blender()
            return None
        write_state()
    except Exception:  # noqa: BLE001 - reported to the driver through state.json
        STATE["errors"].append(traceback.format_exc())
        write_state()
    return 0.2


bpy.app.timers.register(tick, first_interval=1.0)
