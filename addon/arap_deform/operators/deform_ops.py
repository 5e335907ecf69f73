# SPDX-License-Identifier: GPL-3.0-or-later
"""Deform and the shape it starts from: the Deform operator (one solve from the
rest shape, deform_job.DeformJob), Reset to Rest and Set Rest Pose.

Deform, from a script or the redo panel, solves in execute(). From the panel,
a key or F3 it is modal: the solve runs on the worker's thread, the viewport
shows its progress, the view can still be orbited and zoomed, and Esc stops
it with the mesh untouched (the result is written only once the solve is
done, as one undo step).
"""

import bpy

from .. import errors
from ..persistence import solver_settings
from ..persistence.older_settings import setting
from ..solver import deform_job, sessions
from ..ui import modal_timers, status_overlay

# Input that still reaches the viewport while Deform runs (looking around); the rest waits.
NAVIGATION = {'MIDDLEMOUSE', 'WHEELUPMOUSE', 'WHEELDOWNMOUSE', 'MOUSEMOVE', 'INBETWEEN_MOUSEMOVE',
              'TRACKPADPAN', 'TRACKPADZOOM', 'MOUSEROTATE', 'NDOF_MOTION'}
POLL_S = 1.0 / 30.0   # how often the modal looks at the worker


class ARAP_OT_deform(bpy.types.Operator):
    """Pose the mesh: move the handles' vertices with their empties and solve ARAP (Object Mode)"""
    bl_idname = "object.arap_deform"
    bl_label = "ARAP Deform"
    bl_options = {'REGISTER', 'UNDO'}

    # The redo panel (F9) shows the values the solve used: _start_job() fills any not given from the
    # object's settings; defaults and limits are the settings' (solver_settings.py, from the option table).
    max_iterations: solver_settings.option_int(
        "max_iterations", name="Max Iterations", **solver_settings.ITERATIONS_RANGE,
        description="Most iterations; it stops earlier once the pose has settled")
    tolerance: solver_settings.option_float(
        "tolerance", name="Tolerance", **solver_settings.TOLERANCE_STYLE,
        description="Stop when an iteration improves the pose by less than this fraction")
    init: solver_settings.option_enum(
        "init", solver_settings.INIT_ITEMS, solver_settings.INIT_NAMES, name="Start From",
        description="The shape the solver starts from")

    running = None   # the modal Deform's job while it runs (what the viewport's lines show)

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._job = None
        self._shown = None

    def _start_job(self, context, bind_on_thread=False):
        obj = sessions.target_mesh(context)
        if obj is not None and sessions.session_for(obj) is not None:
            raise errors.SetupError("Live is running on '%s': apply or cancel it first" % obj.name)
        source = 'SETTINGS'
        if obj is not None:
            for name in ("max_iterations", "tolerance", "init"):
                if not self.properties.is_property_set(name):
                    setattr(self, name, setting(obj.arap, name))
            # A cap other than the object's setting was set in the redo panel (or by the caller).
            if self.max_iterations != setting(obj.arap, "max_iterations"):
                source = 'OPERATOR'
        return deform_job.DeformJob(obj, context.scene, self.max_iterations, self.tolerance, self.init,
                                    iterations_from=source, bind_on_thread=bind_on_thread)

    def _report_result(self, result):
        for w in result.warnings:
            self.report({'WARNING'}, w)
        for note in result.notes:
            self.report({'INFO'}, note)
        self.report({'INFO'}, "ARAP: %d iterations, energy %.6g, %.1f ms (bind %.1f ms)"
                    % (result.iterations, result.energy, result.solve_ms, result.bind_ms))

    def execute(self, context):
        try:
            result = self._start_job(context).run()
        except Exception as exc:  # noqa: BLE001 - report_error re-raises what is not a user error
            return errors.report_error(self, exc)
        self._report_result(result)
        return {'FINISHED'}

    def invoke(self, context, event):
        if bpy.app.background or context.window is None:
            return self.execute(context)
        try:
            self._job = self._start_job(context, bind_on_thread=True)
            self._job.start()
        except Exception as exc:  # noqa: BLE001
            if self._job is not None:
                self._job.stop()
            return errors.report_error(self, exc)
        ARAP_OT_deform.running = self._job
        status_overlay.add(deform_status_lines)
        modal_timers.add(self.bl_idname, context, POLL_S)
        context.window_manager.modal_handler_add(self)
        status_overlay.redraw(context)
        return {'RUNNING_MODAL'}

    def modal(self, context, event):
        job = self._job
        if event.type == 'ESC' and event.value == 'PRESS':
            self._end(context)
            self.report({'INFO'}, "ARAP Deform stopped: '%s' is unchanged" % job.name)
            return {'CANCELLED'}
        if event.type == 'TIMER':
            try:
                result = job.poll()
            except Exception as exc:  # noqa: BLE001
                self._end(context)
                return errors.report_error(self, exc)
            if result is not None:
                self._end(context)
                self._report_result(result)
                return {'FINISHED'}
            shown = deform_status_lines()
            if shown != self._shown:
                self._shown = shown
                status_overlay.redraw(context)
            return {'RUNNING_MODAL'}
        return {'PASS_THROUGH'} if event.type in NAVIGATION else {'RUNNING_MODAL'}

    def cancel(self, context):
        # Blender calls this when the modal is aborted (file load, window closed).
        self._end(context)

    def _end(self, context):
        if self._job is not None:
            self._job.stop()
        _forget_running()
        status_overlay.redraw(context)


