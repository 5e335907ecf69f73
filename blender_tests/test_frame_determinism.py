# A frame's pose is a function of that frame's handles: the same bits whether the animation is
# rendered by one process, in two chunks by two processes, one frame alone, scrubbed in any
# order, baked, or settled by the viewport's worker.
import os
import shutil
import tempfile
import time
import unittest

import bpy
import numpy as np

import arap_test_utils as U

api, auto, bake = U.addon("api", "auto", "bake")

FRAMES = range(1, 13)

# Run inside the rendering Blender: after each rendered frame, keep the mesh Auto mode wrote.
DUMP = """
import bpy, numpy as np, os
def dump(scene, _unused=None):
    mesh = scene.objects["Bar"].data
    co = np.empty(3 * len(mesh.vertices), np.float32)
    mesh.vertices.foreach_get("co", co)
    np.save(os.path.join(%(folder)r, "%(tag)s_%%04d.npy" %% scene.frame_current), co)
bpy.app.handlers.render_post.append(dump)
"""


def animate(empty):
    """The top comes down to 60% of the height while it swings and turns: a buckling bar, where a
    warm start from the previous frame settles in a pose of its own."""
    for i, f in enumerate(FRAMES):
        empty.location = (0.12 * i, 0.05 * i, 2.0 - 0.13 * i)
        empty.rotation_euler = (0.04 * i, 0.1 * i, 0.0)
        empty.keyframe_insert("location", frame=f)
        empty.keyframe_insert("rotation_euler", frame=f)


class FrameDeterminism(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        U.clear_scene()
        auto.forget()
        obj, empty, _fixed, _top = U.bar_with_handle(vertices=24, cuts=40)
        obj.arap.output = 'MESH'
        animate(empty)
        scene = bpy.context.scene
        scene.frame_start, scene.frame_end = FRAMES[0], FRAMES[-1]
        cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
        scene.collection.objects.link(cam)
        scene.camera = cam
        scene.render.engine = 'BLENDER_WORKBENCH'
        scene.render.resolution_x = scene.render.resolution_y = 8
        scene.frame_set(1)
        api.set_auto(obj, True)
        cls.tmp = tempfile.mkdtemp(prefix="arap_frames_")
        scene.render.filepath = os.path.join(cls.tmp, "img_")
        cls.path = os.path.join(cls.tmp, "shot.blend")
        bpy.ops.wm.save_as_mainfile(filepath=cls.path, copy=True)
        api.set_auto(obj, False)

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def setUp(self):
        bpy.ops.wm.open_mainfile(filepath=self.path)
        self.obj = bpy.data.objects["Bar"]

    def render(self, tag, *frame_args):
        """Render in a new Blender; {frame: float32 coordinates} of the frames it rendered."""
        script = os.path.join(self.tmp, "dump_%s.py" % tag)
        with open(script, "w") as f:
            f.write(DUMP % {"folder": self.tmp, "tag": tag})
        U.run_blender_args([self.path, "--addons", U.ADDON_MODULE, "--python", script] + list(frame_args),
                           factory_startup=False)
        out = {}
        for name in os.listdir(self.tmp):
            if name.startswith(tag + "_") and name.endswith(".npy"):
                out[int(name[len(tag) + 1:-4])] = np.load(os.path.join(self.tmp, name))
        return out

    def played(self, frames):
        out = {}
        for f in frames:
            bpy.context.scene.frame_set(f)
            out[f] = U.raw_coords(self.obj).copy()
        return out

    def assert_same_bits(self, a, b, what):
        for f in sorted(set(a) & set(b)):
            self.assertTrue(np.array_equal(a[f], b[f]), "%s: frame %d differs by %.3g" % (
                what, f, float(np.abs(a[f] - b[f]).max())))

    def test_renders_in_chunks_alone_and_in_one_process_give_the_same_bits(self):
        whole = self.render("whole", "-s", "1", "-e", "12", "-a")
        self.assertEqual(sorted(whole), list(FRAMES))
        first = self.render("first", "-s", "1", "-e", "6", "-a")
        second = self.render("second", "-s", "7", "-e", "12", "-a")
        alone = self.render("alone", "-f", "10")
        self.assertEqual((sorted(first), sorted(second), sorted(alone)), (list(range(1, 7)), list(range(7, 13)), [10]))
        rest = U.raw_coords(self.obj)
        self.assertGreater(np.abs(whole[12] - rest).max(), 0.5)     # the frames do pose the bar
        self.assert_same_bits(whole, first, "chunk 1-6")
        self.assert_same_bits(whole, second, "chunk 7-12")
        self.assert_same_bits(whole, alone, "-f 10")
        # This process: played in order, scrubbed in another order, and the bake.
        self.assert_same_bits(whole, self.played(FRAMES), "playback")
        auto.forget()   # solved again, in another order, each from the state the frame before left
        self.assert_same_bits(whole, self.played([9, 3, 12, 7, 1, 10, 7]), "scrubbing")
        auto.forget()
        self.assert_same_bits(whole, self.played([8, 7, 6]), "backwards")
        baked = bake.bake_shape_keys(self.obj, 5, 12).positions
        self.assert_same_bits(whole, {f: baked[i].ravel() for i, f in enumerate(range(5, 13))}, "bake 5-12")

    def test_the_viewport_settles_on_the_pose_a_render_gives(self):
        scene = bpy.context.scene
        reference = self.played([7])
        auto.forget()
        self.played([2, 3])                       # the solver's state now comes from another path
        poser = auto._posers[self.obj.as_pointer()]
        poser.cache.clear()
        auto._busy = True   # the handler (which solves fully in --background) stays out of this change
        try:
            scene.frame_set(7)
            depsgraph = bpy.context.evaluated_depsgraph_get()
        finally:
            auto._busy = False
        previews = 0
        while not poser.update(self.obj, depsgraph, on_worker=True):
            previews += 1
            self.assertLess(previews, 100000, "Auto never settled")
            time.sleep(0.001)
        self.assert_same_bits(reference, {7: U.raw_coords(self.obj).copy()}, "viewport")


if __name__ == "__main__":
    unittest.main()
