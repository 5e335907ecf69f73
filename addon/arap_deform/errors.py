# SPDX-License-Identifier: GPL-3.0-or-later
"""The add-on's errors a user can act on, and the message shown for each."""

from . import native_loader


class SetupError(Exception):
    """A set-up the user must change (the message says what)."""


class SessionError(Exception):
    """A Live session cannot go on. kind: 'OBJECT', 'TOPOLOGY', 'MODE', 'EMPTY' or 'LOOP'."""

    def __init__(self, message, kind):
        super().__init__(message)
        self.kind = kind


def user_error(exc):
    """The message to show for errors a user can act on, else None (a bug: re-raise)."""
    if isinstance(exc, (SetupError, SessionError, native_loader.NativeModuleError)):
        return str(exc)
    native = native_loader.loaded()
    if native is not None and isinstance(exc, native.ArapError):
        return "ARAP solver: %s" % exc
    return None


def report_error(op, exc):
    """Report `exc` on operator `op` when a user can act on it (user_error(), or a file that could not be
    written: the bake's .pc2) and return {'CANCELLED'}; re-raise bugs."""
    msg = user_error(exc) or (exc.strerror if isinstance(exc, OSError) else None)
    if msg is None:
        raise exc
    op.report({'ERROR'}, msg)
    return {'CANCELLED'}
