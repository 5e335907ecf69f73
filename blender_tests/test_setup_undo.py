# Undo and redo of the set-up buttons (Set Fixed / Add Handle from Selection, the
# handle list's + and -), pressed in Edit Mode and in Object Mode, as the window
# runs them: every button press pushes its operator's undo step (undo=True does
# what the UNDO flag does after a click), Tab is the Toggle Edit Mode step and a
# selection made in Edit Mode is an edit-mesh step of its own (a click pushes one).
# In --background Blender's undo stack starts with the first pushed step (setUp).
#
# After every step, undo and redo, the settings and the vertex groups must agree:
# each group the settings name exists, and the ARAP groups are the ones they name.
import unittest

import bmesh
import bpy

import arap_test_utils as U

NAME = "Bar"


def bar():
    # Memfile undo loads new objects: look the object up again after each step.
    return bpy.data.objects[NAME]


def press(op, **props):
    """Press a button: run the operator and push its undo step."""
    return op('INVOKE_DEFAULT', True, **props)


def toggle_edit_mode():
    """Tab."""
    assert press(bpy.ops.object.editmode_toggle) == {'FINISHED'}


def select_in_edit_mode(predicate):
    """Select the vertices whose rest co satisfies predicate(co), as clicks do."""
    obj = bar()
    bm = bmesh.from_edit_mesh(obj.data)
    for v in bm.verts:
        v.select_set(predicate(v.co))
    bm.select_flush_mode()
    bmesh.update_edit_mesh(obj.data)
    bpy.ops.ed.undo_push(message="Select")
    return sorted(v.index for v in bm.verts if v.select)


def bottom(co):
    return co.z < -1.5


def top(co):
    return co.z > 1.5


def snapshot():
    """Everything a set-up step changes, read in either mode: the settings, the vertex
    groups with their members, the Empties in the file, the selection and the mode."""
    obj = bar()
    names = {g.index: g.name for g in obj.vertex_groups}
    members = {name: [] for name in names.values()}
    if obj.mode == 'EDIT':
        bm = bmesh.from_edit_mesh(obj.data)
        bm.verts.ensure_lookup_table()
        layer = bm.verts.layers.deform.active
        weights = [(v.index, v[layer].keys()) for v in bm.verts] if layer is not None else []
        selected = [v.index for v in bm.verts if v.select]
    else:
        weights = [(v.index, [e.group for e in v.groups]) for v in obj.data.vertices]
        selected = [v.index for v in obj.data.vertices if v.select]
    for index, groups in weights:
        for g in groups:
            # A weight whose group has no name is a group undo forgot.
            members.setdefault(names.get(g, "<group %d>" % g), []).append(index)
    s = obj.arap
    return {
        "mode": obj.mode,
        "fixed": s.fixed_group,
        "handles": [(h.group, h.empty.name if h.empty is not None else None) for h in s.handles],
        "active": s.active_handle,
        "groups": members,
        "empties": sorted(o.name for o in bpy.data.objects if o.type == 'EMPTY'),
        "in_scene": sorted(o.name for o in bpy.context.scene.objects if o.type == 'EMPTY'),
        "selected": selected,
        "texts": [t.name for t in bpy.data.texts],
    }


