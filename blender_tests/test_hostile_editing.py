# A user who deletes, edits, links and re-points things while a solve runs: every case ends with a message
# that names the object, handle or group, no traceback, no orphaned solve, and the mesh either untouched or
# correctly posed, its rest shape never lost. (The cases that need Blender's event loop -- the modal
# Deform, the add-on disabled while Auto solves -- are in gui/hostile_ui.py.)
import unittest

import bmesh
import bpy
import numpy as np
from mathutils import Matrix

import arap_test_utils as U

api, auto, bake, bake_ops, deform_ops, deform_job, errors, meshio = U.addon(
    "api", "auto", "bake", "bake_ops", "deform_ops", "deform_job", "errors", "meshio")
SetupError = errors.SetupError


def move(empty, dx):
    empty.location.x += dx
    bpy.context.view_layer.update()


def renumber_vertices(obj):
    """The same mesh with its vertex order reversed: the same counts, other vertices behind each index."""
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    bm.verts.index_update()
    bm.verts.sort(key=lambda v: -v.index)
    bm.to_mesh(obj.data)
    bm.free()


class DeformWhileItSolves(unittest.TestCase):
    """Deform's job on the worker (what the modal runs) meets a deleted object or an edited mesh."""

    def setUp(self):
        U.clear_scene()
        self.obj, self.empty, _fixed, _top = U.bar_with_handle()
        move(self.empty, 0.6)
        self.before = U.raw_coords(self.obj).copy()
        self.obj.arap.tolerance = 0.0     # the worker keeps solving until stopped
        self.job = deform_job.DeformJob(self.obj, bpy.context.scene, max_iterations=100000)
        self.job.start()

    def tearDown(self):
        self.job.stop()
        deform_ops.ARAP_OT_deform.running = None

    def assert_stopped_with(self, fragment):
        with self.assertRaises(SetupError) as caught:
            self.job.poll()
        self.assertIn(fragment, str(caught.exception))
        self.assertIsNone(self.job.worker)          # no orphaned solve
        self.assertFalse(self.job.solver.busy)
        self.assertEqual(errors.user_error(caught.exception), str(caught.exception))   # a message, no traceback
        return str(caught.exception)

    def test_the_object_deleted(self):
        deform_ops.ARAP_OT_deform.running = self.job   # what the viewport's lines read while the modal runs
        mesh = self.obj.data
        bpy.data.objects.remove(self.obj)
        self.assertIn("'Bar'", deform_ops.deform_status_lines()[0])
        message = self.assert_stopped_with("deleted")
        self.assertIn("'Bar'", message)
        bpy.data.meshes.remove(mesh)

    def test_a_vertex_added(self):
        self.obj.data.vertices.add(1)
        self.assertIn("'Bar'", self.assert_stopped_with("changed while Deform solved"))
        np.testing.assert_array_equal(U.raw_coords(self.obj)[:len(self.before)], self.before)

    def test_vertices_renumbered_with_the_same_count(self):
        # The counts are compared every poll, each corner's vertex once the solve is done, before writing.
        self.job.stop()
        self.job = deform_job.DeformJob(self.obj, bpy.context.scene, max_iterations=5)
        self.job.start()
        renumber_vertices(self.obj)
        renumbered = U.raw_coords(self.obj).copy()
        self.assertFalse(np.array_equal(renumbered, self.before))
        with self.assertRaises(SetupError) as caught:
            while self.job.poll() is None:
                pass
        self.assertIn("changed while Deform solved", str(caught.exception))
        self.assertIsNone(self.job.worker)
        np.testing.assert_array_equal(U.raw_coords(self.obj), renumbered)   # not posed into the wrong vertices

    def test_edit_mode_entered(self):
        bpy.context.view_layer.objects.active = self.obj
        bpy.ops.object.mode_set(mode='EDIT')
        try:
            self.assert_stopped_with("Edit Mode")
        finally:
            bpy.ops.object.mode_set(mode='OBJECT')
        np.testing.assert_array_equal(U.raw_coords(self.obj), self.before)

    def test_untouched_it_finishes_as_before(self):
        self.job.stop()
        self.obj.arap.tolerance = 1e-4
        job = deform_job.DeformJob(self.obj, bpy.context.scene)
        job.start()
        while (result := job.poll()) is None:
            pass
        self.assertGreater(result.iterations, 0)
        self.assertGreater(np.abs(U.raw_coords(self.obj) - self.before).max(), 0.3)


