# SPDX-License-Identifier: GPL-3.0-or-later
"""Read an object's ARAP settings into index arrays, check them, and turn
empty matrices into target positions.

Constraint semantics (object-local coordinates, homogeneous 4x4 matrices):
    target_local = M_obj^-1 @ M_empty_now @ M_empty_bind^-1 @ M_obj @ rest_local
Fixed vertices keep their rest position. A vertex in the fixed group and in
a handle stays fixed; a vertex in two handles follows the first one.
"""

import numpy as np

from . import meshio


class SetupError(Exception):
    """A set-up the user must change (message says what)."""


def matrix_to_numpy(m):
    """mathutils.Matrix 4x4 -> float64 (4, 4) (rows are rows)."""
    return np.array([tuple(row) for row in m], np.float64)


def bind_matrix_of(handle):
    return np.asarray(handle.bind_matrix, np.float64).reshape(4, 4)


def capture_bind(handle):
    """Store the empty's current world matrix as the handle's bind pose."""
    handle.bind_matrix = matrix_to_numpy(handle.empty.matrix_world).ravel().tolist()
    handle.has_bind = True


def empty_is_alive(empty, scene):
    """False for a deleted empty (pointer cleared, or removed from the scene)."""
    if empty is None:
        return False
    try:
        name = empty.name
    except ReferenceError:
        return False
    return scene is None or scene.objects.get(name) == empty


class HandleBlock:
    """Rows [start, stop) of the constrained list follow `empty`."""

    def __init__(self, index, group, empty, start, stop, bind):
        self.index = index      # position in settings.handles
        self.group = group
        self.empty = empty
        self.start = start
        self.stop = stop
        self.bind_inv = np.linalg.inv(bind)


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
    if obj.mode == 'EDIT':
        raise SetupError("Leave Edit Mode first (Tab): ARAP reads and writes the mesh in Object Mode")


def gather(obj, scene=None):
    """Validate obj.arap and return a Setup; raises SetupError."""
    check_object(obj)
    s = obj.arap
    names = [s.fixed_group] if s.fixed_group else []
    names += [h.group for h in s.handles if h.group]
    for name in names:
        if name not in obj.vertex_groups:
            raise SetupError("Vertex group '%s' does not exist on '%s'" % (name, obj.name))
    members = meshio.group_members(obj, names)
    for name in names:
        if len(members[name]) == 0:
            raise SetupError("Vertex group '%s' has no vertices (assign some with weight > 0)" % name)
    if not s.fixed_group and len(s.handles) == 0:
        raise SetupError("Nothing holds the mesh: set a fixed vertex group or add a handle")

    warnings = []
    taken = np.zeros(len(obj.data.vertices), bool)
    blocks = []
    if s.fixed_group:
        fixed = members[s.fixed_group]
        taken[fixed] = True
        blocks.append(fixed)
    n_fixed = sum(len(b) for b in blocks)

    handles = []
    start = n_fixed
    for i, h in enumerate(s.handles):
        label = h.group or "#%d" % (i + 1)
        if not h.group:
            raise SetupError("Handle %s has no vertex group" % label)
        if h.empty is None:
            raise SetupError("Handle '%s' has no empty (never set, or deleted): pick one in the handle list" % label)
        if not empty_is_alive(h.empty, scene):
            raise SetupError("The empty of handle '%s' was deleted: pick another one" % label)
        idx = members[h.group]
        overlap = taken[idx]
        if overlap.any():
            what = "the fixed group '%s'" % s.fixed_group if s.fixed_group else "another handle"
            warnings.append("Handle '%s': %d of its vertices are also in %s and do not follow it"
                            % (label, int(overlap.sum()), what))
            idx = idx[~overlap]
        if len(idx) == 0:
            warnings.append("Handle '%s' has no vertices of its own: ignored" % label)
            continue
        taken[idx] = True
        bind = bind_matrix_of(h) if h.has_bind else matrix_to_numpy(h.empty.matrix_world)
        handles.append(HandleBlock(i, h.group, h.empty, start, start + len(idx), bind))
        blocks.append(idx)
        start += len(idx)
    if not blocks:
        raise SetupError("No vertex is constrained: every handle's vertices are taken by the fixed group")
    constrained = np.concatenate(blocks).astype(np.int64)
    return Setup(constrained, n_fixed, handles, warnings)


def stiffness_of(obj):
    """Per-vertex stiffness for the solver (None when no Stiff Group is set):
    1 + (Stiffness - 1) * weight in the Stiff Group. Raises SetupError."""
    s = obj.arap
    if not s.stiff_group:
        return None
    if s.stiff_group not in obj.vertex_groups:
        raise SetupError("Stiff group '%s' does not exist on '%s'" % (s.stiff_group, obj.name))
    return 1.0 + (s.stiffness - 1.0) * meshio.group_weights(obj, s.stiff_group)


def collapsed_handles(setup, empty_matrices, ratio=1e-6):
    """Groups of the handles whose Empty's volume scale since the bind pose,
    |det(M_now) / det(M_bind)|, is below `ratio`."""
    names = []
    for h, m_now in zip(setup.handles, empty_matrices):
        if abs(np.linalg.det(m_now[:3, :3]) * np.linalg.det(h.bind_inv[:3, :3])) < ratio:
            names.append(h.group)
    return names


def handle_transforms(setup, obj_matrix, empty_matrices):
    """Per handle: the object-local 4x4 map M_obj^-1 @ M_now @ M_bind^-1 @ M_obj."""
    obj_inv = np.linalg.inv(obj_matrix)
    return [obj_inv @ m_now @ h.bind_inv @ obj_matrix for h, m_now in zip(setup.handles, empty_matrices)]


def fill_targets(setup, rest_constrained, transforms, out):
    """Write the (k, 3) float64 targets into `out` (rest rows for fixed vertices)."""
    out[:setup.n_fixed] = rest_constrained[:setup.n_fixed]
    for h, a in zip(setup.handles, transforms):
        block = rest_constrained[h.start:h.stop]
        np.matmul(block, a[:3, :3].T, out=out[h.start:h.stop])
        out[h.start:h.stop] += a[:3, 3]
    return out
