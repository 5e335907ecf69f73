# SPDX-License-Identifier: GPL-3.0-or-later
"""Dependency loops: a handle Empty that follows the mesh it poses.

A pose is solved from the world matrices of the handle Empties. When a handle's
Empty itself follows the posed object, the pose depends on itself:

- a vertex parent (parent type 'VERTEX' or 'VERTEX_3') on the posed mesh puts
  the Empty on vertices the pose moves: each pose moves the Empty, which asks
  for a new pose (in Auto mode a 4-unit cylinder whose handle Empty sits on one
  of its handle vertices climbs 8 units a frame);
- any other parent type on the posed object, a constraint whose target is the
  posed object (Copy Location, Child Of, Damped Track, Shrinkwrap ..., with or
  without a vertex group subtarget), or a driver of the Empty's transform or
  constraints whose variable reads the posed object, its mesh or its shape
  keys, counts too: with a vertex group subtarget, a Shrinkwrap or a driver on
  the mesh the Empty reads the posed vertices (the same loop); otherwise it
  moves with the object's transform, and the handle then carries the object's
  motion into the pose a second time (the handle's vertices move twice);
- the same through other objects: the Empty's parent, a constraint's target or
  a driver's object (an armature's bone included: the parent bone or the
  constraint's subtarget bone and that bone's parents, with their
  constraints) that itself follows the posed object, by any of the links above.

Muted constraints and muted drivers are skipped (they do nothing). Modifiers
of other objects (a Shrinkwrap modifier on a mesh the Empty is vertex-parented
to, say) are not followed.

find() walks those links from each handle Empty, each object once: a few
attribute reads per object, cheap enough for every Auto and Live update.
check() raises DependencyLoop (a SetupError) naming the handle, its Empty and
the links that lead back to the posed object. Deform, Live, the bake and Auto
mode check when they bind (problem.Problem); Auto mode and Live check again
on every update, before anything is solved.
"""

import bpy

from . import drivers
from ..errors import SetupError

VERTEX_PARENTS = {'VERTEX', 'VERTEX_3'}
# Drivers on these properties move an object (or its bones): a driver elsewhere (a custom property,
# visibility) does not change where a handle is.
TRANSFORM_PATHS = ("location", "rotation", "scale", "delta_", "matrix", "constraints", "pose.bones")


class DependencyLoop(SetupError):
    """A handle Empty follows the mesh it poses (the message says how)."""


class Loop:
    """A handle whose Empty follows the posed object: `links` are (owner name, how, target name) from the Empty
    to the posed object."""

    def __init__(self, obj_name, group, empty_name, links, what=None):
        self.obj_name, self.group, self.empty_name, self.links = obj_name, group, empty_name, links
        self.what = what or "Empty '%s'" % empty_name    # drivers.describe(): an Empty or a bone

    @property
    def how(self):
        """'vertex parent', or the chain: "parent 'Link' -> 'Link' constraint 'Copy Location'"."""
        parts = []
        for i, (owner, how, target) in enumerate(self.links):
            parts.append(how if i == 0 else "'%s' %s" % (owner, how))
            if i < len(self.links) - 1:
                parts[-1] += " '%s'" % target
        return " -> ".join(parts)

    def message(self):
        return ("Dependency loop: the %s of handle '%s' follows '%s', the mesh it poses (%s), so every "
                "pose would move its own handle: parent or constrain it to something that does not "
                "follow '%s'" % (self.what, self.group, self.obj_name, self.how, self.obj_name))


def _same(a, b):
    return a is not None and b is not None and a.as_pointer() == b.as_pointer()


def _constraint_links(constraints, label):
    """(how, target object, target bone or None) of each constraint that is not muted."""
    for c in constraints:
        if not getattr(c, "enabled", not getattr(c, "mute", False)):
            continue
        how = "%sconstraint '%s'" % (label, c.name)
        target = getattr(c, "target", None)
        if target is not None:
            yield how, target, getattr(c, "subtarget", "") or None
        for t in getattr(c, "targets", ()):   # the Armature constraint: several targets
            if getattr(t, "target", None) is not None:
                yield how, t.target, getattr(t, "subtarget", "") or None
        pole = getattr(c, "pole_target", None)   # IK
        if pole is not None:
            yield how, pole, getattr(c, "pole_subtarget", "") or None


def _driver_links(ob):
    """(how, ID read) of each unmuted driver on `ob`'s transform, constraints or bones."""
    anim = ob.animation_data
    if anim is None:
        return
    for fcurve in anim.drivers:
        if fcurve.mute or not fcurve.data_path.startswith(TRANSFORM_PATHS):
            continue
        how = "driver of %s" % fcurve.data_path
        for var in fcurve.driver.variables:
            for t in var.targets:
                if t.id is not None:
                    yield how, t.id


def _links(ob, bone):
    """(how, target ID, target bone) of what `ob` (and its bone `bone`, for an armature) follows."""
    if ob.parent is not None:
        if ob.parent_type in VERTEX_PARENTS:
            yield "vertex parent", ob.parent, None
        elif ob.parent_type == 'BONE' and ob.parent_bone:
            yield "parent bone '%s' of" % ob.parent_bone, ob.parent, ob.parent_bone
        else:
            yield "parent", ob.parent, None
    yield from _constraint_links(ob.constraints, "")
    if bone and ob.pose is not None:
        pose_bone = ob.pose.bones.get(bone)
        while pose_bone is not None:
            yield from _constraint_links(pose_bone.constraints, "bone '%s' " % pose_bone.name)
            pose_bone = pose_bone.parent
    for how, id_read in _driver_links(ob):
        yield how, id_read, None


def _reads(id_read, obj):
    """`id_read` is the posed object, its mesh or its shape keys."""
    mesh = obj.data
    return _same(id_read, obj) or _same(id_read, mesh) or _same(id_read, mesh.shape_keys)


def _path_to(empty, obj, bone=None):
    """The links from `empty` (or bone `bone` of armature `empty`) to `obj` [(owner name, how, target name)],
    or None."""
    seen = set()
    stack = [(empty, bone, [])]
    while stack:
        ob, bone, path = stack.pop()
        key = (ob.as_pointer(), bone)
        if key in seen:
            continue
        seen.add(key)
        for how, target, target_bone in _links(ob, bone):
            link = path + [(ob.name, how, target.name)]
            if _reads(target, obj):
                return link
            if isinstance(target, bpy.types.Object):   # follow what it follows
                stack.append((target, target_bone if target.type == 'ARMATURE' else None, link))
    return None


def find(obj, handles):
    """The first Loop among `handles` (the settings' handles, or a Setup's: drivers.py) of the posed object
    `obj`, or None. Handles without an Empty (or armature), or with a deleted one, are skipped."""
    for h in handles:
        empty = drivers.driver(h)
        if empty is None:
            continue
        try:
            empty.name
        except ReferenceError:
            continue
        what = drivers.describe(h)
        if _same(empty, obj):
            return Loop(obj.name, h.group, empty.name, [(empty.name, "the posed object itself", obj.name)], what)
        path = _path_to(empty, obj, h.bone or None)
        if path is not None:
            return Loop(obj.name, h.group, empty.name, path, what)
    return None


def check(obj, handles):
    """Raise DependencyLoop when a handle's Empty follows `obj` (find())."""
    loop = find(obj, handles)
    if loop is not None:
        raise DependencyLoop(loop.message())
