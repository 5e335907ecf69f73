# arap-batch --scheduler slurm on a real Slurm: a single-node cluster (munged, slurmctld,
# slurmd; node = this host) started in a temporary folder for this suite and stopped after
# it, leaving nothing running. Needs root and Debian's slurm-wlm + munge; skipped (ctest:
# "Skipped", with the reason) without them, unless ARAP_REQUIRE_SLURM=1 (CI) makes that a
# failure.
import json
import os
import re
import shutil
import signal
import subprocess
import tempfile
import time
import types
import unittest

import numpy as np

import batch_fixtures as F
import slurm_cluster

WHY_NOT = slurm_cluster.unavailable()
REQUIRED = os.environ.get("ARAP_REQUIRE_SLURM") == "1"


def without_ms(value):
    """A report record without timings (which differ from run to run)."""
    if isinstance(value, dict):
        return {k: without_ms(v) for k, v in value.items() if k not in ("ms", "solve_ms", "bind_ms", "io_ms")}
    if isinstance(value, list):
        return [without_ms(v) for v in value]
    return value


def mesh_bytes(path):
    coords, _keys, _mods = F.load_object(path)
    return coords.astype(np.float32).tobytes()


@unittest.skipIf(WHY_NOT and not REQUIRED, "single-node Slurm test not run: %s" % WHY_NOT)
class SlurmBatch(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        if WHY_NOT:
            raise AssertionError("ARAP_REQUIRE_SLURM=1 but " + WHY_NOT)
        cls.root = tempfile.mkdtemp(prefix="arap_slurm_test_")
        t0 = time.monotonic()
        cls.cluster = slurm_cluster.SlurmCluster().start()
        print("single-node Slurm up in %.1f s (%s)" % (time.monotonic() - t0, cls.cluster.dir))

    @classmethod
    def tearDownClass(cls):
        leftovers = cls.cluster.stop()
        shutil.rmtree(cls.root, ignore_errors=True)
        if leftovers:
            raise AssertionError("processes of the test cluster were still running: %s" % leftovers)

    def folder(self, name):
        d = os.path.join(self.root, self._testMethodName, name)
        os.makedirs(d)
        return d

    def batch(self, *args, timeout=600):
        p = subprocess.run([F.PYTHON, F.LAUNCHER] + [str(a) for a in args], capture_output=True, text=True,
                           timeout=timeout, env=self.cluster.env)
        return p.returncode, p.stdout + p.stderr

    def start_batch(self, *args):
        return subprocess.Popen([F.PYTHON, F.LAUNCHER] + [str(a) for a in args], stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, text=True, env=self.cluster.env)

    def wait_for(self, what, ready, timeout=180):
        deadline = time.monotonic() + timeout
        while not ready():
            self.assertLess(time.monotonic(), deadline, "timed out waiting for " + what)
            time.sleep(0.2)

    def job_id(self, proc, lines):
        for line in proc.stdout:
            lines.append(line)
            m = re.match(r"Slurm job (\d+):", line)
            if m:
                return m.group(1)
        self.fail("no job id printed:\n" + "".join(lines))

    def start_stuck_run(self, names, shards):
        """A --scheduler slurm run over `names` whose worker sleeps on slow.blend while the returned
        flag file exists; returns once a task is asleep there, with the process (proc), its output so
        far (lines), the job id (job), the folders (src, out, runs), the inputs' hashes (before), the
        report's path (report) and the flag file (flag)."""
        src, out, runs = self.folder("in"), self.folder("out"), self.folder("runs")
        for name in names:
            F.make_good(os.path.join(src, name + ".blend"))
        before = F.hashes(src)
        flag, started = os.path.join(runs, "sleep-on-slow"), os.path.join(runs, "slow-started")
        open(flag, "w").close()
        blender = F.patched_blender(runs, "sleepy-blender", "'slow' in e['input'] and os.path.exists(%r) and "
                                    "(open(%r, 'w').close() or time.sleep(600))" % (flag, started))
        report = os.path.join(runs, "r.json")
        proc = self.start_batch(src, "--output", out, "--scheduler", "slurm", "--shards", shards,
                                "--blender", blender, "--report", report)
        lines = []
        job = self.job_id(proc, lines)
        self.wait_for("a task to reach slow.blend", lambda: os.path.exists(started))
        return types.SimpleNamespace(proc=proc, lines=lines, job=job, src=src, out=out, runs=runs, before=before,
                                     report=report, flag=flag)

    def test_same_results_as_local_mode(self):
        src, out_local, out_slurm, runs = (self.folder(n) for n in ("in", "local", "slurm", "runs"))
        for k in range(3):
            F.make_good(os.path.join(src, "good%d.blend" % k), dx=0.3 + 0.2 * k)
        F.make_corrupt(os.path.join(src, "corrupt.blend"))
        F.make_missing_empty(os.path.join(src, "no_empty.blend"))
        before = F.hashes(src)
        local_report = os.path.join(runs, "local.json")
        code_local, text_local = self.batch(src, "--output", out_local, "--jobs", 2, "--frame", 1,
                                            "--report", local_report)
        report = os.path.join(runs, "all.json")
        results = os.path.join(runs, "results.jsonl")
        code, text = self.batch(src, "--output", out_slurm, "--scheduler", "slurm", "--shards", 2, "--frame", 1,
                                "--report", report, "--results-log", results)
        self.assertEqual((code_local, code), (1, 1), text_local + text)
        self.assertIn("5 file(s): 3 ok, 2 failed", text)
        self.assertIn("failed: %s: cannot open" % os.path.join(src, "corrupt.blend"), text)
        self.assertEqual(F.hashes(src), before)                     # inputs byte-identical
        self.assertEqual(sorted(os.listdir(out_slurm)), sorted(os.listdir(out_local)))
        self.assertEqual(sorted(os.listdir(out_slurm)), ["good0.blend", "good1.blend", "good2.blend"])
        for name in os.listdir(out_local):
            self.assertEqual(mesh_bytes(os.path.join(out_slurm, name)), mesh_bytes(os.path.join(out_local, name)),
                             name)

        with open(local_report) as f:
            expected = json.load(f)
        with open(report) as f:
            merged = json.load(f)
        for record in expected["files"]:
            if record["output"]:
                record["output"] = os.path.join(out_slurm, os.path.basename(record["output"]))
        by_input = {r["input"]: r for r in merged["files"]}
        self.assertEqual([r["input"] for r in merged["files"]], sorted(by_input))
        self.assertEqual(without_ms({r["input"]: r for r in expected["files"]}), without_ms(by_input))
        self.assertEqual((merged["ok"], merged["failed"], merged["interrupted"]), (3, 2, False))
        with open(results) as f:                                     # each file as the tasks finished it
            self.assertEqual(sorted(json.loads(line)["input"] for line in f), sorted(by_input))
        self.assertEqual(merged["mode"], dict(expected["mode"], output_dir=out_slurm))
        self.assertEqual((merged["run"]["scheduler"], merged["run"]["shards"]), ("slurm", 2))
        self.assertEqual(set(merged["slurm_tasks"].values()) | {"COMPLETED", "FAILED"}, {"COMPLETED", "FAILED"})

        # The job script beside the report, and what its tasks left in the run folder.
        with open(os.path.join(runs, "all.sbatch")) as f:
            script = f.read()
        self.assertIn("#SBATCH --array=0-1\n", script)
        self.assertIn('--shard "$k/2"', script)
        folder = os.path.join(runs, "all.slurm")
        with open(os.path.join(folder, "files.txt")) as f:
            self.assertEqual(f.read().split("\n")[:-1], sorted(by_input))
        for k in (0, 1):
            with open(os.path.join(folder, "shard-%d.json" % k)) as f:
                self.assertEqual([r["input"] for r in json.load(f)["files"]], sorted(by_input)[k::2])
        self.assertEqual(F.temp_leftovers(src, out_slurm), [])

    def test_no_wait_then_merge_and_resubmit(self):
        src, out, runs = self.folder("in"), self.folder("out"), self.folder("runs")
        F.make_good(os.path.join(src, "a.blend"))
        F.make_good(os.path.join(src, "b.blend"), dx=0.4)
        F.make_corrupt(os.path.join(src, "c.blend"))
        report = os.path.join(runs, "r.json")
        code, text = self.batch(src, "--output", out, "--scheduler", "slurm", "--shards", 2, "--no-wait",
                                "--report", report)
        self.assertEqual(code, 0, text)
        job = re.search(r"Slurm job (\d+):", text).group(1)
        self.assertIn("arap-batch merge-reports %s --report %s" % (os.path.join(runs, "r.slurm"), report), text)
        self.assertFalse(os.path.exists(report))
        self.wait_for("job %s to leave the queue" % job,
                      lambda: not self.cluster.client(["squeue", "--noheader", "--jobs=" + job]).stdout.strip())
        code, text = self.batch("merge-reports", os.path.join(runs, "r.slurm"), "--report", report)
        self.assertEqual(code, 1, text)
        self.assertIn("3 file(s): 2 ok, 1 failed", text)
        first = {f: mesh_bytes(os.path.join(out, f)) for f in os.listdir(out)}
        self.assertEqual(sorted(first), ["a.blend", "b.blend"])

        # The script as written runs again with plain sbatch; outputs are replaced whole.
        p = self.cluster.client(["sbatch", "--wait", os.path.join(runs, "r.sbatch")], timeout=300)
        self.assertIn(p.returncode, (0, 1), p.stdout + p.stderr)   # 1: a task had a failed file
        code, text = self.batch("merge-reports", os.path.join(runs, "r.slurm"), "--report", report)
        self.assertEqual(code, 1, text)
        self.assertIn("3 file(s): 2 ok, 1 failed", text)
        self.assertEqual(sorted(os.listdir(out)), ["a.blend", "b.blend"])
        for name, mesh in first.items():
            self.assertEqual(mesh_bytes(os.path.join(out, name)), mesh, name)

    def test_cancelled_task_fails_and_rerun_completes_it(self):
        run = self.start_stuck_run(("a", "b", "c", "d", "slow"), 2)   # task 0: a, c, slow; task 1: b, d
        proc, job, src, out, report = run.proc, run.job, run.src, run.out, run.report
        self.assertEqual(self.cluster.client(["scancel", job + "_0"]).returncode, 0)
        text = "".join(run.lines) + proc.communicate(timeout=300)[0]
        self.assertEqual(proc.returncode, 1, text)
        self.assertIn("5 file(s): 4 ok, 1 failed", text)
        with open(report) as f:
            r = json.load(f)
        files = {os.path.basename(x["input"]): x for x in r["files"]}
        self.assertEqual(files["slow.blend"]["status"], "failed")
        self.assertIn("Slurm task %s_0 CANCELLED" % job, files["slow.blend"]["reason"])
        self.assertEqual(r["slurm_tasks"], {"0": "CANCELLED", "1": "COMPLETED"})
        self.assertEqual(sorted(os.listdir(out)), ["a.blend", "b.blend", "c.blend", "d.blend"])
        self.assertEqual(F.hashes(src), run.before)
        self.assertEqual(F.temp_leftovers(src, out), [])
        done = {f: os.stat(os.path.join(out, f)).st_mtime_ns for f in os.listdir(out)}

        os.remove(run.flag)
        code, text = self.batch("--rerun-failed", report)
        self.assertEqual(code, 0, text)
        self.assertIn("1 file(s): 1 ok, 0 failed", text)
        with open(report) as f:
            r = json.load(f)
        self.assertEqual((r["ok"], r["failed"]), (5, 0))
        self.assertTrue(os.path.isfile(os.path.join(run.runs, "r.rerun1.sbatch")))
        self.assertEqual(sorted(os.listdir(out)), ["a.blend", "b.blend", "c.blend", "d.blend", "slow.blend"])
        for name, mtime in done.items():          # only the failed file was run again
            self.assertEqual(os.stat(os.path.join(out, name)).st_mtime_ns, mtime, name)
        posed, _k, _m = F.load_object(os.path.join(out, "slow.blend"))
        self.assertGreater(posed[:, 0].max(), 1.0)

    def test_task_killed_outright_keeps_what_it_finished(self):
        # The task's launcher SIGKILLed (what an out-of-memory kill does): no report from the task;
        # the files it finished count from its results log, the others fail and say why, and Slurm
        # ends the task's Blender worker with it.
        run = self.start_stuck_run(("a", "b", "slow"), 1)
        launchers = [pid for pid, cmd in self.cluster.processes() if "--files-from" in cmd and "arap-batch" in cmd]
        self.assertEqual(len(launchers), 1, self.cluster.processes())
        os.kill(launchers[0], signal.SIGKILL)
        text = "".join(run.lines) + run.proc.communicate(timeout=300)[0]
        os.remove(run.flag)
        self.assertEqual(run.proc.returncode, 1, text)
        self.assertFalse(os.path.exists(os.path.join(run.runs, "r.slurm", "shard-0.json")))
        with open(run.report) as f:
            files = {os.path.basename(x["input"]): x for x in json.load(f)["files"]}
        self.assertEqual((files["a.blend"]["status"], files["b.blend"]["status"]), ("ok", "ok"))
        self.assertEqual(files["slow.blend"]["status"], "failed")
        self.assertEqual(files["slow.blend"]["reason"], "no result from Slurm task %s_0 (FAILED)" % run.job)
        self.assertEqual(sorted(os.listdir(run.out)), ["a.blend", "b.blend"])
        self.assertEqual(F.hashes(run.src), run.before)
        self.wait_for("Slurm to end the task's worker",
                      lambda: not [p for p, cmd in self.cluster.processes() if "blender" in cmd], timeout=60)

    def test_ctrl_c_cancels_the_array(self):
        run = self.start_stuck_run(("a", "slow"), 1)
        proc, job, out, report = run.proc, run.job, run.out, run.report
        proc.send_signal(signal.SIGINT)
        text = "".join(run.lines) + proc.communicate(timeout=300)[0]
        os.remove(run.flag)
        self.assertEqual(proc.returncode, 130, text)
        self.assertIn("cancelling Slurm job %s" % job, text)
        self.assertEqual(self.cluster.client(["squeue", "--noheader", "--jobs=" + job]).stdout.strip(), "")
        with open(report) as f:
            r = json.load(f)
        self.assertTrue(r["interrupted"])
        files = {os.path.basename(x["input"]): x["status"] for x in r["files"]}
        self.assertEqual(files, {"a.blend": "ok", "slow.blend": "interrupted"}, r["files"])
        self.assertEqual(os.listdir(out), ["a.blend"])
        self.assertEqual(F.hashes(run.src), run.before)
        self.assertEqual(F.temp_leftovers(run.src, out), [])


if __name__ == "__main__":
    unittest.main()
