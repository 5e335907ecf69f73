# The native module _arap_native in a plain Python (no Blender): the constraint
# rule, the options' one definition, and a solve through numpy buffers.
# Run by ctest (python.module) with PYTHONPATH set to the staged add-on folder.
import os
import signal
import subprocess
import sys
import threading
import unittest
import warnings

import numpy as np

import _arap_native as arap


def strip(columns=12, rows=3):
    """A flat grid of (columns x rows) vertices, two triangles per cell, in the xz plane."""
    x, z = np.meshgrid(np.arange(columns, dtype=np.float64), np.arange(rows, dtype=np.float64))
    rest = np.column_stack([x.ravel(), np.zeros(x.size), z.ravel()])
    tris = []
    for r in range(rows - 1):
        for c in range(columns - 1):
            v = r * columns + c
            tris += [(v, v + 1, v + columns + 1), (v, v + columns + 1, v + columns)]
    return rest, np.array(tris, np.int32)


class ConstraintRule(unittest.TestCase):
    def test_fixed_wins_then_the_first_handle(self):
        s = arap.constraint_set(10, np.array([4, 2, 4]), "the fixed group 'F'",
                                [("handle 'A'", np.array([2, 5, 6])), ("handle 'B'", np.array([6, 7, 5]))])
        self.assertEqual(s.constrained.tolist(), [4, 2, 5, 6, 7])
        self.assertEqual(s.constrained.dtype, np.int64)
        self.assertEqual(s.fixed_count, 2)
        self.assertEqual(s.handles, [(0, 2, 4), (1, 4, 5)])
        self.assertEqual(s.warnings, [
            "Handle 'A': 1 of its vertices are also in the fixed group 'F' and stay fixed",
            "Handle 'B': 2 of its vertices are also in handle 'A' and follow that one"])

    def test_a_handle_with_nothing_of_its_own_is_ignored(self):
        s = arap.constraint_set(4, None, "the fixed group", [("handle 'A'", [1, 2]), ("handle 'B'", [2, 1])])
        self.assertEqual(s.handles, [(0, 0, 2)])
        self.assertIn("Handle 'B' has no vertices of its own: ignored", s.warnings)

    def test_bad_indices_and_nothing_held_are_typed_errors(self):
        with self.assertRaises(arap.ArapError) as cm:
            arap.constraint_set(3, None, "the fixed group", [("handle 'Arm'", [5])])
        self.assertEqual(cm.exception.code, "index out of range")
        self.assertIn("Handle 'Arm' refers to vertex 5", str(cm.exception))
        with self.assertRaises(arap.ArapError) as cm:
            arap.constraint_set(3, [], "the fixed group", [])
        self.assertEqual(cm.exception.code, "no constraints")
        with self.assertRaises(TypeError):
            arap.constraint_set(3, None, "the fixed group", [[0, 1]])


