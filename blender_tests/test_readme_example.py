# The README's scripting example runs as written, on a mesh named "Body".
import os
import re
import unittest

import bpy
import numpy as np

import arap_test_utils as U

README = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "README.md")


def readme_python_blocks():
    text = open(README, encoding="utf-8").read()
    return re.findall(r"```python\n(.*?)```", text, re.S)


class ReadmeExample(unittest.TestCase):
    def setUp(self):
        U.clear_scene()

    def test_scripting_example_poses_the_mesh(self):
        blocks = [b for b in readme_python_blocks() if "api.deform(obj)" in b]
        self.assertEqual(len(blocks), 1, "the README's scripting example was not found")
        body = U.add_cylinder(name="Body")
        rest = U.coords(body)
        z = rest[:, 2]
        namespace = {"feet_indices": np.flatnonzero(z < z.min() + 0.5),
                     "hand_indices": np.flatnonzero(z > z.max() - 0.3),
                     "__name__": "readme_example"}
        exec(compile(blocks[0], "README.md", "exec"), namespace)
        result = namespace["result"]
        posed = U.coords(body)
        self.assertTrue(np.isfinite(posed).all())
        self.assertGreater(np.abs(posed - rest).max(), 0.1)
        np.testing.assert_allclose(posed[z < z.min() + 0.5], rest[z < z.min() + 0.5], atol=1e-6)
        self.assertLess(result.energies[-1], result.initial_energy)


if __name__ == "__main__":
    unittest.main()
