# SPDX-License-Identifier: GPL-3.0-or-later
"""A Live session: bind once, then follow the handle Empties with warm-started
solves (plain class, testable in --background; the modal operator in
live_ops.py drives it from Blender's event loop).

Two ways to drive it: step() solves on the caller's thread (scripts, tests,
benchmarks); update() is what the modal operator calls on Blender's main
thread: it hands new targets to a native worker thread (SolveWorker) and shows
the newest pose that thread has finished, so the viewport never waits for a
solve whatever the mesh size."""

import time

import bpy
import numpy as np

from . import constraints, meshio, rig, sessions
from .dependency_loops import DependencyLoop
from ..errors import SessionError, SetupError
from ..native_loader import native
from ..persistence.older_settings import setting
from .background_bind import BackgroundBind
from .problem import Problem, bind_warnings, configured_solver, contact_held, pose_contact_stop, sync_matrices


class FrameStats:
    """What one Live update cost (milliseconds) and where the pose stands."""

    def __init__(self, read_ms, solve_ms, write_ms, energy, iterations, main_thread_ms):
        self.read_ms = read_ms      # empties -> targets (and, with the worker, handing them over)
        self.solve_ms = solve_ms    # the native solve of the shown pose (on the worker's thread with update())
        self.write_ms = write_ms    # the pose into the mesh: foreach_set + mesh.update()
        self.energy = energy
        self.iterations = iterations
        self.main_thread_ms = main_thread_ms   # what the update held the caller's thread (Blender's UI) for

    @property
    def io_ms(self):
        return self.read_ms + self.write_ms


# How often a Live session compares the faces' corners (see meshio.Topology and LiveSession.check).
TOPOLOGY_CHECK_S = 1.0
SLOW_TOPOLOGY_CHECK_S = 10.0
# How many frame budgets a Live update may spend while the handles stand still and the pose settles
# (3 x 16 ms: the viewport still redraws at about 20 frames a second).
SETTLE_BUDGET_FACTOR = 3.0


def _last_energy(stats):
    return stats.energy[-1] if stats.energy else stats.initial_energy


