# SPDX-License-Identifier: GPL-3.0-or-later
"""The registry of running Live sessions (live.LiveSession adds and removes
itself), and which mesh the panel and the operators act on."""

from ..errors import SessionError

_sessions = set()


def add(session):
    _sessions.add(session)


def discard(session):
    _sessions.discard(session)


def session_for(obj):
    """The running Live session posing `obj`, or None."""
    for session in _sessions:
        try:
            if session.obj == obj:
                return session
        except ReferenceError:
            continue
    return None


def session_on_shared_mesh(obj):
    """The running Live session of another object that poses `obj`'s mesh (a linked duplicate), or None."""
    mesh = obj.data
    if mesh.users < 2:
        return None
    for session in _sessions:
        try:
            if session.obj != obj and session.obj.data == mesh:
                return session
        except ReferenceError:
            continue
    return None


def running():
    """The running Live sessions."""
    return list(_sessions)


def any_session():
    """Some running Live session (the panel shows it while an empty is active), or None."""
    for session in _sessions:
        return session
    return None


def target_mesh(context):
    """The mesh the panel and the operators act on: the active mesh object,
    or, when a handle's Empty (or a bone handle's armature, in Pose Mode say) is
    active, the mesh it poses (the one Live is posing first), so that selecting
    an Empty does not hide the panel."""
    obj = context.active_object
    if obj is None:
        return None
    if obj.type == 'MESH':
        return obj
    if obj.type not in ('EMPTY', 'ARMATURE'):
        return None
    session = any_session()
    if session is not None and session.active:
        try:
            if any(_moved_by(h, obj) for h in session.obj.arap.handles):
                return session.obj
        except ReferenceError:
            pass
    for ob in context.view_layer.objects:
        if ob.type == 'MESH' and any(_moved_by(h, obj) for h in ob.arap.handles):
            return ob
    return None


def _moved_by(handle, obj):
    """`obj` is the handle's Empty, or the armature of its bone."""
    return (handle.armature if handle.bone else handle.empty) == obj


def stop_session(session):
    """Forget a session without restoring (its object or topology is gone)."""
    session.stop_worker()
    session.active = False
    _sessions.discard(session)


def stop_all_sessions():
    """Cancel every running Live session (add-on disabled, file loaded)."""
    for session in list(_sessions):
        try:
            session.cancel()
        except (ReferenceError, ValueError, SessionError):
            session.stop_worker()
            session.active = False
            _sessions.discard(session)
