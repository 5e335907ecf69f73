# SPDX-License-Identifier: GPL-3.0-or-later
"""The start shape of a mesh posed by bone handles: its rig's own pose,
skinned with its own weights by dual quaternions (what Blender's Armature
modifier gives with Preserve Volume).

ARAP is solved by descent from a start: from the rest shape, a joint twisted
by half a turn has two ways to go and lands in the pinched one (the linear
blend's "candy wrapper"). Started from the dual quaternion skin, which turns
the joint's vertices part of the way with each bone, it settles in the
twisted shape the rig asks for, in fewer iterations. The start depends on
the frame's bone transforms alone, so a frame's pose still depends on the
frame alone.

Blending (Kavan et al. 2007): each bone's object-local transform (rotation
R, translation t) as a unit dual quaternion q = q_r + e q_d with
q_d = 1/2 (0, t) q_r; per vertex, the weighted sum of the bones' dual
quaternions, each sign-flipped into the hemisphere of the vertex's heaviest
bone, normalised by |sum of q_r|; the vertex moves by that rigid transform.
"""

import numpy as np

from . import drivers, rig


def rotation_quaternion(r):
    """Unit quaternion (w, x, y, z) of a 3x3 matrix's nearest rotation (its polar factor, so a bone scaled
    since its bind still gives a rotation)."""
    u, _s, vt = np.linalg.svd(r)
    m = u @ vt
    if np.linalg.det(m) < 0:
        m = u @ np.diag([1.0, 1.0, -1.0]) @ vt
    # Shepperd's method: the largest of the four squared components first, for accuracy.
    trace = np.trace(m)
    squares = np.array([1 + trace, 1 + 2 * m[0, 0] - trace, 1 + 2 * m[1, 1] - trace, 1 + 2 * m[2, 2] - trace])
    k = int(np.argmax(squares))
    q = np.empty(4)
    q[k] = 0.5 * np.sqrt(squares[k])
    f = 0.25 / q[k]
    if k == 0:
        q[1], q[2], q[3] = (m[2, 1] - m[1, 2]) * f, (m[0, 2] - m[2, 0]) * f, (m[1, 0] - m[0, 1]) * f
    elif k == 1:
        q[0], q[2], q[3] = (m[2, 1] - m[1, 2]) * f, (m[0, 1] + m[1, 0]) * f, (m[0, 2] + m[2, 0]) * f
    elif k == 2:
        q[0], q[1], q[3] = (m[0, 2] - m[2, 0]) * f, (m[0, 1] + m[1, 0]) * f, (m[1, 2] + m[2, 1]) * f
    else:
        q[0], q[1], q[2] = (m[1, 0] - m[0, 1]) * f, (m[0, 2] + m[2, 0]) * f, (m[1, 2] + m[2, 1]) * f
    return q


def multiply(a, b):
    """Quaternion products a b, rows (w, x, y, z); a and b broadcast."""
    aw, av = a[..., :1], a[..., 1:]
    bw, bv = b[..., :1], b[..., 1:]
    w = aw * bw - np.sum(av * bv, axis=-1, keepdims=True)
    v = aw * bv + bw * av + np.cross(av, bv)
    return np.concatenate([w, v], axis=-1)


def dual_quaternion(transform):
    """(q_r, q_d) of a 4x4 rigid transform."""
    q_r = rotation_quaternion(transform[:3, :3])
    t = np.concatenate([[0.0], transform[:3, 3]])
    return q_r, 0.5 * multiply(t, q_r)


def blend(rest, weights, transforms):
    """Dual quaternion skinning of `rest` ((n, 3) float64) by `weights` ((n, k), rows summing to 1 or 0) and
    the k 4x4 `transforms`; vertices with no weight keep their rest place."""
    duals = [dual_quaternion(t) for t in transforms]
    q_r = np.array([d[0] for d in duals])
    q_d = np.array([d[1] for d in duals])
    heaviest = np.argmax(weights, axis=1)
    signs = np.where(q_r @ q_r.T < 0, -1.0, 1.0)[heaviest]          # (n, k): into each vertex's hemisphere
    signed = weights * signs
    real, dual = signed @ q_r, signed @ q_d
    norm = np.linalg.norm(real, axis=1, keepdims=True)
    weighted = norm[:, 0] > 1e-12
    real = np.divide(real, norm, out=np.zeros_like(real), where=norm > 1e-12)
    dual = np.divide(dual, norm, out=np.zeros_like(dual), where=norm > 1e-12)
    w, v = real[:, :1], real[:, 1:]
    dw, dv = dual[:, :1], dual[:, 1:]
    rotated = rest + 2 * np.cross(v, np.cross(v, rest) + w * rest)
    translation = 2 * (w * dv - dw * v + np.cross(v, dv))
    out = rest.copy()
    out[weighted] = rotated[weighted] + translation[weighted]
    return out


def skin_bones(obj):
    """The bones whose weights a SkinnedStart of `obj` reads: its bone handles' bones."""
    return [h.bone for h in obj.arap.handles if h.bone]


class SkinnedStart:
    """The start shape of a Problem whose handles include bones: blend() of the rest shape by the weights of
    the vertex groups named after those bones (normalised as the Armature modifier normalises them) and the
    bone handles' transforms."""

    def __init__(self, obj, setup, rest64, skin=None):
        self.handles = [k for k, h in enumerate(setup.handles) if drivers.is_bone(h)]
        bones = [setup.handles[k].bone for k in self.handles]
        if skin is not None:   # read already: (bone names, their weights' columns)
            names, columns = skin
            weights = columns[:, [names.index(b) for b in bones]]
        else:
            weights = rig.bone_weights(obj, bones)
        total = weights.sum(axis=1, keepdims=True)
        self.weights = np.divide(weights, total, out=np.zeros_like(weights), where=total > 0)
        self.rest = rest64

    @classmethod
    def of(cls, obj, setup, rest64, skin=None):
        """A SkinnedStart when some handle follows a bone whose vertex group weights a vertex, else None.
        `skin`: (bone names, (n, k) weights) as skin_bones() named them, read already (Problem.read_in_steps)."""
        if not any(drivers.is_bone(h) for h in setup.handles):
            return None
        start = cls(obj, setup, rest64, skin)
        return start if start.weights.any() else None

    def positions(self, transforms):
        """(n, 3) float64 start shape for the handles' object-local `transforms` (HandlePose.transforms)."""
        return blend(self.rest, self.weights, [transforms[k] for k in self.handles])
