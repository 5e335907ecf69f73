# SPDX-License-Identifier: GPL-3.0-or-later
"""Plain Python API of ARAP Deform, for scripts and --background runs.

Blender 3.x loads the add-on as "arap_deform", 4.2+ as the extension
"bl_ext.<repository>.arap_deform" (only under that name), so a script imports
this module through the name Blender gave the add-on, enabling it when it is
off (as in `blender --factory-startup`; enabling an enabled add-on registers it
again):

    import addon_utils
    import importlib

    name = next(mod.__name__ for mod in addon_utils.modules() if mod.__name__.rpartition(".")[2] == "arap_deform")
    if not addon_utils.check(name)[1]:
        addon_utils.enable(name, default_set=True)
    api = importlib.import_module(name + ".api")

Then:

    import bpy
    obj = bpy.data.objects["Suzanne"]
    api.set_fixed(obj, "feet")
    api.add_handle(obj, "hand", bpy.data.objects["HandEmpty"])   # bind pose = the empty now
    bpy.data.objects["HandEmpty"].location.z += 0.5
    result = api.deform(obj, max_iterations=20)
    print(result.energies, result.solve_ms)

Rules:
- Object Mode only (SetupError otherwise); errors leave the mesh untouched.
- Rest shape: the basis shape key when writing to the "ARAP" shape key,
  otherwise the "arap_rest" attribute (captured on the first write or by
  set_rest_pose()).
- Bind pose of an empty: its world matrix when the handle is added, and
  again on reset() / set_rest_pose(). A handle's vertices follow the
  empty's motion since then (full transform: move, rotate, scale).

Errors: SetupError (set-up to change) and ArapError (from the native solver,
e.g. NaN coordinates) are both subclasses of Exception with a readable message.
"""

import importlib

import bpy
import numpy as np

from . import native_loader
from .persistence import older_settings, properties
from .solver import constraints, deform_job, problem, rig, solver_cache
from .solver.deform_job import DeformResult  # noqa: F401
from .errors import SessionError, SetupError  # noqa: F401
from .solver.live import LiveSession  # noqa: F401
from .native_loader import NativeModuleError  # noqa: F401
# Animation bake (see bake.py): shape keys per frame, or a .pc2 point cache read by a Mesh Cache modifier.
from .solver.bake import bake_pc2, bake_shape_keys, clear_bake, read_pc2  # noqa: F401

__all__ = ("SetupError", "SessionError", "NativeModuleError", "DeformResult", "LiveSession", "settings",
           "set_fixed", "add_handle", "remove_handle", "create_group", "deform", "bind", "set_rest_pose",
           "reset", "start_session", "rest_positions", "ArapError", "bake_shape_keys", "bake_pc2", "clear_bake",
           "read_pc2", "last_result", "set_auto")


def __getattr__(name):
    # api.ArapError: the native exception class, resolved when first asked for.
    if name == "ArapError":
        return native_loader.native().ArapError
    raise AttributeError(name)


def _registered():
    """Register the add-on's classes when a script imported this module without
    enabling the add-on (e.g. blender --factory-startup): then obj.arap exists."""
    if not hasattr(bpy.types.Object, "arap"):
        importlib.import_module(__package__).register()


def settings(obj):
    """The object's ARAP settings (ARAP_PG_settings, saved in the .blend)."""
    _registered()
    return obj.arap


def create_group(obj, name, indices):
    """New vertex group `name` holding vertex `indices` with weight 1."""
    group = obj.vertex_groups.new(name=name)
    group.add([int(i) for i in indices], 1.0, 'REPLACE')
    return group


def set_fixed(obj, group):
    """Vertices of vertex group `group` (a name) stay at rest. "" clears it."""
    _registered()
    if group and group not in obj.vertex_groups:
        raise SetupError("Vertex group '%s' does not exist on '%s'" % (group, obj.name))
    obj.arap.fixed_group = group


def add_handle(obj, group, empty):
    """Vertex group `group` follows Empty `empty`; its bind pose is captured now."""
    _registered()
    if group not in obj.vertex_groups:
        raise SetupError("Vertex group '%s' does not exist on '%s'" % (group, obj.name))
    if empty is None or empty.type != 'EMPTY':
        raise SetupError("A handle is driven by an Empty object")
    item = obj.arap.handles.add()
    item.group = group
    item.empty = empty
    deform_job.capture_bind(item)
    obj.arap.active_handle = len(obj.arap.handles) - 1
    return item


