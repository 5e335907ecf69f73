# The Volume setting (docs/volume.md): Global keeps the enclosed
# volume in Deform, Live, Auto mode and the bake, is saved in the .blend, says
# which open parts it leaves, falls back from Anderson to Quasi-Newton; Infill
# poses closed and open meshes. Volumes are computed here from the mesh's
# coordinates, not taken from the solver.
import os
import tempfile
import unittest

import bpy
import numpy as np
from mathutils import Matrix

import arap_test_utils as U

api, auto, bake, native_loader, solver_cache = U.addon("api", "auto", "bake", "native_loader", "solver_cache")

BIND = Matrix.Translation((0.0, 0.0, 2.0))   # the Empty's bind pose (U.bar_with_handle)
POSE = Matrix.Translation((1.6, 0.0, 0.9))   # the top of the 4-high bar pulled sideways and down


def enclosed_volume(coords, tris):
    """Divergence theorem: sum of a . (b x c) / 6 over the triangles."""
    a, b, c = coords[tris[:, 0]], coords[tris[:, 1]], coords[tris[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


class VolumeGlobal(unittest.TestCase):
    def setUp(self):
        U.clear_scene()
        auto.forget()
        bpy.context.scene.frame_set(1)
        self.obj, self.empty, self.fixed, self.top = U.bar_with_handle()
        self.tris = U.triangles(self.obj)
        self.rest_volume = enclosed_volume(U.coords(self.obj), self.tris)

    def tearDown(self):
        if self.obj.name in bpy.data.objects and self.obj.arap.auto:
            api.set_auto(self.obj, False)

    def kept(self, coords=None):
        return enclosed_volume(U.coords(self.obj) if coords is None else coords, self.tris) / self.rest_volume

    def pose_and_deform(self, volume):
        self.empty.matrix_world = BIND
        api.reset(self.obj)   # (captures the Empty's bind pose again)
        self.obj.arap.volume = volume
        self.empty.matrix_world = POSE
        result = api.deform(self.obj)
        return result, self.kept()

    def test_deform_keeps_the_volume_the_surface_loses(self):
        self.assertEqual(self.obj.arap.volume, 'INFILL')   # the default of new objects (older files: test_persistence)
        _r, surface = self.pose_and_deform('NONE')
        self.assertLess(surface, 0.97)
        r, kept = self.pose_and_deform('GLOBAL')
        self.assertFalse(r.cached_bind, "a new Volume setting binds again")
        self.assertAlmostEqual(kept, 1.0, delta=1e-5)   # float32 coordinates
        self.assertFalse([w for w in r.warnings if "Volume" in w], r.warnings)
        # The same as the native module bound with volume="global" directly.
        s = native_loader.native().Solver()
        rest = api.rest_positions(self.obj).astype(np.float64).reshape(-1, 3)
        constrained = np.concatenate([self.fixed, self.top])
        targets = np.concatenate([rest[self.fixed],
                                  U.apply(U.np_matrix(POSE) @ np.linalg.inv(U.np_matrix(BIND)), rest[self.top])])
        s.bind(rest, self.tris, constrained, weights="cotan-clamped", volume="global")
        self.assertEqual(s.volume, "global")
        self.assertEqual(s.mesh_report()["volume_kept_components"], 1)
        self.assertLess(s.solve(targets).volume_drift, 1e-9)
        np.testing.assert_allclose(U.coords(self.obj), s.positions(), atol=1e-4)

    def test_anderson_falls_back_to_quasi_newton_and_says_so(self):
        self.obj.arap.method = 'ANDERSON'
        r, kept = self.pose_and_deform('GLOBAL')
        self.assertAlmostEqual(kept, 1.0, delta=1e-5)
        self.assertTrue(any("solved with Quasi-Newton" in w for w in r.warnings), r.warnings)
        _r, _k = self.pose_and_deform('NONE')
        self.assertFalse(any("Quasi-Newton" in w for w in _r.warnings), _r.warnings)

    def test_live_keeps_the_volume(self):
        self.obj.arap.volume = 'GLOBAL'
        s = api.start_session(self.obj, bpy.context.scene)
        try:
            for i in range(1, 6):
                self.empty.matrix_world = Matrix.Translation((0.3 * i, 0.0, 2.0 - 0.2 * i))
                bpy.context.view_layer.update()
                for _ in range(20):
                    s.step()
                self.assertAlmostEqual(self.kept(), 1.0, delta=1e-5, msg="step %d" % i)
        finally:
            s.cancel()

    def test_auto_mode_keeps_the_volume_and_follows_the_setting(self):
        api.set_auto(self.obj, True)
        self.empty.matrix_world = POSE
        bpy.context.view_layer.update()
        self.assertGreater(np.ptp(U.coords(self.obj)[:, 0]), 1.5)   # it was posed
        self.assertLess(self.kept(), 0.97)
        self.obj.arap.volume = 'GLOBAL'   # Auto poses again with it, nothing else changed
        self.assertAlmostEqual(self.kept(), 1.0, delta=1e-5)
        self.obj.arap.volume = 'NONE'
        self.assertLess(self.kept(), 0.97)

    def test_bake_keeps_the_volume_on_every_frame(self):
        self.obj.arap.volume = 'GLOBAL'
        for i, f in enumerate(range(1, 6)):
            self.empty.location = (0.4 * i, 0.0, 2.0 - 0.2 * i)
            self.empty.keyframe_insert("location", frame=f)
        bake.bake_shape_keys(self.obj, 1, 5)
        for f in range(1, 6):
            bpy.context.scene.frame_set(f)
            self.assertAlmostEqual(self.kept(U.evaluated_coords(self.obj)), 1.0, delta=1e-5, msg="frame %d" % f)
        bpy.context.scene.frame_set(5)
        self.assertGreater(np.ptp(U.evaluated_coords(self.obj)[:, 0]), 1.5)   # it was posed

    def test_settings_are_saved_in_the_blend(self):
        self.obj.arap.volume = 'INFILL'
        self.obj.arap.infill_resolution = 7
        path = os.path.join(tempfile.mkdtemp(prefix="arap_volume_"), "volume.blend")
        bpy.ops.wm.save_as_mainfile(filepath=path)
        bpy.ops.wm.open_mainfile(filepath=path)
        obj = bpy.data.objects["Bar"]
        self.assertEqual((obj.arap.volume, obj.arap.infill_resolution), ('INFILL', 7))
        api.bind(obj)
        solver = solver_cache._cache[obj.as_pointer()][1]
        self.assertEqual((solver.volume, solver.infill_resolution), ("infill", 7))
        self.assertGreater(solver.mesh_report()["infill_cells"], 0)
        self.obj = obj


class VolumeInTheModule(unittest.TestCase):
    def test_bad_volume_arguments_raise_arap_errors(self):
        mod = native_loader.native()
        U.clear_scene()
        obj, _empty, fixed, top = U.bar_with_handle()
        rest, tris, constrained = U.coords(obj), U.triangles(obj), np.concatenate([fixed, top])
        for kwargs in ({"volume": "tets"}, {"volume": "global", "method": "anderson"},
                       {"volume": "infill", "infill_resolution": 1}, {"volume": "infill", "infill_resolution": 257}):
            with self.assertRaises(mod.ArapError, msg=str(kwargs)):
                mod.Solver().bind(rest, tris, constrained, **kwargs)
        s = mod.Solver()
        s.bind(rest, tris, constrained, volume="infill", infill_resolution=4)
        self.assertEqual((s.volume, s.infill_resolution), ("infill", 4))
        coarse = s.mesh_report()["infill_cells"]
        s.bind(rest, tris, constrained, volume="infill", infill_resolution=8)
        self.assertGreater(s.mesh_report()["infill_cells"], coarse)


class VolumeOnOpenMeshes(unittest.TestCase):
    def setUp(self):
        U.clear_scene()
        self.obj = U.add_grid(x=12, y=4)
        U.group_where(self.obj, "left", lambda co: co.x < -0.8)
        U.group_where(self.obj, "right", lambda co: co.x > 0.8)
        api.set_fixed(self.obj, "left")
        self.empty = U.add_empty("RightEmpty", Matrix.Translation((1.0, 0.0, 0.0)))
        api.add_handle(self.obj, "right", self.empty)
        self.empty.matrix_world = Matrix.Translation((0.8, 0.0, 0.6))

    def test_global_says_it_leaves_open_parts_alone(self):
        self.obj.arap.volume = 'NONE'
        surface = api.deform(self.obj)
        surface_coords = U.coords(self.obj)
        self.empty.matrix_world = Matrix.Translation((1.0, 0.0, 0.0))
        api.reset(self.obj)
        self.empty.matrix_world = Matrix.Translation((0.8, 0.0, 0.6))
        self.obj.arap.volume = 'GLOBAL'
        r = api.deform(self.obj)
        self.assertTrue(any("no closed part" in w for w in r.warnings), r.warnings)
        self.assertFalse(any("no closed part" in w for w in surface.warnings), surface.warnings)
        np.testing.assert_allclose(U.coords(self.obj), surface_coords, atol=1e-5)

    def test_infill_poses_an_open_sheet(self):
        self.obj.arap.volume = 'INFILL'
        r = api.deform(self.obj)
        coords = U.coords(self.obj)
        self.assertTrue(np.isfinite(coords).all())
        self.assertGreater(coords[:, 2].max(), 0.5)
        self.assertFalse(any("Volume" in w for w in r.warnings), r.warnings)


if __name__ == "__main__":
    unittest.main()
