# SPDX-License-Identifier: GPL-3.0-or-later
"""ARAP against Blender's own deformers on rigged meshes (rig_scene.py): the same bones, weights and poses,
each posed mesh measured from its file by arap-mesh-measure.

    blender --background --factory-startup --python bench/blender/rig_compare.py -- \\
        --build build --out build/results/rig [--addon-dir build/addon] [--scenario PATH.off ...] \\
        [--picture docs/rig_compare.png] [--vertices 10000] [--repeats 5] [--planes 29]

With --picture, Blender needs an X display for the render:

    LIBGL_ALWAYS_SOFTWARE=1 xvfb-run -a -s "-screen 0 1280x800x24" blender --background --factory-startup \\
        --python bench/blender/rig_compare.py -- --build build --out build/results/rig --picture docs/rig_compare.png

Rigs: the closed tube (rig_scene.capped_tube_rig: --vertices, 3 bones along Z), and each --scenario .off mesh
with a 2-bone chain along its principal axis (rig_scene.scenario_rig). Poses: twist 90 and 180 (the last
bone about its axis), bend 60 and 120 (the middle joint). Deformers, each on a scene built afresh:
- armature: the Armature modifier, linear blend skinning (Preserve Volume off);
- preserve_volume: the same with Preserve Volume on (dual quaternion skinning);
- corrective_smooth: Armature (linear) + a Corrective Smooth modifier after it, rest source 'ORCO' and
  Blender's defaults otherwise (factor 0.5, 5 iterations, scale 1, smooth type Simple, Only Smooth off,
  Pin Boundaries off);
- arap, arap_contact: the add-on's Auto mode on bone handles made by
  bpy.ops.object.arap_handles_from_armature() (default threshold), Self Contact off / on; Auto mutes the
  Armature modifier while it poses the mesh. A missing operator (or add-on) fails these rows only.

Per rig and pose: the rest mesh (OUT/RIG_rest.off, its faces as they are) and each posed mesh (the evaluated
mesh, object-local: OUT/RIG_POSE_DEFORMER.off) go to `arap-mesh-measure REST POSED --planes N` (volume
ratio, material cross-sections across the rest mesh's principal axis, self-intersections, distortion);
--planes defaults to 29 so that planes fall on the joints of the 3-bone tube and of a 2-bone chain (the
chains span the same extent as the planes). CPU time (time.process_time: every thread of Blender) of the
frame change that evaluates the pose: for Blender's deformers the median of --repeats evaluations, for
ARAP the first one (which solves; later ones would read the pose cache). Writes OUT/rig.json (everything)
and OUT/rig.md (the tables).
"""

import argparse
import datetime
import json
import math
import os
import statistics
import subprocess
import sys
import time

import bpy
import numpy as np
from mathutils import Vector

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)   # bench_addon, rig_scene
import bench_addon as U  # noqa: E402
import rig_scene as R  # noqa: E402
from volume_table import read_off  # noqa: E402   (bench/native, on the path through rig_scene)

POSES = (("twist", 90), ("twist", 180), ("bend", 60), ("bend", 120))
DEFORMERS = ("armature", "preserve_volume", "corrective_smooth", "arap", "arap_contact")
ARAP_DEFORMERS = ("arap", "arap_contact")
OPERATOR = "arap_handles_from_armature"
PICTURE_DEFORMERS = (("armature", "Armature (linear)"), ("preserve_volume", "Preserve Volume (DQS)"),
                     ("corrective_smooth", "Corrective Smooth"), ("arap", "ARAP"))
PICTURE_POSES = (("twist", 180), ("bend", 120))
COLOURS = {"armature": (0.80, 0.35, 0.30), "preserve_volume": (0.85, 0.65, 0.25),
           "corrective_smooth": (0.30, 0.55, 0.85), "arap": (0.35, 0.70, 0.40)}


class CaseError(Exception):
    """A deformer that could not be set up or could not pose: its rows say why, the others still run."""


