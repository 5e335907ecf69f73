# Add Handle / Set Fixed from Selection (Edit Mode operators) and the handle list.
import unittest

import bmesh
import bpy
import numpy as np
from mathutils import Euler, Matrix, Vector

import arap_test_utils as U

api = U.addon("api")


def select_in_edit_mode(obj, predicate):
    """Select (in Edit Mode) the vertices whose local co satisfies predicate."""
    bm = bmesh.from_edit_mesh(obj.data)
    for v in bm.verts:
        v.select_set(predicate(v.co))
    bm.select_flush_mode()
    bmesh.update_edit_mesh(obj.data)
    return sorted(v.index for v in bm.verts if v.select)


class HandlesFromSelection(unittest.TestCase):
    def setUp(self):
        U.clear_scene()
        self.obj = U.add_cylinder()
        self.obj.matrix_world = (Matrix.Translation((1.0, -2.0, 0.5)) @ Euler((0.2, 0.3, 0.4)).to_matrix().to_4x4()
                                 @ Matrix.Scale(2.0, 4))
        bpy.context.view_layer.update()
        bpy.ops.object.mode_set(mode='EDIT')

    def tearDown(self):
        if self.obj.mode == 'EDIT':
            bpy.ops.object.mode_set(mode='OBJECT')

    def test_add_handle_creates_group_and_empty_at_world_centroid(self):
        picked = select_in_edit_mode(self.obj, lambda co: co.z > 1.5)
        with bpy.context.temp_override(active_object=self.obj, object=self.obj, edit_object=self.obj):
            self.assertEqual(bpy.ops.object.arap_add_handle_from_selection(), {'FINISHED'})
        bpy.ops.object.mode_set(mode='OBJECT')
        s = self.obj.arap
        self.assertEqual(len(s.handles), 1)
        h = s.handles[0]
        members = sorted(v.index for v in self.obj.data.vertices
                         for g in v.groups if g.group == self.obj.vertex_groups[h.group].index)
        self.assertEqual(members, picked)
        local = U.coords(self.obj)[picked].mean(axis=0)
        world = self.obj.matrix_world @ Vector(local)
        self.assertEqual(h.empty.type, 'EMPTY')
        self.assertLess((h.empty.matrix_world.translation - world).length, 1e-5)
        self.assertTrue(h.has_bind)
        np.testing.assert_allclose(np.array(h.bind_matrix).reshape(4, 4), U.np_matrix(h.empty.matrix_world),
                                   atol=1e-6)
        self.assertIn(h.empty.name, bpy.context.scene.objects)

    def test_set_fixed_replaces_membership(self):
        first = select_in_edit_mode(self.obj, lambda co: co.z < -1.5)
        bpy.ops.object.arap_set_fixed_from_selection()
        second = select_in_edit_mode(self.obj, lambda co: co.z < -1.9)
        bpy.ops.object.arap_set_fixed_from_selection()
        bpy.ops.object.mode_set(mode='OBJECT')
        g = self.obj.vertex_groups[self.obj.arap.fixed_group]
        members = sorted(v.index for v in self.obj.data.vertices for e in v.groups if e.group == g.index)
        self.assertEqual(members, second)
        self.assertLess(len(second), len(first))

    def test_no_selection_is_an_error(self):
        select_in_edit_mode(self.obj, lambda co: False)
        with self.assertRaises(RuntimeError) as cm:
            bpy.ops.object.arap_add_handle_from_selection()
        self.assertIn("No vertex is selected", str(cm.exception))
        self.assertEqual(len(self.obj.vertex_groups), 0)

    def test_set_fixed_and_add_handle_work_in_object_mode(self):
        # The buttons act on the mesh's stored vertex selection in Object Mode too.
        bottom = select_in_edit_mode(self.obj, lambda co: co.z < -1.5)
        bpy.ops.object.mode_set(mode='OBJECT')
        self.assertEqual(bpy.ops.object.arap_set_fixed_from_selection(), {'FINISHED'})
        g = self.obj.vertex_groups[self.obj.arap.fixed_group]
        self.assertEqual(sorted(v.index for v in self.obj.data.vertices for e in v.groups if e.group == g.index),
                         bottom)
        bpy.ops.object.mode_set(mode='EDIT')
        top = select_in_edit_mode(self.obj, lambda co: co.z > 1.5)
        bpy.ops.object.mode_set(mode='OBJECT')
        self.assertEqual(bpy.ops.object.arap_add_handle_from_selection(), {'FINISHED'})
        h = self.obj.arap.handles[0]
        members = sorted(v.index for v in self.obj.data.vertices
                         for e in v.groups if e.group == self.obj.vertex_groups[h.group].index)
        self.assertEqual(members, top)
        world = self.obj.matrix_world @ Vector(U.coords(self.obj)[top].mean(axis=0))
        self.assertLess((h.empty.matrix_world.translation - world).length, 1e-5)
        # Set Fixed again replaces the group's members.
        for v in self.obj.data.vertices:
            v.select = v.index == bottom[0]
        bpy.ops.object.arap_set_fixed_from_selection()
        self.assertEqual([v.index for v in self.obj.data.vertices for e in v.groups if e.group == g.index],
                         [bottom[0]])

    def test_full_workflow_from_operators(self):
        select_in_edit_mode(self.obj, lambda co: co.z < -1.5)
        bpy.ops.object.arap_set_fixed_from_selection()
        top = select_in_edit_mode(self.obj, lambda co: co.z > 1.5)
        bpy.ops.object.arap_add_handle_from_selection()
        bpy.ops.object.mode_set(mode='OBJECT')
        empty = self.obj.arap.handles[0].empty
        empty.location.x += 1.0
        self.assertEqual(bpy.ops.object.arap_deform(max_iterations=5), {'FINISHED'})
        rest_top = np.array([tuple(self.obj.matrix_world @ v.co) for v in self.obj.data.vertices])[top]
        self.assertTrue(np.isfinite(U.coords(self.obj)).all())
        self.assertEqual(len(rest_top), len(top))

    def test_handle_add_remove_buttons(self):
        bpy.ops.object.mode_set(mode='OBJECT')
        bpy.ops.object.arap_handle_add()
        bpy.ops.object.arap_handle_add()
        self.assertEqual(len(self.obj.arap.handles), 2)
        self.assertEqual(self.obj.arap.active_handle, 1)
        bpy.ops.object.arap_handle_remove()
        self.assertEqual(len(self.obj.arap.handles), 1)
        api.remove_handle(self.obj, 0)
        self.assertEqual(len(self.obj.arap.handles), 0)


