# SPDX-License-Identifier: GPL-3.0-or-later
"""Handles from Armature: one handle per deform bone of the mesh's rig (solver/rig.py)."""

import bpy
from bpy.props import FloatProperty

from .. import api
from ..errors import SetupError
from ..solver import rig, sessions
from .setup_ops import _record_settings_in_undo


class ARAP_OT_handles_from_armature(bpy.types.Operator):
    """Pose with the rig: each deform bone's rigid core (its vertices weighted at least Core Weight) follows
    the bone, ARAP poses the joints between, and vertices no bone weights stay put. The Armature modifier is
    turned off while ARAP shows a pose and back on when the mesh is at rest again"""
    bl_idname = "object.arap_handles_from_armature"
    bl_label = "Handles from Armature"
    bl_options = {'REGISTER', 'UNDO'}

    threshold: FloatProperty(
        name="Core Weight",
        description="A vertex follows a bone rigidly when its weight for that bone is at least this; the "
                    "vertices below it for every bone are posed by ARAP",
        default=rig.DEFAULT_CORE_WEIGHT, min=0.01, max=1.0, precision=2, step=5,
    )

    @classmethod
    def poll(cls, context):
        return sessions.target_mesh(context) is not None

    def execute(self, context):
        obj = sessions.target_mesh(context)
        if sessions.session_for(obj) is not None:
            self.report({'ERROR'}, "Apply or cancel Live on '%s' first" % obj.name)
            return {'CANCELLED'}
        try:
            made = api.handles_from_armature(obj, self.threshold)
        except SetupError as exc:
            self.report({'ERROR'}, str(exc))
            return {'CANCELLED'}
        _record_settings_in_undo(obj)
        self.report({'INFO'}, "'%s': %s" % (obj.name, made.summary()))
        return {'FINISHED'}


classes = (ARAP_OT_handles_from_armature,)
register, unregister = bpy.utils.register_classes_factory(classes)
