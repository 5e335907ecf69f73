# SPDX-License-Identifier: GPL-3.0-or-later
"""The final poses of frames played in the viewport, solved on a second solver of their own.

While an animation plays, Auto mode's worker shows a preview of each frame (it follows the handles from the
pose on screen and never settles, as the frame changes before it could). Each frame played goes into this
queue too: a second solver, bound on a thread of its own the first time a frame is queued, solves the frames
one after another from the cold start, as a render would, on a native worker at a lower priority than
Blender's thread. Auto mode caches what comes out, so the next loop of the animation shows final poses
at cache speed. Blender evaluates the handles only at the frame shown, so the frames ahead of the play head
are queued the first time they are played.

Everything here runs on Blender's thread but the bind and the solves; poll() hands over what has finished.
"""

import collections

import numpy as np

from ..native_loader import native
from ..solver.background_bind import BackgroundBind

MAX_QUEUED = 2000   # frames waiting at most (the oldest dropped first)


class FinalPoses:
    """A queue of pose keys to solve from the cold start on a solver bound like Auto mode's own
    (`problem`, the options of `settings`, warm=True, so that a solve after forget_solution() is the one
    Auto mode caches)."""

    def __init__(self, problem, settings, max_iterations):
        self._binding = BackgroundBind(problem, settings, warm=True, nice=10)
        self._problem = problem   # the start shape of each frame (a rig's skinned pose)
        self._max_iterations = max_iterations
        self._worker = None
        self._queue = collections.OrderedDict()   # pose key -> (targets, handle transforms)
        self._job = None                           # (key, targets, transforms) being solved
        self._out = np.empty(len(problem.rest32), np.float32)
        self.failed = None                         # why no final pose can be solved here (the bind's error)

    def want(self, key, targets, transforms):
        """Queue the final pose of `key` (nothing when it is queued or being solved already); `targets` and
        `transforms` are copied."""
        if self.failed is not None or key in self._queue or (self._job is not None and self._job[0] == key):
            return
        self._queue[key] = (targets.copy(), [t.copy() for t in transforms])   # the Problem reuses its buffer
        while len(self._queue) > MAX_QUEUED:
            self._queue.popitem(last=False)

    def drop(self, key):
        """`key` needs no final pose any more (it was cached another way)."""
        self._queue.pop(key, None)

    def busy(self):
        """Work left: a bind, a solve or a queued frame."""
        return self.failed is None and (self._job is not None or bool(self._queue) or
                                        (self._binding is not None and not self._binding.done()))

    def poll(self):
        """The final poses finished since the last call, [(key, float32 positions, transforms, stats)];
        starts the next queued solve. Never raises: a failed bind ends the queue (self.failed)."""
        if self.failed is not None or not self._bound():
            return []
        finished = []
        if self._job is not None:
            result = self._worker.take(self._out)
            if result is not None and result.settled and self._worker.settled:
                key, _targets, transforms = self._job
                finished.append((key, self._out.copy(), transforms, result.stats))
                self._job = None
        if self._job is None and self._queue:
            key, (targets, transforms) = self._queue.popitem(last=False)
            self._job = (key, targets, transforms)
            self._worker.post(targets, restart=True, start=self._problem.start_shape(transforms))
        return finished

    def _bound(self):
        if self._worker is not None:
            return True
        try:
            solver = self._binding.solver()
        except Exception as exc:  # noqa: BLE001 - a second solver that cannot bind only costs the final poses
            self.failed = "%s: %s" % (type(exc).__name__, exc)
            self._queue.clear()
            return False
        if solver is None:
            return False
        self._binding = None
        solver.time_budget_ms = 0.0   # each frame in one solve, to the end
        solver.max_iterations = self._max_iterations
        self._worker = native().SolveWorker(solver, max_iterations=self._max_iterations)
        return True

    def stop(self):
        """End the solve in progress after its iteration; a bind in progress is left to finish unused."""
        if self._worker is not None:
            self._worker.stop()
            self._worker = None
        self._queue.clear()
        self._job = None
        self.failed = "stopped"
