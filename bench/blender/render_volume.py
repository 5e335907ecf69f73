"""The picture of docs/volume.md: one bent bar posed by surface ARAP,
Volume Global and Volume Infill, side by side, rendered headlessly by Blender.

    blender --background --factory-startup --python bench/blender/render_volume.py -- \\
        build/results/volume bar1_x2 docs/volume_bar1.png

Reads CASE_none.off, CASE_global.off and CASE_infill.off from the folder that
bench/native/volume_table.py wrote (its solved meshes), and the volume kept by
each from that folder's volume.json for the labels.
"""

import json
import math
import os
import sys

import bpy
from mathutils import Vector

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [HERE, os.path.join(HERE, "..", "native")]   # volume_table (its mesh reader)
from volume_table import read_off  # noqa: E402

MODES = (("none", "Surface only"), ("global", "Volume Global"), ("infill", "Volume Infill"))
COLOURS = {"none": (0.80, 0.35, 0.30, 1.0), "global": (0.30, 0.55, 0.85, 1.0), "infill": (0.35, 0.70, 0.40, 1.0)}


def kept_volume(folder, case, mode):
    name, factor = case.rsplit("_x", 1)
    with open(os.path.join(folder, "volume.json")) as f:
        for row in json.load(f):
            if row["case"] == name and row["factor"] == int(factor):
                return row[mode]["measure"]["volume_ratio"]
    return None


def render(scene, centre, size, tilt, colour_type, resolution, out):
    """An orthographic picture of `scene` by the Workbench engine into `out`: looking down at `centre`, tilted
    about x by `tilt` radians to show the thickness, `size` across; objects coloured by `colour_type`."""
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    camera.data.type = 'ORTHO'
    camera.data.ortho_scale = 1.1 * size
    camera.data.clip_end = 10 * size
    camera.rotation_euler = (tilt, 0.0, 0.0)
    camera.location = centre + 3 * size * Vector((0.0, -math.sin(tilt), math.cos(tilt)))
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.render.engine = 'BLENDER_WORKBENCH'
    shading = scene.display.shading
    shading.light = 'STUDIO'
    shading.color_type = colour_type
    shading.show_cavity = True
    shading.show_shadows = True
    scene.render.resolution_x, scene.render.resolution_y = resolution
    scene.render.film_transparent = False
    scene.world = bpy.data.worlds.new("world")
    scene.render.filepath = os.path.abspath(out)
    bpy.ops.render.render(write_still=True)


def main():
    argv = sys.argv[sys.argv.index("--") + 1:]
    if len(argv) != 3:
        raise SystemExit(__doc__)
    folder, case, out = argv
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    meshes = [(mode, label, read_off(os.path.join(folder, "%s_%s.off" % (case, mode)))) for mode, label in MODES]
    # Side by side across the bend's plane, with a gap of half a bar between them.
    lo = [min(v[i] for _m, _l, (vs, _f) in meshes for v in vs) for i in range(3)]
    hi = [max(v[i] for _m, _l, (vs, _f) in meshes for v in vs) for i in range(3)]
    step = 1.35 * (hi[1] - lo[1])
    for k, (mode, label, (vertices, faces)) in enumerate(meshes):
        mesh = bpy.data.meshes.new(mode)
        mesh.from_pydata(vertices, [], faces)
        obj = bpy.data.objects.new(mode, mesh)
        obj.location = (0.0, -k * step, 0.0)
        obj.color = COLOURS[mode]
        scene.collection.objects.link(obj)
        kept = kept_volume(folder, case, mode)
        text = bpy.data.curves.new(mode + "_label", 'FONT')
        text.body = label + ("  (volume %.0f%%)" % (100 * kept) if kept is not None else "")
        text.size = 0.09 * (hi[0] - lo[0])
        text_obj = bpy.data.objects.new(mode + "_label", text)
        text_obj.location = (lo[0], -k * step + hi[1] + 0.1 * step, hi[2] + 1.0)
        text_obj.color = (0.95, 0.95, 0.95, 1.0)
        scene.collection.objects.link(text_obj)
    centre = Vector(((lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2 - step, (lo[2] + hi[2]) / 2))
    size = max(hi[0] - lo[0], 3 * step)
    render(scene, centre, size, 0.4, 'OBJECT', (800, 800), out)
    print("wrote", out)


if __name__ == "__main__":
    main()
