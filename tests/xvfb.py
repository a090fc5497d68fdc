"""A private X server for the tests that need a real window (Xvfb)."""

import os
import shutil
import subprocess
import time

#: The Xvfb binary, or None (CI installs it and sets EYELAB_REQUIRE_XVFB).
XVFB = shutil.which("Xvfb")


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
