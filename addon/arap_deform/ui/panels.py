# SPDX-License-Identifier: GPL-3.0-or-later
"""Sidebar panel (View3D > Sidebar > ARAP), the handle list and a menu that
puts the posing and set-up operators in F3 search (Object menu and Edit Mode
Vertex menu); the bake's sub-panel is bake_ops.py's."""

import textwrap

import bpy

from ..persistence import solver_settings
from ..solver import problem, sessions

# Auto mode's lines under its toggle, fn(obj) -> [(text, icon)]: auto.py gives it when it registers (the panels
# import nothing above them).
auto_lines = None


class ARAP_UL_handles(bpy.types.UIList):
    """Handles: each row names its vertex group and the Empty driving it (handle_row_text); the active one
    is edited below the list, each name at full width (as Blender's own vertex group list)."""

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index=0):
        if item.bone:
            icon = 'BONE_DATA' if item.armature is not None else 'ERROR'
        else:
            icon = 'EMPTY_AXIS' if item.empty else 'ERROR'
        layout.label(text=handle_row_text(item, data.id_data), icon=icon)


def handle_row_text(handle, obj):
    """A handle's row: its vertex group, then its Empty when that is not named after the group (Add Handle
    from Selection names the Empty '<mesh>_<group>': the group says it all), or its bone when that is not
    named as the group (Handles from Armature names the group after the bone)."""
    group = handle.group or "(no group)"
    if handle.bone:
        if handle.armature is None:
            return group + "  (no armature)"
        return group if handle.bone in group else "%s → %s" % (group, handle.bone)
    if handle.empty is None:
        return group + "  (no Empty)"
    name = handle.empty.name
    if name in (handle.group, "%s_%s" % (obj.name, handle.group)):
        return group
    return "%s → %s" % (group, name)


NO_MESH_HINT = "Select a mesh object to pose it"


def draw_native_error(layout, message, width=48):
    """Why nothing can be solved (the native module did not load when the add-on was enabled) and what
    to rebuild, in lines the sidebar shows whole."""
    col = layout.box().column(align=True)
    for k, line in enumerate(textwrap.wrap(message, width)):
        col.label(text=line, icon='ERROR' if k == 0 else 'BLANK1')


def panel_object(context):
    """The mesh the panel shows (sessions.target_mesh: the active mesh, or the
    posed mesh of an active handle Empty)."""
    return sessions.target_mesh(context)


class ARAP_PT_main(bpy.types.Panel):
    """ARAP Deform settings of the active mesh"""
    bl_label = "ARAP Deform"
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "ARAP"
    # No poll: the tab is always there, so a new user sees the add-on before choosing a mesh.

    def draw(self, context):
        layout = self.layout
        if solver_settings.NATIVE_ERROR:
            draw_native_error(layout, solver_settings.NATIVE_ERROR)
        obj = panel_object(context)
        if obj is None:
            layout.label(text=NO_MESH_HINT, icon='INFO')
            return
        s = obj.arap
        session = sessions.session_for(obj)
        # One line whatever is active, so that nothing below moves when an Empty becomes active.
        if obj != context.active_object:
            rig = context.active_object.type == 'ARMATURE'   # its bones are the handles
            layout.label(text="Handle of '%s'" % obj.name, icon='ARMATURE_DATA' if rig else 'EMPTY_AXIS')
        else:
            layout.label(text=obj.name, icon='MESH_DATA')

        col = layout.column()
        col.label(text="Fixed Vertices", icon='PINNED')
        col.prop_search(s, "fixed_group", obj, "vertex_groups", text="")
        col.operator("object.arap_set_fixed_from_selection", text="Set Fixed from Selection",
                     icon='RESTRICT_SELECT_OFF')

        col.separator()
        col.label(text="Handles", icon='EMPTY_AXIS')
        row = col.row()
        row.template_list("ARAP_UL_handles", "", s, "handles", s, "active_handle", rows=3)
        sub = row.column(align=True)
        sub.operator("object.arap_handle_add", text="", icon='ADD')
        sub.operator("object.arap_handle_remove", text="", icon='REMOVE')
        if 0 <= s.active_handle < len(s.handles):
            draw_active_handle(col.box(), s.handles[s.active_handle], obj)
        col.operator("object.arap_add_handle_from_selection", text="Add Handle from Selection", icon='ADD')
        col.operator("object.arap_handles_from_armature", text="Handles from Armature", icon='ARMATURE_DATA')

        col.separator()
        sub = col.column()
        sub.use_property_split = True
        sub.use_property_decorate = False
        sub.prop(s, "output")
        sub.prop_search(s, "stiff_group", obj, "vertex_groups", text="Stiff Group")
        # Rows that apply only with another setting are greyed out, not taken away: nothing below moves.
        row = sub.row()
        row.enabled = bool(s.stiff_group)
        row.prop(s, "stiffness")
        sub.prop(s, "volume")
        row = sub.row()
        row.enabled = s.volume == 'INFILL'
        row.prop(s, "infill_resolution")
        sub.prop(s, "contact")

        draw_actions(layout, s, session)
        draw_status(layout, obj, s, session)


