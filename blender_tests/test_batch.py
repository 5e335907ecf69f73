# arap-batch end to end: the launcher (plain python3) runs Blender workers on
# .blend files this test generates; report, exit code, outputs, inputs untouched,
# --in-place, a crashing worker, Ctrl-C, --bake, and what a farm uses: --shard,
# merge-reports, --rerun-failed, --files-from, --results-log (Slurm itself: test_slurm.py).
#
# The launcher and the files come from batch_fixtures.py.
import json
import os
import shutil
import signal
import subprocess
import tempfile
import time
import unittest

import bpy
import numpy as np

import arap_test_utils as U
import batch_fixtures as F
from batch_fixtures import (LAUNCHER, PYTHON, blender_env, hashes, load_object, patched_blender, run_batch, running, sha,
                            temp_leftovers)

bake = U.addon("bake")


class Batch(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        assert os.path.isfile(LAUNCHER), "launcher not found: %s" % LAUNCHER
        cls.root = tempfile.mkdtemp(prefix="arap_batch_")

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.root, ignore_errors=True)

    def folder(self, name):
        d = os.path.join(self.root, self._testMethodName, name)
        os.makedirs(d)
        return d

    def test_end_to_end_with_failures(self):
        src, out = self.folder("in"), self.folder("out")
        for k in range(3):
            F.make_good(os.path.join(src, "good%d.blend" % k), dx=0.3 + 0.2 * k)
        F.make_corrupt(os.path.join(src, "corrupt.blend"))
        F.make_missing_empty(os.path.join(src, "no_empty.blend"))
        F.make_no_settings(os.path.join(src, "no_settings.blend"))
        before = hashes(src)
        report = os.path.join(self.root, "e2e.json")
        code, text = run_batch(src, "--output", out, "--jobs", 2, "--frame", 1, "--report", report)
        self.assertEqual(code, 1, text)
        self.assertEqual(hashes(src), before)  # inputs byte-identical
        self.assertIn("6 file(s): 3 ok, 3 failed", text)
        for name in ("corrupt.blend", "no_empty.blend", "no_settings.blend"):
            self.assertIn("failed: %s" % os.path.join(src, name), text)
        with open(report) as f:
            r = json.load(f)
        self.assertEqual((r["ok"], r["failed"], r["interrupted"]), (3, 3, False))
        by_name = {os.path.basename(f["input"]): f for f in r["files"]}
        self.assertIn("cannot open", by_name["corrupt.blend"]["reason"])
        self.assertIn("no empty", by_name["no_empty.blend"]["reason"])
        self.assertIn("no mesh object has ARAP settings", by_name["no_settings.blend"]["reason"])
        for k in range(3):
            f = by_name["good%d.blend" % k]
            self.assertEqual((f["status"], f["reason"]), ("ok", ""))
            self.assertEqual(f["output"], os.path.join(out, "good%d.blend" % k))
            self.assertEqual(f["objects"][0]["name"], "Bar")
            self.assertGreater(f["ms"], 0)
            posed, _keys, _mods = load_object(f["output"])
            rest, _keys, _mods = load_object(f["input"])
            moved = np.linalg.norm(posed - rest, axis=1)
            self.assertAlmostEqual(moved.max(), 0.3 + 0.2 * k, places=4)  # the handle moved by dx
        self.assertEqual(sorted(os.listdir(out)), ["good0.blend", "good1.blend", "good2.blend"])
        self.assertEqual(temp_leftovers(src, out), [])

    def test_usage_errors_exit_2(self):
        src = self.folder("in")
        F.make_good(os.path.join(src, "a.blend"))
        self.assertEqual(run_batch(src)[0], 2)                                  # no --output
        self.assertEqual(run_batch(src, "--output", src)[0], 2)                 # would overwrite inputs
        self.assertEqual(run_batch(src, "--output", src + "x", "--bake", "5:1")[0], 2)
        self.assertEqual(run_batch(os.path.join(src, "missing.blend"), "--in-place")[0], 2)

    def test_in_place(self):
        src = self.folder("in")
        path = F.make_good(os.path.join(src, "a.blend"))
        before = sha(path)
        code, text = run_batch(path, "--in-place", "--jobs", 1)
        self.assertEqual(code, 0, text)
        self.assertNotEqual(sha(path), before)
        self.assertEqual(os.listdir(src), ["a.blend"])  # no temp file, no .blend1
        posed, _k, _m = load_object(path)
        self.assertGreater(posed[:, 0].max(), 0.5 + 0.5)  # radius 0.5 + the handle's dx 0.6

    def test_crashed_worker_is_restarted(self):
        src, out = self.folder("in"), self.folder("out")
        for name in ("a", "b_crash", "c", "d"):
            F.make_good(os.path.join(src, name + ".blend"))
        # A Blender whose worker segfaults on files named *b_crash*.
        wrapper = patched_blender(self.root, "crashing-blender",
                                  "'b_crash' in e['input'] and os.kill(os.getpid(), signal.SIGSEGV)")
        report = os.path.join(self.root, "crash.json")
        code, text = run_batch(src, "--output", out, "--jobs", 1, "--blender", wrapper, "--report", report)
        self.assertEqual(code, 1, text)
        with open(report) as f:
            files = {os.path.basename(x["input"]): x for x in json.load(f)["files"]}
        self.assertEqual(files["b_crash.blend"]["status"], "failed")
        self.assertIn("worker crashed", files["b_crash.blend"]["reason"])
        for name in ("a", "c", "d"):
            self.assertEqual(files[name + ".blend"]["status"], "ok", text)
        self.assertEqual(sorted(os.listdir(out)), ["a.blend", "c.blend", "d.blend"])
        self.assertEqual(temp_leftovers(out), [])

    def test_timeout_fails_the_file_and_goes_on(self):
        src, out = self.folder("in"), self.folder("out")
        for name in ("a", "b_slow", "c"):
            F.make_good(os.path.join(src, name + ".blend"))
        wrapper = patched_blender(self.root, "slow-blender", "'b_slow' in e['input'] and time.sleep(120)")
        report = os.path.join(self.root, "timeout.json")
        code, text = run_batch(src, "--output", out, "--jobs", 1, "--blender", wrapper, "--timeout", 4,
                               "--report", report)
        self.assertEqual(code, 1, text)
        with open(report) as f:
            files = {os.path.basename(x["input"]): x for x in json.load(f)["files"]}
        self.assertEqual(files["b_slow.blend"]["reason"], "timed out after 4 s")
        self.assertEqual((files["a.blend"]["status"], files["c.blend"]["status"]), ("ok", "ok"), text)
        self.assertEqual(sorted(os.listdir(out)), ["a.blend", "c.blend"])

    def test_named_objects(self):
        src, out = self.folder("in"), self.folder("out")
        path = F.make_good(os.path.join(src, "a.blend"))
        code, text = run_batch(path, "--output", out, "--objects", "Bar")
        self.assertEqual(code, 0, text)
        report = os.path.join(self.root, "objects.json")
        code, text = run_batch(path, "--output", out, "--objects", "Bar", "Nope", "--report", report)
        self.assertEqual(code, 1, text)
        with open(report) as f:
            self.assertEqual(json.load(f)["files"][0]["reason"], "object(s) not found in the scene: Nope")

    def test_worker_alone_for_one_file(self):
        # What a farm task runs: one Blender, one file, exit code = result.
        src, out = self.folder("in"), self.folder("out")
        good = F.make_good(os.path.join(src, "a.blend"))
        bad = F.make_no_settings(os.path.join(src, "b.blend"))
        addon = os.path.dirname(os.path.realpath(U.addon().__file__))
        expr = ("import sys; sys.path.insert(0, %r); from arap_deform import batch_worker; batch_worker.main()"
                % os.path.dirname(addon))
        codes = []
        for inp in (good, bad):
            p = subprocess.run([bpy.app.binary_path, "--background", "--factory-startup", "-noaudio",
                                "--python-exit-code", "1", "--python-expr", expr, "--", "--input", inp,
                                "--output", os.path.join(out, os.path.basename(inp)), "--frame", "1"],
                               capture_output=True, text=True, timeout=120, env=blender_env())
            codes.append(p.returncode)
            lines = [l for l in p.stdout.splitlines() if l.startswith("@arap-batch ")]
            self.assertEqual([json.loads(l[12:])["event"] for l in lines], ["start", "result"])
        self.assertEqual(codes, [0, 1])
        self.assertEqual(os.listdir(out), ["a.blend"])

    def test_sigint_leaves_inputs_and_finished_outputs(self):
        src, out = self.folder("in"), self.folder("out")
        # Enough files that the run is surely still going when the signal lands, even on a loaded machine.
        for k in range(30):
            F.make_good(os.path.join(src, "f%02d.blend" % k), vertices=64, cuts=120)
        before = hashes(src)
        report = os.path.join(self.root, "sigint.json")
        p = subprocess.Popen([PYTHON, LAUNCHER, src, "--output", out, "--jobs", "1", "--report", report],
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        lines = []
        for line in p.stdout:
            lines.append(line)
            if line.startswith("[1/30] ok"):
                p.send_signal(signal.SIGINT)
                break
        rest = p.communicate(timeout=60)[0]
        text = "".join(lines) + rest
        self.assertEqual(p.returncode, 130, text)
        self.assertEqual(hashes(src), before)
        self.assertEqual(temp_leftovers(src, out), [])
        with open(report) as f:
            r = json.load(f)
        self.assertTrue(r["interrupted"])
        done = [f for f in r["files"] if f["status"] == "ok"]
        self.assertGreaterEqual(len(done), 1)
        self.assertLess(len(done), 30)
        self.assertEqual(sorted(os.listdir(out)), sorted(os.path.basename(f["output"]) for f in done))
        for f in done:  # every finished output is a whole, readable .blend
            posed, _k, _m = load_object(f["output"])
            self.assertGreater(posed[:, 0].max(), 1.0)

    def test_shards_merge_to_the_unsharded_run(self):
        src, out_all, out_sharded = self.folder("in"), self.folder("all"), self.folder("sharded")
        for k in range(3):
            F.make_good(os.path.join(src, "good%d.blend" % k), dx=0.3 + 0.2 * k)
        F.make_corrupt(os.path.join(src, "corrupt.blend"))
        F.make_missing_empty(os.path.join(src, "no_empty.blend"))
        names = sorted(os.listdir(src))
        whole = os.path.join(self.root, "whole.json")
        self.assertEqual(run_batch(src, "--output", out_all, "--jobs", 1, "--frame", 1, "--report", whole)[0], 1)
        parts, codes = [], []
        for k in range(2):
            parts.append(os.path.join(self.root, "shard-%d.json" % k))
            code, text = run_batch(src, "--output", out_sharded, "--jobs", 1, "--frame", 1, "--shard", "%d/2" % k,
                                   "--report", parts[-1])
            codes.append(code)
            with open(parts[-1]) as f:
                r = json.load(f)
            self.assertEqual(r["shard"], [k, 2])
            self.assertEqual([os.path.basename(x["input"]) for x in r["files"]], names[k::2])
        # shard 0: corrupt, good1, no_empty -> 1; shard 1: good0, good2 -> 0 (exit codes of those files alone)
        self.assertEqual(codes, [1, 0])
        self.assertEqual(sorted(os.listdir(out_sharded)), sorted(os.listdir(out_all)))
        for name in os.listdir(out_all):
            self.assertTrue(np.array_equal(load_object(os.path.join(out_sharded, name))[0],
                                           load_object(os.path.join(out_all, name))[0]), name)

        merged = os.path.join(self.root, "merged.json")
        code, text = run_batch("merge-reports", *parts, "--report", merged)
        self.assertEqual(code, 1, text)
        self.assertIn("5 file(s): 3 ok, 2 failed", text)
        with open(whole) as f:
            expected = {os.path.basename(x["input"]): (x["status"], x["reason"]) for x in json.load(f)["files"]}
        with open(merged) as f:
            m = json.load(f)
        self.assertEqual({os.path.basename(x["input"]): (x["status"], x["reason"]) for x in m["files"]}, expected)
        self.assertEqual((m["ok"], m["failed"], m.get("missing_shards")), (3, 2, None))
        # A shard's report left out: the merge says so and does not pass.
        code, text = run_batch("merge-reports", parts[1], "--report", merged)
        self.assertEqual(code, 1, text)
        self.assertIn("missing: the report of shard 0/2", text)
        # Reports of runs with other settings do not merge.
        other = os.path.join(self.root, "other.json")
        run_batch(src, "--output", out_sharded, "--jobs", 1, "--frame", 2, "--shard", "0/2", "--report", other)
        code, text = run_batch("merge-reports", parts[1], other, "--report", merged)
        self.assertEqual(code, 2, text)
        self.assertIn("different settings (frame 1 vs 2)", text)

    def test_empty_shard_and_shard_usage_errors(self):
        src, out = self.folder("in"), self.folder("out")
        F.make_good(os.path.join(src, "a.blend"))
        report = os.path.join(self.root, "empty-shard.json")
        code, text = run_batch(src, "--output", out, "--shard", "1/2", "--report", report)
        self.assertEqual(code, 0, text)
        self.assertIn("0 file(s): 0 ok, 0 failed", text)
        with open(report) as f:
            self.assertEqual(json.load(f)["files"], [])
        self.assertEqual(os.listdir(out), [])
        for bad in ("2/2", "1", "-1/2", "a/b"):
            self.assertEqual(run_batch(src, "--output", out, "--shard", bad)[0], 2, bad)
        self.assertEqual(run_batch(src, "--output", out, "--shards", 2)[0], 2)             # only with slurm
        self.assertEqual(run_batch(src, "--output", out, "--scheduler", "slurm")[0], 2)    # needs --report
        self.assertEqual(run_batch("merge-reports", os.path.join(src, "a.blend"), "--report", report)[0], 2)

    def test_rerun_failed_runs_only_those_and_updates_the_report(self):
        src, out = self.folder("in"), self.folder("out")
        for name in ("a", "b"):
            F.make_good(os.path.join(src, name + ".blend"))
        F.make_missing_empty(os.path.join(src, "c.blend"))
        listed = os.path.join(self.root, "list.txt")
        with open(listed, "w") as f:
            f.write("# the shots\n%s\n\n%s\n" % (os.path.join(src, "a.blend"), os.path.join(src, "c.blend")))
        report = os.path.join(self.root, "rerun.json")
        code, text = run_batch(os.path.join(src, "b.blend"), "--files-from", listed, "--output", out, "--jobs", 1,
                               "--frame", 1, "--report", report)
        self.assertEqual(code, 1, text)
        self.assertIn("3 file(s): 2 ok, 1 failed", text)
        done = {f: os.stat(os.path.join(out, f)).st_mtime_ns for f in os.listdir(out)}
        self.assertEqual(sorted(done), ["a.blend", "b.blend"])
        code, text = run_batch("--rerun-failed", report, "--frame", 2)
        self.assertEqual(code, 2, text)                       # settings come from the report
        self.assertIn("drop --frame", text)

        F.make_good(os.path.join(src, "c.blend"))             # the shot is fixed
        code, text = run_batch("--rerun-failed", report)
        self.assertEqual(code, 0, text)
        self.assertIn("1 file(s): 1 ok, 0 failed", text)
        with open(report) as f:
            r = json.load(f)
        self.assertEqual((r["ok"], r["failed"], len(r["files"])), (3, 0, 3))
        self.assertEqual(r["mode"]["frame"], 1)
        for name, mtime in done.items():
            self.assertEqual(os.stat(os.path.join(out, name)).st_mtime_ns, mtime, name)
        self.assertEqual(sorted(os.listdir(out)), ["a.blend", "b.blend", "c.blend"])
        code, text = run_batch("--rerun-failed", report)
        self.assertEqual(code, 0, text)
        self.assertIn("Nothing to rerun", text)

    def test_listed_file_that_is_missing_fails_alone(self):
        src, out = self.folder("in"), self.folder("out")
        F.make_good(os.path.join(src, "a.blend"))
        listed = os.path.join(self.root, "missing-list.txt")
        with open(listed, "w") as f:
            f.write("%s\n%s\n" % (os.path.join(src, "a.blend"), os.path.join(src, "gone.blend")))
        results = os.path.join(self.root, "results.jsonl")
        code, text = run_batch("--files-from", listed, "--output", out, "--results-log", results)
        self.assertEqual(code, 1, text)
        self.assertIn("failed: %s: input file not found" % os.path.join(src, "gone.blend"), text)
        with open(results) as f:
            lines = [json.loads(l) for l in f]
        self.assertEqual(sorted((os.path.basename(x["input"]), x["status"]) for x in lines),
                         [("a.blend", "ok"), ("gone.blend", "failed")])

    def test_sigterm_to_workers_and_launcher_is_an_interrupt(self):
        # What a scheduler cancelling a task does: SIGTERM to every process of the task,
        # here the worker first. The file being posed is "interrupted", not a crash.
        src, out = self.folder("in"), self.folder("out")
        for name in ("a", "b_slow"):
            F.make_good(os.path.join(src, name + ".blend"))
        pid_file = os.path.join(self.root, "slow-worker.pid")
        wrapper = patched_blender(self.root, "pid-blender", "'b_slow' in e['input'] and (open(%r, 'w').write("
                                  "str(os.getpid())), time.sleep(120))" % pid_file)
        report = os.path.join(self.root, "sigterm.json")
        p = subprocess.Popen([PYTHON, LAUNCHER, src, "--output", out, "--jobs", "1", "--blender", wrapper,
                              "--report", report], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        deadline = time.monotonic() + 120
        while not (os.path.exists(pid_file) and os.path.getsize(pid_file)) and time.monotonic() < deadline:
            time.sleep(0.1)
        with open(pid_file) as f:
            os.kill(int(f.read()), signal.SIGTERM)
        time.sleep(0.3)
        p.send_signal(signal.SIGTERM)
        text = p.communicate(timeout=60)[0]
        self.assertEqual(p.returncode, 130, text)
        with open(report) as f:
            files = {os.path.basename(x["input"]): (x["status"], x["reason"]) for x in json.load(f)["files"]}
        self.assertEqual(files, {"a.blend": ("ok", ""), "b_slow.blend": ("interrupted", "not processed (interrupted)")})
        self.assertEqual(temp_leftovers(out), [])

    def test_workers_end_with_a_killed_launcher(self):
        # SIGKILL to the launcher (an out-of-memory kill) cannot be handled by it: its workers,
        # each in its own session, must end on their own instead of posing on for no one.
        src, out = self.folder("in"), self.folder("out")
        F.make_good(os.path.join(src, "b_slow.blend"))
        pid_file = os.path.join(self.root, "orphan-worker.pid")
        wrapper = patched_blender(self.root, "orphan-blender", "'b_slow' in e['input'] and (open(%r, 'w').write("
                                  "str(os.getpid())), time.sleep(120))" % pid_file)
        p = subprocess.Popen([PYTHON, LAUNCHER, src, "--output", out, "--jobs", "1", "--blender", wrapper],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        deadline = time.monotonic() + 120
        while not (os.path.exists(pid_file) and os.path.getsize(pid_file)) and time.monotonic() < deadline:
            time.sleep(0.1)
        with open(pid_file) as f:
            worker = int(f.read())
        p.kill()
        p.wait()
        deadline = time.monotonic() + 30
        while running(worker) and time.monotonic() < deadline:
            time.sleep(0.2)
        self.assertFalse(running(worker), "the worker outlived its launcher")
        self.assertEqual(temp_leftovers(out), [])

    def test_bake_shape_keys_and_pc2(self):
        src, out_sk, out_pc = self.folder("in"), self.folder("sk"), self.folder("pc2")
        path = F.make_animated(os.path.join(src, "anim.blend"), frames=(1, 4))
        code, text = run_batch(path, "--output", out_sk, "--bake", "1:4")
        self.assertEqual(code, 0, text)
        _co, keys, _mods = load_object(os.path.join(out_sk, "anim.blend"))
        self.assertEqual(keys, ["Basis"] + [bake.key_name(f) for f in range(1, 5)])
        code, text = run_batch(path, "--output", out_pc, "--bake", "1:4", "--bake-format", "pc2",
                               "--max-iterations", 300)
        self.assertEqual(code, 0, text)
        self.assertEqual(sorted(os.listdir(out_pc)), ["anim.blend", "anim_Bar.pc2"])
        start, _rate, data = bake.read_pc2(os.path.join(out_pc, "anim_Bar.pc2"))
        self.assertEqual((start, data.shape[0]), (1.0, 4))
        _co, keys, mods = load_object(os.path.join(out_pc, "anim.blend"))
        # Appending made the path absolute: it must name the .pc2 next to the output.
        self.assertEqual(len(mods), 1)
        self.assertEqual(os.path.normpath(bpy.path.abspath(mods[0][1], start=out_pc)),
                         os.path.join(out_pc, "anim_Bar.pc2"))
        self.assertGreater(data[3][:, 0].max() - data[0][:, 0].max(), 0.5)  # x 0.2 -> 0.8

    def test_bake_follows_the_rig_and_turns_its_modifier_off(self):
        src, out = self.folder("in"), self.folder("rig")
        path = F.make_rigged(os.path.join(src, "rig.blend"), frames=(1, 4))
        code, text = run_batch(path, "--output", out, "--bake", "1:4", "--objects", "Tube")
        self.assertEqual(code, 0, text)
        with bpy.data.libraries.load(os.path.join(out, "rig.blend"), link=False) as (_src, dst):
            dst.objects = ["Tube"]
        obj = dst.objects[0]
        try:
            keys = obj.data.shape_keys.key_blocks
            self.assertEqual([kb.name for kb in keys], ["Basis"] + [bake.key_name(f) for f in range(1, 5)])
            first, last = (np.array([v.co for v in keys[bake.key_name(f)].data]) for f in (1, 4))
            # The last bone's end turned half a turn about the tube's axis: its rim's x flips sign.
            top = first[:, 2] > 2.9
            np.testing.assert_allclose(last[top, 0], -first[top, 0], atol=1e-4)
            # The baked keys are the rig's poses already: its Armature modifier is off in the file.
            modifier = obj.modifiers["Armature"]
            self.assertEqual((modifier.show_viewport, modifier.show_render), (False, False))
        finally:
            bpy.data.objects.remove(obj)


if __name__ == "__main__":
    unittest.main()
