# LiveSession (the logic behind the modal Live operator), driven without an event loop,
# and the Live operator's own methods on a stand-in (the posed object or an Empty deleted during Live).
import inspect
import types
import unittest

import bpy
import numpy as np
from mathutils import Matrix

import arap_test_utils as U

api, errors, live, live_ops, sessions = U.addon("api", "errors", "live", "live_ops", "sessions")


def move(empty, dx=0.0, dz=0.0):
    empty.matrix_world = Matrix.Translation((dx, 0.0, dz)) @ empty.matrix_world
    bpy.context.view_layer.update()


class LiveOperator:
    """The Live operator's methods on a plain object holding a started session: a modal operator needs
    Blender's event loop, which --background has not. Its reports are kept in `reports`."""

    def __init__(self, session):
        self._session, self._timer, self._collapsed, self._contact, self._shown = session, None, [], None, None
        self.reports = []

    def report(self, kind, message):
        self.reports.append((set(kind), message))


for _name, _method in vars(live_ops.ARAP_OT_live).items():
    if inspect.isfunction(_method) and _name not in ("__init__", "invoke", "execute"):
        setattr(LiveOperator, _name, _method)


def event(kind, value='NOTHING'):
    return types.SimpleNamespace(type=kind, value=value)


class Live(unittest.TestCase):
    def setUp(self):
        U.clear_scene()
        self.obj, self.empty, self.fixed, self.top = U.bar_with_handle()

    def test_cancel_restores_bit_for_bit(self):
        before = U.raw_coords(self.obj).copy()
        s = api.start_session(self.obj, bpy.context.scene)
        for i in range(5):
            move(self.empty, dx=0.1 * i)
            stats = s.step()
            self.assertGreater(stats.solve_ms, 0.0)
        self.assertFalse(np.array_equal(U.raw_coords(self.obj), before))
        s.cancel()
        self.assertTrue(np.array_equal(U.raw_coords(self.obj), before))
        self.assertIsNone(sessions.session_for(self.obj))
        self.assertNotIn("arap_rest", self.obj.data.attributes)

    def test_cancel_restores_the_empties_bit_for_bit(self):
        # Cancel means the state before Live: the handle Empties too, every channel exactly.
        self.empty.rotation_mode = 'XYZ'
        self.empty.rotation_euler = (0.1, 0.2, 0.3)
        self.empty.scale = (1.1, 0.9, 1.0)
        bpy.context.view_layer.update()
        channels = U.transform_channels(self.empty)
        s = api.start_session(self.obj, bpy.context.scene)
        self.empty.location.x += 0.37
        self.empty.rotation_euler.z += 0.5
        self.empty.scale = (2.0, 2.0, 2.0)
        self.empty.rotation_mode = 'QUATERNION'
        s.step()
        s.cancel()
        self.assertEqual(U.transform_channels(self.empty), channels)

    def test_viewport_status_while_live_runs(self):
        live_ops = U.addon("live_ops")
        self.assertEqual(live_ops.live_status_lines(), [])
        s = api.start_session(self.obj, bpy.context.scene)
        s.step()
        lines = live_ops.live_status_lines()
        self.assertIn("ARAP Live on 'Bar'", lines[0])
        self.assertIn("ms per update", lines[1])
        self.assertIn("Esc: cancel", lines[-1])
        self.assertNotIn("right-click", live_ops.live_status_text())
        # Short lines: each fits the viewport's corner of a small window.
        self.assertLessEqual(max(len(line) for line in lines), 80)
        s.cancel()
        self.assertEqual(live_ops.live_status_lines(), [])

    def test_apply_and_cancel_buttons_leave_the_request_with_the_operators(self):
        # The panel's buttons call operators; the request waits in live_ops.py for the Live
        # modal operator (the session itself knows nothing of the UI).
        live_ops = U.addon("live_ops")
        s = api.start_session(self.obj, bpy.context.scene)
        try:
            bpy.context.view_layer.objects.active = self.obj
            self.assertEqual(bpy.ops.object.arap_live_apply(), {'FINISHED'})
            self.assertEqual(live_ops._end_requests.get(s), 'APPLY')
            self.assertEqual(bpy.ops.object.arap_live_cancel(), {'FINISHED'})
            self.assertEqual(live_ops._end_requests.get(s), 'CANCEL')
            self.assertFalse(hasattr(s, "request"))
        finally:
            live_ops._end_requests.pop(s, None)
            s.cancel()
        self.assertFalse(bpy.ops.object.arap_live_apply.poll())   # no session: nothing to apply

    def test_an_empty_scaled_to_nothing_is_reported(self):
        s = api.start_session(self.obj, bpy.context.scene)
        self.empty.scale = (0.0, 0.0, 0.0)
        s.step()
        self.assertEqual(s.collapsed, ["top"])
        self.empty.scale = (1.0, 1.0, 1.0)
        s.step()
        self.assertEqual(s.collapsed, [])
        s.cancel()

    def test_undo_during_live_poses_the_restored_handles(self):
        # Ctrl+Z while Live runs: Blender reloads the objects as the previous undo
        # step had them; the session finds them again and poses the restored handles.
        rest = U.raw_coords(self.obj).copy()
        start = self.empty.matrix_world.copy()
        bpy.ops.ed.undo_push(message="set-up")
        s = api.start_session(self.obj, bpy.context.scene)
        move(self.empty, dx=0.4)
        s.step()
        bpy.ops.ed.undo_push(message="first move")
        first = self.empty.matrix_world.copy()
        move(self.empty, dx=0.5)
        s.step()
        bpy.ops.ed.undo_push(message="second move")
        bpy.ops.ed.undo()
        self.assertTrue(s.references_lost())
        s.reattach(bpy.data.objects, bpy.context.scene)
        self.assertFalse(s.references_lost())
        for _ in range(100):
            if s.step(force=False) is None:
                break
        obj, empty = bpy.data.objects["Bar"], bpy.data.objects["TopEmpty"]
        np.testing.assert_allclose(U.np_matrix(empty.matrix_world), U.np_matrix(first), atol=1e-6)
        moved = U.coords(obj)[self.top] - rest.reshape(-1, 3)[self.top]
        np.testing.assert_allclose(moved, np.tile((0.4, 0, 0), (len(self.top), 1)), atol=1e-5)
        s.cancel()   # and Cancel still brings back the state before Live
        np.testing.assert_array_equal(U.raw_coords(obj), rest)
        np.testing.assert_allclose(U.np_matrix(empty.matrix_world), U.np_matrix(start), atol=1e-6)
        self.assertIsNone(sessions.session_for(obj))

    def test_cancel_restores_shape_keys(self):
        self.obj.shape_key_add(name="Basis")
        s = api.start_session(self.obj, bpy.context.scene)
        move(self.empty, dx=0.5)
        s.step()
        self.assertIn("ARAP", self.obj.data.shape_keys.key_blocks)
        s.cancel()
        self.assertNotIn("ARAP", self.obj.data.shape_keys.key_blocks)

    def test_finish_keeps_result_and_stores_rest(self):
        rest = U.raw_coords(self.obj).copy()
        s = api.start_session(self.obj, bpy.context.scene)
        move(self.empty, dz=0.5)
        for _ in range(30):
            s.step()
        s.finish()
        self.assertGreater(np.abs(U.coords(self.obj)[self.top] - rest.reshape(-1, 3)[self.top]).max(), 0.4)
        api.reset(self.obj)
        self.assertTrue(np.array_equal(U.raw_coords(self.obj), rest))

    def test_warm_start_converges_to_one_shot(self):
        move(self.empty, dx=0.6)
        s = api.start_session(self.obj, bpy.context.scene, max_iterations=1, write=False)
        for _ in range(400):
            s.step()
        live = s.positions().reshape(-1, 3).astype(np.float64)
        s.cancel()
        api.deform(self.obj, max_iterations=400, tolerance=0.0)
        np.testing.assert_allclose(live, U.coords(self.obj), atol=1e-3)

    def test_write_false_never_touches_mesh(self):
        before = U.raw_coords(self.obj).copy()
        s = api.start_session(self.obj, bpy.context.scene, write=False)
        move(self.empty, dx=0.3)
        s.step()
        self.assertTrue(np.array_equal(U.raw_coords(self.obj), before))
        self.assertFalse(np.array_equal(s.positions(), before))
        s.cancel()

    def test_step_skips_when_nothing_moved_and_converged(self):
        s = api.start_session(self.obj, bpy.context.scene, max_iterations=50)
        s.step()
        if s.converged:
            self.assertIsNone(s.step(force=False))
        move(self.empty, dx=0.2)
        self.assertIsNotNone(s.step(force=False))
        s.cancel()

    def test_settles_then_sleeps_until_something_moves(self):
        s = api.start_session(self.obj, bpy.context.scene)
        move(self.empty, dx=0.5, dz=-0.3)
        steps = 0
        while s.step(force=False) is not None:  # what the modal timer does
            steps += 1
            self.assertLess(steps, 200, "Live never settled")
        self.assertTrue(s.settled)
        settled = U.raw_coords(self.obj).copy()
        # Asleep: nothing is solved or written, the shape does not creep.
        for _ in range(5):
            self.assertIsNone(s.step(force=False))
        self.assertTrue(np.array_equal(U.raw_coords(self.obj), settled))
        # The settled pose is the converged one-shot solve of the same pose.
        live = U.coords(self.obj).copy()
        s.cancel()   # (puts the Empty back too)
        move(self.empty, dx=0.5, dz=-0.3)
        api.deform(self.obj, tolerance=1e-9)
        np.testing.assert_allclose(live, U.coords(self.obj), atol=2e-3)
        # A move wakes it up again.
        s = api.start_session(self.obj, bpy.context.scene)
        while s.step(force=False) is not None:
            pass
        move(self.empty, dx=0.1)
        self.assertIsNotNone(s.step(force=False))
        s.cancel()

    def test_uses_the_objects_method_and_frame_budget(self):
        self.obj.arap.method = 'LOCAL_GLOBAL'
        self.obj.arap.live_frame_ms = 5.0
        s = api.start_session(self.obj, bpy.context.scene)
        self.assertEqual(s.solver.method, "local-global")
        s.step()
        self.assertEqual(s.solver.time_budget_ms, 5.0)  # the first update is a move
        if not s.settled:
            s.step()  # nothing moved: a settling update
            self.assertEqual(s.solver.time_budget_ms, 5.0 * live.SETTLE_BUDGET_FACTOR)
        move(self.empty, dx=0.2)
        s.step()
        self.assertEqual(s.solver.time_budget_ms, 5.0)
        s.cancel()

    def test_deleted_empty_stops(self):
        before = U.raw_coords(self.obj).copy()
        s = api.start_session(self.obj, bpy.context.scene)
        move(self.empty, dx=0.3)
        s.step()
        bpy.data.objects.remove(self.empty)
        with self.assertRaises(errors.SessionError) as cm:
            s.step()
        self.assertEqual(cm.exception.kind, 'EMPTY')
        self.assertIn("top", str(cm.exception))
        s.cancel()
        self.assertTrue(np.array_equal(U.raw_coords(self.obj), before))

    def test_deleted_object_stops_live_naming_it_and_touching_nothing(self):
        # A script deletes the posed object while Live runs; then Blender aborts the operator
        # (cancel()), or its next timer tick comes, or Esc, Enter: Live stops with one message naming
        # the object, no traceback, the Empties where they are, other objects untouched.
        other = U.add_cylinder(name="Other")
        other_coords = U.raw_coords(other).copy()
        for end in (lambda op: op.cancel(bpy.context), lambda op: op.modal(bpy.context, event('TIMER')),
                    lambda op: op.modal(bpy.context, event('ESC', 'PRESS')),
                    lambda op: op.modal(bpy.context, event('RET', 'PRESS'))):
            if "Bar" not in bpy.data.objects:
                self.obj = U.add_cylinder()
                U.group_where(self.obj, "bottom", lambda co: co.z < -1.5)
                U.group_where(self.obj, "top", lambda co: co.z > 1.5)
                api.set_fixed(self.obj, "bottom")
                api.add_handle(self.obj, "top", self.empty)
            s = api.start_session(self.obj, bpy.context.scene)
            op = LiveOperator(s)
            move(self.empty, dx=0.3)
            s.step()
            channels = U.transform_channels(self.empty)
            bpy.data.objects.remove(self.obj)
            result = end(op)
            self.assertIn(result, (None, {'CANCELLED'}))
            self.assertEqual(op.reports, [({'ERROR'}, "Live stopped: the object 'Bar' was deleted")])
            self.assertIsNone(sessions.any_session())
            self.assertFalse(s.active)
            self.assertEqual(live_ops.live_status_lines(), [])
            self.assertEqual(U.transform_channels(self.empty), channels)
            np.testing.assert_array_equal(U.raw_coords(other), other_coords)

    def test_deleted_object_session_cancel_names_it(self):
        s = api.start_session(self.obj, bpy.context.scene)
        s.step()
        bpy.data.objects.remove(self.obj)
        with self.assertRaises(errors.SessionError) as cm:
            s.step()
        self.assertEqual(cm.exception.kind, 'OBJECT')
        self.assertEqual(str(cm.exception), "Live stopped: the object 'Bar' was deleted")
        with self.assertRaises(errors.SessionError) as cm:
            s.cancel()
        self.assertEqual(str(cm.exception), "Live stopped: the object 'Bar' was deleted")
        self.assertIsNone(sessions.any_session())
        s.cancel()     # stopped: nothing more to do

    def test_deleted_empty_stops_the_operator_and_restores_the_mesh(self):
        before = U.raw_coords(self.obj).copy()
        s = api.start_session(self.obj, bpy.context.scene)
        op = LiveOperator(s)
        move(self.empty, dx=0.3)
        s.step()
        bpy.data.objects.remove(self.empty)
        self.assertEqual(op.modal(bpy.context, event('TIMER')), {'CANCELLED'})
        self.assertEqual(op.reports, [({'ERROR'}, "Live stopped: the handle Empty 'TopEmpty' was deleted "
                                                  "(mesh restored)")])
        np.testing.assert_array_equal(U.raw_coords(self.obj), before)
        self.assertIsNone(sessions.any_session())

    def test_topology_change_stops(self):
        s = api.start_session(self.obj, bpy.context.scene)
        s.step()
        self.obj.data.vertices.add(1)
        with self.assertRaises(errors.SessionError) as cm:
            s.step()
        self.assertEqual(cm.exception.kind, 'TOPOLOGY')
        with self.assertRaises(errors.SessionError) as cm:
            s.cancel()
        self.assertEqual(cm.exception.kind, 'TOPOLOGY')
        self.assertIsNone(sessions.any_session())

    def test_esc_after_a_vertex_count_change_reports_it_without_a_traceback(self):
        # Vertices added between two updates (a script; Live checks the count at its next update):
        # Esc ends Live with one message, the Empties back where they were, the mesh left as it is.
        channels = U.transform_channels(self.empty)
        s = api.start_session(self.obj, bpy.context.scene)
        op = LiveOperator(s)
        move(self.empty, dx=0.3)
        s.step()
        self.obj.data.vertices.add(1)
        after = U.raw_coords(self.obj).copy()
        self.assertEqual(op.modal(bpy.context, event('ESC', 'PRESS')), {'CANCELLED'})
        self.assertEqual(len(op.reports), 1)
        self.assertEqual(op.reports[0][0], {'ERROR'})
        self.assertIn("vertex count changed", op.reports[0][1])
        self.assertIsNone(sessions.any_session())
        self.assertEqual(U.transform_channels(self.empty), channels)
        np.testing.assert_array_equal(U.raw_coords(self.obj), after)

    def test_leaving_object_mode_stops(self):
        s = api.start_session(self.obj, bpy.context.scene)
        s.step()
        bpy.ops.object.mode_set(mode='EDIT')
        try:
            with self.assertRaises(errors.SessionError) as cm:
                s.step()
            self.assertEqual(cm.exception.kind, 'MODE')
        finally:
            bpy.ops.object.mode_set(mode='OBJECT')
            s.cancel()

    def test_frame_stats_describe_the_pose_written(self):
        # What the status shows is the pose on the mesh: its energy, and at most a frame's iterations.
        s = api.start_session(self.obj, bpy.context.scene)
        move(self.empty, dx=0.4)
        st = s.step()
        self.assertLessEqual(st.iterations, self.obj.arap.live_max_iterations)
        shown = s.solver.energy(U.coords(self.obj))
        self.assertAlmostEqual(st.energy, shown, delta=1e-4 * shown)   # float32 coordinates on the mesh
        s.cancel()


if __name__ == "__main__":
    unittest.main()
