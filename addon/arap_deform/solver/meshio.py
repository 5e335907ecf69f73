# SPDX-License-Identifier: GPL-3.0-or-later
"""Mesh data <-> numpy: coordinates, triangles, vertex groups, the rest shape
and where results are written (the mesh or the "ARAP" shape key).

Rest shape (what ARAP keeps as rigid as possible):
- result in a shape key: the basis (reference) key, never modified here;
- result in the mesh: the "arap_rest" point attribute, captured from the
  current coordinates the first time the tool writes the mesh and again by
  "Set Rest Pose" (deform_job.set_rest_pose()); "Reset to Rest" copies it back.
"""

import time

import bpy
import numpy as np

from ..errors import SetupError

REST_ATTRIBUTE = "arap_rest"
SHAPE_KEY_NAME = "ARAP"


def read_coords(mesh, out=None):
    """Vertex coordinates as a flat float32 array (3n)."""
    n = len(mesh.vertices)
    if out is None:
        out = np.empty(n * 3, np.float32)
    mesh.vertices.foreach_get("co", out)
    return out


def triangles(mesh):
    """Blender's triangulation of all faces (quads and n-gons included): int32 (m, 3). Blender 4.x keeps
    each corner's vertex in the ".corner_vert" attribute, one array read: the triangles' corners mapped
    through it are their vertices, read faster than the triangles' own vertices (about 0.2 against 0.3 s
    at 1M vertices in Blender 5.2)."""
    mesh.calc_loop_triangles()
    tris = np.empty(len(mesh.loop_triangles) * 3, np.int32)
    corner_vert = mesh.attributes.get(".corner_vert")
    if corner_vert is None:
        mesh.loop_triangles.foreach_get("vertices", tris)
        return tris.reshape(-1, 3)
    mesh.loop_triangles.foreach_get("loops", tris)
    corners = np.empty(len(mesh.loops), np.int32)
    corner_vert.data.foreach_get("value", corners)
    return corners[tris].reshape(-1, 3)


def rest_triangles(mesh, rest32):
    """triangles() of the mesh at its rest shape `rest32` (flat float32). Blender splits a quad or an n-gon
    by the current shape (the shorter diagonal), so a mesh that shows a pose would be triangulated otherwise,
    and a pose solved after a bind then would depend on the pose the mesh showed at the bind (a render
    node that opens a file saved posed). When the mesh shows another shape than its rest, a copy at rest is
    triangulated. (Only a mesh with the rest attribute can show a pose in its coordinates: the shape key
    result leaves them at the basis.)"""
    if not has_rest_attribute(mesh) or np.array_equal(read_coords(mesh), rest32):
        return triangles(mesh)
    at_rest = mesh.copy()
    try:
        at_rest.vertices.foreach_set("co", rest32)
        return triangles(at_rest)
    finally:
        bpy.data.meshes.remove(at_rest)


class Topology:
    """The mesh's connectivity when created. counts_match() compares the
    element counts (free); unchanged() also compares each face corner's vertex
    index. Blender 4.x keeps those in the ".corner_vert" attribute, one array
    read; Blender 3.4 has only the loops, whose foreach_get is many times
    slower on large meshes. `cheap`: this mesh's read took at most CHEAP_MS."""

    CHEAP_MS = 2.0   # a full comparison this fast can run while a handle moves

    def __init__(self, mesh):
        self.counts = self._counts(mesh)
        start = time.perf_counter()
        self.corners = self._read_corners(mesh)
        self.cheap = (time.perf_counter() - start) * 1e3 <= self.CHEAP_MS
        self.faces = self._read(mesh.polygons, "loop_total")
        self._corners_now = np.empty_like(self.corners)
        self._faces_now = np.empty_like(self.faces)

    @staticmethod
    def _counts(mesh):
        return len(mesh.vertices), len(mesh.edges), len(mesh.loops), len(mesh.polygons)

    @staticmethod
    def _read(collection, attribute, out=None):
        if out is None:
            out = np.empty(len(collection), np.int32)
        collection.foreach_get(attribute, out)
        return out

    @classmethod
    def _read_corners(cls, mesh, out=None):
        corner_vert = mesh.attributes.get(".corner_vert")
        if corner_vert is None:
            return cls._read(mesh.loops, "vertex_index", out)
        if out is None:
            out = np.empty(len(mesh.loops), np.int32)
        corner_vert.data.foreach_get("value", out)
        return out

    def counts_match(self, mesh):
        return self._counts(mesh) == self.counts

    def unchanged(self, mesh, corners_only=False):
        """Same counts and corners; and, unless `corners_only`, the same face sizes (a second read
        as slow as the loops' on every Blender)."""
        if not self.counts_match(mesh):
            return False
        if not np.array_equal(self._read_corners(mesh, self._corners_now), self.corners):
            return False
        return corners_only or np.array_equal(self._read(mesh.polygons, "loop_total", self._faces_now), self.faces)


