# Blender side of the Live latency measurement (measure_live_lag.py drives it).
#
#   blender --factory-startup -noaudio --window-geometry 0 0 1280 800 \
#       --python lag_session.py -- <out dir> <addon dir> <vertices>
#
# A tube of about <vertices> vertices (bottom fifth fixed, top 5 % on an
# Empty), the add-on registered from <addon dir> (a staged build/addon). It
# records, with time.monotonic() (the driver's clock too):
#   updates  every Live update that changed the mesh: start, main-thread ms, iterations, read and write ms
#            (LiveSession.update, or step on versions that solved on the main thread)
#   draws    every viewport redraw: time, the Empty's x, Live settled or not
#   moves    every depsgraph update that moved the Empty (G applies each pointer event there): time, x
# and talks to the driver through <out>/state.json and cmd_* files, as gui_session.py does.
import json
import os
import sys
import time
import traceback

import bpy
from mathutils import Matrix

OUT, ADDON_DIR, VERTICES = sys.argv[sys.argv.index("--") + 1:][:3]
HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)   # tube_scene, bench_addon
import bench_addon as U  # noqa: E402
sys.path.insert(0, U.BLENDER_GUI_TESTS)   # session_files
import session_files  # noqa: E402
from tube_scene import add_group, make_tube  # noqa: E402

STATE = {"ready": False, "errors": [], "tick": 0}
RECORD = {"updates": [], "draws": [], "moves": []}


def instrument(live):
    """Time each Live update on the main thread (the method the modal operator calls)."""
    cls = live.LiveSession
    name = "update" if hasattr(cls, "update") else "step"
    original = getattr(cls, name)

    def timed(self, *args, **kwargs):
        t = time.monotonic()
        stats = original(self, *args, **kwargs)
        if stats is not None:
            RECORD["updates"].append([t, (time.monotonic() - t) * 1e3, stats.iterations, stats.read_ms,
                                      stats.write_ms])
        return stats

    setattr(cls, name, timed)
    STATE["update_method"] = name


def setup():
    U.load_addon(ADDON_DIR)
    api, live = U.addon("api", "live")
    instrument(live)
    U.clear_scene()
    obj, fixed, top, h = make_tube("Tube", int(VERTICES))
    add_group(obj, "fixed", fixed)
    add_group(obj, "top", top)
    empty = U.add_empty("Handle", Matrix.Translation((0.0, 0.0, h)))
    empty.empty_display_type = 'SPHERE'
    empty.empty_display_size = 0.4
    bpy.context.view_layer.update()
    api.set_fixed(obj, "fixed")
    api.add_handle(obj, "top", empty)
    win, area, region = session_files.view3d()
    view = area.spaces.active.region_3d
    view.view_location = (0.0, 0.0, 0.5 * h)
    view.view_distance = 2.2 * h
    view.view_rotation = (0.7071, 0.7071, 0.0, 0.0)   # looking along +y: x right, z up
    bpy.types.SpaceView3D.draw_handler_add(on_draw, (), 'WINDOW', 'POST_PIXEL')
    bpy.app.handlers.depsgraph_update_post.append(on_depsgraph_update)
    STATE["vertices"] = len(obj.data.vertices)
    STATE["addon"] = os.path.dirname(U.addon().__file__)
    STATE["ready"] = True


def session():
    return U.addon("sessions").any_session()


def on_draw():
    empty = bpy.data.objects.get("Handle")
    if empty is None or not STATE["ready"]:
        return
    s = session()
    RECORD["draws"].append([time.monotonic(), empty.matrix_world.translation.x,
                            bool(s is not None and s.settled)])


def on_depsgraph_update(_scene, _depsgraph=None):
    empty = bpy.data.objects.get("Handle")
    if empty is None or not STATE["ready"]:
        return
    x = empty.matrix_world.translation.x
    if not RECORD["moves"] or RECORD["moves"][-1][1] != x:
        RECORD["moves"].append([time.monotonic(), x])


def start_live():
    win, area, region = session_files.view3d()
    obj = bpy.data.objects["Tube"]
    bpy.context.view_layer.objects.active = obj
    with bpy.context.temp_override(window=win, area=area, region=region, active_object=obj, object=obj):
        STATE["live_invoke"] = list(bpy.ops.object.arap_live('INVOKE_DEFAULT'))
    empty = bpy.data.objects["Handle"]
    for ob in bpy.context.view_layer.objects:
        ob.select_set(False)
    empty.select_set(True)
    bpy.context.view_layer.objects.active = empty


def write_state():
    if STATE["ready"]:
        s = session()
        STATE["live_running"] = s is not None
        STATE["settled"] = bool(s is not None and s.settled)
        STATE["empty_x"] = bpy.data.objects["Handle"].matrix_world.translation.x
        win, area, region = session_files.view3d()
        STATE["viewport_centre"] = session_files.viewport_centre(win, region)
        STATE["now"] = time.monotonic()
    session_files.write_state(OUT, STATE)


def take(cmd):
    return session_files.take(OUT, cmd)


def tick():
    try:
        if not STATE["ready"]:
            setup()
        if take("cmd_live"):
            start_live()
        if take("cmd_dump"):
            with open(os.path.join(OUT, "record.json"), "w") as f:
                json.dump(RECORD, f)
        if take("cmd_quit"):
            bpy.ops.wm.quit_blender()
            return None
        write_state()
    except Exception:  # noqa: BLE001 - reported to the driver through state.json
        STATE["errors"].append(traceback.format_exc())
        write_state()
    return 0.1


bpy.app.timers.register(tick, first_interval=1.0)
