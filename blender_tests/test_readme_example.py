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


def readme_block(marker):
    """The one README Python block that contains `marker`."""
    blocks = [b for b in readme_python_blocks() if marker in b]
    if len(blocks) != 1:
        raise AssertionError("%d README blocks contain %r, expected one" % (len(blocks), marker))
    return blocks[0]


def loading_recipe():
    """The README's lines that import the add-on's api module on any Blender."""
    return readme_block("importlib.import_module(name + \".api\")")


class ReadmeExample(unittest.TestCase):
    def setUp(self):
        U.clear_scene()

    def test_loading_recipe_finds_the_enabled_addon(self):
        # In a Blender with the add-on enabled (ctest: the extension on 4.2+),
        # the recipe reaches the loaded module and does not register it again
        # (which would stop a running Live session).
        api, sessions = U.addon("api", "sessions")
        obj = U.bar_with_handle()[0]
        session = api.start_session(obj, bpy.context.scene)
        try:
            namespace = {"__name__": "readme_recipe"}
            exec(compile(loading_recipe(), "README.md", "exec"), namespace)
            self.assertEqual(namespace["name"], U.ADDON_MODULE)
            self.assertIs(namespace["api"], api)
            self.assertIs(sessions.session_for(obj), session)
        finally:
            session.cancel()

    def test_api_docstring_gives_the_same_recipe(self):
        def code(text):
            return [line.split("#")[0].strip() for line in text.splitlines() if line.split("#")[0].strip()]
        recipe, doc = code(loading_recipe()), code(U.addon("api").__doc__)
        self.assertIn(recipe[0], doc)
        start = doc.index(recipe[0])
        self.assertEqual(doc[start:start + len(recipe)], recipe)

    def test_scripting_example_poses_the_mesh(self):
        body = U.add_cylinder(name="Body")
        rest = U.coords(body)
        z = rest[:, 2]
        namespace = {"feet_indices": np.flatnonzero(z < z.min() + 0.5),
                     "hand_indices": np.flatnonzero(z > z.max() - 0.3),
                     "__name__": "readme_example"}
        exec(compile(loading_recipe(), "README.md", "exec"), namespace)
        exec(compile(readme_block("api.deform(obj)"), "README.md", "exec"), namespace)
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
        # loading recipe, then the API, in a new Blender process, which finds the
        # add-on as it is installed here (the extension on 4.2+).
        script = loading_recipe() + textwrap.dedent("""
            import bpy
            bpy.ops.mesh.primitive_cylinder_add()
            obj = bpy.context.active_object
            api.create_group(obj, "bottom", [v.index for v in obj.data.vertices if v.co.z < 0])
            api.set_fixed(obj, "bottom")
            print("FACTORY STARTUP API OK", api.__name__, obj.arap.fixed_group)
            """)
        out = U.run_blender_script(script, factory_startup=True)
        self.assertIn("FACTORY STARTUP API OK %s.api bottom" % U.ADDON_MODULE, out)


if __name__ == "__main__":
    unittest.main()
