# SPDX-License-Identifier: GPL-3.0-or-later
"""The only importer of the native module: numpy <-> bpy, solver cache,
one-shot deform and the Live session (plain classes, testable in --background).
"""

import glob
import os
import re
import sys
import time

import bpy
import numpy as np

from . import constraints, meshio
from .constraints import SetupError

WEIGHT_NAMES = {'COTAN': "cotan", 'COTAN_CLAMPED': "cotan-clamped", 'UNIFORM': "uniform"}
INIT_NAMES = {'LAPLACIAN': "laplacian", 'DIFFERENTIAL': "differential", 'NAIVE': "naive"}
METHOD_NAMES = {'QUASI_NEWTON': "quasi-newton", 'LOCAL_GLOBAL': "local-global", 'ANDERSON': "anderson"}
VOLUME_NAMES = {'NONE': "none", 'GLOBAL': "global", 'INFILL': "infill"}


def volume_options(settings):
    """The bind arguments of the object's Volume setting (native names)."""
    return {"volume": VOLUME_NAMES[settings.volume], "infill_resolution": settings.infill_resolution}


def solver_method(settings):
    """The native method for the object's settings: its Method, except that Anderson's extrapolated points
    are not checked against the volume terms, so with Volume on it falls back to Quasi-Newton
    (method_warning() says so)."""
    if settings.volume != 'NONE' and settings.method == 'ANDERSON':
        return METHOD_NAMES['QUASI_NEWTON']
    return METHOD_NAMES[settings.method]


def method_warning(settings):
    if settings.volume != 'NONE' and settings.method == 'ANDERSON':
        return "Volume %s needs Quasi-Newton or Local/Global: solved with Quasi-Newton" % settings.volume.title()
    return None

_native = None


class NativeModuleError(ImportError):
    """The compiled module is missing or was built for another add-on/Python."""


def addon_version():
    """The add-on's version, from blender_manifest.toml (the one source: Blender
    removes bl_info from extensions, and CMake checks bl_info against it)."""
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "blender_manifest.toml")
    with open(path, encoding="utf-8") as f:
        match = re.search(r'^version\s*=\s*"([^"]+)"', f.read(), re.MULTILINE)
    if match is None:
        raise NativeModuleError("%s has no version line: the add-on is damaged, reinstall it" % path)
    return match.group(1)


def native():
    """Import _arap_native on first use and check it matches this add-on."""
    global _native
    if _native is not None:
        return _native
    here = os.path.dirname(os.path.abspath(__file__))
    py = "%d.%d" % sys.version_info[:2]
    rebuild = ("Rebuild the module for Python %s on a Linux with that Python's headers: cmake -S <source> -B build "
               "-DARAP_PYTHON_VERSION=%s && cmake --build build, then install build/arap_deform.zip (README, "
               "'Blender versions')" % (py, py))
    try:
        from . import _arap_native as mod
    except ImportError as exc:
        # One file per Python ABI may sit here (_arap_native.cpython-311-x86_64-linux-gnu.so, ...);
        # Python picks the one whose tag matches its own.
        found = sorted(os.path.basename(p) for p in glob.glob(os.path.join(here, "_arap_native*")))
        tags = sorted(set(re.findall(r"cpython-(\d)(\d+)", " ".join(found))), key=lambda t: int(t[1]))
        if found and sys.implementation.cache_tag.replace("-", "") not in {"cpython%s%s" % t for t in tags}:
            msg = ("This Blender runs Python %s, but the add-on carries its native module only for Python %s "
                   "(%s). " % (py, ", ".join("%s.%s" % t for t in tags) or "?", ", ".join(found)))
        elif found:
            msg = ("The ARAP native module %s does not load in this Blender (Python %s, %s): %s. "
                   % (", ".join(found), py, sys.implementation.cache_tag, exc))
        else:
            msg = "The ARAP native module (_arap_native) is missing from %s. " % here
        raise NativeModuleError(msg + rebuild) from exc
    if tuple(mod.PYTHON_VERSION) != tuple(sys.version_info[:2]):
        raise NativeModuleError("The ARAP native module was built for Python %d.%d (%s) but Blender runs "
                                "Python %s. %s" % (*mod.PYTHON_VERSION, mod.PYTHON_ABI, py, rebuild))
    if mod.__version__ != addon_version():
        raise NativeModuleError("The ARAP native module is version %s but the add-on is %s: rebuild the "
                                "module from the same sources as the add-on. %s"
                                % (mod.__version__, addon_version(), rebuild))
    _native = mod
    return mod


