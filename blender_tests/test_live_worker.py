# Live and Deform as the viewport runs them: the solves on the worker's native
# thread (LiveSession.update(), deform_job.DeformJob.start()/poll()), Blender's
# thread only reading the Empties and writing finished poses.
import contextlib
import threading
import time
import unittest

import bpy
import numpy as np
from mathutils import Matrix

import arap_test_utils as U
api, deform_job, live, live_ops, native_loader, problem, sessions, solver_cache = U.addon(
    "api", "deform_job", "live", "live_ops", "native_loader", "problem", "sessions", "solver_cache")
SetupError, SessionError = U.addon("errors").SetupError, U.addon("errors").SessionError

GIVE_UP_S = 120.0


def move(empty, dx=0.0, dz=0.0):
    empty.matrix_world = Matrix.Translation((dx, 0.0, dz)) @ empty.matrix_world
    bpy.context.view_layer.update()


def set_coords(obj, flat):
    obj.data.vertices.foreach_set("co", flat)
    obj.data.update()


def update_until_settled(session):
    """What the modal's timer does: update() until Live has settled; the updates that wrote a pose."""
    written = []
    end = time.monotonic() + GIVE_UP_S
    while not session.settled:
        stats = session.update()
        if stats is not None:
            written.append(stats)
        if time.monotonic() > end:
            raise AssertionError("Live never settled")
        time.sleep(0.002)
    return written


@contextlib.contextmanager
def held_binds(error=None):
    """Every bind waits until the test sets the event it yields (then raises `error`, when given): what a
    long bind does to whoever waits for it."""
    release = threading.Event()
    bind = problem.Problem.bind

    def held(problem_self):
        release.wait(60)
        if error is not None:
            raise error
        return bind(problem_self)

    problem.Problem.bind = held
    try:
        yield release
    finally:
        release.set()
        problem.Problem.bind = bind


