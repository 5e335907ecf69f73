# arap-batch runs from the source tree (addon/arap-batch, `python3 -m arap_batch`) as
# from the build tree: help, the add-on it defaults to, and a real batch over one .blend.
import json
import os
import shutil
import subprocess
import tempfile
import unittest

import bpy
import numpy as np

import arap_test_utils as U
import batch_fixtures as S

PYTHON = "/usr/bin/python3" if os.path.exists("/usr/bin/python3") else shutil.which("python3")
SOURCE = os.path.realpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "addon"))
STAGED = os.path.dirname(os.path.realpath(U.addon().__file__))    # <build>/addon/arap_deform
BUILD = os.path.dirname(os.path.dirname(STAGED))


def run(args, cwd=None, timeout=300):
    p = subprocess.run([PYTHON] + [str(a) for a in args], capture_output=True, text=True, cwd=cwd,
                       timeout=timeout)
    return p.returncode, p.stdout + p.stderr


def defaults(tree):
    """(default add-on folder, launcher script of the Slurm tasks) of the arap_batch package in `tree`."""
    code, out = run(["-c", "import arap_batch.cli as c; print(c.default_addon_dir()); print(c.LAUNCHER)"],
                    cwd=tree)
    assert code == 0, out
    return out.split()


class Launcher(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="arap_launcher_")

    def tearDown(self):
        shutil.rmtree(self.tmp, ignore_errors=True)

    def test_help_from_the_source_tree(self):
        for args in ([os.path.join(SOURCE, "arap-batch"), "--help"], ["-m", "arap_batch", "--help"]):
            code, out = run(args, cwd=SOURCE if args[0] == "-m" else self.tmp)
            self.assertEqual(code, 0, out)
            self.assertIn("usage: arap-batch", out)
            self.assertIn("--addon-dir", out)

    def test_each_tree_finds_its_add_on_and_script(self):
        self.assertEqual(defaults(SOURCE), [os.path.join(SOURCE, "arap_deform"), os.path.join(SOURCE, "arap-batch")])
        self.assertEqual(defaults(BUILD), [STAGED, os.path.join(BUILD, "arap-batch")])
        for tree in (SOURCE, BUILD):
            self.assertTrue(os.access(os.path.join(tree, "arap-batch"), os.X_OK), tree)

    def test_iterations_limit_is_the_solvers(self):
        # The launcher checks --max-iterations in plain Python 3, without the native module, against its own copy of
        # the limit: that copy must be the native option table's max_iterations maximum, in both trees.
        limit = U.addon("native_loader").native().OPTIONS["max_iterations"]["max"]
        for tree in (SOURCE, BUILD):
            code, out = run(["-c", "import arap_batch.cli as c; print(c.MAX_ITERATIONS)"], cwd=tree)
            self.assertEqual(code, 0, out)
            self.assertEqual(int(out), limit, tree)

    def parsed_cap(self, *args):
        """max_iterations as the launcher parses `args` (after its own checks), in plain Python 3."""
        code, out = run(["-c", "import sys, arap_batch.cli as c; print(c.parse_args(sys.argv[1:]).max_iterations)",
                         *args, "--addon-dir", STAGED, "--blender", bpy.app.binary_path], cwd=BUILD)
        self.assertEqual(code, 0, out)
        return int(out.split()[-1])

    def test_max_iterations_and_its_short_form(self):
        blend = S.make_good(os.path.join(self.tmp, "a.blend"))
        out = os.path.join(self.tmp, "out")
        self.assertEqual(self.parsed_cap(blend, "--output", out, "--max-iterations", 7), 7)
        self.assertEqual(self.parsed_cap(blend, "--output", out, "--iterations", 8), 8)
        code, text = run(["-m", "arap_batch", "--help"], cwd=SOURCE)
        # Python 3.13's argparse names the metavar once: "--max-iterations, --iterations N".
        self.assertRegex(text, r"--max-iterations( N)?, --iterations N")
        self.assertIn("--iterations is accepted as the short form", " ".join(text.split()))
        # A worker given the short form by hand (one file) takes it too.
        job = U.addon("batch_worker").parse_job(["--input", blend, "--output", blend, "--iterations", "9"])
        self.assertEqual(job["max_iterations"], 9)

    def test_rerun_of_an_older_report_keeps_its_iterations(self):
        blend = S.make_good(os.path.join(self.tmp, "a.blend"))
        report = os.path.join(self.tmp, "old.json")
        mode = {"frame": 1, "bake": None, "bake_format": "shapekeys", "iterations": 12, "objects": [],
                "in_place": False, "output_dir": os.path.join(self.tmp, "out")}
        with open(report, "w", encoding="utf-8") as f:
            json.dump({"arap_batch": 1, "mode": mode, "run": {"scheduler": "local"},
                       "files": [{"input": blend, "output": os.path.join(self.tmp, "out", "a.blend"),
                                  "status": "failed"}]}, f)
        self.assertEqual(self.parsed_cap("--rerun-failed", report), 12)

    def test_source_add_on_without_module_is_a_usage_error(self):
        blend = S.make_good(os.path.join(self.tmp, "a.blend"))
        code, out = run([os.path.join(SOURCE, "arap-batch"), blend, "--output", os.path.join(self.tmp, "out"),
                         "--blender", bpy.app.binary_path])
        self.assertEqual(code, 2, out)
        self.assertIn("has no native module", out)
        self.assertIn("--addon-dir", out)
        self.assertFalse(os.path.exists(os.path.join(self.tmp, "out")))

    def test_batch_from_the_source_tree(self):
        src, out = os.path.join(self.tmp, "in"), os.path.join(self.tmp, "out")
        os.makedirs(src)
        blend = S.make_good(os.path.join(src, "shot.blend"), dx=0.4)
        report = os.path.join(self.tmp, "report.json")
        code, text = run([os.path.join(SOURCE, "arap-batch"), src, "--output", out, "--jobs", 1, "--frame", 1,
                          "--addon-dir", STAGED, "--blender", bpy.app.binary_path, "--report", report])
        self.assertEqual(code, 0, text)
        with open(report) as f:
            r = json.load(f)
        self.assertEqual((r["ok"], r["failed"]), (1, 0), text)
        self.assertEqual(r["files"][0]["output"], os.path.join(out, "shot.blend"))
        self.assertEqual(sorted(os.listdir(out)), ["shot.blend"])
        moved = np.linalg.norm(self.coords(os.path.join(out, "shot.blend")) - self.coords(blend), axis=1)
        self.assertAlmostEqual(moved.max(), 0.4, places=4)   # the handle's Empty moved by 0.4

    def coords(self, path, name="Bar"):
        with bpy.data.libraries.load(path, link=False) as (_src, dst):
            dst.objects = [name]
        obj = dst.objects[0]
        co = U.coords(obj)
        mesh = obj.data
        bpy.data.objects.remove(obj)
        bpy.data.meshes.remove(mesh)
        return co


if __name__ == "__main__":
    unittest.main()
