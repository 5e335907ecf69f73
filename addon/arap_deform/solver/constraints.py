# SPDX-License-Identifier: GPL-3.0-or-later
"""Read an object's ARAP settings into index arrays, check them, and turn
empty matrices into target positions.

Fixed vertices keep their rest position; a handle's vertices move by its
target transform (handles.py). Which vertices are fixed and which
follow which handle is decided by the core library's rule (gather()).
"""

import bpy
import numpy as np

from . import drivers, handles, meshio, sessions
from .. import native_loader
from ..errors import SetupError  # noqa: F401 - raised here, imported from here by callers


class HandleBlock:
    """Rows [start, stop) of the constrained list follow the Empty or the bone of saved handle `handle`
    (drivers.py)."""

    def __init__(self, index, handle, start, stop):
        self.index = index      # position in settings.handles
        self.group = handle.group
        self.empty = handle.empty if not drivers.is_bone(handle) else None
        self.armature = handle.armature if drivers.is_bone(handle) else None
        self.bone = handle.bone
        self.start = start
        self.stop = stop
        bind = handles.bind_matrix(handle, drivers.bind_matrix_now)
        self.bind_inv, self.bone_bind_inv = drivers.bind_inverses(handle, bind, handle.group)

    @property
    def driver(self):
        """The Empty or the armature that moves this handle."""
        return drivers.driver(self)

    def set_driver(self, obj):
        """Follow `obj` (the same Empty or armature found again by name after an undo)."""
        if self.bone:
            self.armature = obj
        else:
            self.empty = obj


class Setup:
    """Constrained vertex indices (fixed first, then each handle's block)."""

    def __init__(self, constrained, n_fixed, handles, warnings):
        self.constrained = constrained
        self.n_fixed = n_fixed
        self.handles = handles
        self.warnings = warnings


def check_object(obj):
    if obj is None or obj.type != 'MESH':
        raise SetupError("ARAP works on a mesh object: select one and make it active")
    for what, block in (("object", obj), ("mesh", obj.data)):
        if block.library is not None:
            raise SetupError("The %s '%s' is linked from the library '%s' and cannot be changed: make it local "
                             "(Object > Relations > Make Local) or pose a library override"
                             % (what, block.name, block.library.filepath))
    if obj.mode == 'EDIT':
        raise SetupError("Leave Edit Mode first (Tab): ARAP reads and writes the mesh in Object Mode")
    check_mesh_not_posed_elsewhere(obj)


def check_mesh_not_posed_elsewhere(obj):
    """SetupError when a linked duplicate of `obj` (another object with the same mesh) poses that mesh with
    Auto mode or Live: one mesh has one pose, so only one of them can."""
    session = sessions.session_on_shared_mesh(obj)
    other = auto_poser_of_mesh(obj)
    if session is None and other is None:
        return
    by, owner = ("Live", session.names[0]) if session is not None else ("Auto mode", other.name)
    raise SetupError("'%s' shares its mesh '%s' with '%s', whose %s poses it: stop it there, or make the mesh "
                     "single-user (Object > Relations > Make Single User)" % (obj.name, obj.data.name, owner, by))


def auto_poser_of_mesh(obj):
    """Another object with Auto mode on that uses `obj`'s mesh (a linked duplicate), or None."""
    mesh = obj.data
    if mesh.users < 2:
        return None
    for other in bpy.data.objects:
        if other != obj and other.data == mesh and other.arap.auto:
            return other
    return None


def group_names(obj):
    """The vertex groups a bind reads: the fixed group and the handles' (SetupError when one is missing)."""
    s = obj.arap
    names = [s.fixed_group] if s.fixed_group else []
    names += [h.group for h in s.handles if h.group]
    for name in names:
        if name not in obj.vertex_groups:
            raise SetupError("Vertex group '%s' does not exist on '%s'" % (name, obj.name))
    return names


