# One-shot Deform: equals the native module's direct result, honours object and
# empty transforms, triangulates quads/n-gons, writes a shape key when asked,
# ends at a stationary point of the ARAP energy.
import unittest

import bpy
import numpy as np
from mathutils import Euler, Matrix

import arap_test_utils as U

api, native_loader, problem = U.addon("api", "native_loader", "problem")


def posed_empty_matrix():
    return Matrix.Translation((0.6, -0.3, 1.7)) @ Euler((0.4, 0.2, 0.7)).to_matrix().to_4x4()


class Deform(unittest.TestCase):
    def setUp(self):
        U.clear_scene()

    def native_reference(self, obj, fixed, handle, empty_bind, empty_now, iterations, init="naive",
                         tolerance=0.0):
        """Bind and solve with the native module directly, targets computed here."""
        rest = U.coords(obj)
        m_obj = U.np_matrix(obj.matrix_world)
        a = np.linalg.inv(m_obj) @ U.np_matrix(empty_now) @ np.linalg.inv(U.np_matrix(empty_bind)) @ m_obj
        constrained = np.concatenate([fixed, handle])
        targets = np.concatenate([rest[fixed], U.apply(a, rest[handle])])
        s = native_loader.native().Solver()
        s.bind(rest, U.triangles(obj), constrained, weights="cotan-clamped", init=init,
               max_iterations=iterations, tolerance=tolerance, anderson_window=obj.arap.anderson_window,
               method=problem.METHOD_NAMES[obj.arap.method], volume=problem.VOLUME_NAMES[obj.arap.volume])
        s.solve(targets)
        return s, rest, constrained, targets

    def test_equals_native_direct_result(self):
        obj, empty, fixed, top = U.bar_with_handle()
        bind = empty.matrix_world.copy()
        empty.matrix_world = posed_empty_matrix()
        s, _rest, _c, _t = self.native_reference(obj, fixed, top, bind, empty.matrix_world, 10, tolerance=1e-6)
        result = bpy.ops.object.arap_deform(max_iterations=10)
        self.assertEqual(result, {'FINISHED'})
        np.testing.assert_allclose(U.coords(obj), s.positions(), atol=1e-5)

    def test_operator_redo_properties_and_result(self):
        obj, empty, _f, _t = U.bar_with_handle()
        empty.location.x += 0.5
        r = api.deform(obj, max_iterations=3, tolerance=0.0)
        self.assertEqual(r.iterations, 3)
        self.assertEqual(len(r.energies), 3)
        self.assertEqual(r.output, 'MESH')
        self.assertGreaterEqual(r.bind_ms, 0.0)
        self.assertTrue(r.energies[-1] <= r.initial_energy + 1e-9)
        r2 = api.deform(obj, max_iterations=3, tolerance=0.0)
        self.assertTrue(r2.cached_bind, "the second deform with unchanged inputs reuses the bind")

    def test_the_old_iterations_keyword_still_caps_with_a_deprecation_warning(self):
        obj, empty, _f, _t = U.bar_with_handle()
        empty.location.x += 0.5
        with self.assertWarns(DeprecationWarning) as cm:
            r = api.deform(obj, iterations=2, tolerance=0.0)
        self.assertEqual(r.iterations, 2)
        self.assertIn("max_iterations=", str(cm.warning))
        self.assertTrue(cm.filename.endswith("test_deform.py"), cm.filename)   # the caller's line
        with self.assertWarns(DeprecationWarning):
            session = api.start_session(obj, bpy.context.scene, iterations=1, write=False)
        self.assertEqual(session.solver.max_iterations, 1)
        session.cancel()
        with self.assertRaises(TypeError), self.assertWarns(DeprecationWarning):
            api.deform(obj, max_iterations=2, iterations=2)

    def test_two_threads_give_the_one_thread_result(self):
        # 64 x 42 vertices: enough for the per-vertex passes to run on two threads.
        obj, empty, _f, _t = U.bar_with_handle(vertices=64, cuts=40)
        self.assertGreater(len(obj.data.vertices), 2048)
        rest = U.coords(obj)
        empty.matrix_world = posed_empty_matrix()
        shapes = []
        for threads in (1, 2, 1, 2):
            obj.arap.threads = threads
            r = api.deform(obj, max_iterations=20, tolerance=0.0)
            self.assertEqual(r.iterations, 20)
            shapes.append(U.coords(obj))
        self.assertGreater(np.abs(shapes[0] - rest).max(), 0.5)  # it did move
        for shape in shapes[1:]:
            np.testing.assert_array_equal(shape, shapes[0])

    def test_last_result_reports_the_operator_run(self):
        obj, empty, _f, _t = U.bar_with_handle()
        self.assertIsNone(api.last_result(obj))
        empty.location.x += 0.5
        self.assertEqual(bpy.ops.object.arap_deform(max_iterations=7), {'FINISHED'})
        last = api.last_result(obj)
        self.assertIsNotNone(last)
        self.assertLessEqual(last.iterations, 7)
        self.assertEqual(len(last.energies), last.iterations)
        self.assertLess(last.energy, last.initial_energy)

    def test_reset_and_set_rest_pose_operators(self):
        obj, empty, _f, _t = U.bar_with_handle()
        rest = U.coords(obj)
        empty.location.x += 0.5
        self.assertEqual(bpy.ops.object.arap_deform(), {'FINISHED'})
        posed = U.coords(obj)
        self.assertEqual(bpy.ops.object.arap_reset(), {'FINISHED'})
        np.testing.assert_array_equal(U.coords(obj), rest)
        self.assertEqual(bpy.ops.object.arap_deform(), {'FINISHED'})  # the empty's pose is the new bind pose
        np.testing.assert_allclose(U.coords(obj), rest, atol=1e-6)
        empty.location.x += 0.5
        bpy.ops.object.arap_deform()
        np.testing.assert_allclose(U.coords(obj), posed, atol=1e-5)  # the same move again
        self.assertEqual(bpy.ops.object.arap_set_rest_pose(), {'FINISHED'})
        bpy.ops.object.arap_deform()
        np.testing.assert_allclose(U.coords(obj), posed, atol=1e-6)  # nothing moved since the new rest

    def test_stiff_group_bends_less(self):
        def middle_bend(stiff):
            U.clear_scene()
            obj, empty, _f, _t = U.bar_with_handle()
            U.group_where(obj, "torso", lambda co: -0.8 < co.z < 0.8)
            if stiff:
                obj.arap.stiff_group = "torso"
                obj.arap.stiffness = 50.0
            rest = U.coords(obj)
            empty.location.x += 1.0
            api.deform(obj)
            posed = U.coords(obj)
            middle = np.abs(rest[:, 2]) < 0.8
            # How far the middle departs from a rigid motion: residual of the best affine fit.
            a = np.c_[rest[middle], np.ones(middle.sum())]
            fit, *_ = np.linalg.lstsq(a, posed[middle], rcond=None)
            return np.abs(a @ fit - posed[middle]).max()
        self.assertLess(middle_bend(True), 0.5 * middle_bend(False))

    def test_missing_stiff_group_is_a_setup_error(self):
        obj, empty, _f, _t = U.bar_with_handle()
        obj.arap.stiff_group = "nope"
        rest = U.coords(obj)
        empty.location.x += 0.5
        with self.assertRaises(api.SetupError):
            api.deform(obj)
        np.testing.assert_array_equal(U.coords(obj), rest)

    def test_repeat_deform_uses_rest_not_previous_result(self):
        obj, empty, _f, _t = U.bar_with_handle()
        rest = U.coords(obj)
        empty.location.x += 0.5
        api.deform(obj, max_iterations=5)
        first = U.coords(obj)
        api.deform(obj, max_iterations=5)
        np.testing.assert_array_equal(U.coords(obj), first)
        api.reset(obj)
        np.testing.assert_array_equal(U.coords(obj), rest)

    def test_set_rest_pose_takes_current_shape(self):
        obj, empty, _f, top = U.bar_with_handle()
        empty.location.x += 0.5
        api.deform(obj)
        posed = U.coords(obj)
        api.set_rest_pose(obj)  # posed shape = new rest, empty's pose = new bind pose
        api.deform(obj)
        np.testing.assert_allclose(U.coords(obj), posed, atol=1e-6)
        api.reset(obj)
        np.testing.assert_array_equal(U.coords(obj), posed)

    def test_rigid_motion_of_everything_constrained(self):
        obj = U.add_cylinder()
        obj.matrix_world = (Matrix.Translation((1.0, 2.0, -0.5)) @ Euler((0.3, -0.5, 1.1)).to_matrix().to_4x4()
                            @ Matrix.Scale(1.5, 4))
        U.group_where(obj, "ends", lambda co: abs(co.z) > 1.5)
        empty = U.add_empty("E", Matrix.Translation((0.2, 0.1, 0.3)) @ Euler((0.1, 0.2, 0.3)).to_matrix().to_4x4())
        api.add_handle(obj, "ends", empty)
        rest = U.coords(obj)
        motion = Matrix.Translation((0.4, -1.0, 0.8)) @ Euler((0.7, 0.1, -0.4)).to_matrix().to_4x4()
        empty.matrix_world = motion @ empty.matrix_world
        r = api.deform(obj, max_iterations=150, tolerance=0.0)  # large rotation: ARAP converges slowly
        m_obj = U.np_matrix(obj.matrix_world)
        expected = U.apply(np.linalg.inv(m_obj) @ U.np_matrix(motion) @ m_obj, rest)
        np.testing.assert_allclose(U.coords(obj), expected, atol=2e-5)
        self.assertLess(r.energy, 1e-8)

    def test_scaled_empty_moves_handle_vertices_by_full_transform(self):
        obj, empty, _fixed, top = U.bar_with_handle()
        obj.matrix_world = Matrix.Translation((0, 0, 1)) @ Euler((0.0, 0.0, 0.6)).to_matrix().to_4x4()
        api.reset(obj)  # the empty's bind pose is captured again
        rest = U.coords(obj)
        bind = empty.matrix_world.copy()
        empty.matrix_world = (Matrix.Translation((0.3, 0.0, 0.4)) @ Euler((0.5, 0.0, 0.0)).to_matrix().to_4x4()
                              @ Matrix.Scale(1.3, 4)) @ bind
        api.deform(obj, max_iterations=5)
        m_obj = U.np_matrix(obj.matrix_world)
        a = np.linalg.inv(m_obj) @ U.np_matrix(empty.matrix_world) @ np.linalg.inv(U.np_matrix(bind)) @ m_obj
        np.testing.assert_allclose(U.coords(obj)[top], U.apply(a, rest[top]), atol=1e-5)

    def test_quads_and_ngons_are_triangulated(self):
        obj, empty, _f, _t = U.bar_with_handle()
        self.assertTrue(any(len(p.vertices) > 4 for p in obj.data.polygons), "cylinder caps are n-gons")
        n_loops = len(obj.data.loops)
        empty.location.y += 0.7
        api.deform(obj)
        self.assertEqual(len(obj.data.loops), n_loops, "faces and loops are untouched")
        self.assertTrue(np.isfinite(U.coords(obj)).all())

    def test_shape_key_output_keeps_rest(self):
        obj, empty, _f, top = U.bar_with_handle()
        obj.shape_key_add(name="Basis")
        rest = U.coords(obj)
        empty.location.x += 0.8
        r = api.deform(obj)
        self.assertEqual(r.output, 'SHAPE_KEY')
        key = obj.data.shape_keys.key_blocks["ARAP"]
        self.assertEqual(key.value, 1.0)
        basis = np.empty(len(rest) * 3, np.float32)
        obj.data.shape_keys.reference_key.data.foreach_get("co", basis)
        np.testing.assert_array_equal(basis.reshape(-1, 3), rest.astype(np.float32))
        ev = U.evaluated_coords(obj)
        self.assertGreater(np.abs(ev[top] - rest[top]).max(), 0.5)
        api.reset(obj)
        np.testing.assert_allclose(U.evaluated_coords(obj), rest, atol=1e-6)

    def test_modifiers_above_keep_working(self):
        obj, empty, _f, _t = U.bar_with_handle()
        obj.modifiers.new("sub", 'SUBSURF')
        empty.location.x += 0.5
        api.deform(obj)
        self.assertGreater(len(U.evaluated_coords(obj)), len(obj.data.vertices))

    def test_defaults_converge_on_varied_meshes(self):
        # What a script gets from api.deform(obj) with nothing set: a settled pose
        # (result.converged) on meshes of different kinds, each pulled hard.
        def sphere():
            bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, radius=1.0)
            return bpy.context.active_object

        def grid():
            return U.add_grid(x=40, y=12, size=4.0)

        def monkey():
            bpy.ops.mesh.primitive_monkey_add()
            bpy.ops.object.modifier_add(type='SUBSURF')
            bpy.ops.object.modifier_apply(modifier="Subdivision")
            return bpy.context.active_object

        for make in (U.add_cylinder, sphere, grid, monkey):
            U.clear_scene()
            obj = make()
            co = U.coords(obj)
            axis = int(np.argmax(np.ptp(co, axis=0)))
            low, high = co[:, axis].min(), co[:, axis].max()
            span = high - low
            api.create_group(obj, "low", np.flatnonzero(co[:, axis] < low + 0.1 * span))
            api.create_group(obj, "high", np.flatnonzero(co[:, axis] > high - 0.1 * span))
            api.set_fixed(obj, "low")
            empty = U.add_empty("Pull")
            api.add_handle(obj, "high", empty)
            empty.location = (0.3 * span, 0.2 * span, 0.1 * span)
            result = api.deform(obj)
            with self.subTest(mesh=make.__name__, vertices=len(co)):
                self.assertTrue(result.converged, "%d iterations" % result.iterations)
                self.assertFalse(any("had not settled" in w for w in result.warnings))

    def test_result_is_stationary_point(self):
        obj, empty, fixed, top = U.bar_with_handle()
        obj.arap.volume = 'NONE'    # ARAP's own gradient (Infill's lattice, not given here, is part of its state)
        bind = empty.matrix_world.copy()
        empty.matrix_world = posed_empty_matrix()
        api.deform(obj, max_iterations=300, tolerance=0.0)
        result = U.coords(obj)
        s, rest, constrained, targets = self.native_reference(obj, fixed, top, bind, empty.matrix_world, 1,
                                                              init="naive")
        free = np.setdiff1d(np.arange(len(rest)), constrained)
        start = rest.copy()
        start[constrained] = targets
        g0 = np.linalg.norm(s.energy_gradient(start)[free])
        g = np.linalg.norm(s.energy_gradient(result)[free])
        self.assertGreater(g0, 1e-3)
        # float32 storage in the mesh limits how small the gradient can get.
        self.assertLess(g / g0, 1e-2, "gradient on free vertices %.3g vs initial %.3g" % (g, g0))


