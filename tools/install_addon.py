# Install and enable the ARAP Deform add-on zip in the user's Blender.
#
#   blender --background --factory-startup --python tools/install_addon.py -- build/arap_deform.zip
#
# --factory-startup keeps other add-ons and startup scripts out of the way;
# the user's saved preferences are read back first so that saving them only
# adds this add-on (instead of resetting everything to factory settings).
import importlib
import os
import sys

import addon_utils
import bpy


def install(zip_path):
    """Install + enable; returns the add-on's module name."""
    # Blender 4.2+: the zip carries blender_manifest.toml and installs as an
    # extension of the user repository (not tested here: this machine has 3.4).
    extensions = getattr(bpy.ops, "extensions", None)
    if bpy.app.version >= (4, 2, 0) and extensions is not None and hasattr(extensions, "package_install_files"):
        bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default", enable_on_install=True)
        return "bl_ext.user_default.arap_deform"
    bpy.ops.preferences.addon_install(filepath=zip_path, overwrite=True)
    addon_utils.modules_refresh()
    bpy.ops.preferences.addon_enable(module="arap_deform")
    return "arap_deform"


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if len(argv) != 1 or not os.path.isfile(argv[0]):
        print("usage: blender --background --factory-startup --python install_addon.py -- <arap_deform.zip>")
        sys.exit(2)
    zip_path = os.path.abspath(argv[0])
    try:
        bpy.ops.wm.read_userpref()
    except RuntimeError as exc:
        print("No saved preferences to keep (%s)" % exc)
    module = install(zip_path)
    if module not in bpy.context.preferences.addons:
        print("ERROR: the add-on did not enable; see the messages above")
        sys.exit(1)
    native_loader = importlib.import_module(module + ".native_loader")
    mod = native_loader.native()  # raises with what to rebuild when the module does not match
    bpy.ops.wm.save_userpref()
    print("Installed and enabled arap_deform %s (native %s, %s) from %s"
          % (native_loader.addon_version(), mod.__version__, mod.PYTHON_ABI, zip_path))


main()
