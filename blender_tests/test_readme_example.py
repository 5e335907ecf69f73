# The README's scripting example runs as written, on a mesh named "Body".
import os
import re
import textwrap
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
        np.testing.assert_allclose(posed[z < z.min() + 0.5], rest[z < z.min() + 0.5], atol=1e-6)
        # The hand follows the Empty's motion since add_handle, (0, 0, 0.5), not its position.
        hand = namespace["hand_indices"]
        np.testing.assert_allclose(posed[hand] - rest[hand], np.tile((0.0, 0.0, 0.5), (len(hand), 1)), atol=1e-5)
        self.assertLess(result.energies[-1], result.initial_energy)

    def test_scripting_example_in_a_factory_startup_blender(self):
        # How batch runs and CI start Blender: nothing enabled. The README's
        # "Loading the add-on" lines, then the API, in a new Blender process.
        blocks = [b for b in readme_python_blocks() if "addon_utils.enable" in b]
        self.assertEqual(len(blocks), 1, "the README's loading snippet was not found")
        script = blocks[0] + textwrap.dedent("""
            bpy.ops.mesh.primitive_cylinder_add()
            obj = bpy.context.active_object
            api.create_group(obj, "bottom", [v.index for v in obj.data.vertices if v.co.z < 0])
            api.set_fixed(obj, "bottom")
            print("FACTORY STARTUP API OK", obj.arap.fixed_group)
            """)
        out = U.run_blender_script(script, factory_startup=True)
        self.assertIn("FACTORY STARTUP API OK bottom", out)


if __name__ == "__main__":
    unittest.main()
