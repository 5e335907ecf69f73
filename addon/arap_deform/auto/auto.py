# SPDX-License-Identifier: GPL-3.0-or-later
"""Auto mode: an object's pose follows its handle Empties whenever they change,
like a modifier, with no session to start (Object.arap.auto, saved in the .blend).

Blender's handlers drive it: after every depsgraph update and frame change the
pose key of each Auto object -- the frame, and the evaluated world matrices of
the object and of its handle Empties, so keyframes, drivers, constraints and
parents all count -- is compared with the one last written. Nothing is solved
when it did not change (our own writes trigger depsgraph updates too; they find
the same key).

A new key is solved to the object's tolerance from a cold start (the first
guess from the rest shape), and the result is cached: a frame's pose is a
function of its handles alone, bit for bit the same whether the frame is played,
scrubbed, jumped to, rendered alone, rendered in chunks by other processes or
baked (the energy is not convex: a warm start from the previous frame could
settle elsewhere). Playing a range solves each frame once; scrubbing back to a
frame writes its cached pose. In the viewport the solves run on a native worker
thread (SolveWorker) and a timer shows its newest pose until the pose has
settled, then stops (no CPU while idle): Blender's own input never waits for a
solve. There the worker first follows the handles from the pose on screen (a
preview while an Empty is dragged or the animation plays); once that has
settled it solves the same handles from the cold start, shows that pose and
caches it. While an animation plays, each frame played is also queued for a
second solver (final_poses.py) that solves it from the cold start: the next
loop shows final poses from the cache. In --background and while rendering every pose is solved to the end,
here, from the cold start.

An error (a deleted Empty, a changed vertex count, Edit Mode) turns Auto off for
that object, puts back what the mesh showed before (restore_rest) and leaves the reason in
obj.arap.auto_status; the handlers themselves never raise. A handle Empty that
follows the posed mesh (dependency_loops.py), found when Auto starts or before
any later solve, turns it off the same way but keeps the last pose written.
"""

import time
import traceback

import bmesh
import bpy
import numpy as np
from bpy.app.handlers import persistent

from .. import errors
from ..persistence import properties
from ..solver import bake, meshio, problem, rig, sessions
from ..ui import panels, status_overlay
from ..solver.background_bind import BackgroundBind
from .final_poses import FinalPoses
from ..solver.dependency_loops import DependencyLoop
from ..errors import SetupError
from ..native_loader import native
from ..persistence.older_settings import setting

FRAME_BUDGET_MS = 30.0      # in the viewport, the worker shows a new pose at least this often while it solves
POLL_S = 1.0 / 60.0         # how often the viewport looks for the worker's newest pose
SETTLED_SHOWN_S = 2.0       # the viewport says "settled" this long after a pose settles
CACHE_BYTES = 256 << 20     # solved poses kept per object (least recently used dropped first)
PROP_CREATED = "arap_auto_created"   # mesh custom property: what turning Auto on created
BEFORE_ATTRIBUTE = "arap_before_auto"   # point attribute: a pose the output showed when Auto was turned on

_posers = {}     # obj.as_pointer() -> AutoPoser (dropped on undo and load, when pointers change)
_busy = False    # a handler is writing: its own depsgraph updates must not re-enter
_timer_on = False
solve_count = 0  # solve() calls made by Auto mode (tests count them to check idling)


