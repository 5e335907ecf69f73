# Saving the .blend while Live runs, while a bake runs and while Auto mode settles writes a file
# that reopens consistent: the rest shape recoverable, no bake preview kept, the settings intact.
# A Blender killed during a bake leaves the previous .pc2 and the .blend as they were.
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import unittest

import bpy
import numpy as np
from mathutils import Matrix

import arap_test_utils as U

api, auto, bake, bake_ops, live, meshio = U.addon("api", "auto", "bake", "bake_ops", "live", "meshio")


def rest_attribute(obj):
    attr = obj.data.attributes.get(meshio.REST_ATTRIBUTE)
    if attr is None:
        return None
    out = np.empty(3 * len(obj.data.vertices), np.float32)
    attr.data.foreach_get("vector", out)
    return out


class SaveWhilePosing(unittest.TestCase):
    def setUp(self):
        U.clear_scene()
        self.obj, self.empty, _fixed, self.top = U.bar_with_handle()
        self.obj.arap.output = 'MESH'
        self.obj.arap.max_iterations = 23
        self.rest = U.raw_coords(self.obj).copy()
        self.tmp = tempfile.mkdtemp(prefix="arap_save_")
        self.path = os.path.join(self.tmp, "posing.blend")

    def tearDown(self):
        shutil.rmtree(self.tmp, ignore_errors=True)

    def reopen(self):
        bpy.ops.wm.open_mainfile(filepath=self.path)
        return bpy.data.objects["Bar"]

    def test_live_saves_the_pose_with_its_rest_shape(self):
        self.assertIsNone(rest_attribute(self.obj))
        session = live.LiveSession(self.obj, bpy.context.scene)
        self.empty.matrix_world = Matrix.Translation((0.8, 0.0, 2.2))
        for _ in range(50):
            session.step()
        shown = U.raw_coords(self.obj).copy()
        self.assertGreater(np.abs(shown - self.rest).max(), 0.5)
        bpy.ops.wm.save_as_mainfile(filepath=self.path)
        # Saving changed nothing for the running session: cancel still restores exactly.
        self.assertTrue(np.array_equal(U.raw_coords(self.obj), shown))
        session.cancel()
        self.assertTrue(np.array_equal(U.raw_coords(self.obj), self.rest))
        self.assertIsNone(rest_attribute(self.obj))

        obj = self.reopen()
        self.assertTrue(np.array_equal(U.raw_coords(obj), shown))   # what was on screen
        self.assertTrue(np.array_equal(rest_attribute(obj), self.rest))
        self.assertEqual((obj.arap.output, obj.arap.max_iterations, obj.arap.handles[0].empty.name),
                         ('MESH', 23, "TopEmpty"))
        api.reset(obj)
        self.assertTrue(np.array_equal(U.raw_coords(obj), self.rest))

    def test_a_second_save_during_live_keeps_the_first_rest(self):
        api.set_rest_pose(self.obj)   # a rest attribute there before Live: Live keeps it
        session = live.LiveSession(self.obj, bpy.context.scene)
        self.empty.matrix_world = Matrix.Translation((0.5, 0.0, 2.0))
        for _ in range(20):
            session.step()
        bpy.ops.wm.save_as_mainfile(filepath=self.path)
        session.step()
        bpy.ops.wm.save_as_mainfile(filepath=self.path)
        session.cancel()
        self.assertTrue(np.array_equal(rest_attribute(self.obj), self.rest))
        obj = self.reopen()
        self.assertTrue(np.array_equal(rest_attribute(obj), self.rest))

    def test_a_bake_in_progress_is_not_saved(self):
        for i, f in enumerate(range(1, 9)):
            self.empty.location = (0.2 + 0.1 * i, 0.0, 2.0)
            self.empty.keyframe_insert("location", frame=f)
        bpy.context.scene.frame_set(1)
        shown_before = U.raw_coords(self.obj).copy()
        run = bake_ops.InteractiveBake(bake.Baker(self.obj, 1, 8))
        while run.baker.index < 3:
            run.step()
        self.assertFalse(np.array_equal(U.raw_coords(self.obj), shown_before))   # the preview is shown
        preview = U.raw_coords(self.obj).copy()
        bpy.ops.wm.save_as_mainfile(filepath=self.path)
        self.assertTrue(np.array_equal(U.raw_coords(self.obj), preview))          # and still shown after
        while not run.step():
            pass
        run.finish(lambda baker: baker.write_shape_keys())
        obj = self.reopen()
        # The file holds the mesh as it was before the bake: no preview pose, no half bake.
        self.assertTrue(np.array_equal(U.raw_coords(obj), shown_before))
        self.assertFalse(bake.is_baked(obj))
        self.assertIsNone(rest_attribute(obj))
        self.assertEqual(obj.arap.max_iterations, 23)

    def test_auto_mode_saved_while_settling_reopens_posed(self):
        api.set_auto(self.obj, True)
        poser = auto._posers[self.obj.as_pointer()]
        self.empty.location = (0.9, 0.3, 1.7)
        auto._busy = True   # keep the handler (which solves fully in --background) out of this update
        try:
            depsgraph = bpy.context.evaluated_depsgraph_get()
        finally:
            auto._busy = False
        settled = poser.update(self.obj, depsgraph, on_worker=True)
        self.assertFalse(settled)   # the worker is settling the pose while the file is saved
        bpy.ops.wm.save_as_mainfile(filepath=self.path)
        end = time.monotonic() + 120
        while not poser.update(self.obj, depsgraph, on_worker=True):
            self.assertLess(time.monotonic(), end, "Auto never settled")
            time.sleep(0.002)
        posed = U.raw_coords(self.obj).copy()
        obj = self.reopen()
        self.assertTrue(obj.arap.auto)
        self.assertTrue(np.array_equal(rest_attribute(obj), self.rest))
        auto.update_scene(bpy.context.scene)    # the file's pose: the settled pose of its handles
        scale = float(np.abs(posed).max())
        np.testing.assert_allclose(U.raw_coords(obj), posed, atol=1e-3 * scale)


