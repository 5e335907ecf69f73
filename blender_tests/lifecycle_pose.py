# Blender side of extension_lifecycle.py (run inside `blender --background`):
#
#   ... --python lifecycle_pose.py -- pose <module>            the add-on is enabled; pose a mesh with it
#   ... --python lifecycle_pose.py -- absent <module>          the add-on is neither enabled nor registered
#   ... --python lifecycle_pose.py -- install-from-disk <zip>  4.2+: Install from Disk, pose, uninstall
#   ... --python lifecycle_pose.py -- legacy-install <zip>     3.x: Install..., enable, save preferences
#   ... --python lifecycle_pose.py -- legacy-remove            3.x: disable, remove, save preferences
# Each mode prints "LIFECYCLE ... OK" when every check held; any failure raises.
# Where the add-on is enabled, its modules must sit only under its own name, and
# on 4.2+ the Preferences must show no policy warning for the extension.
import os
import shutil
import sys

import addon_utils
import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import arap_test_utils as U  # noqa: E402


def enabled_modules():
    return {a.module for a in bpy.context.preferences.addons}


def pose_a_bar():
    """A capped cylinder, bottom fixed, top on an Empty moved by (0.3, 0, 0.2):
    the top must move by exactly that and nothing may be non-finite."""
    api = U.addon("api")
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.mesh.primitive_cylinder_add(vertices=16, radius=0.3, depth=2.0)
    obj = bpy.context.active_object
    bpy.ops.object.mode_set(mode='EDIT')
    bpy.ops.mesh.subdivide(number_cuts=6)
    bpy.ops.object.mode_set(mode='OBJECT')
    co = np.array([v.co[:] for v in obj.data.vertices])
    api.create_group(obj, "bottom", np.flatnonzero(co[:, 2] < -0.99))
    top = np.flatnonzero(co[:, 2] > 0.99)
    api.create_group(obj, "top", top)
    api.set_fixed(obj, "bottom")
    empty = bpy.data.objects.new("Handle", None)
    bpy.context.scene.collection.objects.link(empty)
    empty.location = (0.0, 0.0, 1.0)
    bpy.context.view_layer.update()
    api.add_handle(obj, "top", empty)
    empty.location = (0.3, 0.0, 1.2)
    result = api.deform(obj)
    posed = np.array([v.co[:] for v in obj.data.vertices])
    if not np.isfinite(posed).all():
        raise AssertionError("non-finite coordinates after the pose")
    np.testing.assert_allclose(posed[top] - co[top], np.tile((0.3, 0.0, 0.2), (len(top), 1)), atol=1e-5)
    print("posed %d vertices in %d iterations, energy %.4g" % (len(co), result.iterations, result.energy))
    # The operator a user runs from F3, too.
    bpy.context.view_layer.objects.active = obj
    if bpy.ops.object.arap_deform() != {'FINISHED'}:
        raise AssertionError("object.arap_deform did not finish")


def check_policy():
    """The add-on (U.ADDON_MODULE) keeps to its name in sys.modules; on 4.2+ Blender
    lists no policy warning for it."""
    others = U.modules_under_other_names()
    if others:
        raise AssertionError("the add-on's modules also sit under other names: %s" % others)
    print("the add-on's modules sit only under %s" % U.ADDON_MODULE)
    if bpy.app.version >= (4, 2):
        warnings = U.extension_policy_warnings()
        if warnings:
            raise AssertionError("policy warnings for %s:\n%s" % (U.ADDON_MODULE, "\n".join(warnings)))
        print("no policy warnings for %s" % U.ADDON_MODULE)


def pose(module):
    if module not in enabled_modules():
        raise AssertionError("%s is not enabled at start-up (enabled: %s)" % (module, sorted(enabled_modules())))
    U.ADDON_MODULE = module
    pose_a_bar()
    check_policy()
    print("LIFECYCLE POSE OK")


def absent(module):
    if module in enabled_modules():
        raise AssertionError("%s is still enabled" % module)
    if hasattr(bpy.types.Object, "arap") or hasattr(bpy.types, "ARAP_PT_main"):
        raise AssertionError("the add-on's properties or panels are still registered")
    print("LIFECYCLE ABSENT OK")


def user_repo_index():
    for i, repo in enumerate(bpy.context.preferences.extensions.repos):
        if repo.module == "user_default":
            return i, repo.directory
    raise AssertionError("no user_default extension repository")


def install_from_disk(zip_path):
    index, directory = user_repo_index()
    bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default", enable_on_install=True)
    module = "bl_ext.user_default.arap_deform"
    if module not in enabled_modules():
        raise AssertionError("Install from Disk did not enable %s" % module)
    U.ADDON_MODULE = module
    pose_a_bar()
    check_policy()
    bpy.ops.extensions.package_uninstall(repo_index=index, pkg_id="arap_deform")
    if module in enabled_modules() or hasattr(bpy.types.Object, "arap"):
        raise AssertionError("uninstall left the add-on enabled or registered")
    if os.path.exists(os.path.join(directory, "arap_deform")):
        raise AssertionError("uninstall left %s" % os.path.join(directory, "arap_deform"))
    bpy.ops.wm.save_userpref()
    print("LIFECYCLE INSTALL FROM DISK OK")


def legacy_install(zip_path):
    bpy.ops.preferences.addon_install(filepath=zip_path, overwrite=True)
    addon_utils.modules_refresh()
    bpy.ops.preferences.addon_enable(module="arap_deform")
    if "arap_deform" not in enabled_modules():
        raise AssertionError("arap_deform did not enable")
    bpy.ops.wm.save_userpref()
    print("LIFECYCLE LEGACY INSTALL OK")


def legacy_remove():
    bpy.ops.preferences.addon_disable(module="arap_deform")
    # What the Remove button (preferences.addon_remove) does; the operator
    # itself needs a Preferences area, which --background has not.
    folder = os.path.dirname(next(m.__file__ for m in addon_utils.modules() if m.__name__ == "arap_deform"))
    shutil.rmtree(folder)
    addon_utils.modules_refresh()
    if hasattr(bpy.types.Object, "arap"):
        raise AssertionError("disable left the add-on's properties registered")
    bpy.ops.wm.save_userpref()
    print("LIFECYCLE LEGACY REMOVE OK")


def main():
    argv = sys.argv[sys.argv.index("--") + 1:]
    modes = {"pose": pose, "absent": absent, "install-from-disk": install_from_disk,
             "legacy-install": legacy_install, "legacy-remove": legacy_remove}
    modes[argv[0]](*argv[1:])
    sys.stdout.flush()


main()