class AutoPoser:
    """One object's bound solver, its cache of solved poses and what was written."""

    def __init__(self, obj, scene, on_worker=False):
        self.obj = obj   # Blender invalidates it when the object is deleted (alive())
        self.setup_key = setup_key(obj)
        self.fingerprint = problem.topology_counts(obj.data)
        # In the viewport (a file just opened, an undo, Auto turned on) the mesh is read over several
        # updates (the vertex groups a chunk at a time) and the bind runs on a thread of its own: Blender's
        # thread never waits long, and the mesh shows what it showed until the first pose is ready.
        self.reading = None      # the steps of problem.Problem.read_in_steps, while they run
        self.problem = None
        self.binding = None
        self.solver = None
        self.output = None
        self.buffer = None       # in the viewport: the preview shown
        self.warnings = []
        self.cold = None         # the viewport's cold solve is taken here (its iterates are not shown)
        self.cache = {}          # pose key -> (float32 positions, handle transforms)
        self.contacts = {}       # pose key -> problem.ContactStop, for the cached poses Self Contact stopped short
        self.contact = None      # the ContactStop of the pose written, if it was stopped short
        self.held = {}           # pose key -> problem.contact_held's line of its solve (Self Contact on)
        self.contact_held = None   # that line for the pose written
        self.cache_bytes = 0
        self.written = None      # pose key of the mesh's current coordinates
        self.pending = None      # pose key being solved across updates (by the worker, in the viewport)
        self.iterations = 0      # spent on the pending pose
        self.max_iterations = max(setting(obj.arap, "max_iterations"), bake.DEFAULT_ITERATIONS)   # per pose
        self.current = None      # handle transforms of the solver's current state
        self.state_key = None    # the pose key the solver's current state belongs to
        self.by_frame = {}       # frame -> key of its last settled pose (the next frame starts there)
        self.name = obj.name
        self.settled = True          # the shown pose is the settled one of the handles' current place
        self.settled_at = 0.0        # time.monotonic() when it last settled
        self.worker = None           # the SolveWorker of the viewport's solves while one runs
        self.targets = None          # the pending pose's targets (the worker's)
        self.final = False           # the worker solves them from the cold start (else: a preview)
        self.finals = None           # FinalPoses: the played frames' final poses, on a second solver
        self.frame_keys = {}         # frame -> the pose key last shown there in the viewport
        self.frame_range = (1, 1)    # the scene's, when last updated
        if on_worker:
            self.reading = problem.Problem.read_in_steps(obj, scene)
        else:
            self._read(problem.Problem(obj, scene), on_worker)

    def _read(self, read, on_worker):
        """The object's Problem is read: bind it (on a thread of its own in the viewport) and note what
        turning Auto on creates (_created)."""
        self.problem = read
        if on_worker:
            self.binding = BackgroundBind(read, self.obj.arap, warm=True)
        else:
            self.solver = problem.configured_solver(read, self.obj.arap, warm=True)
        self.output = meshio.Output(self.obj, read.output)
        self.buffer = np.empty(len(read.rest32), np.float32)
        self.warnings = list(read.setup.warnings)
        _created(self.obj, self)

    def _read_step(self):
        """One step of reading the object (viewport); True once the Problem is read and its bind started."""
        if self.reading is not None:
            try:
                next(self.reading)
                return False
            except StopIteration as done:
                self.reading = None
                self._read(done.value, on_worker=True)
        return True

    def alive(self):
        """False once the object this poser was made for is deleted (a new object can land at its address)."""
        try:
            self.obj.name
        except ReferenceError:
            return False
        return True

    def update(self, obj, depsgraph, on_worker=False):
        """Bring the mesh to the current pose. Returns True when it is settled
        (False: iterations remain, call again). on_worker: solve on the
        worker's thread and show its newest pose (the viewport); else here,
        to the end (--background, renders)."""
        if not self._read_step():
            self._settled(False)
            return False
        # A handle Empty that follows this mesh would make each pose ask for another: stop before solving.
        self.problem.check_loops(obj)
        if not self._bound(wait=not on_worker):
            self._settled(False)
            return False
        # The pose key: the frame and the evaluated world matrices of the object and the Empties.
        pose = self.problem.pose(obj, depsgraph=depsgraph)
        scene = depsgraph.scene
        key = (scene.frame_current, pose.key)
        if on_worker:
            self._take_final_poses()
            self.frame_keys[key[0]] = key
            self.frame_range = (scene.frame_start, scene.frame_end)
        if key == self.written and self.pending is None:
            return True
        hit = self.cache.get(key)
        if hit is not None:
            self.stop_worker()
            self.pending = None
            self.contact = self.contacts.get(key)
            self.contact_held = self.held.get(key)
            self._write(hit[0], key)
            self._settled(True)
            return True
        if on_worker:
            return self._solve_on_worker(key, pose)
        self.stop_worker()
        return self._solve_here(key, pose)

    def _solve_here(self, key, pose):
        global solve_count
        self.problem.cold_start(self.solver, pose.transforms)   # the pose of these handles, whatever came before
        targets = self.problem.targets(pose)
        self.solver.time_budget_ms = 0.0
        self.solver.max_iterations = self.max_iterations
        stats = self.solver.solve(targets, out=self.buffer)
        solve_count += 1
        self.iterations = stats.iterations
        self.pending = None
        self.state_key, self.current = key, [t.copy() for t in pose.transforms]
        self.contact = problem.contact_stop(self.problem, stats)
        self.contact_held = problem.contact_held(self.problem, stats)
        self._write(self.buffer, key)
        self._remember(key, self.buffer.copy(), pose.transforms, self.contact, self.contact_held)
        self._settled(True)
        return True

    def _solve_on_worker(self, key, pose):
        """New targets go to the worker, which follows them from its current state (a preview); once
        that has settled, the same targets are solved from the cold start: that pose is shown and
        cached (the pose a render gives). Until then the newest preview is shown."""
        global solve_count
        if self.pending != key:
            if self.worker is not None and self.final:
                # The handles moved during the cold solve, whose iterates were never shown: the new
                # preview goes on from the pose on screen, not from one of those.
                self.stop_worker()
                self.solver.set_positions(self.buffer.reshape(-1, 3).astype(np.float64))
                self.state_key = None
            if self.worker is None:
                self._warm_start(key, pose.transforms)   # the solver is still this thread's: pick the start
                self.solver.time_budget_ms = FRAME_BUDGET_MS
                self.solver.max_iterations = self.max_iterations
                self.worker = native().SolveWorker(self.solver, max_iterations=self.max_iterations)
            self.state_key, self.current = key, [t.copy() for t in pose.transforms]
            self.targets = self.problem.targets(pose)
            self.worker.post(self.targets)
            if _playing():
                self._want_final_pose(key, pose.transforms)
            solve_count += 1
            self.pending, self.iterations, self.final = key, 0, False
            self._settled(False)   # a new pose, settling (the worker may have settled it by the take below)
        if self.final and self.cold is None:
            self.cold = np.empty_like(self.buffer)
        out = self.cold if self.final else self.buffer
        result = self.worker.take(out)
        if result is None:
            self._settled(False)
            return False
        self.iterations = result.iterations
        # Settled only when the worker has nothing newer in hand (result is then the pending pose's).
        settled = result.settled and self.worker.settled
        if not self.final:
            self._write(self.buffer, None)
            if settled:
                self.worker.post(self.targets, restart=True, start=self.problem.start_shape(self.current))
                self.final = True
            self._settled(False)
            return False
        if not settled:
            self._settled(False)
            return False   # the preview stays on screen until the cold solve has settled
        # Read from the pose: each of the worker's solves goes on from the last one's.
        self.contact = problem.pose_contact_stop(self.problem, out, self.targets)
        self.contact_held = problem.contact_held(self.problem, result.stats)   # the cold solve's last chunk
        self._write(out, key)
        self.pending = None
        self._remember(key, out.copy(), pose.transforms, self.contact, self.contact_held)
        self.stop_worker()
        self._settled(True)
        return True

    def _want_final_pose(self, key, transforms):
        """Queue `key`'s final pose on the second solver (made the first time a frame is played)."""
        if self.finals is None:
            self.finals = FinalPoses(self.problem, self.obj.arap, self.max_iterations)
        self.finals.want(key, self.targets, transforms)

    def _take_final_poses(self):
        """Cache the final poses the second solver finished."""
        if self.finals is None:
            return
        for key, positions, transforms, stats in self.finals.poll():
            self._remember(key, positions, transforms, problem.contact_stop(self.problem, stats),
                           problem.contact_held(self.problem, stats))
        if self.finals.failed is not None and self.finals.failed != "stopped":
            print("ARAP Auto: no final poses while playing '%s' (%s)" % (self.name, self.finals.failed))
            self.finals.stop()

    def finals_busy(self):
        """The second solver has frames to solve (its poses are polled at each update)."""
        return self.finals is not None and self.finals.busy()

    def frames_final(self):
        """(frames of the scene's range whose pose last shown here is cached, frames in the range)."""
        first, last = self.frame_range
        final = sum(1 for f in range(first, last + 1) if self.frame_keys.get(f) in self.cache)
        return final, last - first + 1

    def close(self):
        """Stop both workers (the object is dropped)."""
        self.stop_worker()
        if self.finals is not None:
            self.finals.stop()

    def _bound(self, wait):
        """True once the solver is bound: a bind on its own thread has finished (or, with `wait`, is
        waited for: --background and renders pose the true pose). Raises the bind's error."""
        if self.solver is None:
            self.solver = self.binding.solver(wait)
            if self.solver is None:
                return False
            self.binding = None
        return True

    def stop_worker(self):
        """The solver back to this thread (the worker's solve ends after its iteration)."""
        if self.worker is not None:
            self.worker.stop()
            self.worker = None

    def _settled(self, settled):
        if settled and not self.settled:
            self.settled_at = time.monotonic()
            _redraw_later(SETTLED_SHOWN_S)
        self.settled = settled

    def status(self):
        """'binding', 'settling, N iterations' or 'settled after N iterations' (the last pose solved), and
        once frames were played, how many of the scene's range have their final pose cached."""
        if self.problem is None:
            return "reading the mesh"
        if self.solver is None:
            return "binding"
        if not self.settled:
            text = "settling, %d iterations" % self.iterations
        else:
            text = "settled after %d iterations" % self.iterations if self.iterations else "settled"
        if self.finals is not None:
            text += "; %d of %d frames final" % self.frames_final()
        return text

    def _warm_start(self, key, transforms):
        """Where the viewport's preview of a new pose starts from: the previous
        frame's settled pose when there is one (playback), else the cached pose
        whose handles were nearest, or the solver's current state when that is
        nearer."""
        previous = self.by_frame.get(key[0] - 1)
        if previous is not None and previous in self.cache:
            if self.state_key != previous:
                self.solver.set_positions(self.cache[previous][0].reshape(-1, 3).astype(np.float64))
        else:
            self._start_from_nearest(transforms)
        self.state_key = key
        self.current = [t.copy() for t in transforms]

    def _start_from_nearest(self, transforms):
        def distance(other):
            return sum(float(np.abs(a - b).sum()) for a, b in zip(transforms, other))

        best = None
        best_distance = np.inf if self.current is None else distance(self.current)
        for positions, cached in self.cache.values():
            d = distance(cached)
            if d < best_distance:
                best, best_distance = positions, d
        if best is not None:
            self.solver.set_positions(best.reshape(-1, 3).astype(np.float64))

    def _remember(self, key, positions, transforms, contact, held):
        """Cache a settled pose (and `contact`, its ContactStop, when Self Contact stopped it short; `held`,
        what Self Contact did in its solve)."""
        self.cache[key] = (positions, [t.copy() for t in transforms])
        if contact is not None:
            self.contacts[key] = contact
        if held is not None:
            self.held[key] = held
        if self.finals is not None:
            self.finals.drop(key)
        self.by_frame[key[0]] = key
        self.cache_bytes += positions.nbytes
        while self.cache_bytes > CACHE_BYTES and len(self.cache) > 1:
            oldest = next(iter(self.cache))
            old = self.cache.pop(oldest)
            self.contacts.pop(oldest, None)
            self.held.pop(oldest, None)
            self.cache_bytes -= old[0].nbytes

    def _write(self, positions, key):
        rig.mute_armature(self.obj)   # the pose shown is ARAP's: the rig's own deformation not on top
        self.output.write(positions)
        self.written = key