KILLED_BAKE = r"""
import sys, bpy
sys.path.insert(0, %(tests)r)
import arap_test_utils as U
U.enable_addon()
bake = U.addon("bake")
obj = bpy.data.objects["Bar"]
print("BAKING", flush=True)
bake.bake_pc2(obj, %(pc2)r, 1, 400)
print("FINISHED", flush=True)
"""


class KilledDuringBake(unittest.TestCase):
    def test_sigkill_leaves_the_previous_cache_and_blend(self):
        U.clear_scene()
        obj, empty, _fixed, _top = U.bar_with_handle(vertices=64, cuts=60)
        for f in (1, 400):
            empty.location = (0.002 * f, 0.0, 2.0 + 0.0005 * f)
            empty.keyframe_insert("location", frame=f)
        tmp = tempfile.mkdtemp(prefix="arap_kill_")
        try:
            pc2 = os.path.join(tmp, "Bar.pc2")
            blend = os.path.join(tmp, "shot.blend")
            bake.bake_pc2(obj, pc2, 1, 3)              # the previous cache: three frames
            bpy.ops.wm.save_as_mainfile(filepath=blend)
            before = {p: open(p, "rb").read() for p in (pc2, blend)}
            script = os.path.join(tmp, "bake.py")
            with open(script, "w") as f:
                f.write(KILLED_BAKE % {"tests": os.path.dirname(os.path.abspath(U.__file__)), "pc2": pc2})
            child = subprocess.Popen([bpy.app.binary_path, "--background", "--factory-startup", "-noaudio", blend,
                                      "--python", script], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                     env=dict(os.environ), text=True)
            try:
                self.assertEqual(self._wait_for_partial_cache(child, tmp), True)
                child.send_signal(signal.SIGKILL)
                child.wait(timeout=60)
            finally:
                if child.poll() is None:
                    child.kill()
                    child.wait()
            self.assertEqual(child.returncode, -signal.SIGKILL)
            for path, data in before.items():
                with open(path, "rb") as f:
                    self.assertEqual(f.read(), data, path)
            self.assertEqual(bake.read_pc2(pc2)[2].shape[0], 3)
            # What the killed bake leaves is a hidden temporary file of its own, never the cache itself.
            leftovers = [n for n in os.listdir(tmp) if n not in ("Bar.pc2", "shot.blend", "bake.py")]
            self.assertTrue(all(n.startswith(".Bar.arap-tmp-%d" % child.pid) for n in leftovers), leftovers)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)

    @staticmethod
    def _wait_for_partial_cache(child, folder, timeout=120):
        """True once the child's temporary .pc2 holds more than its header (the bake is under way)."""
        tmp_name = ".Bar.arap-tmp-%d.pc2" % child.pid
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if child.poll() is not None:
                sys.stdout.write(child.stdout.read())
                return False
            try:
                if os.path.getsize(os.path.join(folder, tmp_name)) > 32 + 3 * 4 * 64 * 10:
                    return True
            except OSError:
                pass
            time.sleep(0.02)
        return False


if __name__ == "__main__":
    unittest.main()
