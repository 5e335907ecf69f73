# Shared helpers of the Blender tests: scenes from Blender primitives only.
import importlib
import os
import sys

import addon_utils
import bmesh
import bpy
import numpy as np
from mathutils import Matrix

# The add-on's module name as Blender loads it: "arap_deform" (legacy add-on,
# Blender 3.x) or "bl_ext.user_default.arap_deform" (extension, 4.2+); ctest sets
# it, scripts that load the add-on another way assign it.
ADDON_MODULE = os.environ.get("ARAP_ADDON_MODULE", "arap_deform")


def addon(*names):
    """The loaded add-on's modules by name, under the name Blender loaded it
    with (ADDON_MODULE): `api = addon("api")`, `api, bake = addon("api", "bake")`
    (a module of a subpackage by its own name: "bake" is solver/bake.py, see
    module_path()); addon() is the package. The add-on is only in sys.modules
    under that name, so `import arap_deform` fails when Blender loaded it as an
    extension."""
    if not names:
        return importlib.import_module(ADDON_MODULE)
    modules = tuple(importlib.import_module(ADDON_MODULE + "." + module_path(name)) for name in names)
    return modules[0] if len(names) == 1 else modules


def module_path(name):
    """The dotted path in the add-on of its module `name`: the file name.py at its top or in one of its
    subpackages ("bake" -> "solver.bake"); a name with a dot is the path already."""
    if "." in name:
        return name
    folder = os.path.dirname(importlib.import_module(ADDON_MODULE).__file__)
    found = [name] if os.path.isfile(os.path.join(folder, name + ".py")) else []
    for sub in sorted(os.listdir(folder)):
        if os.path.isfile(os.path.join(folder, sub, "__init__.py")) and \
                os.path.isfile(os.path.join(folder, sub, name + ".py")):
            found.append(sub + "." + name)
    if len(found) != 1:
        raise ImportError("the add-on has %s module named %s: %s" % ("no" if not found else "more than one",
                                                                    name, found))
    return found[0]


def modules_under_other_names():
    """{sys.modules key: file} of every key outside the add-on's package that
    holds one of the add-on's modules, found by identity or by its file lying in
    the add-on's folder (Blender's extension policy forbids them): empty when
    the add-on keeps to its own name."""
    def in_package(name):
        return name == ADDON_MODULE or name.startswith(ADDON_MODULE + ".")

    folder = os.path.realpath(os.path.dirname(sys.modules[ADDON_MODULE].__file__)) + os.sep
    entries = [(name, module) for name, module in list(sys.modules.items()) if module is not None]
    ours = {id(module) for name, module in entries if in_package(name)}
    found = {}
    for name, module in entries:
        path = getattr(module, "__file__", None) or ""
        if not in_package(name) and (id(module) in ours or (path and os.path.realpath(path).startswith(folder))):
            found[name] = path
    return found


def extension_policy_warnings():
    """What Blender 4.2+ lists under the warning sign of the add-on's extension
    in the Preferences ("Policy violation with top level module: ..."), computed
    now rather than the first time they were asked for."""
    addon_utils._extensions_warnings_get._is_first = True
    return list(addon_utils._extensions_warnings_get().get(ADDON_MODULE, []))


def enable_addon(handle_error=None):
    return addon_utils.enable(ADDON_MODULE, default_set=True, handle_error=handle_error)


def disable_addon():
    addon_utils.disable(ADDON_MODULE, default_set=True)


def run_blender_args(args, factory_startup=True, timeout=240):
    """Run a new `blender --background <args>` in this test's environment (the
    same user folders: the add-on is installed, and not enabled unless asked);
    returns its output, fails on a non-zero exit or a traceback."""
    import subprocess
    cmd = [bpy.app.binary_path, "--background", "-noaudio", "--python-exit-code", "1"]
    cmd += ["--factory-startup"] if factory_startup else []
    proc = subprocess.run(cmd + list(args), capture_output=True, text=True, timeout=timeout)
    out = proc.stdout + proc.stderr
    if proc.returncode != 0 or "Traceback" in out:
        raise AssertionError("%s failed (exit %d):\n%s" % (" ".join(args), proc.returncode, out[-3000:]))
    return out


