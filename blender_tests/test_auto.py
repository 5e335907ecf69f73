# Auto mode: the pose follows the handles through Blender's handlers, like a modifier.
import os
import tempfile
import threading
import time
import types
import unittest

import bpy
import numpy as np
from mathutils import Matrix

import arap_test_utils as U

api, auto, bake, problem = U.addon("api", "auto", "bake", "problem")
SetupError = U.addon("constraints").SetupError

FRAMES = range(1, 9)


def animate(empty):
    """Keyframes: the top swings sideways and turns."""
    for i, f in enumerate(FRAMES):
        empty.location = (0.15 * i, 0.0, 2.0 + 0.03 * i)
        empty.rotation_euler = (0.0, 0.05 * i, 0.0)
        empty.keyframe_insert("location", frame=f)
        empty.keyframe_insert("rotation_euler", frame=f)


def scale_of(coords):
    return float(np.ptp(coords, axis=0).max())


class Auto(unittest.TestCase):
    def setUp(self):
        U.clear_scene()
        auto.forget()
        bpy.context.scene.frame_set(1)
        self.obj, self.empty, self.fixed, self.top = U.bar_with_handle()
        self.rest = U.raw_coords(self.obj).copy()
        self.rest3 = self.rest.reshape(-1, 3).astype(np.float64)

    def tearDown(self):
        if self.obj.name in bpy.data.objects and self.obj.arap.auto:
            api.set_auto(self.obj, False)

    def top_motion(self):
        return U.coords(self.obj)[self.top] - self.rest3[self.top]

    def test_follows_a_moved_empty_and_idles(self):
        api.set_auto(self.obj, True)
        np.testing.assert_allclose(U.raw_coords(self.obj), self.rest, atol=1e-6)  # the handle has not moved yet
        self.empty.location.x += 0.4
        bpy.context.view_layer.update()   # a depsgraph update, as any edit in the UI makes
        np.testing.assert_allclose(self.top_motion(), np.tile((0.4, 0, 0), (len(self.top), 1)), atol=1e-5)
        np.testing.assert_allclose(U.coords(self.obj)[self.fixed], self.rest3[self.fixed], atol=1e-6)
        # Nothing that affects the pose changes: no solve, however many updates.
        count = auto.solve_count
        for _ in range(5):
            self.obj.select_set(not self.obj.select_get())
            bpy.context.view_layer.update()
            bpy.context.scene.frame_set(bpy.context.scene.frame_current)
        self.assertEqual(auto.solve_count, count)

    def settle_on_the_worker(self, poser, check=lambda: None):
        """Update `poser` as the viewport's timer does (the worker solves) until it has settled; `check`
        after every unsettled update."""
        auto._busy = True   # keep the handler (which solves fully in --background) out of this update
        try:
            depsgraph = bpy.context.evaluated_depsgraph_get()
        finally:
            auto._busy = False
        end = time.monotonic() + 120
        while not poser.update(self.obj, depsgraph, on_worker=True):
            check()
            self.assertLess(time.monotonic(), end, "Auto never settled")
            time.sleep(0.002)

    def test_in_the_viewport_the_worker_solves_and_the_pose_settles(self):
        # In the viewport the solve runs on the worker's thread: each update shows its newest
        # pose, the last one settled and cached; the status says settling, then settled.
        api.set_auto(self.obj, True)
        poser = auto._posers[self.obj.as_pointer()]
        self.empty.location = (0.9, 0.3, 1.7)
        self.settle_on_the_worker(poser, lambda: self.assertTrue(poser.status().startswith("settling")))
        self.assertIsNone(poser.worker)          # settled: the solver is back on this thread
        self.assertTrue(poser.status().startswith("settled after"))
        self.assertIn("ARAP Auto on 'Bar': settled", " ".join(auto.auto_status_lines()))
        self.assertIn(poser.written, poser.cache)
        spread = U.coords(self.obj)
        api.set_auto(self.obj, False)
        api.deform(self.obj, tolerance=self.obj.arap.tolerance)
        np.testing.assert_allclose(spread, U.coords(self.obj), atol=1e-3 * scale_of(spread))

    def test_in_the_viewport_a_move_during_the_cold_solve_goes_on_from_the_pose_on_screen(self):
        # Once the preview has settled the worker solves the pose cold, showing none of its iterates;
        # when the Empty moves again then, the next preview starts from the pose on screen.
        api.set_auto(self.obj, True)
        poser = auto._posers[self.obj.as_pointer()]
        starts = []
        native = auto.native

        def recording_worker(solver, **kwargs):
            starts.append(solver.positions().astype(np.float32).ravel())
            return native().SolveWorker(solver, **kwargs)

        def update():
            auto._busy = True   # the handler (which solves fully in --background) stays out
            try:
                depsgraph = bpy.context.evaluated_depsgraph_get()
            finally:
                auto._busy = False
            return poser.update(self.obj, depsgraph, on_worker=True)

        auto.native = lambda: types.SimpleNamespace(SolveWorker=recording_worker)
        try:
            self.empty.location = (0.9, 0.3, 1.7)
            end = time.monotonic() + 120
            while not poser.final:
                self.assertFalse(update(), "settled without a cold solve")
                self.assertLess(time.monotonic(), end)
                time.sleep(0.001)
            on_screen = U.raw_coords(self.obj).copy()
            self.empty.location = (0.7, 0.3, 1.8)
            update()
            self.assertEqual(len(starts), 2)
            np.testing.assert_array_equal(starts[1], on_screen)
            while not update():
                self.assertLess(time.monotonic(), end)
                time.sleep(0.001)
        finally:
            auto.native = native
        settled = U.raw_coords(self.obj).copy()
        auto.forget()
        api.set_auto(self.obj, False)
        api.set_auto(self.obj, True)    # --background: solved here, from the cold start
        np.testing.assert_array_equal(U.raw_coords(self.obj), settled)

    def test_in_the_viewport_the_bind_runs_on_its_own_thread(self):
        # A file opened, an undo or Auto turned on in the viewport: Blender's thread does not wait for
        # the bind. Here the bind is held until the test lets it go: the handler has returned, the mesh
        # shows what it showed, the status says binding; then the pose comes.
        self.empty.location = (0.9, 0.3, 1.7)
        release = threading.Event()
        bind = problem.Problem.bind

        def held_bind(problem_self):
            self.assertTrue(release.wait(60))
            return bind(problem_self)

        interactive = auto._interactive
        problem.Problem.bind = held_bind
        auto._interactive = lambda: True
        try:
            api.set_auto(self.obj, True)
            poser = auto._posers[self.obj.as_pointer()]
            self.assertEqual(poser.status(), "binding")
            np.testing.assert_array_equal(U.raw_coords(self.obj), self.rest)
            self.assertIn("binding", " ".join(auto.auto_status_lines()))
            release.set()
            self.settle_on_the_worker(poser)
        finally:
            release.set()
            problem.Problem.bind = bind
            auto._interactive = interactive
        posed = U.coords(self.obj)
        api.set_auto(self.obj, False)
        api.deform(self.obj, tolerance=self.obj.arap.tolerance)
        np.testing.assert_allclose(posed, U.coords(self.obj), atol=1e-3 * scale_of(posed))

    def test_in_the_viewport_a_large_mesh_is_read_over_several_updates(self):
        # Blender has no array read of vertex groups: in the viewport they are read a chunk of vertices per
        # update (here 50 of the bar's 480), the mesh unchanged meanwhile; the pose is the one read at once.
        meshio = U.addon("meshio")
        self.empty.location = (0.9, 0.3, 1.7)
        chunk, interactive = meshio.GROUP_CHUNK, auto._interactive
        meshio.GROUP_CHUNK, auto._interactive = 50, (lambda: True)
        try:
            api.set_auto(self.obj, True)
            poser = auto._posers[self.obj.as_pointer()]
            self.assertEqual(poser.status(), "reading the mesh")
            reads = 1
            while poser.problem is None:
                np.testing.assert_array_equal(U.raw_coords(self.obj), self.rest)
                auto.update_scene(bpy.context.scene)
                reads += 1
                self.assertLess(reads, 100, "the reading never ended")
            self.assertGreaterEqual(reads, 2)   # (an update can take two steps: its depsgraph's handler runs one)
            at_once = problem.Problem(self.obj, bpy.context.scene)
            np.testing.assert_array_equal(poser.problem.setup.constrained, at_once.setup.constrained)
            self.settle_on_the_worker(poser)
        finally:
            meshio.GROUP_CHUNK, auto._interactive = chunk, interactive
        posed = U.coords(self.obj)
        api.set_auto(self.obj, False)
        api.deform(self.obj, tolerance=self.obj.arap.tolerance)
        np.testing.assert_allclose(posed, U.coords(self.obj), atol=1e-3 * scale_of(posed))

    def test_opening_a_file_while_the_timer_runs_lets_the_next_update_start_it_again(self):
        # Loading a file removes Blender's non-persistent timers: an opened file whose Auto objects are
        # still binding must get the timer back, or they stay "binding" until something else moves.
        path = os.path.join(tempfile.mkdtemp(), "timer.blend")
        bpy.ops.wm.save_as_mainfile(filepath=path)
        auto._timer_on = True   # as while a pose settles in the viewport
        bpy.ops.wm.open_mainfile(filepath=path)
        self.assertFalse(auto._timer_on)
        self.obj = bpy.data.objects["Bar"]

    def test_an_error_of_a_bind_on_its_own_thread_stops_auto_with_its_message(self):
        release = threading.Event()

        def failing_bind(_problem):
            release.wait(60)
            raise SetupError("no memory left for this test")

        bind, interactive = problem.Problem.bind, auto._interactive
        problem.Problem.bind = failing_bind
        auto._interactive = lambda: True
        try:
            api.set_auto(self.obj, True)
            poser = auto._posers[self.obj.as_pointer()]
            release.set()
            poser.binding.wait()
            auto.update_scene(bpy.context.scene)   # the next update takes the bind's error
        finally:
            release.set()
            problem.Problem.bind = bind
            auto._interactive = interactive
        self.assertFalse(self.obj.arap.auto)
        self.assertIn("no memory left for this test", self.obj.arap.auto_status)
        np.testing.assert_array_equal(U.raw_coords(self.obj), self.rest)

    def assert_top_follows_the_empty(self, bind):
        """The handle's vertices moved by the Empty's motion since the bind (an affine map)."""
        motion = np.array(self.empty.matrix_world @ bind.inverted())
        rest_top = np.c_[self.rest3[self.top], np.ones(len(self.top))]
        expected = rest_top @ motion.T
        np.testing.assert_allclose(U.coords(self.obj)[self.top], expected[:, :3], atol=1e-4)

    def test_follows_a_driver(self):
        bind = self.empty.matrix_world.copy()
        controller = U.add_empty("Controller", Matrix.Translation((0, 0, 0)))
        fcurve = self.empty.driver_add("location", 0)
        var = fcurve.driver.variables.new()
        var.type = 'TRANSFORMS'
        var.targets[0].id = controller
        var.targets[0].transform_type = 'LOC_Y'
        fcurve.driver.expression = "0.5 * var"   # a simple expression: no script auto-run needed
        api.set_auto(self.obj, True)
        controller.location.y = 0.8
        bpy.context.view_layer.update()
        self.assertAlmostEqual(self.empty.matrix_world.translation.x, 0.4, places=5)
        self.assert_top_follows_the_empty(bind)

    def test_follows_a_constraint(self):
        bind = self.empty.matrix_world.copy()
        target = U.add_empty("Target", bind)
        copy = self.empty.constraints.new('COPY_LOCATION')
        copy.target = target
        api.set_auto(self.obj, True)
        target.location = (0.3, -0.2, 2.2)
        bpy.context.view_layer.update()
        np.testing.assert_allclose(self.empty.matrix_world.translation, (0.3, -0.2, 2.2), atol=1e-6)
        self.assert_top_follows_the_empty(bind)

    def test_follows_a_posed_bone_the_empty_is_parented_to(self):
        bind = self.empty.matrix_world.copy()
        rig = U.add_armature("Rig", [("Spine", (0, 0, -2), (0, 0, 0), None)])
        self.empty.parent, self.empty.parent_type, self.empty.parent_bone = rig, 'BONE', "Spine"
        bpy.context.view_layer.update()
        self.empty.matrix_world = bind   # parented where it was: the rest pose is unchanged
        bpy.context.view_layer.update()
        api.set_auto(self.obj, True)
        np.testing.assert_allclose(U.raw_coords(self.obj), self.rest, atol=1e-5)
        pose_bone = rig.pose.bones["Spine"]
        pose_bone.rotation_mode = 'XYZ'
        pose_bone.rotation_euler = (0.25, 0.0, 0.0)   # the bone bends: the Empty swings with it
        bpy.context.view_layer.update()
        self.assertGreater((self.empty.matrix_world.translation - bind.translation).length, 0.3)
        self.assert_top_follows_the_empty(bind)

    def test_the_pose_equals_deform(self):
        self.empty.location = (0.5, 0.2, 2.1)
        api.set_auto(self.obj, True)
        posed = U.coords(self.obj)
        api.set_auto(self.obj, False)
        api.deform(self.obj)
        np.testing.assert_allclose(posed, U.coords(self.obj), atol=1e-4 * scale_of(posed))

    def test_frame_set_poses_each_frame_and_scrubbing_writes_cached_poses(self):
        animate(self.empty)
        api.set_auto(self.obj, True)
        played = []
        for f in FRAMES:
            bpy.context.scene.frame_set(f)
            played.append(U.coords(self.obj))
        self.assertGreater(np.abs(played[-1] - played[0]).max(), 0.5)
        count = auto.solve_count
        for f in reversed(FRAMES):   # scrubbing back: every frame is in the cache
            bpy.context.scene.frame_set(f)
            np.testing.assert_array_equal(U.coords(self.obj), played[f - 1])
        self.assertEqual(auto.solve_count, count)

    def test_the_second_solver_gives_each_frame_the_pose_a_render_gives(self):
        # What the viewport caches for a frame played (final_poses.py) against --background's pose of it.
        final_poses = U.addon("final_poses")
        animate(self.empty)
        scene = bpy.context.scene
        poser = auto.AutoPoser(self.obj, scene)
        finals = final_poses.FinalPoses(poser.problem, self.obj.arap, poser.max_iterations)
        keys = {}
        try:
            for f in FRAMES:
                scene.frame_set(f)
                pose = poser.problem.pose(self.obj, depsgraph=bpy.context.evaluated_depsgraph_get())
                keys[(f, pose.key)] = f
                finals.want((f, pose.key), poser.problem.targets(pose), pose.transforms)
                finals.want((f, pose.key), poser.problem.targets(pose), pose.transforms)   # once only
            done = {}
            deadline = time.monotonic() + 120
            while finals.busy() and time.monotonic() < deadline:
                for key, positions, _transforms, stats in finals.poll():
                    self.assertTrue(stats.converged or stats.iterations == poser.max_iterations)
                    done[keys[key]] = positions
                time.sleep(0.01)
        finally:
            finals.stop()
        self.assertIsNone(finals.failed if finals.failed != "stopped" else None)
        self.assertEqual(sorted(done), list(FRAMES))
        api.set_auto(self.obj, True)
        for f in FRAMES:
            scene.frame_set(f)
            np.testing.assert_array_equal(done[f], U.raw_coords(self.obj), "frame %d" % f)

    def test_frames_do_not_depend_on_the_path(self):
        # Sequential play vs. jumping straight to frames in a shuffled order (a
        # fresh cache) vs. the bake: the same pose within the tolerance.
        animate(self.empty)
        api.set_auto(self.obj, True)
        played = {}
        for f in FRAMES:
            bpy.context.scene.frame_set(f)
            played[f] = U.coords(self.obj)
        auto.forget()
        order = [5, 2, 8, 1, 7, 3, 6, 4]
        worst = 0.0
        for f in order:
            bpy.context.scene.frame_set(f)
            worst = max(worst, np.abs(U.coords(self.obj) - played[f]).max())
        api.set_auto(self.obj, False)
        baked = bake.bake_shape_keys(self.obj, FRAMES[0], FRAMES[-1]).positions
        bake.clear_bake(self.obj)
        worst_bake = max(np.abs(baked[i] - played[f]).max() for i, f in enumerate(FRAMES))
        size = scale_of(self.rest3)
        print("path independence: worst scrub difference %.2e, vs bake %.2e (size %.2f)" % (worst, worst_bake, size))
        self.assertLess(worst, 1e-3 * size)
        self.assertLess(worst_bake, 1e-3 * size)

    def test_turning_off_restores_the_mesh_bit_for_bit(self):
        attributes = {a.name for a in self.obj.data.attributes}
        api.set_auto(self.obj, True)
        self.empty.location.x += 0.6
        bpy.context.view_layer.update()
        self.assertFalse(np.array_equal(U.raw_coords(self.obj), self.rest))
        api.set_auto(self.obj, False)
        np.testing.assert_array_equal(U.raw_coords(self.obj), self.rest)
        self.assertEqual({a.name for a in self.obj.data.attributes}, attributes)
        self.assertNotIn(auto.PROP_CREATED, self.obj.data)

    def test_turning_off_after_a_deform_brings_back_that_pose(self):
        self.empty.location.x += 0.4
        api.deform(self.obj)
        applied = U.raw_coords(self.obj).copy()
        self.assertFalse(np.array_equal(applied, self.rest))
        attributes = {a.name for a in self.obj.data.attributes}
        api.set_auto(self.obj, True)
        self.empty.location.x += 0.3
        bpy.context.view_layer.update()
        self.assertFalse(np.array_equal(U.raw_coords(self.obj), applied))
        # Kept in the file: saved and opened again while Auto is on.
        name = self.obj.name
        path = os.path.join(tempfile.mkdtemp(), "applied.blend")
        bpy.ops.wm.save_as_mainfile(filepath=path)
        bpy.ops.wm.open_mainfile(filepath=path)
        self.obj = bpy.data.objects[name]
        api.set_auto(self.obj, False)
        np.testing.assert_array_equal(U.raw_coords(self.obj), applied)
        self.assertEqual({a.name for a in self.obj.data.attributes}, attributes)

    def test_turning_off_after_a_live_apply_into_the_shape_key_brings_back_that_pose(self):
        self.obj.shape_key_add(name="Basis", from_mix=False)
        self.empty.location.x += 0.4
        session = api.start_session(self.obj)
        for _ in range(50):
            session.step()
        session.finish()
        key = self.obj.data.shape_keys.key_blocks["ARAP"]
        applied = np.empty(len(self.rest), np.float32)
        key.data.foreach_get("co", applied)
        self.assertFalse(np.array_equal(applied, self.rest))
        api.set_auto(self.obj, True)
        self.empty.location.x -= 0.8
        bpy.context.view_layer.update()
        api.set_auto(self.obj, False)
        now = np.empty(len(self.rest), np.float32)
        self.obj.data.shape_keys.key_blocks["ARAP"].data.foreach_get("co", now)
        np.testing.assert_array_equal(now, applied)
        self.assertNotIn(auto.BEFORE_ATTRIBUTE, self.obj.data.attributes)

    def test_shape_key_result_and_off(self):
        self.obj.shape_key_add(name="Basis", from_mix=False)
        api.set_auto(self.obj, True)
        self.empty.location.x += 0.6
        bpy.context.view_layer.update()
        key = self.obj.data.shape_keys.key_blocks["ARAP"]
        self.assertGreater(np.abs(U.evaluated_coords(self.obj) - self.rest3).max(), 0.5)
        basis = np.empty(len(self.rest), np.float32)
        self.obj.data.shape_keys.reference_key.data.foreach_get("co", basis)
        np.testing.assert_array_equal(basis, self.rest)  # the rest shape (Basis) is never touched
        self.assertIsNotNone(key)
        api.set_auto(self.obj, False)
        self.assertEqual([kb.name for kb in self.obj.data.shape_keys.key_blocks], ["Basis"])
        np.testing.assert_allclose(U.evaluated_coords(self.obj), self.rest3, atol=0)

    def test_deleted_empty_stops_auto_at_rest(self):
        api.set_auto(self.obj, True)
        self.empty.location.x += 0.6
        bpy.context.view_layer.update()
        bpy.data.objects.remove(self.empty)
        bpy.context.view_layer.update()   # the handler must not raise
        self.assertFalse(self.obj.arap.auto)
        self.assertIn("deleted", self.obj.arap.auto_status)
        np.testing.assert_array_equal(U.raw_coords(self.obj), self.rest)
        with self.assertRaises(SetupError):
            api.set_auto(self.obj, True)   # and a clear error when turned on again
        self.assertFalse(self.obj.arap.auto)

    def test_vertex_count_change_stops_auto(self):
        api.set_auto(self.obj, True)
        self.obj.data.vertices.add(1)
        bpy.context.view_layer.update()
        self.assertFalse(self.obj.arap.auto)
        self.assertIn("changed its vertices", self.obj.arap.auto_status)

    def test_edit_mode_stops_auto_and_shows_the_rest_shape(self):
        api.set_auto(self.obj, True)
        self.empty.location.x += 0.6
        bpy.context.view_layer.update()
        bpy.context.view_layer.objects.active = self.obj
        bpy.ops.object.mode_set(mode='EDIT')
        bpy.context.view_layer.update()
        bpy.ops.object.mode_set(mode='OBJECT')
        self.assertFalse(self.obj.arap.auto)
        self.assertIn("Edit Mode", self.obj.arap.auto_status)
        np.testing.assert_allclose(U.raw_coords(self.obj), self.rest, atol=0)

    def test_live_owns_the_object_while_it_runs(self):
        api.set_auto(self.obj, True)
        session = api.start_session(self.obj)
        count = auto.solve_count
        self.empty.location.x += 0.3
        bpy.context.view_layer.update()
        self.assertEqual(auto.solve_count, count)
        session.step()
        session.cancel()

    def test_save_and_reload(self):
        animate(self.empty)
        api.set_auto(self.obj, True)
        bpy.context.scene.frame_set(4)
        at4 = U.coords(self.obj)
        path = os.path.join(tempfile.mkdtemp(prefix="arap_auto_"), "auto.blend")
        bpy.ops.wm.save_as_mainfile(filepath=path)
        bpy.ops.wm.open_mainfile(filepath=path)
        obj = bpy.data.objects["Bar"]
        self.obj = obj
        self.assertTrue(obj.arap.auto)
        bpy.context.scene.frame_set(6)   # binds again lazily
        bpy.context.scene.frame_set(4)
        np.testing.assert_allclose(U.coords(obj), at4, atol=1e-4 * scale_of(at4))

    def test_undo_brings_back_the_pose_of_the_restored_handles(self):
        api.set_auto(self.obj, True)
        self.empty.location.x += 0.3
        bpy.context.view_layer.update()
        first = U.coords(self.obj)
        bpy.ops.ed.undo_push(message="first move")
        bpy.data.objects["TopEmpty"].location.x += 0.4
        bpy.context.view_layer.update()
        bpy.ops.ed.undo_push(message="second move")
        self.assertGreater(np.abs(U.coords(bpy.data.objects["Bar"]) - first).max(), 0.3)
        bpy.ops.ed.undo()
        obj = bpy.data.objects["Bar"]
        self.obj = obj
        self.assertTrue(obj.arap.auto)
        np.testing.assert_allclose(U.coords(obj), first, atol=1e-4 * scale_of(first))


