# SPDX-License-Identifier: GPL-3.0-or-later
"""Temporary files renamed into place once complete (the bake's .pc2 point
cache, the batch worker's .blend), so that readers never see half a file:
how they are named, and how the ones a dead process left are found.

Plain Python (no bpy): the arap-batch launcher loads this file too, from the
add-on folder its workers run (arap_batch/cli.py), so both use one rule.
"""

import os
import re


def temp_path(final, pid=None):
    """A hidden file next to `final`, named after it and the writing process,
    with its extension kept (Blender saves .blend files only under .blend):
    shot.blend -> .shot.arap-tmp-<pid>.blend."""
    folder, name = os.path.split(final)
    stem, ext = os.path.splitext(name)
    return os.path.join(folder, ".%s.arap-tmp-%d%s" % (stem, os.getpid() if pid is None else pid, ext))


def left_by(folder, pid):
    """The temporary files of process `pid` in `folder` (Blender's '@' files of them included)."""
    pattern = re.compile(r"^\..*\.arap-tmp-%d(\.[^.]*)?@?$" % pid)
    try:
        return [os.path.join(folder, n) for n in os.listdir(folder) if pattern.match(n)]
    except OSError:
        return []