def run_blender_script(script, factory_startup=True, timeout=240):
    """run_blender_args with a Python script given as text."""
    import tempfile
    with tempfile.NamedTemporaryFile("w", suffix=".py", delete=False) as f:
        f.write(script)
    try:
        return run_blender_args(["--python", f.name], factory_startup, timeout)
    finally:
        os.remove(f.name)


def clear_scene():
    """Remove every object and mesh (the add-on stays enabled)."""
    for ob in list(bpy.data.objects):
        bpy.data.objects.remove(ob)
    for me in list(bpy.data.meshes):
        bpy.data.meshes.remove(me)
    deform_job, sessions = addon("deform_job", "sessions")
    sessions.stop_all_sessions()
    deform_job.clear_cache()


def add_grid(x=12, y=4, size=2.0, name="Grid"):
    """A flat strip of quads, x by y vertices, in Object Mode and active."""
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=x, y_subdivisions=y, size=size)
    obj = bpy.context.active_object
    obj.name = name
    return obj


def add_cylinder(vertices=16, depth=4.0, cuts=8, name="Bar"):
    """An upright cylinder subdivided along its height (quads and two n-gon caps)."""
    bpy.ops.mesh.primitive_cylinder_add(vertices=vertices, depth=depth, radius=0.5)
    obj = bpy.context.active_object
    obj.name = name
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    side = [e for e in bm.edges if abs(e.verts[0].co.z - e.verts[1].co.z) > 1e-6]
    bmesh.ops.subdivide_edges(bm, edges=side, cuts=cuts, use_grid_fill=False)
    bm.to_mesh(obj.data)
    bm.free()
    obj.data.update()
    return obj


def add_sphere(subdivisions=1, segments=32, rings=16, name="Sphere"):
    """A UV sphere, optionally subdivided (Catmull-Clark applied) for size."""
    bpy.ops.mesh.primitive_uv_sphere_add(segments=segments, ring_count=rings, radius=1.0)
    obj = bpy.context.active_object
    obj.name = name
    if subdivisions:
        mod = obj.modifiers.new("sub", 'SUBSURF')
        mod.levels = subdivisions
        with bpy.context.temp_override(object=obj, active_object=obj):
            bpy.ops.object.modifier_apply(modifier=mod.name)
    return obj


def coords(obj):
    """Base mesh coordinates, float64 (n, 3)."""
    buf = np.empty(len(obj.data.vertices) * 3, np.float32)
    obj.data.vertices.foreach_get("co", buf)
    return buf.astype(np.float64).reshape(-1, 3)


def raw_coords(obj):
    buf = np.empty(len(obj.data.vertices) * 3, np.float32)
    obj.data.vertices.foreach_get("co", buf)
    return buf


def evaluated_coords(obj):
    """Coordinates after shape keys and modifiers, float64 (n, 3)."""
    dg = bpy.context.evaluated_depsgraph_get()
    ev = obj.evaluated_get(dg)
    me = ev.to_mesh()
    buf = np.empty(len(me.vertices) * 3, np.float32)
    me.vertices.foreach_get("co", buf)
    ev.to_mesh_clear()
    return buf.astype(np.float64).reshape(-1, 3)


def group_where(obj, name, predicate):
    """Vertex group `name` of the vertices whose local co satisfies predicate(co)."""
    idx = [v.index for v in obj.data.vertices if predicate(v.co)]
    g = obj.vertex_groups.new(name=name)
    g.add(idx, 1.0, 'REPLACE')
    return np.array(idx, np.int64)


def add_empty(name, matrix=None):
    empty = bpy.data.objects.new(name, None)
    bpy.context.scene.collection.objects.link(empty)
    if matrix is not None:
        empty.matrix_world = matrix
    return empty


def add_armature(name, bones):
    """An armature object with `bones`: (name, head, tail, parent name or None), made in Edit Mode; back in
    Object Mode, active."""
    rig = bpy.data.objects.new(name, bpy.data.armatures.new(name))
    bpy.context.scene.collection.objects.link(rig)
    bpy.context.view_layer.objects.active = rig
    bpy.ops.object.mode_set(mode='EDIT')
    for bone_name, head, tail, parent in bones:
        bone = rig.data.edit_bones.new(bone_name)
        bone.head, bone.tail = head, tail
        if parent:
            bone.parent = rig.data.edit_bones[parent]
    bpy.ops.object.mode_set(mode='OBJECT')
    return rig


