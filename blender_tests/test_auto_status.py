# Auto mode's line in the viewport: a pose the worker has settled before the
# viewport's first look at it is still shown as settled.
import types
import unittest

import bpy

import arap_test_utils as U

api, auto, native_loader = U.addon("api", "auto", "native_loader")


class WaitingWorker:
    """A SolveWorker whose post() returns only once the worker has a finished solve to take: the
    viewport's first take() then finds the pose solved (as when Blender's thread is held up)."""

    def __init__(self, *args, **kwargs):
        self._worker = native_loader.native().SolveWorker(*args, **kwargs)

    def post(self, targets, restart=False, start=None):
        self._worker.post(targets, restart=restart, start=start)
        assert self._worker.wait(60000), "the worker solved nothing in 60 s"

    def __getattr__(self, name):
        return getattr(self._worker, name)


class AutoStatus(unittest.TestCase):
    def setUp(self):
        U.clear_scene()
        auto.forget()
        self.obj, self.empty, _fixed, _top = U.bar_with_handle()

    def tearDown(self):
        if self.obj.arap.auto:
            api.set_auto(self.obj, False)

    def test_a_pose_settled_at_the_first_take_is_shown_settled(self):
        api.set_auto(self.obj, True)
        poser = auto._posers[self.obj.as_pointer()]
        self.empty.location.x += 0.4
        auto._busy = True   # keep the handler (which solves fully in --background) out of this update
        try:
            depsgraph = bpy.context.evaluated_depsgraph_get()
        finally:
            auto._busy = False
        native = auto.native
        auto.native = lambda: types.SimpleNamespace(SolveWorker=WaitingWorker)
        try:
            for _ in range(100):
                if poser.update(self.obj, depsgraph, on_worker=True):
                    break
        finally:
            auto.native = native
        self.assertTrue(poser.settled)
        self.assertIn("ARAP Auto on 'Bar': settled", " ".join(auto.auto_status_lines()))


if __name__ == "__main__":
    unittest.main()
