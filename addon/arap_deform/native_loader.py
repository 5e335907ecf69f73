# SPDX-License-Identifier: GPL-3.0-or-later
"""Loads the compiled module _arap_native on first use and checks that it was
built for this add-on and this Python: the only importer of the native module.
"""

import glob
import importlib
import os
import re
import sys

_native = None


class NativeModuleError(ImportError):
    """The compiled module is missing or was built for another add-on/Python."""


def addon_version():
    """The add-on's version, from blender_manifest.toml (the one source: Blender
    removes bl_info from extensions, and CMake checks bl_info against it)."""
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "blender_manifest.toml")
    with open(path, encoding="utf-8") as f:
        match = re.search(r'^version\s*=\s*"([^"]+)"', f.read(), re.MULTILINE)
    if match is None:
        raise NativeModuleError("%s has no version line: the add-on is damaged, reinstall it" % path)
    return match.group(1)


def native():
    """Import _arap_native on first use and check it matches this add-on."""
    global _native
    if _native is not None:
        return _native
    here = os.path.dirname(os.path.abspath(__file__))
    py = "%d.%d" % sys.version_info[:2]
    rebuild = ("Rebuild the module for Python %s on a Linux with that Python's headers: cmake -S <source> -B build "
               "-DARAP_PYTHON_VERSION=%s && cmake --build build, then install build/arap_deform.zip (README, "
               "'Blender versions')" % (py, py))
    try:
        mod = importlib.import_module(__package__ + "._arap_native")   # the compiled file beside this one
    except ImportError as exc:
        # One file per Python ABI may sit here (_arap_native.cpython-311-x86_64-linux-gnu.so, ...);
        # Python picks the one whose tag matches its own.
        found = sorted(os.path.basename(p) for p in glob.glob(os.path.join(here, "_arap_native*")))
        tags = sorted(set(re.findall(r"cpython-(\d)(\d+)", " ".join(found))), key=lambda t: int(t[1]))
        if found and sys.implementation.cache_tag.replace("-", "") not in {"cpython%s%s" % t for t in tags}:
            msg = ("This Blender runs Python %s, but the add-on carries its native module only for Python %s "
                   "(%s). " % (py, ", ".join("%s.%s" % t for t in tags) or "?", ", ".join(found)))
        elif found:
            msg = ("The ARAP native module %s does not load in this Blender (Python %s, %s): %s. "
                   % (", ".join(found), py, sys.implementation.cache_tag, exc))
        else:
            msg = "The ARAP native module (_arap_native) is missing from %s. " % here
        raise NativeModuleError(msg + rebuild) from exc
    if tuple(mod.PYTHON_VERSION) != tuple(sys.version_info[:2]):
        raise NativeModuleError("The ARAP native module was built for Python %d.%d (%s) but Blender runs "
                                "Python %s. %s" % (*mod.PYTHON_VERSION, mod.PYTHON_ABI, py, rebuild))
    if mod.__version__ != addon_version():
        raise NativeModuleError("The ARAP native module is version %s but the add-on is %s: rebuild the "
                                "module from the same sources as the add-on. %s"
                                % (mod.__version__, addon_version(), rebuild))
    _native = mod
    return mod


def loaded():
    """The native module if native() loaded it already, else None (never loads it)."""
    return _native