class BakeWhileItSolves(unittest.TestCase):
    def setUp(self):
        U.clear_scene()
        self.obj, self.empty, _fixed, _top = U.bar_with_handle()
        for f, x in ((1, 0.0), (6, 0.8)):
            self.empty.location.x = x
            self.empty.keyframe_insert("location", frame=f)
        self.run = bake_ops.InteractiveBake(bake.Baker(self.obj, 1, 6))
        self.run.step(slice_ms=0.0)

    def tearDown(self):
        if bake_ops.InteractiveBake.current is not None:
            bake_ops.InteractiveBake.current.cancel()

    def test_the_object_deleted(self):
        mesh = self.obj.data
        bpy.data.objects.remove(self.obj)
        self.assertIn("'Bar'", self.run.status())
        with self.assertRaises(SetupError) as caught:
            while not self.run.step(slice_ms=0.0):
                pass
        self.assertIn("'Bar' was deleted", str(caught.exception))
        self.run.cancel()                           # what the modal does then: no error on a deleted object
        self.assertIsNone(bake_ops.InteractiveBake.current)
        bpy.data.meshes.remove(mesh)

    def test_a_vertex_added(self):
        self.obj.data.vertices.add(1)
        with self.assertRaises(SetupError) as caught:
            while not self.run.step(slice_ms=0.0):
                pass
        self.assertIn("changed during the bake", str(caught.exception))
        self.run.cancel()


class LinkedDuplicates(unittest.TestCase):
    """Two objects sharing one mesh: only one of them can pose it, and its rest shape is never lost."""

    def setUp(self):
        U.clear_scene()
        auto.forget()
        self.a, self.empty, _fixed, self.top = U.bar_with_handle()
        self.rest = U.raw_coords(self.a).copy()

    def linked_duplicate(self, name="Bar.Linked"):
        """Alt+D: a new object with the same mesh, settings (Auto's flag too) and handles."""
        b = self.a.copy()
        b.name = name
        bpy.context.scene.collection.objects.link(b)
        bpy.context.view_layer.update()
        return b

    def test_the_second_is_refused_and_the_rest_shape_survives(self):
        api.set_auto(self.a, True)
        move(self.empty, 0.5)
        posed = U.raw_coords(self.a).copy()
        self.assertGreater(np.abs(posed - self.rest).max(), 0.3)
        b = self.linked_duplicate()
        with self.assertRaises(SetupError) as caught:
            api.set_auto(b, True)
        self.assertIn("shares its mesh", str(caught.exception))
        self.assertIn("'Bar'", str(caught.exception))
        np.testing.assert_array_equal(U.raw_coords(self.a), posed)      # the first goes on posing
        move(self.empty, 0.1)
        self.assertFalse(np.array_equal(U.raw_coords(self.a), posed))
        api.set_auto(b, False)                                           # off where it never posed: no change
        self.assertTrue(meshio.has_rest_attribute(self.a.data))
        api.set_auto(self.a, False)
        np.testing.assert_array_equal(U.raw_coords(self.a), self.rest)
        api.set_auto(b, True)                                            # now the mesh is free for it
        move(self.empty, 0.1)
        self.assertGreater(np.abs(U.raw_coords(b) - self.rest).max(), 0.3)
        api.set_auto(b, False)
        np.testing.assert_array_equal(U.raw_coords(b), self.rest)
        self.assertFalse(meshio.has_rest_attribute(b.data))

    def test_a_duplicate_made_while_auto_poses_is_turned_off_with_a_message(self):
        api.set_auto(self.a, True)
        move(self.empty, 0.5)
        posed = U.raw_coords(self.a).copy()
        b = self.linked_duplicate()          # its Auto flag came with the copy
        move(self.empty, 0.0)
        self.assertTrue(self.a.arap.auto)
        self.assertFalse(b.arap.auto)
        self.assertIn("shares its mesh", b.arap.auto_status)
        np.testing.assert_array_equal(U.raw_coords(self.a), posed)
        api.set_auto(self.a, False)
        np.testing.assert_array_equal(U.raw_coords(self.a), self.rest)

    def test_deform_live_and_bake_are_refused_on_the_other(self):
        api.set_auto(self.a, True)
        move(self.empty, 0.5)
        posed = U.raw_coords(self.a).copy()
        b = self.linked_duplicate()
        b.arap["auto"] = False
        for start in (lambda: api.deform(b), lambda: api.start_session(b), lambda: bake.Baker(b, 1, 2)):
            with self.assertRaises(SetupError) as caught:
                start()
            self.assertIn("whose Auto mode poses it", str(caught.exception))
            self.assertIn("'Bar.Linked' shares its mesh", str(caught.exception))
        np.testing.assert_array_equal(U.raw_coords(self.a), posed)
        api.set_auto(self.a, False)


    def test_live_on_one_refuses_live_deform_and_auto_on_the_other(self):
        session = api.start_session(self.a)
        move(self.empty, 0.5)
        session.step()
        posed = U.raw_coords(self.a).copy()
        b = self.linked_duplicate()
        for start in (lambda: api.start_session(b), lambda: api.deform(b), lambda: api.set_auto(b, True)):
            with self.assertRaises(SetupError) as caught:
                start()
            self.assertIn("whose Live poses it", str(caught.exception))
        np.testing.assert_array_equal(U.raw_coords(self.a), posed)   # Auto's refusal kept Live's pose
        session.cancel()
        np.testing.assert_array_equal(U.raw_coords(self.a), self.rest)


