"""``eyelab cache [--clear]``: the on-disk cache of expensive deterministic results
(:mod:`eyelab.core.diskcache`: optimised progressive designs) — its folder, whether it is
on, its entries and bound; ``--clear`` removes the entries. A bad ``$EYELAB_CACHE_DIR`` or
``$EYELAB_CACHE_MAX_MB`` is refused first (one line naming it, exit status 2, nothing
removed)."""

from __future__ import annotations


def add_parser(sub) -> None:
    c = sub.add_parser("cache", help="the on-disk cache of expensive results (optimised "
                       "progressive designs): folder, entries, size; --clear empties it")
    c.add_argument("--clear", action="store_true", help="remove every entry")
    c.add_argument("--json", action="store_true", help="print JSON instead of text")


def run(args) -> int:
    from eyelab.core import diskcache
    from eyelab.core.fileio import json_text

    diskcache.check_environment(always=True)     # SpecError before anything is removed
    removed = diskcache.clear() if args.clear else None
    info = diskcache.info()
    if removed is not None:
        info["removed_bytes"] = removed
    if args.json:
        print(json_text(info), end="")
        return 0
    state = "on" if info["enabled"] else f"off ({diskcache.OFF_ENV} or --no-cache)"
    lines = [f"cache folder: {info['folder']} ({state}; ${diskcache.DIR_ENV} to move it)",
             f"entries: {info['entries']}, {info['bytes'] / 1e6:.2f} MB of at most "
             f"{info['max_bytes'] / 1e6:g} MB (${diskcache.MAX_ENV})"]
    if removed is not None:
        lines.append(f"removed {removed / 1e6:.2f} MB")
    print("\n".join(lines))
    return 0