def add_bone_handle(obj, group, armature, bone):
    """Vertex group `group` follows bone `bone` of armature object `armature`, bound at the bone's rest pose:
    its vertices move as the Armature modifier moves a vertex weighted fully to that bone."""
    _registered()
    if group not in obj.vertex_groups:
        raise SetupError("Vertex group '%s' does not exist on '%s'" % (group, obj.name))
    if armature is None or armature.type != 'ARMATURE':
        raise SetupError("A bone handle is driven by a bone of an armature object")
    if bone not in armature.data.bones:
        raise SetupError("The armature '%s' has no bone '%s'" % (armature.name, bone))
    item = obj.arap.handles.add()
    item.group, item.armature, item.bone = group, armature, bone
    deform_job.capture_bind(item, at_rest=True)
    obj.arap.active_handle = len(obj.arap.handles) - 1
    return item


def handles_from_armature(obj, threshold=None, armature=None):
    """One handle per deform bone of the armature deforming `obj` (its Armature modifier, or an armature
    parent; or `armature`): the vertices weighted at least `threshold` (default rig.DEFAULT_CORE_WEIGHT) to
    a bone follow it, in a vertex group ARAP_Core_<bone>; the vertices no deform bone weights become the
    fixed group ARAP_Unweighted. Bone handles of that armature made before are replaced. While ARAP shows a
    pose, the Armature modifier is turned off (and back on at rest). Returns rig.RigHandles (.bones,
    .skipped, .summary())."""
    _registered()
    constraints.check_object(obj)
    made = rig.handles_from_armature(obj, rig.DEFAULT_CORE_WEIGHT if threshold is None else threshold, armature)
    if obj.arap.auto and properties.on_bind_changed is not None:
        properties.on_bind_changed(obj.arap, bpy.context)   # Auto mode binds the new cores and poses again
    return made


def remove_handle(obj, index):
    """Remove handle number `index` (the empty and vertex group are kept)."""
    _registered()
    handles = obj.arap.handles
    if not 0 <= index < len(handles):
        raise IndexError("no handle %d on '%s'" % (index, obj.name))
    handles.remove(index)
    obj.arap.active_handle = max(0, min(obj.arap.active_handle, len(handles) - 1))


def bind(obj, scene=None):
    """Check the set-up and bind the solver now (it is cached for deform()).

    Returns the native mesh report (dict: components, unconstrained_vertices, ...).
    """
    _registered()
    solver, _ms, _cached = solver_cache.bound_solver(obj, problem.Problem(obj, scene))
    return solver.mesh_report()


def deform(obj, max_iterations=None, tolerance=None, init=None, scene=None, iterations=None):
    """Solve from the rest shape and write the result. Returns DeformResult.

    max_iterations/tolerance/init (None: the object's settings; init is one of
    'LAPLACIAN', 'DIFFERENTIAL', 'NAIVE'). `scene`, when given, is used to
    detect empties deleted from it. iterations= is the deprecated name of
    max_iterations= (a DeprecationWarning).
    """
    _registered()
    max_iterations = older_settings.max_iterations_argument(max_iterations, iterations)
    return deform_job.deform(obj, scene=scene, max_iterations=max_iterations, tolerance=tolerance, init=init)


def set_rest_pose(obj):
    """Take the current shape as rest and the empties' current poses as bind poses."""
    _registered()
    deform_job.set_rest_pose(obj)


def reset(obj):
    """Put the rest shape back and capture the empties' bind poses again."""
    _registered()
    deform_job.reset(obj)


def set_auto(obj, enabled=True):
    """Auto mode on or off (obj.arap.auto): while on, the mesh is posed by its
    handles whenever they change -- moves, keyframes and frame changes
    (scene.frame_set) included. Off shows what the mesh showed when Auto was
    turned on (the rest shape, or a pose applied before). Turning it on
    poses at once and raises SetupError / ArapError when it cannot."""
    _registered()
    obj.arap.auto = enabled
    if enabled and not obj.arap.auto:
        raise SetupError(obj.arap.auto_status or "Auto posing could not start on '%s'" % obj.name)


def start_session(obj, scene=None, max_iterations=None, write=True, iterations=None):
    """A LiveSession: call .step() after moving empties, then .finish() or .cancel().

    max_iterations: per step (None: the object's Live Max Iterations; iterations= is its deprecated name).
    With write=False the mesh is never changed; read .positions() (flat float32,
    object-local) after each step, e.g. to bake frames.
    """
    _registered()
    max_iterations = older_settings.max_iterations_argument(max_iterations, iterations)
    return LiveSession(obj, scene=scene, max_iterations=max_iterations, write=write)


def last_result(obj):
    """Energies and timings of the last Deform or bake of `obj` in this session
    (operators included): a DeformResult or BakeResult, or None."""
    return deform_job.last_result(obj)


def rest_positions(obj):
    """The rest shape used by the solver, float64 (n, 3), object-local."""
    from .solver import meshio
    mode = meshio.resolve_output(obj, obj.arap.output)
    return meshio.rest_coords(obj, mode).astype(np.float64).reshape(-1, 3)
