# SPDX-License-Identifier: GPL-3.0-or-later
"""A handle's target transform, one function per rule: the bind pose taken
from its Empty, that pose inverted, the object-local map of the Empty's move
since then and the test for an Empty scaled to (almost) nothing.

Object-local coordinates, homogeneous 4x4 matrices:
    target_local = M_obj^-1 @ M_empty_now @ M_empty_bind^-1 @ M_obj @ rest_local
"""

import numpy as np

from ..errors import SetupError


def matrix_to_numpy(m):
    """mathutils.Matrix 4x4 -> float64 (4, 4) (rows are rows)."""
    return np.array([tuple(row) for row in m], np.float64)


def capture_bind(handle, matrix):
    """Store `matrix` (drivers.bind_matrix_now(), or a bone's rest matrix) as the handle's bind pose."""
    handle.bind_matrix = np.asarray(matrix, np.float64).ravel().tolist()
    handle.has_bind = True


def bind_matrix(handle, now):
    """The handle's bind pose: the one stored, or `now` (a callable giving the matrix a bind would take now)
    when none was taken."""
    if handle.has_bind:
        return np.asarray(handle.bind_matrix, np.float64).reshape(4, 4)
    return now(handle)


def invert(matrix, what):
    """The inverse of a 4x4 transform; SetupError naming `what` when it has
    (near) zero scale and so no usable inverse."""
    try:
        inverse = np.linalg.inv(matrix)
    except np.linalg.LinAlgError:
        inverse = None
    if inverse is None or not np.all(np.isfinite(inverse)):
        raise SetupError("%s has zero scale, so its transform cannot be inverted: give it a non-zero scale" % what)
    return inverse


def bind_inverse(bind, group, empty_name):
    """M_empty_bind^-1 of handle `group`; SetupError when its bind pose has zero scale."""
    return invert(bind, "The bind pose of handle '%s' (its empty '%s' when the pose was taken; "
                        "press Reset to Rest after fixing it)" % (group, empty_name))


def target_transform(obj_matrix, obj_inverse, empty_matrix, bind_inv):
    """The object-local 4x4 map of a handle's vertices: M_obj^-1 @ M_empty_now @ M_empty_bind^-1 @ M_obj."""
    return obj_inverse @ empty_matrix @ bind_inv @ obj_matrix


def target_transforms(obj_matrix, empty_matrices, bind_inverses, obj_name="the posed object"):
    """target_transform() of each handle; SetupError when the object has zero scale."""
    obj_inverse = invert(obj_matrix, "'%s'" % obj_name)
    return [target_transform(obj_matrix, obj_inverse, m_now, bind_inv)
            for m_now, bind_inv in zip(empty_matrices, bind_inverses)]


def collapsed(empty_matrix, bind_inv, ratio=1e-6):
    """The Empty's volume scale since its bind pose, |det(M_now) / det(M_bind)|, is below `ratio`: the
    handle's vertices collapse to a point."""
    return abs(np.linalg.det(empty_matrix[:3, :3]) * np.linalg.det(bind_inv[:3, :3])) < ratio
