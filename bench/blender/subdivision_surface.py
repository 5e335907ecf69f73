"""A mesh after Blender's Subdivision Surface modifier (Catmull-Clark, level 1, the modifier's defaults) is applied,
for bench/native/resolution.py's --subsurf check.

    blender --background --factory-startup --python bench/blender/subdivision_surface.py -- IN.json OUT.json

IN.json: {"vertices": [[x, y, z], ...], "faces": [[i, j, k], ...], "groups": [[vertex index, ...], ...]}.
OUT.json: the same keys for the evaluated mesh. A vertex is in a group when its interpolated weight is 1: an original
vertex keeps its membership, a new one joins when every vertex it is made from is in the group. Blender lists the
original vertices first (their positions moved by the smoothing); the script checks that they come first.
"""

import json
import sys

import bpy
import numpy as np


def subdivided(data):
    mesh = bpy.data.meshes.new("base")
    mesh.from_pydata([tuple(v) for v in data["vertices"]], [], [tuple(f) for f in data["faces"]])
    mesh.update()
    obj = bpy.data.objects.new("base", mesh)
    bpy.context.scene.collection.objects.link(obj)
    for k, members in enumerate(data["groups"]):
        obj.vertex_groups.new(name="group%d" % k).add([int(i) for i in members], 1.0, "REPLACE")
    modifier = obj.modifiers.new("subsurf", "SUBSURF")
    modifier.levels = modifier.render_levels = 1
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    result = evaluated.to_mesh()
    vertices = np.empty(len(result.vertices) * 3)
    result.vertices.foreach_get("co", vertices)
    groups = [[] for _ in data["groups"]]
    for v in result.vertices:
        for g in v.groups:
            if g.weight > 1.0 - 1e-6:
                groups[g.group].append(v.index)
    faces = [list(p.vertices) for p in result.polygons]
    evaluated.to_mesh_clear()
    return vertices.reshape(-1, 3), faces, groups


def main():
    source, target = sys.argv[sys.argv.index("--") + 1:][:2]
    with open(source) as f:
        data = json.load(f)
    vertices, faces, groups = subdivided(data)
    base = np.array(data["vertices"], dtype=float)
    diagonal = np.linalg.norm(base.max(axis=0) - base.min(axis=0))
    moved = np.linalg.norm(vertices[:len(base)] - base, axis=1).max() / diagonal
    if moved > 0.05:
        sys.exit("subdivision_surface.py: the first vertices are not the original ones (moved %.3f of the diagonal)"
                 % moved)
    with open(target, "w") as f:
        json.dump({"vertices": vertices.tolist(), "faces": faces, "groups": groups, "rest_moved": moved}, f)


main()
