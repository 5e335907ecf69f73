# Enabling/disabling the add-on leaves nothing behind; operators are documented and in menus.
import sys
import unittest

import bpy

import arap_test_utils as U

OPS = ("add_handle_from_selection", "set_fixed_from_selection", "handle_add", "handle_remove", "deform",
       "reset", "set_rest_pose", "live", "live_apply", "live_cancel")


def arap_classes():
    names = []
    for base in (bpy.types.Operator, bpy.types.Panel, bpy.types.PropertyGroup, bpy.types.UIList, bpy.types.Menu):
        names += [c.__name__ for c in base.__subclasses__() if c.__name__.startswith("ARAP_")
                  and getattr(c, "is_registered", False)]
    return names


class Registration(unittest.TestCase):
    def tearDown(self):
        U.enable_addon()

    def test_enabled_state(self):
        self.assertTrue(hasattr(bpy.types.Object, "arap"))
        for op in OPS:
            self.assertIn("arap_" + op, dir(bpy.ops.object))
        self.assertTrue(hasattr(bpy.types, "ARAP_PT_main"))
        self.assertTrue(hasattr(bpy.types, "ARAP_UL_handles"))
        self.assertIn("ARAP_PG_settings", arap_classes())

    def test_modules_only_under_the_addon_name(self):
        # Blender 4.2+ loads the add-on as bl_ext.<repository>.arap_deform; its
        # extension policy forbids its files under any other name in sys.modules.
        self.assertIn(U.ADDON_MODULE + ".api", sys.modules)
        self.assertEqual(U.modules_under_other_names(), {})
        if U.ADDON_MODULE != "arap_deform":
            self.assertNotIn("arap_deform", sys.modules)
        for _ in range(2):  # and after a disable/enable cycle (Blender reloads the package)
            U.disable_addon()
            U.enable_addon()
        self.assertEqual(U.modules_under_other_names(), {})

    def test_the_module_check_finds_an_alias(self):
        # The check above can fail: an alias of a submodule, and one of a copy
        # loaded from the add-on's file, are both found.
        import importlib.util
        api = U.addon("api")
        spec = importlib.util.spec_from_file_location("arap_probe_copy", sys.modules[U.ADDON_MODULE].__file__)
        copy = importlib.util.module_from_spec(spec)
        sys.modules["arap_probe_alias"], sys.modules["arap_probe_copy"] = api, copy
        try:
            self.assertEqual(sorted(U.modules_under_other_names()), ["arap_probe_alias", "arap_probe_copy"])
        finally:
            del sys.modules["arap_probe_alias"], sys.modules["arap_probe_copy"]

    @unittest.skipIf(bpy.app.version < (4, 2), "extensions and their policy start with Blender 4.2")
    def test_no_extension_policy_warnings(self):
        # What the Preferences show under a warning sign ("Policy violation with top
        # level module: ...") for the extension; Blender reports an alias, too.
        self.assertTrue(U.ADDON_MODULE.startswith("bl_ext."), U.ADDON_MODULE)
        self.assertEqual(U.extension_policy_warnings(), [])
        sys.modules["arap_probe_alias"] = U.addon("api")
        try:
            self.assertEqual(U.extension_policy_warnings(),
                             ["Policy violation with top level module: arap_probe_alias"])
        finally:
            del sys.modules["arap_probe_alias"]
        self.assertEqual(U.extension_policy_warnings(), [])

    def test_operators_documented_and_in_menus(self):
        operators = [cls for mod in U.addon("setup_ops", "deform_ops", "live_ops", "bake_ops") for cls in mod.classes
                     if issubclass(cls, bpy.types.Operator)]
        self.assertEqual(sorted(cls.bl_idname for cls in operators),
                         sorted("object.arap_" + op for op in OPS + ("bake", "bake_clear")))
        for cls in operators:
            self.assertTrue(cls.__doc__ and cls.__doc__.strip(), cls.__name__)
        # F3 (menu search) finds operators that sit in a menu.
        self.assertIn("_menu_entry", [f.__name__ for f in bpy.types.VIEW3D_MT_object._dyn_ui_initialize()])

    def test_disable_leaves_nothing(self):
        U.disable_addon()
        self.assertFalse(hasattr(bpy.types.Object, "arap"))
        self.assertEqual(arap_classes(), [])
        for op in OPS:
            self.assertNotIn("arap_" + op, dir(bpy.ops.object))
        for name in ("ARAP_PT_main", "ARAP_UL_handles", "ARAP_MT_menu", "ARAP_PG_settings", "ARAP_PG_handle"):
            self.assertFalse(hasattr(bpy.types, name), name)
        self.assertNotIn("_menu_entry", [f.__name__ for f in bpy.types.VIEW3D_MT_object._dyn_ui_initialize()])
        self.assertNotIn(U.ADDON_MODULE, bpy.context.preferences.addons)

    def test_reenable_twice(self):
        for _ in range(2):
            U.disable_addon()
            U.enable_addon()
        self.assertTrue(hasattr(bpy.types.Object, "arap"))
        self.assertEqual(len([f for f in bpy.types.VIEW3D_MT_object._dyn_ui_initialize()
                              if f.__name__ == "_menu_entry"]), 1)
