# SPDX-License-Identifier: GPL-3.0-or-later
"""Bake operator and its sub-panel: a thin shell around bake.Baker.

Interactive runs are modal (see InteractiveBake): the frames are solved on a
worker thread, the newest one is shown in the viewport as it comes, with a
progress bar in the status bar and the frame in the viewport's corner; Esc
cancels and nothing is changed. In --background (no event loop) and from the
redo panel the bake runs synchronously in execute(), so scripts can call
bpy.ops.object.arap_bake(frame_start=1, frame_end=100, output='PC2', filepath="//pose.pc2").
"""

import time

import bpy
from bpy.props import EnumProperty, IntProperty, StringProperty

from .. import errors
from ..solver import bake, meshio, sessions
from ..ui import modal_timers, panels, status_overlay
from ..errors import SetupError
from ..native_loader import native

TICK_S = 1.0 / 60.0     # the modal's timer
TICK_SLICE_MS = 8.0     # how long a tick waits for frames the worker solves (Blender's thread is held meanwhile)
REPORTED_WARNINGS = 3   # frames whose warning the bake reports one by one (BakeResult.warnings has them all)
REDRAWN = ('VIEW_3D', 'STATUSBAR')   # where a bake shows itself: the preview and lines, the progress bar

OUTPUT_ITEMS = (
    ('SHAPE_KEYS', "Shape Keys", "One shape key per frame (ARAP_f0001...), keyed on at its frame"),
    ('PC2', "Point Cache (.pc2)", "A .pc2 file read by a Mesh Cache modifier"),
)


# A FILE_PATH property that takes "//" (next to the .blend) must say so on newer
# Blenders (5.2), which warn at every such value otherwise; older ones (3.4, 4.3)
# refuse the flag and drop the property, so ask Blender whether it knows it.
BLEND_RELATIVE = ({"options": {'ANIMATABLE', 'PATH_SUPPORTS_BLEND_RELATIVE'}}
                  if "is_path_supports_blend_relative" in bpy.types.Property.bl_rna.properties else {})


def _default_pc2(obj):
    return "//%s_arap.pc2" % bpy.path.clean_name(obj.name)


class InteractiveBake:
    """What the modal bake does each tick, as plain logic (tested in --background):
    hand the next frame's solve to the worker thread, show each solved frame on
    the mesh (a preview, undone before the bake writes its result or when it is
    cancelled: the mesh comes back bit for bit) and publish the progress the
    status bar and the viewport draw."""

    current = None   # the running InteractiveBake, read by draw_status_bar

    def __init__(self, baker):
        self.baker = baker
        obj = baker.obj
        self.snapshot = meshio.Snapshot(obj)
        self.preview = meshio.Output(obj, meshio.resolve_output(obj, obj.arap.output))
        self.preview.ensure()
        self.worker = native().SolveWorker(baker.solver, max_iterations=baker.solver.max_iterations)
        self.posted = False      # a frame's solve is with the worker
        InteractiveBake.current = self

    @property
    def fraction(self):
        return self.baker.index / len(self.baker.frames)

    def status(self):
        b = self.baker
        return "ARAP bake of '%s': frame %d (%d of %d)" % (b.name, b.frames[max(b.index - 1, 0)], b.index,
                                                           len(b.frames))

    def count(self):
        """The progress bar's own text: short enough for its width."""
        return "%d/%d" % (self.baker.index, len(self.baker.frames))

    def step(self, slice_ms=TICK_SLICE_MS):
        """One tick: frames go to the worker one after the other while they come back within
        `slice_ms` (small meshes: many frames a tick); the last one solved is shown. True when every
        frame is solved."""
        end = time.perf_counter() + slice_ms / 1e3
        solved = False
        while not self.baker.done:
            if not self.posted:
                self.baker.post_frame(self.worker)
                self.posted = True
            if not self.worker.wait(max(0.0, (end - time.perf_counter()) * 1e3)):
                break
            if self.baker.take_frame(self.worker):
                self.posted = False
                solved = True
        if solved:
            self.baker.check()
            self.preview.write(self.baker.last_positions.ravel())
        return self.baker.done

    def before_save(self):
        """The preview is not the bake: a .blend saved now holds the mesh as it was before the bake."""
        self.snapshot.restore()

    def after_save(self):
        """Show the preview again (the last frame solved)."""
        self.preview.ensure()
        if self.baker.index > 0:
            self.preview.write(self.baker.last_positions.ravel())

    def _stop(self):
        self.worker.stop()
        try:
            self.baker.check()
        except SetupError:
            pass   # deleted, or edited meanwhile: the mesh is the user's now, nothing to take back
        else:
            self.snapshot.restore()
        if InteractiveBake.current is self:
            InteractiveBake.current = None

    def cancel(self):
        self._stop()
        self.baker.cancel()

    def finish(self, write):
        """Take the preview away, then write the bake with `write(baker)`."""
        self._stop()
        return write(self.baker)


