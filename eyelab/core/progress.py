"""Progress bars for long work: one switch for the whole process.

Bars go to stderr through tqdm, and only appear once the work has taken ``DELAY_S``
seconds, so short jobs stay silent. They are on when stderr is a terminal, off when it is
not (logs, pipes, CI) or after :func:`set_enabled(False) <set_enabled>` (``eyelab
--quiet``); ``force=True`` shows a bar whatever the switch says (the reference renderer's
``progress`` option).
"""

from __future__ import annotations

import contextlib
import sys

#: Seconds of work before a bar appears.
DELAY_S = 2.0
_enabled: bool | None = None        # None: on when stderr is a terminal


def set_enabled(flag: bool | None) -> None:
    """True/False: bars on/off for this process; None: on when stderr is a terminal."""
    global _enabled
    _enabled = flag


@contextlib.contextmanager
def quiet_if(flag: bool):
    """Bars off within the block when ``flag`` (``eyelab --quiet``), the switch as it was
    after it: a command run in-process (``eyelab.apps.cli.main``) leaves none behind."""
    global _enabled
    was = _enabled
    if flag:
        _enabled = False
    try:
        yield
    finally:
        _enabled = was


def enabled() -> bool:
    if _enabled is not None:
        return _enabled
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):
        return False


class _Silent:
    """The bar's interface, doing nothing."""

    def update(self, n=1):
        pass

    def set_postfix_str(self, s):
        pass

    def close(self):
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def bar(total, desc: str, unit: str = "it", *, force: bool = False):
    """A tqdm bar of ``total`` steps described by ``desc`` (a context manager with
    ``update(n)``), or a silent stand-in when bars are off."""
    if not (force or enabled()):
        return _Silent()
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit=unit, file=sys.stderr, delay=0.0 if force
                else DELAY_S, mininterval=0.5, leave=False, dynamic_ncols=True)
