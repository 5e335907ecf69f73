# SPDX-License-Identifier: GPL-3.0-or-later
"""Settings (Object.arap) as a .blend saved by an older version holds them.

- Renamed settings. The object's settings are named after the solver's
  options (the native option table). An older file holds the old names as plain
  ID properties inside obj.arap, which no property reads any more: they move to
  the new names (the old key is deleted; a value already set under the new
  name wins).
- Changed defaults. A setting left at its default is not stored in the file,
  so a new default would change the poses of older files. Volume's default is
  now Infill (the native option table's); an object that older versions posed
  with the Surface Only default keeps Surface Only: Volume is written into its
  settings. An object is from an older version when its settings hold anything
  but not `saved_with`: this version writes that mark into every object's
  settings on save.

Both happen for every local object when a file is opened (load_post) and once
when the add-on is enabled (the file already open). A linked (library) object
cannot be written: setting() reads it as if it had been, until the library is
saved again by this version.
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

# Setting -> its default in the versions before it changed (the property's identifier).
OLD_DEFAULTS = {"volume": 'NONE'}
# The mark of the settings' layout this version saves (ARAP_PG_settings.saved_with); 0, the property's
# default, is every version before it.
SAVED_WITH = 1


def _holds_settings(settings):
    """Whether anything of the object's ARAP settings is stored (a handle, a setting not at its default)."""
    if len(settings.handles) or any(old in settings for old in RENAMED):
        return True
    return any(settings.is_property_set(p.identifier) for p in settings.bl_rna.properties
               if p.identifier not in ("rna_type", "saved_with"))


def _from_older_version(settings):
    return not settings.is_property_set("saved_with") and _holds_settings(settings)


def setting(settings, name):
    """settings.<name> as the object's file means it: for an object an older version saved that could not be
    migrated (a linked one), the value it stored under an old name, or the default it was posed with."""
    old, kind = OLD_NAME.get(name, (None, None))
    if old is not None and name not in settings and old in settings:
        return kind(settings[old])
    if (name in OLD_DEFAULTS and settings.id_data.library is not None and not settings.is_property_set(name)
            and _from_older_version(settings)):
        return OLD_DEFAULTS[name]
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
    """One object's settings as this version saves them: the old names' values under the new names (a new
    name already set wins), and the old defaults written where an older version relied on them."""
    older = _from_older_version(settings)
    for old, (new, kind) in RENAMED.items():
        if old not in settings:
            continue
        if new not in settings:
            # As an ID property: no update callback runs (Auto is not bound again while a file opens).
            settings[new] = kind(settings[old])
        del settings[old]
    if older:
        for name, value in OLD_DEFAULTS.items():
            if not settings.is_property_set(name):
                settings[name] = settings.bl_rna.properties[name].enum_items[value].value
        mark(settings)


def mark(settings):
    """Mark the settings as saved by this version."""
    settings.saved_with = SAVED_WITH


def migrate_file():
    """Migrate every local object of the open file (linked ones cannot be written; setting() reads them)."""
    # Not `"arap" in obj`: since Blender 5.0 the add-on's settings are not among the object's custom properties.
    for obj in bpy.data.objects:
        if obj.library is None:
            migrate(obj.arap)


@persistent
def _on_load(_file=None, _unused=None):
    migrate_file()


@persistent
def _on_save(_file=None, _unused=None):
    for obj in bpy.data.objects:
        if obj.library is None and _holds_settings(obj.arap):
            mark(obj.arap)


def _migrate_later():
    migrate_file()
    return None


def register():
    bpy.app.handlers.load_post.append(_on_load)
    bpy.app.handlers.save_pre.append(_on_save)
    # Blender registers add-ons with bpy.data restricted (addon_utils.enable, start-up): the open file is then
    # migrated from the event loop.
    if isinstance(bpy.data, bpy.types.BlendData):
        migrate_file()
    else:
        bpy.app.timers.register(_migrate_later, first_interval=0.0)


def unregister():
    if _on_load in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(_on_load)
    if _on_save in bpy.app.handlers.save_pre:
        bpy.app.handlers.save_pre.remove(_on_save)
    if bpy.app.timers.is_registered(_migrate_later):
        bpy.app.timers.unregister(_migrate_later)
