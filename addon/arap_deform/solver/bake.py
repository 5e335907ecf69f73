# SPDX-License-Identifier: GPL-3.0-or-later
"""Bake ARAP poses over a frame range so that Blender plays them back natively.

    result = api.bake_shape_keys(obj, 1, 100)             # one shape key per frame
    result = api.bake_pc2(obj, "//pose.pc2", 1, 100)      # a point cache + Mesh Cache modifier
    print(result.energies, result.iterations, result.ms)
    api.clear_bake(obj)                                   # back to the un-baked object

(api re-exports these; api.py says how a script imports it.)

Each frame: scene.frame_set(f), read the evaluated world matrices of the
object and of the handle empties (keyframes, constraints and drivers all
count), solve from the cold start (the first guess from the rest shape)
until the energy stops dropping (the object's tolerance), keep the float32
result: each frame's pose depends on that frame alone, the same bits as Auto
mode shows and renders give, whatever range is baked. Nothing is written into
the scene before every frame is solved (a .pc2 is streamed to a temporary file
renamed at the end; the interactive bake's preview on the mesh is put back bit
for bit first), so a cancelled bake changes nothing.

Rest shape: the one Deform uses (the Basis key, or the "arap_rest" attribute,
or the mesh), ignoring a Basis key the bake itself created. It is never
modified: the base mesh and the Basis keep their coordinates.

Determinism: every frame starts cold (its results do not depend on the
thread count, a test checks it) and the bake clears the previous bake first,
so baking twice, or baking a range in two parts, stores identical
coordinates.

Outputs:
- shape keys "ARAP_f0001"...: absolute coordinates, relative to the Basis,
  value keyed 1 at its frame and 0 at the neighbouring frames (linear, so
  sub-frames blend two neighbouring poses). The add-on's own "ARAP" key is
  muted while a bake exists (the baked keys replace it); other shape keys keep
  mixing on top.
- PC2: object-local float32 coordinates, one sample per frame, read by a
  Mesh Cache modifier "ARAP Bake" placed first in the stack.
"""

import os
import struct
import time

import bpy
import numpy as np

from . import anim_compat, constraints, deform_job, meshio, problem, rig, sessions
from ..persistence import temp_files
from ..persistence.older_settings import max_iterations_argument
from ..errors import SetupError
from ..native_loader import native

KEY_PREFIX = "ARAP_f"
MODIFIER_NAME = "ARAP Bake"
# Custom properties on the mesh remembering what the bake created or changed.
PROP_BASIS = "arap_bake_basis"          # the Basis key was created by the bake
PROP_ACTION = "arap_bake_action"        # the shape-key action was created by the bake
PROP_MUTED = "arap_bake_muted_live"     # the "ARAP" key was muted by the bake

# Each frame is solved as Auto mode solves a pose (auto.py): the object's method and
# tolerance, each frame starting from the previous one, so baked frames and the frames
# Auto mode plays are the same poses.
DEFAULT_ITERATIONS = 2000    # per frame, an upper bound: frames stop on the tolerance

__all__ = ("BakeResult", "Baker", "bake_shape_keys", "bake_pc2", "clear_bake", "PC2Writer", "read_pc2",
           "key_name", "is_baked")


def key_name(frame):
    return "%s%04d" % (KEY_PREFIX, frame)


def _is_bake_key(name):
    return name.startswith(KEY_PREFIX) and name[len(KEY_PREFIX):].lstrip("-").isdigit()


def is_baked(obj):
    """True when the object carries baked shape keys or the bake's Mesh Cache modifier."""
    keys = obj.data.shape_keys
    if keys is not None and any(_is_bake_key(kb.name) for kb in keys.key_blocks):
        return True
    return obj.modifiers.get(MODIFIER_NAME) is not None


