# SPDX-License-Identifier: GPL-3.0-or-later
"""What moves a handle: an Empty, or one bone of an armature object.

Both give the world-space motion of the handle since its bind pose, which
handles.target_transform() turns into object-local targets:

    Empty:  M_now = M_empty_world,  bound with M_bind^-1 = (M_empty_world at bind)^-1
    bone:   M_now = A @ P @ B^-1 @ A^-1,  bound with the identity

where A is the armature object's world matrix now, P the pose bone's matrix
(armature space) now and B its matrix at bind, kept in armature space. The
bone's bind is kept relative to its armature, as the Armature modifier's rest
pose is, so moving the armature object carries the handle with it; for the
handles made from a rig (rig.py) B is the bone's rest matrix, and their
vertices move exactly as the Armature modifier moves a vertex weighted 1 to
that bone.

`handle`: a saved handle (ARAP_PG_handle) or a bound one (constraints.HandleBlock),
both with .group, .empty, .armature and .bone.
"""

import numpy as np

from . import handles
from ..errors import SetupError


def is_bone(handle):
    """The handle follows a bone (else an Empty)."""
    return bool(handle.bone)


def driver(handle):
    """The object that moves the handle: its Empty or its armature (None when unset or cleared)."""
    return handle.armature if is_bone(handle) else handle.empty


def describe(handle):
    """How messages name what moves the handle: "Empty 'E'" or "bone 'B' of 'Rig'"."""
    if is_bone(handle):
        return "bone '%s' of '%s'" % (handle.bone, _name(handle.armature))
    return "Empty '%s'" % _name(handle.empty)


def _name(obj):
    try:
        return obj.name if obj is not None else "(none)"
    except ReferenceError:
        return "(deleted)"


def object_alive(obj, scene):
    """False for a deleted object (pointer cleared, or removed from the scene)."""
    if obj is None:
        return False
    try:
        name = obj.name
    except ReferenceError:
        return False
    return scene is None or scene.objects.get(name) == obj


def check(handle, scene, label):
    """SetupError saying what to do when handle `label`'s Empty or bone is unset, deleted or renamed."""
    if not is_bone(handle):
        if handle.empty is None:
            raise SetupError("Handle '%s' has no empty (never set, or deleted): pick one in the handle list" % label)
        if not object_alive(handle.empty, scene):
            raise SetupError("The empty of handle '%s' was deleted: pick another one" % label)
        return
    if handle.armature is None or not object_alive(handle.armature, scene):
        raise SetupError("The armature of handle '%s' (bone '%s') was deleted: remove the handle or run "
                         "Handles from Armature again" % (label, handle.bone))
    if handle.armature.type != 'ARMATURE':
        raise SetupError("Handle '%s' follows bone '%s' of '%s', which is not an armature"
                         % (label, handle.bone, handle.armature.name))
    if handle.armature.pose is None or handle.armature.pose.bones.get(handle.bone) is None:
        raise SetupError("Handle '%s' follows bone '%s', which '%s' no longer has (renamed or deleted): "
                         "run Handles from Armature again" % (label, handle.bone, handle.armature.name))


def _evaluated(obj, depsgraph):
    return obj.evaluated_get(depsgraph) if depsgraph is not None else obj


def bone_pose_matrix(armature, bone):
    """The pose bone's matrix P (armature space, float64 (4, 4))."""
    return handles.matrix_to_numpy(armature.pose.bones[bone].matrix)


def bone_rest_matrix(armature, bone):
    """The bone's rest matrix (armature space): the bind the Armature modifier deforms from."""
    return handles.matrix_to_numpy(armature.data.bones[bone].matrix_local)


def bind_matrix_now(handle):
    """What a bind taken now stores: the Empty's world matrix, or the pose bone's matrix in armature space."""
    if is_bone(handle):
        return bone_pose_matrix(handle.armature, handle.bone)
    return handles.matrix_to_numpy(handle.empty.matrix_world)


def bind_inverses(handle, bind, label):
    """(M_bind^-1 used by target_transform, B^-1 of a bone or None): see the module's formula."""
    if is_bone(handle):
        b_inv = handles.invert(bind, "The bind pose of handle '%s' (bone '%s' when the pose was taken)"
                               % (label, handle.bone))
        return np.eye(4), b_inv
    return handles.bind_inverse(bind, label, handle.empty.name), None


def motion_matrix(block, depsgraph=None):
    """M_now of a bound handle (HandleBlock): its Empty's world matrix, or A @ P @ B^-1 @ A^-1 of its bone,
    evaluated in `depsgraph` when given (keyframes, drivers, constraints and IK of the frame shown)."""
    if block.bone_bind_inv is None:
        return handles.matrix_to_numpy(_evaluated(block.empty, depsgraph).matrix_world)
    armature = _evaluated(block.armature, depsgraph)
    a = handles.matrix_to_numpy(armature.matrix_world)
    p = bone_pose_matrix(armature, block.bone)
    return a @ p @ block.bone_bind_inv @ handles.invert(a, "The armature '%s'" % armature.name)
