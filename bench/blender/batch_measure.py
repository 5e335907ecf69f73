# Measurement (not a test): files per minute of arap-batch, two ways of running it taken
# in turn on the same N generated .blend files (~7.8k vertices each), ROUNDS times each.
#
#   BLENDER_USER_SCRIPTS=<build>/blender_tests/user_scripts blender --background --factory-startup \
#       -noaudio --python-exit-code 1 --python bench/blender/batch_measure.py -- <work dir> [N] [ROUNDS] \
#       [--slurm] [ARGS...]
#
# Compares --jobs 1 with --jobs 2; with --slurm (root, slurm-wlm + munge), the local --jobs 2
# with --scheduler slurm --shards 2 (one Blender per task) on a single-node Slurm started for
# the measurement (slurm_cluster.py): the difference is what the scheduler costs.
# ARGS go to arap-batch (e.g. --iterations 200). Prints each run's summary line, then the
# median rate of each way and the ratio of the medians.
import json
import os
import re
import shutil
import statistics
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)   # tube_scene, bench_addon
import bench_addon as U  # noqa: E402

U.enable_addon()
import batch_fixtures as F  # noqa: E402  (after enable_addon: it uses the add-on's api)

argv = sys.argv[sys.argv.index("--") + 1:]
work = os.path.abspath(argv[0])
n = int(argv[1]) if len(argv) > 1 else 20
rounds = int(argv[2]) if len(argv) > 2 else 2
extra = argv[3:]
use_slurm = "--slurm" in extra
extra = [a for a in extra if a != "--slurm"]
src = os.path.join(work, "in")
shutil.rmtree(work, ignore_errors=True)
os.makedirs(src)
for k in range(n):
    F.make_good(os.path.join(src, "f%02d.blend" % k), vertices=64, cuts=120, dx=0.3 + 0.02 * k)



def slurm_breakdown(folder, report):
    """Where a Slurm run's time went, from the run folder's timestamps (milliseconds)."""
    from datetime import datetime
    with open(os.path.join(folder, "run.json")) as f:
        submitted = datetime.fromisoformat(json.load(f)["submitted"])
    starts, ends = [], []
    for k in range(2):
        with open(os.path.join(folder, "shard-%d.json" % k)) as f:
            shard = json.load(f)
        starts.append((datetime.fromisoformat(shard["started"]) - submitted).total_seconds())
        ends.append(starts[-1] + shard["elapsed_s"])
    with open(report) as f:
        total = json.load(f)["elapsed_s"]
    return ("tasks' launchers started %s s after the submission, ended at %s s; merged report at %.2f s"
            % ("/".join("%.2f" % x for x in starts), "/".join("%.2f" % x for x in ends), total))


env, cluster = F.blender_env(), None
if use_slurm:
    import slurm_cluster  # noqa: E402
    cluster = slurm_cluster.SlurmCluster().start()
    env = dict(cluster.env, PATH=env["PATH"])
    ways = [("local --jobs 2", ["--jobs", "2"]),
            ("slurm --shards 2", ["--scheduler", "slurm", "--shards", "2", "--report", os.path.join(work, "r.json")])]
else:
    ways = [("local --jobs 1", ["--jobs", "1"]), ("local --jobs 2", ["--jobs", "2"])]
rates = {name: [] for name, _opts in ways}
try:
    for r in range(rounds):
        for name, opts in ways:
            out = os.path.join(work, "out")
            shutil.rmtree(out, ignore_errors=True)
            p = subprocess.run([F.PYTHON, F.LAUNCHER, src, "--output", out] + opts + extra,
                               capture_output=True, text=True, env=env)
            summary = [l for l in p.stdout.splitlines() if " file(s): " in l][-1]
            rates[name].append(float(re.search(r"\(([\d.]+) files/min", summary).group(1)))
            print("round %d, %s %s: %s" % (r + 1, name, " ".join(extra), summary))
            if "--scheduler" in opts:
                print("    " + slurm_breakdown(os.path.join(work, "r.slurm"), os.path.join(work, "r.json")))
            sys.stdout.flush()
finally:
    if cluster is not None:
        left = cluster.stop()
        print("Slurm stopped%s" % (", leftovers killed: %s" % left if left else ", nothing left running"))
medians = [statistics.median(rates[name]) for name, _opts in ways]
for (name, _opts), m in zip(ways, medians):
    print("median %-18s %.1f files/min over %d rounds" % (name, m, rounds))
print("ratio %s / %s: %.2f" % (ways[1][0], ways[0][0], medians[1] / medians[0]))
sys.stdout.flush()
os._exit(0)
