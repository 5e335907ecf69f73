# SPDX-License-Identifier: GPL-3.0-or-later
"""Settings saved in the .blend: Object.arap (ARAP_PG_settings).

Bind pose of a handle's empty: `bind_matrix` holds the empty's world matrix
(row-major, 16 floats) captured when the handle is created (operator or
api.add_handle) and captured again by "Reset to Rest" and "Set Rest Pose".
A handle's vertices then follow M_empty_now @ inverse(bind_matrix).
A handle on a bone (`bone` set) keeps the bone's matrix in armature space
instead (solver/drivers.py).
"""

import bpy
from bpy.props import (BoolProperty, CollectionProperty, EnumProperty, FloatProperty,
                       FloatVectorProperty, IntProperty, PointerProperty, StringProperty)
from bpy.types import PropertyGroup

from .solver_settings import (INIT_ITEMS, INIT_NAMES, ITERATIONS_RANGE, METHOD_ITEMS, METHOD_NAMES,
                              TOLERANCE_STYLE, VOLUME_ITEMS, VOLUME_NAMES, WEIGHT_ITEMS, WEIGHT_NAMES,
                              option_enum, option_float, option_int)

IDENTITY16 = (1.0, 0.0, 0.0, 0.0,
              0.0, 1.0, 0.0, 0.0,
              0.0, 0.0, 1.0, 0.0,
              0.0, 0.0, 0.0, 1.0)

OUTPUT_ITEMS = (
    ('AUTO', "Auto", "A shape key named \"ARAP\" when the mesh has shape keys, otherwise the mesh itself"),
    ('MESH', "Mesh", "Overwrite the mesh coordinates (the rest shape is kept in the \"arap_rest\" attribute)"),
    ('SHAPE_KEY', "Shape Key", "Write into a shape key named \"ARAP\": the basis (rest shape) is never touched"),
)


def _poll_empty(_self, obj):
    return obj.type == 'EMPTY'


def _poll_armature(_self, obj):
    return obj.type == 'ARMATURE'


class ARAP_PG_handle(PropertyGroup):
    """A vertex group whose vertices follow an empty, or a bone when `bone` is set."""

    group: StringProperty(
        name="Vertex Group",
        description="Vertices of this group follow the empty",
        default="",
    )
    empty: PointerProperty(
        name="Empty",
        description="Empty object whose motion since the bind pose moves the group's vertices",
        type=bpy.types.Object,
        poll=_poll_empty,
    )
    armature: PointerProperty(
        name="Armature",
        description="Armature object whose bone moves the group's vertices (with Bone set)",
        type=bpy.types.Object,
        poll=_poll_armature,
    )
    bone: StringProperty(
        name="Bone",
        description="Bone whose pose since the bind pose moves the group's vertices, as the Armature modifier "
                    "moves a vertex weighted fully to it (empty: the handle follows its Empty)",
        default="",
    )
    bind_matrix: FloatVectorProperty(
        name="Bind Matrix",
        description="World matrix of the empty at bind time, or the bone's matrix in armature space (row-major)",
        size=16,
        default=IDENTITY16,
        options={'HIDDEN'},
    )
    has_bind: BoolProperty(
        name="Has Bind Pose",
        description="The bind matrix was captured",
        default=False,
        options={'HIDDEN'},
    )


# What Auto mode does when these settings change, fn(settings, context): auto.py gives them when it registers
# (the settings import nothing above them).
on_auto_changed = None     # Auto turned on or off
on_bind_changed = None     # a setting fixed at bind (Volume, Self Contact)


def _auto_changed(settings, context):
    if on_auto_changed is not None:
        on_auto_changed(settings, context)


def _bind_changed(settings, context):
    if on_bind_changed is not None:
        on_bind_changed(settings, context)


