# SPDX-License-Identifier: GPL-3.0-or-later
"""The set-up operators: the fixed group and handles from the selected
vertices, and the handle list's add and remove buttons. Deform, Reset to Rest
and Set Rest Pose are in deform_ops.py, Live in live_ops.py, the bake in
bake_ops.py."""

import bmesh
import bpy
import numpy as np
from bpy.props import StringProperty
from mathutils import Matrix, Vector

from .. import api
from ..solver import sessions


def _mesh_object(context):
    obj = context.active_object
    return obj if obj is not None and obj.type == 'MESH' else None


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


classes = (
    ARAP_OT_add_handle_from_selection,
    ARAP_OT_set_fixed_from_selection,
    ARAP_OT_handle_add,
    ARAP_OT_handle_remove,
)

register, unregister = bpy.utils.register_classes_factory(classes)
