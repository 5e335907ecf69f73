# Blender side of the GUI driver's protocol (gui_driver.py): the state written
# for the driver (<out>/state.json, replaced whole so it is never read half
# written; "tick" counts the writes), the commands it leaves (<out>/cmd_*),
# and where the window's 3D viewport is.
import json
import os

import bpy


def view3d():
    """(window, area, region) of the first window's 3D viewport."""
    win = bpy.context.window_manager.windows[0]
    for area in win.screen.areas:
        if area.type == 'VIEW_3D':
            return win, area, next(r for r in area.regions if r.type == 'WINDOW')
    raise RuntimeError("no 3D viewport")


def viewport_centre(win, region):
    """The region's centre in X screen coordinates (y down), where xdotool puts the pointer."""
    return [region.x + region.width // 2, win.height - (region.y + region.height // 2)]


def write_state(out, state):
    state["tick"] = state.get("tick", 0) + 1
    tmp = os.path.join(out, "state.json.tmp")
    with open(tmp, "w") as f:
        json.dump(state, f)
    os.replace(tmp, os.path.join(out, "state.json"))


def take(out, cmd):
    """The command `cmd`'s argument (True when it has none) and remove it; None when it was not given."""
    path = os.path.join(out, cmd)
    if not os.path.exists(path):
        return None
    with open(path) as f:
        arg = f.read().strip()
    os.remove(path)
    return arg or True
