# A bind that would not fit in the memory Blender has left is refused before it
# allocates: an "out of memory" error with both figures in the status bar (the
# operator) or as ArapError (scripts), the mesh untouched, Blender going on.
# Without the check, a desktop Linux overcommits and the OOM killer ends
# Blender when the pages are touched, unsaved work and all. The limit here is
# the address space (RLIMIT_AS, as `ulimit -v`), set just above what Blender
# uses for the length of one call.
import contextlib
import resource
import unittest

import bpy
import numpy as np

import arap_test_utils as U

api, native_loader, sessions = U.addon("api", "native_loader", "sessions")


HEADROOM_MB = 64


@contextlib.contextmanager
def address_space_left(megabytes):
    """Blender may grow by about `megabytes` while the block runs."""
    with open("/proc/self/status") as f:
        size = next(int(line.split()[1]) * 1024 for line in f if line.startswith("VmSize:"))
    before = resource.getrlimit(resource.RLIMIT_AS)
    resource.setrlimit(resource.RLIMIT_AS, (size + (megabytes << 20), before[1]))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_AS, before)


class MemoryLimit(unittest.TestCase):
    def setUp(self):
        U.clear_scene()
        # A 450 x 450 grid (about 200k vertices): its bind needs about 190 MiB more than Blender uses, far more
        # than the HEADROOM_MB it is given; the arrays read from the mesh on the way (some 30 MiB) fit in it.
        self.obj = U.add_grid(x=450, y=450, size=4.0)
        U.group_where(self.obj, "left", lambda co: co.x < -1.8)
        U.group_where(self.obj, "right", lambda co: co.x > 1.8)
        api.set_fixed(self.obj, "left")
        self.empty = U.add_empty("RightEmpty")
        api.add_handle(self.obj, "right", self.empty)
        self.empty.location.z += 0.5
        bpy.context.view_layer.update()
        self.rest = U.raw_coords(self.obj)

    def test_deform_from_a_script_raises_a_typed_error_and_leaves_the_mesh(self):
        with address_space_left(HEADROOM_MB):
            with self.assertRaises(native_loader.native().ArapError) as cm:
                api.deform(self.obj)
        self.assertEqual(cm.exception.code, "out of memory")
        message = str(cm.exception)
        self.assertIn("binding %d vertices" % len(self.obj.data.vertices), message)
        self.assertIn("needs about", message)
        self.assertIn("is left under the address-space limit", message)
        np.testing.assert_array_equal(U.raw_coords(self.obj), self.rest)
        # Blender goes on: with the limit lifted the same Deform poses the mesh.
        api.deform(self.obj)
        self.assertGreater(np.abs(U.raw_coords(self.obj) - self.rest).max(), 0.1)

    def test_the_deform_operator_cancels_and_blender_goes_on(self):
        # In the background an operator's error report comes back as RuntimeError (in a window: the status bar).
        with address_space_left(HEADROOM_MB):
            with self.assertRaises(RuntimeError) as cm:
                bpy.ops.object.arap_deform()
        self.assertIn("ARAP solver: binding", str(cm.exception))
        self.assertIn("more memory, but only", str(cm.exception))
        np.testing.assert_array_equal(U.raw_coords(self.obj), self.rest)
        self.assertEqual(bpy.ops.object.arap_deform(), {'FINISHED'})
        self.assertGreater(np.abs(U.raw_coords(self.obj) - self.rest).max(), 0.1)

    def test_live_does_not_start(self):
        with address_space_left(HEADROOM_MB):
            with self.assertRaises(native_loader.native().ArapError) as cm:
                api.start_session(self.obj)
        self.assertEqual(cm.exception.code, "out of memory")
        self.assertIsNone(sessions.session_for(self.obj))
        np.testing.assert_array_equal(U.raw_coords(self.obj), self.rest)


if __name__ == "__main__":
    unittest.main()
