# The add-on's life in a user's Blender, from the zip a user downloads:
# check, install, enable, pose, disable, uninstall, with nothing left behind
# and no traceback at any step. Runs with any Python 3 (it only starts Blender):
#
#   python3 extension_lifecycle.py --blender blender --zip build/arap_deform.zip --scratch build/.../lifecycle
#
# Every Blender run gets its own user folders under --scratch (BLENDER_USER_*),
# so the user's real preferences and extensions are never read or written.
#   Blender 4.2+: `blender --command extension validate`, then two installs:
#     1. `--command extension install-file -r user_default -e`, pose in a new
#        Blender, `--command extension remove`;
#     2. Install from Disk (bpy.ops.extensions.package_install_files, what the
#        Preferences button runs), pose, uninstall (package_uninstall).
#   Blender 3.x: Install... (preferences.addon_install), enable, pose in a new
#   Blender, disable and remove (preferences.addon_remove).
# Every pose also checks that the enabled add-on's modules sit only under its own
# name and, on 4.2+, that Blender lists no policy warning for the extension (what
# the Preferences would show under a warning sign).
import argparse
import os
import re
import shutil
import subprocess
import sys
import zipfile

HERE = os.path.dirname(os.path.abspath(__file__))
POSE_SCRIPT = os.path.join(HERE, "lifecycle_pose.py")


class Fail(Exception):
    pass


