# The native module: version/ABI checks at load, errors, array handling.
import glob
import importlib
import os
import shutil
import sys
import tempfile
import unittest

import numpy as np

import arap_test_utils as U

errors, native_loader = U.addon("errors", "native_loader")


class NativeBridge(unittest.TestCase):
    def test_module_matches_addon(self):
        mod = native_loader.native()
        self.assertEqual(mod.__version__, native_loader.addon_version())
        self.assertEqual(tuple(mod.PYTHON_VERSION), tuple(sys.version_info[:2]))
        self.assertTrue(mod.PYTHON_ABI.startswith(sys.implementation.cache_tag), mod.PYTHON_ABI)

    def test_version_mismatch_says_what_to_rebuild(self):
        mod = native_loader.native()
        saved = mod.__version__
        try:
            native_loader._native = None
            mod.__version__ = "0.0.0-other"
            with self.assertRaises(native_loader.NativeModuleError) as cm:
                native_loader.native()
            self.assertIn("0.0.0-other", str(cm.exception))
            self.assertIn("Rebuild", str(cm.exception))
        finally:
            mod.__version__ = saved
            native_loader._native = None
        self.assertIs(native_loader.native(), mod)

    def test_python_mismatch_says_what_to_rebuild(self):
        mod = native_loader.native()
        saved = mod.PYTHON_VERSION
        try:
            native_loader._native = None
            mod.PYTHON_VERSION = (3, 99)
            with self.assertRaises(native_loader.NativeModuleError) as cm:
                native_loader.native()
            self.assertIn("Python 3.99", str(cm.exception))
            self.assertIn("-DARAP_PYTHON_VERSION=%d.%d" % sys.version_info[:2], str(cm.exception))
        finally:
            mod.PYTHON_VERSION = saved
            native_loader._native = None
        native_loader.native()

    def test_no_module_for_this_python_names_the_ones_shipped(self):
        # A copy of the add-on whose only module is for another Python (3.99):
        # the error names the Pythons it has and what to rebuild.
        here = os.path.dirname(native_loader.__file__)
        with tempfile.TemporaryDirectory() as tmp:
            probe = os.path.join(tmp, "arap_abi_probe")
            os.makedirs(probe)
            for name in ("__init__.py", "native_loader.py", "blender_manifest.toml"):
                shutil.copy(os.path.join(here, name), probe)
            with open(os.path.join(probe, "__init__.py"), "w") as f:
                f.write("")  # skip registration: only native_loader.native() is under test
            shutil.copy(glob.glob(os.path.join(here, "_arap_native*"))[0],
                        os.path.join(probe, "_arap_native.cpython-399-x86_64-linux-gnu.so"))
            sys.path.insert(0, tmp)
            try:
                probe_loader = importlib.import_module("arap_abi_probe.native_loader")
                with self.assertRaises(probe_loader.NativeModuleError) as cm:
                    probe_loader.native()
            finally:
                sys.path.remove(tmp)
                for name in [n for n in sys.modules if n.startswith("arap_abi_probe")]:
                    del sys.modules[name]
        msg = str(cm.exception)
        self.assertIn("only for Python 3.99", msg)
        self.assertIn("Rebuild the module for Python %d.%d" % sys.version_info[:2], msg)

    def _square(self):
        rest = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float64)
        tris = np.array([[0, 1, 2], [0, 2, 3]], np.int32)
        return rest, tris

    def test_arap_error_and_code(self):
        mod = native_loader.native()
        rest, tris = self._square()
        s = mod.Solver()
        with self.assertRaises(mod.ArapError) as cm:
            s.bind(rest, tris, np.array([0, 0]))
        self.assertTrue(cm.exception.code)
        self.assertTrue(str(cm.exception))
        self.assertIsNotNone(errors.user_error(cm.exception))

    def test_float32_and_float64_in_and_out(self):
        mod = native_loader.native()
        rest, tris = self._square()
        for dtype in (np.float32, np.float64):
            s = mod.Solver()
            s.bind(rest.astype(dtype), tris, np.array([0, 1]))
            for out in (np.empty(12, np.float32), np.empty((4, 3), np.float64)):
                s.solve(np.array([[0, 0, 0], [1, 0, 0.5]], dtype), out=out)
                np.testing.assert_allclose(out.reshape(-1, 3), s.positions(), atol=1e-6)
        with self.assertRaises(ValueError):
            s.solve(np.zeros((2, 3)), out=np.empty(11, np.float32))
        with self.assertRaises(TypeError):
            s.solve(np.zeros((2, 3), np.int32))
        with self.assertRaises(ValueError):
            s.solve(np.zeros((3, 2)))
        with self.assertRaises(ValueError):
            s.solve(np.zeros((6, 3))[::2])


if __name__ == "__main__":
    unittest.main()
