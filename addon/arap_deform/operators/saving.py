# SPDX-License-Identifier: GPL-3.0-or-later
"""What a .blend saved while posing holds (Blender's save_pre and save_post handlers).

- Live: the pose on screen, and with output in the mesh its rest shape too (the "arap_rest"
  attribute, as Apply stores it), so that the reopened file can go back to rest.
- A bake in progress: the mesh as it was before the bake; its preview comes back after the save.
- Auto mode: nothing to do, its rest shape is stored when it starts; the file reopens posed.

A handler never stops the save: what fails here is printed and the file is written anyway.
"""

import traceback

import bpy
from bpy.app.handlers import persistent

from . import bake_ops
from ..solver import sessions


def _tell(runs, action):
    for run in runs:
        try:
            getattr(run, action)()
        except (ReferenceError, ValueError):
            traceback.print_exc()   # the object went away: that session or bake ends at its next update


def _bakes():
    run = bake_ops.InteractiveBake.current
    return [] if run is None else [run]


@persistent
def _before_save(*_args):
    _tell(sessions.running() + _bakes(), "before_save")


@persistent
def _after_save(*_args):
    _tell(_bakes(), "after_save")


_HANDLERS = (("save_pre", _before_save), ("save_post", _after_save))


def register():
    for name, fn in _HANDLERS:
        getattr(bpy.app.handlers, name).append(fn)


def unregister():
    for name, fn in _HANDLERS:
        handlers = getattr(bpy.app.handlers, name)
        if fn in handlers:
            handlers.remove(fn)
