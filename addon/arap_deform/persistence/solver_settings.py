# SPDX-License-Identifier: GPL-3.0-or-later
"""The solver's settings as Blender properties, declared once: defaults, limits and
choices from the native option table, names and tooltips the add-on's. The object's
settings (properties.py) and the Deform operator's redo panel (deform_ops.py) are made
with these; problem.py turns the enum identifiers into the solver's names."""

from bpy.props import EnumProperty, FloatProperty, IntProperty

from .. import native_loader

# The solver's options take their defaults, limits and choices from the native
# option table (arap::option_specs(), _arap_native.OPTIONS), read once when the
# add-on is enabled; the add-on adds names, tooltips and the enum items. When the
# module does not load in this Blender (built for another Python), the add-on
# still registers: those settings then have Blender's plain defaults and no
# limits, nothing can be solved, and NATIVE_ERROR (shown in the panel and by
# every operator that solves) says what to rebuild.
try:
    OPTIONS = native_loader.native().OPTIONS
    NATIVE_ERROR = None
except native_loader.NativeModuleError as exc:
    OPTIONS, NATIVE_ERROR = {}, str(exc)


def _limits(option, own):
    """The table's default, min and max of a numeric `option`, then the add-on's own keywords `own`
    (a narrower range where the add-on needs one; test_settings.py checks each against the table)."""
    spec = OPTIONS.get(option)
    keywords = {} if spec is None else {"default": spec["default"], "min": spec["min"], "max": spec["max"]}
    keywords.update(own)
    return keywords


def option_int(option, **keywords):
    """An IntProperty for the integer `option` of the table (name, description and any narrowing given)."""
    return IntProperty(**_limits(option, keywords))


def option_float(option, **keywords):
    """A FloatProperty for the real `option` of the table."""
    return FloatProperty(**_limits(option, keywords))


def _choices(*choices):
    """Enum choices, each once: (identifier, native name, label, tooltip). Returns the EnumProperty items
    and {identifier: native name} (what problem.py passes to the solver)."""
    return tuple((c[0], c[2], c[3]) for c in choices), {c[0]: c[1] for c in choices}


def option_enum(option, items, names, **keywords):
    """An EnumProperty for the choice `option`: its default is the item named as the table's default."""
    spec = OPTIONS.get(option)
    if spec is not None:
        keywords["default"] = next(i for i, n in names.items() if n == spec["default"])
    return EnumProperty(items=items, **keywords)


# Max Iterations and Tolerance as the object's settings and the Deform operator's redo panel both show them:
# at least one iteration (the solve worker refuses none); dragging reaches 10 000, typing the table's maximum.
ITERATIONS_RANGE = {"min": 1, "soft_max": 10000}
TOLERANCE_STYLE = {"precision": 7, "step": 0.0001}

WEIGHT_ITEMS, WEIGHT_NAMES = _choices(
    ('COTAN_CLAMPED', "cotan-clamped", "Cotangent (clamped)",
     "Cotangent weights with negative cotangents set to zero: robust on obtuse triangles"),
    ('COTAN', "cotan", "Cotangent",
     "Cotangent weights (Sorkine & Alexa 2007); may be negative on obtuse triangles"),
    ('UNIFORM', "uniform", "Uniform", "Every edge weighs 1: ignores the triangle shapes"),
)
# The start of a solve; the table's "warm" (the last solution) is Live's and Auto mode's own, not a setting.
INIT_ITEMS, INIT_NAMES = _choices(
    ('NAIVE', "naive", "Rest Shape", "Start from the rest shape with only the fixed and handle vertices moved. "
     "Usually ends in the least stretched pose"),
    ('LAPLACIAN', "laplacian", "Smooth",
     "Start from a smooth blend of the handle motion over the mesh (Laplacian editing)"),
    ('DIFFERENTIAL', "differential", "Smooth (uniform)", "Like Smooth, but every edge counts the same "
     "(Lipman et al. 2004): a start that ignores the triangle shapes"),
)
METHOD_ITEMS, METHOD_NAMES = _choices(
    ('QUASI_NEWTON', "quasi-newton", "Quasi-Newton", "L-BFGS with the factored Laplacian and a line search "
     "(Liu et al. 2017): the same minimum as local/global, on meshes of 10k+ vertices in a fifth of the time "
     "or less"),
    ('LOCAL_GLOBAL', "local-global", "Local/Global", "The textbook alternation of Sorkine & Alexa 2007"),
    ('ANDERSON', "anderson", "Anderson", "Local/global with Anderson acceleration over the Anderson Window"),
)
VOLUME_ITEMS, VOLUME_NAMES = _choices(
    ('NONE', "none", "Surface Only", "Surface ARAP (the paper's method): thick parts can fold flat and lose volume "
     "where they bend, and the pose depends on how finely the mesh is tessellated. Files from older versions "
     "keep it"),
    ('GLOBAL', "global", "Global", "Keep the enclosed volume of every closed part exactly; open parts are left "
     "as they are. About 1.4x the cost of an iteration, but the volume a bend squeezes out goes to the ends"),
    ('INFILL', "infill", "Infill", "Fill the inside with a lattice posed with the surface, like a 3D print's "
     "infill: keeps the volume and cross-sections where it bends, on any mesh (open ones too), and the same pose "
     "however finely the mesh is tessellated. An iteration costs 1.3x to 3.4x a surface one, but it settles in "
     "far fewer"),
)
# Self Contact is a switch: off and on are the contact option's two choices.
CONTACT_NAMES = {False: "none", True: "self"}