def smooth_bone_weights(z, joints, blend):
    """Weights of the bones of a chain along z, cut at `joints` (increasing heights): 1 inside a bone, a
    smoothstep over `blend` on each side of a joint, summing to 1. (n, len(joints) + 1) float64."""
    weights = np.zeros((len(z), len(joints) + 1))
    up = np.ones(len(z))    # the share of the bones above each joint
    for k, zj in enumerate(joints):
        t = np.clip((z - zj + blend) / (2 * blend), 0.0, 1.0)
        s = t * t * (3 - 2 * t)
        weights[:, k] = up * (1 - s)
        up = up * s
    weights[:, -1] = up
    return weights


def rigged_tube(bones=3, length=6.0, cuts=30, segments=16, blend=0.5, parent_type='OBJECT'):
    """A cylinder along z (add_cylinder) with an armature of a chain of `bones` connected bones named B0, B1,
    ... along its axis, smooth weights (smooth_bone_weights, a vertex group per bone), an Armature modifier
    and the armature as parent (`parent_type` 'OBJECT', as Ctrl+P > With Empty Groups, or 'ARMATURE'). The
    mesh is active. Returns (mesh object, armature object)."""
    obj = add_cylinder(vertices=segments, depth=length, cuts=cuts, name="Tube")
    step = length / bones
    chain = [("B%d" % k, (0.0, 0.0, -length / 2 + k * step), (0.0, 0.0, -length / 2 + (k + 1) * step),
              "B%d" % (k - 1) if k else None) for k in range(bones)]
    rig = add_armature("Rig", chain)
    z = coords(obj)[:, 2]
    weights = smooth_bone_weights(z, [-length / 2 + k * step for k in range(1, bones)], blend)
    for k in range(bones):
        group = obj.vertex_groups.new(name="B%d" % k)
        for w in np.unique(weights[:, k][weights[:, k] > 0]):
            group.add([int(i) for i in np.flatnonzero(weights[:, k] == w)], float(w), 'REPLACE')
    modifier = obj.modifiers.new("Armature", 'ARMATURE')
    modifier.object = rig
    obj.parent = rig
    obj.parent_type = parent_type
    for ob in bpy.context.view_layer.objects:
        ob.select_set(False)
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    bpy.context.view_layer.update()
    return obj, rig


def triangles(obj):
    me = obj.data
    me.calc_loop_triangles()
    t = np.empty(len(me.loop_triangles) * 3, np.int32)
    me.loop_triangles.foreach_get("vertices", t)
    return t.reshape(-1, 3)


def transform_channels(ob):
    """Every transform channel of `ob` as plain tuples (to compare bit for bit)."""
    names = ("location", "rotation_mode", "rotation_euler", "rotation_quaternion", "rotation_axis_angle", "scale",
             "delta_location", "delta_rotation_euler", "delta_rotation_quaternion", "delta_scale")
    return {n: (getattr(ob, n) if isinstance(getattr(ob, n), str) else tuple(getattr(ob, n))) for n in names}


def np_matrix(m):
    return np.array([tuple(r) for r in m], np.float64)


def apply(m, pts):
    """4x4 numpy or mathutils matrix applied to (n, 3) points."""
    m = np_matrix(m) if isinstance(m, Matrix) else m
    return pts @ m[:3, :3].T + m[:3, 3]


def bar_with_handle(fixed_below=-1.5, handle_above=1.5, **cylinder):
    """Cylinder (add_cylinder's arguments) with a fixed bottom, a handle on the top and its empty at the top centre."""
    obj = add_cylinder(**cylinder)
    fixed = group_where(obj, "bottom", lambda co: co.z < fixed_below)
    top = group_where(obj, "top", lambda co: co.z > handle_above)
    api = addon("api")
    api.set_fixed(obj, "bottom")
    empty = add_empty("TopEmpty", Matrix.Translation((0, 0, 2.0)))
    api.add_handle(obj, "top", empty)
    return obj, empty, fixed, top
