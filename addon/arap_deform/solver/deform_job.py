# SPDX-License-Identifier: GPL-3.0-or-later
"""One-shot Deform (solve from the rest shape, write the result), the last
result of each object, and the rest and bind poses (Reset to Rest, Set Rest
Pose). Plain functions, testable in --background.

Beside it: problem.py (settings -> configured solver), solver_cache.py (bound
solvers reused by Deform), live.py (the Live session), sessions.py (the running
sessions); at the add-on's top native_loader.py (the native module) and
errors.py (what the user is told).
"""

import time

import numpy as np

from . import constraints, drivers, handles, meshio, rig, solver_cache
from ..errors import SetupError
from ..native_loader import native
from .background_bind import BackgroundBind
from .problem import (Problem, bind_warnings, collapsed_handles_warning, contact_held, contact_warning,
                      solver_options, sync_matrices, unconverged_warning)


class DeformResult:
    """What a solve did: energies, timings (ms), warnings, mesh checks."""

    def __init__(self, stats, bind_ms, io_ms, output, warnings, report, cached_bind, notes=()):
        self.initial_energy = stats.initial_energy
        self.energies = list(stats.energy)
        self.iterations = stats.iterations
        self.converged = stats.converged
        # Self Contact: the share of their moves the handles made (1: at their targets; below, stopped short).
        self.contact_reached = stats.contact_reached
        self.solve_ms = sum(stats.iteration_ms) + stats.init_ms
        self.bind_ms = bind_ms
        self.io_ms = io_ms
        self.output = output
        self.warnings = warnings
        self.notes = list(notes)   # what the solve did that is not a problem (Self Contact's pairs held apart)
        self.mesh_report = report
        self.cached_bind = cached_bind

    @property
    def energy(self):
        return self.energies[-1] if self.energies else self.initial_energy

    def __repr__(self):
        return ("<DeformResult iterations=%d energy=%.6g bind_ms=%.1f solve_ms=%.1f io_ms=%.1f output=%s>"
                % (self.iterations, self.energy, self.bind_ms, self.solve_ms, self.io_ms, self.output))