def gather(obj, scene=None, members=None):
    """Validate obj.arap and return a Setup; raises SetupError. Which vertex
    follows which group is the core's rule (native constraint_set, docs/design.md,
    "Constraints: the rules"): fixed first, fixed wins, the first handle wins.
    `members`: group_names()' groups as meshio.read_groups_in_steps() read them (else read here)."""
    check_object(obj)
    s = obj.arap
    names = group_names(obj)
    if members is None:
        members = meshio.group_members(obj, names)
    for name in names:
        if len(members[name]) == 0:
            raise SetupError("Vertex group '%s' has no vertices (assign some with weight > 0)" % name)
    if not s.fixed_group and len(s.handles) == 0:
        raise SetupError("Nothing holds the mesh: set a fixed vertex group or add a handle")
    for i, h in enumerate(s.handles):
        label = h.group or "#%d" % (i + 1)
        if not h.group:
            raise SetupError("Handle %s has no vertex group" % label)
        drivers.check(h, scene, label)

    # Every group named here has vertices (checked above), so something is always held.
    chosen = native_loader.native().constraint_set(
        len(obj.data.vertices), members[s.fixed_group] if s.fixed_group else None,
        "the fixed group '%s'" % s.fixed_group, [("handle '%s'" % h.group, members[h.group]) for h in s.handles])
    blocks = []
    for index, start, stop in chosen.handles:
        blocks.append(HandleBlock(index, s.handles[index], start, stop))
    return Setup(chosen.constrained, chosen.fixed_count, blocks, list(chosen.warnings))


def handle_of(setup, vertex):
    """The HandleBlock whose vertices include `vertex` (an input index), or None (a fixed vertex, one not
    constrained, -1)."""
    rows = np.flatnonzero(setup.constrained == vertex)
    for h in setup.handles:
        if rows.size and h.start <= rows[0] < h.stop:
            return h
    return None


def stiff_group(obj):
    """The Stiff Group's name, None when none is set; SetupError when it is missing."""
    s = obj.arap
    if not s.stiff_group:
        return None
    if s.stiff_group not in obj.vertex_groups:
        raise SetupError("Stiff group '%s' does not exist on '%s'" % (s.stiff_group, obj.name))
    return s.stiff_group


def stiffness_of(obj, weights=None):
    """Per-vertex stiffness for the solver (None when no Stiff Group is set):
    1 + (Stiffness - 1) * weight in the Stiff Group. Raises SetupError. `weights`: the Stiff Group's, read
    already (meshio.read_groups_in_steps)."""
    name = stiff_group(obj)
    if name is None:
        return None
    if weights is None:
        weights = meshio.group_weights(obj, name)
    return 1.0 + (obj.arap.stiffness - 1.0) * weights


# Farthest a handle may move its vertices, in sizes of the mesh: there float32 coordinates (Blender's) round
# to 1e4 * 2^-24, about 6e-4 of the size, so the posed shape is still there to see; beyond, it is lost.
MAX_REACH = 1e4


def check_reach(setup, rest_constrained, targets, size):
    """SetupError naming the handle and its Empty when `targets` move a vertex farther from its rest place than
    MAX_REACH times the mesh's `size` (an Empty scaled or moved out to float32's end). A NaN target is left to
    the solver, which refuses it."""
    limit = MAX_REACH * max(size, np.finfo(np.float32).tiny)
    reach = np.abs(targets - rest_constrained).max(initial=0.0)
    if reach <= limit:
        return
    for h in setup.handles:
        far = np.abs(targets[h.start:h.stop] - rest_constrained[h.start:h.stop]).max(initial=0.0)
        if far > limit:
            raise SetupError("Handle '%s' would move its vertices %.3g away, more than %d times the mesh's size "
                             "(%.3g): its %s is moved or scaled too far for the pose to be kept. Move or "
                             "scale it back" % (h.group, far, MAX_REACH, size, drivers.describe(h)))


def fill_targets(setup, rest_constrained, transforms, out):
    """Write the (k, 3) float64 targets into `out` (rest rows for fixed vertices)."""
    out[:setup.n_fixed] = rest_constrained[:setup.n_fixed]
    for h, a in zip(setup.handles, transforms):
        block = rest_constrained[h.start:h.stop]
        np.matmul(block, a[:3, :3].T, out=out[h.start:h.stop])
        out[h.start:h.stop] += a[:3, 3]
    return out
