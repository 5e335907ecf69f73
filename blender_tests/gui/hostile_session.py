# Blender side of hostile_ui.py, run in Blender's UI (its event loop drives the modal operators, the Auto
# mode's timer and the worker's previews): a user who deletes the object a modal Deform solves and disables
# the add-on while Auto, Deform or a bake runs. Each step is a timer; every check prints "CHECK ok: ..." or
# "CHECK FAILED: ..."; the last line is "HOSTILE DONE". The driver fails on any failed check or traceback.
import os
import sys
import time
import traceback

import bpy
from mathutils import Matrix

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import arap_test_utils as U  # noqa: E402

STEP_S = 0.5
GIVE_UP_S = 120.0


def check(ok, what):
    print("CHECK %s: %s" % ("ok" if ok else "FAILED", what), flush=True)


def until(condition, timeout=GIVE_UP_S):
    """Steps until `condition()` holds (True) or `timeout` seconds pass (False): a loaded machine is slow."""
    end = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > end:
            return False
        yield STEP_S / 5
    return True


def view3d_override():
    win = bpy.context.window_manager.windows[0]
    area = next(a for a in win.screen.areas if a.type == 'VIEW_3D')
    region = next(r for r in area.regions if r.type == 'WINDOW')
    return dict(window=win, area=area, region=region)


def invoke(operator, **kwargs):
    with bpy.context.temp_override(**view3d_override()):
        return operator('INVOKE_DEFAULT', **kwargs)


def slow_bar(name, cuts=60):
    """A bar whose solve runs until it is stopped (the textbook method, tolerance 0), its Empty moved."""
    obj, empty, _fixed, top = U.bar_with_handle(vertices=48, cuts=cuts)
    obj.name, empty.name = name, name + "Empty"
    obj.arap.method, obj.arap.tolerance, obj.arap.max_iterations = 'LOCAL_GLOBAL', 0.0, 100000
    bpy.context.view_layer.objects.active = obj
    empty.location.x += 0.6
    bpy.context.view_layer.update()
    return obj, empty, top


def centroid(obj, indices):
    return U.coords(obj)[indices].mean(axis=0)


def auto_follows(obj, empty, top, rest_top, when):
    """Steps: with a settling method, Auto (in the add-on loaded now) follows one more move of the Empty to a
    settled pose whose top moved as far as the Empty (it started at x = 0); then Auto off."""
    auto = U.addon("auto")
    obj.arap.method, obj.arap.tolerance = 'QUASI_NEWTON', 1e-5
    auto.forget(obj)   # bind again with the settings just changed
    empty.location.x += 0.2
    bpy.context.view_layer.update()
    end = time.monotonic() + GIVE_UP_S
    while not auto.status(obj).startswith("settled") and time.monotonic() < end:
        yield STEP_S
    moved = centroid(obj, top) - rest_top
    check(auto.status(obj).startswith("settled") and obj.arap.auto,
          "%s: Auto settles (%r; auto %s, %r)" % (when, auto.status(obj), obj.arap.auto, obj.arap.auto_status))
    check(abs(moved[0] - empty.location.x) < 1e-3, "%s: the mesh follows its Empty (top moved by %.4f, the Empty "
          "by %.4f)" % (when, moved[0], empty.location.x))
    obj.arap.auto = False


