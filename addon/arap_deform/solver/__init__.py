# SPDX-License-Identifier: GPL-3.0-or-later
"""What talks to the native module: the problem read from Blender (problem.py, constraints.py,
handles.py, meshio.py), the jobs that solve it (deform_job.py, live.py, bake.py), binds on a thread of their own (background_bind.py) and
the running sessions."""
