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


if not has_display():
    use_offscreen()
