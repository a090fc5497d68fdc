"""What the command-line front ends share: common flags."""

from __future__ import annotations


def add_quiet(parser) -> None:
    """``--quiet``: no progress bars (they show on a terminal for work longer than 2 s)."""
    parser.add_argument("--quiet", action="store_true", help="no progress bars (shown on "
                        "stderr when it is a terminal, for work longer than 2 s)")


def add_no_cache(parser) -> None:
    """``--no-cache``: results are computed, not read from or written to the on-disk cache
    (:mod:`eyelab.core.diskcache`) — as ``EYELAB_NO_CACHE=1``, which the command sets for
    itself and the processes it starts (a batch's local Dask workers)."""
    parser.add_argument("--no-cache", action="store_true",
                        help="neither read nor write the on-disk cache of expensive results "
                        "(optimised progressive designs); as EYELAB_NO_CACHE=1")


def apply_max_memory(args) -> None:
    """``--max-memory``, when given, becomes this process's limit (every render checks it)."""
    from eyelab.imaging.memory import set_memory_limit

    set_memory_limit(getattr(args, "max_memory", None))


def add_max_memory(parser) -> None:
    """``--max-memory GIB``: the memory limit renders are checked against up front."""
    parser.add_argument("--max-memory", type=float, metavar="GIB",
                        help="refuse renders whose estimated memory exceeds this many GiB "
                        "(default: $EYELAB_MAX_MEMORY_GB, else half the machine's memory)")


def warn(warnings) -> None:
    """Each distinct warning on one line of stderr, ``eyelab: warning: ...``."""
    import sys

    for warning in dict.fromkeys(warnings):
        print(f"eyelab: warning: {warning}", file=sys.stderr)
