# SPDX-License-Identifier: GPL-3.0-or-later
"""Settings that older versions saved under other names (Object.arap).

The object's settings are named after the solver's options (the native option
table). A .blend saved before that holds the old names as plain ID properties
inside obj.arap, which no property reads any more. Every local object's are
moved to the new names when a file is opened (load_post) and once when the
add-on is enabled (the file already open): the old key is deleted, and a value
already set under the new name is kept (the new name wins).

A linked (library) object cannot be written: setting() reads its old value
instead, until the library is saved again by this version.
"""

import warnings

import bpy
from bpy.app.handlers import persistent

# Old name -> (new name, the new property's type).
RENAMED = {
    "iterations": ("max_iterations", int),
    "live_iterations": ("live_max_iterations", int),
    "acceleration": ("anderson_window", int),
    "self_contact": ("contact", bool),    # True: the contact option's "self" (solver_settings.CONTACT_NAMES)
}
OLD_NAME = {new: (old, kind) for old, (new, kind) in RENAMED.items()}


def setting(settings, name):
    """settings.<name>, or the value an older version saved under its old name when only that is there
    (an object of a library that was not migrated)."""
    old, kind = OLD_NAME.get(name, (None, None))
    if old is not None and name not in settings and old in settings:
        return kind(settings[old])
    return getattr(settings, name)


def max_iterations_argument(max_iterations, iterations):
    """The cap a caller of the Python API gave: max_iterations=, or the deprecated iterations= of older
    scripts (with a DeprecationWarning at the caller's line)."""
    if iterations is None:
        return max_iterations
    warnings.warn("iterations= is deprecated: pass max_iterations=", DeprecationWarning, stacklevel=3)
    if max_iterations is not None:
        raise TypeError("give max_iterations= only (iterations= is its deprecated name)")
    return iterations


def migrate(settings):
    """Move the old names' values of one object's settings to the new names (a new name already set wins)."""
    for old, (new, kind) in RENAMED.items():
        if old not in settings:
            continue
        if new not in settings:
            # As an ID property: no update callback runs (Auto is not bound again while a file opens).
            settings[new] = kind(settings[old])
        del settings[old]


def migrate_file():
    """Migrate every local object of the open file (linked ones cannot be written; setting() reads them)."""
    # Not `"arap" in obj`: since Blender 5.0 the add-on's settings are not among the object's custom properties.
    for obj in bpy.data.objects:
        if obj.library is None:
            migrate(obj.arap)


@persistent
def _on_load(_file=None, _unused=None):
    migrate_file()


def _migrate_later():
    migrate_file()
    return None


def register():
    bpy.app.handlers.load_post.append(_on_load)
    # Blender registers add-ons with bpy.data restricted (addon_utils.enable, start-up): the open file is then
    # migrated from the event loop.
    if isinstance(bpy.data, bpy.types.BlendData):
        migrate_file()
    else:
        bpy.app.timers.register(_migrate_later, first_interval=0.0)


def unregister():
    if _on_load in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(_on_load)
    if bpy.app.timers.is_registered(_migrate_later):
        bpy.app.timers.unregister(_migrate_later)