class AutoFollowsItsObject(unittest.TestCase):
    def setUp(self):
        U.clear_scene()
        auto.forget()
        self.obj, self.empty, _fixed, self.top = U.bar_with_handle()
        self.rest = U.raw_coords(self.obj).copy()

    def tearDown(self):
        for ob in bpy.data.objects:
            if ob.type == 'MESH' and ob.arap.auto:
                api.set_auto(ob, False)

    def test_a_deleted_objects_state_is_dropped(self):
        api.set_auto(self.obj, True)
        move(self.empty, 0.4)
        self.assertEqual(len(auto._posers), 1)
        mesh = self.obj.data
        bpy.data.objects.remove(self.obj)
        bpy.data.meshes.remove(mesh)
        bpy.context.view_layer.update()
        self.assertEqual(len(auto._posers), 0)

    def test_an_object_taken_out_of_the_scene_stops_its_worker(self):
        poser = auto.AutoPoser(self.obj, bpy.context.scene)
        # Evaluated before Auto is on: the poser's own first writes (its rest attribute) must not have the
        # depsgraph handler pose the mesh here, in --background's way.
        depsgraph = bpy.context.evaluated_depsgraph_get()
        self.obj.arap["auto"] = True
        auto._posers[self.obj.as_pointer()] = poser
        poser.update(self.obj, depsgraph, on_worker=True)   # a preview under way
        self.assertIsNotNone(poser.worker)
        for collection in self.obj.users_collection:
            collection.objects.unlink(self.obj)
        move(self.empty, 0.2)
        self.assertNotIn(self.obj.as_pointer(), auto._posers)
        self.assertIsNone(poser.worker)
        self.obj.arap["auto"] = False

    def test_a_new_object_at_a_deleted_ones_address_poses_with_its_own_empty(self):
        api.set_auto(self.obj, True)
        move(self.empty, 0.4)
        stale = auto._posers[self.obj.as_pointer()]
        auto._busy = True     # no handler runs between the deletion and the new object
        try:
            bpy.data.objects.remove(self.obj)
            obj, empty, _fixed, top = U.bar_with_handle()
            obj.name, empty.name = "Second", "SecondEmpty"
            # Where the allocator gives the freed address back, the state is found under the new object's
            # address: put it there (as_pointer() keys the state).
            auto._posers[obj.as_pointer()] = stale
        finally:
            auto._busy = False
        rest = U.raw_coords(obj).copy()
        api.set_auto(obj, True)
        move(empty, 0.3)
        moved = U.coords(obj)[top] - rest.reshape(-1, 3)[top]
        np.testing.assert_allclose(moved, np.tile((0.3, 0.0, 0.0), (len(top), 1)), atol=1e-5)
        self.assertTrue(obj.arap.auto)
        self.assertEqual(obj.arap.auto_status, "")
        self.assertIsNot(auto._posers[obj.as_pointer()], stale)

    def test_a_removed_handle_group_stops_auto_with_deforms_message(self):
        api.set_auto(self.obj, True)
        move(self.empty, 0.4)
        self.obj.vertex_groups.remove(self.obj.vertex_groups["top"])
        move(self.empty, 0.1)   # Auto follows the Empty no further with the old sets
        self.assertFalse(self.obj.arap.auto)
        self.assertIn("Vertex group 'top' does not exist on 'Bar'", self.obj.arap.auto_status)
        np.testing.assert_array_equal(U.raw_coords(self.obj), self.rest)

    def test_a_renamed_fixed_group_stops_auto_with_deforms_message(self):
        api.set_auto(self.obj, True)
        move(self.empty, 0.4)
        self.obj.vertex_groups["bottom"].name = "base"
        move(self.empty, 0.1)
        self.assertFalse(self.obj.arap.auto)
        self.assertIn("Vertex group 'bottom' does not exist", self.obj.arap.auto_status)
        np.testing.assert_array_equal(U.raw_coords(self.obj), self.rest)

    def test_a_handle_pointed_at_another_empty_is_followed(self):
        api.set_auto(self.obj, True)
        move(self.empty, 0.4)
        other = U.add_empty("Other", Matrix.Translation((0, 0, 2.0)))
        self.obj.arap.handles[0].empty = other
        api.reset(self.obj)   # its bind pose
        move(other, -0.3)
        moved = U.coords(self.obj)[self.top] - self.rest.reshape(-1, 3)[self.top]
        np.testing.assert_allclose(moved, np.tile((-0.3, 0.0, 0.0), (len(self.top), 1)), atol=1e-5)

    def test_the_arap_shape_key_deleted(self):
        self.obj.shape_key_add(name="Basis", from_mix=False)
        api.set_auto(self.obj, True)
        move(self.empty, 0.4)
        key = self.obj.data.shape_keys.key_blocks["ARAP"]
        self.obj.shape_key_remove(key)
        move(self.empty, 0.1)
        status = self.obj.arap.auto_status
        self.assertFalse(self.obj.arap.auto)
        self.assertIn("The shape key 'ARAP' of 'Bar' was removed", status)
        self.assertNotIn("bpy_prop_collection", status)
        np.testing.assert_array_equal(U.raw_coords(self.obj), self.rest)


