# Runs one blender_tests/test_*.py file with unittest inside Blender.
#
#   blender --background --factory-startup -noaudio --python-exit-code 1 \
#       --python run.py -- <test file> [unittest names...]
#
# The add-on is found via BLENDER_USER_SCRIPTS (Blender 3.x) or
# BLENDER_USER_EXTENSIONS (4.2+): ctest points them at folders that link to
# the staged add-on in the build tree, and ARAP_ADDON_MODULE names the module.
# Exit code: 0 only when every test passed and at least one ran; 77 (SKIPPED, ctest's
# SKIP_RETURN_CODE) when every test was skipped, so ctest reports it as not run.
import importlib.util
import os
import sys
import traceback
import unittest

SKIPPED = 77


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if not argv:
        print("usage: ... --python run.py -- <test file> [test names]")
        sys.exit(2)
    path = os.path.abspath(argv[0])
    sys.path.insert(0, os.path.dirname(path))  # for arap_test_utils

    import arap_test_utils as U
    mod = U.enable_addon(handle_error=lambda exc: traceback.print_exc())
    if mod is None:
        print("FAIL: could not enable the add-on %s (BLENDER_USER_SCRIPTS=%s, BLENDER_USER_EXTENSIONS=%s)"
              % (U.ADDON_MODULE, os.environ.get("BLENDER_USER_SCRIPTS"), os.environ.get("BLENDER_USER_EXTENSIONS")))
        sys.exit(1)

    spec = importlib.util.spec_from_file_location(os.path.splitext(os.path.basename(path))[0], path)
    test_module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(test_module)
    loader = unittest.defaultTestLoader
    if len(argv) > 1:
        suite = loader.loadTestsFromNames(argv[1:], test_module)
    else:
        suite = loader.loadTestsFromModule(test_module)
    result = unittest.TextTestRunner(stream=sys.stdout, verbosity=2).run(suite)
    ok = result.wasSuccessful() and result.testsRun > 0
    skipped = ok and len(result.skipped) == result.testsRun
    print("ARAP blender test %s: %s (%d run)" % (os.path.basename(path),
                                                 "SKIPPED" if skipped else "OK" if ok else "FAILED", result.testsRun))
    sys.stdout.flush()
    # os._exit: Blender's own exit path would otherwise decide the code.
    os._exit(SKIPPED if skipped else 0 if ok else 1)


main()
