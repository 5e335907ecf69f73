# Bad set-ups: a clear error (or warning) and an untouched mesh.
import unittest

import bpy
import numpy as np
from mathutils import Matrix

import arap_test_utils as U

api = U.addon("api")


class BadSetups(unittest.TestCase):
    def setUp(self):
        U.clear_scene()
        self.obj, self.empty, self.fixed, self.top = U.bar_with_handle()
        self.empty.matrix_world = Matrix.Translation((0.5, 0.0, 2.2))
        self.before = U.raw_coords(self.obj).copy()

    def assert_untouched(self):
        self.assertTrue(np.array_equal(U.raw_coords(self.obj), self.before), "the mesh was changed")
        self.assertIsNone(self.obj.data.shape_keys)
        self.assertNotIn("arap_rest", self.obj.data.attributes)

    def assert_deform_error(self, *fragments):
        with self.assertRaises(RuntimeError) as cm:
            bpy.ops.object.arap_deform()
        msg = str(cm.exception)
        for f in fragments:
            self.assertIn(f, msg)
        self.assert_untouched()
        return msg

    def test_nothing_constrained(self):
        self.obj.arap.fixed_group = ""
        self.obj.arap.handles.clear()
        self.assert_deform_error("set a fixed vertex group or add a handle")

    def test_missing_group(self):
        self.obj.arap.fixed_group = "nope"
        self.assert_deform_error("'nope'", "does not exist")

    def test_empty_group(self):
        self.obj.vertex_groups.new(name="hollow")
        self.obj.arap.handles[0].group = "hollow"
        self.assert_deform_error("'hollow'", "has no vertices")

    def test_handle_without_empty(self):
        self.obj.arap.handles[0].empty = None
        self.assert_deform_error("'top'", "has no empty")

    def test_handle_empty_removed(self):
        bpy.data.objects.remove(self.empty)
        self.assert_deform_error("'top'", "empty")

    def test_handle_empty_unlinked_from_scene(self):
        bpy.context.scene.collection.objects.unlink(self.empty)
        self.assert_deform_error("'top'", "deleted")

    def test_handle_without_group(self):
        self.obj.arap.handles.add().empty = self.empty
        self.assert_deform_error("no vertex group")

    def test_non_mesh_active(self):
        # (An active handle Empty stands for its mesh: test_handles.PanelAndRedo.)
        other = bpy.data.objects.new("NotAHandle", None)
        bpy.context.scene.collection.objects.link(other)
        bpy.context.view_layer.objects.active = other
        self.assert_deform_error("mesh object")

    def test_no_active_object(self):
        bpy.context.view_layer.objects.active = None
        self.assert_deform_error("mesh object")

    def test_edit_mode(self):
        bpy.ops.object.mode_set(mode='EDIT')
        try:
            with self.assertRaises(RuntimeError) as cm:
                bpy.ops.object.arap_deform()
            self.assertIn("Leave Edit Mode", str(cm.exception))
        finally:
            bpy.ops.object.mode_set(mode='OBJECT')
        self.assert_untouched()

    def test_nan_coordinates(self):
        self.obj.data.vertices[0].co.x = float("nan")
        self.before = U.raw_coords(self.obj).copy()
        with self.assertRaises(RuntimeError) as cm:
            bpy.ops.object.arap_deform()
        self.assertIn("ARAP solver", str(cm.exception))
        after = U.raw_coords(self.obj)
        self.assertTrue(np.array_equal(np.isnan(after), np.isnan(self.before)))
        self.assertTrue(np.array_equal(after[~np.isnan(after)], self.before[~np.isnan(self.before)]))

    def test_unconstrained_part_warns_and_stays(self):
        bpy.ops.object.mode_set(mode='EDIT')
        bpy.ops.mesh.select_all(action='DESELECT')
        bpy.ops.mesh.primitive_cube_add(size=0.5, location=(3.0, 0.0, 0.0))
        bpy.ops.object.mode_set(mode='OBJECT')
        rest = U.coords(self.obj)
        r = api.deform(self.obj)
        self.assertTrue(any("8 vertices in 1 part" in w for w in r.warnings), r.warnings)
        self.assertEqual(r.mesh_report["unconstrained_vertices"], 8)
        np.testing.assert_array_equal(U.coords(self.obj)[-8:], rest[-8:])

    def test_vertex_in_fixed_and_handle_warns(self):
        both = U.group_where(self.obj, "both", lambda co: co.z > 1.5 or co.z < -1.9)
        self.obj.arap.handles[0].group = "both"
        r = api.deform(self.obj)
        self.assertIn("Handle 'both': %d of its vertices are also in the fixed group 'bottom' and stay fixed"
                      % len(np.intersect1d(both, self.fixed)), r.warnings)
        rest = self.before.reshape(-1, 3)
        np.testing.assert_array_equal(U.raw_coords(self.obj).reshape(-1, 3)[self.fixed], rest[self.fixed])
        self.assertGreater(len(both), len(self.fixed))

    def test_vertex_in_two_handles_follows_the_first(self):
        # The core's rule (docs/design.md, "Constraints: the rules"): the first handle in the list wins,
        # and the warning names the handle that took the vertices.
        upper = U.group_where(self.obj, "upper", lambda co: co.z > 1.0)
        api.add_handle(self.obj, "upper", U.add_empty("Still", Matrix.Translation((0.0, 0.0, 1.3))))
        rest = self.before.reshape(-1, 3)
        only_upper = np.setdiff1d(upper, self.top)
        self.assertGreater(len(only_upper), 0)

        r = api.deform(self.obj)   # 'top' (moved by (0.5, 0, 0.2)) first, then 'upper' (still)
        self.assertIn("Handle 'upper': %d of its vertices are also in handle 'top' and follow that one"
                      % len(self.top), r.warnings)
        out = U.raw_coords(self.obj).reshape(-1, 3)
        np.testing.assert_allclose(out[self.top], rest[self.top] + (0.5, 0.0, 0.2), atol=1e-5)
        np.testing.assert_allclose(out[only_upper], rest[only_upper], atol=1e-5)

        self.obj.arap.handles.move(1, 0)   # 'upper' first: it keeps every vertex of 'top'
        r = api.deform(self.obj)
        self.assertIn("Handle 'top': %d of its vertices are also in handle 'upper' and follow that one"
                      % len(self.top), r.warnings)
        self.assertIn("Handle 'top' has no vertices of its own: ignored", r.warnings)
        out = U.raw_coords(self.obj).reshape(-1, 3)
        np.testing.assert_allclose(out[upper], rest[upper], atol=1e-5)

    def test_setup_error_from_api(self):
        self.obj.arap.fixed_group = "nope"
        with self.assertRaises(api.SetupError):
            api.deform(self.obj)
        with self.assertRaises(api.SetupError):
            api.set_fixed(self.obj, "nope")
        with self.assertRaises(api.SetupError):
            api.add_handle(self.obj, "top", self.obj)
        self.assert_untouched()


if __name__ == "__main__":
    unittest.main()
