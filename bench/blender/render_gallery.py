"""The pictures of docs/gallery.md: one scenario posed at x1, x2 and x3 of its displacement (rows) by Surface Only
and by Volume Infill (columns), rendered headlessly by Blender's Workbench into one small PNG per scenario.

    blender --background --factory-startup --python bench/blender/render_gallery.py -- \\
        build/results/gallery docs/gallery [NAME ...]

Reads NAME_xK_none.off and NAME_xK_infill.off (K = 1, 2, 3) and NAME_x1.json from the folder that
bench/native/volume_table.py wrote, and each cell's label from its volume.json (the volume kept for closed meshes,
the self-crossing triangle pairs); writes OUT/NAME.png, in 256 colours when ImageMagick's convert is found.
Without names, every case of volume.json whose scenario JSON is in the folder (the reference scenarios, not the
procedural meshes).

The view is orthographic, the same for the six cells: across the plane of the mesh's longest axis and the handles'
pull (where a bend shows), world z up where it can be, turned a quarter when the poses are taller than wide, then
tilted by VIEW_TILT to show the thickness; VIEWS sets it per scenario.
"""

import json
import math
import os
import shutil
import subprocess
import sys

import bpy
import numpy as np
from mathutils import Matrix, Vector

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [HERE, os.path.join(HERE, "..", "native")]   # volume_table (its mesh reader)
from volume_table import read_off  # noqa: E402

FACTORS = (1, 2, 3)
MODES = (("none", "Surface Only"), ("infill", "Infill"))
COLOURS = {"none": (0.80, 0.35, 0.30, 1.0), "infill": (0.35, 0.70, 0.40, 1.0)}
TEXT_COLOUR = (0.08, 0.08, 0.08, 1.0)
BACKGROUND = (0.93, 0.93, 0.93)
WIDTH = 800                     # pixels across at most
MAX_HEIGHT = 940                # pixels down at most
VIEW_TILT = 0.35                # radians about the picture's horizontal axis
# Per scenario, when the automatic view hides the pose or stands it on its head: (the world direction the camera
# looks from, the world direction kept up on the picture).
VIEWS = {
    "dino": ((0.0, -1.0, 0.0), (0.0, 0.0, -1.0)),       # from its side, standing (its up is -z)
    "letter_a": ((0.0, -1.0, 0.0), (0.0, 0.0, -1.0)),   # upright (its up is -z), from the side the pulled
                                                        # vertex comes out of (the letter reads mirrored)
}


def rows(folder):
    with open(os.path.join(folder, "volume.json")) as f:
        return {(r["case"], r["factor"]): r for r in json.load(f)}


def label(row, mode):
    """'volume 94%, 2 crossings' for a closed mesh, '0 crossings' for an open one (with the rest's own count)."""
    m = row[mode]["measure"]
    parts = []
    if m["closed_components"] and not m["open_components"]:
        parts.append("volume %.0f%%" % (100 * m["volume_ratio"]))
    crossings = m["self_intersections"]
    text = "%d crossing%s" % (crossings, "" if crossings == 1 else "s")
    if m["rest_self_intersections"]:
        text += " (rest %d)" % m["rest_self_intersections"]
    parts.append(text)
    return ", ".join(parts)


def view_basis(rest, scenario, name, points):
    """(right, up, back) unit vectors of the camera: back points from the meshes towards it. World z is kept up
    on the picture where it can be; an automatic view is turned a quarter when the poses are taller than wide."""
    helper = np.array([0.0, 0.0, 1.0])
    if name in VIEWS:
        back, helper = (np.array(v, dtype=float) for v in VIEWS[name])
    else:
        centred = rest - rest.mean(axis=0)
        _, _, axes = np.linalg.svd(centred, full_matrices=False)   # rows: principal axes, longest first
        pull = np.sum([h.get("translate", [0.0, 0.0, 0.0]) for h in scenario["handles"]], axis=0)
        back = np.cross(axes[0], pull) if np.linalg.norm(pull) > 0 else axes[2]
        if np.linalg.norm(back) < 1e-6 * max(np.linalg.norm(pull), 1e-30):
            back = axes[2]
        if back[np.argmax(np.abs(back))] < 0:   # the same side whatever the cross product's sign
            back = -back
    back = back / np.linalg.norm(back)
    if abs(np.dot(helper, back)) > 0.9:
        helper = np.array([0.0, 1.0, 0.0])
    right = np.cross(helper, back)
    right /= np.linalg.norm(right)
    up = np.cross(back, right)
    if name not in VIEWS:
        x, y = points @ right, points @ up
        if y.max() - y.min() > x.max() - x.min():
            right, up = up, -right
    # Tilt about the horizontal axis to show the thickness: the camera rises above the view.
    c, s = math.cos(VIEW_TILT), math.sin(VIEW_TILT)
    back, up = c * back + s * up, -s * back + c * up
    return right, up, back


def text_object(scene, name, body, size, location, rotation):
    """A line of text centred on `location`, facing the camera (turned by `rotation`, the camera's)."""
    curve = bpy.data.curves.new(name, 'FONT')
    curve.body = body
    curve.size = size
    curve.align_x = 'CENTER'
    curve.align_y = 'CENTER'
    obj = bpy.data.objects.new(name, curve)
    obj.location = location
    obj.rotation_euler = rotation
    obj.color = TEXT_COLOUR
    scene.collection.objects.link(obj)