def draw_active_handle(box, handle, obj):
    """The active handle's group and Empty (or bone), each on a row of its own at the sidebar's full width
    (the list above shortens long names)."""
    col = box.column(align=True)
    col.label(text="Group")
    col.prop_search(handle, "group", obj, "vertex_groups", text="")
    if handle.bone:
        armature = handle.armature
        col.label(text="Bone of '%s'" % (armature.name if armature is not None else "(deleted armature)"))
        if armature is not None and armature.type == 'ARMATURE':
            col.prop_search(handle, "bone", armature.data, "bones", text="")
        else:
            col.prop(handle, "bone", text="")
        return
    col.label(text="Empty")
    col.prop(handle, "empty", text="")


def draw_actions(layout, s, session):
    """Every action button, in the same place whatever is active and whether a Live session runs: what does
    not apply now is greyed out, not taken away."""
    col = layout.column(align=True)
    row = col.row(align=True)
    row.enabled = session is None
    row.operator("object.arap_deform", text="Deform", icon='MOD_SIMPLEDEFORM')
    row.operator("object.arap_live", text="Live", icon='PLAY')
    row = col.row(align=True)
    row.enabled = session is not None
    row.operator("object.arap_live_apply", text="Apply", icon='CHECKMARK')
    row.operator("object.arap_live_cancel", text="Cancel", icon='CANCEL')
    col.prop(s, "auto", text="Auto (follow the handles)", toggle=True, icon='AUTO')
    col = layout.column(align=True)
    col.operator("object.arap_reset", text="Reset to Rest", icon='LOOP_BACK')
    col.operator("object.arap_set_rest_pose", text="Set Rest Pose", icon='ARMATURE_DATA')


def draw_status(layout, obj, s, session):
    """What Live and Auto are doing, under every button (these lines come and go)."""
    col = layout.column(align=True)
    if s.auto_status and not s.auto:
        col.label(text=s.auto_status, icon='ERROR')
    elif s.auto and auto_lines is not None:
        for text, icon in auto_lines(obj):
            col.label(text=text, icon=icon)
    if session is not None:
        state = "binding" if session.solver is None else "settled" if session.settled else "settling"
        if session.last is not None:
            state += ", %.1f ms per update" % session.last.main_thread_ms
        col.label(text="Live: " + state, icon='INFO')
        if session.contact is not None:
            col.label(text=session.contact.status(), icon='ERROR')


class SubPanel:
    """Mixin: a collapsed sub-panel of ARAP_PT_main, shown for the same mesh."""
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "ARAP"
    bl_parent_id = "ARAP_PT_main"
    bl_options = {'DEFAULT_CLOSED'}

    @classmethod
    def poll(cls, context):
        return panel_object(context) is not None


class ARAP_PT_solver(SubPanel, bpy.types.Panel):
    """How the solver works: method, max iterations, frame budget, tolerance, weights, Anderson window, threads"""
    bl_label = "Solver"

    @classmethod
    def poll(cls, context):
        # Without the native module the settings have no limits from its table: nothing to set.
        return solver_settings.NATIVE_ERROR is None and super().poll(context)

    def draw(self, context):
        s = panel_object(context).arap
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        for name in ("method", "max_iterations", "live_max_iterations", "live_frame_ms", "tolerance", "weights",
                     "init"):
            layout.prop(s, name)
        if s.method == 'ANDERSON':
            layout.prop(s, "anderson_window")
            unchecked = problem.anderson_unchecked(s)
            if unchecked:
                layout.label(text="%s: solved with Quasi-Newton" % " and ".join(unchecked), icon='INFO')
        layout.prop(s, "threads")


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
        layout.operator("object.arap_handles_from_armature")
        layout.operator("object.arap_set_fixed_from_selection")
        layout.operator("object.arap_handle_add")
        layout.operator("object.arap_handle_remove")


def _menu_entry(self, context):
    self.layout.menu(ARAP_MT_menu.bl_idname)


classes = (ARAP_UL_handles, ARAP_PT_main, ARAP_PT_solver, ARAP_MT_menu)
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
