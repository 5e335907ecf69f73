# SPDX-License-Identifier: GPL-3.0-or-later
"""Thin operators: gather from bpy, call engine/api, report."""

import bmesh
import bpy
import numpy as np
from bpy.props import EnumProperty, FloatProperty, IntProperty, StringProperty
from mathutils import Matrix, Vector

from . import api, errors, live, properties, sessions


def _mesh_object(context):
    obj = context.active_object
    return obj if obj is not None and obj.type == 'MESH' else None


def _report_error(op, exc):
    """Report errors a user can act on and return {'CANCELLED'}; re-raise bugs."""
    msg = errors.user_error(exc)
    if msg is None:
        raise exc
    op.report({'ERROR'}, msg)
    return {'CANCELLED'}


def _redraw_live(context):
    """The viewport redraws on input; Live changes the mesh (and its status) between inputs."""
    screen = context.window.screen if context.window is not None else None
    for area in (screen.areas if screen is not None else ()):
        if area.type in {'VIEW_3D', 'STATUSBAR'}:
            area.tag_redraw()


def live_status_text():
    """What the status bar shows while Live runs ('' when it does not)."""
    session = sessions.any_session()
    if session is None or not session.active:
        return ""
    last = session.last
    text = "ARAP Live on '%s': %s" % (session.names[0], "settled" if session.settled else "settling")
    if last is not None:
        text += ", %.1f ms/update (%d iterations), energy %.5g" % (last.total_ms, last.iterations, last.energy)
    return text + " | Enter: apply, Esc: cancel"


def _draw_live_status(self, _context):
    # In the status bar, beside Blender's own hints: a G/R/S keeps its Dx/Dy/angle
    # read-out in the viewport header, which Live never writes.
    text = live_status_text()
    if text:
        self.layout.label(text=text, icon='PLAY')


_status_shown = False


def _live_status(on):
    """Show the Live status in the status bar (on), or stop when no session is left."""
    global _status_shown
    if on and not _status_shown:
        bpy.types.STATUSBAR_HT_header.append(_draw_live_status)
        _status_shown = True
    elif not on and _status_shown and sessions.any_session() is None:
        bpy.types.STATUSBAR_HT_header.remove(_draw_live_status)
        _status_shown = False


def live_status_off():
    """Take the Live status out of the status bar (the add-on is disabled)."""
    global _status_shown
    if _status_shown:
        bpy.types.STATUSBAR_HT_header.remove(_draw_live_status)
        _status_shown = False


def _selected_vertices(obj):
    """Indices and local centroid of the selected vertices, in Edit Mode (the
    edit mesh) or Object Mode (the selection stored in the mesh)."""
    if obj.mode == 'EDIT':
        bm = bmesh.from_edit_mesh(obj.data)
        sel = [v for v in bm.verts if v.select]
        if not sel:
            return [], None
        return [v.index for v in sel], sum((v.co for v in sel), Vector()) / len(sel)
    verts = obj.data.vertices
    flags = np.empty(len(verts), bool)
    verts.foreach_get("select", flags)
    indices = np.flatnonzero(flags)
    if len(indices) == 0:
        return [], None
    co = np.empty(len(verts) * 3, np.float32)
    verts.foreach_get("co", co)
    return indices.tolist(), Vector(co.reshape(-1, 3)[indices].mean(axis=0))


def _assign(obj, group, indices, replace):
    """Give `indices` weight 1 in `group` (and with `replace`, only them)."""
    if obj.mode != 'EDIT':
        if replace:
            group.remove(range(len(obj.data.vertices)))
        group.add(indices, 1.0, 'REPLACE')
        return
    # In Edit Mode the edit mesh owns the weights: write its deform layer.
    bm = bmesh.from_edit_mesh(obj.data)
    layer = bm.verts.layers.deform.verify()
    wanted = set(indices)
    bm.verts.ensure_lookup_table()
    for v in bm.verts:
        weights = v[layer]
        if v.index in wanted:
            weights[group.index] = 1.0
        elif replace and group.index in weights:
            del weights[group.index]
    bmesh.update_edit_mesh(obj.data)