class LiveOnTheWorker(unittest.TestCase):
    def setUp(self):
        U.clear_scene()
        self.obj, self.empty, self.fixed, self.top = U.bar_with_handle()

    def tearDown(self):
        for s in list(sessions._sessions):
            s.cancel()

    def test_settles_in_the_pose_of_a_one_shot_solve(self):
        rest = U.coords(self.obj).copy()
        s = api.start_session(self.obj, bpy.context.scene)
        move(self.empty, dx=0.5, dz=-0.3)
        written = update_until_settled(s)
        self.assertTrue(written, "no pose was ever shown")
        self.assertIsNone(s.update())           # asleep: nothing more is written
        live = U.coords(self.obj).copy()
        moved = live[self.top] - rest[self.top]
        np.testing.assert_allclose(moved, np.tile((0.5, 0.0, -0.3), (len(self.top), 1)), atol=1e-5)
        s.cancel()
        move(self.empty, dx=0.5, dz=-0.3)
        api.deform(self.obj, tolerance=1e-9)
        np.testing.assert_allclose(live, U.coords(self.obj), atol=2e-3)

    def test_the_operators_session_binds_on_a_thread_of_its_own(self):
        rest = U.raw_coords(self.obj).copy()
        with held_binds() as release:
            s = live.LiveSession(self.obj, bpy.context.scene, bind_on_thread=True)
            move(self.empty, dx=0.5)
            self.assertIsNone(s.update())    # returned at once: the bind is still running
            self.assertIsNone(s.solver)
            self.assertIn("binding", live_ops.live_status_text())
            np.testing.assert_array_equal(U.raw_coords(self.obj), rest)
            release.set()
            update_until_settled(s)
        moved = U.coords(self.obj)[self.top] - rest.reshape(-1, 3)[self.top]
        np.testing.assert_allclose(moved, np.tile((0.5, 0.0, 0.0), (len(self.top), 1)), atol=1e-5)
        s.cancel()
        np.testing.assert_array_equal(U.raw_coords(self.obj), rest)

    def test_a_bind_that_fails_on_its_thread_raises_from_update_and_cancel_restores(self):
        rest = U.raw_coords(self.obj).copy()
        with held_binds(SetupError("no memory left for this test")) as release:
            s = live.LiveSession(self.obj, bpy.context.scene, bind_on_thread=True)
            release.set()
            s.binding.wait()
            with self.assertRaisesRegex(SetupError, "no memory left"):
                s.update()
        s.cancel()
        np.testing.assert_array_equal(U.raw_coords(self.obj), rest)
        # The object deleted while Live binds: the next update stops Live, naming it.
        with held_binds() as release:
            s = live.LiveSession(self.obj, bpy.context.scene, bind_on_thread=True)
            bpy.data.objects.remove(self.obj)
            release.set()
            with self.assertRaisesRegex(SessionError, "was deleted"):
                s.update()
        with self.assertRaisesRegex(SessionError, "was deleted"):
            s.cancel()   # stops without touching anything, naming the object (LiveSession.cancel)
        self.assertIsNone(sessions.any_session())

    def test_the_solve_runs_between_updates_not_in_them(self):
        # A solve that never settles (tolerance 0) on a finer bar: while the caller sleeps,
        # the worker goes on iterating; the solver itself is the worker's meanwhile.
        U.clear_scene()
        self.obj, self.empty, _f, _t = U.bar_with_handle(vertices=64, cuts=40)
        self.obj.arap.tolerance = 0.0
        rest = U.raw_coords(self.obj).copy()
        s = api.start_session(self.obj, bpy.context.scene)
        move(self.empty, dx=0.5)
        s.update()
        first = s.worker.progress[0]
        end = time.monotonic() + GIVE_UP_S
        while s.worker.progress[0] <= first + 2 and time.monotonic() < end:
            time.sleep(0.01)
        self.assertGreater(s.worker.progress[0], first + 2)
        with self.assertRaises(native_loader.native().ArapError) as cm:
            s.solver.solve(s.targets)
        self.assertEqual(cm.exception.code, "solver busy")
        s.cancel()
        self.assertFalse(s.solver.busy)
        self.assertTrue(np.array_equal(U.raw_coords(self.obj), rest))

    def test_cancel_while_solving_restores_mesh_and_empties_bit_for_bit(self):
        before = U.raw_coords(self.obj).copy()
        channels = U.transform_channels(self.empty)
        self.obj.arap.tolerance = 0.0
        s = api.start_session(self.obj, bpy.context.scene)
        for k in range(5):
            move(self.empty, dx=0.1)
            s.update()
            time.sleep(0.01)
        s.update()
        s.cancel()
        self.assertTrue(np.array_equal(U.raw_coords(self.obj), before))
        self.assertEqual(U.transform_channels(self.empty), channels)
        self.assertIsNone(s.worker)
        self.assertEqual(live_ops.live_status_lines(), [])

    def test_apply_keeps_the_newest_finished_pose(self):
        s = api.start_session(self.obj, bpy.context.scene)
        move(self.empty, dz=0.5)
        update_until_settled(s)
        settled = s.positions().copy()
        s.finish()
        np.testing.assert_array_equal(U.raw_coords(self.obj), settled)
        self.assertIsNone(sessions.session_for(self.obj))
        self.assertIn("arap_rest", self.obj.data.attributes)

    def test_the_status_is_that_of_the_pose_shown(self):
        s = api.start_session(self.obj, bpy.context.scene)
        move(self.empty, dx=0.4)
        written = update_until_settled(s)
        last = written[-1]
        self.assertEqual(s.last, last)
        self.assertLessEqual(last.main_thread_ms, last.read_ms + last.write_ms + 1.0)
        self.assertIn("settled", live_ops.live_status_lines()[0])
        s.stop_worker()   # the solver is the caller's again: measure the shown pose's energy
        shown = s.solver.energy(U.coords(self.obj))
        self.assertAlmostEqual(last.energy, shown, delta=1e-4 * shown)

    def test_undo_reattach_and_a_deleted_empty_with_the_worker(self):
        s = api.start_session(self.obj, bpy.context.scene)
        move(self.empty, dx=0.3)
        update_until_settled(s)
        bpy.data.objects.remove(self.empty)
        with self.assertRaises(api.SessionError) as cm:
            s.update()
        self.assertEqual(cm.exception.kind, 'EMPTY')
        s.cancel()
        self.assertFalse(s.solver.busy)


