# Bone handles: Handles from Armature on a rigged tube (three bones, smooth weights). Each bone's rigid core
# follows its bone exactly as the Armature modifier moves a vertex weighted fully to it, the object's and the
# armature's transforms included; the modifier is off while ARAP shows a pose and back exactly when it is off;
# Auto mode follows keyframes, constraints (IK) and the frame alone; a renamed or deleted bone or armature
# gets a message naming it and the mesh back at rest; the operator is one undo step; Live's Cancel puts the
# bones back; the bake bakes the rig's frames; each solve starts from the rig's Preserve Volume skin.
import math
import unittest

import bpy
import numpy as np
from mathutils import Matrix

import arap_test_utils as U

api, auto, errors, meshio, problem, rig, sessions = U.addon(
    "api", "auto", "errors", "meshio", "problem", "rig", "sessions")
SetupError = errors.SetupError


def bend_and_twist(armature, bend=60.0, twist=180.0):
    """Bend the middle joint about x and twist the last bone about its own axis (the candy wrapper)."""
    for name, angles in (("B1", (math.radians(bend), 0.0, 0.0)), ("B2", (0.0, math.radians(twist), 0.0))):
        bone = armature.pose.bones[name]
        bone.rotation_mode = 'XYZ'
        bone.rotation_euler = angles
    bpy.context.view_layer.update()


def linear_blend_of_one_bone(obj, armature, bone, rest):
    """Where the Armature modifier puts vertices weighted fully to `bone` (object-local, float64):
    M_obj^-1 @ A @ P @ R^-1 @ A^-1 @ M_obj."""
    a = U.np_matrix(armature.matrix_world)
    p = U.np_matrix(armature.pose.bones[bone].matrix)
    r = U.np_matrix(armature.data.bones[bone].matrix_local)
    m = U.np_matrix(obj.matrix_world)
    return U.apply(np.linalg.inv(m) @ a @ p @ np.linalg.inv(r) @ np.linalg.inv(a) @ m, rest)


def weighted_fully(obj, group):
    index = obj.vertex_groups[group].index
    return np.array([v.index for v in obj.data.vertices if any(g.group == index and g.weight >= 1.0
                                                                for g in v.groups)])