class SetUpNames(unittest.TestCase):
    """Names say which object and which handle: group ARAP_Handle_<n> (the next number
    on the object), Empty <object>_ARAP_Handle_<n>; the fixed group is ARAP_Fixed."""

    def setUp(self):
        U.clear_scene()
        self.obj = U.add_cylinder()
        bpy.ops.object.mode_set(mode='EDIT')

    def tearDown(self):
        if self.obj.mode == 'EDIT':
            bpy.ops.object.mode_set(mode='OBJECT')

    def add_handle(self, predicate, **props):
        select_in_edit_mode(self.obj, predicate)
        self.assertEqual(bpy.ops.object.arap_add_handle_from_selection(**props), {'FINISHED'})
        h = self.obj.arap.handles[-1]
        return h.group, h.empty.name

    def test_handles_are_numbered_per_object(self):
        self.assertEqual(self.add_handle(lambda co: co.z > 1.5), ("ARAP_Handle_1", "Bar_ARAP_Handle_1"))
        self.assertEqual(self.add_handle(lambda co: co.z < -1.5), ("ARAP_Handle_2", "Bar_ARAP_Handle_2"))
        # Another object starts at 1 and its Empties say whose they are.
        bpy.ops.object.mode_set(mode='OBJECT')
        self.obj = U.add_cylinder(name="Arm")
        bpy.ops.object.mode_set(mode='EDIT')
        self.assertEqual(self.add_handle(lambda co: co.z > 1.5), ("ARAP_Handle_1", "Arm_ARAP_Handle_1"))

    def test_a_removed_handles_number_is_not_given_again(self):
        self.add_handle(lambda co: co.z > 1.5)
        self.add_handle(lambda co: co.z < -1.5)
        bpy.ops.object.arap_handle_remove()   # handle 2; its group and Empty are kept
        self.assertEqual(self.add_handle(lambda co: abs(co.z) < 0.3), ("ARAP_Handle_3", "Bar_ARAP_Handle_3"))
        # Without its group, the kept Empty still holds the number.
        bpy.ops.object.mode_set(mode='OBJECT')
        for name in ("ARAP_Handle_2", "ARAP_Handle_3"):
            self.obj.vertex_groups.remove(self.obj.vertex_groups[name])
        api.remove_handle(self.obj, 1)
        for v in self.obj.data.vertices:
            v.select = v.co.z > 1.5
        self.assertEqual(bpy.ops.object.arap_add_handle_from_selection(), {'FINISHED'})
        self.assertEqual(self.obj.arap.handles[-1].group, "ARAP_Handle_4")

    def test_a_given_group_name_is_kept(self):
        self.assertEqual(self.add_handle(lambda co: co.z > 1.5, group_name="Head"), ("Head", "Bar_Head"))
        self.assertEqual(self.add_handle(lambda co: co.z < -1.5), ("ARAP_Handle_1", "Bar_ARAP_Handle_1"))

    def test_set_fixed_takes_the_fixed_group_the_settings_lost(self):
        select_in_edit_mode(self.obj, lambda co: co.z < -1.5)
        bpy.ops.object.arap_set_fixed_from_selection()
        self.obj.arap.fixed_group = ""
        picked = select_in_edit_mode(self.obj, lambda co: co.z < -1.9)
        bpy.ops.object.arap_set_fixed_from_selection()
        bpy.ops.object.mode_set(mode='OBJECT')
        self.assertEqual([g.name for g in self.obj.vertex_groups], ["ARAP_Fixed"])
        self.assertEqual(self.obj.arap.fixed_group, "ARAP_Fixed")
        g = self.obj.vertex_groups["ARAP_Fixed"].index
        self.assertEqual([v.index for v in self.obj.data.vertices for e in v.groups if e.group == g], picked)

    def test_set_fixed_writes_the_group_the_settings_name(self):
        bpy.ops.object.mode_set(mode='OBJECT')
        self.obj.vertex_groups.new(name="feet")
        api.set_fixed(self.obj, "feet")
        bpy.ops.object.mode_set(mode='EDIT')
        picked = select_in_edit_mode(self.obj, lambda co: co.z < -1.5)
        bpy.ops.object.arap_set_fixed_from_selection()
        bpy.ops.object.mode_set(mode='OBJECT')
        self.assertEqual([g.name for g in self.obj.vertex_groups], ["feet"])
        self.assertEqual(self.obj.arap.fixed_group, "feet")
        self.assertEqual([v.index for v in self.obj.data.vertices if v.groups], picked)


