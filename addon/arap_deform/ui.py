# SPDX-License-Identifier: GPL-3.0-or-later
"""Sidebar panel (View3D > Sidebar > ARAP), the handle list and a menu that
puts every operator in F3 search (Object menu and Edit Mode Vertex menu)."""

import bpy

from . import engine


class ARAP_UL_handles(bpy.types.UIList):
    """Handles: vertex group and the Empty driving it."""

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index=0):
        obj = data.id_data
        row = layout.row(align=True)
        row.prop_search(item, "group", obj, "vertex_groups", text="", icon='GROUP_VERTEX')
        row.prop(item, "empty", text="", icon='EMPTY_AXIS')


def _panel_object(context):
    """The active mesh; while Live runs and an empty is active, the posed mesh."""
    obj = context.active_object
    if obj is not None and obj.type == 'MESH':
        return obj
    session = engine.any_session()
    if session is not None and session.active:
        try:
            return session.obj if session.obj.name else None
        except ReferenceError:
            return None
    return None


class ARAP_PT_main(bpy.types.Panel):
    """ARAP Deform settings of the active mesh"""
    bl_label = "ARAP Deform"
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "ARAP"

    @classmethod
    def poll(cls, context):
        return _panel_object(context) is not None

    def draw(self, context):
        layout = self.layout
        obj = _panel_object(context)
        s = obj.arap
        session = engine.session_for(obj)
        if obj != context.active_object:
            layout.label(text="Live: posing '%s'" % obj.name, icon='PLAY')

        col = layout.column()
        col.label(text="Fixed (anchor) vertices:")
        row = col.row(align=True)
        row.prop_search(s, "fixed_group", obj, "vertex_groups", text="")
        row.operator("object.arap_set_fixed_from_selection", text="", icon='RESTRICT_SELECT_OFF')

        col.label(text="Handles:")
        row = col.row()
        row.template_list("ARAP_UL_handles", "", s, "handles", s, "active_handle", rows=3)
        sub = row.column(align=True)
        sub.operator("object.arap_handle_add", text="", icon='ADD')
        sub.operator("object.arap_handle_remove", text="", icon='REMOVE')
        col.operator("object.arap_add_handle_from_selection", icon='EMPTY_AXIS')
        if obj.mode == 'EDIT':
            col.label(text="Deform and Live run in Object Mode", icon='INFO')

        box = layout.box()
        box.prop_search(s, "stiff_group", obj, "vertex_groups", text="Stiff")
        if s.stiff_group:
            box.prop(s, "stiffness")
        box.prop(s, "method")
        box.prop(s, "iterations")
        box.prop(s, "live_iterations")
        box.prop(s, "live_frame_ms")
        box.prop(s, "tolerance")
        box.prop(s, "weights")
        box.prop(s, "init")
        if s.method == 'ANDERSON':
            box.prop(s, "acceleration")
        box.prop(s, "threads")
        box.prop(s, "output")

        col = layout.column(align=True)
        if session is None:
            col.operator("object.arap_deform", icon='MOD_SIMPLEDEFORM')
            col.operator("object.arap_live", icon='PLAY')
        else:
            row = col.row(align=True)
            row.operator("object.arap_live_apply", text="Apply", icon='CHECKMARK')
            row.operator("object.arap_live_cancel", text="Cancel", icon='CANCEL')
            if session.last is not None:
                col.label(text="%.1f ms/frame, energy %.5g" % (session.last.total_ms, session.last.energy))
        row = col.row(align=True)
        row.operator("object.arap_reset", icon='LOOP_BACK')
        row.operator("object.arap_set_rest_pose", icon='ARMATURE_DATA')


class ARAP_MT_menu(bpy.types.Menu):
    """ARAP Deform operators"""
    bl_label = "ARAP Deform"
    bl_idname = "ARAP_MT_menu"

    def draw(self, context):
        layout = self.layout
        layout.operator("object.arap_deform")
        layout.operator("object.arap_live")
        layout.operator("object.arap_live_apply")
        layout.operator("object.arap_live_cancel")
        layout.operator("object.arap_reset")
        layout.operator("object.arap_set_rest_pose")
        layout.separator()
        layout.operator("object.arap_add_handle_from_selection")
        layout.operator("object.arap_set_fixed_from_selection")
        layout.operator("object.arap_handle_add")
        layout.operator("object.arap_handle_remove")


def _menu_entry(self, context):
    self.layout.menu(ARAP_MT_menu.bl_idname)


classes = (ARAP_UL_handles, ARAP_PT_main, ARAP_MT_menu)
_register_classes, _unregister_classes = bpy.utils.register_classes_factory(classes)
_MENUS = ("VIEW3D_MT_object", "VIEW3D_MT_edit_mesh_vertices")


def register():
    _register_classes()
    for name in _MENUS:
        getattr(bpy.types, name).append(_menu_entry)


def unregister():
    for name in _MENUS:
        getattr(bpy.types, name).remove(_menu_entry)
    _unregister_classes()