def native_error_type():
    return native().ArapError


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


# Bound solvers reused across redo-panel re-runs, keyed on object, topology,
# rest shape, constraint set and weights (as LoopTools caches its data).
_cache = {}
_CACHE_SIZE = 4


def _digest(*arrays):
    return hash(tuple(a.tobytes() for a in arrays))


def bound_solver(obj, rest64, tris, constrained, weights, stiffness=None, volume=None):
    """(solver, bind_ms, cached) for these inputs; binds only when they changed.
    volume: volume_options() (None: surface only)."""
    stiff = np.empty(0) if stiffness is None else stiffness
    volume = volume or {}
    key = (obj.as_pointer(), len(rest64), _digest(rest64, tris, constrained, stiff), weights,
           tuple(sorted(volume.items())))
    hit = _cache.get(obj.as_pointer())
    if hit is not None and hit[0] == key:
        return hit[1], 0.0, True
    solver = native().Solver()
    solver.bind(rest64, tris, constrained, weights=weights, stiffness=stiffness, **volume)
    _cache[obj.as_pointer()] = (key, solver)
    while len(_cache) > _CACHE_SIZE:
        _cache.pop(next(iter(_cache)))
    return solver, solver.bind_ms, False


def clear_cache():
    """Forget bound solvers and last results (e.g. after objects were deleted)."""
    _cache.clear()
    _last_results.clear()


def unconstrained_warning(report):
    n = report["unconstrained_components"]
    if n == 0:
        return None
    return ("%d vertices in %d part(s) have no fixed or handle vertex: they keep their rest shape"
            % (report["unconstrained_vertices"], n))


def volume_warning(report, volume):
    """Volume Global keeps closed parts only: say which were left alone."""
    if volume.get("volume") != "global":
        return None
    n = report["volume_open_components"]
    if n == 0:
        return None
    if report["volume_kept_components"] == 0:
        return ("Volume Global keeps nothing here: the mesh has no closed part (%d open); try Volume Infill" % n)
    return ("Volume Global keeps the volume of %d closed part(s); %d open part(s) are left as they are"
            % (report["volume_kept_components"], n))


def unconverged_warning(stats, max_iterations, tolerance):
    if stats.converged or tolerance <= 0:
        return None
    return ("The pose had not settled after %d iterations (tolerance %g): raise Iterations in the Solver "
            "panel, or run Deform again to go on" % (max_iterations, tolerance))


def collapsed_handles_warning(problem, obj, scene):
    """A warning naming handles whose Empty is scaled to (almost) nothing since
    its bind pose: their vertices collapse to a point."""
    names = constraints.collapsed_handles(problem.setup, problem.empty_matrices(scene))
    if not names:
        return None
    return ("The Empty of handle%s %s is scaled to almost nothing: %s vertices collapse to a point"
            % ("s" if len(names) > 1 else "", ", ".join("'%s'" % n for n in names),
               "their" if len(names) > 1 else "its"))


class Problem:
    """Everything read from Blender for one bind: rest, triangles, constraints."""

    def __init__(self, obj, scene):
        self.setup = constraints.gather(obj, scene)
        s = obj.arap
        self.output = meshio.resolve_output(obj, s.output)
        self.rest32 = meshio.rest_coords(obj, self.output)
        self.rest64 = self.rest32.astype(np.float64).reshape(-1, 3)
        self.tris = meshio.triangles(obj.data)
        if len(self.tris) == 0:
            raise SetupError("'%s' has no faces: ARAP needs a surface" % obj.name)
        self.rest_constrained = self.rest64[self.setup.constrained]
        self.targets = np.empty_like(self.rest_constrained)
        self.weights = WEIGHT_NAMES[s.weights]
        self.stiffness = constraints.stiffness_of(obj)
        self.volume = volume_options(s)

    def empty_matrices(self, scene):
        mats = []
        for h in self.setup.handles:
            if not constraints.empty_is_alive(h.empty, scene):
                raise SetupError("The empty of handle '%s' was deleted" % h.group)
            mats.append(constraints.matrix_to_numpy(h.empty.matrix_world))
        return mats

    def compute_targets(self, obj, scene):
        transforms = constraints.handle_transforms(
            self.setup, constraints.matrix_to_numpy(obj.matrix_world), self.empty_matrices(scene), obj.name)
        return constraints.fill_targets(self.setup, self.rest_constrained, transforms, self.targets)


