# Hostile inputs to the native module and hostile Blender set-ups:
# each ends in a typed error with a one-line message, writes nothing, and
# leaves the mesh (coordinates, shape keys, attributes) exactly as it was.
import os
import tempfile
import time
import unittest

import bmesh
import bpy
import numpy as np
from mathutils import Matrix

import arap_test_utils as U

api, errors, live, native_loader, sessions = U.addon("api", "errors", "live", "native_loader", "sessions")


def tube_arrays():
    """A small open tube (float64 rest, int triangles) with its two end rings constrained."""
    around, rings = 8, 5
    t = np.linspace(0, 2 * np.pi, around, endpoint=False)
    rest = np.array([(np.cos(a), np.sin(a), 2.0 * r / (rings - 1)) for r in range(rings) for a in t])
    tris = []
    for r in range(rings - 1):
        for a in range(around):
            v00, v01 = r * around + a, r * around + (a + 1) % around
            tris += [(v00, v01, v01 + around), (v00, v01 + around, v00 + around)]
    constrained = np.array(list(range(around)) + list(range((rings - 1) * around, rings * around)))
    return rest, np.array(tris), constrained



def flip_a_face(obj):
    """Reverse one face's corners: the same vertex count, edges and faces, other connectivity."""
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    bm.faces.ensure_lookup_table()
    bm.faces[3].normal_flip()
    bm.to_mesh(obj.data)
    bm.free()