def _forget_running():
    modal_timers.remove(ARAP_OT_deform.bl_idname)
    ARAP_OT_deform.running = None
    status_overlay.remove(deform_status_lines)


def stop_running():
    """The add-on is disabled while a modal Deform runs: stop its solve (the mesh stays as it was) and remove
    its timer and lines, which would outlive the operator."""
    if ARAP_OT_deform.running is not None:
        ARAP_OT_deform.running.stop()
    _forget_running()


def deform_status_lines():
    """What the viewport shows while a modal Deform runs."""
    job = ARAP_OT_deform.running
    if job is None:
        return []
    if job.binding is not None:
        head = "ARAP Deform on '%s': binding (%d vertices)" % (job.name, len(job.problem.rest64))
    else:
        iterations, energy = job.progress
        head = "ARAP Deform on '%s': %d of at most %d iterations, energy %.5g" % (
            job.name, iterations, job.max_iterations, energy)
        timing = job.time_left()
        if timing is not None:
            head += "; %s so far, at most %s more" % (_duration(timing[0]), _duration(timing[1]))
    lines = [head]
    if job.problem.has_contact:
        lines.append("Self Contact is on: each iteration checks the surface for crossings (slower)")
    return lines + ["Esc: stop (the mesh stays as it was)"]


def _duration(seconds):
    return "%.0f s" % seconds if seconds < 120 else "%.0f min" % (seconds / 60)


class _ApplyToActiveObject:
    """Mixin: execute() runs `action` (a deform_job function) on the panel's mesh and reports its errors."""
    action = None

    def execute(self, context):
        try:
            type(self).action(sessions.target_mesh(context))
        except Exception as exc:  # noqa: BLE001 - report_error re-raises what is not a user error
            return errors.report_error(self, exc)
        return {'FINISHED'}


class ARAP_OT_reset(_ApplyToActiveObject, bpy.types.Operator):
    """Put the mesh back to its rest shape and take the empties' current poses as their bind poses"""
    bl_idname = "object.arap_reset"
    bl_label = "Reset to Rest"
    bl_options = {'REGISTER', 'UNDO'}
    action = staticmethod(deform_job.reset)


class ARAP_OT_set_rest_pose(_ApplyToActiveObject, bpy.types.Operator):
    """Take the current shape as the rest shape and the empties' current poses as bind poses"""
    bl_idname = "object.arap_set_rest_pose"
    bl_label = "Set Rest Pose"
    bl_options = {'REGISTER', 'UNDO'}
    action = staticmethod(deform_job.set_rest_pose)


classes = (ARAP_OT_deform, ARAP_OT_reset, ARAP_OT_set_rest_pose)
register, _unregister_classes = bpy.utils.register_classes_factory(classes)


def unregister():
    stop_running()
    _unregister_classes()