def _record_settings_in_undo(obj):
    """Make the undo step of a set-up operator run in Edit Mode restore the object's
    ARAP settings too, as it does in Object Mode.

    In Edit Mode the operator's undo step is an edit-mesh step: it restores the mesh
    (its weights; its group names in Blender 5.2, not in 3.4 or 4.3) and nothing of the
    object (obj.arap, new Empties). Those are in Blender's global undo steps only, and
    Blender writes one beside an edit-mesh step only when a data-block was added or
    removed since the last (undo_system.cc: "MemFile Internal (pre)", hidden from Undo
    History). Without it the settings changed here are in no undo step, and the next
    undo that loads an older global step drops them: Set Fixed, select, Add Handle,
    Ctrl+Z lost the Fixed setting (the new Empty had made Blender write a global step).
    Adding and removing a scratch data-block asks for that global step; written after
    this operator, it holds the settings and the Empties. (Leaving Edit Mode for the
    work and going back does not: the step is still an edit-mesh step.)
    """
    if obj.mode == 'EDIT':
        bpy.data.texts.remove(bpy.data.texts.new(".arap_undo"))


FIXED_GROUP = "ARAP_Fixed"
HANDLE_GROUP = "ARAP_Handle_"


def _fixed_group(obj):
    """The group Set Fixed writes: the one the settings name, else the ARAP_Fixed group
    made before (also when the settings lost it), else a new ARAP_Fixed."""
    for name in (obj.arap.fixed_group, FIXED_GROUP):
        group = obj.vertex_groups.get(name) if name else None
        if group is not None:
            return group
    return obj.vertex_groups.new(name=FIXED_GROUP)


def _new_handle_group_name(obj):
    """ARAP_Handle_<n>, n one more than the highest number a vertex group, a handle or a
    handle Empty (<object>_ARAP_Handle_<n>) of `obj` uses: a removed handle's number is
    not given again while its group or Empty is kept."""
    prefix = obj.name + "_"
    names = [g.name for g in obj.vertex_groups] + [h.group for h in obj.arap.handles]
    names += [o.name[len(prefix):] for o in bpy.data.objects if o.name.startswith(prefix)]
    numbers = [int(n[len(HANDLE_GROUP):]) for n in names
               if n.startswith(HANDLE_GROUP) and n[len(HANDLE_GROUP):].isdigit()]
    return HANDLE_GROUP + str(max(numbers, default=0) + 1)


NOTHING_SELECTED = "No vertex is selected: select some in Edit Mode (Tab), then press the button again"


class ARAP_OT_add_handle_from_selection(bpy.types.Operator):
    """Make the selected vertices a new handle: a vertex group and an Empty at their centroid"""
    bl_idname = "object.arap_add_handle_from_selection"
    bl_label = "Add Handle from Selection"
    bl_options = {'REGISTER', 'UNDO'}

    group_name: StringProperty(name="Group Name", default="",
                               description="Name of the new vertex group (made unique); empty: ARAP_Handle_1, "
                                           "ARAP_Handle_2, ... (the next number on this object)")

    @classmethod
    def poll(cls, context):
        return _mesh_object(context) is not None

    def execute(self, context):
        obj = _mesh_object(context)
        indices, centroid = _selected_vertices(obj)
        if not indices:
            self.report({'ERROR'}, NOTHING_SELECTED)
            return {'CANCELLED'}
        group = obj.vertex_groups.new(name=self.group_name or _new_handle_group_name(obj))
        _assign(obj, group, indices, replace=False)
        # Named after its object and group: Bar_ARAP_Handle_1 drives group ARAP_Handle_1 of Bar.
        empty = bpy.data.objects.new("%s_%s" % (obj.name, group.name), None)
        empty.empty_display_type = 'SPHERE'
        empty.empty_display_size = max(0.05, 0.1 * max(obj.dimensions))
        collection = obj.users_collection[0] if obj.users_collection else context.scene.collection
        collection.objects.link(empty)
        # Set matrix_world (not location) so it is valid before the next depsgraph update.
        empty.matrix_world = Matrix.Translation(obj.matrix_world @ centroid)
        api.add_handle(obj, group.name, empty)
        _record_settings_in_undo(obj)
        self.report({'INFO'}, "Handle '%s': %d vertices, empty '%s'" % (group.name, len(indices), empty.name))
        return {'FINISHED'}