GROUP_CHUNK = 100_000   # vertices read per step by read_groups_in_steps (about 0.1 s of Blender's thread)


def read_groups_in_steps(obj, names, weights_of=(), chunk=None):
    """Generator: reads the vertex groups `names` (and the weights of the groups `weights_of`) over the
    vertices, `chunk` at a time (default GROUP_CHUNK), and yields between chunks, so that Blender's thread can
    go on in between (Blender has no array read of vertex groups: each vertex is a Python object). Returns, as
    the generator's value, ({group name: sorted int64 indices of vertices with weight > 0}, float64
    (n, len(weights_of)) weights of the groups `weights_of`, 0 outside a group and for a missing group)."""
    chunk = chunk or GROUP_CHUNK
    groups = obj.vertex_groups
    index_of = {groups[name].index: name for name in names if name in groups}
    column_of = {groups[name].index: k for k, name in enumerate(weights_of) if name in groups}
    members = {name: [] for name in index_of.values()}
    weights = np.zeros((len(obj.data.vertices), len(weights_of)), np.float64)
    vertices = obj.data.vertices
    if index_of or column_of:
        for start in range(0, len(vertices), chunk):
            if start:
                yield   # between chunks: a mesh of one chunk is read in one go
            for v in vertices[start:start + chunk]:
                for g in v.groups:
                    column = column_of.get(g.group)
                    if column is not None:
                        weights[v.index, column] = g.weight
                    name = index_of.get(g.group)
                    if name is not None and g.weight > 0.0:
                        members[name].append(v.index)
    return {name: np.asarray(idx, np.int64) for name, idx in members.items()}, weights


def finish(steps):
    """Run a generator of steps (read_groups_in_steps, problem.Problem.read_in_steps) to its end, here: its
    value."""
    while True:
        try:
            next(steps)
        except StopIteration as done:
            return done.value


def group_weights(obj, name):
    """Per-vertex weight (float64, 0 outside) of vertex group `name`."""
    return finish(read_groups_in_steps(obj, [], weights_of=[name]))[1][:, 0]


def group_members(obj, names):
    """{group name: sorted int64 indices of vertices with weight > 0}."""
    return finish(read_groups_in_steps(obj, names))[0]


def resolve_output(obj, output):
    """'AUTO' -> 'SHAPE_KEY' when the mesh has shape keys, else 'MESH'."""
    if output == 'AUTO':
        return 'SHAPE_KEY' if obj.data.shape_keys is not None else 'MESH'
    return output


def rest_coords(obj, output):
    """Flat float32 rest shape for the resolved output mode."""
    mesh = obj.data
    if output == 'SHAPE_KEY' and mesh.shape_keys is not None:
        out = np.empty(len(mesh.vertices) * 3, np.float32)
        mesh.shape_keys.reference_key.data.foreach_get("co", out)
        return out
    attr = mesh.attributes.get(REST_ATTRIBUTE)
    if output == 'MESH' and attr is not None and attr.domain == 'POINT' and attr.data_type == 'FLOAT_VECTOR':
        out = np.empty(len(mesh.vertices) * 3, np.float32)
        attr.data.foreach_get("vector", out)
        return out
    return read_coords(mesh)


def has_rest_attribute(mesh):
    return mesh.attributes.get(REST_ATTRIBUTE) is not None


def store_rest(mesh, flat):
    """Keep `flat` (float32, 3n) as the mesh's rest shape attribute."""
    attr = mesh.attributes.get(REST_ATTRIBUTE)
    if attr is None:
        attr = mesh.attributes.new(REST_ATTRIBUTE, 'FLOAT_VECTOR', 'POINT')
    attr.data.foreach_set("vector", flat)