class Lifecycle:
    def __init__(self, blender, zip_path, scratch):
        self.blender = blender
        self.zip = os.path.abspath(zip_path)
        self.scratch = os.path.abspath(scratch)
        self.version = self._version()
        self.steps = 0

    def _version(self):
        out = subprocess.run([self.blender, "--version"], capture_output=True, text=True, timeout=120).stdout
        m = re.search(r"Blender (\d+)\.(\d+)", out)
        if not m:
            raise Fail("cannot read the Blender version from: %s" % out[:300])
        return int(m.group(1)), int(m.group(2))

    def fresh_user(self, name):
        """Empty user folders for one scenario; returns the environment."""
        root = os.path.join(self.scratch, name)
        shutil.rmtree(root, ignore_errors=True)
        os.makedirs(root)
        env = dict(os.environ)
        # A pyenv/virtualenv Python first on PATH (or PYTHONHOME/PYTHONPATH) can make
        # Blender's embedded Python pick the wrong prefix and miss numpy.
        env["PATH"] = os.pathsep.join(p for p in env.get("PATH", "").split(os.pathsep)
                                      if "pyenv" not in p and "virtualenv" not in p)
        for name in ("PYTHONHOME", "PYTHONPATH", "VIRTUAL_ENV"):
            env.pop(name, None)
        env.update({"BLENDER_USER_RESOURCES": root,
                    "BLENDER_USER_CONFIG": os.path.join(root, "config"),
                    "BLENDER_USER_SCRIPTS": os.path.join(root, "scripts"),
                    "BLENDER_USER_EXTENSIONS": os.path.join(root, "extensions"),
                    "PYTHONDONTWRITEBYTECODE": "1"})
        self.env, self.root = env, root
        return root

    def run(self, what, args, expect="", timeout=300):
        """Run Blender; fail on a non-zero exit, a traceback, or a missing `expect` line."""
        self.steps += 1
        cmd = [self.blender, *args]
        proc = subprocess.run(cmd, env=self.env, capture_output=True, text=True, errors="replace", timeout=timeout)
        out = proc.stdout + proc.stderr
        log = os.path.join(self.root, "step%02d.log" % self.steps)
        with open(log, "w") as f:
            f.write("$ %s\n%s" % (" ".join(cmd), out))
        if proc.returncode != 0:
            raise Fail("%s: exit %d (log %s)\n%s" % (what, proc.returncode, log, out[-3000:]))
        if "Traceback" in out:
            raise Fail("%s: a traceback in Blender's output (log %s)\n%s" % (what, log, out[-3000:]))
        if expect and expect not in out:
            raise Fail("%s: '%s' not printed (log %s)\n%s" % (what, expect, log, out[-3000:]))
        print("ok   %s" % what)
        return out

    def pose(self, what, module, factory=False):
        args = ["--background", "-noaudio"] + (["--factory-startup"] if factory else []) + [
            "--python-exit-code", "1", "--python", POSE_SCRIPT, "--", "pose", module]
        self.run(what, args, expect="LIFECYCLE POSE OK")

    def script(self, what, *script_args, expect):
        self.run(what, ["--background", "-noaudio", "--python-exit-code", "1", "--python", POSE_SCRIPT, "--",
                        *script_args], expect=expect)

    def assert_gone(self, folder):
        if os.path.exists(folder):
            left = sorted(os.listdir(folder))
            raise Fail("uninstall left %s behind: %s" % (folder, left))
        print("ok   nothing left in %s" % os.path.relpath(folder, self.scratch))

    def assert_declares_file_access(self):
        """The bake and batch write files: the manifest says so (the extensions platform asks for it)."""
        with zipfile.ZipFile(self.zip) as archive:
            name = next(n for n in archive.namelist() if n.endswith("blender_manifest.toml"))
            manifest = archive.read(name).decode()
        # A `[permissions]` table with a `files` reason (tomllib is not in every Python this runs with).
        table = re.search(r"^\[permissions\]\s*$(.*?)(^\[|\Z)", manifest, re.M | re.S)
        if table is None or not re.search(r'^files\s*=\s*"[^"]+"', table.group(1), re.M):
            raise Fail("the manifest declares no files permission:\n" + manifest)
        print("ok   the manifest declares file access")

    def extension(self):
        ext_dir = lambda: os.path.join(self.root, "extensions", "user_default", "arap_deform")  # noqa: E731
        module = "bl_ext.user_default.arap_deform"

        self.fresh_user("validate")
        self.run("extension validate", ["--command", "extension", "validate", self.zip])
        self.assert_declares_file_access()

        self.fresh_user("command_line")
        self.run("extension install-file", ["--command", "extension", "install-file", "-r", "user_default", "-e",
                                            self.zip])
        if not os.path.isfile(os.path.join(ext_dir(), "blender_manifest.toml")):
            raise Fail("install-file did not unpack into %s" % ext_dir())
        self.pose("enabled at start-up, poses (install-file)", module)
        self.run("extension remove", ["--command", "extension", "remove", "user_default.arap_deform"])
        self.assert_gone(ext_dir())
        self.script("not enabled after remove", "absent", module, expect="LIFECYCLE ABSENT OK")

        self.fresh_user("install_from_disk")
        self.script("Install from Disk, enable, pose, uninstall", "install-from-disk", self.zip,
                    expect="LIFECYCLE INSTALL FROM DISK OK")
        self.assert_gone(ext_dir())
        self.script("not enabled after uninstall", "absent", module, expect="LIFECYCLE ABSENT OK")

    def legacy(self):
        addon_dir = lambda: os.path.join(self.root, "scripts", "addons", "arap_deform")  # noqa: E731
        self.fresh_user("legacy")
        self.script("Install..., enable, save preferences", "legacy-install", self.zip,
                    expect="LIFECYCLE LEGACY INSTALL OK")
        self.pose("enabled at start-up, poses", "arap_deform")
        self.script("disable and remove", "legacy-remove", expect="LIFECYCLE LEGACY REMOVE OK")
        self.assert_gone(addon_dir())
        self.script("not enabled after remove", "absent", "arap_deform", expect="LIFECYCLE ABSENT OK")

    def main(self):
        print("Blender %d.%d, zip %s" % (*self.version, self.zip))
        if self.version >= (4, 2):
            self.extension()
        else:
            self.legacy()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--blender", default="blender")
    ap.add_argument("--zip", required=True)
    ap.add_argument("--scratch", required=True)
    args = ap.parse_args()
    try:
        Lifecycle(args.blender, args.zip, args.scratch).main()
    except (Fail, subprocess.TimeoutExpired) as exc:
        print("LIFECYCLE FAILED:", exc)
        sys.exit(1)
    print("LIFECYCLE OK")


main()