class BoneHandles(unittest.TestCase):
    def setUp(self):
        U.clear_scene()
        for arm in list(bpy.data.armatures):
            bpy.data.armatures.remove(arm)
        auto.forget()
        bpy.context.scene.frame_set(1)
        self.obj, self.rig = U.rigged_tube()
        # Off the identity: the armature moved and turned, the mesh moved under it.
        self.rig.matrix_world = Matrix.Translation((0.4, -0.3, 0.2)) @ Matrix.Rotation(0.3, 4, 'Z')
        self.obj.location = (0.1, 0.2, -0.1)
        bpy.context.view_layer.update()
        self.rest = U.coords(self.obj).copy()
        self.size = float(np.ptp(self.rest, axis=0).max())

    def tearDown(self):
        for session in list(sessions._sessions):
            session.cancel()
        if self.obj.name in bpy.data.objects and self.obj.arap.auto:
            api.set_auto(self.obj, False)

    def make_handles(self, **props):
        self.assertEqual(bpy.ops.object.arap_handles_from_armature(**props), {'FINISHED'})

    def test_one_handle_per_deform_bone_from_its_core(self):
        self.rig.data.bones["B0"].use_deform = True
        made = api.handles_from_armature(self.obj, threshold=0.9)
        self.assertEqual(made.bones, ["B0", "B1", "B2"])
        self.assertEqual([(h.group, h.armature, h.bone) for h in self.obj.arap.handles],
                         [("ARAP_Core_B%d" % k, self.rig, "B%d" % k) for k in range(3)])
        for k in range(3):
            core = meshio.group_members(self.obj, ["ARAP_Core_B%d" % k])["ARAP_Core_B%d" % k]
            weights = meshio.group_weights(self.obj, "B%d" % k)
            np.testing.assert_array_equal(core, np.flatnonzero(weights >= 0.9))
        # Every vertex is weighted here: nothing is fixed. A lower core weight takes in more of each joint, and
        # running it again replaces the bone handles (and their groups) instead of adding more.
        self.assertEqual(self.obj.arap.fixed_group, "")
        wide = api.handles_from_armature(self.obj, threshold=0.5)
        wide_b1 = meshio.group_weights(self.obj, "B1")
        self.assertEqual(len(self.obj.arap.handles), 3)
        self.assertGreater(sum(wide.core_sizes), sum(made.core_sizes))
        self.assertEqual(sum(1 for g in self.obj.vertex_groups if g.name.startswith(rig.CORE_PREFIX)), 3)
        # A bone no vertex reaches any more loses its handle and its core group.
        self.obj.vertex_groups["B1"].add(list(range(len(self.rest))), 0.3, 'REPLACE')
        self.obj.vertex_groups["B1"].remove([int(i) for i in np.flatnonzero(wide_b1 == 0)])
        again = api.handles_from_armature(self.obj, threshold=0.9)
        self.assertEqual(again.bones, ["B0", "B2"])
        self.assertNotIn("ARAP_Core_B1", self.obj.vertex_groups)
        self.assertEqual([h.bone for h in self.obj.arap.handles], ["B0", "B2"])

    def test_a_mesh_without_a_rig_or_weights_gets_a_message_and_nothing_changes(self):
        self.obj.modifiers.remove(self.obj.modifiers["Armature"])
        self.obj.parent = None
        with self.assertRaisesRegex(SetupError, "no Armature modifier"):
            api.handles_from_armature(self.obj)
        with self.assertRaisesRegex(SetupError, "has no deform bones"):
            for bone in self.rig.data.bones:
                bone.use_deform = False
            api.handles_from_armature(self.obj, armature=self.rig)
        for bone in self.rig.data.bones:
            bone.use_deform = True
        self.obj.vertex_groups.clear()
        groups = len(self.obj.vertex_groups)
        with self.assertRaisesRegex(SetupError, "No deform bone of 'Rig' weights a vertex"):
            api.handles_from_armature(self.obj, armature=self.rig)
        self.assertEqual((len(self.obj.arap.handles), len(self.obj.vertex_groups)), (0, groups))

    def test_handles_made_again_while_auto_poses_rebind(self):
        self.make_handles(threshold=0.99)
        bend_and_twist(self.rig, twist=90.0)
        api.set_auto(self.obj, True)
        narrow = U.coords(self.obj).copy()
        self.make_handles(threshold=0.6)
        bpy.context.view_layer.update()
        self.assertTrue(self.obj.arap.auto, self.obj.arap.auto_status)
        self.assertGreater(np.abs(U.coords(self.obj) - narrow).max(), 1e-3 * self.size)

    def test_a_bone_handle_made_by_hand(self):
        hand = weighted_fully(self.obj, "B2")
        api.create_group(self.obj, "hand", hand)
        api.create_group(self.obj, "foot", np.flatnonzero(self.rest[:, 2] < -2.5))
        api.set_fixed(self.obj, "foot")
        with self.assertRaisesRegex(SetupError, "no bone 'Wrist'"):
            api.add_bone_handle(self.obj, "hand", self.rig, "Wrist")
        with self.assertRaisesRegex(SetupError, "armature"):
            api.add_bone_handle(self.obj, "hand", U.add_empty("NotARig"), "B2")
        api.add_bone_handle(self.obj, "hand", self.rig, "B2")
        bend_and_twist(self.rig, bend=45.0, twist=90.0)
        result = api.deform(self.obj)
        self.assertTrue(result.converged)
        expected = linear_blend_of_one_bone(self.obj, self.rig, "B2", self.rest[hand])
        np.testing.assert_allclose(U.coords(self.obj)[hand], expected, atol=1e-6 * self.size)
        self.assertFalse(self.obj.modifiers["Armature"].show_viewport)

    def test_unweighted_vertices_are_fixed_and_non_deform_bones_left_out(self):
        loose = [int(i) for i in np.flatnonzero(self.rest[:, 2] < -2.5)]
        for name in ("B0", "B1", "B2"):
            self.obj.vertex_groups[name].remove(loose)
        # B1 does not deform: the vertices only it weights stay put under the Armature modifier too.
        self.rig.data.bones["B1"].use_deform = False
        made = api.handles_from_armature(self.obj)
        self.assertEqual(made.bones, ["B0", "B2"])
        self.assertEqual(self.obj.arap.fixed_group, rig.UNWEIGHTED_GROUP)
        deforming = meshio.group_weights(self.obj, "B0") + meshio.group_weights(self.obj, "B2")
        fixed = meshio.group_members(self.obj, [rig.UNWEIGHTED_GROUP])[rig.UNWEIGHTED_GROUP]
        np.testing.assert_array_equal(fixed, np.flatnonzero(deforming == 0))
        self.assertTrue(set(loose) < set(fixed.tolist()))

    def test_cores_follow_their_bones_exactly_and_the_modifier_comes_back(self):
        self.make_handles()
        modifier = self.obj.modifiers["Armature"]
        bend_and_twist(self.rig)
        api.set_auto(self.obj, True)
        self.assertEqual((modifier.show_viewport, modifier.show_render), (False, False))
        pose = self.problem().pose(self.obj)
        targets = self.problem().targets(pose)
        shown = U.coords(self.obj)
        setup = self.problem().setup
        for h in setup.handles:
            rows = setup.constrained[h.start:h.stop]
            expected = linear_blend_of_one_bone(self.obj, self.rig, h.bone, self.rest[rows])
            # The targets (float64) to 1e-9 of the size; the mesh holds them to float32's rounding.
            np.testing.assert_allclose(targets[h.start:h.stop], expected, atol=1e-9 * self.size)
            np.testing.assert_allclose(shown[rows], expected, atol=1e-6 * self.size)
        # Vertices weighted fully to one bone sit where the Armature modifier put them (seen with it on).
        api.set_auto(self.obj, False)
        self.assertEqual((modifier.show_viewport, modifier.show_render), (True, True))
        self.assertEqual(self.obj.arap.armature_muted, "")
        np.testing.assert_array_equal(U.coords(self.obj), self.rest)   # the base mesh at rest, bit for bit
        by_modifier = U.evaluated_coords(self.obj)
        for name in ("B0", "B2"):
            full = weighted_fully(self.obj, name)
            np.testing.assert_allclose(shown[full], by_modifier[full], atol=1e-5 * self.size)

    def test_the_start_shape_is_blenders_preserve_volume_skin(self):
        # Each solve of a rig starts from its dual quaternion skin (solver/skinning.py): the pose Blender's
        # Armature modifier gives with Preserve Volume, from the same weights.
        self.make_handles()
        bend_and_twist(self.rig, bend=70.0, twist=150.0)
        read = problem.Problem(self.obj, bpy.context.scene)
        start = read.start_shape(read.pose(self.obj).transforms)
        self.obj.modifiers["Armature"].use_deform_preserve_volume = True
        np.testing.assert_allclose(start, U.evaluated_coords(self.obj), atol=1e-5 * self.size)
        # Read in steps (Auto mode in the viewport), the same weights and start.
        stepped = meshio.finish(problem.Problem.read_in_steps(self.obj, bpy.context.scene))
        np.testing.assert_array_equal(stepped.skinned.weights, read.skinned.weights)
        np.testing.assert_array_equal(stepped.start_shape(read.pose(self.obj).transforms), start)
        # Live goes on from its last pose: its Problem reads no weights for a start.
        self.assertIsNone(problem.Problem(self.obj, bpy.context.scene, cold_starts=False).skinned)
        # Without bone handles there is none: the solver's own first guess (the Start setting).
        self.obj.arap.handles.clear()
        self.obj.arap.fixed_group = "B0"
        self.assertIsNone(problem.Problem(self.obj, bpy.context.scene).start_shape([]))

    def test_an_armature_parent_is_muted_and_restored(self):
        self.obj.parent_type = 'ARMATURE'
        self.obj.modifiers.remove(self.obj.modifiers["Armature"])
        bpy.context.view_layer.update()
        world = U.np_matrix(self.obj.matrix_world)
        self.make_handles()
        bend_and_twist(self.rig)
        api.set_auto(self.obj, True)
        self.assertEqual(self.obj.parent_type, 'OBJECT')
        np.testing.assert_allclose(U.np_matrix(self.obj.matrix_world), world, atol=1e-6)
        np.testing.assert_allclose(U.evaluated_coords(self.obj), U.coords(self.obj), atol=0)   # nothing on top
        api.set_auto(self.obj, False)
        self.assertEqual(self.obj.parent_type, 'ARMATURE')

    def problem(self):
        return auto._posers[self.obj.as_pointer()].problem

    def test_auto_follows_keyframes_and_a_frame_depends_on_the_frame_alone(self):
        self.make_handles()
        bone = self.rig.pose.bones["B2"]
        bone.rotation_mode = 'XYZ'
        for frame, angle in ((1, 0.0), (10, 180.0)):
            bone.rotation_euler = (0.0, math.radians(angle), 0.0)
            bone.keyframe_insert("rotation_euler", frame=frame)
        api.set_auto(self.obj, True)
        scene = bpy.context.scene
        scene.frame_set(7)
        at_7 = U.coords(self.obj).copy()
        self.assertGreater(np.abs(at_7 - self.rest).max(), 0.1 * self.size)
        for frame in (3, 10, 7):
            scene.frame_set(frame)
        np.testing.assert_array_equal(U.coords(self.obj), at_7)
        auto.forget()   # a new machine: frame 7 first
        scene.frame_set(7)
        np.testing.assert_array_equal(U.coords(self.obj), at_7)

    def test_auto_follows_an_ik_target(self):
        self.make_handles()
        target = U.add_empty("IK target", Matrix.Translation((2.0, -0.3, 2.0)))
        ik = self.rig.pose.bones["B2"].constraints.new('IK')
        ik.target, ik.chain_count = target, 2
        api.set_auto(self.obj, True)
        first = U.coords(self.obj).copy()
        target.location = (2.0, 1.5, 1.0)
        bpy.context.view_layer.update()
        self.assertGreater(np.abs(U.coords(self.obj) - first).max(), 0.05 * self.size)
        setup = self.problem().setup
        h = setup.handles[2]
        rows = setup.constrained[h.start:h.stop]
        expected = linear_blend_of_one_bone(self.obj, self.rig, "B2", self.rest[rows])
        np.testing.assert_allclose(U.coords(self.obj)[rows], expected, atol=1e-6 * self.size)

    def assert_stopped_at_rest(self, *words):
        self.assertFalse(self.obj.arap.auto)
        for word in words:
            self.assertIn(word, self.obj.arap.auto_status)
        np.testing.assert_array_equal(U.coords(self.obj), self.rest)
        modifier = self.obj.modifiers["Armature"]
        self.assertEqual((modifier.show_viewport, modifier.show_render), (True, True))

    def test_a_renamed_bone_stops_auto_with_a_message_and_the_mesh_at_rest(self):
        self.make_handles()
        bend_and_twist(self.rig)
        api.set_auto(self.obj, True)
        self.rig.data.bones["B2"].name = "Hand"
        bpy.context.view_layer.update()
        self.assert_stopped_at_rest("'B2'", "renamed or deleted", "Handles from Armature")
        with self.assertRaisesRegex(SetupError, "'B2'"):
            api.deform(self.obj)

    def test_a_deleted_bone_stops_auto_with_a_message_and_the_mesh_at_rest(self):
        self.make_handles()
        bend_and_twist(self.rig)
        api.set_auto(self.obj, True)
        bpy.context.view_layer.objects.active = self.rig
        bpy.ops.object.mode_set(mode='EDIT')
        self.rig.data.edit_bones.remove(self.rig.data.edit_bones["B2"])
        bpy.ops.object.mode_set(mode='OBJECT')
        bpy.context.view_layer.update()
        self.assert_stopped_at_rest("'B2'", "renamed or deleted")

    def test_a_deleted_armature_stops_auto_with_a_message(self):
        self.make_handles()
        api.set_auto(self.obj, True)
        bpy.data.objects.remove(self.rig)
        bpy.context.view_layer.update()
        self.assertFalse(self.obj.arap.auto)
        self.assertIn("armature", self.obj.arap.auto_status)
        np.testing.assert_array_equal(U.coords(self.obj), self.rest)

    def test_a_bone_that_follows_the_mesh_is_a_dependency_loop(self):
        self.make_handles()
        c = self.rig.pose.bones["B2"].constraints.new('COPY_LOCATION')
        c.target = self.obj
        with self.assertRaisesRegex(SetupError, "bone 'B2' of 'Rig'"):
            api.deform(self.obj)

    def test_the_operator_is_one_undo_step(self):
        bpy.ops.ed.undo_push(message="before")
        groups = [g.name for g in self.obj.vertex_groups]
        self.assertEqual(bpy.ops.object.arap_handles_from_armature('INVOKE_DEFAULT', True), {'FINISHED'})
        self.assertEqual(len(bpy.data.objects["Tube"].arap.handles), 3)
        bpy.ops.ed.undo()
        obj = bpy.data.objects["Tube"]
        self.assertEqual(len(obj.arap.handles), 0)
        self.assertEqual([g.name for g in obj.vertex_groups], groups)
        bpy.ops.ed.redo()
        self.assertEqual(len(bpy.data.objects["Tube"].arap.handles), 3)
        self.obj = bpy.data.objects["Tube"]

    def test_live_cancel_puts_the_bones_and_the_modifier_back(self):
        self.make_handles()
        session = api.start_session(self.obj)
        channels = {b.name: tuple(b.rotation_quaternion) for b in self.rig.pose.bones}
        bend_and_twist(self.rig)
        session.step()
        self.assertFalse(self.obj.modifiers["Armature"].show_viewport)
        self.assertGreater(np.abs(U.coords(self.obj) - self.rest).max(), 0.1 * self.size)
        session.cancel()
        self.assertEqual({b.name: tuple(b.rotation_quaternion) for b in self.rig.pose.bones}, channels)
        self.assertEqual([b.rotation_mode for b in self.rig.pose.bones], ['QUATERNION'] * 3)
        self.assertTrue(self.obj.modifiers["Armature"].show_viewport)
        np.testing.assert_array_equal(U.coords(self.obj), self.rest)

    def test_deform_mutes_the_modifier_until_reset_to_rest(self):
        self.make_handles()
        bend_and_twist(self.rig, twist=90.0)
        api.deform(self.obj)
        np.testing.assert_allclose(U.evaluated_coords(self.obj), U.coords(self.obj), atol=0)
        api.reset(self.obj)
        self.assertTrue(self.obj.modifiers["Armature"].show_viewport)
        np.testing.assert_array_equal(U.coords(self.obj), self.rest)
        # Reset binds the bones at their rest pose again: the next Deform poses the rig's pose, not the rest.
        api.deform(self.obj)
        self.assertGreater(np.abs(U.coords(self.obj) - self.rest).max(), 0.1 * self.size)

    def test_the_bake_bakes_the_rigs_frames_as_auto_poses_them(self):
        self.make_handles()
        bone = self.rig.pose.bones["B1"]
        bone.rotation_mode = 'XYZ'
        for frame, angle in ((1, 0.0), (4, 90.0)):
            bone.rotation_euler = (math.radians(angle), 0.0, 0.0)
            bone.keyframe_insert("rotation_euler", frame=frame)
        api.bake_shape_keys(self.obj, 1, 4)
        keys = self.obj.data.shape_keys.key_blocks
        baked = np.empty(3 * len(self.rest), np.float32)
        keys[-1].data.foreach_get("co", baked)
        api.clear_bake(self.obj)
        api.set_auto(self.obj, True)
        bpy.context.scene.frame_set(4)
        np.testing.assert_allclose(baked.reshape(-1, 3), U.coords(self.obj), atol=1e-5 * self.size)


if __name__ == "__main__":
    unittest.main()