class ARAP_OT_set_fixed_from_selection(bpy.types.Operator):
    """Make the selected vertices the fixed (anchor) group: they stay at rest"""
    bl_idname = "object.arap_set_fixed_from_selection"
    bl_label = "Set Fixed from Selection"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        return _mesh_object(context) is not None

    def execute(self, context):
        obj = _mesh_object(context)
        indices, _centroid = _selected_vertices(obj)
        if not indices:
            self.report({'ERROR'}, NOTHING_SELECTED)
            return {'CANCELLED'}
        group = _fixed_group(obj)
        _assign(obj, group, indices, replace=True)
        obj.arap.fixed_group = group.name
        _record_settings_in_undo(obj)
        self.report({'INFO'}, "Fixed group '%s': %d vertices" % (group.name, len(indices)))
        return {'FINISHED'}


class ARAP_OT_handle_add(bpy.types.Operator):
    """Add an empty handle slot: pick its vertex group and Empty in the list"""
    bl_idname = "object.arap_handle_add"
    bl_label = "Add Handle"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        return sessions.target_mesh(context) is not None

    def execute(self, context):
        obj = sessions.target_mesh(context)
        obj.arap.handles.add()
        obj.arap.active_handle = len(obj.arap.handles) - 1
        _record_settings_in_undo(obj)
        return {'FINISHED'}


class ARAP_OT_handle_remove(bpy.types.Operator):
    """Remove the active handle (its vertex group and Empty are kept)"""
    bl_idname = "object.arap_handle_remove"
    bl_label = "Remove Handle"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        obj = sessions.target_mesh(context)
        return obj is not None and len(obj.arap.handles) > 0

    def execute(self, context):
        obj = sessions.target_mesh(context)
        api.remove_handle(obj, min(obj.arap.active_handle, len(obj.arap.handles) - 1))
        _record_settings_in_undo(obj)
        return {'FINISHED'}


class ARAP_OT_deform(bpy.types.Operator):
    """Pose the mesh: move the handles' vertices with their empties and solve ARAP (Object Mode)"""
    bl_idname = "object.arap_deform"
    bl_label = "ARAP Deform"
    bl_options = {'REGISTER', 'UNDO'}

    # The redo panel (F9) shows the values the solve used: execute() fills
    # any not given from the object's settings (properties.py has the tooltips).
    iterations: IntProperty(name="Iterations", default=100, min=1, max=1000,
                            description="Most solver rounds; it stops earlier once the pose has settled")
    tolerance: FloatProperty(name="Tolerance", default=1e-6, min=0.0, max=1.0, precision=7, step=0.0001,
                             description="Stop when a round improves the pose by less than this fraction")
    init: EnumProperty(name="Start From", items=properties.INIT_ITEMS, default='NAIVE',
                       description="The shape the solver starts from")

    def execute(self, context):
        obj = sessions.target_mesh(context)
        if obj is not None and sessions.session_for(obj) is not None:
            self.report({'ERROR'}, "Live is running on '%s': apply or cancel it first" % obj.name)
            return {'CANCELLED'}
        if obj is not None:
            for name in ("iterations", "tolerance", "init"):
                if not self.properties.is_property_set(name):
                    setattr(self, name, getattr(obj.arap, name))
        try:
            result = api.deform(obj, iterations=self.iterations, tolerance=self.tolerance, init=self.init,
                                scene=context.scene)
        except Exception as exc:  # noqa: BLE001 - _report_error re-raises what is not a user error
            return _report_error(self, exc)
        for w in result.warnings:
            self.report({'WARNING'}, w)
        self.report({'INFO'}, "ARAP: %d iterations, energy %.6g, %.1f ms (bind %.1f ms)"
                    % (result.iterations, result.energy, result.solve_ms, result.bind_ms))
        return {'FINISHED'}


class _ApplyToActiveObject:
    """Mixin: execute() runs `action` (an api function) on the panel's mesh and reports its errors."""
    action = None

    def execute(self, context):
        try:
            type(self).action(sessions.target_mesh(context))
        except Exception as exc:  # noqa: BLE001 - _report_error re-raises what is not a user error
            return _report_error(self, exc)
        return {'FINISHED'}


