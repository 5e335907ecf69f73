# What the batch tests and measurements share: .blend files built from Blender
# primitives (each make_* clears the scene, builds, saves a copy to `path`; the
# open file is unchanged), the arap-batch launcher and how to run it, and
# checks on its outputs.
#
# The launcher is the build tree's arap-batch, found next to the staged add-on
# (<build>/addon/arap_deform -> <build>/arap-batch) or via ARAP_BATCH_LAUNCHER.
import glob
import hashlib
import os
import shutil
import subprocess

import bpy
from mathutils import Matrix

import arap_test_utils as U

api = U.addon("api")

PYTHON = "/usr/bin/python3" if os.path.exists("/usr/bin/python3") else shutil.which("python3")


def find_launcher():
    env = os.environ.get("ARAP_BATCH_LAUNCHER")
    if env:
        return env
    staged = os.path.dirname(os.path.realpath(U.addon().__file__))
    return os.path.join(os.path.dirname(os.path.dirname(staged)), "arap-batch")


LAUNCHER = find_launcher()


def run_batch(*args, timeout=300):
    p = subprocess.run([PYTHON, LAUNCHER] + [str(a) for a in args], capture_output=True, text=True,
                       timeout=timeout)
    return p.returncode, p.stdout + p.stderr


def sha(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def hashes(folder):
    return {p: sha(p) for p in sorted(glob.glob(os.path.join(folder, "*")))}


def temp_leftovers(*folders):
    return [n for d in folders for n in os.listdir(d) if "arap-tmp" in n or ".tmp-" in n or n.endswith("@")]


def running(pid):
    """The process exists and is not a zombie waiting for its parent."""
    try:
        with open("/proc/%d/stat" % pid) as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def blender_env():
    """Without pyenv/virtualenv folders on PATH: Blender's Python would take their library."""
    env = dict(os.environ)
    env["PATH"] = os.pathsep.join(p for p in env.get("PATH", "").split(os.pathsep)
                                  if "pyenv" not in p and "virtualenv" not in p)
    return env


def patched_blender(folder, name, patch):
    """An executable that runs Blender with batch_worker.process(entry, job) wrapped:
    `patch` is an expression run first, with `e` (the file entry) in scope."""
    path = os.path.join(folder, name)
    code = ("import os, signal, time; from arap_deform import batch_worker as w; "
            "p = w.process; w.process = lambda e, j: (%s) or p(e, j); " % patch)
    with open(path, "w") as f:
        f.write("#!%s\nimport os, sys\nargs = sys.argv[1:]\ni = args.index('--python-expr') + 1\n"
                "head, tail = args[i].rsplit('from ', 1)\nargs[i] = head + %r + 'from ' + tail\n"
                "os.execv(%r, [%r] + args)\n" % (PYTHON, code, bpy.app.binary_path, bpy.app.binary_path))
    os.chmod(path, 0o755)
    return path


def load_object(path, name="Bar"):
    """(mesh coords float64 (n, 3), shape key names, modifiers) of object `name` in a .blend."""
    with bpy.data.libraries.load(path, link=False) as (_src, dst):
        dst.objects = [name]
    obj = dst.objects[0]
    keys = [kb.name for kb in obj.data.shape_keys.key_blocks] if obj.data.shape_keys else []
    mods = [(m.type, m.filepath) for m in obj.modifiers if m.type == 'MESH_CACHE']
    out = U.coords(obj), keys, mods
    mesh = obj.data
    bpy.data.objects.remove(obj)
    bpy.data.meshes.remove(mesh)
    return out


def _save(path):
    bpy.ops.wm.save_as_mainfile(filepath=path, copy=True)
    return path


def posed_bar(vertices=16, cuts=8, dx=0.6):
    """Bar with fixed bottom and a handle on top whose empty moved by dx since the bind."""
    U.clear_scene()
    obj = U.add_cylinder(vertices=vertices, cuts=cuts)
    U.group_where(obj, "bottom", lambda co: co.z < -1.5)
    U.group_where(obj, "top", lambda co: co.z > 1.5)
    api.set_fixed(obj, "bottom")
    empty = U.add_empty("TopEmpty", Matrix.Translation((0, 0, 2.0)))
    api.add_handle(obj, "top", empty)
    empty.location.x += dx
    bpy.context.view_layer.update()
    return obj, empty


def make_good(path, vertices=16, cuts=8, dx=0.6):
    posed_bar(vertices, cuts, dx)
    return _save(path)


def make_animated(path, frames=(1, 5), vertices=16, cuts=8):
    """The handle empty keyframed from x=0.2 at the first frame to x=0.8 at the last."""
    _obj, empty = posed_bar(vertices, cuts, 0.2)
    for f, x in zip(frames, (0.2, 0.8)):
        empty.location.x = x
        empty.keyframe_insert("location", frame=f)
    bpy.context.scene.frame_set(frames[0])
    return _save(path)


def make_rigged(path, frames=(1, 4)):
    """A rigged tube (arap_test_utils.rigged_tube, object "Tube") with Handles from Armature, its last bone
    keyframed from no twist at the first frame to 180 degrees at the last."""
    U.clear_scene()
    obj, rig = U.rigged_tube()
    api.handles_from_armature(obj)
    bone = rig.pose.bones["B2"]
    bone.rotation_mode = 'XYZ'
    for f, angle in zip(frames, (0.0, 3.14159265)):
        bone.rotation_euler = (0.0, angle, 0.0)
        bone.keyframe_insert("rotation_euler", frame=f)
    bpy.context.scene.frame_set(frames[0])
    return _save(path)


def make_missing_empty(path):
    _obj, empty = posed_bar()
    bpy.data.objects.remove(empty)
    return _save(path)


def make_no_settings(path):
    U.clear_scene()
    U.add_cylinder()
    return _save(path)


def make_corrupt(path, size=4096):
    with open(path, "wb") as f:
        f.write(os.urandom(size))
    return path