class DeformJob:
    """One Deform: bind (or reuse the cached bind), solve from the start shape, write.

    run() solves on the caller's thread; start() hands the solve to a native
    worker thread instead and poll() finishes the job once that solve is done,
    so the Deform operator keeps Blender responsive (progress shown, Esc
    stops) on big meshes. Either way the mesh is only written when the solve
    has finished: a stopped or failed job leaves it untouched.
    """

    def __init__(self, obj, scene=None, max_iterations=None, tolerance=None, init=None, iterations_from=None,
                 bind_on_thread=False):
        t0 = time.perf_counter()
        self.obj, self.scene = obj, scene
        sync_matrices()
        self.problem = Problem(obj, scene)
        self.name = obj.name    # a deleted object's own name can no longer be read
        self.topology = None    # the mesh's connectivity when the worker started (run() needs none)
        self.pose = self.problem.pose(obj, scene)
        self.targets = self.problem.targets(self.pose)
        self._overrides = dict(max_iterations=max_iterations, tolerance=tolerance, init=init)
        self.max_iterations = solver_options(obj.arap, **self._overrides)["max_iterations"]
        # bind_on_thread (the modal operator): a bind start() runs on a thread of its own, poll() waits for.
        self._cache_key, self.solver = solver_cache.lookup(obj, self.problem)
        self.cached = self.solver is not None
        self.bind_ms = 0.0
        self.binding = None
        if self.solver is None and not bind_on_thread:
            self._bound(self.problem.bind())
        elif self.solver is not None:
            self.solver.configure(**solver_options(obj.arap, **self._overrides))
        # Where the cap was set, for the warning when the pose does not settle (problem.RAISE_ITERATIONS).
        self.iterations_from = iterations_from or ('SETTINGS' if max_iterations is None else 'ARGUMENT')
        self.positions = np.empty(len(self.problem.rest32), np.float32)
        self.worker = None
        self._prepare_ms = (time.perf_counter() - t0) * 1e3 - self.bind_ms

    def run(self):
        """Solve here and write; the DeformResult."""
        start = self.problem.start_shape(self.pose.transforms)   # a rig's skinned pose, else the Start setting
        if start is not None:
            self.solver.start_from(start)
        return self._finish(self.solver.solve(self.targets, out=self.positions))

    def _bound(self, solver):
        """`solver` was just bound: kept for the next Deform of the same inputs, configured."""
        self.solver, self.bind_ms = solver, solver.bind_ms
        solver_cache.keep(self.obj, self._cache_key, solver)
        solver.configure(**solver_options(self.obj.arap, **self._overrides))

    def start(self):
        """Solve on the worker's thread (after binding on a thread of its own, when the job was made with
        bind_on_thread and no bound solver was kept); poll() until it returns the DeformResult."""
        self.topology = meshio.Topology(self.obj.data)
        if self.solver is None:
            self.binding = BackgroundBind(self.problem, self.obj.arap, **self._overrides)
        else:
            self._start_worker()

    def _start_worker(self):
        self.worker = native().SolveWorker(self.solver, max_iterations=self.max_iterations)
        start = self.problem.start_shape(self.pose.transforms)
        self.worker.post(self.targets, restart=start is not None, start=start)
        self.solving_since = time.monotonic()

    def time_left(self):
        """(seconds solving so far, at most how many more): the rate so far times the iterations its cap
        leaves; None before the first iteration. Most solves settle well before the cap."""
        iterations = self.progress[0]
        if self.worker is None or iterations == 0:
            return None
        spent = time.monotonic() - self.solving_since
        return spent, spent / iterations * max(0, self.max_iterations - iterations)

    @property
    def progress(self):
        """(iterations done, energy) of the solve in progress."""
        return self.worker.progress if self.worker is not None else (0, 0.0)

    def poll(self):
        """The DeformResult once the worker's solve is done (the mesh written), else None. SetupError (the
        worker stopped, nothing written) when the object was deleted or its mesh changed meanwhile; the
        bind's error (out of memory, a bad mesh) when it failed on its thread."""
        if self.binding is not None:
            self.check(full=False)
            solver = self.binding.solver()
            if solver is None:
                return None
            self.binding = None
            self._bound(solver)
            self._start_worker()
        try:
            self.check(full=False)
            result = self.worker.take(self.positions)
            if result is not None:
                self.check(full=True)
        except SetupError:
            self.stop()
            raise
        if result is None:
            return None
        self.stop()
        return self._finish(result.stats)

    def check(self, full=True):
        """SetupError when the object was deleted, or its mesh's vertices or faces changed since the job
        started (the pose would go into the wrong vertices): element counts, and with `full` each face
        corner's vertex too (renumbered vertices)."""
        try:
            mesh, mode = self.obj.data, self.obj.mode
        except ReferenceError:
            raise SetupError("'%s' was deleted while Deform solved: nothing was written" % self.name) from None
        if mode == 'EDIT':
            raise SetupError("'%s' went into Edit Mode while Deform solved: nothing was written" % self.name)
        if not (self.topology.unchanged(mesh) if full else self.topology.counts_match(mesh)):
            raise SetupError("The vertices or faces of '%s' changed while Deform solved: nothing was written; "
                             "run Deform again" % self.name)

    def stop(self):
        """Stop the worker (the solve in progress ends after its iteration; a bind in progress is left to
        finish unused); the mesh stays as it is."""
        self.binding = None
        if self.worker is not None:
            self.worker.stop()
            self.worker = None

    def _finish(self, stats):
        t0 = time.perf_counter()
        obj, problem = self.obj, self.problem
        if problem.output == 'MESH' and not meshio.has_rest_attribute(obj.data):
            meshio.store_rest(obj.data, problem.rest32)
        rig.mute_armature(obj)   # the pose shown is ARAP's: the rig's own deformation not on top
        out = meshio.Output(obj, problem.output)
        out.ensure()
        out.write(self.positions)
        report = self.solver.mesh_report()
        warnings = list(problem.setup.warnings) + bind_warnings(report, problem, obj.arap)
        for w in (collapsed_handles_warning(problem, self.pose), contact_warning(problem, stats),
                  unconverged_warning(stats, self.max_iterations, self.solver.tolerance, self.iterations_from)):
            if w:
                warnings.append(w)
        io_ms = self._prepare_ms + (time.perf_counter() - t0) * 1e3
        held = contact_held(problem, stats)
        return remember_result(obj, DeformResult(stats, self.bind_ms, io_ms, problem.output, warnings, report,
                                                 self.cached, [held] if held else []))


