# SPDX-License-Identifier: GPL-3.0-or-later
"""A solver bound on a thread of its own, so that Blender's thread does not wait.

Binding a large mesh (ordering and factoring its Laplacian) takes seconds at a
million vertices. The native bind releases the GIL, so a Python thread can run
it while Blender's thread goes on drawing and handling input. What the bind
reads from Blender (the rest shape, triangles, constraints, settings) is read
before, on Blender's thread (problem.Problem, problem.solver_options): the
thread touches no bpy data.
"""

import os
import threading

from .problem import solver_options


class BackgroundBind:
    """Binds `problem` with the options of `settings` (obj.arap; `overrides`: solver_options()'s keywords)
    on a new thread. solver() returns the bound solver once the bind has finished, else None; an error of the
    bind is raised there, on the caller's thread. `nice`: on Linux, how much lower than Blender's the thread's
    priority is (work that may wait for Blender's)."""

    def __init__(self, problem, settings, nice=0, **overrides):
        options = solver_options(settings, **overrides)
        self._solver = None
        self._error = None

        def bind():
            if nice and hasattr(os, "setpriority"):
                try:
                    os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), nice)   # this thread only
                except OSError:
                    pass
            try:
                solver = problem.bind()
                solver.configure(**options)
                self._solver = solver
            except BaseException as exc:   # noqa: BLE001 - handed to the caller's thread
                self._error = exc

        # Not a daemon: quitting Blender waits for a bind in progress rather than unloading the module under it.
        self._thread = threading.Thread(target=bind, name="arap-bind")
        self._thread.start()

    def done(self):
        return not self._thread.is_alive()

    def wait(self):
        self._thread.join()

    def solver(self, wait=False):
        """The bound solver (None while the bind runs, unless `wait`); raises the bind's error."""
        if wait:
            self._thread.join()
        elif self._thread.is_alive():
            return None
        if self._error is not None:
            raise self._error
        return self._solver