def setup_key(obj):
    """What a bind reads from the object's set-up besides the mesh: the groups by name and whether each is
    there (with its index), the handles' Empties and bones, the weights and the result. A change binds again, so a
    set-up Deform would refuse (a removed or renamed group) stops Auto mode with Deform's message."""
    s = obj.arap
    names = [s.fixed_group, s.stiff_group] + [h.group for h in s.handles]
    groups = obj.vertex_groups
    present = tuple(groups[n].index if n in groups else -1 for n in names)
    empties = tuple((h.empty.as_pointer() if h.empty is not None else 0,
                     h.armature.as_pointer() if h.armature is not None else 0, h.bone) for h in s.handles)
    return (tuple(names), present, empties, s.stiffness, s.weights, s.output)


def status(obj):
    """Auto mode's state for `obj` as the panel says it ('' before its first pose)."""
    poser = _posers.get(obj.as_pointer())
    return poser.status() if poser is not None else ""


def contact(obj):
    """The problem.ContactStop of the pose Auto mode last wrote on `obj`, when Self Contact stopped it short
    of the handles' targets (else None)."""
    poser = _posers.get(obj.as_pointer())
    return poser.contact if poser is not None else None


def panel_lines(obj):
    """What the panel says under the Auto toggle of `obj`, [(text, icon)]: its state, and whether Self Contact
    stopped its pose short (nothing before its first pose)."""
    poser = _posers.get(obj.as_pointer())
    if poser is None:
        return []
    lines = [("Auto: " + poser.status(), 'INFO')]
    if poser.contact is not None:
        lines.append((poser.contact.status(), 'ERROR'))
    if poser.contact_held is not None:
        lines.append((poser.contact_held, 'INFO'))
    return lines


