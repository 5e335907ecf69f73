# The settings that are solver options take their defaults, limits and choices from
# the native option table (OPTIONS, arap::option_specs()), on the object and on every
# operator; Deform honours the whole range; the add-on still registers, and says what
# to rebuild, when its native module does not load in this Blender.
import glob
import importlib
import os
import shutil
import sys
import tempfile
import unittest

import bpy
from mathutils import Matrix

import arap_test_utils as U

api, native_loader, problem = U.addon("api", "native_loader", "problem")

SETTINGS = "ARAP_PG_settings"
# Every property of the add-on's settings and operators that is a solver option, and the option.
OPTION_PROPERTIES = {
    (SETTINGS, "method"): "method",
    (SETTINGS, "max_iterations"): "max_iterations",
    (SETTINGS, "live_max_iterations"): "max_iterations",
    (SETTINGS, "tolerance"): "tolerance",
    (SETTINGS, "weights"): "weights",
    (SETTINGS, "init"): "init",
    (SETTINGS, "volume"): "volume",
    (SETTINGS, "infill_resolution"): "infill_resolution",
    (SETTINGS, "contact"): "contact",
    (SETTINGS, "anderson_window"): "anderson_window",
    (SETTINGS, "threads"): "threads",
    ("object.arap_deform", "max_iterations"): "max_iterations",
    ("object.arap_deform", "tolerance"): "tolerance",
    ("object.arap_deform", "init"): "init",
}
# Where the add-on departs from the table, and why.
OWN = {
    # At least one iteration: the solve worker (Deform's, Live's) refuses none.
    (SETTINGS, "max_iterations"): {"min": 1},
    ("object.arap_deform", "max_iterations"): {"min": 1},
    # Live's cap per viewport update, not a solve's.
    (SETTINGS, "live_max_iterations"): {"min": 1, "default": 100},
}
# Choices of the table that are no setting: "warm" (the last solution) is how Live and Auto mode start.
NOT_OFFERED = {"init": {"warm"}}
# Enum items (a switch's off and on) -> native names, per option (the add-on's translation; every item must
# have one).
NATIVE_NAMES = {"method": problem.METHOD_NAMES, "weights": problem.WEIGHT_NAMES, "init": problem.INIT_NAMES,
                "volume": problem.VOLUME_NAMES, "contact": problem.CONTACT_NAMES}
# The other properties: none is a solver option (a new property must be put in one of the two lists).
NOT_OPTIONS = {
    SETTINGS: {"auto", "auto_status", "fixed_group", "handles", "active_handle", "stiff_group", "stiffness",
               "output", "live_interval",
               # Live's frame budget: the time_budget_ms of each update, where the table's 0 (no limit) is no choice.
               "live_frame_ms",
               # The mark this version writes on save (persistence/older_settings.py).
               "saved_with",
               # What ARAP turned off of a rig's Armature deformation while it shows a pose (solver/rig.py).
               "armature_muted"},
    "ARAP_PG_handle": {"group", "empty", "armature", "bone", "bind_matrix", "has_bind"},
    "object.arap_add_handle_from_selection": {"group_name"},
    "object.arap_handles_from_armature": {"threshold"},
    "object.arap_bake": {"frame_start", "frame_end", "output", "filepath"},
}


def operator_ids():
    return ["object." + name for name in dir(bpy.ops.object) if name.startswith("arap_")]


# Every property group's own (Blender's, on each one).
GROUP_BUILTINS = {p.identifier for p in bpy.types.PropertyGroup.bl_rna.properties}


def rna_properties(owner):
    """{name: RNA property} of the settings, a handle or an operator (its id), as Blender registered them."""
    if owner.startswith("object."):
        rna = getattr(bpy.ops.object, owner.split(".", 1)[1]).get_rna_type()
    else:
        rna = bpy.types.Object.bl_rna.properties["arap"].fixed_type
        if owner == "ARAP_PG_handle":
            rna = rna.properties["handles"].fixed_type
        assert rna.identifier == owner, (rna.identifier, owner)
    return {p.identifier: p for p in rna.properties if p.identifier not in GROUP_BUILTINS}


