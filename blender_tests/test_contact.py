# Self Contact: the surface never passes through itself in the poses Deform, Live,
# Auto mode and the bake make; a handle whose move would make it cross stops short
# and the warning names it; the setting is saved in the .blend and falls back from
# Anderson to Quasi-Newton. Crossings are counted here, with mathutils' BVH, on the
# coordinates the mesh shows, not taken from the solver.
import os
import tempfile
import types
import unittest

import bpy
import numpy as np
from mathutils import Matrix
from mathutils.bvhtree import BVHTree

import arap_test_utils as U

api, auto, bake, live_ops, problem, solver_cache = U.addon("api", "auto", "bake", "live_ops", "problem",
                                                         "solver_cache")

BAR = {"vertices": 16, "cuts": 16}              # 288 vertices: a solve with Self Contact takes well under a second
BIND = Matrix.Translation((0.0, 0.0, 2.0))       # the Empty's bind pose (U.bar_with_handle)
# The top of the 4-high bar brought down beside its bottom, 0.3 apart: free, the bar folds through itself;
# with Self Contact it bends round and the top gets there.
POSE = Matrix.Translation((1.3, 0.0, -0.5))
# The top pushed straight down through the fixed bottom: no pose gets it there without a crossing.
THROUGH = Matrix.Translation((0.0, 0.0, -5.0))
STEPS = 4   # Live's moves, Auto mode's and the bake's frames on the way from BIND to POSE


def crossings(coords, tris):
    """Pairs of triangles that share no vertex and intersect (the BVH's overlap of the mesh with itself)."""
    tree = BVHTree.FromPolygons(coords.tolist(), tris.tolist())
    pairs = {(min(i, j), max(i, j)) for i, j in tree.overlap(tree)}
    return sum(1 for i, j in pairs if not set(tris[i].tolist()) & set(tris[j].tolist()))


def on_the_way(k):
    """The Empty's matrix after k of STEPS equal moves from BIND to POSE."""
    return Matrix.Translation(BIND.translation.lerp(POSE.translation, k / STEPS))


