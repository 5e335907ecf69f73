# SPDX-License-Identifier: GPL-3.0-or-later
"""One-shot Deform (solve from the rest shape, write the result), the last
result of each object, and the rest and bind poses (Reset to Rest, Set Rest
Pose). Plain functions, testable in --background.

The other jobs live beside it: native_loader.py (the native module),
problem.py (settings -> configured solver), solver_cache.py (bound solvers
reused by Deform), live.py (the Live session), sessions.py (the running
sessions), errors.py (what the user is told).
"""

import time

import numpy as np

from . import constraints, meshio, solver_cache
from .problem import (Problem, bind_warnings, collapsed_handles_warning, solver_options, sync_matrices,
                      unconverged_warning)


class DeformResult:
    """What a solve did: energies, timings (ms), warnings, mesh checks."""

    def __init__(self, stats, bind_ms, io_ms, output, warnings, report, cached_bind):
        self.initial_energy = stats.initial_energy
        self.energies = list(stats.energy)
        self.iterations = stats.iterations
        self.converged = stats.converged
        self.solve_ms = sum(stats.iteration_ms) + stats.init_ms
        self.bind_ms = bind_ms
        self.io_ms = io_ms
        self.output = output
        self.warnings = warnings
        self.mesh_report = report
        self.cached_bind = cached_bind

    @property
    def energy(self):
        return self.energies[-1] if self.energies else self.initial_energy

    def __repr__(self):
        return ("<DeformResult iterations=%d energy=%.6g bind_ms=%.1f solve_ms=%.1f io_ms=%.1f output=%s>"
                % (self.iterations, self.energy, self.bind_ms, self.solve_ms, self.io_ms, self.output))


def deform(obj, scene=None, iterations=None, tolerance=None, init=None):
    """One-shot solve from the rest shape; writes the result (mesh or shape key).

    Raises SetupError or the native ArapError; the mesh is untouched then.
    """
    t0 = time.perf_counter()
    sync_matrices()
    problem = Problem(obj, scene)
    targets = problem.compute_targets(obj, scene)
    solver, bind_ms, cached = solver_cache.bound_solver(obj, problem)
    solver.configure(**solver_options(obj.arap, iterations=iterations, tolerance=tolerance, init=init))
    result32 = np.empty(len(problem.rest32), np.float32)
    t1 = time.perf_counter()
    stats = solver.solve(targets, out=result32)
    t2 = time.perf_counter()
    if problem.output == 'MESH' and not meshio.has_rest_attribute(obj.data):
        meshio.store_rest(obj.data, problem.rest32)
    out = meshio.Output(obj, problem.output)
    out.ensure()
    out.write(result32)
    t3 = time.perf_counter()
    report = solver.mesh_report()
    warnings = list(problem.setup.warnings) + bind_warnings(report, problem, obj.arap)
    for w in (collapsed_handles_warning(problem, scene),
              unconverged_warning(stats, solver.max_iterations, solver.tolerance)):
        if w:
            warnings.append(w)
    io_ms = (t1 - t0 + t3 - t2) * 1000.0 - bind_ms
    return remember_result(obj, DeformResult(stats, bind_ms, io_ms, problem.output, warnings, report, cached))


# The last DeformResult or BakeResult of each object in this Blender session (not saved in the .blend).
_last_results = {}


def remember_result(obj, result):
    _last_results[obj.as_pointer()] = result
    return result


def last_result(obj):
    """The last DeformResult / BakeResult made for `obj` in this session, or None."""
    return _last_results.get(obj.as_pointer())


def reset(obj):
    """Put the rest shape back and capture every handle's bind pose again."""
    constraints.check_object(obj)
    mesh = obj.data
    keys = mesh.shape_keys
    key = keys.key_blocks.get(meshio.SHAPE_KEY_NAME) if keys is not None else None
    if key is not None:
        rest = meshio.rest_coords(obj, 'SHAPE_KEY')
        meshio.Output(obj, 'SHAPE_KEY').write(rest)
    if meshio.has_rest_attribute(mesh):
        meshio.Output(obj, 'MESH').write(meshio.rest_coords(obj, 'MESH'))
    capture_all_binds(obj)


def set_rest_pose(obj):
    """Take the current shape as the rest shape and the empties' poses as bind poses."""
    constraints.check_object(obj)
    if meshio.resolve_output(obj, obj.arap.output) == 'MESH':
        meshio.store_rest(obj.data, meshio.read_coords(obj.data))
    capture_all_binds(obj)


def capture_bind(handle):
    """Take the handle Empty's world matrix now as its bind pose (matrices
    brought up to date first: a script may just have moved the Empty)."""
    sync_matrices()
    constraints.capture_bind(handle)


def capture_all_binds(obj):
    sync_matrices()
    for h in obj.arap.handles:
        if h.empty is not None:
            constraints.capture_bind(h)


def clear_cache():
    """Forget bound solvers and last results (e.g. after objects were deleted)."""
    solver_cache.clear()
    _last_results.clear()
