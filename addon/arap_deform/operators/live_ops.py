# SPDX-License-Identifier: GPL-3.0-or-later
"""The Live modal operator, its Apply and Cancel buttons, and what Live shows
in the viewport. The posing itself is live.LiveSession's: each timer tick
calls its update(), which hands new targets to the solve worker's thread and
shows the newest finished pose, so Blender's own input (a G/R/S on an Empty)
never waits for a solve."""

import bpy

from .. import errors
from ..solver import live, sessions
from ..ui import modal_timers, status_overlay


def live_status_lines():
    """What the viewport shows while Live runs (no lines when it does not)."""
    session = sessions.any_session()
    if session is None or not session.active:
        return []
    head = "ARAP Live on '%s': %s" % (session.names[0], live_state(session))
    last = session.last
    lines = [head]
    if last is not None:
        lines.append("%.1f ms per update, %d iterations, energy %.5g"
                     % (last.main_thread_ms, last.iterations, last.energy))
    if session.contact is not None:
        lines.append(session.contact.status())
    if session.contact_held is not None:
        lines.append(session.contact_held)
    return lines + ["Enter: apply   Esc: cancel"]


def live_state(session):
    """'binding' (on its thread, the mesh at rest), 'settling' or 'settled'."""
    if session.solver is None:
        return "binding"
    return "settled" if session.settled else "settling"


def live_status_text():
    """The Live status as one line ('' when Live does not run)."""
    return " | ".join(live_status_lines())


def _live_status(on):
    """Show Live's lines in the viewport (on), or stop when no session is left."""
    if on:
        status_overlay.add(live_status_lines)
    elif sessions.any_session() is None:
        status_overlay.remove(live_status_lines)


# What the Apply / Cancel operators (the panel's buttons, F3) asked of a running
# Live session: session -> 'APPLY' or 'CANCEL'. The Live modal operator takes
# the request at its next event (a timer tick at the latest) and ends itself.
_end_requests = {}