def deform(obj, scene=None, max_iterations=None, tolerance=None, init=None, iterations_from=None):
    """One-shot solve from the rest shape; writes the result (mesh or shape key).

    Raises SetupError or the native ArapError; the mesh is untouched then.
    iterations_from: where `max_iterations` came from (a key of problem.RAISE_ITERATIONS), named by the warning
    when the pose did not settle; by default the argument, or the Solver panel's setting when it is None.
    """
    return DeformJob(obj, scene, max_iterations, tolerance, init, iterations_from).run()


# The last DeformResult or BakeResult of each object in this Blender session (not saved in the .blend).
_last_results = {}


def remember_result(obj, result):
    _last_results[obj.as_pointer()] = result
    return result


def last_result(obj):
    """The last DeformResult / BakeResult made for `obj` in this session, or None."""
    return _last_results.get(obj.as_pointer())


def reset(obj):
    """Put the rest shape back (the rig's deformation too, rig.restore_armature) and capture every handle's
    bind pose again: an Empty's where it is now, a bone's at its rest pose."""
    constraints.check_object(obj)
    mesh = obj.data
    keys = mesh.shape_keys
    key = keys.key_blocks.get(meshio.SHAPE_KEY_NAME) if keys is not None else None
    if key is not None:
        rest = meshio.rest_coords(obj, 'SHAPE_KEY')
        meshio.Output(obj, 'SHAPE_KEY').write(rest)
    if meshio.has_rest_attribute(mesh):
        meshio.Output(obj, 'MESH').write(meshio.rest_coords(obj, 'MESH'))
    rig.restore_armature(obj)
    capture_all_binds(obj, bones_at_rest=True)


def set_rest_pose(obj):
    """Take the current shape as the rest shape and the empties' poses as bind poses."""
    constraints.check_object(obj)
    if meshio.resolve_output(obj, obj.arap.output) == 'MESH':
        meshio.store_rest(obj.data, meshio.read_coords(obj.data))
    capture_all_binds(obj)


def capture_bind(handle, at_rest=False):
    """Take the handle Empty's world matrix (or its bone's pose; with `at_rest`, the bone's rest pose) now as
    its bind pose (matrices brought up to date first: a script may just have moved the Empty)."""
    sync_matrices()
    if at_rest and drivers.is_bone(handle):
        handles.capture_bind(handle, drivers.bone_rest_matrix(handle.armature, handle.bone))
    else:
        handles.capture_bind(handle, drivers.bind_matrix_now(handle))


def capture_all_binds(obj, bones_at_rest=False):
    """Each handle's bind pose taken now (a bone's at its rest pose with `bones_at_rest`)."""
    sync_matrices()
    for i, h in enumerate(obj.arap.handles):
        try:
            drivers.check(h, None, h.group or "#%d" % (i + 1))
        except SetupError:
            continue    # nothing to take a pose from: gather() says so at the next bind
        if bones_at_rest and drivers.is_bone(h):
            handles.capture_bind(h, drivers.bone_rest_matrix(h.armature, h.bone))
        else:
            handles.capture_bind(h, drivers.bind_matrix_now(h))


def clear_cache():
    """Forget bound solvers and last results (e.g. after objects were deleted)."""
    solver_cache.clear()
    _last_results.clear()
