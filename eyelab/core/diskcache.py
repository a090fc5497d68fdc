"""Expensive deterministic results kept on disk, computed once per machine.

Some results take seconds and depend only on their inputs and on eyelab's code (an
as-worn optimised progressive design: :func:`eyelab.optics.lens.optimise.optimised_progressive`;
a lens's as-worn maps and figures of merit: :mod:`eyelab.optics.lens.mapcache`).
The in-process LRU caches (:mod:`eyelab.core.cache`) forget them when the process ends;
this cache keeps them between processes, Dask workers included.

* **Folder**: ``$EYELAB_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/eyelab``, else
  ``~/.cache/eyelab`` (the XDG Base Directory Specification's rule, version 0.8:
  https://specifications.freedesktop.org/basedir-spec/0.8/).
* **Off**: ``EYELAB_NO_CACHE=1`` (``eyelab … --no-cache`` sets it for the command and
  the processes it starts) or :func:`set_enabled(False) <set_enabled>`.
* **Keys**: :func:`eyelab.core.cache.content_key` of the namespace, eyelab's
  ``__version__``, a digest of the source files of the code that computes the result
  (``code``: an edited optimiser in an editable install misses rather than reads a stale
  result) and the caller's inputs.
* **Entries** are one file each, ``<namespace>.<key>.entry``
  (:mod:`eyelab.core.cacheentry`): a magic line, the length of a JSON header, the header
  — namespace, key, version, payload length and blake2b digest — and the payload, an
  ``.npz`` archive of numpy arrays plus the caller's JSON dict (``__meta__``). No pickle
  anywhere: the archive is read with ``allow_pickle=False``, so a cache folder is never a
  code-execution path.
* **Verified on read**: only a regular file is opened (a symbolic link, FIFO, device,
  socket or folder named as an entry never is: no read hangs or runs without end), of a
  size its header accounts for exactly (at most
  :data:`~eyelab.core.cacheentry.ENTRY_MAX_BYTES`); the digest over the whole payload is
  checked before any of it is parsed. Anything else — truncated, corrupt, another
  entry's, not a regular file — is a miss: the entry is removed (a link itself, never
  what it points to) and the result computed and written again; the
  :class:`Status` then says it was written (``replaced``: what was wrong with the old
  one).
* **Atomic, concurrent writes**: a temporary in the same folder, then ``os.replace``;
  several processes filling one entry at once each publish a whole file, the last rename
  wins, and readers never see a partial file. (:func:`eyelab.core.fileio.atomic_path`
  does not fit: it sweeps the temporaries of the same final name, which here may belong
  to a concurrent writer.)
* **Bounded**: after each write, entries are removed oldest-used first (a hit touches
  the file's modification time, which mounts with ``noatime`` keep too) until the folder
  holds at most ``max_bytes`` (:data:`DEFAULT_MAX_BYTES`, or ``$EYELAB_CACHE_MAX_MB``).
* **Checked settings**: ``$EYELAB_CACHE_MAX_MB`` must be a finite number of MB in
  :data:`MAX_MB_RANGE`, ``$EYELAB_CACHE_DIR`` a path of at most :data:`DIR_MAX_CHARS`
  characters whose ``~user`` is a known user; anything else is a
  :class:`~eyelab.core.errors.SpecError` naming the variable (:func:`check_environment`,
  which the commands call up front: one line, exit status 2, nothing written).
* **Never in the way**: a folder that cannot be made, read or written means the result is
  computed as without the cache; nothing is printed or warned, the returned
  :class:`Status` says why.
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
import stat
import tempfile
import threading
import time
from pathlib import Path

from eyelab.core import cacheentry
from eyelab.core.cache import content_key
from eyelab.core.cacheentry import BadEntry, TooLarge, pack, read_entry
from eyelab.core.errors import SpecError
from eyelab.core.fileio import TMP_PREFIX

#: The cache folder's environment variable (overrides the XDG rule).
DIR_ENV = "EYELAB_CACHE_DIR"
#: ``$EYELAB_CACHE_DIR``'s longest value (characters): Linux's PATH_MAX.
DIR_MAX_CHARS = 4096
#: ``EYELAB_NO_CACHE=1`` (any value but "", "0", "false", "no", "off") turns the cache off.
OFF_ENV = "EYELAB_NO_CACHE"
#: The size bound's environment variable, in MB (10^6 bytes).
MAX_ENV = "EYELAB_CACHE_MAX_MB"
#: ``$EYELAB_CACHE_MAX_MB``'s range (MB, both ends included): 0 keeps nothing; 10^6 MB
#: is a terabyte.
MAX_MB_RANGE = (0, 10**6)
#: The folder's size bound (bytes): 256 MB — tens of thousands of optimised designs (~5 kB
#: each), or some 1800 ``eyelab maps`` runs' maps (31 x 31: ~130 kB) and figures (~8 kB).
DEFAULT_MAX_BYTES = 256 * 10**6
#: First bytes of every entry (:data:`eyelab.core.cacheentry.MAGIC`).
MAGIC = cacheentry.MAGIC
#: Temporaries older than this (s) belong to a killed writer and are swept on eviction.
STALE_TMP_S = 3600.0
#: Suffix of entry files.
SUFFIX = ".entry"

_enabled: bool | None = None
_code_digests: dict = {}
_code_lock = threading.Lock()


@dataclasses.dataclass(frozen=True)
class Status:
    """Where a result came from: ``source`` "disk" (read from ``path``) or "computed";
    ``path`` the entry's file, read or written (None when the cache is off or nothing was
    written); ``note`` why the cache was not used (None when the result was read, or
    computed and written); ``replaced`` what was wrong with the entry found in its place
    (a bad one, removed), which the computed result was written over (None when there
    was none)."""

    source: str
    path: str | None = None
    note: str | None = None
    replaced: str | None = None

    def to_json(self) -> dict:
        return dataclasses.asdict(self)


def set_enabled(flag: bool | None) -> None:
    """False: the cache is off for this process (nothing read or written); True or None:
    on unless ``EYELAB_NO_CACHE`` says otherwise (the environment always can turn it
    off)."""
    global _enabled
    _enabled = flag


def enabled() -> bool:
    """Whether the cache is on: not :func:`set_enabled(False) <set_enabled>` and no
    ``EYELAB_NO_CACHE`` set to a true value."""
    off = os.environ.get(OFF_ENV, "").strip().lower() not in ("", "0", "false", "no", "off")
    return _enabled is not False and not off


def _shown(text: str) -> str:
    """``text`` as a message quotes it: its repr, abridged past 40 characters."""
    r = repr(text)
    return r if len(r) <= 40 else f"{r[:20]}... ({len(text)} characters)"


def cache_dir() -> Path:
    """The cache folder (module text): ``$EYELAB_CACHE_DIR`` (``~`` / ``~user``
    expanded), else ``$XDG_CACHE_HOME/eyelab`` (an absolute ``XDG_CACHE_HOME`` only, as
    the specification asks), else ``~/.cache/eyelab``. Not created here.
    :class:`~eyelab.core.errors.SpecError` naming ``EYELAB_CACHE_DIR`` when it is longer
    than :data:`DIR_MAX_CHARS` or names an unknown user's home; OSError when there is no
    home to put the folder in."""
    own = os.environ.get(DIR_ENV, "")
    if own:
        try:
            if len(own) <= DIR_MAX_CHARS:
                return Path(own).expanduser()
            why = "too long"
        except RuntimeError:           # "Could not determine home directory"
            why = "no such user's home" if own[:2] != "~/" and own != "~" else "no home"
        raise SpecError(DIR_ENV, f"must be a folder path of at most {DIR_MAX_CHARS} "
                                 f"characters ('~' or '~user' of a known user), got "
                                 f"{_shown(own)} ({why})")
    xdg = os.environ.get("XDG_CACHE_HOME", "")
    if xdg and os.path.isabs(xdg):
        return Path(xdg) / "eyelab"
    try:
        return Path.home() / ".cache" / "eyelab"
    except RuntimeError as e:          # "Could not determine home directory"
        raise OSError(f"no cache folder: {e}; set {DIR_ENV}") from None


def _folder(folder) -> Path:
    return Path(folder) if folder is not None else cache_dir()


def max_bytes() -> int:
    """The folder's size bound (bytes): ``$EYELAB_CACHE_MAX_MB`` x 10^6 (unset or empty:
    :data:`DEFAULT_MAX_BYTES`). :class:`~eyelab.core.errors.SpecError` naming the
    variable unless it is a finite number of MB in :data:`MAX_MB_RANGE`."""
    text = os.environ.get(MAX_ENV, "")
    if not text.strip():
        return DEFAULT_MAX_BYTES
    lo, hi = MAX_MB_RANGE
    try:
        mb = float(text)               # "inf", "nan", "1e400" (inf) parse; refused below
    except ValueError:
        mb = float("nan")
    if not lo <= mb <= hi:             # NaN and infinities fail too
        raise SpecError(MAX_ENV, f"must be a finite number of MB in [{lo}, {hi}], got "
                                 f"{_shown(text)}")
    return int(mb * 10**6)


def check_environment(*, always: bool = False) -> None:
    """Refuse settings the cache cannot take, up front (before a command computes or
    writes anything): :class:`~eyelab.core.errors.SpecError` naming
    ``EYELAB_CACHE_MAX_MB`` (:func:`max_bytes`) or ``EYELAB_CACHE_DIR``
    (:func:`cache_dir`). Nothing is checked when the cache is off, unless ``always``
    (``eyelab cache``, which shows them). A missing home is not an error: the cache is
    then skipped, quietly."""
    if not (always or enabled()):
        return
    max_bytes()
    try:
        cache_dir()
    except OSError:
        pass


def code_digest(*folders) -> str:
    """blake2b (hex, 16 bytes) of every ``*.py`` file's name and bytes under ``folders``
    (sorted), computed once per process and folder set: the code a cached result was
    computed by."""
    key = tuple(str(Path(f).resolve()) for f in folders)
    with _code_lock:
        if key in _code_digests:
            return _code_digests[key]
    h = hashlib.blake2b(digest_size=16)
    for folder in key:
        for p in sorted(Path(folder).rglob("*.py")):
            h.update(str(p.relative_to(folder)).encode() + b"\0")
            h.update(p.read_bytes())
    with _code_lock:
        _code_digests[key] = h.hexdigest()
    return _code_digests[key]


def entry_key(namespace: str, parts: dict, *, version: str | None = None,
              code=()) -> str:
    """The key of a result: its namespace, eyelab's version (``version``, default
    ``eyelab.__version__``), the digest of its ``code`` folders and its inputs
    ``parts`` (anything :func:`~eyelab.core.cache.content_key` takes)."""
    if version is None:
        from eyelab import __version__ as version
    return content_key(namespace=namespace, version=version,
                       code=code_digest(*code) if code else None, parts=parts)


def _entry_path(folder: Path, namespace: str, key: str) -> Path:
    return folder / f"{namespace}.{key}{SUFFIX}"


def _remove(path: Path) -> None:
    try:
        path.unlink()              # a link itself, never what it points to
    except OSError:                # gone already (another process), or not ours
        pass


def _discard(path: Path, why: str) -> str:
    """Remove the bad entry ``path`` (a link itself, never its target); the note saying
    so."""
    try:
        path.unlink()
    except FileNotFoundError:      # another process removed it first
        pass
    except OSError as e:           # a folder named as an entry, a read-only folder
        return f"bad entry left in place ({e.strerror or e}): {why}"
    return f"bad entry removed: {why}"


def load(namespace: str, key: str, *, folder=None, version: str | None = None) -> tuple:
    """(arrays, meta, status) of the entry ``key`` (written by eyelab ``version``, when
    given), or (None, None, status) on a miss:
    the cache off (``status.note`` "off"), no entry, an unusable folder, or an entry
    that fails verification (:func:`~eyelab.core.cacheentry.read_entry`: removed,
    ``status.note`` says why). Never opens anything but a regular file."""
    if not enabled():
        return None, None, Status("computed", note="off")
    try:
        path = _entry_path(_folder(folder), namespace, key)
    except OSError as e:
        return None, None, Status("computed", note=f"cannot read the cache: {e}")
    try:
        arrays, meta = read_entry(path, namespace, key, version)
    except FileNotFoundError:
        return None, None, Status("computed", str(path))
    except BadEntry as e:
        return None, None, Status("computed", str(path), _discard(path, str(e)))
    except OSError as e:
        return None, None, Status("computed", str(path),
                                  f"cannot read the cache: {e.strerror or e}")
    try:
        os.utime(path, follow_symlinks=os.utime not in os.supports_follow_symlinks)
    except OSError:                # used now: the last to be evicted
        pass
    return arrays, meta, Status("disk", str(path))


def store(namespace: str, key: str, arrays: dict, meta: dict, *, folder=None,
          version: str | None = None) -> Status:
    """Write the entry ``key`` (``arrays``: name -> numeric numpy array; ``meta``: a dict
    JSON can write) atomically, then trim the folder to its bound (:func:`max_bytes`).
    Returns the status of a computed result: its path, or why it was not written.
    :class:`~eyelab.core.errors.SpecError` for a bad ``$EYELAB_CACHE_MAX_MB`` or
    ``$EYELAB_CACHE_DIR``, before anything is written."""
    if not enabled():
        return Status("computed", note="off")
    limit = max_bytes()
    if version is None:
        from eyelab import __version__ as version
    try:
        data = pack(namespace, key, version, arrays, meta)
    except TooLarge as e:
        return Status("computed", None, str(e))
    tmp = None
    try:
        folder = _folder(folder)
        path = _entry_path(folder, namespace, key)
        folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=f"{TMP_PREFIX}{path.name}.")
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)       # atomic: readers see the old file or the whole new one
        tmp = None
    except OSError as e:
        return Status("computed", None, f"cannot write the cache: {e}")
    finally:
        if tmp is not None:
            _remove(Path(tmp))
    trim(folder, limit)
    return Status("computed", str(path))


def _scan(folder: Path) -> tuple:
    """(entries, temporaries) of ``folder``: (mtime, name, bytes, path, regular) each, of
    the names themselves (nothing is opened or followed; bytes 0 but for a regular
    file)."""
    entries, temps = [], []
    for e in os.scandir(folder):
        try:
            st = e.stat(follow_symlinks=False)
        except OSError:            # removed meanwhile
            continue
        regular = stat.S_ISREG(st.st_mode)
        row = (st.st_mtime, e.name, st.st_size if regular else 0, Path(e.path), regular)
        if e.name.startswith(TMP_PREFIX):
            temps.append(row)
        elif e.name.endswith(SUFFIX):
            entries.append(row)
    return entries, temps


def trim(folder=None, limit: int | None = None) -> int:
    """Remove entries oldest-used first until those left hold at most ``limit`` bytes
    (default :func:`max_bytes`; 0: every entry), names of entries that are not regular
    files (links, FIFOs: never read), and temporaries older than :data:`STALE_TMP_S`.
    Returns the bytes removed. Files another process removes meanwhile are skipped."""
    limit = max_bytes() if limit is None else limit
    removed, now = 0, time.time()
    try:
        entries, temps = _scan(_folder(folder))
    except OSError:
        return 0
    for mtime, _, _, path, _ in temps:
        if now - mtime > STALE_TMP_S:
            _remove(path)
    for *_, path, regular in entries:
        if not regular:
            _remove(path)
    entries = [e for e in entries if e[4]]
    total = sum(e[2] for e in entries)
    for _, _, size, path, _ in sorted(entries):
        if total <= limit:
            break
        _remove(path)
        total -= size
        removed += size
    return removed


def fetch(namespace: str, parts: dict, compute, *, code=(), folder=None,
          version: str | None = None) -> tuple:
    """The result for the inputs ``parts``: read from the cache, or ``compute()`` —
    returning (arrays, meta) as :func:`store` takes them — run and stored. Returns
    (arrays, meta, status). Arrays read back equal those computed bit for bit (npz keeps
    dtype and bytes); meta read back is what JSON gives back (tuples become lists).
    :class:`~eyelab.core.errors.SpecError` for a bad ``$EYELAB_CACHE_MAX_MB`` or
    ``$EYELAB_CACHE_DIR`` (:func:`check_environment`), before anything is computed."""
    check_environment()
    if version is None:
        from eyelab import __version__ as version
    key = entry_key(namespace, parts, version=version, code=code)
    arrays, meta, status = load(namespace, key, folder=folder, version=version)
    if arrays is not None:
        return arrays, meta, status
    arrays, meta = compute()
    written = store(namespace, key, arrays, meta, folder=folder, version=version)
    if written.path is not None and written.note is None:      # computed and written
        return arrays, meta, Status("computed", written.path, None, status.note)
    note = "; ".join(dict.fromkeys(n for n in (status.note, written.note) if n)) or None
    return arrays, meta, Status("computed", written.path, note)


def info(folder=None) -> dict:
    """The folder, whether the cache is on, its bound, and its entries' count and bytes
    (names ending in ``.entry``, none opened)."""
    limit = max_bytes()
    entries, where = [], None
    try:
        where = _folder(folder)
        entries = _scan(where)[0]
    except OSError:
        pass
    return {"folder": None if where is None else str(where), "enabled": enabled(),
            "max_bytes": limit, "entries": len(entries), "bytes": sum(e[2] for e in entries)}


def clear(folder=None) -> int:
    """Remove every entry (and stale temporary); returns the bytes removed."""
    return trim(folder, limit=0)