class Output:
    """Writes flat float32 coordinates into the mesh or the ARAP shape key."""

    def __init__(self, obj, mode):
        self.obj = obj
        self.mode = mode

    def ensure(self):
        """Create the Basis and ARAP keys when writing to a shape key."""
        if self.mode != 'SHAPE_KEY':
            return
        obj = self.obj
        if obj.data.shape_keys is None:
            obj.shape_key_add(name="Basis", from_mix=False)
        key = obj.data.shape_keys.key_blocks.get(SHAPE_KEY_NAME)
        if key is None:
            key = obj.shape_key_add(name=SHAPE_KEY_NAME, from_mix=False)
        key.value = 1.0

    def write(self, flat):
        mesh = self.obj.data
        if self.mode == 'SHAPE_KEY':
            keys = mesh.shape_keys
            key = keys.key_blocks.get(SHAPE_KEY_NAME) if keys is not None else None
            if key is None:
                raise SetupError("The shape key '%s' of '%s' was removed while it was being posed"
                                 % (SHAPE_KEY_NAME, self.obj.name))
            key.data.foreach_set("co", flat)
        else:
            mesh.vertices.foreach_set("co", flat)
        mesh.update()
        self.obj.update_tag(refresh={'DATA'})


class TransformSnapshot:
    """The transform channels of objects (the handle Empties and armatures, with an armature's bones), to
    put them back bit for bit: the values are copied, not a matrix recomposed."""

    CHANNELS = ("location", "rotation_mode", "rotation_euler", "rotation_quaternion", "rotation_axis_angle",
                "scale", "delta_location", "delta_rotation_euler", "delta_rotation_quaternion", "delta_scale")

    BONE_CHANNELS = ("location", "rotation_mode", "rotation_euler", "rotation_quaternion", "rotation_axis_angle",
                     "scale")

    def __init__(self, objects):
        objects = list({ob.name: ob for ob in objects}.values())   # an armature of several bone handles once
        self.names = [ob.name for ob in objects]
        self.values = [{c: _copy_channel(getattr(ob, c)) for c in self.CHANNELS} for ob in objects]
        # An armature's pose too (bone handles): its bones' channels.
        self.bones = [{b.name: {c: _copy_channel(getattr(b, c)) for c in self.BONE_CHANNELS}
                       for b in ob.pose.bones} if ob.type == 'ARMATURE' and ob.pose is not None else {}
                      for ob in objects]

    def restore(self, objects_by_name):
        """Put the channels back on the objects of that name still there (and on their bones)."""
        for name, values, bones in zip(self.names, self.values, self.bones):
            ob = objects_by_name.get(name)
            if ob is not None:
                for channel, value in values.items():
                    setattr(ob, channel, value)
                for bone_name, channels in bones.items():
                    bone = ob.pose.bones.get(bone_name) if ob.pose is not None else None
                    for channel, value in channels.items() if bone is not None else ():
                        setattr(bone, channel, value)


def _copy_channel(value):
    return value if isinstance(value, str) else tuple(value)


class Snapshot:
    """Exact copy of what Live and the bake's preview change, to restore bit for bit."""

    def __init__(self, obj):
        mesh = obj.data
        self.obj = obj
        self.coords = read_coords(mesh)
        self.had_keys = mesh.shape_keys is not None
        self.key_coords = None
        self.key_value = None
        self.had_rest = has_rest_attribute(mesh)
        if self.had_keys:
            key = mesh.shape_keys.key_blocks.get(SHAPE_KEY_NAME)
            if key is not None:
                self.key_coords = np.empty(len(mesh.vertices) * 3, np.float32)
                key.data.foreach_get("co", self.key_coords)
                self.key_value = key.value

    def restore(self):
        obj = self.obj
        mesh = obj.data
        if len(mesh.vertices) * 3 != len(self.coords):
            raise ValueError("the mesh's vertex count changed: cannot restore the snapshot")
        keys = mesh.shape_keys
        if keys is not None:
            key = keys.key_blocks.get(SHAPE_KEY_NAME)
            if not self.had_keys:
                obj.shape_key_clear()
            elif key is not None and self.key_coords is None:
                obj.shape_key_remove(key)
            elif key is not None:
                key.data.foreach_set("co", self.key_coords)
                key.value = self.key_value
        if not self.had_rest and has_rest_attribute(mesh):
            mesh.attributes.remove(mesh.attributes[REST_ATTRIBUTE])
        mesh.vertices.foreach_set("co", self.coords)
        mesh.update()
        obj.update_tag(refresh={'DATA'})