def draw_status_bar(self, _context):
    """Status bar progress of a running interactive bake (Blender's progress bar on 4.0+); the words
    are in the viewport (bake_status_lines), where nothing cuts them short."""
    run = InteractiveBake.current
    if run is None:
        return
    if hasattr(self.layout, "progress"):
        self.layout.progress(factor=run.fraction, type='BAR', text=run.count())
    else:
        self.layout.label(text="ARAP bake %d%%" % round(100 * run.fraction))


def bake_status_lines():
    """What the viewport shows while an interactive bake runs."""
    run = InteractiveBake.current
    if run is None:
        return []
    return [run.status(), "Esc: cancel (nothing is changed)"]


class ARAP_OT_bake(bpy.types.Operator):
    """Solve every frame of a range (warm-started, to the tolerance) and store the poses for playback"""
    bl_idname = "object.arap_bake"
    bl_label = "Bake ARAP Animation"
    bl_options = {'REGISTER', 'UNDO'}

    frame_start: IntProperty(name="Start", description="First frame to bake (default: the scene's start)",
                             default=1)
    frame_end: IntProperty(name="End", description="Last frame to bake (default: the scene's end)", default=250)
    output: EnumProperty(name="Output", description="Where the baked poses go", items=OUTPUT_ITEMS,
                         default='SHAPE_KEYS')
    filepath: StringProperty(name="File", description="The .pc2 file to write (empty: //<object>_arap.pc2)",
                             subtype='FILE_PATH', default="", **BLEND_RELATIVE)

    @classmethod
    def poll(cls, context):
        obj = sessions.target_mesh(context)
        return obj is not None and obj.mode == 'OBJECT'

    def _check(self, context):
        """Fill defaults; returns an error message or None."""
        if self.output == 'PC2':
            if not self.filepath:
                self.filepath = _default_pc2(sessions.target_mesh(context))
            if self.filepath.startswith("//") and not bpy.data.filepath:
                return "Save the .blend first, or give the .pc2 file an absolute path"
        return None

    def _start(self, context):
        return bake.Baker(sessions.target_mesh(context), self.frame_start, self.frame_end, scene=context.scene,
                          pc2_path=self.filepath if self.output == 'PC2' else None)

    def _write(self, baker):
        return baker.write_pc2_cache() if self.output == 'PC2' else baker.write_shape_keys()

    def _finish(self, baker):
        self._report(self._write(baker))

    def _report(self, result):
        for w in result.warnings[:REPORTED_WARNINGS]:
            self.report({'WARNING'}, w)
        more = len(result.warnings) - REPORTED_WARNINGS
        if more > 0:
            self.report({'WARNING'}, "%d more frame(s) stopped short of the handles' targets (Self Contact)" % more)
        n = len(result.frames)
        total = "%.1f s" % (result.total_ms / 1e3) if result.total_ms >= 1e3 else "%.0f ms" % result.total_ms
        self.report({'INFO'}, "Baked %d frame(s) in %s (%.1f ms/frame, %.1f iterations/frame)"
                    % (n, total, sum(result.ms) / n, sum(result.iterations) / n))

    def execute(self, context):
        error = self._check(context)
        if error:
            self.report({'ERROR'}, error)
            return {'CANCELLED'}
        baker = None
        try:
            baker = self._start(context)
            baker.run()
            self._finish(baker)
        except Exception as exc:  # noqa: BLE001 - user errors are reported, bugs re-raised
            if baker is not None:
                baker.cancel()
            return errors.report_error(self, exc)
        return {'FINISHED'}

    def invoke(self, context, event):
        scene = context.scene
        if not self.properties.is_property_set("frame_start"):
            self.frame_start = scene.frame_start
        if not self.properties.is_property_set("frame_end"):
            self.frame_end = scene.frame_end
        if bpy.app.background or context.window is None:
            return self.execute(context)
        error = self._check(context)
        if error:
            self.report({'ERROR'}, error)
            return {'CANCELLED'}
        try:
            self._run = InteractiveBake(self._start(context))
        except Exception as exc:  # noqa: BLE001
            return errors.report_error(self, exc)
        modal_timers.add(self.bl_idname, context, TICK_S)
        context.window_manager.modal_handler_add(self)
        bpy.types.STATUSBAR_HT_header.append(draw_status_bar)
        status_overlay.add(bake_status_lines)
        return {'RUNNING_MODAL'}

    def _end(self, context):
        _remove_progress()
        status_overlay.redraw(context, REDRAWN)

    def modal(self, context, event):
        run = self._run
        if event.type == 'ESC':
            self._end(context)
            run.cancel()
            self.report({'WARNING'}, "Bake cancelled: nothing was changed")
            return {'CANCELLED'}
        if event.type != 'TIMER':
            return {'RUNNING_MODAL'}  # the bake owns the frame: other input waits
        try:
            if run.step():
                self._end(context)
                self._report(run.finish(self._write))
                return {'FINISHED'}
        except Exception as exc:  # noqa: BLE001
            self._end(context)
            run.cancel()
            return errors.report_error(self, exc)
        status_overlay.redraw(context, REDRAWN)
        return {'RUNNING_MODAL'}