def parse_args():
    """The options after Blender's `--`."""
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="rig_compare.py")
    p.add_argument("--build", default="build", help="the build folder (its arap-mesh-measure)")
    p.add_argument("--out", default=os.path.join("build", "results", "rig"))
    p.add_argument("--addon-dir", default="", help="a staged build/addon (default: the installed add-on)")
    p.add_argument("--scenario", action="append", default=[], help="an .off mesh to rig with 2 bones")
    p.add_argument("--picture", default="", help="a PNG of the tube at twist 180 and bend 120")
    p.add_argument("--vertices", type=int, default=10000, help="the tube's vertex count")
    p.add_argument("--repeats", type=int, default=5, help="evaluations timed per pose, Blender's deformers")
    p.add_argument("--planes", type=int, default=29, help="arap-mesh-measure --planes")
    p.add_argument("--deformers", nargs="+", choices=DEFORMERS, default=list(DEFORMERS),
                   help="the deformers to run (default: all)")
    p.add_argument("--core-weight", type=float, default=None,
                   help="Handles from Armature's Core Weight (default: the operator's)")
    return p.parse_args(argv)


def command_line():
    """How this run was started, for the report's header."""
    return " ".join(sys.argv)


def load_arap(addon_dir):
    """The add-on's api module, or (None, why) when it cannot be loaded (the ARAP rows then fail)."""
    try:
        U.load_addon(addon_dir)
        return U.addon("api"), None
    except (SystemExit, Exception) as exc:   # load_addon raises SystemExit when nothing can be enabled
        return None, "add-on not loaded: %s" % exc


def clear(arap_loaded):
    """An empty scene: objects, meshes, armatures and text curves removed; the add-on's sessions, caches and
    Auto posers dropped when it is loaded."""
    if arap_loaded:
        U.addon("auto").forget()
        U.clear_scene()
    for collection in (bpy.data.objects, bpy.data.meshes, bpy.data.armatures, bpy.data.curves,
                       bpy.data.cameras):
        for block in list(collection):
            collection.remove(block)


def mesh_arrays(me):
    """(float64 (n, 3) vertex coordinates, polygons as lists of vertex indices) of a mesh datablock."""
    co = np.empty(len(me.vertices) * 3, np.float32)
    me.vertices.foreach_get("co", co)
    loops = np.empty(len(me.loops), np.int32)
    me.loops.foreach_get("vertex_index", loops)
    start = np.empty(len(me.polygons), np.int32)
    total = np.empty(len(me.polygons), np.int32)
    me.polygons.foreach_get("loop_start", start)
    me.polygons.foreach_get("loop_total", total)
    faces = [loops[s:s + t].tolist() for s, t in zip(start, total)]
    return co.astype(np.float64).reshape(-1, 3), faces


def evaluated_arrays(obj):
    """mesh_arrays of the object's evaluated mesh (modifiers, shape keys, Auto's pose), object-local."""
    ev = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    me = ev.to_mesh()
    try:
        return mesh_arrays(me)
    finally:
        ev.to_mesh_clear()


def write_off(path, vertices, faces):
    """An .off file of the polygons as they are (n-gons included)."""
    with open(path, "w") as f:
        f.write("OFF\n%d %d 0\n" % (len(vertices), len(faces)))
        f.writelines("%.9g %.9g %.9g\n" % tuple(v) for v in vertices)
        f.writelines("%d %s\n" % (len(face), " ".join(map(str, face))) for face in faces)


def measure(build, rest_path, posed_path, planes):
    """arap-mesh-measure's JSON for a rest and a posed file."""
    tool = os.path.join(build, "arap-mesh-measure")
    done = subprocess.run([tool, rest_path, posed_path, "--planes", str(planes)], capture_output=True, text=True)
    if done.returncode != 0:
        raise CaseError("arap-mesh-measure failed (%d): %s" % (done.returncode, done.stderr.strip()))
    return json.loads(done.stdout)


