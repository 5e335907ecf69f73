# The animation bake (bake.py) and its operator (bake_ops.py): playback equals
# the solve, determinism, rest shape untouched, stationary and coherent frames.
import os
import tempfile
import unittest
import warnings

import bpy
import numpy as np

import arap_test_utils as U

anim_compat, api, bake, bake_ops = U.addon("anim_compat", "api", "bake", "bake_ops")
SetupError = U.addon("constraints").SetupError

FRAMES = range(1, 11)


def animate(empty):
    """Keyframes: the top swings sideways, rises and turns; frame 1 is already off the bind pose."""
    for i, f in enumerate(FRAMES):
        empty.location = (0.3 + 0.12 * i, 0.0, 2.0 + 0.04 * i)
        empty.rotation_euler = (0.0, 0.06 * i, 0.0)
        empty.keyframe_insert("location", frame=f)
        empty.keyframe_insert("rotation_euler", frame=f)


def playback(obj, frames):
    out = []
    for f in frames:
        bpy.context.scene.frame_set(f)
        out.append(U.evaluated_coords(obj))
    return np.array(out)


def float32_tol(values):
    return 8 * np.finfo(np.float32).eps * max(1.0, float(np.abs(values).max()))


class Bake(unittest.TestCase):
    def setUp(self):
        U.clear_scene()
        if not bake_ops.ARAP_OT_bake.is_registered:  # until __init__.py registers bake_ops
            bake_ops.register()
        self.obj, self.empty, self.fixed, self.top = U.bar_with_handle()
        animate(self.empty)
        bpy.context.scene.frame_set(1)
        self.rest = U.raw_coords(self.obj).copy()
        self.tmp = tempfile.mkdtemp(prefix="arap_bake_")

    def assert_rest_untouched(self):
        self.assertTrue(np.array_equal(U.raw_coords(self.obj), self.rest))
        keys = self.obj.data.shape_keys
        if keys is not None:
            basis = np.empty(len(self.rest), np.float32)
            keys.reference_key.data.foreach_get("co", basis)
            self.assertTrue(np.array_equal(basis, self.rest))

    def test_shape_keys_play_back_the_solve(self):
        r = bake.bake_shape_keys(self.obj, FRAMES[0], FRAMES[-1])
        names = [kb.name for kb in self.obj.data.shape_keys.key_blocks]
        self.assertEqual(names, ["Basis"] + [bake.key_name(f) for f in FRAMES])
        curves, _ = anim_compat.fcurves(self.obj.data.shape_keys)
        fc = curves.find('key_blocks["ARAP_f0004"].value')
        self.assertEqual([tuple(p.co) for p in fc.keyframe_points], [(3.0, 0.0), (4.0, 1.0), (5.0, 0.0)])
        self.assertEqual(bpy.context.scene.frame_current, 1)  # the bake puts the frame back
        played = playback(self.obj, FRAMES)
        np.testing.assert_allclose(played, r.positions, rtol=0, atol=float32_tol(r.positions))
        self.assertGreater(np.abs(r.positions[-1] - self.rest.reshape(-1, 3)).max(), 0.5)
        self.assert_rest_untouched()

    def test_pc2_plays_back_the_solve(self):
        path = os.path.join(self.tmp, "bar.pc2")
        r = bake.bake_pc2(self.obj, path, FRAMES[0], FRAMES[-1])
        start, rate, data = bake.read_pc2(path)
        self.assertEqual((start, rate, data.shape), (1.0, 1.0, (len(FRAMES), len(self.rest) // 3, 3)))
        with open(path, "rb") as f:
            self.assertEqual(f.read(12), b"POINTCACHE2\0")
        self.assertEqual(r.path, path)
        self.assertEqual(len(r.energies), len(FRAMES))
        mod = self.obj.modifiers[0]
        self.assertEqual((mod.type, mod.cache_format, mod.name), ('MESH_CACHE', 'PC2', bake.MODIFIER_NAME))
        played = playback(self.obj, FRAMES)
        np.testing.assert_allclose(played, data, rtol=0, atol=float32_tol(data))
        self.assertIsNone(self.obj.data.shape_keys)
        self.assert_rest_untouched()
        self.assertEqual([n for n in os.listdir(self.tmp)], ["bar.pc2"])  # no temporary file left
        # The same solve as a shape-key bake (which replaces the cache modifier).
        self.assertTrue(np.array_equal(bake.bake_shape_keys(self.obj, 1, 10).positions, data))
        self.assertEqual(len(self.obj.modifiers), 0)

    def test_baking_twice_is_identical(self):
        a = bake.bake_shape_keys(self.obj, FRAMES[0], FRAMES[-1]).positions.copy()
        b = bake.bake_shape_keys(self.obj, FRAMES[0], FRAMES[-1]).positions
        self.assertTrue(np.array_equal(a, b))
        self.assertEqual(len(self.obj.data.shape_keys.key_blocks), len(FRAMES) + 1)
        p1, p2 = os.path.join(self.tmp, "1.pc2"), os.path.join(self.tmp, "2.pc2")
        bake.bake_pc2(self.obj, p1, FRAMES[0], FRAMES[-1])
        bake.bake_pc2(self.obj, p2, FRAMES[0], FRAMES[-1])
        with open(p1, "rb") as f1, open(p2, "rb") as f2:
            self.assertEqual(f1.read(), f2.read())
        self.assertTrue(np.array_equal(bake.read_pc2(p1)[2], a))
        self.assertEqual([m.name for m in self.obj.modifiers], [bake.MODIFIER_NAME])

    def test_existing_basis_is_kept_and_live_key_muted(self):
        self.obj.shape_key_add(name="Basis", from_mix=False)
        live = self.obj.shape_key_add(name="ARAP", from_mix=False)
        live.value = 1.0
        r = bake.bake_shape_keys(self.obj, FRAMES[0], FRAMES[-1])
        self.assertTrue(live.mute)
        played = playback(self.obj, FRAMES)
        np.testing.assert_allclose(played, r.positions, rtol=0, atol=float32_tol(r.positions))
        self.assert_rest_untouched()
        bake.clear_bake(self.obj)
        self.assertEqual([kb.name for kb in self.obj.data.shape_keys.key_blocks], ["Basis", "ARAP"])
        self.assertFalse(live.mute)

    def test_the_per_frame_cap_is_max_iterations_and_iterations_its_deprecated_name(self):
        r = bake.bake_shape_keys(self.obj, 1, 3, max_iterations=2, tolerance=0.0)
        self.assertEqual(max(r.iterations), 2)
        with self.assertWarns(DeprecationWarning):
            r = bake.bake_pc2(self.obj, os.path.join(self.tmp, "old.pc2"), 1, 3, iterations=2, tolerance=0.0)
        self.assertEqual(max(r.iterations), 2)

    def test_every_frame_is_stationary(self):
        # The bake solves to the object's tolerance (as Auto mode): a tight one gives stationary frames.
        self.assertTrue(all(bake.bake_shape_keys(self.obj, FRAMES[0], FRAMES[-1]).converged))
        self.obj.arap.tolerance = 1e-10
        r = bake.bake_shape_keys(self.obj, FRAMES[0], FRAMES[-1], measure_gradient=True)
        self.assertGreater(r.gradient_reference, 1e-3)
        self.assertTrue(all(r.converged), r.iterations)
        worst = max(r.gradients)
        self.assertLess(worst, 1e-4 * r.gradient_reference, r.gradients)

    def test_frames_are_coherent(self):
        r = bake.bake_shape_keys(self.obj, FRAMES[0], FRAMES[-1])
        p = r.positions.astype(np.float64)
        for i in range(1, len(p)):
            handle_move = np.linalg.norm(p[i][self.top] - p[i - 1][self.top], axis=1).max()
            jump = np.linalg.norm(p[i] - p[i - 1], axis=1).max()
            self.assertLessEqual(jump, 1.5 * handle_move + 1e-6, "frame %d" % FRAMES[i])

    def test_constraint_driven_empty(self):
        # The handle empty follows another empty through a Copy Location constraint.
        leader = U.add_empty("Leader")
        for f, x in ((1, 0.0), (5, 0.8)):
            leader.location = (x, 0.0, 2.0)
            leader.keyframe_insert("location", frame=f)
        self.empty.animation_data_clear()
        con = self.empty.constraints.new('COPY_LOCATION')
        con.target = leader
        r = bake.bake_shape_keys(self.obj, 1, 5)
        top_rest = self.rest.reshape(-1, 3)[self.top].astype(np.float64)
        for i, f in enumerate(range(1, 6)):
            bpy.context.scene.frame_set(f)
            dx = leader.matrix_world.translation.x
            np.testing.assert_allclose(r.positions[i][self.top], top_rest + (dx, 0, 0), atol=1e-5)

    def test_clear_bake_restores(self):
        bake.bake_shape_keys(self.obj, FRAMES[0], FRAMES[-1])
        bake.clear_bake(self.obj)
        self.assertIsNone(self.obj.data.shape_keys)
        self.assertFalse(any(a.name.endswith("_ARAPBake") for a in bpy.data.actions))
        bake.bake_pc2(self.obj, os.path.join(self.tmp, "c.pc2"), 1, 3)
        self.assertTrue(bake.is_baked(self.obj))
        bake.clear_bake(self.obj)
        self.assertEqual(len(self.obj.modifiers), 0)
        self.assertFalse(bake.is_baked(self.obj))
        bpy.context.scene.frame_set(5)
        np.testing.assert_array_equal(U.evaluated_coords(self.obj), U.coords(self.obj))
        self.assertEqual(set(self.obj.data.keys()) & {bake.PROP_BASIS, bake.PROP_ACTION}, set())

    def test_cancel_changes_nothing(self):
        pc2 = os.path.join(self.tmp, "cancelled.pc2")
        for baker in (bake.Baker(self.obj, 1, 10), bake.Baker(self.obj, 1, 10, pc2_path=pc2)):
            for _ in range(3):
                baker.step()
            baker.cancel()
            self.assertIsNone(self.obj.data.shape_keys)
            self.assertEqual(len(self.obj.modifiers), 0)
            self.assertEqual(bpy.context.scene.frame_current, 1)
            self.assert_rest_untouched()
        self.assertEqual(os.listdir(self.tmp), [])  # the streamed .pc2 temporary file is gone

    def test_interactive_bake_shows_frames_then_writes_the_bake(self):
        # What the modal operator runs each tick: the frames are solved on the worker's thread,
        # the newest solved one is shown on the mesh, the status shows the progress, and the result
        # equals a synchronous bake's bit for bit (the preview is undone before writing).
        run = bake_ops.InteractiveBake(bake.Baker(self.obj, 1, 4))
        self.assertIs(bake_ops.InteractiveBake.current, run)
        shown = {}
        done = False
        while not done:      # a tick posts or takes frames (all four, if the worker was that quick)
            done = run.step(slice_ms=0.0)
            if run.baker.index:
                shown[run.baker.index] = U.raw_coords(self.obj).copy()
            self.assertIn("of 4", run.status())
        self.assertTrue(shown)
        for solved, coords in shown.items():   # the mesh shows the newest solved frame
            np.testing.assert_array_equal(coords, run.baker.positions[solved - 1].ravel())
            self.assertGreater(np.abs(coords - self.rest).max(), 0.1)
        self.assertEqual(run.fraction, 1.0)
        result = run.finish(lambda baker: baker.write_shape_keys())
        self.assertIsNone(bake_ops.InteractiveBake.current)
        self.assert_rest_untouched()
        reference = bake.bake_shape_keys(self.obj, 1, 4)
        np.testing.assert_array_equal(result.positions, reference.positions)

    def test_a_tick_takes_every_frame_that_comes_back_in_its_slice(self):
        run = bake_ops.InteractiveBake(bake.Baker(self.obj, 1, 6))
        self.assertTrue(run.step(slice_ms=60000.0))   # a small mesh: all six frames in one tick
        np.testing.assert_array_equal(U.raw_coords(self.obj), run.baker.positions[5].ravel())
        run.cancel()
        self.assert_rest_untouched()

    def test_interactive_bake_cancel_restores_the_mesh(self):
        run = bake_ops.InteractiveBake(bake.Baker(self.obj, 1, 10))
        while run.baker.index < 2:
            run.step(slice_ms=0.0)
        self.assertFalse(np.array_equal(U.raw_coords(self.obj), self.rest))
        run.cancel()
        self.assertIsNone(bake_ops.InteractiveBake.current)
        self.assertIsNone(self.obj.data.shape_keys)
        self.assertEqual(bpy.context.scene.frame_current, 1)
        self.assert_rest_untouched()
        self.assertFalse(self.obj.data.attributes.get("arap_rest"))
        self.assertFalse(run.baker.solver.busy)

    def test_status_bar_draws_a_progress_bar(self):
        class Layout:  # records what draw_status_bar asks of the status bar's layout
            def __init__(self):
                self.calls = []

            def progress(self, **kw):
                self.calls.append(("progress", kw))

            def label(self, **kw):
                self.calls.append(("label", kw))

        header = type("Header", (), {"layout": Layout()})()
        bake_ops.draw_status_bar(header, bpy.context)
        self.assertEqual(header.layout.calls, [])  # nothing while no bake runs
        run = bake_ops.InteractiveBake(bake.Baker(self.obj, 1, 4))
        # One frame solved, by hand: a tick of run.step() takes as many as the worker finished,
        # which on this tiny mesh can be any number.
        run.baker.post_frame(run.worker)
        self.assertTrue(run.worker.wait(30000))
        self.assertTrue(run.baker.take_frame(run.worker))
        self.assertEqual(run.baker.index, 1)
        bake_ops.draw_status_bar(header, bpy.context)
        kind, kw = header.layout.calls[-1]
        self.assertEqual(kind, "progress")
        self.assertAlmostEqual(kw["factor"], 0.25)
        self.assertEqual(kw["text"], "1/4")          # what fits the bar's own width
        # The words go to the viewport, where nothing cuts them.
        lines = bake_ops.bake_status_lines()
        self.assertIn("ARAP bake of 'Bar': frame 1 (1 of 4)", lines[0])
        self.assertIn("Esc", lines[-1])
        run.cancel()
        self.assertEqual(bake_ops.bake_status_lines(), [])

    def test_deleted_empty_is_a_setup_error(self):
        bpy.data.objects.remove(self.empty)
        with self.assertRaises(SetupError):
            bake.bake_shape_keys(self.obj, 1, 3)
        self.assertIsNone(self.obj.data.shape_keys)

    def test_operator_runs_synchronously_in_background(self):
        bpy.context.view_layer.objects.active = self.obj
        self.assertEqual(bpy.ops.object.arap_bake(frame_start=1, frame_end=4, output='SHAPE_KEYS'), {'FINISHED'})
        self.assertEqual(len(self.obj.data.shape_keys.key_blocks), 5)
        path = os.path.join(self.tmp, "op.pc2")
        self.assertEqual(bpy.ops.object.arap_bake(frame_start=2, frame_end=4, output='PC2', filepath=path),
                         {'FINISHED'})
        self.assertIsNone(self.obj.data.shape_keys)  # the new bake replaced the old one
        self.assertEqual(bake.read_pc2(path)[2].shape[0], 3)
        self.assertEqual(bpy.ops.object.arap_bake_clear(), {'FINISHED'})
        self.assertFalse(bake.is_baked(self.obj))
        # Invoked (as from a button) in --background: still synchronous.
        self.assertEqual(bpy.ops.object.arap_bake('INVOKE_DEFAULT', frame_start=1, frame_end=2), {'FINISHED'})

    def test_blend_relative_path_without_a_warning(self):
        # Blender 5.2 warns at each "//" value of a FILE_PATH property that does not
        # declare PATH_SUPPORTS_BLEND_RELATIVE (3.4 and 4.3 refuse the flag).
        bpy.ops.wm.save_as_mainfile(filepath=os.path.join(self.tmp, "scene.blend"))
        bpy.context.view_layer.objects.active = self.obj
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            result = bpy.ops.object.arap_bake(frame_start=1, frame_end=3, output='PC2', filepath="//x.pc2")
        self.assertEqual(result, {'FINISHED'})
        self.assertEqual([str(w.message) for w in caught], [])
        self.assertEqual(bake.read_pc2(os.path.join(self.tmp, "x.pc2"))[2].shape[0], 3)
        prop = bpy.ops.object.arap_bake.get_rna_type().properties["filepath"]
        if hasattr(prop, "is_path_supports_blend_relative"):
            self.assertTrue(prop.is_path_supports_blend_relative)

    def test_operator_reports_setup_errors(self):
        bpy.context.view_layer.objects.active = self.obj
        api.set_fixed(self.obj, "")
        self.obj.arap.handles.clear()
        with self.assertRaises(RuntimeError):  # the operator's ERROR report becomes RuntimeError
            bpy.ops.object.arap_bake(frame_start=1, frame_end=2)
        self.assertIsNone(self.obj.data.shape_keys)


if __name__ == "__main__":
    unittest.main()