def configured_solver(problem, settings, warm=False):
    """A solver bound to `problem` with the object's settings (`warm`: each
    solve() starts from the last solution, the first from the cold guess)."""
    solver = native().Solver()
    solver.bind(problem.rest64, problem.tris, problem.setup.constrained, weights=problem.weights,
                stiffness=problem.stiffness, **problem.volume)
    solver.max_iterations = settings.iterations
    solver.tolerance = settings.tolerance
    solver.method = solver_method(settings)
    solver.anderson_window = settings.acceleration
    solver.threads = settings.threads
    if warm:
        solver.cold_start = INIT_NAMES[settings.init]
        solver.init = "warm"
    else:
        solver.init = INIT_NAMES[settings.init]
    return solver


def topology_counts(mesh):
    """Vertex, edge, loop and face counts: a cheap check that the topology the
    solver was bound to is still there."""
    return (len(mesh.vertices), len(mesh.edges), len(mesh.loops), len(mesh.polygons))


def sync_matrices():
    """Bring matrix_world up to date after scripts changed location/rotation
    (Blender updates it only when the depsgraph is evaluated)."""
    view_layer = getattr(bpy.context, "view_layer", None)
    if view_layer is not None:
        view_layer.update()


def deform(obj, scene=None, iterations=None, tolerance=None, init=None):
    """One-shot solve from the rest shape; writes the result (mesh or shape key).

    Raises SetupError or the native ArapError; the mesh is untouched then.
    """
    t0 = time.perf_counter()
    sync_matrices()
    problem = Problem(obj, scene)
    targets = problem.compute_targets(obj, scene)
    s = obj.arap
    solver, bind_ms, cached = bound_solver(obj, problem.rest64, problem.tris, problem.setup.constrained,
                                           problem.weights, problem.stiffness, problem.volume)
    solver.max_iterations = iterations if iterations else s.iterations
    solver.tolerance = s.tolerance if tolerance is None else tolerance
    solver.init = INIT_NAMES[init or s.init]
    solver.method = solver_method(s)
    solver.anderson_window = s.acceleration
    solver.time_budget_ms = 0.0
    solver.threads = s.threads
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
    warnings = list(problem.setup.warnings)
    for w in (unconstrained_warning(report), volume_warning(report, problem.volume), method_warning(s),
              collapsed_handles_warning(problem, obj, scene),
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


class FrameStats:
    def __init__(self, read_ms, solve_ms, write_ms, energy, iterations):
        self.read_ms = read_ms      # empties -> targets
        self.solve_ms = solve_ms    # native solve (warm start) incl. copy into the float32 buffer
        self.write_ms = write_ms    # foreach_set + mesh.update()
        self.energy = energy
        self.iterations = iterations

    @property
    def io_ms(self):
        return self.read_ms + self.write_ms

    @property
    def total_ms(self):
        return self.read_ms + self.solve_ms + self.write_ms


class SessionError(Exception):
    """The Live session cannot go on. kind: 'OBJECT', 'TOPOLOGY', 'MODE' or 'EMPTY'."""

    def __init__(self, message, kind):
        super().__init__(message)
        self.kind = kind


def user_error(exc):
    """The message to show for errors a user can act on, else None (a bug: re-raise)."""
    if isinstance(exc, (SetupError, SessionError, NativeModuleError)):
        return str(exc)
    if _native is not None and isinstance(exc, _native.ArapError):
        return "ARAP solver: %s" % exc
    return None


_sessions = set()

# How often a Live session compares the faces in full (see meshio.Topology).
TOPOLOGY_CHECK_S = 1.0
# How many frame budgets a Live update may spend while the handles stand still and the pose settles
# (3 x 16 ms: the viewport still redraws at about 20 frames a second).
SETTLE_BUDGET_FACTOR = 3.0


class LiveSession:
    """Bind once, then step(): read empties, solve warm-started, write.

    Each step spends at most the frame budget (live_frame_ms) on iterations, so
    the viewport stays interactive while a handle moves. When nothing moved,
    step() goes on from where the last one stopped (the quasi-Newton history is
    kept; up to SETTLE_BUDGET_FACTOR frame budgets a step) until the pose has
    settled (the tolerance); then, until something moves again,
    step(force=False) does nothing and returns None: Live sleeps.
    The modal operator is a thin shell around this; scripts and tests drive
    it directly. cancel() restores the snapshot taken at start bit for bit.
    """

    def __init__(self, obj, scene=None, iterations=None, write=True):
        constraints.check_object(obj)
        if session_for(obj) is not None:
            # A second session would take the first one's pose as its rest shape.
            raise SetupError("'%s' is already being posed by a Live session: apply or cancel it first" % obj.name)
        self.obj = obj
        self.scene = scene
        sync_matrices()
        self.problem = Problem(obj, scene)
        self.n_vertices = len(obj.data.vertices)
        self.topology = meshio.Topology(obj.data)
        self._next_topology_check = time.monotonic() + TOPOLOGY_CHECK_S
        self.snapshot = meshio.Snapshot(obj)
        # Cancel means the state before Live: the Empties too.
        self.empties = meshio.TransformSnapshot(self._empties())
        self.names = (obj.name, [h.empty.name for h in self.problem.setup.handles])
        self.collapsed = []     # handles whose Empty is scaled to almost nothing (the operator warns)
        s = obj.arap
        self.solver = native().Solver()
        self.solver.bind(self.problem.rest64, self.problem.tris, self.problem.setup.constrained,
                         weights=self.problem.weights, stiffness=self.problem.stiffness, **self.problem.volume)
        self.bind_ms = self.solver.bind_ms
        self.solver.max_iterations = iterations or s.live_iterations
        self.solver.tolerance = s.tolerance
        self.solver.cold_start = INIT_NAMES[s.init]
        self.solver.init = "warm"
        self.solver.method = solver_method(s)
        self.solver.anderson_window = s.acceleration
        self.frame_ms = s.live_frame_ms
        self.solver.time_budget_ms = self.frame_ms
        self.solver.threads = s.threads
        self.buffer = np.empty(len(self.problem.rest32), np.float32)
        self.write_enabled = write
        self.output = meshio.Output(obj, self.problem.output)
        self.warnings = list(self.problem.setup.warnings)
        for w in (unconstrained_warning(self.solver.mesh_report()),
                  volume_warning(self.solver.mesh_report(), self.problem.volume), method_warning(s)):
            if w:
                self.warnings.append(w)
        self.last = None
        self.active = True
        # Set by the panel's Apply/Cancel buttons; the modal operator acts on it.
        self.request = None
        self.converged = False
        self._pose = None
        if write:
            self.output.ensure()
        _sessions.add(self)

    def check(self, full=False):
        """Raise SessionError when the object can no longer be posed. The
        faces are compared in full at most every TOPOLOGY_CHECK_S seconds (or
        with `full`); element counts every time."""
        try:
            obj = self.obj
            n = len(obj.data.vertices)
            mode = obj.mode
        except ReferenceError:
            raise SessionError("The posed object was deleted", 'OBJECT') from None
        if n != self.n_vertices:
            raise SessionError("The mesh's vertex count changed (%d -> %d): Live stopped"
                               % (self.n_vertices, n), 'TOPOLOGY')
        now = time.monotonic()
        full = full or now >= self._next_topology_check
        if not (self.topology.unchanged(obj.data) if full else self.topology.counts_match(obj.data)):
            raise SessionError("The mesh's faces changed (same vertex count, new connectivity): Live stopped",
                               'TOPOLOGY')
        if full:
            self._next_topology_check = now + TOPOLOGY_CHECK_S
        if mode != 'OBJECT':
            raise SessionError("'%s' left Object Mode: Live stopped" % obj.name, 'MODE')

    @property
    def settled(self):
        """The last update's solve converged: until something moves, step(force=False) does nothing."""
        return self.converged

    def step(self, force=True):
        """One update; with force=False returns None when the empties and the
        object did not move and the last solve had converged (settled)."""
        self.check()
        t0 = time.perf_counter()
        sync_matrices()  # scripts move empties without a depsgraph update; cheap when nothing changed
        try:
            mats = self.problem.empty_matrices(self.scene)
        except SetupError as exc:
            raise SessionError(str(exc), 'EMPTY') from None
        obj_matrix = constraints.matrix_to_numpy(self.obj.matrix_world)
        pose = np.concatenate([obj_matrix.ravel()] + [m.ravel() for m in mats])
        still = self._pose is not None and np.array_equal(pose, self._pose)
        if not force and self.converged and still:
            return None
        self._pose = pose
        self.collapsed = constraints.collapsed_handles(self.problem.setup, mats)
        # While a handle moves, keep to the frame budget; once it stops, nobody waits for a
        # new frame of the handle, so the settling updates may take a few times longer.
        self.solver.time_budget_ms = self.frame_ms * (SETTLE_BUDGET_FACTOR if still else 1.0)
        transforms = constraints.handle_transforms(self.problem.setup, obj_matrix, mats, self.obj.name)
        targets = constraints.fill_targets(self.problem.setup, self.problem.rest_constrained, transforms,
                                           self.problem.targets)
        t1 = time.perf_counter()
        stats = self.solver.solve(targets, out=self.buffer)
        t2 = time.perf_counter()
        if self.write_enabled:
            self.output.write(self.buffer)
        t3 = time.perf_counter()
        energy = stats.energy[-1] if stats.energy else stats.initial_energy
        self.converged = stats.converged
        self.last = FrameStats((t1 - t0) * 1e3, (t2 - t1) * 1e3, (t3 - t2) * 1e3, energy, stats.iterations)
        return self.last

    def positions(self):
        """The current solution, flat float32 (3n), object-local."""
        return self.buffer

    def _empties(self):
        return [h.empty for h in self.problem.setup.handles]

    def references_lost(self):
        """True when Blender replaced the objects this session holds (an undo
        reloads them): the session must find them again (reattach)."""
        try:
            self.obj.name
            for empty in self._empties():
                empty.name
        except ReferenceError:
            return True
        return False

    def reattach(self, objects, scene=None):
        """After an undo: find the posed object and the handle Empties again by
        name in `objects` (bpy.data.objects; `scene`: the current scene) and go
        on posing the restored handles. Raises SessionError when they are gone
        or the mesh changed."""
        obj_name, empty_names = self.names
        if self.scene is not None:
            self.scene = scene
        obj = objects.get(obj_name)
        empties = [objects.get(name) for name in empty_names]
        if obj is None or obj.type != 'MESH' or any(e is None for e in empties):
            raise SessionError("Undo removed the posed object or a handle Empty: Live stopped", 'OBJECT')
        self.obj = obj
        self.snapshot.obj = obj
        self.output.obj = obj
        for handle, empty in zip(self.problem.setup.handles, empties):
            handle.empty = empty
        self._pose = None    # solve for the restored handles
        self.converged = False
        self.check(full=True)

    def cancel(self):
        """Restore the mesh and the handle Empties exactly as they were when the session started."""
        if self.active:
            self.active = False
            _sessions.discard(self)
            self.snapshot.restore()
            self.empties.restore(bpy.data.objects)
            sync_matrices()

    def finish(self):
        """Keep the current result. Raises SessionError (and stops without
        keeping anything more) when the faces changed since the last check."""
        if self.active:
            try:
                self.check(full=True)
            except SessionError:
                stop_session(self)
                raise
            self.active = False
            _sessions.discard(self)
            if self.problem.output == 'MESH' and not self.snapshot.had_rest:
                meshio.store_rest(self.obj.data, self.problem.rest32)


def session_for(obj):
    """The running Live session posing `obj`, or None."""
    for session in _sessions:
        try:
            if session.obj == obj:
                return session
        except ReferenceError:
            continue
    return None


def target_mesh(context):
    """The mesh the panel and the operators act on: the active mesh object,
    or, when a handle's Empty is active, the mesh it poses (the one Live is
    posing first), so that selecting an Empty does not hide the panel."""
    obj = context.active_object
    if obj is None:
        return None
    if obj.type == 'MESH':
        return obj
    if obj.type != 'EMPTY':
        return None
    session = any_session()
    if session is not None and session.active:
        try:
            if any(h.empty == obj for h in session.obj.arap.handles):
                return session.obj
        except ReferenceError:
            pass
    for ob in context.view_layer.objects:
        if ob.type == 'MESH' and any(h.empty == obj for h in ob.arap.handles):
            return ob
    return None


def any_session():
    """Some running Live session (the panel shows it while an empty is active), or None."""
    for session in _sessions:
        return session
    return None


def stop_session(session):
    """Forget a session without restoring (its object or topology is gone)."""
    session.active = False
    _sessions.discard(session)


def stop_all_sessions():
    """Cancel every running Live session (add-on disabled, file loaded)."""
    for session in list(_sessions):
        try:
            session.cancel()
        except (ReferenceError, ValueError):
            session.active = False
            _sessions.discard(session)