def evaluate(frame):
    """CPU ms of a frame change and the update after it (where Blender evaluates the modifiers, and
    Auto mode solves)."""
    c = time.process_time()
    bpy.context.scene.frame_set(frame)
    bpy.context.view_layer.update()
    return (time.process_time() - c) * 1e3


def set_up_blender(obj, deformer):
    """The Armature modifier as `deformer` wants it, and Corrective Smooth after it for corrective_smooth."""
    arm = next(m for m in obj.modifiers if m.type == 'ARMATURE')
    arm.use_deform_preserve_volume = deformer == "preserve_volume"
    if deformer == "corrective_smooth":
        smooth = obj.modifiers.new("CorrectiveSmooth", 'CORRECTIVE_SMOOTH')
        smooth.rest_source = 'ORCO'


def set_up_arap(api, obj, deformer, core_weight=None):
    """Bone handles from the armature (`core_weight`, default the operator's), Self Contact for arap_contact,
    Auto on."""
    core = {} if core_weight is None else {"threshold": core_weight}
    if api is None:
        raise CaseError("the add-on is not loaded")
    if not hasattr(bpy.types, "OBJECT_OT_" + OPERATOR):
        raise CaseError("operator missing: bpy.ops.object.%s is not registered by this add-on" % OPERATOR)
    for other in bpy.context.view_layer.objects:
        other.select_set(False)
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    with bpy.context.temp_override(object=obj, active_object=obj, selected_objects=[obj],
                                   selected_editable_objects=[obj]):
        done = getattr(bpy.ops.object, OPERATOR)(**core)
    if 'FINISHED' not in done:
        raise CaseError("bpy.ops.object.%s() returned %s" % (OPERATOR, sorted(done)))
    obj.arap.contact = deformer == "arap_contact"
    api.set_auto(obj, True)


def arap_state(obj):
    """What Auto says after a pose (and whether it is still on), and whether the Armature modifier is muted."""
    arm = [m for m in obj.modifiers if m.type == 'ARMATURE']
    return {"auto": bool(obj.arap.auto), "auto_status": obj.arap.auto_status,
            "armature_modifier_on": bool(arm and arm[0].show_viewport and arm[0].show_render)}


def pose_and_time(rig, obj, deformer, kind, angle, frame, repeats):
    """Pose the chain, change to `frame`; CPU ms of each evaluation timed (ARAP: the first, the solve)."""
    R.pose(rig, kind, angle)
    cpu = [evaluate(frame)]
    if deformer not in ARAP_DEFORMERS:
        for _ in range(repeats - 1):
            obj.update_tag()   # the same pose evaluated again
            cpu.append(evaluate(frame))
    return cpu


def run_deformer(args, api, build_rig, rig_name, deformer, rest_faces):
    """Every pose of one rig with one deformer, on a scene of its own: {pose name: result}."""
    clear(api is not None)
    obj, rig = build_rig()
    results = {}
    try:
        if deformer in ARAP_DEFORMERS:
            set_up_arap(api, obj, deformer, args.core_weight)
        else:
            set_up_blender(obj, deformer)
        for k, (kind, angle) in enumerate(POSES):
            name = "%s_%d" % (kind, angle)
            cpu = pose_and_time(rig, obj, deformer, kind, angle, k + 2, args.repeats)
            if deformer in ARAP_DEFORMERS and not obj.arap.auto:
                raise CaseError("Auto turned off at %s: %s" % (name, obj.arap.auto_status))
            co, faces = evaluated_arrays(obj)
            if faces != rest_faces:
                raise CaseError("the posed mesh does not have the rest mesh's faces")
            path = os.path.join(args.out, "%s_%s_%s.off" % (rig_name, name, deformer))
            write_off(path, co, faces)
            result = {"cpu_ms": cpu, "cpu_ms_median": statistics.median(cpu), "posed": path,
                      "measure": measure(args.build, os.path.join(args.out, rig_name + "_rest.off"), path,
                                         args.planes)}
            if deformer in ARAP_DEFORMERS:
                result.update(arap_state(obj))
            results[name] = result
            print("  %-17s %-10s %s" % (deformer, name, summary(result)), flush=True)
    except Exception as exc:   # a CaseError, or what the add-on raised: these rows fail, the others run
        why = str(exc) if isinstance(exc, CaseError) else "%s: %s" % (type(exc).__name__, exc)
        print("  %-17s FAILED: %s" % (deformer, why), flush=True)
        for kind, angle in POSES:
            results.setdefault("%s_%d" % (kind, angle), {"error": why})
    finally:
        if deformer in ARAP_DEFORMERS and api is not None and obj.arap.auto:
            api.set_auto(obj, False)
    return results