class SetUpUndo:
    """The flows, run in MODE ('EDIT' or 'OBJECT') by the classes below."""
    MODE = None

    def setUp(self):
        U.clear_scene()
        U.add_cylinder(name=NAME)
        bpy.ops.ed.undo_push(message="Original")
        self.history = [snapshot()]
        self.kept = set()
        if self.MODE == 'EDIT':
            toggle_edit_mode()
            self.history.append(snapshot())

    def tearDown(self):
        if bpy.context.object is not None and bpy.context.object.mode == 'EDIT':
            bpy.ops.object.mode_set(mode='OBJECT')

    def step(self, op=None, select=None, **props):
        """Select (when `select` is given) and press `op`, recording each undo step. In
        Object Mode the selection is made in Edit Mode and Tab leaves it again."""
        picked = None
        if select is not None:
            if self.MODE == 'OBJECT':
                toggle_edit_mode()
                self.record()
            picked = select_in_edit_mode(select)
            self.record()
            if self.MODE == 'OBJECT':
                toggle_edit_mode()
                self.record()
        if op is not None:
            self.assertEqual(press(op, **props), {'FINISHED'})
            self.record()
        return picked

    def record(self):
        state = snapshot()
        self.assert_consistent(state, self.kept)
        self.assertEqual(state["texts"], [])   # no scratch data-block is left behind
        self.history.append(state)

    def assert_consistent(self, state, kept=()):
        """Each group the settings name exists; the ARAP groups are those (and `kept`)."""
        named = {state["fixed"]} | {g for g, _e in state["handles"]}
        named.discard("")
        self.assertLessEqual(named, set(state["groups"]), state)
        arap = {g for g in state["groups"] if g.startswith("ARAP_")}
        self.assertEqual(arap, {g for g in named if g.startswith("ARAP_")} | set(kept), state)
        for _g, empty in state["handles"]:
            if empty is not None:   # a slot added with + has none yet
                self.assertIn(empty, state["in_scene"], state)

    def walk_back_and_forth(self):
        """Undo to the first step, checking each against the state it had, then redo to the last."""
        last = len(self.history) - 1
        for i in range(last - 1, -1, -1):
            bpy.ops.ed.undo()
            self.assertEqual(snapshot(), self.history[i], "undo to step %d of %d" % (i, last))
        for i in range(1, last + 1):
            bpy.ops.ed.redo()
            self.assertEqual(snapshot(), self.history[i], "redo to step %d of %d" % (i, last))

    def fixed_then_handle(self):
        fixed = self.step(bpy.ops.object.arap_set_fixed_from_selection, select=bottom)
        handle = self.step(bpy.ops.object.arap_add_handle_from_selection, select=top)
        state = snapshot()
        self.assertEqual(state["mode"], self.MODE)
        self.assertEqual(state["fixed"], "ARAP_Fixed")
        self.assertEqual(state["groups"]["ARAP_Fixed"], fixed)
        self.assertEqual(state["handles"], [("ARAP_Handle_1", "Bar_ARAP_Handle_1")])
        self.assertEqual(state["groups"]["ARAP_Handle_1"], handle)
        return fixed, handle

    def test_undo_once_after_add_handle_keeps_the_fixed_group(self):
        fixed, _handle = self.fixed_then_handle()
        bpy.ops.ed.undo()
        state = snapshot()
        self.assertEqual(state["fixed"], "ARAP_Fixed")
        self.assertEqual(state["groups"]["ARAP_Fixed"], fixed)
        self.assertEqual(state["handles"], [])
        self.assertEqual(state["empties"], [])
        self.assertNotIn("ARAP_Handle_1", state["groups"])
        self.assert_consistent(state)

    def test_undo_and_redo_every_step(self):
        self.fixed_then_handle()
        self.walk_back_and_forth()

    def test_set_fixed_after_undo_makes_no_second_group(self):
        # Undo once goes back to the top selected; Set Fixed takes it.
        _fixed, picked = self.fixed_then_handle()
        bpy.ops.ed.undo()
        self.assertEqual(press(bpy.ops.object.arap_set_fixed_from_selection), {'FINISHED'})
        state = snapshot()
        self.assertEqual(state["fixed"], "ARAP_Fixed")
        self.assertEqual(sorted(state["groups"]), ["ARAP_Fixed"])
        self.assertEqual(state["groups"]["ARAP_Fixed"], picked)

    def test_set_fixed_again_after_undoing_it(self):
        self.step(bpy.ops.object.arap_set_fixed_from_selection, select=bottom)
        bpy.ops.ed.undo()
        state = snapshot()
        self.assertEqual(state["fixed"], "")
        self.assertEqual(state["groups"], {})
        self.assertEqual(press(bpy.ops.object.arap_set_fixed_from_selection), {'FINISHED'})
        state = snapshot()
        self.assertEqual(state["fixed"], "ARAP_Fixed")
        self.assertEqual(sorted(state["groups"]), ["ARAP_Fixed"])
        self.assert_consistent(state)

    def test_remove_handle_undo_and_redo(self):
        self.fixed_then_handle()
        self.step(bpy.ops.object.arap_add_handle_from_selection, select=bottom)
        self.kept = {"ARAP_Handle_2"}
        self.step(bpy.ops.object.arap_handle_remove)
        state = snapshot()
        # The removed handle's group and Empty are kept.
        self.assertEqual(state["handles"], [("ARAP_Handle_1", "Bar_ARAP_Handle_1")])
        self.assertIn("ARAP_Handle_2", state["groups"])
        self.assertIn("Bar_ARAP_Handle_2", state["in_scene"])
        bpy.ops.ed.undo()
        state = snapshot()
        self.assertEqual(state["handles"], [("ARAP_Handle_1", "Bar_ARAP_Handle_1"),
                                            ("ARAP_Handle_2", "Bar_ARAP_Handle_2")])
        self.assertEqual(state["active"], 1)
        self.assert_consistent(state)
        bpy.ops.ed.redo()
        state = snapshot()
        self.assertEqual(state["handles"], [("ARAP_Handle_1", "Bar_ARAP_Handle_1")])
        self.assert_consistent(state, kept={"ARAP_Handle_2"})

    def test_handle_list_add_survives_a_later_undo(self):
        # + adds a slot (object settings only); a later Add Handle from Selection and
        # its undo must leave the slot there, and undoing + removes it.
        self.step(bpy.ops.object.arap_handle_add)
        self.assertEqual(snapshot()["handles"], [("", None)])
        self.step(bpy.ops.object.arap_add_handle_from_selection, select=top)
        self.assertEqual(snapshot()["handles"], [("", None), ("ARAP_Handle_1", "Bar_ARAP_Handle_1")])
        bpy.ops.ed.undo()
        self.assertEqual(snapshot()["handles"], [("", None)])
        bpy.ops.ed.redo()
        self.assertEqual(snapshot(), self.history[-1])
        self.walk_back_and_forth()


class SetUpUndoInEditMode(SetUpUndo, unittest.TestCase):
    MODE = 'EDIT'


class SetUpUndoInObjectMode(SetUpUndo, unittest.TestCase):
    MODE = 'OBJECT'


if __name__ == "__main__":
    unittest.main()