def auto_status_lines():
    """What the viewport shows: each Auto object settling, or settled in the last SETTLED_SHOWN_S (and
    whether Self Contact stopped its pose short)."""
    now = time.monotonic()
    lines = []
    for p in _posers.values():
        if not p.settled or p.finals_busy() or now - p.settled_at < SETTLED_SHOWN_S:
            lines.append("ARAP Auto on '%s': %s" % (p.name, p.status()))
            if p.contact is not None:
                lines.append(p.contact.status())
    return lines


def _redraw_later(seconds):
    """Redraw the viewports once `seconds` from now (to take a line away), in the UI only."""
    if not bpy.app.background:
        bpy.app.timers.register(lambda: status_overlay.redraw(), first_interval=seconds + 0.1)


def _auto_changed(settings, context):
    """Auto turned on (pose now) or off (what the mesh showed before comes back)."""
    if settings.auto:
        settings.auto_status = ""
        update_scene(context.scene)
    else:
        stop(settings.id_data)


def _bind_changed(settings, context):
    """Auto mode poses with a new setting fixed at bind (Volume, Self Contact) at once: its solver is bound
    again."""
    if settings.auto:
        forget(settings.id_data)
        update_scene(context.scene)


def _settings_objects(scene):
    return [ob for ob in scene.objects if ob.type == 'MESH' and ob.arap.auto]