class ARAP_OT_reset(_ApplyToActiveObject, bpy.types.Operator):
    """Put the mesh back to its rest shape and take the empties' current poses as their bind poses"""
    bl_idname = "object.arap_reset"
    bl_label = "Reset to Rest"
    bl_options = {'REGISTER', 'UNDO'}
    action = staticmethod(api.reset)


class ARAP_OT_set_rest_pose(_ApplyToActiveObject, bpy.types.Operator):
    """Take the current shape as the rest shape and the empties' current poses as bind poses"""
    bl_idname = "object.arap_set_rest_pose"
    bl_label = "Set Rest Pose"
    bl_options = {'REGISTER', 'UNDO'}
    action = staticmethod(api.set_rest_pose)


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

    def invoke(self, context, event):
        obj = sessions.target_mesh(context)
        if obj is not None and sessions.session_for(obj) is not None:
            self.report({'ERROR'}, "Live is already running on '%s'" % obj.name)
            return {'CANCELLED'}
        try:
            if obj is None or obj.type != 'MESH':
                raise errors.SetupError("ARAP works on a mesh object: select one and make it active")
            self._session = live.LiveSession(obj, context.scene)
            self._session.step()
        except Exception as exc:  # noqa: BLE001
            if self._session is not None:
                self._session.cancel()
            return _report_error(self, exc)
        for w in self._session.warnings:
            self.report({'WARNING'}, w)
        wm = context.window_manager
        self._timer = wm.event_timer_add(obj.arap.live_interval, window=context.window)
        wm.modal_handler_add(self)
        _live_status(True)
        return {'RUNNING_MODAL'}

    def execute(self, context):
        # Scripts without an event loop: use api.start_session() instead.
        self.report({'ERROR'}, "ARAP Live is interactive; from scripts use arap_deform.api.start_session()")
        return {'CANCELLED'}

    def modal(self, context, event):
        try:
            return self._modal(context, event)
        except Exception as exc:  # noqa: BLE001 - never leave a half-running session behind
            if self._session.active:
                self._end(context, apply=False)
            return _report_error(self, exc)

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
                if session.step(force=False) is not None:
                    self._warn_collapsed(session)
                    _redraw_live(context)
            except errors.SessionError as exc:
                return self._end(context, apply=False, error=exc)
        return {'PASS_THROUGH'}

    def _warn_collapsed(self, session):
        if session.collapsed != self._collapsed:
            self._collapsed = session.collapsed
            if session.collapsed:
                self.report({'WARNING'}, "The Empty of handle %s is scaled to almost nothing: its vertices collapse "
                            "to a point" % ", ".join("'%s'" % n for n in session.collapsed))

    def cancel(self, context):
        # Blender calls this when the modal is aborted (file load, window closed).
        _end_requests.pop(self._session, None)
        if self._session is not None and self._session.active:
            self._cleanup(context)
            self._session.cancel()
        _live_status(False)

    def _cleanup(self, context):
        if self._timer is not None:
            context.window_manager.event_timer_remove(self._timer)
            self._timer = None

    def _end(self, context, apply, error=None):
        _end_requests.pop(self._session, None)
        try:
            return self._end_session(context, apply, error)
        finally:
            _live_status(False)
            _redraw_live(context)

    def _end_session(self, context, apply, error):
        self._cleanup(context)
        session = self._session
        if apply:
            session.finish()
            self.report({'INFO'}, "ARAP Live applied")
            return {'FINISHED'}
        if error is not None and error.kind == 'TOPOLOGY':
            session.active = False
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
        return {'CANCELLED'}


def _live_session(context):
    """The Live session of the active mesh, else the running one (an empty may be active)."""
    obj = _mesh_object(context)
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


classes = (
    ARAP_OT_add_handle_from_selection,
    ARAP_OT_set_fixed_from_selection,
    ARAP_OT_handle_add,
    ARAP_OT_handle_remove,
    ARAP_OT_deform,
    ARAP_OT_reset,
    ARAP_OT_set_rest_pose,
    ARAP_OT_live,
    ARAP_OT_live_apply,
    ARAP_OT_live_cancel,
)

register, unregister = bpy.utils.register_classes_factory(classes)
