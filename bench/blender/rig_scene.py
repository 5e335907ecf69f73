# SPDX-License-Identifier: GPL-3.0-or-later
"""Rigged scenes of the Blender-side deformer comparison (rig_compare.py): a mesh skinned to a chain of bones
by an Armature modifier, with smooth procedural weights, and the poses the comparison applies.

    import rig_scene as R
    mesh, rig = R.capped_tube_rig(vertices=10000, bones=3)    # closed tube along +Z, 3 bones
    mesh, rig = R.scenario_rig("meshes/armadillo_1k.off")     # an .off mesh, 2 bones along its principal axis
    R.pose(rig, "twist", 180)                                 # the last bone about its own axis
    R.pose(rig, "bend", 120)                                  # the middle joint's child bone about its local X

Weights: the mesh's height h along the chain (0 at the first bone's head, the chain's length at the last
tail) is owned fully by one bone inside its middle; around each joint, over +-JOINT_ZONE of a bone's length,
the two bones meet by a smoothstep (0.5 each at the joint). The weights sum to 1 everywhere. Each bone's
vertex group is named after the bone.
"""

import math
import os
import sys

import bpy
import numpy as np
from mathutils import Quaternion, Vector

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)   # bench_addon (and through it the Blender tests' helpers, volume_table's folder)
import bench_addon as U  # noqa: E402

sys.path.insert(0, U.BENCH_NATIVE)
from arap_test_utils import add_armature, smooth_bone_weights  # noqa: E402
from volume_table import read_off  # noqa: E402

JOINT_ZONE = 0.25     # half-width of a joint's blend, in bone lengths
POSE_KINDS = ("twist", "bend")


def bone_names(count):
    """The chain's bone names, root first."""
    return ["Bone%d" % i for i in range(count)]


def chain_weights(h, length, bones):
    """(n, bones) weights of heights `h` along a chain of `bones` equal bones spanning [0, length]
    (arap_test_utils.smooth_bone_weights at the joints, JOINT_ZONE of a bone on each side)."""
    bone = length / bones
    return smooth_bone_weights(h, [j * bone for j in range(1, bones)], JOINT_ZONE * bone)


def mesh_object(name, vertices, faces):
    """A new mesh object linked to the scene, from vertex coordinates and polygons (vertex index lists)."""
    me = bpy.data.meshes.new(name)
    me.from_pydata([tuple(map(float, v)) for v in vertices], [], [tuple(int(i) for i in f) for f in faces])
    me.update(calc_edges=True)
    obj = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def capped_tube(vertices, radius, height):
    """(vertices, faces) of a closed tube along +Z from 0 to `height`: s segments, r + 1 rings of outward
    quads, ~`vertices` in all with near-square cells, each end closed by a triangle fan to a centre vertex."""
    s = max(8, int(round(math.sqrt(vertices * 2 * math.pi * radius / height))))
    r = max(2, int(round((vertices - 2) / s)) - 1)
    t = np.linspace(0, 2 * math.pi, s, endpoint=False)
    z = np.linspace(0, height, r + 1)
    co = np.empty((r + 1, s, 3))
    co[..., 0] = radius * np.cos(t)[None, :]
    co[..., 1] = radius * np.sin(t)[None, :]
    co[..., 2] = z[:, None]
    co = np.concatenate([co.reshape(-1, 3), [[0.0, 0.0, 0.0], [0.0, 0.0, height]]])
    bottom, top = s * (r + 1), s * (r + 1) + 1
    faces = []
    for i in range(r):
        for j in range(s):
            a, b = i * s + j, i * s + (j + 1) % s
            faces.append((a, b, b + s, a + s))
    for j in range(s):
        faces.append((bottom, (j + 1) % s, j))                           # facing -Z
        faces.append((top, r * s + j, r * s + (j + 1) % s))              # facing +Z
    return co, faces