def _poser(obj, scene, on_worker=False):
    uid = obj.as_pointer()
    poser = _posers.get(uid)
    if poser is not None and (not poser.alive() or poser.setup_key != setup_key(obj)):
        # Another object at a deleted one's address, or a new set-up: bind again (gather() checks it).
        _drop(uid)
        poser = None
    if poser is not None and poser.fingerprint != problem.topology_counts(obj.data):
        raise SetupError("'%s' changed its vertices or faces: Auto posing stopped" % obj.name)
    if poser is None:
        poser = _posers[uid] = AutoPoser(obj, scene, on_worker)
    return poser


def _created(obj, poser):
    """Remember what Auto mode adds to the mesh (the ARAP key or the rest
    attribute), so that turning it off removes exactly that."""
    mesh = obj.data
    if PROP_CREATED in mesh:
        return
    made = []
    if poser.output.mode == 'SHAPE_KEY':
        if mesh.shape_keys is None:
            made.append("keys")
        elif mesh.shape_keys.key_blocks.get(meshio.SHAPE_KEY_NAME) is None:
            made.append("key")
    elif not meshio.has_rest_attribute(mesh):
        made.append("rest")
        meshio.store_rest(mesh, poser.problem.rest32)
    shown = _shown_before(obj, poser.output.mode)
    if shown is not None and not np.array_equal(shown, poser.problem.rest32):
        # A pose applied before (Live, Deform): turning Auto off brings it back, not the rest shape.
        attribute = mesh.attributes.new(BEFORE_ATTRIBUTE, 'FLOAT_VECTOR', 'POINT')
        attribute.data.foreach_set("vector", shown)
    mesh[PROP_CREATED] = ",".join(made) or "-"
    poser.output.ensure()