class Options(unittest.TestCase):
    def test_a_new_solver_has_the_published_defaults(self):
        solver = arap.Solver()
        for name, spec in arap.OPTIONS.items():
            self.assertEqual(getattr(solver, name), spec["default"], name)

    def test_limits_are_checked_and_nothing_is_kept_on_error(self):
        solver = arap.Solver()
        top = arap.OPTIONS["anderson_window"]["max"]
        solver.anderson_window = top
        with self.assertRaises(arap.ArapError):
            solver.anderson_window = top + 1
        with self.assertRaises(arap.ArapError):
            solver.configure(tolerance=0.5, threads=arap.OPTIONS["threads"]["max"] + 1)
        self.assertEqual(solver.tolerance, arap.OPTIONS["tolerance"]["default"])
        self.assertEqual(solver.anderson_window, top)
        with self.assertRaises(arap.ArapError):
            solver.method = "gradient-descent"

    def test_options_fixed_at_bind_change_only_with_a_new_bind(self):
        rest, tris = strip()
        solver = arap.Solver()
        solver.bind(rest, tris, np.array([0, 11]), volume="infill", infill_resolution=4)
        self.assertEqual((solver.volume, solver.infill_resolution, solver.weights), ("infill", 4, "cotan-clamped"))
        for name, value in (("weights", "uniform"), ("volume", "none"), ("infill_resolution", 6)):
            with self.assertRaises(arap.ArapError, msg=name):
                solver.configure(**{name: value})
            with self.assertRaises(AttributeError, msg=name):
                setattr(solver, name, value)
        self.assertEqual((solver.volume, solver.infill_resolution), ("infill", 4))
        solver.configure(volume="infill", tolerance=1e-3)   # the same value is no change
        self.assertEqual(solver.tolerance, 1e-3)
        with self.assertRaises(arap.ArapError):   # Anderson's extrapolation ignores the volume terms
            solver.configure(method="anderson")

    def test_method_conflicts_names_what_anderson_cannot_be_combined_with(self):
        self.assertEqual(arap.method_conflicts(), [])
        self.assertEqual(arap.method_conflicts(method="anderson"), [])
        self.assertEqual(arap.method_conflicts(method="quasi-newton", volume="global", contact="self"), [])
        both = arap.method_conflicts(method="anderson", volume="infill", infill_resolution=4, contact="self")
        self.assertEqual([(option, value) for option, value, _ in both], [("volume", "infill"), ("contact", "self")])
        self.assertIn("volume terms", both[0][2])
        self.assertIn("collision check", both[1][2])
        # The first is the one a solver refuses with.
        solver = arap.Solver()
        with self.assertRaisesRegex(arap.ArapError, "volume infill .* not anderson"):
            solver.configure(method="anderson", volume="infill")
        with self.assertRaises(arap.ArapError):   # each option's limits, as configure() checks them
            arap.method_conflicts(method="gradient-descent")

    def test_the_default_model_is_infill_and_anderson_alone_solves_the_surface(self):
        self.assertEqual(arap.OPTIONS["volume"]["default"], "infill")
        rest, tris = strip()
        solver = arap.Solver()
        solver.bind(rest, tris, np.array([0, 11]))
        self.assertEqual(solver.volume, "infill")
        solver.bind(rest, tris, np.array([0, 11]), method="anderson")    # it cannot carry the volume terms
        self.assertEqual((solver.method, solver.volume), ("anderson", "none"))
        self.assertEqual(arap.method_conflicts(method="anderson", volume="infill")[0][:2], ("volume", "infill"))

    def test_self_contact_is_fixed_at_bind_and_reports_how_far_the_handles_came(self):
        rest, tris = strip()
        solver = arap.Solver()
        solver.bind(rest, tris, np.array([0, 11]), contact="self")
        self.assertEqual(solver.contact, "self")
        with self.assertRaises(arap.ArapError):
            solver.configure(contact="none")
        with self.assertRaises(arap.ArapError):   # Anderson's extrapolation skips the collision checks
            solver.configure(method="anderson")
        targets = rest[[0, 11]] + np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.3]])
        stats = solver.solve(targets)
        self.assertEqual(stats.contact_reached, 1.0)
        self.assertEqual(stats.contact_stopped_vertex, -1)
        self.assertTrue(np.all(np.isfinite(solver.positions())))
        # Nothing comes near: the solve without contact, which ran first, is the result as it is.
        plain = arap.Solver()
        plain.bind(rest, tris, np.array([0, 11]))
        plain_stats = plain.solve(targets)
        self.assertEqual(stats.contact_free_iterations, stats.iterations)
        self.assertEqual(stats.iterations, plain_stats.iterations)
        np.testing.assert_array_equal(solver.positions(), plain.positions())


class Solve(unittest.TestCase):
    def test_handles_reach_their_targets_and_the_energy_never_rises(self):
        rest, tris = strip()
        columns = 12
        fixed = np.arange(0, rest.shape[0], columns)                # the left edge
        moved = np.arange(columns - 1, rest.shape[0], columns)      # the right edge
        chosen = arap.constraint_set(len(rest), fixed, "the fixed group", [("handle 'end'", moved)])
        solver = arap.Solver()
        solver.bind(rest, tris, chosen.constrained, weights="cotan-clamped")
        solver.configure(method="local-global", max_iterations=50, tolerance=0.0)
        targets = rest[chosen.constrained].copy()
        targets[chosen.fixed_count:] += (0.0, 0.0, 4.0)
        out = np.empty(rest.size, np.float32)
        stats = solver.solve(targets, out=out)
        self.assertEqual(stats.iterations, 50)
        energies = [stats.initial_energy] + list(stats.energy)
        self.assertTrue(all(b <= a * (1 + 1e-12) + 1e-12 for a, b in zip(energies, energies[1:])), energies)
        result = out.reshape(-1, 3)
        np.testing.assert_allclose(result[chosen.constrained], targets, atol=1e-5)
        np.testing.assert_allclose(solver.positions(), result, atol=1e-5)
        self.assertTrue(np.all(np.isfinite(result)))
        report = solver.mesh_report()
        self.assertEqual(report.vertices, len(rest))
        self.assertEqual(report["unconstrained_components"], 0)

    def test_bad_buffers_are_refused(self):
        rest, tris = strip()
        solver = arap.Solver()
        solver.bind(rest, tris, np.array([0, 11]))
        with self.assertRaises((arap.ArapError, ValueError)):
            solver.solve(np.zeros((3, 3)))
        with self.assertRaises((arap.ArapError, ValueError, TypeError)):
            solver.solve(rest[[0, 11]], out=np.empty(5, np.float32))