def run_rig(args, api, rig_name, build_rig):
    """The rest mesh written once, then every deformer: the rig's entry of rig.json."""
    clear(api is not None)
    obj, rig = build_rig()
    co, faces = mesh_arrays(obj.data)
    write_off(os.path.join(args.out, rig_name + "_rest.off"), co, faces)
    entry = {"rig": rig_name, "vertices": len(co), "faces": len(faces), "bones": len(rig.data.bones),
             "poses": {}}
    print("%s: %d vertices, %d faces, %d bones" % (rig_name, len(co), len(faces), len(rig.data.bones)), flush=True)
    for deformer in args.deformers:
        for name, result in run_deformer(args, api, build_rig, rig_name, deformer, faces).items():
            entry["poses"].setdefault(name, {})[deformer] = result
    return entry


def new_crossings(m):
    """Self-intersecting triangle pairs the pose made (posed minus rest)."""
    return m["self_intersections"] - m["rest_self_intersections"]


def summary(result):
    """One line of a result for the log."""
    m = result["measure"]
    return "volume %5.1f %%  section min %.3f median %.3f  new crossings %5d  distortion %.4f  %.1f ms CPU" % (
        100 * m["volume_ratio"], m["cross_section_min"], m["cross_section_median"], new_crossings(m),
        m["distortion"], result["cpu_ms_median"])


def cell(result):
    """A table cell: volume % / smallest cross-section / new crossings / distortion, or why it failed."""
    if result is None:
        return "-"
    if "error" in result:
        return "failed: " + ("operator missing" if "operator missing" in result["error"] else result["error"])
    m = result["measure"]
    return "%.1f / %.2f / %d / %.3f" % (100 * m["volume_ratio"], m["cross_section_min"], new_crossings(m),
                                        m["distortion"])


def markdown(entries, header, deformers=DEFORMERS):
    """rig.md: the shape table and the CPU table."""
    lines = [header, "",
             "Per deformer: volume % / smallest cross-section (posed / rest area) / new self-crossings "
             "(triangle pairs) / distortion, from arap-mesh-measure.", "",
             "| rig | pose | " + " | ".join(deformers) + " |",
             "|---|---|" + "---:|" * len(deformers)]
    for e in entries:
        for pose_name, row in e["poses"].items():
            lines.append("| %s | %s | %s |" % (e["rig"], pose_name.replace("_", " "),
                                               " | ".join(cell(row.get(d)) for d in deformers)))
    lines += ["", "CPU ms of the frame evaluation (Blender's deformers: median of the repeats; ARAP: the "
              "first evaluation, the solve).", "",
              "| rig | pose | " + " | ".join(deformers) + " |", "|---|---|" + "---:|" * len(deformers)]
    for e in entries:
        for pose_name, row in e["poses"].items():
            cpu = ["%.1f" % row[d]["cpu_ms_median"] if d in row and "cpu_ms_median" in row[d] else "-"
                   for d in deformers]
            lines.append("| %s | %s | %s |" % (e["rig"], pose_name.replace("_", " "), " | ".join(cpu)))
    return "\n".join(lines) + "\n"