def _shown_before(obj, mode):
    """What the output Auto mode is about to write shows now (flat float32), or None when it does not exist
    yet (a shape key Auto mode creates)."""
    mesh = obj.data
    if mode != 'SHAPE_KEY':
        return meshio.read_coords(mesh)
    key = mesh.shape_keys.key_blocks.get(meshio.SHAPE_KEY_NAME) if mesh.shape_keys is not None else None
    if key is None:
        return None
    shown = np.empty(3 * len(mesh.vertices), np.float32)
    key.data.foreach_get("co", shown)
    return shown


def _take_before(mesh):
    """The shape kept by _created (flat float32), removed from the mesh; None when there is none or the vertex
    count changed since."""
    attribute = mesh.attributes.get(BEFORE_ATTRIBUTE)
    if attribute is None:
        return None
    shown = None
    if len(attribute.data) == len(mesh.vertices):
        shown = np.empty(3 * len(mesh.vertices), np.float32)
        attribute.data.foreach_get("vector", shown)
    mesh.attributes.remove(attribute)
    return shown


def restore_rest(obj):
    """Show what the mesh showed when Auto was turned on (the rest shape, or a pose applied before) and
    remove what Auto mode created: bit for bit the state before it was turned on, when nothing else changed
    in between."""
    mesh = obj.data
    made = set(str(mesh.get(PROP_CREATED, "")).split(","))
    before = _take_before(mesh)
    keys = mesh.shape_keys
    key = keys.key_blocks.get(meshio.SHAPE_KEY_NAME) if keys is not None else None
    if "keys" in made and keys is not None:
        obj.shape_key_clear()
    elif "key" in made and key is not None:
        obj.shape_key_remove(key)
    elif key is not None:
        key.data.foreach_set("co", before if before is not None else meshio.rest_coords(obj, 'SHAPE_KEY'))
        before = None
    if before is not None:
        mesh.vertices.foreach_set("co", before)
    elif meshio.has_rest_attribute(mesh):
        rest = meshio.rest_coords(obj, 'MESH')
        if len(rest) == 3 * len(mesh.vertices):
            mesh.vertices.foreach_set("co", rest)
        if "rest" in made:
            mesh.attributes.remove(mesh.attributes[meshio.REST_ATTRIBUTE])
    if PROP_CREATED in mesh:
        del mesh[PROP_CREATED]
    mesh.update()


def _restore_in_edit_mode(obj, poser):
    """Edit Mode owns the mesh: show the rest shape there (the edit then
    applies to the rest shape, not to a pose)."""
    if poser is None or poser.problem is None:
        return
    if poser.output.mode == 'SHAPE_KEY':
        obj.active_shape_key_index = 0   # the Basis: the rest shape
        return
    bm = bmesh.from_edit_mesh(obj.data)
    rest = poser.problem.rest32.reshape(-1, 3)
    if len(bm.verts) == len(rest):
        bm.verts.ensure_lookup_table()
        for v, co in zip(bm.verts, rest):
            v.co = co
        bmesh.update_edit_mesh(obj.data)


