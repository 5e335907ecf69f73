# SPDX-License-Identifier: GPL-3.0-or-later
"""From an object's ARAP settings to a configured solver: what is read from
Blender for one bind and the targets of the handles' pose (Problem), the one
mapping of the settings to the solver's options (solver_options), both used by
Deform, Live, the bake and Auto mode, and the warnings a solve reports.
"""

import functools

import bpy
import numpy as np

from . import constraints, dependency_loops, drivers, handles, meshio, skinning
from ..errors import SetupError
from ..native_loader import native
# Blender enum items -> the native module's option values (declared with the items).
from ..persistence.solver_settings import CONTACT_NAMES, INIT_NAMES, METHOD_NAMES, VOLUME_NAMES, WEIGHT_NAMES
# Renamed settings and changed defaults, read through setting(): a library saved by an older version holds
# the old names and relied on the old defaults.
from ..persistence.older_settings import setting


def bind_options(settings):
    """The bind options of the object's Volume and Self Contact settings (native names): what the solver
    keeps besides the surface's rigidity, fixed at bind."""
    return {"volume": VOLUME_NAMES[setting(settings, "volume")], "infill_resolution": settings.infill_resolution,
            "contact": CONTACT_NAMES[setting(settings, "contact")]}


# How the panel names a native option's value that Anderson cannot be combined with.
_UNCHECKED_NAMES = {"volume": lambda value: "Volume %s" % value.title(), "contact": lambda _value: "Self Contact"}


def anderson_unchecked(settings):
    """The settings Anderson's extrapolated points are not checked against (the native module's rule), as the
    panel names them: Volume (its terms) and Self Contact (its collision check). Empty when there is none."""
    conflicts = native().method_conflicts(method=METHOD_NAMES['ANDERSON'], **bind_options(settings))
    return [_UNCHECKED_NAMES[option](value) for option, value, _reason in conflicts]


def solver_method(settings):
    """The native method for the object's settings: its Method, except that Anderson's extrapolated points
    are not checked against the volume terms nor the collision check of Self Contact, so with either on it
    falls back to Quasi-Newton (method_warning() says so)."""
    if settings.method == 'ANDERSON' and anderson_unchecked(settings):
        return METHOD_NAMES['QUASI_NEWTON']
    return METHOD_NAMES[settings.method]


def sync_matrices():
    """Bring matrix_world up to date after scripts changed location/rotation
    (Blender updates it only when the depsgraph is evaluated)."""
    view_layer = getattr(bpy.context, "view_layer", None)
    if view_layer is not None:
        view_layer.update()


def topology_counts(mesh):
    """Vertex, edge, loop and face counts: a cheap check that the topology the
    solver was bound to is still there."""
    return (len(mesh.vertices), len(mesh.edges), len(mesh.loops), len(mesh.polygons))


class HandlePose:
    """Where the handles are: the world matrices of the posed object and of its handle Empties, read
    together (Problem.pose()), and each handle's object-local transform since its bind pose."""

    def __init__(self, setup, obj_name, obj_matrix, empty_matrices):
        self._setup, self._obj_name = setup, obj_name
        self.obj_matrix = obj_matrix            # float64 (4, 4)
        self.empty_matrices = empty_matrices    # [float64 (4, 4)], one per handle
        # The matrices' bytes: poses with the same key have the same targets (Live: nothing moved;
        # Auto mode: a pose solved before).
        self.key = np.concatenate([obj_matrix.ravel()] + [m.ravel() for m in empty_matrices]).tobytes()

    @functools.cached_property
    def transforms(self):
        """[M_obj^-1 @ M_now @ M_bind^-1 @ M_obj], one per handle (worked out when first asked for: Live
        reads a pose every tick and needs them only when it moved); SetupError when the object has zero
        scale."""
        return handles.target_transforms(self.obj_matrix, self.empty_matrices,
                                         [h.bind_inv for h in self._setup.handles], self._obj_name)


