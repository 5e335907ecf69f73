# Add Handle / Set Fixed from Selection (Edit Mode operators) and the handle list.
import unittest

import bmesh
import bpy
import numpy as np
from mathutils import Euler, Matrix, Vector

import arap_test_utils as U
from arap_deform import api


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
        self.assertIn("Select the vertices", str(cm.exception))
        self.assertEqual(len(self.obj.vertex_groups), 0)

    def test_full_workflow_from_operators(self):
        select_in_edit_mode(self.obj, lambda co: co.z < -1.5)
        bpy.ops.object.arap_set_fixed_from_selection()
        top = select_in_edit_mode(self.obj, lambda co: co.z > 1.5)
        bpy.ops.object.arap_add_handle_from_selection()
        bpy.ops.object.mode_set(mode='OBJECT')
        empty = self.obj.arap.handles[0].empty
        empty.location.x += 1.0
        self.assertEqual(bpy.ops.object.arap_deform(iterations=5), {'FINISHED'})
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