class BakeResult:
    """Per-frame statistics of a bake (lists in frame order, times in ms)."""

    def __init__(self, frames):
        self.frames = list(frames)
        self.energies = []
        self.iterations = []
        self.converged = []
        self.ms = []            # per frame: frame_set + targets + solve
        self.gradients = []     # max |dE/dp| over free vertices (measure_gradient=True)
        self.gradient_reference = None  # same, for the first frame's naive guess
        self.warnings = []      # "Frame N: ..." for each frame Self Contact stopped short of the handles' targets
        self.bind_ms = 0.0
        self.write_ms = 0.0
        self.total_ms = 0.0
        self.output = None      # 'SHAPE_KEYS' | 'PC2'
        self.path = None
        self.positions = None   # float32 (frames, n, 3), object-local (shape keys; PC2: read_pc2(path))

    def __repr__(self):
        n = len(self.ms)
        return ("<BakeResult %d frames, %.1f ms/frame, %.1f iterations/frame, output=%s>"
                % (n, sum(self.ms) / max(n, 1), sum(self.iterations) / max(n, 1), self.output))


def bake_rest(obj):
    """Flat float32 rest shape of a bake (a Basis the bake created does not count)."""
    mode = obj.arap.output
    keys = obj.data.shape_keys
    if mode == 'AUTO':
        own_only = (keys is not None and obj.data.get(PROP_BASIS)
                    and all(kb == keys.reference_key or _is_bake_key(kb.name) for kb in keys.key_blocks))
        mode = 'MESH' if keys is None or own_only else 'SHAPE_KEY'
    return meshio.rest_coords(obj, mode)


