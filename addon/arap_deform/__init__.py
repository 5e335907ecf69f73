# SPDX-License-Identifier: GPL-3.0-or-later
"""ARAP Deform: pose a mesh as-rigidly-as-possible with handle empties.

This file only registers. See api.py for scripting and native_loader.py for
the native bridge; solver/ for the jobs (deform_job.py: Deform, live.py: Live,
bake.py) and what they read from Blender (problem.py, handles.py); auto/ for
Auto mode; operators/ (saving.py: what a .blend saved while posing holds), ui/
and persistence/ (properties.py: the settings kept in the .blend) for the
Blender side.
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
    # Script reload (F3 > Reload Scripts): Blender has unregistered the add-on and runs this file again. Forget
    # every loaded submodule but the native module (loaded once per process), so that the imports below load
    # each one afresh, after the modules it imports.
    import sys
    for _name in [name for name in sys.modules if name.startswith(__name__ + ".")]:
        if _name != __name__ + "._arap_native":
            del sys.modules[_name]
            globals().pop(_name[len(__name__) + 1:], None)   # the package's attribute would outlive the module

import bpy  # noqa: E402,F401 - its presence in locals() marks a reload

from . import api  # noqa: E402,F401 - scripts reach it as <add-on>.api
from .auto import auto  # noqa: E402
from .operators import bake_ops, deform_ops, live_ops, rig_ops, saving, setup_ops  # noqa: E402
from .persistence import properties, older_settings  # noqa: E402
from .ui import panels, status_overlay  # noqa: E402

# Order matters: bake_ops' panel is a child of panels' ARAP_PT_main; auto adds Blender handlers.
# older_settings after properties (it reads Object.arap) and before auto (its load_post handler runs first).
_modules = (properties, older_settings, setup_ops, rig_ops, deform_ops, live_ops, panels, bake_ops, auto,
            status_overlay, saving)


def register():
    for mod in _modules:
        mod.register()


def unregister():
    from .solver import deform_job, sessions
    from .ui import modal_timers
    sessions.stop_all_sessions()
    deform_job.clear_cache()
    live_ops.live_status_off()
    for mod in reversed(_modules):
        mod.unregister()
    modal_timers.remove_all()   # Live's, once its sessions are cancelled above
