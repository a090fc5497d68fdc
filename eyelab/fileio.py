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