class AutoRender(unittest.TestCase):
    def test_render_anim_and_single_frames_pose_the_mesh(self):
        U.clear_scene()
        obj, empty, _fixed, _top = U.bar_with_handle()
        animate(empty)
        scene = bpy.context.scene
        scene.frame_start, scene.frame_end = 1, 8
        cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
        scene.collection.objects.link(cam)
        cam.location = (0.0, -12.0, 0.5)
        cam.rotation_euler = (1.5708, 0.0, 0.0)
        scene.camera = cam
        scene.render.engine = 'BLENDER_WORKBENCH'
        scene.render.resolution_x = scene.render.resolution_y = 96
        scene.render.image_settings.file_format = 'PNG'
        api.set_auto(obj, True)
        tmp = tempfile.mkdtemp(prefix="arap_auto_render_")
        scene.render.filepath = os.path.join(tmp, "anim_")
        path = os.path.join(tmp, "auto.blend")
        bpy.ops.wm.save_as_mainfile(filepath=path, copy=True)
        api.set_auto(obj, False)
        # A new Blender renders the file: frames 1 and 8 of --render-anim, and -f 8 alone.
        U.run_blender_args([path, "--addons", U.ADDON_MODULE, "-s", "1", "-e", "8", "-j", "7", "--render-anim"],
                           factory_startup=False)
        U.run_blender_args([path, "--addons", U.ADDON_MODULE, "-o", os.path.join(tmp, "single_"), "-f", "8"],
                           factory_startup=False)
        frames = [self.pixels(os.path.join(tmp, name)) for name in ("anim_0001.png", "anim_0008.png",
                                                                     "single_0008.png")]
        self.assertGreater(np.abs(frames[0] - frames[1]).max(), 0.2)   # the bar bends as the handle moves
        np.testing.assert_allclose(frames[1], frames[2], atol=2 / 255)  # -f 8 alone gives the same picture

    def pixels(self, path):
        self.assertTrue(os.path.exists(path), path)
        image = bpy.data.images.load(path)
        try:
            return np.array(image.pixels[:], np.float32)
        finally:
            bpy.data.images.remove(image)


if __name__ == "__main__":
    unittest.main()
