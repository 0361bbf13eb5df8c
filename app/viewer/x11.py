"""The viewer's window closed from outside, as a clean end instead of Xlib's exit(1).

A window manager closes a window politely (WM_DELETE_WINDOW: glfw sets "should close"
and the viewer's loop ends), but not always: another client may destroy the window
(``xdotool windowclose``), and a window manager whose polite request was not answered
kills the client's connection (``XKillClient``, ``xkill``). Xlib's default handlers then
print an "X Error of failed request: BadWindow" dump or "X connection broken" and call
``exit(1)``. ``watch`` installs handlers that turn both into the window being closed:

- an X protocol error about the viewer's own window (it no longer exists) marks it gone,
  and the loop ends at its next step; other X errors are ignored (Xlib's default would
  end the process for any of them);
- a lost connection can no longer draw or answer anything, so the process ends at once,
  with exit code 0 and nothing on stderr, as a closed window should.

Handlers are process-wide (Xlib has no per-display ones); glfw saves and restores
whichever is installed around its own calls, so these stay in force.
"""

from __future__ import annotations

import ctypes
import os
import sys
from dataclasses import dataclass, field


class _XErrorEvent(ctypes.Structure):
    _fields_ = [
        ("type", ctypes.c_int),
        ("display", ctypes.c_void_p),
        ("resourceid", ctypes.c_ulong),
        ("serial", ctypes.c_ulong),
        ("error_code", ctypes.c_ubyte),
        ("request_code", ctypes.c_ubyte),
        ("minor_code", ctypes.c_ubyte),
    ]


_ERROR_HANDLER = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.POINTER(_XErrorEvent))
_IO_ERROR_HANDLER = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p)
BAD_WINDOW, BAD_DRAWABLE = 3, 9


@dataclass
class WindowWatch:
    """Whether X said the viewer's window is gone; the installed handlers (kept alive)."""

    window: int
    gone: bool = False
    errors: int = 0
    _handlers: list = field(default_factory=list)


def _lost_connection(display: int) -> int:
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)  # the window is gone with the connection: the viewer has ended


def watch(window: int) -> WindowWatch | None:
    """Install the handlers for the X11 window ``window`` (glfw's X window id); None
    where there is no libX11 (another platform)."""
    try:
        x11 = ctypes.CDLL("libX11.so.6")
    except OSError:
        return None
    state = WindowWatch(window)

    def on_error(display: int, event: ctypes.POINTER(_XErrorEvent)) -> int:  # type: ignore[valid-type]
        e = event.contents
        state.errors += 1
        if e.error_code in (BAD_WINDOW, BAD_DRAWABLE) and e.resourceid == state.window:
            state.gone = True
        return 0

    handler, io_handler = _ERROR_HANDLER(on_error), _IO_ERROR_HANDLER(_lost_connection)
    x11.XSetErrorHandler.argtypes = [_ERROR_HANDLER]
    x11.XSetErrorHandler.restype = ctypes.c_void_p
    x11.XSetIOErrorHandler.argtypes = [_IO_ERROR_HANDLER]
    x11.XSetIOErrorHandler.restype = ctypes.c_void_p
    x11.XSetErrorHandler(handler)
    x11.XSetIOErrorHandler(io_handler)
    state._handlers += [handler, io_handler]
    return state