def shown(panel, context):
    """Whether Blender draws `panel`: a panel without poll() always is."""
    return not hasattr(panel, "poll") or panel.poll(context)


class StandInLayout:
    """Records the calls a panel's draw() makes; each returns a child layout (row, column, box ...)."""

    def __init__(self):
        self.calls = []
        self.children = []

    def __getattr__(self, name):
        def call(*args, **kwargs):
            self.calls.append((name, args, kwargs))
            child = StandInLayout()
            self.children.append(child)
            return child
        return call

    def all_calls(self):
        return self.calls + [c for child in self.children for c in child.all_calls()]

    def in_order(self):
        """Every call in the order Blender would lay it out: each call, then what was drawn into its child."""
        for call, child in zip(self.calls, self.children):
            yield call
            yield from child.in_order()


def button_places(panel):
    """What comes before each button of a drawn StandInPanel, as Blender stacks it: one entry per call (a label's
    text left out: its line is there whatever it says), up to the last operator or property."""
    places = []
    for name, args, kwargs in panel.layout.in_order():
        key = args[0] if name == "operator" else args[1] if name in ("prop", "prop_search") else None
        places.append((name, key))
    last = max(i for i, (name, _) in enumerate(places) if name in ("operator", "prop"))
    return places[:last + 1]


class StandInPanel:
    def __init__(self):
        self.layout = StandInLayout()