class ARAP_PG_settings(PropertyGroup):
    """ARAP settings of one mesh object."""

    auto: BoolProperty(
        name="Auto",
        description="Keep the mesh posed by its handles whenever they move, animate or are scrubbed, like a "
                    "modifier. Off: the mesh shows again what it showed when Auto was turned on (the rest shape, or a "
                    "pose applied before)",
        default=False,
        update=_auto_changed,
    )
    auto_status: StringProperty(
        name="Auto Status",
        description="Why Auto posing last stopped by itself (empty when it did not)",
        default="",
    )

    fixed_group: StringProperty(
        name="Fixed Group",
        description="Vertex group whose vertices stay at their rest position",
        default="",
    )
    handles: CollectionProperty(type=ARAP_PG_handle, name="Handles")
    active_handle: IntProperty(name="Active Handle", default=0, min=0)
    armature_muted: StringProperty(
        name="Armature Muted",
        description="What ARAP turned off of the rig's own deformation while it shows a pose (solver/rig.py), "
                    "to put back exactly",
        default="",
        options={'HIDDEN'},
    )
    method: option_enum(
        "method", METHOD_ITEMS, METHOD_NAMES,
        name="Method", description="How the energy is minimised (all reach the same minimum)",
    )
    max_iterations: option_int(
        "max_iterations",
        name="Max Iterations",
        description="Most iterations a Deform may take, a safety cap: it stops once the pose has settled "
                    "(see Tolerance)",
        **ITERATIONS_RANGE,
    )
    live_max_iterations: option_int(
        "max_iterations",
        name="Live Max Iterations",
        description="Most iterations per viewport update while Live runs; each update also stops at the "
                    "Live Frame Budget, and Live goes on while nothing moves until the pose has settled",
        default=100, min=1, soft_max=1000,
    )
    live_frame_ms: FloatProperty(
        name="Live Frame Budget",
        description="Milliseconds of solving per Live update: the viewport stays interactive while a handle "
                    "moves, and the pose settles over the next updates once it stops",
        default=16.0, min=1.0, max=1000.0,
    )
    tolerance: option_float(
        "tolerance",
        name="Tolerance",
        description="How settled the pose must be to stop: the solver stops when an iteration improves it by "
                    "less than this fraction. Smaller is more exact and slower; 0 runs every iteration up to "
                    "Max Iterations",
        **TOLERANCE_STYLE,
    )
    weights: option_enum(
        "weights", WEIGHT_ITEMS, WEIGHT_NAMES,
        name="Edge Weights", description="How much each edge resists stretching. Cotangent (clamped) suits "
        "almost every mesh",
    )
    init: option_enum(
        "init", INIT_ITEMS, INIT_NAMES,
        name="Start From", description="The shape the solver starts from; the pose it settles in can differ",
    )
    stiff_group: StringProperty(
        name="Stiff Group",
        description="Vertex group of regions that should bend less (e.g. a torso while the limbs bend); "
                    "its weights blend from normal (0) to Stiffness (1)",
        default="",
    )
    stiffness: FloatProperty(
        name="Stiffness",
        description="How much more the Stiff Group resists bending than the rest of the mesh "
                    "(it scales those vertices' share of the ARAP energy)",
        default=10.0, min=1.0, max=1000.0, soft_max=100.0,
    )
    volume: option_enum(
        "volume", VOLUME_ITEMS, VOLUME_NAMES,
        name="Volume", description="What keeps thick parts from folding flat and losing volume where they bend "
        "(surface ARAP keeps the surface rigid, not the inside). Global and Infill work with the Quasi-Newton and "
        "Local/Global methods (with Anderson, Quasi-Newton is used)",
        update=_bind_changed,
    )
    infill_resolution: option_int(
        "infill_resolution",
        name="Infill Resolution",
        description="Lattice cubes along the longest side of the mesh: finer follows thin parts better and costs "
                    "more per iteration",
        soft_max=64, update=_bind_changed,
    )
    # Named after the solver's contact option: on is its "self", off its "none" (solver_settings.CONTACT_NAMES).
    contact: BoolProperty(
        name="Self Contact",
        description="The surface never passes through itself: parts that are apart at rest stay at least a small "
                    "gap apart in every pose Deform, Live, Auto and the bake make, and a handle whose move would "
                    "make it cross stops short. Works with the Quasi-Newton and Local/Global methods (with "
                    "Anderson, Quasi-Newton is used); costs more per solve",
        default=False,
        update=_bind_changed,
    )
    anderson_window: option_int(
        "anderson_window",
        name="Anderson Window",
        description="Speeds up settling of the Anderson method by extrapolating from this many past iterations "
                    "(Anderson acceleration). A step is kept only when it improves the pose",
    )
    threads: option_int(
        "threads",
        name="Threads",
        description="CPU threads for the solver; more than 1 only helps on large meshes (100k+ vertices), "
                    "and with Self Contact from a few thousand vertices, "
                    "when the computer is otherwise idle",
    )
    output: EnumProperty(
        name="Result", description="Where the deformed coordinates are written",
        items=OUTPUT_ITEMS, default='AUTO',
    )
    live_interval: FloatProperty(
        name="Live Interval",
        description="Seconds between Live updates",
        default=1.0 / 30.0, min=0.001, max=1.0,
    )
    # Written on save (older_settings.SAVED_WITH): settings without it that hold anything were saved by a
    # version whose defaults older_settings.OLD_DEFAULTS lists.
    saved_with: IntProperty(name="Saved With", default=0, min=0, options={'HIDDEN'})


classes = (ARAP_PG_handle, ARAP_PG_settings)
_register_classes, _unregister_classes = bpy.utils.register_classes_factory(classes)


def register():
    _register_classes()
    bpy.types.Object.arap = PointerProperty(type=ARAP_PG_settings, name="ARAP Deform")


def unregister():
    del bpy.types.Object.arap
    _unregister_classes()
