"""The picture of docs/contact.md and the README: one bent bar posed by surface
ARAP and with Self Contact, side by side, rendered headlessly by Blender; the
triangles that pass through the surface are drawn red.

    blender --background --factory-startup --python bench/blender/render_contact.py -- \\
        build/results/contact bar1_x2 docs/contact_bar1.png

Reads CASE_none_none.off (surface only) and CASE_none_self.off (Self Contact)
from the folder that bench/native/contact_table.py wrote, and finds the
crossing triangles with arap-mesh-measure (ARAP_BUILD, default build/).
"""

import json
import os
import subprocess
import sys

import bpy
from mathutils import Vector

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [HERE, os.path.join(HERE, "..", "native")]   # render_volume; volume_table (its mesh reader)
from render_volume import render  # noqa: E402
from volume_table import read_off  # noqa: E402

RUNS = (("none", "Surface only"), ("self", "Self Contact"))
SKIN = (0.80, 0.62, 0.48, 1.0)
CROSSING = (0.90, 0.10, 0.10, 1.0)


def crossing_triangles(build, rest, posed):
    found = subprocess.run([os.path.join(build, "arap-mesh-measure"), rest, posed, "--list-intersections"],
                           capture_output=True, text=True, check=True)
    pairs = json.loads(found.stdout)["intersecting_pairs"]
    return {t for pair in pairs for t in pair}


def material(name, colour):
    m = bpy.data.materials.new(name)
    m.diffuse_color = colour
    return m


def main():
    argv = sys.argv[sys.argv.index("--") + 1:]
    if len(argv) != 3:
        raise SystemExit(__doc__)
    folder, case, out = argv
    build = os.environ.get("ARAP_BUILD", "build")
    with open(os.path.join(folder, case + ".json")) as f:
        rest = json.load(f)["mesh"]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    skin, crossing = material("skin", SKIN), material("crossing", CROSSING)
    meshes = []
    for contact, label in RUNS:
        path = os.path.join(folder, "%s_none_%s.off" % (case, contact))
        meshes.append((contact, label, read_off(path), crossing_triangles(build, rest, path)))
    lo = [min(v[i] for _c, _l, (vs, _f), _x in meshes for v in vs) for i in range(3)]
    hi = [max(v[i] for _c, _l, (vs, _f), _x in meshes for v in vs) for i in range(3)]
    # Side by side along x, seen from above the bend's plane (x, y).
    step = 1.15 * (hi[0] - lo[0])
    for k, (contact, label, (vertices, faces), crossed) in enumerate(meshes):
        mesh = bpy.data.meshes.new(contact)
        mesh.from_pydata(vertices, [], faces)
        mesh.materials.append(skin)
        mesh.materials.append(crossing)
        # The measure lists fan triangles; the meshes here are triangles already (one per face).
        for polygon in mesh.polygons:
            polygon.material_index = 1 if polygon.index in crossed else 0
        obj = bpy.data.objects.new(contact, mesh)
        obj.location = (k * step, 0.0, 0.0)
        scene.collection.objects.link(obj)
        text = bpy.data.curves.new(contact + "_label", 'FONT')
        text.body = "%s  (%d crossing triangles)" % (label, len(crossed))
        text.size = 0.06 * (hi[0] - lo[0])
        text.align_x = 'CENTER'
        text_obj = bpy.data.objects.new(contact + "_label", text)
        text_obj.location = ((lo[0] + hi[0]) / 2 + k * step, hi[1] + 0.08 * (hi[1] - lo[1]), hi[2] + 1.0)
        text_obj.data.materials.append(material("label", (0.95, 0.95, 0.95, 1.0)))
        scene.collection.objects.link(text_obj)
    centre = Vector(((lo[0] + hi[0]) / 2 + step / 2, (lo[1] + hi[1]) / 2 + 0.05 * (hi[1] - lo[1]),
                     (lo[2] + hi[2]) / 2))
    size = max(step + hi[0] - lo[0], 1.2 * (hi[1] - lo[1]))
    render(scene, centre, size / 1.1 * 1.05, 0.25, 'MATERIAL', (1000, 560), out)
    print("wrote", out)


if __name__ == "__main__":
    main()
