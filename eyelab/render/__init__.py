"""Everything that touches VTK / PyVista lives here (and only here).

Without a display (no DISPLAY / WAYLAND_DISPLAY), VTK is pointed at its offscreen OSMesa
window before it is first imported, unless the caller chose a window class already
(e.g. ``VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow`` on a GPU machine).
"""

import os

if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkOSOpenGLRenderWindow")
