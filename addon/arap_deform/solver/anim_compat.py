# SPDX-License-Identifier: GPL-3.0-or-later
"""F-curves of a data-block's action, on every supported Blender.

Blender 4.4 introduced slotted actions (action -> layers -> strips ->
channelbag per slot -> fcurves) and 5.0 removed the flat `Action.fcurves`
that 3.x-4.3 have. The bake only needs "the F-curve collection that animates
this data-block"; this module gives it on both.
"""

import bpy

SLOTTED = bpy.app.version >= (4, 4, 0)


def fcurves(id_data, create=False, action_name=None):
    """The F-curve collection (has .new/.remove/.find) animating `id_data`.

    Returns (fcurves, created_action); fcurves is None when the data-block
    has no action and create is False. With create=True a missing action
    (named `action_name`) and, on 4.4+, its slot, layer and strip are made.
    """
    anim = id_data.animation_data
    if anim is None:
        if not create:
            return None, False
        anim = id_data.animation_data_create()
    created = False
    if anim.action is None:
        if not create:
            return None, False
        anim.action = bpy.data.actions.new(action_name or id_data.name)
        created = True
    action = anim.action
    if not SLOTTED:
        return action.fcurves, created
    slot = anim.action_slot
    if slot is None:
        if not create:
            return None, created
        slot = action.slots.new(id_type=id_data.id_type, name=id_data.name)
        anim.action_slot = slot
    channelbag = _channelbag(action, slot, create)
    return (None if channelbag is None else channelbag.fcurves), created


def _channelbag(action, slot, create):
    for layer in action.layers:
        for strip in layer.strips:
            bag = strip.channelbag(slot)
            if bag is not None:
                return bag
    if not create:
        return None
    layer = action.layers[0] if len(action.layers) else action.layers.new("Layer")
    strip = layer.strips[0] if len(layer.strips) else layer.strips.new(type='KEYFRAME')
    return strip.channelbag(slot, ensure=True)


def unassign_action(id_data):
    """Detach the data-block's action; returns it (or None)."""
    anim = id_data.animation_data
    if anim is None or anim.action is None:
        return None
    action = anim.action
    anim.action = None
    return action