class ModuleCalls(unittest.TestCase):
    """The native module called directly with what a script could pass it."""

    def setUp(self):
        self.mod = native_loader.native()
        self.rest, self.tris, self.constrained = tube_arrays()
        self.solver = self.mod.Solver()
        self.solver.bind(self.rest, self.tris, self.constrained)
        self.targets = self.rest[self.constrained].copy()
        self.targets[8:, 0] += 0.5
        self.solver.solve(self.targets)
        self.before = self.solver.positions().copy()

    def assert_refused(self, call, types=None, keeps_solution=True):
        types = types or (self.mod.ArapError, ValueError, TypeError)
        with self.assertRaises(types) as cm:
            call()
        msg = str(cm.exception)
        self.assertTrue(msg and "\n" not in msg, repr(msg))
        if keeps_solution:  # a refused call leaves the last solution as it was
            np.testing.assert_array_equal(self.solver.positions(), self.before)
        return cm.exception

    def test_hostile_binds(self):
        rest, tris, con = self.rest, self.tris, self.constrained
        nan_rest = rest.copy()
        nan_rest[3, 1] = np.nan
        inf_rest = rest.copy()
        inf_rest[5, 2] = -np.inf
        cases = {
            "NaN rest": (nan_rest, tris, con, {}),
            "Inf rest": (inf_rest, tris, con, {}),
            "rest (n, 2)": (rest[:, :2], tris, con, {}),
            "rest of ints": (rest.astype(np.int32), tris, con, {}),
            "rest of objects": (rest.astype(object), tris, con, {}),
            "no vertices": (np.empty((0, 3)), tris, con, {}),
            "no triangles": (rest, np.empty((0, 3), np.int64), con, {}),
            "triangle index out of range": (rest, np.where(tris == 7, 999, tris), con, {}),
            "negative triangle index": (rest, np.where(tris == 7, -1, tris), con, {}),
            "triangle index 2^40": (rest, np.where(tris == 7, 2 ** 40, tris), con, {}),
            "triangles (m, 4)": (rest, np.hstack([tris, tris[:, :1]]), con, {}),
            "duplicate constraint": (rest, tris, np.append(con, con[0]), {}),
            "constraint out of range": (rest, tris, np.append(con, 10 ** 6), {}),
            "constraints 2-D": (rest, tris, con.reshape(2, -1), {}),
            "no constraints": (rest, tris, np.empty(0, np.int64), {}),
            "NaN stiffness": (rest, tris, con, {"stiffness": np.full(len(rest), np.nan)}),
            "zero stiffness": (rest, tris, con, {"stiffness": np.zeros(len(rest))}),
            "short stiffness": (rest, tris, con, {"stiffness": np.ones(3)}),
            "unknown weights": (rest, tris, con, {"weights": "nonsense"}),
            "unknown init": (rest, tris, con, {"init": "sideways"}),
            "negative iterations": (rest, tris, con, {"max_iterations": -1}),
            "NaN tolerance": (rest, tris, con, {"tolerance": float("nan")}),
            "zero threads": (rest, tris, con, {"threads": 0}),
            "Anderson window 1000": (rest, tris, con, {"anderson_window": 1000}),
        }
        for name, (r, t, c, kw) in cases.items():
            with self.subTest(name):
                self.assert_refused(lambda: self.solver.bind(r, t, c, **kw))
        # A refused bind keeps the previous one.
        self.solver.solve(self.targets)
        np.testing.assert_array_equal(self.solver.positions(), self.before)

    def test_hostile_solves(self):
        out = np.full(len(self.rest) * 3, 7.0, np.float32)
        nan_targets = self.targets.copy()
        nan_targets[2, 0] = np.nan
        cases = {
            "NaN target": lambda: self.solver.solve(nan_targets, out=out),
            "too few targets": lambda: self.solver.solve(self.targets[:-1], out=out),
            "out of the wrong size": lambda: self.solver.solve(self.targets, out=np.empty(5, np.float32)),
            "out of ints": lambda: self.solver.solve(self.targets, out=np.empty(len(out), np.int32)),
            "out not contiguous": lambda: self.solver.solve(self.targets, out=np.empty((len(self.rest), 6))[:, ::2]),
            "out read-only": lambda: self.solver.solve(self.targets, out=np.frombuffer(bytes(out.nbytes), np.float32)),
            "out a list": lambda: self.solver.solve(self.targets, out=[0.0] * len(out)),
        }
        for name, call in cases.items():
            with self.subTest(name):
                self.assert_refused(call)
                self.assertTrue(np.all(out == 7.0), "the out buffer was written")
        # The solve itself succeeds in double precision (the solver keeps that
        # result as its warm start), but a float32 buffer receives nothing.
        self.assert_refused(lambda: self.solver.solve(self.targets + 5e38, out=out), keeps_solution=False)
        self.assertTrue(np.all(out == 7.0), "the out buffer was written")

    def test_float32_overflow_names_the_vertex(self):
        out = np.zeros(len(self.rest) * 3, np.float32)
        with self.assertRaises(self.mod.ArapError) as cm:
            self.solver.solve(self.targets * 1e39, out=out)
        self.assertIn("float32", str(cm.exception))
        self.assertEqual(cm.exception.code, "non-finite value")
        self.assertTrue(np.all(out == 0.0))
        # float64 holds it: the same solve succeeds into a double buffer, finite.
        out64 = np.zeros(len(self.rest) * 3)
        self.solver.solve(self.targets * 1e39, out=out64)
        self.assertTrue(np.all(np.isfinite(out64)))

    def test_energy_functions_refuse_non_finite_positions(self):
        for bad in (np.nan, np.inf):
            p = self.rest.copy()
            p[4, 0] = bad
            for fn in (self.solver.energy, self.solver.energy_gradient, self.solver.set_positions):
                with self.subTest(fn=fn.__name__, value=bad):
                    exc = self.assert_refused(lambda: fn(p), self.mod.ArapError)
                    self.assertEqual(exc.code, "non-finite value")
        self.assert_refused(lambda: self.solver.energy(self.rest[:-1]), self.mod.ArapError)

    def test_statistics_are_finite(self):
        self.solver.init = "warm"
        self.solver.anderson_window = 3
        self.targets[8:, 1] += 0.1
        stats = self.solver.solve(self.targets)  # reuses the last rotations
        self.assertTrue(np.isfinite(stats.initial_energy))
        self.solver.max_iterations = 0
        stats = self.solver.solve(self.targets)
        self.assertTrue(np.isfinite(stats.initial_energy))
        self.assertAlmostEqual(stats.initial_energy, self.solver.energy(self.solver.positions()), places=12)

    def test_solve_before_bind(self):
        with self.assertRaises(self.mod.ArapError) as cm:
            self.mod.Solver().solve(self.targets)
        self.assertEqual(cm.exception.code, "not bound")


