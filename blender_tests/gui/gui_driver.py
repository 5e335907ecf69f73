# Driving a real Blender window under Xvfb (drive_gui.py, the GUI suite;
# bench/blender/measure_live_lag.py, the Live latency measurement): start Blender with its
# UI and a session script, read the state it writes (state.json), send it
# commands (cmd_* files) and real X input (xdotool), take screenshots.
import json
import os
import shutil
import subprocess
import time

HERE = os.path.dirname(os.path.abspath(__file__))
WINDOW_WIDTH, WINDOW_HEIGHT = 1280, 800   # the Xvfb screen of blender_tests/CMakeLists.txt


class Fail(Exception):
    pass


class Gui:
    def __init__(self, blender, out, session_script, *script_args):
        """Blender with its UI running `session_script` (in this folder) with `out` and `script_args`."""
        self.out = out
        self.drags = 0
        self.during_drag = {}
        shutil.rmtree(out, ignore_errors=True)
        os.makedirs(out)
        self.log = open(os.path.join(out, "blender.log"), "w")
        # A pyenv/virtualenv python first on PATH can make Blender's embedded
        # Python pick the wrong prefix (no numpy): drop those PATH entries.
        env = dict(os.environ)
        env["PATH"] = os.pathsep.join(p for p in env.get("PATH", "").split(os.pathsep)
                                      if "pyenv" not in p and "virtualenv" not in p)
        self.proc = subprocess.Popen(
            [blender, "--factory-startup", "-noaudio", "--window-geometry", "0", "0", str(WINDOW_WIDTH), str(WINDOW_HEIGHT),
             "--python", os.path.join(HERE, session_script), "--", out, *script_args],
            stdout=self.log, stderr=subprocess.STDOUT, env=env)

    def state(self):
        try:
            with open(os.path.join(self.out, "state.json")) as f:
                return json.load(f)
        except (OSError, ValueError):
            return {}

    def wait(self, what, pred, timeout=90.0):
        end = time.time() + timeout
        while time.time() < end:
            if self.proc.poll() is not None:
                raise Fail("Blender exited (code %s) while waiting for %s" % (self.proc.returncode, what))
            s = self.state()
            if s.get("errors"):
                raise Fail("Blender-side error:\n" + "\n".join(s["errors"]))
            if s and pred(s):
                return s
            time.sleep(0.2)
        raise Fail("timed out waiting for %s; last state: %s" % (what, json.dumps(self.state())[:2000]))

    def settle(self, ticks=3, timeout=90.0):
        """Wait until Blender's event loop has run `ticks` more times."""
        start = self.state().get("tick", 0)
        return self.wait("Blender to handle the input", lambda s: s.get("tick", 0) >= start + ticks, timeout)

    def command(self, name, arg=""):
        with open(os.path.join(self.out, name), "w") as f:
            f.write(arg)

    def xdo(self, *args):
        subprocess.run(["xdotool", *args], check=True)

    def shot(self, name):
        subprocess.run(["import", "-window", "root", os.path.join(self.out, name)], check=False)

    def drag_with_g(self, centre, dx, dy, follows):
        """G, move the pointer in small steps, check `follows(state)` while the
        transform runs, then click to confirm. G is pressed again if the
        first press was lost (the empty never moved)."""
        x, y = centre
        before = self.state()["empty_location"]
        for attempt in (1, 2):
            self.xdo("mousemove", str(x), str(y))
            self.settle()
            self.xdo("key", "g")
            self.settle()
            for i in range(1, 11):  # small steps: Blender sees a continuous motion
                self.xdo("mousemove", str(x + dx * i // 10), str(y + dy * i // 10))
                self.settle(1)
            try:
                self.wait("the empty to follow the pointer (G)",
                          lambda s: moved(s["empty_location"], before) > 0.05, timeout=30 * attempt)
                break
            except Fail:
                if attempt == 2:
                    raise
                self.xdo("key", "Escape")  # whatever took the key, leave it
                self.settle()
        self.during_drag = self.wait("the mesh to follow during the drag", follows)
        self.drags += 1
        self.shot("during_drag_%d.png" % self.drags)
        self.xdo("click", "1")
        self.settle()

    def quit(self):
        if self.proc.poll() is None:
            self.command("cmd_quit")
            try:
                self.proc.wait(15)
            except subprocess.TimeoutExpired:
                self.proc.kill()


def moved(a, b):
    return sum((x - y) ** 2 for x, y in zip(a, b)) ** 0.5
