# Settings survive save and reload of the .blend; Deform after reload uses the stored bind pose.
import os
import tempfile
import unittest

import bpy
import numpy as np
from mathutils import Matrix

import arap_test_utils as U


class Persistence(unittest.TestCase):
    def test_save_reload_keeps_settings_and_bind_pose(self):
        U.clear_scene()
        obj, empty, _fixed, top = U.bar_with_handle()
        s = obj.arap
        s.iterations = 17
        s.live_iterations = 3
        s.tolerance = 1e-4
        s.weights = 'UNIFORM'
        s.init = 'DIFFERENTIAL'
        s.output = 'MESH'
        bind = [float(v) for v in s.handles[0].bind_matrix]
        empty.matrix_world = Matrix.Translation((0.4, 0.0, 2.3))
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "arap.blend")
            bpy.ops.wm.save_as_mainfile(filepath=path)
            bpy.ops.wm.open_mainfile(filepath=path)
        obj = bpy.data.objects["Bar"]
        s = obj.arap
        self.assertEqual((s.fixed_group, s.iterations, s.live_iterations, s.weights, s.init, s.output),
                         ("bottom", 17, 3, 'UNIFORM', 'DIFFERENTIAL', 'MESH'))
        self.assertAlmostEqual(s.tolerance, 1e-4)
        self.assertEqual(len(s.handles), 1)
        h = s.handles[0]
        self.assertEqual(h.group, "top")
        self.assertEqual(h.empty.name, "TopEmpty")
        self.assertTrue(h.has_bind)
        self.assertEqual([float(v) for v in h.bind_matrix], bind)
        # The empty moved by (0.4, 0, 0.3) since its bind pose: the handle follows.
        bpy.context.view_layer.objects.active = obj
        rest = U.coords(obj)
        self.assertEqual(bpy.ops.object.arap_deform(), {'FINISHED'})
        np.testing.assert_allclose(U.coords(obj)[top], rest[top] + [0.4, 0.0, 0.3], atol=1e-5)


if __name__ == "__main__":
    unittest.main()
