# Undo after Deform restores the mesh. In --background Blender has no window,
# but the memfile undo stack still works when steps are pushed explicitly
# (ed.undo_push), which is what the operator's UNDO flag does in the UI.
import unittest

import bpy
import numpy as np

import arap_test_utils as U


class Undo(unittest.TestCase):
    def test_undo_after_deform_restores(self):
        U.clear_scene()
        obj, empty, _f, _t = U.bar_with_handle()
        empty.location.x += 0.7
        bpy.context.view_layer.update()
        before = U.raw_coords(obj).copy()
        bpy.ops.ed.undo_push(message="before ARAP")
        self.assertEqual(bpy.ops.object.arap_deform(), {'FINISHED'})
        bpy.ops.ed.undo_push(message="ARAP Deform")
        self.assertFalse(np.array_equal(U.raw_coords(bpy.data.objects["Bar"]), before))
        bpy.ops.ed.undo()
        self.assertTrue(np.array_equal(U.raw_coords(bpy.data.objects["Bar"]), before))
        bpy.ops.ed.redo()
        self.assertFalse(np.array_equal(U.raw_coords(bpy.data.objects["Bar"]), before))


if __name__ == "__main__":
    unittest.main()
