# Measurement (not a test): files per minute of arap-batch with --jobs 1 and 2,
# run alternately on the same N generated .blend files (~7.8k vertices each).
#
#   BLENDER_USER_SCRIPTS=<build>/blender_tests/user_scripts blender --background --factory-startup \
#       -noaudio --python-exit-code 1 --python blender_tests/batch_measure.py -- <work dir> [N] [ROUNDS] [ARGS...]
#
# ARGS go to arap-batch (e.g. --iterations 200).
import os
import shutil
import subprocess
import sys

import addon_utils

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
addon_utils.enable("arap_deform", default_set=True)

import batch_scenes as S  # noqa: E402
import test_batch as T  # noqa: E402  (launcher lookup and environment)

argv = sys.argv[sys.argv.index("--") + 1:]
work = os.path.abspath(argv[0])
n = int(argv[1]) if len(argv) > 1 else 20
rounds = int(argv[2]) if len(argv) > 2 else 2
extra = argv[3:]
src = os.path.join(work, "in")
shutil.rmtree(work, ignore_errors=True)
os.makedirs(src)
for k in range(n):
    S.make_good(os.path.join(src, "f%02d.blend" % k), vertices=64, cuts=120, dx=0.3 + 0.02 * k)
for r in range(rounds):
    for jobs in (1, 2):
        out = os.path.join(work, "out")
        shutil.rmtree(out, ignore_errors=True)
        p = subprocess.run([T.PYTHON, T.LAUNCHER, src, "--output", out, "--jobs", str(jobs)] + extra,
                           capture_output=True, text=True, env=T.blender_env())
        print("round %d, --jobs %d %s: %s" % (r + 1, jobs, " ".join(extra), p.stdout.strip().splitlines()[-1]))
sys.stdout.flush()
os._exit(0)