class Baker:
    """Solves frames start..end one step() at a time; changes nothing in the
    scene until write_shape_keys() / write_pc2_cache(). bake_shape_keys() /
    bake_pc2() loop over step(); the modal operator hands each frame's solve
    to a worker thread instead (post_frame(), take_frame()), with the same
    results. With pc2_path, frames are streamed to a temporary file (memory
    stays one frame) that write_pc2_cache() renames and cancel() removes;
    otherwise they are kept in memory for the shape keys.
    """

    def __init__(self, obj, start, end, scene=None, max_iterations=None, tolerance=None, anderson=None,
                 measure_gradient=False, pc2_path=None):
        constraints.check_object(obj)
        if end < start:
            raise SetupError("The bake's end frame (%d) is before its start frame (%d)" % (end, start))
        if sessions.session_for(obj) is not None:
            raise SetupError("ARAP Live is running on '%s': apply or cancel it before baking" % obj.name)
        self.obj = obj
        self.name = obj.name    # a deleted object's own name can no longer be read
        self.counts = problem.topology_counts(obj.data)
        self.scene = scene or bpy.context.scene
        self.frames = list(range(int(start), int(end) + 1))
        self.frame_before = (self.scene.frame_current, self.scene.frame_subframe)
        self.measure_gradient = measure_gradient
        self.result = BakeResult(self.frames)
        t0 = time.perf_counter()
        problem.sync_matrices()
        self.problem = problem.Problem(obj, self.scene, rest32=bake_rest(obj))
        self.setup = self.problem.setup
        self.rest64 = self.problem.rest64
        if anderson is None:   # the option's default window, not the object's Anderson Window
            anderson = native().OPTIONS["anderson_window"]["default"]
        self.solver = problem.configured_solver(self.problem, obj.arap,
                                                max_iterations=max_iterations or DEFAULT_ITERATIONS,
                                                tolerance=tolerance, warm=True, anderson=anderson)
        self.free = np.ones(len(self.rest64), bool)
        self.free[self.setup.constrained] = False
        self.pc2_path = pc2_path
        self.pc2 = None
        if pc2_path:
            self.positions = np.empty((1, len(self.rest64), 3), np.float32)
            self.pc2 = PC2Writer(bpy.path.abspath(pc2_path), len(self.rest64), self.frames[0], len(self.frames))
        else:
            self.positions = np.empty((len(self.frames), len(self.rest64), 3), np.float32)
        self.index = 0
        self.result.bind_ms = (time.perf_counter() - t0) * 1e3
        self.started = time.perf_counter()

    @property
    def done(self):
        return self.index >= len(self.frames)

    @property
    def last_positions(self):
        """Float32 (n, 3) object-local pose of the frame step() solved last."""
        return self.positions[0 if self.pc2 else max(self.index - 1, 0)]

    def _targets(self):
        """The targets of the frame just set: the handles as evaluated there (DependencyLoop when a handle's
        Empty follows the baked mesh by then: the bake refuses such a set-up at the start too)."""
        self.problem.check_loops(self.obj)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        pose = self.problem.pose(self.obj, self.scene, depsgraph)
        self._start = self.problem.start_shape(pose.transforms)   # the cold solve's start (a rig's skin)
        return self.problem.targets(pose)

    def _gradient(self, positions):
        g = self.solver.energy_gradient(np.ascontiguousarray(positions, np.float64))
        return float(np.linalg.norm(g[self.free], axis=1).max()) if self.free.any() else 0.0

    def step(self):
        """Solve the next frame here; returns its frame number."""
        f = self._begin_frame()
        targets = self._targets()
        if self.measure_gradient and self.index == 0:
            guess = self.rest64.copy()
            guess[self.setup.constrained] = targets
            self.result.gradient_reference = self._gradient(guess)
        out = self._out()
        # Each frame from the cold start: the pose Auto mode and renders show.
        if self._start is None:
            self.solver.forget_solution()
        else:
            self.solver.start_from(self._start)
        self._record(out, self.solver.solve(targets, out=out))
        return f

    def post_frame(self, worker):
        """Go to the next frame and hand its solve to `worker` (a SolveWorker of self.solver whose
        max_iterations is the solver's: one solve, the same arithmetic as step()); returns the frame."""
        f = self._begin_frame()
        targets = self._targets()
        worker.post(targets, restart=True, start=self._start)
        return f

    def take_frame(self, worker):
        """Record the frame post_frame() handed over once `worker` has solved it: True then."""
        out = self._out()
        result = worker.take(out)
        if result is None:
            return False
        self._record(out, result.stats)
        return True

    def check(self):
        """SetupError when the baked object was deleted or its vertex or face count changed (the bake's
        frames would not fit it)."""
        try:
            counts = problem.topology_counts(self.obj.data)
        except ReferenceError:
            raise SetupError("'%s' was deleted during the bake: nothing was written" % self.name) from None
        if counts != self.counts:
            raise SetupError("The vertices or faces of '%s' changed during the bake: nothing was written"
                             % self.name)

    def _begin_frame(self):
        self.check()
        f = self.frames[self.index]
        self._frame_started = time.perf_counter()
        self.scene.frame_set(f)
        return f

    def _out(self):
        return self.positions[0 if self.pc2 else self.index]

    def _record(self, out, stats):
        if self.pc2:
            self.pc2.add(out)
        r = self.result
        r.ms.append((time.perf_counter() - self._frame_started) * 1e3)
        r.energies.append(stats.energy[-1] if stats.energy else stats.initial_energy)
        r.iterations.append(stats.iterations)
        r.converged.append(stats.converged)
        w = problem.contact_warning(self.problem, stats)
        if w:
            r.warnings.append("Frame %d: %s" % (self.frames[self.index], w))
        if self.measure_gradient:
            r.gradients.append(self._gradient(self.solver.positions()))
        self.index += 1

    def run(self, progress=None):
        """Solve every remaining frame; progress(done, total) after each."""
        while not self.done:
            self.step()
            if progress is not None:
                progress(self.index, len(self.frames))

    def restore_frame(self):
        frame, sub = self.frame_before
        self.scene.frame_set(frame, subframe=sub)

    def cancel(self):
        """Nothing was changed: remove the temporary .pc2 and put the scene's frame back."""
        if self.pc2 is not None:
            self.pc2.abort()
        self.restore_frame()

    def _finish(self, output, path, write):
        if not self.done:
            raise RuntimeError("the bake is not finished (%d of %d frames)" % (self.index, len(self.frames)))
        t0 = time.perf_counter()
        clear_bake(self.obj)
        write()
        rig.mute_armature(self.obj)   # the baked frames are the rig's poses already: not deformed again
        self.restore_frame()
        r = self.result
        r.write_ms = (time.perf_counter() - t0) * 1e3
        r.total_ms = (time.perf_counter() - self.started) * 1e3 + r.bind_ms
        r.output, r.path = output, path
        r.positions = None if self.pc2 else self.positions
        deform_job.remember_result(self.obj, r)
        return r

    def write_shape_keys(self):
        """Replace any previous bake with one shape key per frame; returns the BakeResult."""
        return self._finish('SHAPE_KEYS', None, lambda: _write_keys(self.obj, self.frames, self.positions))

    def write_pc2_cache(self):
        """Rename the .pc2 into place and add the Mesh Cache modifier; returns the BakeResult."""
        if self.pc2 is None:
            raise RuntimeError("this Baker was made without pc2_path")

        def write():
            self.pc2.close()
            _add_cache_modifier(self.obj, self.pc2_path, self.frames[0])
        return self._finish('PC2', self.pc2_path, write)