class OptionTable(unittest.TestCase):
    def test_every_property_is_classified(self):
        owners = [SETTINGS, "ARAP_PG_handle"] + operator_ids()
        self.assertIn("object.arap_deform", owners)
        for owner in owners:
            options = {name for (o, name) in OPTION_PROPERTIES if o == owner}
            self.assertEqual(set(rna_properties(owner)), options | NOT_OPTIONS.get(owner, set()), owner)

    def test_option_properties_follow_the_table(self):
        table = native_loader.native().OPTIONS
        for (owner, name), option in OPTION_PROPERTIES.items():
            prop, spec = rna_properties(owner)[name], table[option]
            want = dict(spec, **OWN.get((owner, name), {}))
            where = "%s.%s (%s)" % (owner, name, option)
            if "choices" in spec:
                names = NATIVE_NAMES[option]
                # A BoolProperty switches between two choices: its items are off and on.
                items = [False, True] if prop.type == 'BOOLEAN' else [item.identifier for item in prop.enum_items]
                self.assertEqual(sorted(names[i] for i in items),
                                 sorted(set(spec["choices"]) - NOT_OFFERED.get(option, set())), where)
                self.assertEqual(names[prop.default], want["default"], where)
                continue
            self.assertEqual(prop.type, {"int": 'INT', "float": 'FLOAT'}[spec["kind"]], where)
            for key, got in (("default", prop.default), ("min", prop.hard_min), ("max", prop.hard_max)):
                # Blender keeps float properties in single precision.
                self.assertAlmostEqual(got, want[key], delta=abs(want[key]) * 1e-6, msg="%s %s" % (where, key))

    def test_option_properties_are_named_after_their_option(self):
        # One name per setting everywhere: the property is the option's name ("live_" for Live's own cap).
        for (owner, name), option in OPTION_PROPERTIES.items():
            self.assertIn(name, (option, "live_" + option), owner)

    def test_own_limits_are_within_the_table(self):
        table = native_loader.native().OPTIONS
        for (owner, name), own in OWN.items():
            spec = table[OPTION_PROPERTIES[owner, name]]
            self.assertLessEqual(spec["min"], own.get("min", spec["min"]))
            self.assertLessEqual(own.get("min", spec["min"]), own.get("default", spec["default"]))
            self.assertLessEqual(own.get("default", spec["default"]), spec["max"])


class DeformIterations(unittest.TestCase):
    def setUp(self):
        # A square sheet held at one corner and twisted at the other: local/global to a tolerance of 0
        # takes about 3300 iterations to settle here (it stops only where the energy stops dropping).
        U.clear_scene()
        self.obj = U.add_grid(x=20, y=20, size=4.0, name="Sheet")
        U.group_where(self.obj, "corner", lambda co: co.x < -1.8 and co.y < 0)
        U.group_where(self.obj, "other", lambda co: co.x > 1.8 and co.y > 0)
        api.set_fixed(self.obj, "corner")
        empty = U.add_empty("Handle", Matrix.Translation((2.0, 0.0, 0.0)))
        api.add_handle(self.obj, "other", empty)
        empty.rotation_euler.y = 2.5
        empty.location.z += 1.0
        self.obj.arap.method = 'LOCAL_GLOBAL'
        self.obj.arap.tolerance = 0.0

    def deform(self, **properties):
        self.assertEqual(bpy.ops.object.arap_deform(**properties), {'FINISHED'})
        result = api.last_result(self.obj)
        self.assertFalse(result.converged)
        return result.iterations

    def test_operator_runs_more_than_1000_iterations(self):
        self.assertEqual(self.deform(max_iterations=1500), 1500)

    def test_operator_runs_the_objects_setting_above_1000(self):
        self.obj.arap.max_iterations = 1200
        self.assertEqual(self.deform(), 1200)


class WithoutTheNativeModule(unittest.TestCase):
    """A copy of the add-on whose only module is for another Python (3.99), enabled instead of the add-on."""

    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="arap_no_module_")
        here = os.path.dirname(os.path.realpath(U.addon().__file__))
        probe = os.path.join(self.tmp, "arap_abi_probe")
        shutil.copytree(here, probe, ignore=shutil.ignore_patterns("_arap_native*", "__pycache__"))
        shutil.copy(glob.glob(os.path.join(here, "_arap_native*"))[0],
                    os.path.join(probe, "_arap_native.cpython-399-x86_64-linux-gnu.so"))
        U.clear_scene()
        U.disable_addon()
        sys.path.insert(0, self.tmp)

    def tearDown(self):
        sys.path.remove(self.tmp)
        for name in [n for n in sys.modules if n == "arap_abi_probe" or n.startswith("arap_abi_probe.")]:
            del sys.modules[name]
        shutil.rmtree(self.tmp, ignore_errors=True)
        U.enable_addon()
        U.clear_scene()

    def test_registers_and_says_what_to_rebuild(self):
        probe = importlib.import_module("arap_abi_probe")
        probe.register()
        try:
            message = probe.persistence.solver_settings.NATIVE_ERROR
            self.assertIn("only for Python 3.99", message)
            self.assertIn("Rebuild the module for Python %d.%d" % sys.version_info[:2], message)
            self.assertTrue(hasattr(bpy.types.Object, "arap"))
            obj = U.add_cylinder()
            U.group_where(obj, "bottom", lambda co: co.z < -1.5)
            obj.arap.fixed_group = "bottom"
            obj.arap.max_iterations = 20000     # a setting can be set and read without the module's table
            self.assertEqual(obj.arap.max_iterations, 20000)
            self.assertFalse(probe.ui.panels.ARAP_PT_solver.poll(bpy.context))   # limits unknown: not shown
            with self.assertRaises(RuntimeError) as cm:
                bpy.ops.object.arap_deform()
            self.assertIn("only for Python 3.99", str(cm.exception))
            self.assertIn("Rebuild", str(cm.exception))
        finally:
            probe.unregister()
        self.assertFalse(hasattr(bpy.types.Object, "arap"))


if __name__ == "__main__":
    unittest.main()
