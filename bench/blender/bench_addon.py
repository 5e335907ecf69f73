# SPDX-License-Identifier: GPL-3.0-or-later
# What the Blender-side benchmarks share besides the tube scene (tube_scene.py): the add-on, registered from
# a staged build/addon or enabled as installed, and the scene helpers of the Blender tests, whose one home is
# blender_tests/arap_test_utils.py (the tests import it from their own folder; the benchmarks through here).
#
#   sys.path.insert(0, HERE)
#   import bench_addon as U    # U.load_addon(folder), U.enable_addon(), U.addon("live"), U.clear_scene(), ...
#
# BLENDER_GUI_TESTS is the real-window suite's folder (its driver and session files, which the measurements in
# a real window use); BENCH_NATIVE holds volume_table.py's mesh readers.
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
BLENDER_TESTS = os.path.normpath(os.path.join(HERE, "..", "..", "blender_tests"))
BLENDER_GUI_TESTS = os.path.join(BLENDER_TESTS, "gui")
BENCH_NATIVE = os.path.normpath(os.path.join(HERE, "..", "native"))
if BLENDER_TESTS not in sys.path:
    sys.path.insert(0, BLENDER_TESTS)

import arap_test_utils as _tests  # noqa: E402
from arap_test_utils import (add_cylinder, add_empty, addon, clear_scene, coords, enable_addon,  # noqa: E402,F401
                             group_where)


def load_addon(addon_dir):
    """Register the add-on from `addon_dir` (a staged build/addon) as the plain package arap_deform, or,
    with no folder, enable the installed one (arap_test_utils.ADDON_MODULE)."""
    if addon_dir:
        sys.path.insert(0, os.path.abspath(addon_dir))
        _tests.ADDON_MODULE = "arap_deform"
        addon().register()
    elif enable_addon() is None:
        raise SystemExit("could not enable %s (give --addon-dir or set BLENDER_USER_SCRIPTS)" % _tests.ADDON_MODULE)