class Threads(unittest.TestCase):
    """Two threads give the same result bit for bit, from any Python thread and in a forked child
    (the solver keeps helper threads per calling thread between its parallel passes)."""

    @classmethod
    def setUpClass(cls):
        # 22 000 vertices: above 20 000 free ones, so the bind's ordering and factorization,
        # the triangular solves and the quasi-Newton vector passes split in halves too,
        # not only the per-vertex passes.
        columns = 200
        cls.rest, cls.tris = strip(columns=columns, rows=110)
        fixed = np.arange(0, len(cls.rest), columns)
        moved = np.arange(columns - 1, len(cls.rest), columns)
        cls.chosen = arap.constraint_set(len(cls.rest), fixed, "the fixed group", [("handle 'end'", moved)])
        cls.targets = cls.rest[cls.chosen.constrained].copy()
        cls.targets[cls.chosen.fixed_count:] += (0.0, 30.0, 20.0)
        cls.one_thread = cls.solve(1)

    @classmethod
    def solve(cls, threads):
        solver = arap.Solver()
        solver.bind(cls.rest, cls.tris, cls.chosen.constrained, threads=threads)  # the factor's halves too
        solver.configure(max_iterations=15, tolerance=0.0)
        out = np.empty(cls.rest.size, np.float64)
        stats = solver.solve(cls.targets, out=out)
        assert stats.iterations == 15
        return out

    def test_two_threads_match_one_on_the_main_and_another_python_thread(self):
        self.assertFalse(np.array_equal(self.one_thread, self.rest.ravel()))  # it did move
        np.testing.assert_array_equal(self.solve(2), self.one_thread)
        results = []
        worker = threading.Thread(target=lambda: results.append(self.solve(2)))
        worker.start()
        worker.join()
        np.testing.assert_array_equal(results[0], self.one_thread)
        np.testing.assert_array_equal(self.solve(2), self.one_thread)  # this thread's helpers still work

    def test_a_forked_child_solves_on_two_threads(self):
        self.solve(2)  # this thread now has helper threads; the child will not
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)  # fork() with threads: ours are asleep
            child = os.fork()
        if child == 0:
            signal.alarm(120)  # a hang ends the child with SIGALRM instead of stalling the suite
            code = 1
            try:
                code = 0 if np.array_equal(self.solve(2), self.one_thread) else 3
            finally:
                os._exit(code)
        _, status = os.waitpid(child, 0)
        self.assertTrue(os.WIFEXITED(status), f"the child ended by signal {os.WTERMSIG(status)}")
        self.assertEqual(os.WEXITSTATUS(status), 0)


class MemoryLimit(unittest.TestCase):
    """A bind that would not fit is refused before it allocates: ArapError "out of memory" with both figures,
    the previous binding kept. In a child Python whose address space is limited, as `ulimit -v` does."""

    CHILD = r"""
import resource, sys
import numpy as np
sys.path[:0] = [%r]
from test_module import strip
import _arap_native as arap
small_rest, small_tris = strip()
large_rest, large_tris = strip(600, 300)
s = arap.Solver()
s.bind(small_rest, small_tris, np.arange(12, dtype=np.int32))
vm = int([l for l in open("/proc/self/status") if l.startswith("VmSize:")][0].split()[1]) * 1024
resource.setrlimit(resource.RLIMIT_AS, (vm + (24 << 20), resource.getrlimit(resource.RLIMIT_AS)[1]))
try:
    s.bind(large_rest, large_tris, np.arange(600, dtype=np.int32))
    print("bound")
except arap.ArapError as e:
    print(e.code + "|" + str(e))
resource.setrlimit(resource.RLIMIT_AS, (resource.RLIM_INFINITY, resource.RLIM_INFINITY))
targets = small_rest[:12].copy()
targets[:, 1] += 0.5
s.solve(targets)
print(s.positions().shape[0])
"""

    def test_a_bind_too_large_is_a_typed_error_and_the_previous_binding_stays(self):
        child = subprocess.run([sys.executable, "-c", self.CHILD % os.path.dirname(os.path.abspath(__file__))],
                               capture_output=True, text=True, timeout=120, env=os.environ)
        self.assertEqual(child.returncode, 0, child.stderr)
        refusal, vertices = child.stdout.split("\n")[:2]
        code, message = refusal.split("|", 1)
        self.assertEqual(code, "out of memory", refusal)
        self.assertIn("binding 180000 vertices", message)
        self.assertIn("needs about", message)
        self.assertIn("is left under the address-space limit", message)
        self.assertEqual(vertices, "36")  # the small strip's binding still solves


if __name__ == "__main__":
    unittest.main()