def stop(obj, reason=None, keep_pose=False):
    """Turn Auto off for `obj`: what it showed before Auto back (restore_rest; or, with `keep_pose`, the mesh as last written: a dependency
    loop stops Auto at its last good pose), state dropped, reason kept."""
    global _busy
    poser = _posers.get(obj.as_pointer())
    if poser is not None and not poser.alive():
        poser = None   # another object's, at the address of a deleted one
    _drop(obj.as_pointer())
    was_busy, _busy = _busy, True
    try:
        s = obj.arap
        if s.auto:
            s["auto"] = False   # the raw value: do not run the property's update again
        if keep_pose:
            pass   # the pose stays; turning Auto on and off again removes what it created
        elif _posed_by_another(obj) is not None or sessions.session_on_shared_mesh(obj) is not None:
            pass   # a linked duplicate's Auto or Live poses this mesh: its pose and rest shape are that one's
        elif obj.mode == 'EDIT':
            _restore_in_edit_mode(obj, poser)
            rig.restore_armature(obj)
        else:
            restore_rest(obj)
            rig.restore_armature(obj)
        s.auto_status = reason or ""
    finally:
        _busy = was_busy
    if reason:
        print("ARAP Auto:", reason)


def _drop(uid):
    poser = _posers.pop(uid, None)
    if poser is not None:
        poser.close()


def forget(obj=None):
    """Drop bound solvers and caches (all, or one object's; their workers stopped): they are rebuilt
    lazily."""
    for uid in list(_posers) if obj is None else [obj.as_pointer()]:
        _drop(uid)


def _drop_deleted(visited):
    """Stop and drop the state of objects deleted, or taken out of every scene, since the last update (no
    update would poll their workers again). `visited`: the objects this update posed, which are in its scene
    (users_scene walks every scene: asked only of the others)."""
    for uid, poser in list(_posers.items()):
        if not poser.alive() or (uid not in visited and not poser.obj.users_scene):
            _drop(uid)


def _posed_by_another(obj):
    """The other object whose Auto mode poses `obj`'s mesh (linked duplicates share one), or None."""
    mesh = obj.data
    if mesh.users < 2:
        return None
    for poser in _posers.values():
        if poser.alive() and poser.obj != obj and poser.obj.data == mesh:
            return poser.obj
    return None


def _one_poser_per_mesh(objects):
    """Linked duplicates share a mesh, so only one of them can pose it: the one already posing it, else the
    first by name. Auto is turned off on the others with a message; the mesh is left to that one."""
    by_mesh = {}
    for obj in objects:
        by_mesh.setdefault(obj.data.as_pointer(), []).append(obj)
    kept = []
    for group in by_mesh.values():
        owner = _posed_by_another(group[0]) if len(group) == 1 else None
        if owner is None:
            posing = [ob for ob in group if ob.as_pointer() in _posers and _posers[ob.as_pointer()].alive()]
            owner = (posing or sorted(group, key=lambda ob: ob.name))[0]
        for ob in group:
            if ob == owner:
                kept.append(ob)
            else:
                stop(ob, "'%s' shares its mesh '%s' with '%s', which Auto mode poses: Auto posing stopped on "
                         "'%s' (make the mesh single-user to pose it on its own: Object > Relations > Make "
                         "Single User)" % (ob.name, ob.data.name, owner.name, ob.name), keep_pose=True)
    return kept


def _stop_reason(obj, exc):
    """What Auto mode's status says when an error stopped it on `obj`."""
    message = errors.user_error(exc)
    if message is None:
        traceback.print_exception(type(exc), exc, exc.__traceback__)
        return ("Auto posing stopped on '%s' by an internal error (%s: %s); please report it"
                % (obj.name, type(exc).__name__, exc))
    return message if "Auto posing stopped" in message else "%s: Auto posing stopped" % message


def _playing():
    """An animation plays in one of Blender's windows."""
    wm = getattr(bpy.context, "window_manager", None)
    return wm is not None and any(w.screen is not None and w.screen.is_animation_playing for w in wm.windows)


def _interactive():
    if bpy.app.background:
        return False
    is_running = getattr(bpy.app, "is_job_running", None)
    return not (is_running is not None and is_running('RENDER'))


