# SPDX-License-Identifier: GPL-3.0-or-later
"""ARAP Deform: pose a mesh as-rigidly-as-possible with handle empties.

This file only registers. See api.py for scripting; deform_job.py (Deform),
live.py (Live), bake.py and auto.py for the jobs, problem.py for what they
read from Blender, native_loader.py for the native bridge; solver_settings.py,
properties.py, setup_ops.py, deform_ops.py, live_ops.py, bake_ops.py, ui.py and
status_overlay.py for the Blender side; saving.py for what a .blend saved while
posing holds.
"""

bl_info = {
    "name": "ARAP Deform",
    "author": "ARAP Deform developers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "3D Viewport > Sidebar > ARAP",
    "description": "As-Rigid-As-Possible posing with vertex-group handles driven by empties",
    "category": "Mesh",
}

if "bpy" in locals():
    # Script reload (F3 > Reload Scripts): reload submodules in dependency order.
    import importlib
    for _name in ("native_loader", "errors", "temp_files", "properties", "meshio", "constraints", "problem",
                  "solver_cache", "sessions", "status_overlay", "modal_timers", "deform_job", "live", "anim_compat",
                  "api", "bake", "background_bind", "auto", "setup_ops", "deform_ops", "live_ops", "ui", "bake_ops",
                  "saving"):
        if _name in locals():
            importlib.reload(locals()[_name])

import bpy  # noqa: E402,F401 - its presence in locals() marks a reload

from . import properties, setup_ops, deform_ops, live_ops, ui, bake_ops, auto, api, status_overlay, saving  # noqa: E402

# Order matters: bake_ops' panel is a child of ui's ARAP_PT_main; auto adds Blender handlers.
_modules = (properties, setup_ops, deform_ops, live_ops, ui, bake_ops, auto, status_overlay, saving)


def register():
    for mod in _modules:
        mod.register()


def unregister():
    from . import deform_job, modal_timers, sessions
    sessions.stop_all_sessions()
    deform_job.clear_cache()
    live_ops.live_status_off()
    for mod in reversed(_modules):
        mod.unregister()
    modal_timers.remove_all()   # Live's, once its sessions are cancelled above