class ARAP_OT_live(bpy.types.Operator):
    """Pose interactively: the mesh follows its handle empties while you move them. Enter applies, Esc cancels"""
    bl_idname = "object.arap_live"
    bl_label = "ARAP Live"
    bl_options = {'REGISTER', 'UNDO'}

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._session = None
        self._timer = None
        self._collapsed = []
        self._contact = None  # the handle Self Contact stopped, last reported
        self._shown = None    # the status last drawn: redraw when it changes

    def invoke(self, context, event):
        obj = sessions.target_mesh(context)
        if obj is not None and sessions.session_for(obj) is not None:
            self.report({'ERROR'}, "Live is already running on '%s'" % obj.name)
            return {'CANCELLED'}
        try:
            if obj is None or obj.type != 'MESH':
                raise errors.SetupError("ARAP works on a mesh object: select one and make it active")
            self._session = live.LiveSession(obj, context.scene, bind_on_thread=True)
            self._session.update()
        except Exception as exc:  # noqa: BLE001
            if self._session is not None:
                self._session.cancel()
            return errors.report_error(self, exc)
        self._report_new_warnings(self._session.warnings)
        self._timer = modal_timers.add(self._session, context, obj.arap.live_interval)
        context.window_manager.modal_handler_add(self)
        _live_status(True)
        status_overlay.redraw(context)
        return {'RUNNING_MODAL'}

    def execute(self, context):
        # Scripts without an event loop: use api.start_session() instead.
        self.report({'ERROR'}, "ARAP Live is interactive; from scripts use the API's start_session()")
        return {'CANCELLED'}

    def modal(self, context, event):
        try:
            return self._modal(context, event)
        except Exception as exc:  # noqa: BLE001 - never leave a half-running session behind
            if self._session.active:
                self._end(context, apply=False)
            return errors.report_error(self, exc)

    def _modal(self, context, event):
        session = self._session
        request = _end_requests.pop(session, None)
        if request == 'APPLY' or (event.type in {'RET', 'NUMPAD_ENTER'} and event.value == 'PRESS'):
            return self._end(context, apply=True)
        # Only Esc (or the panel's Cancel) throws the pose away: right-click belongs to
        # Blender (it cancels a running G/R/S, or opens a context menu).
        if request == 'CANCEL' or (event.type == 'ESC' and event.value == 'PRESS'):
            return self._end(context, apply=False)
        if event.type == 'TIMER':
            try:
                if session.references_lost():
                    # Ctrl+Z went back one step (Blender reloaded the objects): pose the
                    # handles as that step had them and go on.
                    session.reattach(bpy.data.objects, context.scene)
                    self.report({'INFO'}, "Undo: the handles went back one step; Live goes on (Esc cancels)")
                changed = session.update() is not None
                self._report_new_warnings(session.new_warnings)
                if changed:
                    self._warn_collapsed(session)
                    self._warn_contact(session)
                shown = live_status_text()
                if changed or shown != self._shown:
                    self._shown = shown
                    status_overlay.redraw(context)
            except errors.SessionError as exc:
                return self._end(context, apply=False, error=exc)
        return {'PASS_THROUGH'}

    def _report_new_warnings(self, warnings):
        """The set-up's warnings at the start, the bind's once it is done (on its thread)."""
        for w in warnings:
            self.report({'WARNING'}, w)
        self._session.new_warnings = []

    def _warn_collapsed(self, session):
        if session.collapsed != self._collapsed:
            self._collapsed = session.collapsed
            if session.collapsed:
                self.report({'WARNING'}, "The Empty of handle %s is scaled to almost nothing: its vertices collapse "
                            "to a point" % ", ".join("'%s'" % n for n in session.collapsed))

    def _warn_contact(self, session):
        """Report a handle Self Contact stopped short, once each time another handle is the one stopped (the
        viewport's lines follow the share it made)."""
        group = session.contact.group if session.contact is not None else None
        if session.contact is not None and group != self._contact:
            self.report({'WARNING'}, session.contact.warning())
        self._contact = group

    def cancel(self, context):
        # Blender calls this when the modal is aborted (file load, window closed).
        _end_requests.pop(self._session, None)
        if self._session is not None and self._session.active:
            self._cleanup(context)
            try:
                self._session.cancel()
            except errors.SessionError as exc:   # the posed object was deleted: nothing to restore
                self.report({'ERROR'}, str(exc))
        _live_status(False)

    def _cleanup(self, context):
        if self._timer is not None:
            modal_timers.remove(self._session)
            self._timer = None

    def _end(self, context, apply, error=None):
        _end_requests.pop(self._session, None)
        try:
            return self._end_session(context, apply, error)
        finally:
            _live_status(False)
            status_overlay.redraw(context)

    def _end_session(self, context, apply, error):
        self._cleanup(context)
        try:
            return self._end_session_as_asked(context, apply, error)
        except errors.SessionError as exc:
            # The posed object was deleted, or its vertex count changed, since the last update: Live
            # stops with that message, the mesh as it is (session.cancel() says what it put back).
            sessions.stop_session(self._session)
            self.report({'ERROR'}, str(exc))
            return {'CANCELLED'}

    def _end_session_as_asked(self, context, apply, error):
        session = self._session
        name = session.names[0]
        if apply:
            session.finish()
            self.report({'INFO'}, "ARAP Live applied: '%s' keeps the pose" % name)
            return {'FINISHED'}
        if error is not None and error.kind == 'TOPOLOGY':
            sessions.stop_session(session)
            self.report({'ERROR'}, str(error) + " (the mesh was not restored)")
            return {'CANCELLED'}
        if error is not None and error.kind == 'MODE':
            # Restore in Object Mode, then go back to the mode the user picked.
            mode = session.obj.mode
            with context.temp_override(active_object=session.obj, object=session.obj):
                bpy.ops.object.mode_set(mode='OBJECT')
                session.cancel()
                bpy.ops.object.mode_set(mode=mode)
        elif error is not None and error.kind == 'OBJECT':
            sessions.stop_session(session)
        else:
            session.cancel()
        if error is not None:
            self.report({'ERROR'}, str(error) + " (mesh restored)" if error.kind != 'OBJECT' else str(error))
        else:
            self.report({'INFO'}, "ARAP Live cancelled: '%s' and its Empties are back as they were" % name)
        return {'CANCELLED'}


def _live_session(context):
    """The Live session of the panel's mesh, else the running one."""
    obj = sessions.target_mesh(context)
    session = sessions.session_for(obj) if obj is not None else None
    return session or sessions.any_session()


class ARAP_OT_live_apply(bpy.types.Operator):
    """Keep the current Live pose and stop Live (one undo step)"""
    bl_idname = "object.arap_live_apply"
    bl_label = "Apply Live"

    @classmethod
    def poll(cls, context):
        return _live_session(context) is not None

    def execute(self, context):
        _end_requests[_live_session(context)] = 'APPLY'
        return {'FINISHED'}


class ARAP_OT_live_cancel(bpy.types.Operator):
    """Stop Live and restore the mesh exactly as it was"""
    bl_idname = "object.arap_live_cancel"
    bl_label = "Cancel Live"

    @classmethod
    def poll(cls, context):
        return _live_session(context) is not None

    def execute(self, context):
        _end_requests[_live_session(context)] = 'CANCEL'
        return {'FINISHED'}


def live_status_off():
    """Take Live's lines out of the viewport (the add-on is disabled)."""
    status_overlay.remove(live_status_lines)


classes = (ARAP_OT_live, ARAP_OT_live_apply, ARAP_OT_live_cancel)
register, unregister = bpy.utils.register_classes_factory(classes)
