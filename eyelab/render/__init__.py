"""Everything that touches VTK / PyVista lives here (and only here).

The offscreen policy, in one place: without a display (no DISPLAY / WAYLAND_DISPLAY) VTK
is pointed at its offscreen OSMesa window before it is first imported; jobs that never
open a window (batch, benchmarks, screenshots) ask for it with :func:`use_offscreen`. A
window class the caller chose is kept (e.g. ``VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow``
on a GPU machine). This module imports no VTK itself.
"""

import os
import sys

#: The environment variable VTK reads for its default window class, and the offscreen one.
WINDOW_ENV = "VTK_DEFAULT_OPENGL_WINDOW"
OFFSCREEN_WINDOW = "vtkOSOpenGLRenderWindow"


def use_offscreen(env=None) -> dict:
    """Make VTK's windows offscreen (OSMesa) unless a window class was chosen; must run
    before VTK is first imported. ``env``: the environment to set (a dict for a child
    process), default this process's. Returns it."""
    env = os.environ if env is None else env
    env.setdefault(WINDOW_ENV, OFFSCREEN_WINDOW)
    return env


def has_display() -> bool:
    """Whether a window can be shown: a display on Linux/BSD; always on macOS/Windows."""
    if sys.platform in ("darwin", "win32"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


#: What to do instead when no window can be opened (the inspector's line says it).
NO_WINDOW_WAYS = "use --screenshot FILE or --offscreen, or run under xvfb-run"


def display_error() -> str | None:
    """Why no window can be shown here, or None when one can: no DISPLAY / WAYLAND_DISPLAY
    set, or an X server that does not answer (``XOpenDisplay`` through libX11, which VTK's
    X window uses too; without libX11 the variable is trusted), or a Wayland socket that
    is not there."""
    if sys.platform in ("darwin", "win32"):
        return None
    x, wayland = os.environ.get("DISPLAY"), os.environ.get("WAYLAND_DISPLAY")
    if not (x or wayland):
        return "no display to open a window on (DISPLAY is not set)"
    if x:
        return None if _x_answers(x) else f"cannot open display {x}"
    runtime = os.environ.get("XDG_RUNTIME_DIR", "")
    sock = wayland if os.path.isabs(wayland) else os.path.join(runtime, wayland)
    return None if os.path.exists(sock) else f"cannot open Wayland display {wayland}"


#: The X connections :func:`_x_answers` opened, by display name, held for the process's life.
_HELD_X: dict[str, int] = {}


def _x_answers(name: str) -> bool:
    """Whether the X server ``name`` accepts a connection (libX11's XOpenDisplay).

    The connection is kept open, not closed: an X server with no other client (a bare
    Xvfb) resets when its last client leaves, and a window opened during that reset
    fails ("bad X server connection"), after which VTK's event loop returns at once."""
    if name in _HELD_X:
        return True
    import ctypes
    import ctypes.util

    path = ctypes.util.find_library("X11") or "libX11.so.6"
    try:
        x11 = ctypes.CDLL(path)
    except OSError:
        return True                        # no libX11 to ask: trust the variable
    x11.XOpenDisplay.restype = ctypes.c_void_p
    x11.XOpenDisplay.argtypes = [ctypes.c_char_p]
    handle = x11.XOpenDisplay(name.encode())
    if not handle:
        return False
    _HELD_X[name] = handle
    return True


def window_error(ren_win) -> str | None:
    """Why the initialised VTK render window ``ren_win`` is not a window on the X display,
    or None. A display can answer the probe and still refuse VTK's own connection; VTK
    then falls back to an offscreen window, its event loop returns at once, and the
    command would end with status 0 having shown nothing."""
    if sys.platform in ("darwin", "win32"):
        return None
    if ren_win.IsA("vtkXOpenGLRenderWindow") and ren_win.GetGenericDisplayId():
        return None
    x = os.environ.get("DISPLAY")
    where = f"on display {x}" if x else "without an X display (DISPLAY is not set)"
    return f"cannot open a window {where} (VTK made a {ren_win.GetClassName()})"


if not has_display():
    use_offscreen()