def stripes(co, axis_points):
    """Per vertex, 0 or 1: eight stripes around the rest mesh's axis (from the first to the last of
    `axis_points`), so that a twist shows."""
    a, b = Vector(axis_points[0]), Vector(axis_points[-1])
    d = (b - a).normalized()
    u = d.orthogonal().normalized()
    v = d.cross(u)
    rel = co - np.asarray(a)
    angle = np.arctan2(rel @ np.asarray(v), rel @ np.asarray(u))
    return (np.floor((angle + math.pi) / (2 * math.pi) * 8).astype(int) % 2).astype(np.float32)


def static_object(name, vertices, faces, colour, shade):
    """A plain mesh object with a per-vertex colour: `colour` darkened where `shade` is 1."""
    me = bpy.data.meshes.new(name)
    me.from_pydata([tuple(v) for v in vertices], [], faces)
    rgb = np.asarray(colour)[None, :] * (1.0 - 0.45 * shade[:, None])
    attribute = me.color_attributes.new("stripes", 'FLOAT_COLOR', 'POINT')
    attribute.data.foreach_set("color", np.hstack([rgb, np.ones((len(rgb), 1))]).astype(np.float32).ravel())
    me.color_attributes.active_color = attribute
    obj = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def label(name, body, location, size, align='CENTER'):
    """A text object facing +X (the camera), reading along +Y, aligned on `location` by `align`."""
    text = bpy.data.curves.new(name, 'FONT')
    text.body = body
    text.size = size
    text.align_x = align
    obj = bpy.data.objects.new(name, text)
    obj.location = location
    obj.rotation_euler = (math.pi / 2, 0.0, math.pi / 2)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def camera_at(scene, centre, width, height, resolution):
    """An orthographic camera on the +X side looking at `centre` along -X, framing width (Y) x height (Z)."""
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    camera.data.type = 'ORTHO'
    aspect = resolution[0] / resolution[1]
    camera.data.ortho_scale = 1.05 * max(width, height * aspect)
    camera.data.clip_end = 100.0 * max(width, height)
    camera.location = centre + Vector((20.0 * max(width, height), 0.0, 0.0))
    camera.rotation_euler = Vector((-1.0, 0.0, 0.0)).to_track_quat('-Z', 'Y').to_euler()
    scene.collection.objects.link(camera)
    scene.camera = camera


def render(scene, out, resolution):
    """Workbench, studio light, cavity, vertex colours, into `out`."""
    scene.render.engine = 'BLENDER_WORKBENCH'
    shading = scene.display.shading
    shading.light = 'STUDIO'
    shading.color_type = 'VERTEX'
    shading.show_cavity = True
    shading.show_shadows = False   # the labels' shadows would fall on the meshes
    scene.render.resolution_x, scene.render.resolution_y = resolution
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = False
    scene.world = bpy.data.worlds.new("world")
    scene.render.filepath = os.path.abspath(out)
    bpy.ops.render.render(write_still=True)