class MeshReading(unittest.TestCase):
    """What a bind reads from Blender, read the fast ways: the triangles and the vertex groups."""

    def setUp(self):
        U.clear_scene()
        # Triangles, quads (one concave, which Blender cuts along its other diagonal) and a pentagon.
        verts = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0), (2, 1, 0), (1.9, 0.5, 0.3),
                 (3, 0, 0), (3.2, 0.6, 0), (2.9, 1.2, 0.2), (2.4, 1.5, 0), (0.5, 2, 0)]
        faces = [(0, 1, 2, 3), (1, 4, 6, 5, 2), (4, 7, 8, 6), (6, 8, 9, 10), (3, 2, 11), (2, 5, 10, 11)]
        mesh = bpy.data.meshes.new("Mixed")
        mesh.from_pydata(verts, [], faces)
        mesh.update()
        self.obj = bpy.data.objects.new("Mixed", mesh)
        bpy.context.scene.collection.objects.link(self.obj)

    def test_triangles_are_blenders_own(self):
        meshio = U.addon("meshio")
        mesh = self.obj.data
        mesh.calc_loop_triangles()
        own = np.empty(len(mesh.loop_triangles) * 3, np.int32)
        mesh.loop_triangles.foreach_get("vertices", own)
        np.testing.assert_array_equal(meshio.triangles(mesh), own.reshape(-1, 3))

    def test_groups_read_in_steps_are_read_as_in_one(self):
        meshio = U.addon("meshio")
        a = self.obj.vertex_groups.new(name="a")
        a.add([0, 3, 7], 1.0, 'REPLACE')
        a.add([5], 0.0, 'REPLACE')   # weight 0: not a member
        b = self.obj.vertex_groups.new(name="b")
        b.add([1, 2, 11], 0.25, 'REPLACE')
        b.add([7], 0.5, 'REPLACE')
        steps = meshio.read_groups_in_steps(self.obj, ["a", "b"], weights_of=["b", "missing", "a"], chunk=2)
        yields = 0
        while True:
            try:
                next(steps)
                yields += 1
            except StopIteration as done:
                members, weights = done.value
                break
        self.assertEqual(yields, 5)   # 12 vertices, 2 at a time: a yield between chunks
        self.assertEqual(members["a"].tolist(), [0, 3, 7])
        self.assertEqual(members["b"].tolist(), [1, 2, 7, 11])
        np.testing.assert_array_equal(weights[:, 0], meshio.group_weights(self.obj, "b"))
        np.testing.assert_array_equal(weights[:, 1], 0.0)   # no such group
        np.testing.assert_array_equal(weights[:, 2], meshio.group_weights(self.obj, "a"))
        self.assertEqual((weights[7, 0], weights[7, 2]), (0.5, 1.0))
        self.assertEqual({k: v.tolist() for k, v in meshio.group_members(self.obj, ["a", "b"]).items()},
                         {k: v.tolist() for k, v in members.items()})


if __name__ == "__main__":
    unittest.main()
