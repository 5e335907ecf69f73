# Settings survive save and reload of the .blend; Deform after reload uses the stored bind pose. A .blend saved
# with the settings' old names (before they were named after the solver's options) keeps its values, and one
# saved before Volume Infill became the default keeps Surface Only and its poses.
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
        s.max_iterations = 17
        s.live_max_iterations = 3
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
        self.assertEqual((s.fixed_group, s.max_iterations, s.live_max_iterations, s.weights, s.init, s.output),
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


# The settings as an older version saved them: plain ID properties under the old names.
OLD_SETTINGS = {"iterations": 1, "live_iterations": 3, "acceleration": 7, "self_contact": 1}
NEW_SETTINGS = {"max_iterations": 1, "live_max_iterations": 3, "anderson_window": 7, "contact": True}


class RenamedSettings(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.addCleanup(self.tmp.cleanup)
        self.problem, self.renamed = U.addon("problem", "older_settings")

    def save_old_file(self, name, **new_values):
        """A .blend holding a bar whose settings are under the old names (and `new_values` under the new)."""
        U.clear_scene()
        obj, _empty, _fixed, _top = U.bar_with_handle()
        obj.arap.tolerance = 0.0      # every iteration up to the cap runs
        for key, value in OLD_SETTINGS.items():
            obj.arap[key] = value
            self.assertIn(key, obj.arap)    # no property of that name any more: a plain ID property
        for key, value in new_values.items():
            setattr(obj.arap, key, value)
        path = os.path.join(self.tmp.name, name)
        bpy.ops.wm.save_as_mainfile(filepath=path)
        return path

    def assert_migrated(self, s, expected):
        self.assertEqual({key: getattr(s, key) for key in expected}, expected)
        self.assertEqual([key for key in OLD_SETTINGS if key in s], [])

    def test_an_old_file_opens_with_its_settings_under_the_new_names(self):
        bpy.ops.wm.open_mainfile(filepath=self.save_old_file("old.blend"))
        obj = bpy.data.objects["Bar"]
        self.assert_migrated(obj.arap, NEW_SETTINGS)
        bpy.context.view_layer.objects.active = obj
        bpy.data.objects["TopEmpty"].location.x += 0.3
        self.assertEqual(bpy.ops.object.arap_deform(), {'FINISHED'})
        self.assertEqual(U.addon("api").last_result(obj).iterations, 1)    # the old cap of 1
        # Saved again, the file holds only the new names.
        path = os.path.join(self.tmp.name, "resaved.blend")
        bpy.ops.wm.save_as_mainfile(filepath=path)
        bpy.ops.wm.open_mainfile(filepath=path)
        self.assert_migrated(bpy.data.objects["Bar"].arap, NEW_SETTINGS)

    def test_a_value_set_under_the_new_name_wins(self):
        bpy.ops.wm.open_mainfile(filepath=self.save_old_file("both.blend", max_iterations=9, contact=False))
        self.assert_migrated(bpy.data.objects["Bar"].arap, dict(NEW_SETTINGS, max_iterations=9, contact=False))

    def test_the_open_file_is_migrated_when_the_addon_is_enabled(self):
        self.save_old_file("open.blend")
        U.disable_addon()
        U.enable_addon()
        # Blender registers add-ons without the file's data (restricted): a timer migrates it from the event
        # loop, which --background does not run here.
        renamed = U.addon("older_settings")
        self.assertTrue(bpy.app.timers.is_registered(renamed._migrate_later))
        renamed._migrate_later()
        self.assert_migrated(bpy.data.objects["Bar"].arap, NEW_SETTINGS)

    def test_a_linked_object_is_read_under_its_old_names(self):
        library = self.save_old_file("library.blend")
        U.clear_scene()
        bpy.ops.wm.save_as_mainfile(filepath=os.path.join(self.tmp.name, "shot.blend"))   # not the library
        with bpy.data.libraries.load(library, link=True) as (_src, dst):
            dst.objects = ["Bar"]
        obj = dst.objects[0]
        self.assertIsNotNone(obj.library)
        self.renamed.migrate_file()     # a library cannot be written: it keeps the old names
        self.assertIn("iterations", obj.arap)
        options = self.problem.solver_options(obj.arap)
        self.assertEqual((options["max_iterations"], options["anderson_window"]), (1, 7))
        self.assertEqual(self.problem.bind_options(obj.arap)["contact"], "self")
        self.assertEqual(self.renamed.setting(obj.arap, "live_max_iterations"), 3)


class ChangedDefaults(unittest.TestCase):
    """Volume's default is Infill; objects of a file saved before keep the Surface Only they were posed with."""

    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.addCleanup(self.tmp.cleanup)
        self.problem, self.older = U.addon("problem", "older_settings")

    def save(self, name, older_version):
        """Save the open file as `name`; as an older version saved it (without the mark of this one) when
        `older_version`."""
        path = os.path.join(self.tmp.name, name)
        if older_version:
            bpy.app.handlers.save_pre.remove(self.older._on_save)
            try:
                for obj in bpy.data.objects:
                    obj.arap.property_unset("saved_with")
                bpy.ops.wm.save_as_mainfile(filepath=path)
            finally:
                bpy.app.handlers.save_pre.append(self.older._on_save)
        else:
            bpy.ops.wm.save_as_mainfile(filepath=path)
        return path

    def posed_bar(self, volume=None):
        U.clear_scene()
        obj, empty, _fixed, _top = U.bar_with_handle()
        if volume is not None:
            obj.arap.volume = volume
        empty.location.x += 0.6
        return obj

    def deform(self, obj):
        bpy.context.view_layer.objects.active = obj
        self.assertEqual(bpy.ops.object.arap_deform(), {'FINISHED'})
        return U.coords(obj)

    def test_a_new_object_is_posed_with_infill(self):
        obj = self.posed_bar()
        self.assertEqual(obj.arap.volume, 'INFILL')
        self.assertEqual(self.problem.bind_options(obj.arap)["volume"], "infill")

    def test_an_older_file_keeps_surface_only_and_its_pose_bit_for_bit(self):
        surface = self.deform(self.posed_bar('NONE'))    # the pose the older version made
        obj = self.posed_bar()
        obj.arap.property_unset("volume")                # left at the default of its time
        bpy.ops.wm.open_mainfile(filepath=self.save("older.blend", older_version=True))
        obj = bpy.data.objects["Bar"]
        self.assertEqual(obj.arap.volume, 'NONE')
        np.testing.assert_array_equal(self.deform(obj), surface)
        # Saved again and reopened, it stays Surface Only.
        bpy.ops.wm.open_mainfile(filepath=self.save("resaved.blend", older_version=False))
        self.assertEqual(bpy.data.objects["Bar"].arap.volume, 'NONE')

    def test_a_file_of_this_version_keeps_the_infill_default(self):
        self.posed_bar()
        bpy.ops.wm.open_mainfile(filepath=self.save("new.blend", older_version=False))
        obj = bpy.data.objects["Bar"]
        self.assertFalse(obj.arap.is_property_set("volume"))
        self.assertEqual(obj.arap.volume, 'INFILL')

    def test_an_object_without_arap_settings_takes_the_new_default(self):
        U.clear_scene()
        U.add_cylinder()
        bpy.ops.wm.open_mainfile(filepath=self.save("plain.blend", older_version=True))
        self.assertEqual(bpy.data.objects["Bar"].arap.volume, 'INFILL')

    def test_a_linked_object_of_an_older_file_is_read_as_surface_only(self):
        self.posed_bar()
        library = self.save("library.blend", older_version=True)
        U.clear_scene()
        bpy.ops.wm.save_as_mainfile(filepath=os.path.join(self.tmp.name, "shot.blend"))
        with bpy.data.libraries.load(library, link=True) as (_src, dst):
            dst.objects = ["Bar"]
        obj = dst.objects[0]
        self.older.migrate_file()     # a library cannot be written
        self.assertEqual(self.problem.bind_options(obj.arap)["volume"], "none")


if __name__ == "__main__":
    unittest.main()