class BlenderSetups(unittest.TestCase):
    """Hostile scenes for api.deform, the Live session and the operators."""

    def setUp(self):
        U.clear_scene()
        self.obj, self.empty, self.fixed, self.top = U.bar_with_handle()
        self.before = U.raw_coords(self.obj).copy()

    def assert_untouched(self, obj=None):
        obj = obj or self.obj
        self.assertTrue(np.array_equal(U.raw_coords(obj), self.before), "the mesh was changed")
        self.assertIsNone(obj.data.shape_keys)
        self.assertNotIn("arap_rest", obj.data.attributes)

    def assert_refused(self, call, types=(api.SetupError,), *fragments):
        with self.assertRaises(types) as cm:
            call()
        msg = str(cm.exception)
        self.assertNotIn("\n", msg)
        for f in fragments:
            self.assertIn(f, msg)
        self.assert_untouched()
        return msg

    def test_catalogue(self):
        """Each set-up is refused by api.deform and by starting a Live session."""
        def nan_empty():
            self.empty.location.x = float("nan")

        def nan_empty_rotation():
            self.empty.rotation_euler.z = float("nan")

        def nan_object():
            self.obj.location.y = float("nan")

        def nan_bind_pose():
            self.obj.arap.handles[0].bind_matrix[5] = float("nan")

        def zero_scale_object():
            self.obj.scale = (0.0, 0.0, 0.0)

        def flat_object():
            self.obj.scale = (1.0, 0.0, 1.0)

        def zero_scale_empty_at_bind():
            self.empty.scale = (0.0, 0.0, 0.0)
            bpy.context.view_layer.update()
            api.reset(self.obj)  # takes the (singular) bind pose
            self.empty.scale = (1.0, 1.0, 1.0)

        def far_beyond_float32():
            self.obj.scale = (1e-20, 1e-20, 1e-20)
            bpy.context.view_layer.update()
            api.reset(self.obj)
            self.empty.location.x += 1e20  # 1e40 in the object's space

        def no_faces():
            bm = bmesh.new()
            bm.from_mesh(self.obj.data)
            bmesh.ops.delete(bm, geom=list(bm.faces), context='FACES_ONLY')
            bm.to_mesh(self.obj.data)
            bm.free()
            self.before = U.raw_coords(self.obj).copy()

        def stiff_group_missing():
            self.obj.arap.stiff_group = "nowhere"

        def empty_is_the_object():
            self.obj.arap.handles[0].empty = None

        arap_error = native_loader.native().ArapError
        cases = [
            ("NaN empty location", nan_empty, (api.SetupError, arap_error), ""),
            ("NaN empty rotation", nan_empty_rotation, (api.SetupError, arap_error), ""),
            ("NaN object location", nan_object, (api.SetupError, arap_error), ""),
            ("NaN stored bind pose", nan_bind_pose, (api.SetupError, arap_error), ""),
            ("zero-scale object", zero_scale_object, api.SetupError, "zero scale"),
            ("object flattened to a plane", flat_object, api.SetupError, "zero scale"),
            ("zero-scale empty at bind", zero_scale_empty_at_bind, api.SetupError, "bind pose of handle 'top'"),
            ("pose beyond float32", far_beyond_float32, api.SetupError, "Handle 'top' would move its vertices"),
            ("no faces", no_faces, api.SetupError, "no faces"),
            ("stiff group missing", stiff_group_missing, api.SetupError, "nowhere"),
            ("handle without empty", empty_is_the_object, api.SetupError, "no empty"),
        ]
        for name, make, types, fragment in cases:
            for entry in ("deform", "live"):
                with self.subTest(name, entry=entry):
                    self.setUp()
                    make()
                    bpy.context.view_layer.update()
                    if entry == "deform":
                        call = lambda: api.deform(self.obj)  # noqa: E731
                    else:
                        call = lambda: api.start_session(self.obj, bpy.context.scene).step()  # noqa: E731
                    msg = self.assert_refused(call, types)
                    self.assertIn(fragment, msg)
                    self.assertIsNone(sessions.session_for(self.obj) if entry == "deform" else None)
                    sessions.stop_all_sessions()
                    self.assert_untouched()

    def test_live_step_beyond_float32_leaves_the_last_pose(self):
        self.obj.scale = (1e-20, 1e-20, 1e-20)
        bpy.context.view_layer.update()
        api.reset(self.obj)
        s = api.start_session(self.obj, bpy.context.scene)
        self.empty.location.x += 1e-20
        s.step()
        posed = U.raw_coords(self.obj).copy()
        self.empty.location.x += 1e20
        with self.assertRaises(api.SetupError):   # beyond what float32 can hold the mesh's shape at
            s.step()
        self.assertTrue(np.all(np.isfinite(U.raw_coords(self.obj))))
        np.testing.assert_array_equal(U.raw_coords(self.obj), posed)
        s.cancel()
        self.assert_untouched()

    def test_second_live_session_on_one_object_is_refused(self):
        s = api.start_session(self.obj, bpy.context.scene)
        self.empty.location.x += 0.7
        s.step()
        self.assertFalse(np.array_equal(U.raw_coords(self.obj), self.before))
        with self.assertRaises(api.SetupError) as cm:
            api.start_session(self.obj, bpy.context.scene)
        self.assertIn("already being posed", str(cm.exception))
        s.cancel()
        self.assert_untouched()
        # Once the first ends, a new one may start.
        api.start_session(self.obj, bpy.context.scene).cancel()

    def test_step_reads_empties_moved_by_a_script(self):
        s = api.start_session(self.obj, bpy.context.scene, max_iterations=30)
        s.step()
        self.empty.location.x += 0.8  # no view_layer.update(): matrix_world is stale until the depsgraph runs
        s.step()
        moved = U.coords(self.obj)[self.top][:, 0] - self.before.reshape(-1, 3)[self.top][:, 0]
        np.testing.assert_allclose(moved, 0.8, atol=1e-5)
        s.cancel()

    def test_topology_change_with_the_same_vertex_count_stops_live(self):
        s = api.start_session(self.obj, bpy.context.scene)
        s.step()
        bm = bmesh.new()
        bm.from_mesh(self.obj.data)
        inner = [e for e in bm.edges if len(e.link_faces) == 2 and all(len(f.verts) == 4 for f in e.link_faces)]
        bmesh.ops.rotate_edges(bm, edges=inner[:1], use_ccw=True)
        n = len(bm.verts)
        bm.to_mesh(self.obj.data)
        bm.free()
        self.assertEqual(len(self.obj.data.vertices), n)
        # Applying compares the faces in full; a step does within TOPOLOGY_CHECK_S.
        with self.assertRaises(errors.SessionError) as cm:
            s.finish()
        self.assertEqual(cm.exception.kind, 'TOPOLOGY')
        self.assertIn("faces changed", str(cm.exception))
        self.assertIsNone(sessions.session_for(self.obj))
        self.assertNotIn("arap_rest", self.obj.data.attributes)
        s = api.start_session(self.obj, bpy.context.scene)
        flip_a_face(self.obj)
        time.sleep(live.TOPOLOGY_CHECK_S)
        with self.assertRaises(errors.SessionError) as cm:
            s.step()
        self.assertEqual(cm.exception.kind, 'TOPOLOGY')
        sessions.stop_session(s)

    def test_where_reading_the_corners_is_slow_they_are_compared_once_the_pose_settles(self):
        # Blender 3.4 reads a big mesh's corners in tens of milliseconds: an update that moves the
        # pose only compares counts, a settled one the corners as well.
        s = api.start_session(self.obj, bpy.context.scene)
        s.topology.cheap = False
        self.empty.location.x += 0.5
        bpy.context.view_layer.update()
        s.solver.max_iterations = 1
        s.step()
        self.assertFalse(s.converged)
        flip_a_face(self.obj)
        s._next_topology_check = 0.0     # a check is due
        s.step()                         # not settled: counts only
        s.solver.max_iterations = 1000
        with self.assertRaises(errors.SessionError) as cm:
            for _ in range(100):
                s.step()
                s._next_topology_check = 0.0
        self.assertEqual(cm.exception.kind, 'TOPOLOGY')
        sessions.stop_session(s)

    def test_linked_library_mesh_is_refused_and_untouched(self):
        with tempfile.TemporaryDirectory() as folder:
            path = os.path.join(folder, "library.blend")
            bpy.data.libraries.write(path, {self.obj, self.obj.data, self.empty})
            with bpy.data.libraries.load(path, link=True) as (src, dst):
                dst.objects = ["Bar"]
            linked = dst.objects[0]
            bpy.context.scene.collection.objects.link(linked)
            local_on_linked_mesh = bpy.data.objects.new("LocalOnLinked", linked.data)
            bpy.context.scene.collection.objects.link(local_on_linked_mesh)
            bpy.context.view_layer.update()
            for obj in (linked, local_on_linked_mesh):
                for call in (api.deform, api.bind, lambda o: api.start_session(o, bpy.context.scene),
                             api.reset, api.set_rest_pose):
                    with self.subTest(obj=obj.name, call=getattr(call, "__name__", "start_session")):
                        with self.assertRaises(api.SetupError) as cm:
                            call(obj)
                        self.assertIn("linked from the library", str(cm.exception))
                        np.testing.assert_array_equal(U.raw_coords(linked), self.before)
                        self.assertNotIn("arap_rest", linked.data.attributes)
                        self.assertIsNone(linked.data.shape_keys)
            bpy.data.objects.remove(local_on_linked_mesh)
            bpy.data.objects.remove(linked)


if __name__ == "__main__":
    unittest.main()