def update_scene(scene, depsgraph=None):
    """Pose every Auto object of `scene`; returns True when all are settled."""
    global _busy
    if _busy:
        return True
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    on_worker = _interactive()
    settled = True
    _busy = True
    try:
        objects = _one_poser_per_mesh(_settings_objects(scene))
        _drop_deleted({obj.as_pointer() for obj in objects})
        for obj in objects:
            if sessions.session_for(obj) is not None:
                continue  # Live owns the object while it runs
            try:
                if obj.mode == 'EDIT':
                    raise SetupError("'%s' is in Edit Mode: Auto posing stopped (the rest shape is shown); "
                                     "turn it on again after editing" % obj.name)
                poser = _poser(obj, scene, on_worker)
                settled &= poser.update(obj, depsgraph, on_worker)
                settled &= not poser.finals_busy()   # the timer polls the second solver too
            except DependencyLoop as exc:
                stop(obj, "%s. Auto posing stopped on '%s' (the mesh stays as it is)" % (exc, obj.name),
                     keep_pose=True)
            except Exception as exc:  # noqa: BLE001 - a handler must never raise; the reason is kept
                stop(obj, _stop_reason(obj, exc))
    finally:
        _busy = False
    if not settled:
        _start_timer()
    return settled


def _start_timer():
    global _timer_on
    if not _timer_on and not bpy.app.background:
        _timer_on = True
        bpy.app.timers.register(_continue, first_interval=0.0)


def _continue():
    """Timer: show the worker's newest poses until every Auto object has settled."""
    global _timer_on
    context = bpy.context
    scene = getattr(context, "scene", None)
    if scene is None or update_scene(scene):
        _timer_on = False
        return None
    return POLL_S


@persistent
def _on_depsgraph_update(scene, depsgraph=None):
    update_scene(scene, depsgraph)


@persistent
def _on_frame_change(scene, depsgraph=None):
    update_scene(scene, depsgraph)


@persistent
def _on_load(_file=None, _unused=None):
    global _timer_on
    forget()
    _timer_on = False   # loading a file removed the timer (it is not persistent): the next update starts it
    if not bpy.app.background:
        # Opening a file changes nothing Blender reports to the handlers: pose its Auto objects from the
        # event loop once the file is in (--background: the first frame change or render does).
        bpy.app.timers.register(_pose_opened_file, first_interval=0.0)


def _pose_opened_file():
    scene = getattr(bpy.context, "scene", None)
    if scene is not None and _settings_objects(scene):
        update_scene(scene)
    return None


@persistent
def _on_undo(scene=None, _unused=None):
    # Undo brings back older objects and meshes: rebind from what they hold now.
    forget()
    if scene is not None:
        update_scene(scene)


_HANDLERS = (("depsgraph_update_post", _on_depsgraph_update), ("frame_change_post", _on_frame_change),
             ("load_post", _on_load), ("undo_post", _on_undo), ("redo_post", _on_undo))


def register():
    global _timer_on
    _timer_on = False
    for name, fn in _HANDLERS:
        getattr(bpy.app.handlers, name).append(fn)
    status_overlay.add(auto_status_lines)
    panels.auto_lines = panel_lines
    properties.on_auto_changed, properties.on_bind_changed = _auto_changed, _bind_changed
    if not bpy.app.background:
        # Enabled again (or for the first time) with Auto objects in the open file: pose them now.
        bpy.app.timers.register(_pose_opened_file, first_interval=0.0)


def unregister():
    """Disabled: no handler, no timer and no worker of ours is left running (the meshes keep their last pose;
    Auto goes on when the add-on is enabled again)."""
    global _timer_on
    status_overlay.remove(auto_status_lines)
    panels.auto_lines = None
    properties.on_auto_changed = properties.on_bind_changed = None
    for name, fn in _HANDLERS:
        handlers = getattr(bpy.app.handlers, name)
        if fn in handlers:
            handlers.remove(fn)
    for fn in (_continue, _pose_opened_file):
        if bpy.app.timers.is_registered(fn):
            bpy.app.timers.unregister(fn)
    _timer_on = False
    forget()