def bake_shape_keys(obj, start, end, scene=None, max_iterations=None, tolerance=None, anderson=None,
                    measure_gradient=False, progress=None, iterations=None):
    """Bake frames start..end (inclusive) into shape keys "ARAP_f0001"...

    Each key holds the solved pose of its frame and is keyed to 1 at that frame
    and 0 at the frames next to it. max_iterations: at most this many per frame
    (default 2000); tolerance: the solver's tolerance for a frame (default:
    the object's, as Auto mode); the object's method solves (anderson: the
    window when that is Anderson; default: the option's default window, not
    the object's Anderson Window). Replaces a previous bake; the Basis and base
    mesh are not modified. Returns a BakeResult
    (energies, iterations, ms per frame). Raises SetupError on a bad set-up,
    with the object unchanged. iterations= is the deprecated name of max_iterations=.
    """
    max_iterations = max_iterations_argument(max_iterations, iterations)
    baker = Baker(obj, start, end, scene, max_iterations, tolerance, anderson, measure_gradient)
    try:
        baker.run(progress)
    except BaseException:
        baker.cancel()
        raise
    return baker.write_shape_keys()


def bake_pc2(obj, path, start, end, scene=None, max_iterations=None, tolerance=None, anderson=None,
             measure_gradient=False, progress=None, iterations=None):
    """Bake frames start..end into the point cache `path` (.pc2, object-local
    coordinates, start frame = `start`, one sample per frame) and add a Mesh
    Cache modifier "ARAP Bake" reading it. `path` may be Blender-relative
    ("//anim.pc2"). Other arguments and the result as bake_shape_keys(), but
    result.positions is None: read them back with read_pc2(path).
    """
    max_iterations = max_iterations_argument(max_iterations, iterations)
    baker = Baker(obj, start, end, scene, max_iterations, tolerance, anderson, measure_gradient, pc2_path=path)
    try:
        baker.run(progress)
    except BaseException:
        baker.cancel()
        raise
    return baker.write_pc2_cache()


def clear_bake(obj):
    """Remove the baked shape keys, their keyframes and the bake's Mesh Cache
    modifier, and undo what the bake changed (muted "ARAP" key, created Basis,
    the rig's Armature modifier turned off).
    The .pc2 file is left on disk. Returns the number of things removed."""
    removed = 0
    mesh = obj.data
    keys = mesh.shape_keys
    if keys is not None:
        curves, _ = anim_compat.fcurves(keys)
        if curves is not None:
            for fc in [fc for fc in curves if fc.data_path.startswith('key_blocks["%s' % KEY_PREFIX)]:
                curves.remove(fc)
            if mesh.get(PROP_ACTION) and len(curves) == 0:
                action = anim_compat.unassign_action(keys)
                if action is not None and action.users == 0:
                    bpy.data.actions.remove(action)
        for kb in [kb for kb in keys.key_blocks if _is_bake_key(kb.name)]:
            obj.shape_key_remove(kb)
            removed += 1
        live = keys.key_blocks.get(meshio.SHAPE_KEY_NAME)
        if live is not None and mesh.get(PROP_MUTED):
            live.mute = False
        if mesh.get(PROP_BASIS) and len(keys.key_blocks) == 1:
            obj.shape_key_clear()
            removed += 1
    for prop in (PROP_BASIS, PROP_ACTION, PROP_MUTED):
        if prop in mesh:
            del mesh[prop]
    mod = obj.modifiers.get(MODIFIER_NAME)
    if mod is not None and mod.type == 'MESH_CACHE':
        obj.modifiers.remove(mod)
        removed += 1
    if not obj.arap.auto and sessions.session_for(obj) is None:
        rig.restore_armature(obj)   # the rig deforms the mesh again (unless ARAP poses it now)
    mesh.update()
    return removed