class Problem:
    """Everything read from Blender for one bind: rest, triangles, constraints;
    and the targets of the constrained vertices for the handles' pose (pose(),
    targets()), the one way Deform, Live, the bake and Auto mode get them.
    `rest32`: another flat float32 rest shape than the one Deform uses (the bake's); `cold_starts`: False when
    no solve will start cold (Live), so start_shape() is None."""

    def __init__(self, obj, scene, rest32=None, groups=None, tris=None, cold_starts=True):
        # groups: (members, stiff weights, skin) as read_in_steps() read them
        members, stiff_weights, skin = groups if groups is not None else (None, None, None)
        self.setup = constraints.gather(obj, scene, members)
        self.check_loops(obj)
        s = obj.arap
        self.output = meshio.resolve_output(obj, s.output)
        self.rest32 = meshio.rest_coords(obj, self.output) if rest32 is None else rest32
        self.rest64 = self.rest32.astype(np.float64).reshape(-1, 3)
        self.tris = meshio.rest_triangles(obj.data, self.rest32) if tris is None else tris
        if len(self.tris) == 0:
            raise SetupError("'%s' has no faces: ARAP needs a surface" % obj.name)
        self.rest_constrained = self.rest64[self.setup.constrained]
        # A rig's skinned start (None without bone handles, or for Live, which goes on from its last pose and
        # needs none: its bone weights are then not read).
        self.skinned = skinning.SkinnedStart.of(obj, self.setup, self.rest64, skin) if cold_starts else None
        self._targets = np.empty_like(self.rest_constrained)
        self.weights = WEIGHT_NAMES[s.weights]
        self.stiffness = constraints.stiffness_of(obj, stiff_weights)
        self.bind_options = bind_options(s)
        self.threads = s.threads  # large meshes order and factor in two halves side by side

    @classmethod
    def read_in_steps(cls, obj, scene):
        """Generator: the Problem of `obj`, read over several calls (the vertex groups a chunk of vertices at
        a time, meshio.read_groups_in_steps; then the triangles; then the rest), so that Blender's thread goes
        on in between; the Problem is the generator's value. The object may change between steps: the caller
        checks it is still the same."""
        constraints.check_object(obj)
        stiff, bones = constraints.stiff_group(obj), skinning.skin_bones(obj)
        weights_of = ([stiff] if stiff else []) + bones
        members, weights = yield from meshio.read_groups_in_steps(obj, constraints.group_names(obj), weights_of)
        skin = (bones, weights[:, len(weights_of) - len(bones):])
        groups = (members, weights[:, 0] if stiff else None, skin)
        if len(obj.data.vertices) > meshio.GROUP_CHUNK:
            yield
        rest32 = meshio.rest_coords(obj, meshio.resolve_output(obj, obj.arap.output))
        tris = meshio.rest_triangles(obj.data, rest32)
        if len(obj.data.vertices) > meshio.GROUP_CHUNK:
            yield
        return cls(obj, scene, rest32=rest32, groups=groups, tris=tris)

    @property
    def has_contact(self):
        """The surface is kept from passing through itself (Self Contact): a pose may stop short."""
        return self.bind_options["contact"] != "none"

    @functools.cached_property
    def size(self):
        """The rest shape's longest side (what "at its target" is measured against)."""
        return float(np.ptp(self.rest64, axis=0).max())

    def check_loops(self, obj):
        """DependencyLoop (a SetupError) when a handle's Empty or bone follows `obj`, the mesh it poses
        (dependency_loops.py): Auto mode and Live check before each solve, everything at the bind."""
        dependency_loops.check(obj, self.setup.handles)

    def check_drivers(self, scene=None):
        """SetupError when a handle's Empty or armature was deleted (or, given `scene`, is not in it), or its
        bone renamed or deleted."""
        for h in self.setup.handles:
            drivers.check(h, scene, h.group)

    def pose(self, obj, scene=None, depsgraph=None):
        """The HandlePose of `obj` now: the world matrices as the viewport last updated them, or, with
        `depsgraph`, as evaluated there (keyframes, drivers, constraints, IK and parents of the frame it shows
        count). Raises SetupError when a handle's Empty or bone is gone (check_drivers)."""
        self.check_drivers(scene)
        if depsgraph is not None:
            obj = obj.evaluated_get(depsgraph)
        obj_matrix = handles.matrix_to_numpy(obj.matrix_world)
        mats = [drivers.motion_matrix(h, depsgraph) for h in self.setup.handles]
        return HandlePose(self.setup, obj.name, obj_matrix, mats)

    def targets(self, pose):
        """The constrained vertices' targets for `pose` (float64 (k, 3): fixed vertices at rest, each
        handle's block moved by its transform), in this Problem's buffer: the next call overwrites it.
        SetupError when the object has zero scale, or when a handle moves its vertices farther than its
        coordinates can hold the mesh's shape (constraints.check_reach)."""
        targets = constraints.fill_targets(self.setup, self.rest_constrained, pose.transforms, self._targets)
        constraints.check_reach(self.setup, self.rest_constrained, targets, self.size)
        return targets

    def start_shape(self, transforms):
        """The shape a cold solve for the handles' `transforms` starts from: the rig's own skinned pose when
        handles follow bones (skinning.py), else None (the solver's first guess, the Start setting)."""
        return None if self.skinned is None else self.skinned.positions(transforms)

    def cold_start(self, solver, transforms):
        """Make `solver`'s next solve a cold one, from start_shape(): its pose then depends on the handles'
        pose alone."""
        start = self.start_shape(transforms)
        if start is None:
            solver.forget_solution()
        else:
            solver.start_from(start)

    def collapsed(self, pose):
        """The groups of the handles whose Empty `pose` scales to almost nothing since its bind pose."""
        return [h.group for h, m_now in zip(self.setup.handles, pose.empty_matrices)
                if handles.collapsed(m_now, h.bind_inv)]

    def bind(self):
        """A new native solver bound to this problem (default options but those fixed at bind: the weights,
        the volume terms and self contact; and the threads, which the bind uses too)."""
        solver = native().Solver()
        solver.bind(self.rest64, self.tris, self.setup.constrained, weights=self.weights, stiffness=self.stiffness,
                    threads=self.threads, **self.bind_options)
        return solver