def steps():
    """The scenario, one yield per step; a yielded number is the seconds to wait before the next."""
    U.clear_scene()
    deform_ops = U.addon("deform_ops")

    # 1. The object a modal Deform solves is deleted: the modal ends with a message, its lines and its worker
    #    go, no traceback.
    obj, empty, _top = slow_bar("Doomed", cuts=150)
    check(invoke(bpy.ops.object.arap_deform) == {'RUNNING_MODAL'}, "Deform runs modal")
    job = deform_ops.ARAP_OT_deform.running
    solving = yield from until(lambda: job.binding is None and (job.progress[0] > 0 or job.worker is None))
    check(solving and job.worker is not None, "Deform's worker solves (%s)" % (job.progress,))
    mesh = obj.data
    bpy.data.objects.remove(obj)
    check((yield from until(lambda: deform_ops.ARAP_OT_deform.running is None)),
          "the modal ended after the object was deleted")
    check(deform_ops.deform_status_lines() == [], "its lines left the viewport")
    check(job.worker is None and not job.solver.busy, "its worker stopped")
    bpy.data.meshes.remove(mesh)
    bpy.data.objects.remove(empty)

    # 2. The add-on disabled while Auto's worker solves, then enabled again: nothing of Auto keeps running
    #    while it is off, and once on again the mesh follows its Empty.
    auto = U.addon("auto")
    obj, empty, top = slow_bar("Auto")
    rest_top = U.coords(obj)[top].mean(axis=0)   # the Empty starts at x = 0
    obj.arap.auto = True
    empty.location.x += 0.1
    bpy.context.view_layer.update()
    solving = yield from until(lambda: obj.as_pointer() in auto._posers and auto._timer_on)
    poser = auto._posers.get(obj.as_pointer())
    check(solving, "Auto is solving on the worker (%s)" % auto.status(obj))
    U.disable_addon()
    yield 1.0
    check(poser.worker is None, "disabled: Auto's worker stopped")
    check(not bpy.app.timers.is_registered(auto._continue), "disabled: Auto's timer is gone")
    check(U.enable_addon() is not None, "enabled again")
    yield from auto_follows(obj, empty, top, rest_top, "enabled again")
    U.clear_scene()

    # 3. Disabled while a modal Deform solves: its solve stops, the mesh is untouched; enabled again, Deform
    #    works.
    obj, empty, _top = slow_bar("Deformed", cuts=150)
    rest = U.raw_coords(obj).copy()
    check(invoke(bpy.ops.object.arap_deform) == {'RUNNING_MODAL'}, "Deform runs modal")
    job = U.addon("deform_ops").ARAP_OT_deform.running
    solving = yield from until(lambda: job.binding is None and (job.progress[0] > 0 or job.worker is None))
    check(solving and job.worker is not None, "Deform's worker solves (%s)" % (job.progress,))
    U.disable_addon()
    yield 1.0
    check(job.worker is None and not job.solver.busy, "disabled: Deform's worker stopped")
    check((U.raw_coords(obj) == rest).all(), "disabled: the mesh is untouched")
    check(U.enable_addon() is not None, "enabled again")
    obj.arap.method, obj.arap.tolerance, obj.arap.max_iterations = 'QUASI_NEWTON', 1e-4, 1000
    check(bpy.ops.object.arap_deform() == {'FINISHED'}, "Deform works again")
    check(abs(U.raw_coords(obj) - rest).max() > 0.3, "and poses the mesh")
    U.clear_scene()

    # 4. Disabled during an interactive bake: cancelled, nothing changed, no progress left in the status bar.
    obj, empty, _top = slow_bar("Baked", cuts=30)
    obj.arap.method, obj.arap.tolerance = 'QUASI_NEWTON', 1e-5
    for f, x in ((1, 0.0), (40, 0.8)):
        empty.location.x = x
        empty.keyframe_insert("location", frame=f)
    rest = U.raw_coords(obj).copy()
    check(invoke(bpy.ops.object.arap_bake, frame_start=1, frame_end=40) == {'RUNNING_MODAL'}, "the bake runs modal")
    yield 0.5
    bake_ops = U.addon("bake_ops")
    check(bake_ops.InteractiveBake.current is not None, "the bake is under way")
    U.disable_addon()
    yield 1.0
    check(bake_ops.InteractiveBake.current is None, "disabled: the bake was cancelled")
    check(obj.data.shape_keys is None and (U.raw_coords(obj) == rest).all(), "disabled: nothing was changed")
    check(U.enable_addon() is not None, "enabled again")
    yield 0.5
    U.clear_scene()

    # 5. Disabled during Live: cancelled (the mesh and the Empty back), Live's timer gone; enabled again, Live
    #    starts.
    obj, empty, _top = slow_bar("Live", cuts=30)
    obj.arap.method, obj.arap.tolerance = 'QUASI_NEWTON', 1e-5
    empty.location.x = 0.0
    bpy.context.view_layer.update()
    rest = U.raw_coords(obj).copy()
    check(invoke(bpy.ops.object.arap_live) == {'RUNNING_MODAL'}, "Live runs")
    empty.location.x = 0.5
    check((yield from until(lambda: abs(U.raw_coords(obj) - rest).max() > 0.3)), "Live poses the mesh")
    timers = U.addon("modal_timers")
    U.disable_addon()
    yield 0.5
    check((U.raw_coords(obj) == rest).all() and empty.location.x == 0.0, "disabled: Live cancelled, all restored")
    check(not timers._timers, "disabled: no modal's timer is left")
    check(U.enable_addon() is not None, "enabled again")
    check(invoke(bpy.ops.object.arap_live) == {'RUNNING_MODAL'}, "Live runs again")
    empty.location.x = 0.5
    check((yield from until(lambda: abs(U.raw_coords(obj) - rest).max() > 0.3)), "and poses the mesh")
    with bpy.context.temp_override(**view3d_override()):
        bpy.ops.object.arap_live_cancel()
    check((yield from until(lambda: (U.raw_coords(obj) == rest).all())), "Live cancelled from the panel's button")
    U.clear_scene()

    # 6. Reload Scripts (F3) while Auto's worker solves: Auto goes on in the reloaded add-on.
    obj, empty, top = slow_bar("Reloaded")
    rest_top = U.coords(obj)[top].mean(axis=0)
    obj.arap.auto = True
    empty.location.x += 0.1
    bpy.context.view_layer.update()
    yield 0.5
    before = U.addon("auto")
    with bpy.context.temp_override(**view3d_override()):
        bpy.ops.script.reload()
    # Blender reloads from its event loop, after the operator returns: wait for the new module.
    check((yield from until(lambda: U.addon("auto") is not before)), "the add-on was reloaded")
    yield from auto_follows(obj, empty, top, rest_top, "after Reload Scripts")


def main():
    check(U.enable_addon() is not None, "the add-on is enabled")
    scenario = steps()

    def tick():
        try:
            return next(scenario)
        except StopIteration:
            print("HOSTILE DONE", flush=True)
        except Exception:  # noqa: BLE001 - a broken step ends the session (the driver sees the traceback)
            traceback.print_exc()
        bpy.ops.wm.quit_blender()
        return None

    bpy.app.timers.register(tick, first_interval=1.0)


main()
