# arap-batch with destinations and inputs it cannot use: refused
# before any work with exit 2 and one line, nothing written, inputs untouched;
# a save that fails on a full disk says so.
import os
import shutil
import tempfile
import unittest

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
