# arap-batch with destinations, inputs and numbers it cannot use: refused
# before any work with exit 2 and one line, nothing written, no Blender started,
# inputs untouched; a save that fails on a full disk says so.
import os
import shutil
import stat
import tempfile
import unittest

import bpy

import arap_test_utils as U
import batch_fixtures as F
from batch_fixtures import hashes, run_batch

batch_worker = U.addon("batch_worker")


class BatchHostile(unittest.TestCase):
    def setUp(self):
        self.root = tempfile.mkdtemp(prefix="arap_batch_hostile_")
        self.src = os.path.join(self.root, "in")
        os.makedirs(self.src)
        F.make_good(os.path.join(self.src, "a.blend"))
        self.inputs = hashes(self.src)

    def tearDown(self):
        shutil.rmtree(self.root)

    def assert_refused(self, *args, fragment):
        before = sorted(os.listdir(self.root))
        code, text = run_batch(*args, timeout=60)
        self.assertEqual(code, 2, text)
        self.assertEqual(len(text.strip().splitlines()), 1, text)
        self.assertIn(fragment, text)
        self.assertNotIn("Traceback", text)
        self.assertEqual(sorted(os.listdir(self.root)), before)  # nothing written
        self.assertEqual(hashes(self.src), self.inputs)
        return text

    def test_destinations_are_checked_before_any_work(self):
        existing = os.path.join(self.root, "taken.txt")
        with open(existing, "w") as f:
            f.write("keep me")
        self.assert_refused(self.src, "--output", existing, fragment="exists and is not a folder")
        self.assert_refused(self.src, "--output", os.path.join(self.root, "out"),
                            "--report", os.path.join(self.root, "missing", "r.json"), fragment="does not exist")
        self.assert_refused(self.src, "--output", os.path.join(self.root, "out"), "--report", self.src,
                            fragment="is a folder")
        with open(existing) as f:
            self.assertEqual(f.read(), "keep me")

    def test_numeric_flags_take_finite_numbers_in_range_only(self):
        # Every numeric flag with the spellings nobody means (NaN, Inf, overflow, hex, empty, spaces, digit
        # separators, non-ASCII digits, 5000 digits): exit 2, one line naming the flag and quoting at most 40
        # characters of the value, before any Blender starts (a stand-in Blender notes each start).
        started = os.path.join(self.root, "blender-started")
        blender = os.path.join(self.root, "blender")
        with open(blender, "w") as f:
            f.write('#!/bin/sh\necho "$@" >> %s\nexec %s "$@"\n' % (started, bpy.app.binary_path))
        os.chmod(blender, stat.S_IRWXU)
        out = os.path.join(self.root, "out")
        common = [self.src, "--output", out, "--blender", blender, "--report", os.path.join(self.root, "r.json")]
        flags = [("--jobs", "%s"), ("-j", "%s"), ("--frame", "%s"), ("--max-iterations", "%s"), ("--iterations", "%s"),
                 ("--timeout", "%s"), ("--bake", "%s:10"), ("--bake", "1:%s"), ("--shard", "%s/4"), ("--shard", "0/%s")]
        spellings = ["nan", "inf", "-inf", "1e999", "-1e999", "", "0x10", "0x1p3", " 1", "1 ", "1\n", "1_0", "+-1",
                     "\u0663", "9" * 5000]
        for flag, form in flags:
            zero = flag in ("--jobs", "-j", "--max-iterations", "--iterations", "--timeout")
            for spelling in spellings + ["-0"] * zero:
                value = form % spelling
                with self.subTest(flag=flag, value=value[:50]):
                    text = self.assert_refused(*common, flag, value, fragment=flag)
                    self.assertIn(repr(value[:40]) + ("..." if len(value) > 40 else ""), text)
        self.assert_refused(*common, "--scheduler", "slurm", "--shards", "nan", fragment="--shards")
        self.assert_refused(*common, "--scheduler", "slurm", "--shards", "-0", fragment="--shards")
        # -0 is 0 where 0 is in range (frame 0, a range from frame 0): the run goes on to refuse the next
        # mistake, an --output that is a file.
        taken = os.path.join(self.root, "taken")
        with open(taken, "w") as f:
            f.write("keep me")
        for flag, value in (("--frame", "-0"), ("--bake", "-0:0"), ("--timeout", "1e-3"), ("--frame", "+5")):
            self.assert_refused(self.src, "--output", taken, "--blender", blender, flag, value,
                                fragment="--output %s exists" % taken)
        self.assertFalse(os.path.exists(started))
        # The stand-in does note a start: a good run starts it.
        code, text = run_batch(*common, "--timeout", "60", "--jobs", "1", timeout=300)
        self.assertEqual(code, 0, text)
        self.assertTrue(os.path.exists(started))

    def test_device_input_is_named_as_such(self):
        link = os.path.join(self.root, "zero.blend")  # not in src: hashing it would read forever
        os.symlink("/dev/zero", link)
        self.assert_refused(link, "--output", os.path.join(self.root, "out"), fragment="not a regular file")

    def test_full_disk_says_no_space_left(self):
        blender_said = RuntimeError("Error: Cannot change old file (file saved with @): No such file or directory")
        out = os.path.join(self.root, "out", "a.blend")
        reason = batch_worker.write_failure(out, blender_said, free_bytes=4096)
        self.assertIn("no space left", reason)
        self.assertIn("4096 bytes free", reason)
        # With room to spare the reason is Blender's, naming the file.
        reason = batch_worker.write_failure(out, blender_said, free_bytes=10 ** 10)
        self.assertTrue(reason.startswith("cannot write %s" % out), reason)


if __name__ == "__main__":
    unittest.main()