class TargetsOutOfReach(unittest.TestCase):
    """An Empty scaled or moved to where float32 cannot keep the mesh's shape is refused, naming the handle."""

    def setUp(self):
        U.clear_scene()
        auto.forget()
        self.obj, self.empty, _fixed, _top = U.bar_with_handle()
        self.rest = U.raw_coords(self.obj).copy()

    def test_deform_refuses_an_empty_scaled_to_infinity(self):
        self.empty.scale = (float("inf"),) * 3       # Blender keeps about 3.4e38
        bpy.context.view_layer.update()
        with self.assertRaises(SetupError) as caught:
            api.deform(self.obj)
        message = str(caught.exception)
        self.assertIn("Handle 'top'", message)
        self.assertIn("'TopEmpty'", message)
        np.testing.assert_array_equal(U.raw_coords(self.obj), self.rest)

    def test_auto_stops_on_an_empty_moved_out_of_reach_and_a_near_one_poses(self):
        api.set_auto(self.obj, True)
        move(self.empty, 1e6)
        self.assertFalse(self.obj.arap.auto)
        self.assertIn("Handle 'top'", self.obj.arap.auto_status)
        np.testing.assert_array_equal(U.raw_coords(self.obj), self.rest)
        self.empty.location.x = 50.0      # far, but within reach: posed
        api.set_auto(self.obj, True)
        self.assertTrue(np.isfinite(U.raw_coords(self.obj)).all())
        self.assertGreater(np.abs(U.raw_coords(self.obj) - self.rest).max(), 40.0)
        api.set_auto(self.obj, False)


if __name__ == "__main__":
    unittest.main()
