# Expected to FAIL (ctest WILL_FAIL): proves that a failing assertion inside
# Blender makes the runner exit non-zero. Not named test_* on purpose.
import unittest


class Canary(unittest.TestCase):
    def test_failure_is_reported(self):
        self.assertEqual(1, 2, "this failure is intended")