class LiveSession:
    """Bind once, then read the empties, solve warm-started, write.

    step() spends at most the frame budget (live_frame_ms) on iterations. When
    nothing moved, it goes on from where the last one stopped (the
    quasi-Newton history is kept; up to SETTLE_BUDGET_FACTOR frame budgets a
    step) until the pose has settled (the tolerance); then, until something
    moves again, step(force=False) does nothing and returns None: Live sleeps.

    update() runs the same solves, chunks of one frame budget each, on the
    SolveWorker's thread, and the worker sleeps once the pose has settled (or
    after the Max Iterations setting's cap on one set of targets). cancel()
    restores the snapshot taken at start bit for bit; finish() keeps the
    newest finished pose.
    """

    def __init__(self, obj, scene=None, max_iterations=None, write=True, bind_on_thread=False):
        constraints.check_object(obj)
        if sessions.session_for(obj) is not None:
            # A second session would take the first one's pose as its rest shape.
            raise SetupError("'%s' is already being posed by a Live session: apply or cancel it first" % obj.name)
        self.obj = obj
        self.scene = scene
        sync_matrices()
        self.problem = Problem(obj, scene, cold_starts=False)
        self.n_vertices = len(obj.data.vertices)
        self.topology = meshio.Topology(obj.data)
        self._next_topology_check = time.monotonic() + TOPOLOGY_CHECK_S
        self.snapshot = meshio.Snapshot(obj)
        # Cancel means the state before Live: the Empties too.
        self.empties = meshio.TransformSnapshot(self._drivers())
        self.names = (obj.name, [h.driver.name for h in self.problem.setup.handles])
        self.collapsed = []     # handles whose Empty is scaled to almost nothing (the operator warns)
        self.contact = None     # problem.ContactStop: Self Contact stopped the last settled pose short
        self.contact_held = None   # what Self Contact did in the last solve shown (problem.contact_held)
        s = obj.arap
        self.frame_ms = s.live_frame_ms
        options = dict(warm=True, time_budget_ms=self.frame_ms,
                       max_iterations=max_iterations or setting(s, "live_max_iterations"))
        # bind_on_thread (the Live operator): the bind runs on a thread of its own and update() shows the
        # rest until it is done (the status says "binding"); else it is done here.
        self.solver = None
        self.binding = BackgroundBind(self.problem, s, **options) if bind_on_thread else None
        self.bind_ms = None
        self.buffer = np.empty(len(self.problem.rest32), np.float32)
        self.write_enabled = write
        self.output = meshio.Output(obj, self.problem.output)
        self.warnings = list(self.problem.setup.warnings)
        self.new_warnings = []   # the bind's warnings once it is done on its thread (the operator reports them)
        if self.binding is None:
            self._bound(configured_solver(self.problem, s, **options))
        self.last = None
        self.active = True
        self.converged = False
        self._pose_key = None    # HandlePose.key of the targets last solved for
        self.targets = None      # those targets
        self.worker = None       # the SolveWorker update() hands the solves to (created by its first call)
        self._settle_iterations = setting(s, "max_iterations")
        if write:
            self.output.ensure()
        sessions.add(self)

    def _bound(self, solver):
        self.solver = solver
        self.bind_ms = solver.bind_ms
        self.new_warnings = bind_warnings(solver.mesh_report(), self.problem, self.obj.arap)
        self.warnings += self.new_warnings

    def is_bound(self, wait=False):
        """True once the solver is bound (with `wait`, waits for a bind on its thread). Raises the bind's
        error (out of memory, a bad mesh)."""
        if self.solver is None:
            solver = self.binding.solver(wait)
            if solver is None:
                return False
            self.binding = None
            self._bound(solver)
        return True

    def check(self, full=False):
        """Raise SessionError when the object can no longer be posed. Element
        counts are compared every time; the faces' corners every
        TOPOLOGY_CHECK_S seconds where that is cheap (Blender 4.x, small
        meshes), else only while the pose has settled, every
        SLOW_TOPOLOGY_CHECK_S (an update that moves the pose stays short);
        everything with `full` (Apply, after an undo)."""
        try:
            obj = self.obj
            n = len(obj.data.vertices)
            mode = obj.mode
        except ReferenceError:
            raise self._object_deleted() from None
        if n != self.n_vertices:
            raise SessionError("The mesh's vertex count changed (%d -> %d): Live stopped"
                               % (self.n_vertices, n), 'TOPOLOGY')
        now = time.monotonic()
        due = now >= self._next_topology_check and (self.topology.cheap or self.converged)
        if full:
            same = self.topology.unchanged(obj.data)
        elif due:
            same = self.topology.unchanged(obj.data, corners_only=True)
        else:
            same = self.topology.counts_match(obj.data)
        if not same:
            raise SessionError("The mesh's faces changed (same vertex count, new connectivity): Live stopped",
                               'TOPOLOGY')
        if full or due:
            self._next_topology_check = now + (TOPOLOGY_CHECK_S if self.topology.cheap else SLOW_TOPOLOGY_CHECK_S)
        if mode != 'OBJECT':
            raise SessionError("'%s' left Object Mode: Live stopped" % obj.name, 'MODE')

    @property
    def settled(self):
        """The last update's solve converged: until something moves, step(force=False) does nothing."""
        return self.converged

    def step(self, force=True):
        """One update, solved on the caller's thread; with force=False returns
        None when the empties and the object did not move and the last solve
        had converged (settled)."""
        self.stop_worker()
        self.check()
        self.is_bound(wait=True)
        t0 = time.perf_counter()
        pose = self._read_pose()
        still = pose.key == self._pose_key
        if not force and self.converged and still:
            return None
        # While a handle moves, keep to the frame budget; once it stops, nobody waits for a
        # new frame of the handle, so the settling updates may take a few times longer.
        self.solver.time_budget_ms = self.frame_ms * (SETTLE_BUDGET_FACTOR if still else 1.0)
        targets = self._targets(pose)
        t1 = time.perf_counter()
        stats = self.solver.solve(targets, out=self.buffer)
        t2 = time.perf_counter()
        if self.write_enabled:
            self._show()
        t3 = time.perf_counter()
        self.converged = stats.converged
        self.contact_held = contact_held(self.problem, stats)
        self._check_contact()
        self.last = FrameStats((t1 - t0) * 1e3, (t2 - t1) * 1e3, (t3 - t2) * 1e3, _last_energy(stats),
                               stats.iterations, (t3 - t0) * 1e3)
        return self.last

    def update(self):
        """One tick of Blender's event loop: when the handles moved, hand the
        new targets to the worker thread; when the worker finished a solve,
        show it. Returns FrameStats when the mesh changed, else None. Never
        waits for a solve (the worker goes on between ticks until the pose
        has settled, then sleeps)."""
        self.check()
        if not self.is_bound():
            return None
        t0 = time.perf_counter()
        if self.worker is None:
            self.worker = native().SolveWorker(self.solver, max_iterations=self._settle_iterations)
        pose = self._read_pose()
        if pose.key != self._pose_key:
            self.worker.post(self._targets(pose))
            self.converged = False
        t1 = time.perf_counter()
        result = self.worker.take(self.buffer)
        if result is None:
            return None
        if self.write_enabled:
            self._show()
        t2 = time.perf_counter()
        stats = result.stats
        self.converged = result.settled and self.worker.settled
        self.contact_held = contact_held(self.problem, stats)
        self._check_contact()
        self.last = FrameStats((t1 - t0) * 1e3, sum(stats.iteration_ms) + stats.init_ms, (t2 - t1) * 1e3,
                               _last_energy(stats), result.iterations, (t2 - t0) * 1e3)
        return self.last

    def _check_contact(self):
        """Once the pose has settled: whether Self Contact stopped it short of the handles' targets (read from
        the pose: each update's solve goes on from the last one's)."""
        if self.converged:
            self.contact = pose_contact_stop(self.problem, self.buffer, self.targets)

    def _read_pose(self):
        """The handles' pose now (problem.HandlePose); SessionError 'EMPTY' when an Empty (or a bone or its
        armature) was deleted, 'LOOP' when one now follows the posed mesh (dependency_loops.py: each pose
        would move its own handle)."""
        sync_matrices()  # scripts move empties without a depsgraph update; cheap when nothing changed
        try:
            self.problem.check_drivers(self.scene)
        except SetupError as exc:
            raise SessionError(str(exc), 'EMPTY') from None
        try:
            self.problem.check_loops(self.obj)
        except DependencyLoop as exc:
            raise SessionError("%s: Live stopped" % exc, 'LOOP') from None
        return self.problem.pose(self.obj, self.scene)

    def _targets(self, pose):
        """The constrained vertices' targets for `pose`, remembered as the pose solved for (and
        its handles scaled to almost nothing, which the operator warns about)."""
        self._pose_key = pose.key
        self.collapsed = self.problem.collapsed(pose)
        self.targets = self.problem.targets(pose)
        return self.targets

    def stop_worker(self):
        """Give the solver back to the caller's thread: the worker's solve in progress ends after its
        iteration (at most one iteration's wait)."""
        if self.worker is not None:
            self.worker.stop()
            self.worker = None

    def _take_newest(self):
        """Show the newest pose the worker finished (if it finished one not shown yet)."""
        if self.worker is not None and self.worker.take(self.buffer) is not None and self.write_enabled:
            self._show()

    def _show(self):
        """Write the pose in hand (the rig's own deformation turned off first: the pose shown is ARAP's)."""
        rig.mute_armature(self.obj)
        self.output.write(self.buffer)

    def positions(self):
        """The current solution, flat float32 (3n), object-local."""
        return self.buffer

    def _drivers(self):
        return [h.driver for h in self.problem.setup.handles]

    def _object_deleted(self):
        # The name as it was at the start: a deleted object's own can no longer be read.
        return SessionError("Live stopped: the object '%s' was deleted" % self.names[0], 'OBJECT')

    def _find_object(self, objects):
        """Take the posed object of that name in `objects` (an undo reloads it); SessionError 'OBJECT'
        when there is none."""
        obj = objects.get(self.names[0])
        if obj is None or obj.type != 'MESH':
            raise self._object_deleted()
        self.obj = self.snapshot.obj = self.output.obj = obj

    def references_lost(self):
        """True when Blender replaced the objects this session holds (an undo
        reloads them): the session must find them again (reattach)."""
        try:
            self.obj.name
            for driver in self._drivers():
                driver.name
        except ReferenceError:
            return True
        return False

    def reattach(self, objects, scene=None):
        """After an undo: find the posed object and the handle Empties again by
        name in `objects` (bpy.data.objects; `scene`: the current scene) and go
        on posing the restored handles. Raises SessionError naming the object
        ('OBJECT') or the Empty ('EMPTY') that is gone, or when the mesh changed."""
        empty_names = self.names[1]
        if self.scene is not None:
            self.scene = scene
        self._find_object(objects)
        empties = [objects.get(name) for name in empty_names]
        for name, empty in zip(empty_names, empties):
            if empty is None:
                # Cancel restores the mesh (the object is there).
                raise SessionError("Live stopped: the handle Empty '%s' was deleted" % name, 'EMPTY')
        for handle, empty in zip(self.problem.setup.handles, empties):
            handle.set_driver(empty)
        self._pose_key = None    # solve for the restored handles
        self.converged = False
        self.check(full=True)

    def cancel(self):
        """Restore the mesh and the handle Empties exactly as they were when the session started.
        When the posed object was deleted, stop without touching anything (the Empties stay where
        they are) and raise SessionError 'OBJECT' naming it; when its vertex count changed, put the
        Empties back, leave the mesh as it is and raise SessionError 'TOPOLOGY'."""
        self.stop_worker()
        if self.active:
            self.active = False
            sessions.discard(self)
            try:
                self.obj.name
            except ReferenceError:
                self._find_object(bpy.data.objects)
            n = len(self.obj.data.vertices)
            if n != self.n_vertices:
                self.empties.restore(bpy.data.objects)
                sync_matrices()
                raise SessionError("The mesh's vertex count changed (%d -> %d): Live stopped, the mesh was not "
                                   "restored" % (self.n_vertices, n), 'TOPOLOGY')
            self.snapshot.restore()
            self.empties.restore(bpy.data.objects)
            rig.restore_armature(self.obj)
            sync_matrices()

    def before_save(self):
        """A .blend saved now holds the pose on screen: with output in the mesh, store the rest shape
        beside it (as Apply would) so that the file can go back to rest. Cancel still removes it."""
        if self.active and self.problem.output == 'MESH' and not meshio.has_rest_attribute(self.obj.data):
            meshio.store_rest(self.obj.data, self.problem.rest32)

    def finish(self):
        """Keep the current result. Raises SessionError (and stops without
        keeping anything more) when the faces changed since the last check."""
        if self.active:
            try:
                self.check(full=True)
            except SessionError:
                sessions.stop_session(self)
                raise
            try:
                self._take_newest()
            finally:
                self.stop_worker()
            self.active = False
            sessions.discard(self)
            if self.problem.output == 'MESH' and not self.snapshot.had_rest:
                meshio.store_rest(self.obj.data, self.problem.rest32)