class SelfContact(unittest.TestCase):
    def setUp(self):
        U.clear_scene()
        auto.forget()
        bpy.context.scene.frame_set(1)
        self.obj, self.empty, self.fixed, self.top = U.bar_with_handle(**BAR)
        self.tris = U.triangles(self.obj)
        self.rest = U.coords(self.obj)

    def tearDown(self):
        if self.obj.name in bpy.data.objects and self.obj.arap.auto:
            api.set_auto(self.obj, False)

    def crossings(self, coords=None):
        return crossings(U.evaluated_coords(self.obj) if coords is None else coords, self.tris)

    def deform(self, pose, contact):
        self.empty.matrix_world = BIND
        api.reset(self.obj)   # (captures the Empty's bind pose again)
        self.obj.arap.contact = contact
        self.empty.matrix_world = pose
        return api.deform(self.obj)

    def top_targets(self, pose):
        return U.apply(U.np_matrix(pose) @ np.linalg.inv(U.np_matrix(BIND)), self.rest[self.top])

    def animate(self):
        """Keyframes: the top on its way from BIND to POSE over frames 1..STEPS."""
        for f in range(1, STEPS + 1):
            self.empty.matrix_world = on_the_way(f)
            self.empty.keyframe_insert("location", frame=f)

    def test_deform_never_crosses_and_meets_the_constraints(self):
        self.assertFalse(self.obj.arap.contact)   # the default: existing files pose as before
        free = self.deform(POSE, False)
        self.assertGreater(self.crossings(), 0, "without Self Contact the bar must fold through itself here")
        self.assertEqual(free.contact_reached, 1.0)
        r = self.deform(POSE, True)
        self.assertFalse(r.cached_bind, "a new Self Contact setting binds again")
        coords = U.coords(self.obj)
        self.assertTrue(np.isfinite(coords).all())
        self.assertEqual(self.crossings(), 0)
        # Reachable: the handle's vertices are at their targets, the fixed ones at rest.
        self.assertEqual(r.contact_reached, 1.0)
        np.testing.assert_allclose(coords[self.top], self.top_targets(POSE), atol=1e-5)
        np.testing.assert_allclose(coords[self.fixed], self.rest[self.fixed], atol=1e-6)
        self.assertFalse([w for w in r.warnings if "Self Contact" in w], r.warnings)
        # The report says what Self Contact did: the folded bar is held apart at close pairs.
        self.assertEqual(len(r.notes), 1, r.notes)
        self.assertRegex(r.notes[0], r"^Self Contact held [1-9][0-9]* close pairs of the surface apart$")
        self.assertEqual(free.notes, [])
        solver = solver_cache._cache[self.obj.as_pointer()][1]
        self.assertEqual(solver.contact, "self")

    def test_where_nothing_comes_near_deform_gives_the_pose_without_contact(self):
        gentle = Matrix.Translation((0.6, 0.0, 1.8))   # a sideways lean: no part comes near another
        self.deform(gentle, False)
        free = U.coords(self.obj)
        self.assertEqual(self.crossings(free), 0)
        r = self.deform(gentle, True)
        np.testing.assert_array_equal(U.coords(self.obj), free)
        self.assertEqual(r.notes, ["Self Contact: no part of the surface came near another"])

    def test_a_handle_pushed_through_the_mesh_stops_short_and_is_named(self):
        free = self.deform(THROUGH, False)
        self.assertGreater(self.crossings(), 0)
        self.assertFalse([w for w in free.warnings if "Self Contact" in w], free.warnings)
        r = self.deform(THROUGH, True)
        coords = U.coords(self.obj)
        self.assertTrue(np.isfinite(coords).all())
        self.assertEqual(self.crossings(), 0)
        self.assertLess(r.contact_reached, 1.0)
        # The handle stands short of its targets, by the share of its move the warning gives.
        short = np.linalg.norm(coords[self.top] - self.top_targets(THROUGH), axis=1).max()
        self.assertGreater(short, 0.1)
        stopped = [w for w in r.warnings if "Self Contact" in w]
        self.assertEqual(stopped, ["Handle 'top' stopped at %d%% of its move: going further would make the "
                                   "surface pass through itself (Self Contact)" % int(100 * r.contact_reached)],
                         r.warnings)
        # Read from the pose instead (Live, Auto mode in the viewport: solves that go on from one another):
        # the same handle, the same share.
        p = problem.Problem(self.obj, bpy.context.scene)
        stop = problem.pose_contact_stop(p, U.raw_coords(self.obj), p.targets(p.pose(self.obj)))
        self.assertEqual(stop.group, "top")
        self.assertAlmostEqual(stop.reached, r.contact_reached, delta=1e-3)
        # The Deform operator reports it.
        self.empty.matrix_world = THROUGH
        bpy.context.view_layer.objects.active = self.obj
        self.assertEqual(bpy.ops.object.arap_deform(), {'FINISHED'})
        # Its solve runs on the worker thread in chunks, whose stop at the contact can come a step apart.
        reported = [w for w in api.last_result(self.obj).warnings if "Self Contact" in w]
        self.assertEqual(len(reported), 1, api.last_result(self.obj).warnings)
        self.assertTrue(reported[0].startswith("Handle 'top' stopped at "), reported)
        self.assertAlmostEqual(int(reported[0].split(" stopped at ")[1].split("%")[0]), int(100 * r.contact_reached),
                               delta=3)

    def test_live_never_crosses(self):
        written = {}
        for contact in (False, True):
            self.empty.matrix_world = BIND
            api.reset(self.obj)
            self.obj.arap.contact = contact
            s = api.start_session(self.obj, bpy.context.scene)
            try:
                self.assertEqual(s.solver.contact, "self" if contact else "none")
                counts = []
                for k in range(1, STEPS + 1):
                    self.empty.matrix_world = on_the_way(k)
                    bpy.context.view_layer.update()
                    for _ in range(15):
                        s.step()
                        counts.append(self.crossings())
                written[contact] = counts
                # Live's lines say what Self Contact does (nothing when it is off).
                held = [line for line in live_ops.live_status_lines() if line.startswith("Self Contact held")]
                self.assertEqual(len(held), 1 if contact else 0, live_ops.live_status_lines())
                self.assertTrue(np.isfinite(U.coords(self.obj)).all())
                self.assertGreater(np.ptp(U.coords(self.obj)[:, 0]), 1.5)   # it was posed
            finally:
                s.cancel()
        self.assertGreater(max(written[False]), 0, "without Self Contact the moves must cross")
        self.assertEqual(max(written[True]), 0, written[True])

    def test_live_reports_the_handle_stopped_once(self):
        self.obj.arap.contact = True
        s = api.start_session(self.obj, bpy.context.scene)
        try:
            s.step()
            self.assertIsNone(s.contact)   # nothing moved: nothing stopped
            self.assertFalse([line for line in live_ops.live_status_lines() if "stopped" in line])
            self.assertIn("Self Contact: no part of the surface came near another", live_ops.live_status_lines())
            op = types.SimpleNamespace(_contact=None, reports=[])
            op.report = lambda kind, message: op.reports.append((set(kind), message))
            for reached in (0.42, 0.5):   # the same handle stopped again: reported once, the lines follow
                s.contact = problem.ContactStop("top", reached)
                live_ops.ARAP_OT_live._warn_contact(op, s)
            self.assertEqual(op.reports, [({'WARNING'}, "Handle 'top' stopped at 42% of its move: going further "
                                           "would make the surface pass through itself (Self Contact)")])
            self.assertIn("Self Contact: handle 'top' stopped at 50%", live_ops.live_status_lines())
        finally:
            s.cancel()

    def test_auto_mode_never_crosses_and_follows_the_setting(self):
        self.animate()
        api.set_auto(self.obj, True)
        scene = bpy.context.scene
        scene.frame_set(STEPS)
        self.assertGreater(self.crossings(), 0)
        self.obj.arap.contact = True   # Auto poses again with it, nothing else changed
        self.assertEqual(self.crossings(), 0)
        for f in range(1, STEPS + 1):
            scene.frame_set(f)
            coords = U.evaluated_coords(self.obj)
            self.assertTrue(np.isfinite(coords).all(), "frame %d" % f)
            self.assertEqual(self.crossings(coords), 0, "frame %d" % f)
            np.testing.assert_allclose(coords[self.top], self.top_targets(on_the_way(f)), atol=1e-5,
                                       err_msg="frame %d" % f)
        self.assertIsNone(auto.contact(self.obj))
        self.obj.arap.contact = False
        self.assertGreater(self.crossings(), 0)

    def test_auto_mode_says_which_handle_stopped(self):
        self.obj.arap.contact = True
        api.set_auto(self.obj, True)
        self.empty.matrix_world = THROUGH
        bpy.context.view_layer.update()
        self.assertEqual(self.crossings(), 0)
        self.assertTrue(np.isfinite(U.coords(self.obj)).all())
        stop = auto.contact(self.obj)
        self.assertIsNotNone(stop)
        self.assertEqual(stop.group, "top")
        self.assertEqual(stop.warning(), "Handle 'top' stopped at %d%% of its move: going further would make "
                         "the surface pass through itself (Self Contact)" % stop.percent)
        self.assertEqual(stop.status(), "Self Contact: handle 'top' stopped at %d%%" % stop.percent)
        # The panel says what Self Contact did in that pose's solve.
        held = [text for text, _icon in auto.panel_lines(self.obj) if text.startswith("Self Contact held")]
        self.assertEqual(len(held), 1, auto.panel_lines(self.obj))

    def test_bake_never_crosses(self):
        self.obj.arap.contact = True
        self.animate()
        r = bake.bake_shape_keys(self.obj, 1, STEPS)
        self.assertEqual(r.warnings, [])
        for f in range(1, STEPS + 1):
            bpy.context.scene.frame_set(f)
            coords = U.evaluated_coords(self.obj)
            self.assertTrue(np.isfinite(coords).all(), "frame %d" % f)
            self.assertEqual(self.crossings(coords), 0, "frame %d" % f)
            np.testing.assert_allclose(coords[self.top], self.top_targets(on_the_way(f)), atol=1e-5,
                                       err_msg="frame %d" % f)
        # The same frames without Self Contact: the last ones cross.
        self.obj.arap.contact = False
        free = bake.bake_shape_keys(self.obj, STEPS, STEPS)
        self.assertGreater(self.crossings(free.positions[0].astype(np.float64)), 0)

    def test_bake_names_the_frames_a_handle_stopped(self):
        self.obj.arap.contact = True
        self.empty.location = (0.0, 0.0, 2.0)
        self.empty.keyframe_insert("location", frame=1)
        self.empty.matrix_world = THROUGH
        self.empty.keyframe_insert("location", frame=2)
        r = bake.bake_shape_keys(self.obj, 1, 2)
        self.assertEqual(len(r.warnings), 1, r.warnings)
        self.assertTrue(r.warnings[0].startswith("Frame 2: Handle 'top' stopped at "), r.warnings)
        for positions in r.positions:
            self.assertTrue(np.isfinite(positions).all())
        # Frame 1 is the rest pose: it comes back as the rest (to rounding: Infill's lattice is solved too, and
        # BVHTree.overlap counts triangles that touch at rest once they move by 1e-15). Frame 2 never crosses.
        np.testing.assert_allclose(r.positions[0].reshape(-1, 3), self.rest, atol=1e-6)
        self.assertEqual(self.crossings(r.positions[1].astype(np.float64)), 0)

    def test_saved_in_the_blend_and_anderson_solves_with_quasi_newton(self):
        self.obj.arap.contact = True
        self.obj.arap.method = 'ANDERSON'
        self.obj.arap.volume = 'NONE'     # Self Contact the one setting Anderson cannot carry
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "contact.blend")
            bpy.ops.wm.save_as_mainfile(filepath=path)
            bpy.ops.wm.open_mainfile(filepath=path)
        self.obj = obj = bpy.data.objects["Bar"]
        self.empty = bpy.data.objects["TopEmpty"]
        self.assertTrue(obj.arap.contact)
        self.assertEqual(obj.arap.method, 'ANDERSON')
        self.empty.matrix_world = POSE
        r = api.deform(obj)
        solver = solver_cache._cache[obj.as_pointer()][1]
        self.assertEqual((solver.contact, solver.method), ("self", "quasi-newton"))
        self.assertIn("Self Contact needs Quasi-Newton or Local/Global: solved with Quasi-Newton", r.warnings)
        self.assertEqual(self.crossings(), 0)
        obj.arap.volume = 'GLOBAL'
        r = api.deform(obj)
        self.assertIn("Volume Global and Self Contact need Quasi-Newton or Local/Global: solved with "
                      "Quasi-Newton", r.warnings)
        obj.arap.contact = False
        obj.arap.volume = 'NONE'
        r = api.deform(obj)
        self.assertFalse([w for w in r.warnings if "Quasi-Newton" in w], r.warnings)
        self.assertEqual(solver_cache._cache[obj.as_pointer()][1].method, "anderson")


if __name__ == "__main__":
    unittest.main()
