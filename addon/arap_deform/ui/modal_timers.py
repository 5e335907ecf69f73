# SPDX-License-Identifier: GPL-3.0-or-later
"""The event timers of the running modal operators (Deform, the bake, Live), kept here so that disabling the
add-on removes them: Blender keeps a window's timers after the operator that added them is unregistered."""

_timers = {}   # owner (an operator's name, a Live session) -> (window manager, timer)


def add(owner, context, interval):
    """A timer firing every `interval` seconds in the context's window, owned by `owner`."""
    wm = context.window_manager
    timer = wm.event_timer_add(interval, window=context.window)
    _timers[owner] = (wm, timer)
    return timer


def remove(owner):
    """Remove `owner`'s timer (nothing when it has none)."""
    entry = _timers.pop(owner, None)
    if entry is not None:
        entry[0].event_timer_remove(entry[1])


def remove_all():
    for owner in list(_timers):
        remove(owner)
