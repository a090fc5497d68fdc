"""Output files written whole or not at all, and JSON for numpy values.

Every file eyelab writes (images, reports, blur fields, cached references) goes through
:func:`atomic_path`: a bad input or a crash never leaves a partial file behind.
"""

from __future__ import annotations

import os
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from eyelab.errors import SpecError


@contextmanager
def atomic_path(path, suffix: str = ".tmp"):
    """Yield a temporary file name beside ``path`` (ending in ``suffix``, so writers that
    pick a format by extension still can); when the block ends without an exception the
    file replaces ``path`` with the usual permissions (umask), otherwise it is removed.
    Parent folders are created."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=p.parent, prefix=f".{p.name}.", suffix=suffix)
    os.close(fd)
    try:
        yield tmp
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, p)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def json_default(o):
    """``json.dumps(default=...)`` for numpy scalars and arrays; anything else as text."""
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    return str(o)


def check_output(flag: str, path) -> Path:
    """Fail early, before any work: ``path`` must not be a folder, its parent must be a
    folder (or creatable) that this process may write in. Returns the path."""
    p = Path(path)
    if p.is_dir():
        raise SpecError(flag, f"{str(p)!r} is a folder, not a file")
    parent = p.parent
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        raise SpecError(flag, f"cannot create {str(p)!r}: {str(parent)!r} is not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise SpecError(flag, f"cannot write in {str(parent)!r}")
    return p


def check_distinct(**paths) -> None:
    """Refuse two outputs at the same path (``flag=path`` pairs; None ignored)."""
    seen = {}
    for flag, path in paths.items():
        if path is None:
            continue
        key = os.path.realpath(path)
        if key in seen:
            raise SpecError(flag, f"is the same file as {seen[key]} ({str(path)!r})")
        seen[key] = flag
