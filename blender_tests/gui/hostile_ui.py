# Hostile editing in Blender's UI (hostile_session.py): a modal Deform whose object is deleted, the add-on
# disabled and enabled again while Auto, Deform or a bake runs. Runs under
# `xvfb-run -a -s "-screen 0 1280x800x24"`: python3 hostile_ui.py --blender B --out DIR
# Fails on a failed check, a traceback or Python error in Blender's output, or a session that never ends.
import argparse
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--blender", required=True)
    p.add_argument("--out", required=True)
    args = p.parse_args()
    os.makedirs(args.out, exist_ok=True)
    try:
        proc = subprocess.run([args.blender, "--factory-startup", "-noaudio", "--window-geometry", "0", "0", "1280",
                               "800", "--python", os.path.join(HERE, "hostile_session.py")],
                              capture_output=True, text=True, timeout=600)
        log, code = proc.stdout + proc.stderr, proc.returncode
    except subprocess.TimeoutExpired as exc:
        log, code = "%s%s" % (exc.stdout or "", exc.stderr or ""), "timed out"
    with open(os.path.join(args.out, "blender.log"), "w") as f:
        f.write(log)
    checks = [line for line in log.splitlines() if line.startswith("CHECK ")]
    print("\n".join(checks))
    problems = [line for line in checks if not line.startswith("CHECK ok")]
    for marker in ("Traceback", "ReferenceError", "AttributeError"):
        if marker in log:
            problems.append("Blender printed %r" % marker)
    if "HOSTILE DONE" not in log:
        problems.append("the session did not reach its end (exit %s)" % code)
    if problems:
        sys.exit("FAIL:\n%s\n--- Blender's output (end) ---\n%s" % ("\n".join(problems), log[-4000:]))
    print("%d checks passed, no traceback" % len(checks))


if __name__ == "__main__":
    main()