def _write_keys(obj, frames, positions):
    mesh = obj.data
    if mesh.shape_keys is None:
        obj.shape_key_add(name="Basis", from_mix=False)
        mesh[PROP_BASIS] = True
    keys = mesh.shape_keys
    basis = keys.reference_key
    live = keys.key_blocks.get(meshio.SHAPE_KEY_NAME)
    if live is not None and not live.mute:
        live.mute = True
        mesh[PROP_MUTED] = True
    curves, created = anim_compat.fcurves(keys, create=True, action_name="%s_ARAPBake" % obj.name)
    if created:
        mesh[PROP_ACTION] = True
    for f, pos in zip(frames, positions):
        kb = obj.shape_key_add(name=key_name(f), from_mix=False)
        kb.relative_key = basis
        kb.data.foreach_set("co", pos.ravel())
        kb.value = 0.0
        fc = curves.new('key_blocks["%s"].value' % kb.name)
        fc.keyframe_points.add(3)
        fc.keyframe_points.foreach_set("co", (f - 1, 0.0, f, 1.0, f + 1, 0.0))
        for p in fc.keyframe_points:
            p.interpolation = 'LINEAR'
        fc.update()
    mesh.update()


PC2_HEADER = struct.Struct("<12siiffi")


class PC2Writer:
    """Streams a PC2 point cache (object-local float32 xyz per point per sample)
    into a temporary file next to `path`; close() renames it into place, so
    readers never see half a file, and abort() removes it."""

    def __init__(self, path, points, start, samples, rate=1.0):
        self.path = path
        self.tmp = temp_files.temp_path(path)
        self.points, self.samples, self.written = points, samples, 0
        self.file = open(self.tmp, "wb")
        self.file.write(PC2_HEADER.pack(b"POINTCACHE2\0", 1, points, float(start), float(rate), samples))

    def add(self, positions):
        """Append one sample: float32 (points, 3) or (3 * points,)."""
        data = np.ascontiguousarray(positions, dtype="<f4")
        if data.size != 3 * self.points or self.written >= self.samples:
            raise ValueError("PC2 sample %d: expected %d points" % (self.written, self.points))
        self.file.write(data)  # the buffer itself, no copy
        self.written += 1

    def close(self):
        if self.written != self.samples:
            self.abort()
            raise ValueError("PC2 file has %d of %d samples" % (self.written, self.samples))
        self.file.close()
        os.replace(self.tmp, self.path)

    def abort(self):
        self.file.close()
        if os.path.exists(self.tmp):
            os.remove(self.tmp)


def read_pc2(path):
    """(start, rate, float32 array (samples, n, 3)) of a PC2 file."""
    with open(path, "rb") as f:
        magic, version, n, start, rate, samples = PC2_HEADER.unpack(f.read(PC2_HEADER.size))
        if magic != b"POINTCACHE2\0" or version != 1:
            raise ValueError("%s is not a PC2 (version 1) file" % path)
        data = np.frombuffer(f.read(), dtype="<f4")
    if data.size != samples * n * 3:
        raise ValueError("%s is truncated: %d of %d floats" % (path, data.size, samples * n * 3))
    return start, rate, data.reshape(samples, n, 3)


def _add_cache_modifier(obj, path, start):
    mod = obj.modifiers.new(MODIFIER_NAME, 'MESH_CACHE')
    mod.cache_format = 'PC2'
    mod.filepath = path
    mod.time_mode = 'FRAME'
    mod.play_mode = 'SCENE'
    mod.frame_start = start
    mod.frame_scale = 1.0
    mod.interpolation = 'LINEAR'
    mod.deform_mode = 'OVERWRITE'
    mod.factor = 1.0
    # First in the stack: the cache holds the deformed base mesh.
    while obj.modifiers[0] != mod:
        with bpy.context.temp_override(object=obj, active_object=obj):
            bpy.ops.object.modifier_move_up(modifier=mod.name)
    return mod