def solver_options(settings, max_iterations=None, tolerance=None, init=None, anderson=None, warm=False,
                   time_budget_ms=0.0):
    """The solver's options (native OPTIONS names) from an object's settings
    (obj.arap); a given argument replaces the setting. `warm`: each solve()
    starts from the last solution, the first from the start shape `init`."""
    start = INIT_NAMES[init or settings.init]
    options = {
        "max_iterations": max_iterations or setting(settings, "max_iterations"),
        "tolerance": settings.tolerance if tolerance is None else tolerance,
        "method": solver_method(settings),
        "anderson_window": setting(settings, "anderson_window") if anderson is None else anderson,
        "threads": settings.threads,
        "time_budget_ms": time_budget_ms,
    }
    if warm:
        options.update(init="warm", cold_start=start)
    else:
        options["init"] = start
    return options


def configured_solver(problem, settings, **overrides):
    """A solver bound to `problem` and configured from `settings` (obj.arap);
    `overrides`: the keyword arguments of solver_options()."""
    solver = problem.bind()
    solver.configure(**solver_options(settings, **overrides))
    return solver


def unconstrained_warning(report):
    n = report["unconstrained_components"]
    if n == 0:
        return None
    return ("%d vertices in %d part(s) have no fixed or handle vertex: they keep their rest shape"
            % (report["unconstrained_vertices"], n))


def volume_warning(report, bind_options):
    """Volume Global keeps closed parts only: say which were left alone."""
    if bind_options.get("volume") != "global":
        return None
    n = report["volume_open_components"]
    if n == 0:
        return None
    if report["volume_kept_components"] == 0:
        return ("Volume Global keeps nothing here: the mesh has no closed part (%d open); try Volume Infill" % n)
    return ("Volume Global keeps the volume of %d closed part(s); %d open part(s) are left as they are"
            % (report["volume_kept_components"], n))


def method_warning(settings):
    """Anderson replaced by Quasi-Newton for Volume or Self Contact (solver_method())."""
    unchecked = anderson_unchecked(settings) if settings.method == 'ANDERSON' else []
    if not unchecked:
        return None
    return "%s need%s Quasi-Newton or Local/Global: solved with Quasi-Newton" % (
        " and ".join(unchecked), "" if len(unchecked) > 1 else "s")


def bind_warnings(report, problem, settings):
    """What a bind has to tell the user: parts without constraints, open parts Volume Global leaves alone,
    a method replaced for the volume terms or self contact."""
    found = (unconstrained_warning(report), volume_warning(report, problem.bind_options), method_warning(settings))
    return [w for w in found if w]


# Where the iteration cap of a solve was set, and what a user raises there (unconverged_warning).
RAISE_ITERATIONS = {
    'SETTINGS': "raise Max Iterations in the Solver panel",
    'OPERATOR': "raise Max Iterations in the Adjust Last Operation panel (F9)",
    'ARGUMENT': "pass a larger max_iterations=",
}