def bone_chain(name, start, end, bones):
    """An armature object at the origin with `bones` connected bones from `start` to `end` (roll 0)."""
    start, end = Vector(start), Vector(end)
    names = bone_names(bones)
    specs = [(names[i], start.lerp(end, i / bones), start.lerp(end, (i + 1) / bones), names[i - 1] if i else None)
             for i in range(bones)]
    rig = add_armature(name, specs)
    bpy.ops.object.mode_set(mode='EDIT')
    for bone in rig.data.edit_bones[1:]:
        bone.use_connect = True
    bpy.ops.object.mode_set(mode='OBJECT')
    return rig


def skin(obj, rig, heights, length, bones):
    """Vertex groups of the chain's smooth weights at `heights`, an Armature modifier on `rig` (linear blend,
    vertex groups only) and `rig` as the object's parent."""
    weights = chain_weights(np.asarray(heights, np.float64), length, bones)
    for k, name in enumerate(bone_names(bones)):
        group = obj.vertex_groups.new(name=name)
        for w in sorted(set(np.round(weights[:, k], 6)) - {0.0}):
            group.add([int(i) for i in np.nonzero(np.round(weights[:, k], 6) == w)[0]], float(w), 'REPLACE')
    mod = obj.modifiers.new("Armature", 'ARMATURE')
    mod.object = rig
    mod.use_vertex_groups = True
    mod.use_bone_envelopes = False
    mod.use_deform_preserve_volume = False
    obj.parent = rig
    bpy.context.view_layer.update()
    return mod


def capped_tube_rig(vertices=10000, bones=3, radius=0.5, height=6.0):
    """The closed tube (capped_tube) with a chain of `bones` bones along Z from 0 to `height`, skinned by
    its height. Returns (mesh_obj, armature_obj)."""
    co, faces = capped_tube(vertices, radius, height)
    obj = mesh_object("Tube", co, faces)
    rig = bone_chain("TubeRig", (0.0, 0.0, 0.0), (0.0, 0.0, height), bones)
    skin(obj, rig, co[:, 2], height, bones)
    return obj, rig


def principal_axis(points):
    """Unit direction of largest variance of (n, 3) centred points (the sign made deterministic: its largest
    component positive)."""
    _values, vectors = np.linalg.eigh(points.T @ points)
    axis = vectors[:, 2]
    return axis if axis[np.argmax(np.abs(axis))] > 0 else -axis


def scenario_rig(off_path, bones=2):
    """The mesh of an .off file, centred on its vertices' mean, with a chain of `bones` bones along its
    principal axis across the vertices' extent, skinned by each vertex's projection on that axis.
    Returns (mesh_obj, armature_obj)."""
    vertices, faces = read_off(off_path)
    co = np.asarray(vertices, np.float64)
    co -= co.mean(axis=0)
    axis = principal_axis(co)
    t = co @ axis
    name = os.path.splitext(os.path.basename(off_path))[0]
    obj = mesh_object(name, co, faces)
    rig = bone_chain(name + "Rig", t.min() * axis, t.max() * axis, bones)
    skin(obj, rig, t - t.min(), t.max() - t.min(), bones)
    return obj, rig


def rest(rig):
    """Every pose bone back to its rest pose."""
    for pb in rig.pose.bones:
        pb.rotation_mode = 'QUATERNION'
        pb.rotation_quaternion = (1.0, 0.0, 0.0, 0.0)
        pb.location = (0.0, 0.0, 0.0)
        pb.scale = (1.0, 1.0, 1.0)


def pose(rig, kind, angle_deg):
    """Put the chain in one pose, from rest: 'twist' turns the last bone about its own axis (bone-space Y)
    by `angle_deg`; 'bend' turns the middle joint's child bone (bone bones // 2: the second of two, the
    second of three) about its local X. The depsgraph is updated by the caller (frame_set / update)."""
    if kind not in POSE_KINDS:
        raise ValueError("pose kind %r is not one of %s" % (kind, POSE_KINDS))
    rest(rig)
    names = bone_names(len(rig.pose.bones))
    if kind == "twist":
        pb, axis = rig.pose.bones[names[-1]], (0.0, 1.0, 0.0)
    else:
        pb, axis = rig.pose.bones[names[len(names) // 2]], (1.0, 0.0, 0.0)
    pb.rotation_quaternion = Quaternion(axis, math.radians(angle_deg))
    return pb
