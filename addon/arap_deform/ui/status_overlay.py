# SPDX-License-Identifier: GPL-3.0-or-later
"""What ARAP is doing, drawn in the 3D viewport's lower-left corner.

The status bar is Blender's: during G/R/S its own hints fill it and cut
anything appended there short, and a progress bar's text is cut to its
width. The viewport's corner is free on every version, so Live, Deform, the
bake and Auto mode say there what they are doing (each through a function
that returns its lines, registered with add()), in short lines that always
fit. lines() is what is drawn, for tests and scripts.
"""

import blf
import bpy

_sources = []     # functions returning a list of lines (str), drawn in this order
_handle = None    # the SpaceView3D draw handler while the add-on is enabled

MARGIN_PX = 16    # from the region's left and bottom edges, before UI scale
FONT_PX = 13


def add(source):
    """Draw the lines `source()` returns (a function; no lines: nothing drawn)."""
    if source not in _sources:
        _sources.append(source)


def remove(source):
    if source in _sources:
        _sources.remove(source)


def lines():
    """Every line the overlay shows now, top to bottom."""
    out = []
    for source in _sources:
        try:
            out.extend(source())
        except ReferenceError:   # a source whose object Blender just removed (undo, delete)
            continue
    return out


def redraw(context=None, areas=('VIEW_3D',)):
    """Ask every 3D viewport (every area of the types `areas`: the bake's progress bar is in the
    'STATUSBAR') to draw again: what the modal operators show changed between inputs."""
    wm = (context or bpy.context).window_manager
    for window in wm.windows if wm is not None else ():
        for area in window.screen.areas:
            if area.type in areas:
                area.tag_redraw()


def _set_size(font, size):
    if bpy.app.version < (4, 0, 0):
        blf.size(font, size, 72)   # 3.x takes a DPI too (dropped in 4.0)
    else:
        blf.size(font, size)


def _bottom(context, scale):
    """Where the lines may start from the region's bottom: above the redo panel (the "HUD" region
    Blender puts in the viewport's lower-left corner after an operator) when it is shown."""
    bottom = round(MARGIN_PX * scale)
    area, region = context.area, context.region
    if area is None or region is None:
        return bottom
    for hud in area.regions:
        if hud.type == 'HUD' and hud.width > 1 and hud.height > 1 and hud.x < region.x + region.width // 2:
            bottom = max(bottom, hud.y - region.y + hud.height + round(MARGIN_PX * scale / 2))
    return bottom


def _draw():
    text = lines()
    if not text:
        return
    context = bpy.context
    scale = context.preferences.system.ui_scale
    font = 0
    size = round(FONT_PX * scale)
    _set_size(font, size)
    blf.enable(font, blf.SHADOW)
    blf.shadow(font, 3, 0.0, 0.0, 0.0, 0.9)
    blf.shadow_offset(font, 1, -1)
    blf.color(font, 1.0, 1.0, 1.0, 1.0)
    x = round(MARGIN_PX * scale)
    step = round(size * 1.5)
    y = _bottom(context, scale) + step * (len(text) - 1)
    for line in text:
        blf.position(font, x, y, 0)
        blf.draw(font, line)
        y -= step
    blf.disable(font, blf.SHADOW)


def register():
    global _handle
    if _handle is None and not bpy.app.background:
        _handle = bpy.types.SpaceView3D.draw_handler_add(_draw, (), 'WINDOW', 'POST_PIXEL')


def unregister():
    global _handle
    if _handle is not None:
        bpy.types.SpaceView3D.draw_handler_remove(_handle, 'WINDOW')
        _handle = None
    _sources.clear()