def unconverged_warning(stats, max_iterations, tolerance, iterations_from='SETTINGS'):
    """The warning for a solve that hit its iteration cap, naming where the cap was set
    (RAISE_ITERATIONS' keys)."""
    if stats.converged or tolerance <= 0:
        return None
    return ("The pose had not settled after %d iterations (tolerance %g): %s, or run Deform again to go on"
            % (max_iterations, tolerance, RAISE_ITERATIONS[iterations_from]))


def collapsed_handles_warning(problem, pose):
    """A warning naming handles whose Empty is scaled to (almost) nothing since
    its bind pose in `pose` (a HandlePose): their vertices collapse to a point."""
    names = problem.collapsed(pose)
    if not names:
        return None
    return ("The Empty of handle%s %s is scaled to almost nothing: %s vertices collapse to a point"
            % ("s" if len(names) > 1 else "", ", ".join("'%s'" % n for n in names),
               "their" if len(names) > 1 else "its"))


class ContactStop:
    """A pose Self Contact stopped short: handle `group` (None when the solver named none) made the share
    `reached` (< 1) of its move, as going further would make the surface pass through itself."""

    def __init__(self, group, reached):
        self.group = group
        self.reached = reached

    @property
    def percent(self):
        """The share made in whole percent, rounded down (a handle short of its targets never shows 100)."""
        return min(99, max(0, int(self.reached * 100.0)))

    def warning(self):
        if self.group is None:
            return ("The handles stopped at %d%% of their move: going further would make the surface pass "
                    "through itself (Self Contact)" % self.percent)
        return ("Handle '%s' stopped at %d%% of its move: going further would make the surface pass through "
                "itself (Self Contact)" % (self.group, self.percent))

    def status(self):
        """The short form, for the viewport's lines and the panel."""
        who = "handles" if self.group is None else "handle '%s'" % self.group
        return "Self Contact: %s stopped at %d%%" % (who, self.percent)


def contact_stop(problem, stats):
    """The ContactStop of one solve from the start shape (Deform, the bake, Auto mode here), from its stats
    (contact_reached, contact_stopped_vertex), or None when the handles reached their targets."""
    if stats.contact_reached >= 1.0:
        return None
    handle = constraints.handle_of(problem.setup, stats.contact_stopped_vertex)
    return ContactStop(handle.group if handle is not None else None, stats.contact_reached)


def contact_held(problem, stats):
    """What Self Contact did in a solve, for the report and the status: how many close pairs of the surface
    (a point and a triangle, or two edges, within the barrier's reach) it held apart at the end. None when
    Self Contact is off."""
    if not problem.has_contact:
        return None
    if stats.contact_pairs == 0:
        return "Self Contact: no part of the surface came near another"
    return "Self Contact held %d close pairs of the surface apart" % stats.contact_pairs


def contact_warning(problem, stats):
    """The warning for a solve Self Contact stopped short, naming the handle and the share of its move made."""
    stop = contact_stop(problem, stats)
    return stop.warning() if stop is not None else None


# A handle short of its targets by more than this share of its move, and this share of the mesh's size,
# was stopped by Self Contact (float32 coordinates are nearer than that).
SHORT_OF_MOVE = 1e-4
SHORT_OF_SIZE = 1e-5


def pose_contact_stop(problem, positions, targets):
    """The ContactStop of a settled pose read from the pose itself: `positions` (flat float32) solved for
    `targets`; the handle that made the smallest share of its move from rest, or None when each is at its
    targets. For solves that go on from one another (Live, Auto mode in the viewport), each of which
    reports only how far it took the handles itself."""
    if not problem.has_contact:
        return None
    at = positions.reshape(-1, 3)[problem.setup.constrained]
    stop = None
    for h in problem.setup.handles:
        rows = slice(h.start, h.stop)
        move = np.linalg.norm(targets[rows] - problem.rest_constrained[rows], axis=1)
        short = np.linalg.norm(targets[rows] - at[rows], axis=1)
        if short.max(initial=0.0) <= SHORT_OF_SIZE * problem.size or short.sum() <= SHORT_OF_MOVE * move.sum():
            continue
        reached = max(0.0, 1.0 - short.sum() / move.sum()) if move.sum() > 0 else 0.0
        if stop is None or reached < stop.reached:
            stop = ContactStop(h.group, reached)
    return stop