class PanelAndRedo(unittest.TestCase):
    def setUp(self):
        U.clear_scene()
        self.obj, self.empty, self.fixed, self.top = U.bar_with_handle()

    def test_an_active_handle_empty_keeps_the_mesh_panel(self):
        sessions, panels = U.addon("sessions", "panels")
        bpy.context.view_layer.objects.active = self.empty
        self.assertIs(sessions.target_mesh(bpy.context), self.obj)
        self.assertTrue(shown(panels.ARAP_PT_solver, bpy.context))
        # ... and the panel's buttons act on that mesh.
        rest = U.coords(self.obj)
        self.empty.location.x += 0.5
        self.assertEqual(bpy.ops.object.arap_deform(), {'FINISHED'})
        self.assertGreater(np.abs(U.coords(self.obj) - rest).max(), 0.1)
        other = bpy.data.objects.new("Unrelated", None)
        bpy.context.scene.collection.objects.link(other)
        bpy.context.view_layer.objects.active = other
        self.assertIsNone(sessions.target_mesh(bpy.context))
        self.assertFalse(panels.ARAP_PT_solver.poll(bpy.context))

    def test_the_tab_is_there_without_a_mesh(self):
        # Right after installing, with no mesh (or none active): the ARAP tab shows
        # one line saying what to do; the sub-panels stay hidden.
        panels, bake_ops = U.addon("panels", "bake_ops")
        for active in (None, U.add_empty("Unrelated")):
            bpy.context.view_layer.objects.active = active
            self.assertTrue(shown(panels.ARAP_PT_main, bpy.context))
            self.assertFalse(shown(panels.ARAP_PT_solver, bpy.context))
            self.assertFalse(shown(bake_ops.ARAP_PT_bake, bpy.context))
            panel = StandInPanel()
            panels.ARAP_PT_main.draw(panel, bpy.context)
            self.assertEqual(panel.layout.calls, [("label", (), {"text": "Select a mesh object to pose it",
                                                                  "icon": 'INFO'})])
        # With the mesh active, the same draw shows its settings, not the line.
        bpy.context.view_layer.objects.active = self.obj
        self.assertTrue(shown(panels.ARAP_PT_solver, bpy.context))
        panel = StandInPanel()
        panels.ARAP_PT_main.draw(panel, bpy.context)
        texts = [kw.get("text") for _name, _args, kw in panel.layout.all_calls()]
        self.assertNotIn("Select a mesh object to pose it", texts)
        self.assertIn("Fixed Vertices", texts)

    def test_the_panel_says_how_auto_mode_posed_the_mesh(self):
        panels = U.addon("panels")
        bpy.context.view_layer.objects.active = self.obj
        rest = U.coords(self.obj)
        self.empty.location.x += 0.5
        self.obj.arap.auto = True   # the setting's update callback poses the mesh (at once in --background)
        try:
            self.assertGreater(np.abs(U.coords(self.obj) - rest).max(), 0.1)
            panel = StandInPanel()
            panels.ARAP_PT_main.draw(panel, bpy.context)
            labels = [(kw.get("text"), kw.get("icon")) for name, _args, kw in panel.layout.all_calls()
                      if name == "label"]
            self.assertTrue(any(text.startswith("Auto: settled") and icon == 'INFO' for text, icon in labels), labels)
        finally:
            self.obj.arap.auto = False

    def test_the_buttons_stay_in_place_whatever_is_active_and_running(self):
        panels = U.addon("panels")

        def places():
            panel = StandInPanel()
            panels.ARAP_PT_main.draw(panel, bpy.context)
            return button_places(panel)

        bpy.context.view_layer.objects.active = self.obj
        mesh_active = places()
        self.assertIn(("operator", "object.arap_deform"), mesh_active)
        self.assertIn(("operator", "object.arap_live_apply"), mesh_active)
        bpy.context.view_layer.objects.active = self.empty
        self.assertEqual(places(), mesh_active, "an active handle Empty moved the buttons")
        for volume in ('NONE', 'GLOBAL', 'INFILL'):
            self.obj.arap.volume = volume
            self.assertEqual(places(), mesh_active, "Volume %s moved the buttons" % volume)
        self.obj.arap.stiff_group = self.obj.arap.fixed_group
        self.assertEqual(places(), mesh_active, "a stiff group moved the buttons")
        self.obj.arap.stiff_group = ""
        session = api.start_session(self.obj)
        try:
            session.step()
            self.assertEqual(places(), mesh_active, "a Live session moved the buttons")
        finally:
            session.cancel()
        self.empty.location.x += 0.5
        self.obj.arap.auto = True
        try:
            self.assertEqual(places(), mesh_active, "Auto mode's status moved the buttons")
        finally:
            self.obj.arap.auto = False

    def test_handle_rows_name_the_group_and_a_differently_named_empty(self):
        panels = U.addon("panels")
        handle = self.obj.arap.handles[0]
        self.empty.name = "%s_%s" % (self.obj.name, handle.group)
        self.assertEqual(panels.handle_row_text(handle, self.obj), handle.group)
        self.empty.name = "Wrist"
        self.assertEqual(panels.handle_row_text(handle, self.obj), "%s \u2192 Wrist" % handle.group)
        handle.empty = None
        self.assertIn("no Empty", panels.handle_row_text(handle, self.obj))

    def test_solver_settings_in_a_collapsed_sub_panel_with_plain_tooltips(self):
        properties, panels = U.addon("properties", "panels")
        self.assertEqual(panels.ARAP_PT_solver.bl_parent_id, "ARAP_PT_main")
        self.assertIn('DEFAULT_CLOSED', panels.ARAP_PT_solver.bl_options)
        for name in ("max_iterations", "live_max_iterations", "tolerance", "weights", "init", "anderson_window",
                     "threads"):
            prop = properties.ARAP_PG_settings.bl_rna.properties[name]
            self.assertNotIn("README", prop.description, name)
            self.assertGreater(len(prop.description), 30, name)

    def test_an_empty_scaled_to_nothing_warns(self):
        self.empty.scale = (0.0, 0.0, 0.0)
        result = api.deform(self.obj)
        self.assertTrue(any("scaled to almost nothing" in w and "'top'" in w for w in result.warnings),
                        result.warnings)
        self.empty.scale = (0.5, 0.5, 0.5)
        self.assertFalse(any("scaled" in w for w in api.deform(self.obj).warnings))