def render_case(folder, name, table, out):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    with open(os.path.join(folder, "%s_x1.json" % name)) as f:
        scenario = json.load(f)
    rest = np.array(read_off(scenario["mesh"])[0], dtype=float)   # the reference scenarios' meshes are OFF files
    meshes = {(k, mode): read_off(os.path.join(folder, "%s_x%d_%s.off" % (name, k, mode)))
              for k in FACTORS for mode, _ in MODES}
    points = {key: np.array(v, dtype=float) for key, (v, _f) in meshes.items()}
    right, up, back = view_basis(rest, scenario, name, np.concatenate(list(points.values())))

    # One cell per mesh, all the same size: the largest extent on the picture of a row's two meshes together, and a
    # margin.
    boxes = {}
    for key, p in points.items():
        x, y = p @ right, p @ up
        boxes[key] = (x.min(), x.max(), y.min(), y.max())
    row_boxes = [[f(boxes[(k, m)][i] for m, _ in MODES) for i, f in enumerate((min, max, min, max))] for k in FACTORS]
    cell_w = 1.12 * max(b[1] - b[0] for b in row_boxes)
    cell_h = 1.08 * max(b[3] - b[2] for b in row_boxes)
    cell_h = max(cell_h, 0.3 * cell_w)
    # The picture is WIDTH pixels across, narrower when it would be more than MAX_HEIGHT tall; text sizes in world
    # units from its width in pixels (labels ~15 px tall), and the margins from the text.
    width = WIDTH
    for _ in range(4):
        text = 2 * cell_w * 15.0 / width
        for _ in range(3):
            left = 2.6 * text
            total_w = left + 2 * cell_w
            text = total_w * 15.0 / width
        header = 2.2 * text
        line = 1.9 * text
        total_h = header + 3 * (cell_h + line)
        width = min(WIDTH, int(MAX_HEIGHT * total_w / total_h))

    depth = max(float(p.max()) - float(p.min()) for p in points.values()) + total_w
    rotation = Matrix([list(right), list(up), list(back)]).transposed().to_euler()
    all_points = np.concatenate(list(points.values()))
    origin = float((all_points @ back).mean()) * back   # the picture plane through the meshes' middle

    def world(x, y, z=0.0):
        """A point of the picture plane: x right from the left edge, y down from the top, z towards the camera."""
        return Vector(origin + x * right - y * up + z * back)

    for r, k in enumerate(FACTORS):
        top = header + r * (cell_h + line)
        text_object(scene, "row%d" % k, "\u00d7%d" % k, 1.25 * text, world(left / 2, top + line + cell_h / 2, depth),
                    rotation)
        for c, (mode, title) in enumerate(MODES):
            vertices, faces = meshes[(k, mode)]
            mesh = bpy.data.meshes.new("%s_x%d_%s" % (name, k, mode))
            mesh.from_pydata(vertices, [], faces)
            obj = bpy.data.objects.new(mesh.name, mesh)
            # Both meshes of a row by the same offset from their common box (same fixed part, same handles'
            # targets), so the two solvers' poses line up across the row; that box's centre is the cell's.
            x0, x1, y0, y1 = row_boxes[r]
            cx = left + c * cell_w + cell_w / 2
            cy = top + line + cell_h / 2
            shift = world(cx, cy) - Vector(((x0 + x1) / 2) * right + ((y0 + y1) / 2) * up)
            obj.location = shift
            obj.color = COLOURS[mode]
            scene.collection.objects.link(obj)
            text_object(scene, "label_%d_%s" % (k, mode), label(table[(name, k)], mode), 0.85 * text,
                        world(cx, top + line / 2, depth), rotation)
    for c, (mode, title) in enumerate(MODES):
        text_object(scene, "title_" + mode, title, 1.15 * text,
                    world(left + c * cell_w + cell_w / 2, header / 2, depth), rotation)

    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    camera.data.type = 'ORTHO'
    camera.data.ortho_scale = max(total_w, total_h)
    camera.data.clip_end = 6 * depth
    camera.rotation_euler = rotation
    camera.location = world(total_w / 2, total_h / 2, 3 * depth)
    scene.collection.objects.link(camera)
    scene.camera = camera

    scene.render.engine = 'BLENDER_WORKBENCH'
    scene.display.render_aa = '8'
    shading = scene.display.shading
    shading.light = 'STUDIO'
    shading.color_type = 'OBJECT'
    shading.show_cavity = False
    shading.show_shadows = False
    shading.show_backface_culling = False
    scene.world = bpy.data.worlds.new("world")
    scene.world.color = BACKGROUND
    scene.render.resolution_x = width
    scene.render.resolution_y = int(round(width * total_h / total_w))
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = False
    scene.render.dither_intensity = 0.0   # no noise: PNGs a third the size
    scene.view_settings.view_transform = 'Standard'
    settings = scene.render.image_settings
    settings.file_format = 'PNG'
    settings.color_mode = 'RGB'
    settings.color_depth = '8'
    settings.compression = 100
    scene.render.filepath = os.path.abspath(out)
    bpy.ops.render.render(write_still=True)
    convert = shutil.which("convert")   # ImageMagick, when installed: 256 colours, a third to half the size
    if convert:
        subprocess.run([convert, out, "-strip", "-dither", "None", "-colors", "256", "PNG8:" + out], check=True)
    print("wrote", out, scene.render.resolution_x, "x", scene.render.resolution_y, os.path.getsize(out), "bytes")


def main():
    argv = sys.argv[sys.argv.index("--") + 1:]
    if len(argv) < 2:
        raise SystemExit(__doc__)
    folder, out_dir = argv[:2]
    table = rows(folder)
    names = argv[2:] or sorted({case for case, _k in table
                                if os.path.exists(os.path.join(folder, "%s_x1.json" % case))})
    os.makedirs(out_dir, exist_ok=True)
    for name in names:
        render_case(folder, name, table, os.path.join(out_dir, name + ".png"))


if __name__ == "__main__":
    main()
