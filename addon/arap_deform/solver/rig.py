# SPDX-License-Identifier: GPL-3.0-or-later
"""Handles from the rig a mesh already has, and the Armature modifier kept
off the pose ARAP shows.

Each deform bone with a vertex group of its name gives one handle: the
vertices whose weight for that bone is at least a threshold (the bone's rigid
core) follow the bone, bound at its rest pose (drivers.py), so they move as
the Armature modifier moves a vertex weighted fully to the bone; ARAP poses
everything between the cores, with no joint weights. Vertices no deform bone
weights stay where they are, as the modifier leaves them.

While ARAP shows a pose of such a mesh, its Armature deformation (modifiers
on the handles' armatures, or an armature parent) would move that pose a
second time: ARAP turns it off in the viewport and in renders, keeps what it
changed in the object's settings (`armature_muted`) and puts it back exactly
when the mesh shows its rest shape again (restore_armature).
"""

import json

import numpy as np

from . import drivers, meshio
from ..errors import SetupError

CORE_PREFIX = "ARAP_Core_"            # + bone name: the vertex group of a bone's rigid core
UNWEIGHTED_GROUP = "ARAP_Unweighted"  # the vertices no deform bone moves: the fixed group
DEFAULT_CORE_WEIGHT = 0.9             # chosen on the rig benchmark (docs/rig.md)
MAX_GROUP_NAME = 63                   # Blender's vertex group names are at most 63 bytes


def armature_of(obj):
    """The armature object that deforms `obj`: its first Armature modifier's, else an armature parent
    (parent type Armature); SetupError when there is none."""
    for m in obj.modifiers:
        if m.type == 'ARMATURE' and m.object is not None:
            return m.object
    if obj.parent is not None and obj.parent.type == 'ARMATURE' and obj.parent_type == 'ARMATURE':
        return obj.parent
    raise SetupError("'%s' has no Armature modifier with an armature, nor an armature parent: add one "
                     "(Object > Parent > With Automatic Weights) first" % obj.name)


def core_group_name(bone):
    name = CORE_PREFIX + bone
    while len(name.encode("utf-8")) > MAX_GROUP_NAME:
        name = name[:-1]
    return name


def bone_weights(obj, bones):
    """(n, len(bones)) float64 weights of the vertex groups named after `bones` (0 where a vertex is not in
    one; a bone without a group gets a column of zeros)."""
    return meshio.finish(meshio.read_groups_in_steps(obj, [], weights_of=bones))[1]


class RigHandles:
    """What handles_from_armature() made: the bones given a handle, the bones left out with why, the
    number of vertices in each core and of those fixed."""

    def __init__(self):
        self.bones, self.skipped, self.core_sizes, self.fixed = [], [], [], 0

    def summary(self):
        text = "%d bone handles" % len(self.bones)
        if self.fixed:
            text += ", %d unweighted vertices fixed" % self.fixed
        if self.skipped:
            text += "; left out: " + ", ".join("%s (%s)" % s for s in self.skipped)
        return text


def _set_group(obj, name, indices):
    """Vertex group `name` holding exactly `indices` with weight 1 (one made before is replaced)."""
    old = obj.vertex_groups.get(name)
    if old is not None:
        obj.vertex_groups.remove(old)
    group = obj.vertex_groups.new(name=name)
    group.add([int(i) for i in indices], 1.0, 'REPLACE')
    return group


def handles_from_armature(obj, threshold=DEFAULT_CORE_WEIGHT, armature=None):
    """One handle per deform bone of `armature` (default armature_of(obj)) that weights some vertex at least
    `threshold`, bound at the bone's rest pose; the vertices no deform bone weights become the fixed group.
    The bone handles of that armature made before are replaced; other handles are kept. Returns RigHandles."""
    if not 0.0 < threshold <= 1.0:
        raise SetupError("The core weight must be in (0, 1], not %g" % threshold)
    armature = armature or armature_of(obj)
    bones = [b.name for b in armature.data.bones if b.use_deform]
    if not bones:
        raise SetupError("The armature '%s' has no deform bones" % armature.name)
    weights = bone_weights(obj, bones)
    s = obj.arap
    for i in reversed(range(len(s.handles))):
        if s.handles[i].bone and s.handles[i].armature == armature:
            s.handles.remove(i)
    made = RigHandles()
    for k, bone in enumerate(bones):
        core = np.flatnonzero(weights[:, k] >= threshold)
        if bone not in obj.vertex_groups or core.size == 0:
            made.skipped.append((bone, "no vertex group" if bone not in obj.vertex_groups else
                                 "no vertex weighted %g or more" % threshold))
            stale = obj.vertex_groups.get(core_group_name(bone))   # a core made before, by a lower Core Weight
            if stale is not None:
                obj.vertex_groups.remove(stale)
            continue
        group = _set_group(obj, core_group_name(bone), core).name
        item = s.handles.add()
        item.group, item.armature, item.bone = group, armature, bone
        item.bind_matrix = drivers.bone_rest_matrix(armature, bone).ravel().tolist()
        item.has_bind = True
        made.bones.append(bone)
        made.core_sizes.append(int(core.size))
    if not made.bones:
        raise SetupError("No deform bone of '%s' weights a vertex of '%s' %g or more: lower the core weight, "
                         "or weight the mesh to the bones" % (armature.name, obj.name, threshold))
    unweighted = np.flatnonzero(weights.max(axis=1) <= 0.0)
    if unweighted.size:
        s.fixed_group = _set_group(obj, UNWEIGHTED_GROUP, unweighted).name
    elif s.fixed_group == UNWEIGHTED_GROUP:
        s.fixed_group = ""
    made.fixed = int(unweighted.size)
    s.active_handle = len(s.handles) - 1
    return made


def deforming_armatures(obj):
    """The armature objects of `obj`'s bone handles."""
    return {h.armature.name: h.armature for h in obj.arap.handles if h.bone and h.armature is not None}


def mute_armature(obj):
    """Turn off the Armature deformation of `obj` by its bone handles' armatures (Armature modifiers in the
    viewport and renders; an armature parent becomes a plain object parent, which keeps the object where it
    is), remembering what was on. Nothing to do without bone handles, or when already muted."""
    s = obj.arap
    if s.armature_muted:
        return   # every pose written checks: muted already is one string test
    armatures = deforming_armatures(obj)
    if not armatures:
        return
    muted = {"modifiers": [], "parent_type": None}
    for m in obj.modifiers:
        if m.type == 'ARMATURE' and m.object is not None and m.object.name in armatures:
            muted["modifiers"].append([m.name, m.show_viewport, m.show_render])
            m.show_viewport = m.show_render = False
    if obj.parent is not None and obj.parent.name in armatures and obj.parent_type == 'ARMATURE':
        muted["parent_type"] = obj.parent_type
        obj.parent_type = 'OBJECT'
    s.armature_muted = json.dumps(muted)


def restore_armature(obj):
    """Put back what mute_armature() turned off (a modifier removed or renamed since is skipped)."""
    s = obj.arap
    if not s.armature_muted:
        return
    muted = json.loads(s.armature_muted)
    for name, viewport, render in muted["modifiers"]:
        m = obj.modifiers.get(name)
        if m is not None:
            m.show_viewport, m.show_render = viewport, render
    if muted["parent_type"] and obj.parent is not None:
        obj.parent_type = muted["parent_type"]
    s.armature_muted = ""
