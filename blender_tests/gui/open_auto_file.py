# Opening a .blend saved with Auto mode on poses its mesh in Blender's UI with nothing else done
# (the viewport's path: the bind on a thread of its own, the worker's preview, then the final pose
# from the cold start), and that pose is bit for bit the one `blender --background` gives for the
# frame. Runs under `xvfb-run -a -s "-screen 0 1280x800x24"`: python3 open_auto_file.py --blender B --out DIR
import argparse
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
TESTS = os.path.dirname(HERE)

PRELUDE = """
import sys, bpy
sys.path.insert(0, %(tests)r)
import arap_test_utils as U
"""

MAKE = PRELUDE + """
from mathutils import Matrix
assert U.enable_addon() is not None
api = U.addon("api")
U.clear_scene()
obj, empty, _fixed, _top = U.bar_with_handle(vertices=24, cuts=30)
obj.arap.output = 'MESH'
empty.location = (0.9, 0.2, 1.8)
bpy.context.view_layer.update()
obj.arap["auto"] = True   # on, never posed: the file holds the rest shape
bpy.ops.wm.save_as_mainfile(filepath=%(blend)r)
with open(%(rest)r, "wb") as f:
    f.write(U.raw_coords(obj).tobytes())
"""

EXPECT = PRELUDE + """
assert U.enable_addon() is not None
bpy.ops.wm.open_mainfile(filepath=%(blend)r)
scene = bpy.context.scene
scene.frame_set(scene.frame_current)      # --background: Auto poses on the frame change
with open(%(expected)r, "wb") as f:
    f.write(U.raw_coords(bpy.data.objects["Bar"]).tobytes())
"""

IN_THE_UI = PRELUDE + """
import time
assert U.enable_addon() is not None
auto = U.addon("auto")
started = time.monotonic()

def open_file():
    bpy.ops.wm.open_mainfile(filepath=%(blend)r)
    return None

def poll():
    obj = bpy.data.objects.get("Bar")
    status = auto.status(obj) if obj is not None else ""
    if status.startswith("settled"):
        with open(%(shown)r, "wb") as f:
            f.write(U.raw_coords(obj).tobytes())
    elif time.monotonic() - started < 300:
        return 0.1
    print("Auto status after opening: %%r" %% status, flush=True)
    bpy.ops.wm.quit_blender()
    return None

bpy.app.timers.register(open_file, first_interval=1.0)
bpy.app.timers.register(poll, first_interval=1.5, persistent=True)
"""


def blender(args, cmd, timeout=600):
    proc = subprocess.run([args.blender, "--factory-startup", "-noaudio"] + cmd, capture_output=True, text=True,
                          timeout=timeout)
    log = proc.stdout + proc.stderr
    if proc.returncode != 0 or "Traceback" in log:
        sys.exit("FAIL: %s\n%s" % (" ".join(cmd), log[-3000:]))
    return log


def script(args, name, text, **paths):
    path = os.path.join(args.out, name)
    with open(path, "w") as f:
        f.write(text % dict(paths, tests=TESTS))
    return path


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--blender", required=True)
    p.add_argument("--out", required=True)
    args = p.parse_args()
    os.makedirs(args.out, exist_ok=True)
    paths = {name: os.path.join(args.out, name) for name in ("auto.blend", "rest.bin", "expected.bin", "shown.bin")}
    for path in paths.values():
        if os.path.exists(path):
            os.remove(path)
    files = dict(blend=paths["auto.blend"], rest=paths["rest.bin"], expected=paths["expected.bin"],
                 shown=paths["shown.bin"])
    blender(args, ["--background", "--python-exit-code", "1", "--python", script(args, "make.py", MAKE, **files)])
    blender(args, ["--background", "--python-exit-code", "1", "--python",
                   script(args, "expect.py", EXPECT, **files)])
    log = blender(args, ["--window-geometry", "0", "0", "1280", "800", "--python",
                         script(args, "in_the_ui.py", IN_THE_UI, **files)])
    if not os.path.exists(paths["shown.bin"]):
        sys.exit("FAIL: the opened file's mesh was never posed in the UI\n" + log[-2000:])
    rest, expected, shown = (open(paths[n], "rb").read() for n in ("rest.bin", "expected.bin", "shown.bin"))
    if expected == rest:
        sys.exit("FAIL: the handle's move does not pose the bar in --background")
    if shown != expected:
        sys.exit("FAIL: the pose shown after opening differs from --background's")
    print("opened with Auto on: posed in the UI, the same bits as --background")


if __name__ == "__main__":
    main()