class DeformOnTheWorker(unittest.TestCase):
    def setUp(self):
        U.clear_scene()
        self.obj, self.empty, self.fixed, self.top = U.bar_with_handle()
        move(self.empty, dx=0.6, dz=-0.2)

    def poll_until_done(self, job):
        end = time.monotonic() + GIVE_UP_S
        while True:
            result = job.poll()
            if result is not None:
                return result
            self.assertLess(time.monotonic(), end, "Deform never finished")
            time.sleep(0.002)

    def test_same_result_as_deform_and_stop_leaves_the_mesh_untouched(self):
        before = U.raw_coords(self.obj).copy()
        here = api.deform(self.obj)
        posed = U.raw_coords(self.obj).copy()
        set_coords(self.obj, before)
        job = deform_job.DeformJob(self.obj, bpy.context.scene)
        job.start()
        result = self.poll_until_done(job)
        np.testing.assert_array_equal(U.raw_coords(self.obj), posed)
        self.assertEqual((result.iterations, result.energy), (here.iterations, here.energy))
        # Stopped: nothing written, the solver usable again.
        set_coords(self.obj, before)
        self.obj.arap.tolerance = 0.0
        job = deform_job.DeformJob(self.obj, bpy.context.scene, max_iterations=1000)
        job.start()
        job.stop()
        self.assertTrue(np.array_equal(U.raw_coords(self.obj), before))
        self.assertFalse(job.solver.busy)
        self.assertEqual(job.progress, (0, 0.0))

    def test_the_operators_job_binds_on_a_thread_of_its_own(self):
        before = U.raw_coords(self.obj).copy()
        here = api.deform(self.obj)
        posed = U.raw_coords(self.obj).copy()
        set_coords(self.obj, before)
        solver_cache.clear()
        with held_binds() as release:
            job = deform_job.DeformJob(self.obj, bpy.context.scene, bind_on_thread=True)
            job.start()
            self.assertIsNone(job.poll())
            self.assertIn("binding", " ".join(deform_ops_lines(job)))
            release.set()
            result = self.poll_until_done(job)
        np.testing.assert_array_equal(U.raw_coords(self.obj), posed)
        self.assertEqual((result.iterations, result.energy), (here.iterations, here.energy))
        # The bound solver is kept: the redo panel's next run binds nothing.
        again = deform_job.DeformJob(self.obj, bpy.context.scene, bind_on_thread=True)
        self.assertTrue(again.cached)

    def test_esc_while_binding_and_a_failed_bind_leave_the_mesh_untouched(self):
        before = U.raw_coords(self.obj).copy()
        solver_cache.clear()
        with held_binds() as release:
            job = deform_job.DeformJob(self.obj, bpy.context.scene, bind_on_thread=True)
            job.start()
            job.stop()
            release.set()
        self.assertIsNone(job.binding)
        with held_binds(SetupError("no memory left for this test")) as release:
            job = deform_job.DeformJob(self.obj, bpy.context.scene, bind_on_thread=True)
            job.start()
            release.set()
            job.binding.wait()
            with self.assertRaisesRegex(SetupError, "no memory left"):
                job.poll()
        np.testing.assert_array_equal(U.raw_coords(self.obj), before)
        # The object deleted while its bind runs: a clear error at the next poll, nothing written.
        with held_binds() as release:
            job = deform_job.DeformJob(self.obj, bpy.context.scene, bind_on_thread=True)
            job.start()
            bpy.data.objects.remove(self.obj)
            release.set()
            with self.assertRaisesRegex(SetupError, "was deleted"):
                job.poll()

    def test_progress_counts_up_while_it_solves(self):
        # The textbook method with tolerance 0 on a finer bar runs its whole cap (thousands of
        # iterations): the progress the viewport shows climbs while this thread only looks.
        U.clear_scene()
        self.obj, self.empty, _f, _t = U.bar_with_handle(vertices=64, cuts=40)
        move(self.empty, dx=0.6)
        self.obj.arap.method, self.obj.arap.tolerance = 'LOCAL_GLOBAL', 0.0
        job = deform_job.DeformJob(self.obj, bpy.context.scene, max_iterations=10000)
        job.start()
        seen = set()
        end = time.monotonic() + GIVE_UP_S
        while len(seen) < 3 and time.monotonic() < end:
            seen.add(job.progress[0])
            time.sleep(0.001)
        # The viewport's line gives the time so far and at most how much more (the rate times the cap left).
        head = deform_ops_lines(job)[0]
        self.assertRegex(head, r"iterations, energy .*; [0-9]+ s so far, at most [0-9]+ (s|min) more$")
        spent, left = job.time_left()
        self.assertGreater(left, spent)   # most of its 10000 iterations are still to come
        job.stop()
        self.assertGreaterEqual(len(seen), 3)
        self.assertLess(max(seen), 10000)

    def test_the_operator_outside_the_viewport_solves_at_once(self):
        # --background has no event loop: invoke falls back to execute, one undo step as before.
        rest = U.coords(self.obj).copy()
        bpy.context.view_layer.objects.active = self.obj
        self.assertEqual(bpy.ops.object.arap_deform('INVOKE_DEFAULT'), {'FINISHED'})
        moved = U.coords(self.obj)[self.top] - rest[self.top]
        np.testing.assert_allclose(moved, np.tile((0.6, 0.0, -0.2), (len(self.top), 1)), atol=1e-5)


def deform_ops_lines(job):
    """The viewport's lines for `job` as the modal Deform shows them."""
    deform_ops = U.addon("deform_ops")
    deform_ops.ARAP_OT_deform.running = job
    try:
        return deform_ops.deform_status_lines()
    finally:
        deform_ops.ARAP_OT_deform.running = None


class UnsettledWarnings(unittest.TestCase):
    """The warning for a pose that did not settle names the setting the user can raise."""

    def setUp(self):
        U.clear_scene()
        self.obj, self.empty, _f, _t = U.bar_with_handle()
        move(self.empty, dx=0.8)
        self.obj.arap.tolerance = 1e-12

    def test_from_the_object_setting(self):
        self.obj.arap.max_iterations = 2
        self.assertIn("in the Solver panel", " ".join(api.deform(self.obj).warnings))

    def test_from_an_argument(self):
        self.assertIn("max_iterations=", " ".join(api.deform(self.obj, max_iterations=2).warnings))

    def test_from_the_redo_panel(self):
        bpy.context.view_layer.objects.active = self.obj
        bpy.ops.object.arap_deform(max_iterations=2)
        result = api.last_result(self.obj)
        self.assertIn("Adjust Last Operation panel", " ".join(result.warnings))


if __name__ == "__main__":
    unittest.main()
