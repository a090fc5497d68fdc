"""A private X server for the tests that need a real window (Xvfb)."""

import contextlib
import os
import shutil
import subprocess
import time

import pytest

#: The Xvfb binary, or None (CI installs it and sets EYELAB_REQUIRE_XVFB).
XVFB = shutil.which("Xvfb")

#: A test that needs a real X server: skipped without Xvfb unless EYELAB_REQUIRE_XVFB.
needs_xvfb = pytest.mark.skipif(XVFB is None and not os.environ.get("EYELAB_REQUIRE_XVFB"),
                                reason="Xvfb is not installed (CI installs it and sets "
                                       "EYELAB_REQUIRE_XVFB)")


def start_xvfb():
    """An Xvfb server on a free display, waited for: it writes its display number to a
    pipe (-displayfd) once it accepts connections. Returns (process, ":N")."""
    r, w = os.pipe()
    proc = subprocess.Popen([XVFB, "-displayfd", str(w), "-screen", "0", "1280x1024x24",
                             "-nolisten", "tcp", "-ac"], pass_fds=(w,),
                            stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    os.close(w)
    try:
        num = b""
        deadline = time.monotonic() + 30
        while not num.endswith(b"\n") and time.monotonic() < deadline:
            chunk = os.read(r, 16)
            if not chunk:
                break
            num += chunk
    finally:
        os.close(r)
    assert num.strip().isdigit(), f"Xvfb did not start ({num!r})"
    return proc, f":{num.strip().decode()}"


@contextlib.contextmanager
def xvfb_env():
    """A private Xvfb for the block: yields this process's environment pointed at it
    (DISPLAY its display, no Wayland, VTK's window class left to VTK) for the subprocesses
    that open windows; the server is stopped after the block."""
    assert XVFB is not None, "EYELAB_REQUIRE_XVFB is set but Xvfb is missing"
    proc, display = start_xvfb()
    env = {k: v for k, v in os.environ.items()
           if k not in ("VTK_DEFAULT_OPENGL_WINDOW", "WAYLAND_DISPLAY")}
    env["DISPLAY"] = display
    try:
        yield env
    finally:
        proc.terminate()
        proc.wait(timeout=30)