def picture(args, api, entry, resolution=(1600, 1000)):
    """The tube's posed files, four deformers side by side (along Y), one row per PICTURE_POSES pose, each
    labelled below with its volume and smallest cross-section; viewed from +X, so the bend's plane (the
    bones' local X is world X) faces the camera. Stripes around the rest tube show the twist."""
    clear(api is not None)
    scene = bpy.context.scene
    rest_co, _faces = read_off_arrays(os.path.join(args.out, "tube_rest.off"))
    shade = stripes(rest_co, [(0, 0, rest_co[:, 2].min()), (0, 0, rest_co[:, 2].max())])
    cells = {}
    for kind, angle in PICTURE_POSES:
        for deformer, _title in PICTURE_DEFORMERS:
            result = entry["poses"]["%s_%d" % (kind, angle)].get(deformer, {})
            cells[(kind, angle, deformer)] = (read_off_arrays(result["posed"]) if "posed" in result else None,
                                              result)
    extents = [c[0][0].max(axis=0) - c[0][0].min(axis=0) for c in cells.values() if c[0] is not None]
    tall = max(e[2] for e in extents)
    size = 0.05 * tall
    column = max(1.2 * max(e[1] for e in extents), 20 * size)
    pitch = tall + 5 * size
    for r, (kind, angle) in enumerate(PICTURE_POSES):
        z0 = -r * pitch
        label("row%d" % r, "%s %d°" % (kind, angle), (1.0, -0.55 * column, z0 + 0.4 * tall), 1.2 * size, 'RIGHT')
        for k, (deformer, title) in enumerate(PICTURE_DEFORMERS):
            mesh, result = cells[(kind, angle, deformer)]
            y0 = k * column
            if r == 0:
                label("title_" + deformer, title, (1.0, y0, tall + size), 1.2 * size)
            if mesh is None:
                text = cell(result if result else None)
            else:
                co, faces = mesh
                lo, hi = co.min(axis=0), co.max(axis=0)
                obj = static_object("%s_%s_%d" % (deformer, kind, angle), co, faces, COLOURS[deformer], shade)
                obj.location = (0.0, y0 - 0.5 * (lo[1] + hi[1]), z0 - lo[2])
                m = result["measure"]
                text = "volume %.0f%%, min section %.2f" % (100 * m["volume_ratio"], m["cross_section_min"])
            label("label_%s_%d_%s" % (kind, angle, deformer), text, (1.0, y0, z0 - 1.6 * size), size)
    left, right = -1.5 * column, (len(PICTURE_DEFORMERS) - 0.5) * column
    top, bottom = tall + 3 * size, -(len(PICTURE_POSES) - 1) * pitch - 3 * size
    centre = Vector((0.0, 0.5 * (left + right), 0.5 * (top + bottom)))
    camera_at(scene, centre, right - left, top - bottom, resolution)
    os.makedirs(os.path.dirname(os.path.abspath(args.picture)), exist_ok=True)
    render(scene, args.picture, resolution)
    print("wrote", args.picture, flush=True)


def read_off_arrays(path):
    """(float64 (n, 3) vertices, faces) of an .off file."""
    vertices, faces = read_off(path)
    return np.asarray(vertices, np.float64), [list(f) for f in faces]


def main():
    args = parse_args()
    started = time.perf_counter()
    os.makedirs(args.out, exist_ok=True)
    api, why = load_arap(args.addon_dir)
    if why:
        print("ARAP rows will fail:", why, flush=True)
    elif not hasattr(bpy.types, "OBJECT_OT_" + OPERATOR):
        print("ARAP rows will fail: operator missing: bpy.ops.object.%s" % OPERATOR, flush=True)
    rigs = [("tube", lambda: R.capped_tube_rig(vertices=args.vertices, bones=3))]
    for path in args.scenario:
        name = os.path.splitext(os.path.basename(path))[0]
        rigs.append((name, lambda path=path: R.scenario_rig(path, bones=2)))
    entries = [run_rig(args, api, name, build) for name, build in rigs]
    date = datetime.datetime.now().strftime("%Y-%m-%d %H:%M")
    header = "# ARAP vs Blender's deformers on rigged meshes (Blender %s, %s)\n\n`%s`" % (
        bpy.app.version_string, date, command_line())
    with open(os.path.join(args.out, "rig.json"), "w") as f:
        json.dump({"command": command_line(), "date": date, "blender": bpy.app.version_string,
                   "planes": args.planes, "repeats": args.repeats, "poses": POSES, "deformers": args.deformers,
                   "core_weight": args.core_weight,
                   "rigs": entries}, f, indent=1)
    table = markdown(entries, header, args.deformers)
    with open(os.path.join(args.out, "rig.md"), "w") as f:
        f.write(table)
    print(table)
    print("wrote", os.path.join(args.out, "rig.md"), "and rig.json", flush=True)
    if args.picture:
        picture(args, api, entries[0])
    print("total %.0f s" % (time.perf_counter() - started), flush=True)


if __name__ == "__main__":
    main()
