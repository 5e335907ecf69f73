# The add-on's Deform equals the arap-deform command-line tool on the exported
# mesh (skipped when the CLI was not built). The mesh is exported as the
# triangles Blender solves on (loop_triangles), so both see the same topology.
import json
import os
import shutil
import subprocess
import tempfile
import unittest

import numpy as np
from mathutils import Euler, Matrix

import arap_test_utils as U

api, problem = U.addon("api", "problem")

CLI = os.environ.get("ARAP_DEFORM_CLI", "")


def write_off(path, verts, tris):
    with open(path, "w") as f:
        f.write("OFF\n%d %d 0\n" % (len(verts), len(tris)))
        for v in verts:
            f.write("%.17g %.17g %.17g\n" % tuple(v))
        for t in tris:
            f.write("3 %d %d %d\n" % tuple(t))


def read_off_vertices(path):
    with open(path) as f:
        words = [w for line in f for w in line.split("#")[0].split()]
    assert words[0] == "OFF", words[:3]
    n = int(words[1])
    return np.array(words[4:4 + 3 * n], np.float64).reshape(n, 3)


@unittest.skipUnless(CLI and os.path.isfile(CLI), "arap-deform CLI not built (ARAP_DEFORM_CLI unset)")
class CliEquivalence(unittest.TestCase):
    def setUp(self):
        U.clear_scene()
        self.tmp = tempfile.mkdtemp(prefix="arap_cli_")

    def tearDown(self):
        shutil.rmtree(self.tmp, ignore_errors=True)

    def test_deform_equals_cli(self):
        obj, empty, fixed, top = U.bar_with_handle()
        obj.matrix_world = Matrix.Translation((0.5, 0, 0)) @ Euler((0.0, 0.3, 0.0)).to_matrix().to_4x4()
        api.reset(obj)
        rest = U.coords(obj)
        bind = U.np_matrix(empty.matrix_world)
        empty.matrix_world = Matrix.Translation((0.4, 0.2, -0.3)) @ Euler((0.3, 0.0, 0.5)).to_matrix().to_4x4() \
            @ empty.matrix_world
        m_obj = U.np_matrix(obj.matrix_world)
        a = np.linalg.inv(m_obj) @ U.np_matrix(empty.matrix_world) @ np.linalg.inv(bind) @ m_obj

        mesh_path = os.path.join(self.tmp, "bar.off")
        write_off(mesh_path, rest, U.triangles(obj))
        scenario = {"mesh": "bar.off", "fixed": [int(i) for i in fixed],
                    "handles": [{"vertices": [int(i) for i in top], "matrix": a.tolist(), "translate": [0, 0, 0]}]}
        with open(os.path.join(self.tmp, "s.json"), "w") as f:
            json.dump(scenario, f)
        out = os.path.join(self.tmp, "out.off")
        subprocess.run([CLI, "--scenario", os.path.join(self.tmp, "s.json"), "--iterations", "10",
                        "--tolerance", "1e-6", "--init", "laplacian", "--weights", "cotan-clamped",
                        "--method", problem.METHOD_NAMES[obj.arap.method], "--output", out, "--quiet"], check=True)
        api.deform(obj, max_iterations=10, tolerance=1e-6, init='LAPLACIAN')
        np.testing.assert_allclose(U.coords(obj), read_off_vertices(out), atol=1e-5)


if __name__ == "__main__":
    unittest.main()