def _remove_progress():
    """The modal's timer, status bar progress and viewport lines away."""
    modal_timers.remove(ARAP_OT_bake.bl_idname)
    bpy.types.STATUSBAR_HT_header.remove(draw_status_bar)   # no error when it is not there
    status_overlay.remove(bake_status_lines)


def stop_running():
    """The add-on is disabled during an interactive bake: cancel it (nothing changed, the mesh as it was) and
    take its timer and progress away, which would outlive the operator."""
    run = InteractiveBake.current
    if run is not None:
        run.cancel()
    _remove_progress()


class ARAP_OT_bake_clear(bpy.types.Operator):
    """Remove the baked shape keys or Mesh Cache modifier (the .pc2 file stays on disk)"""
    bl_idname = "object.arap_bake_clear"
    bl_label = "Clear ARAP Bake"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        obj = sessions.target_mesh(context)
        return obj is not None and obj.mode == 'OBJECT'

    def execute(self, context):
        n = bake.clear_bake(sessions.target_mesh(context))
        self.report({'INFO'}, "Removed %d baked item(s)" % n)
        return {'FINISHED'}


class ARAP_PT_bake(panels.SubPanel, bpy.types.Panel):
    """Bake the ARAP pose of every frame for playback"""
    bl_label = "Bake Animation"

    def draw(self, context):
        layout = self.layout
        scene = context.scene
        obj = sessions.target_mesh(context)
        row = layout.row(align=True)
        row.prop(scene, "frame_start", text="Start")
        row.prop(scene, "frame_end", text="End")
        col = layout.column(align=True)
        op = col.operator(ARAP_OT_bake.bl_idname, text="Bake Shape Keys", icon='SHAPEKEY_DATA')
        op.output = 'SHAPE_KEYS'
        op = col.operator(ARAP_OT_bake.bl_idname, text="Bake Point Cache (.pc2)", icon='FILE_CACHE')
        op.output = 'PC2'
        op.filepath = _default_pc2(obj)
        if bake.is_baked(obj):
            col.operator(ARAP_OT_bake_clear.bl_idname, icon='TRASH')


classes = (ARAP_OT_bake, ARAP_OT_bake_clear, ARAP_PT_bake)
register, _unregister_classes = bpy.utils.register_classes_factory(classes)


def unregister():
    stop_running()
    _unregister_classes()
