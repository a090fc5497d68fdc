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
* **Entries** are one file each, ``<namespace>.<key>.entry``: a magic line, the length
  of a JSON header (8 bytes, big-endian), the header — namespace, key, version, payload
  length and blake2b digest — and the payload, an ``.npz`` archive of numpy arrays plus
  the caller's JSON dict (``__meta__``). No pickle anywhere: the archive is read with
  ``allow_pickle=False``, so a cache folder is never a code-execution path.
* **Verified on read**: a truncated, corrupt or mismatched entry is a miss; it is
  deleted and the result computed and written again.
* **Atomic, concurrent writes**: a temporary in the same folder, then ``os.replace``;
  several processes filling one entry at once each publish a whole file, the last rename
  wins, and readers never see a partial file. (:func:`eyelab.core.fileio.atomic_path`
  does not fit: it sweeps the temporaries of the same final name, which here may belong
  to a concurrent writer.)
* **Bounded**: after each write, entries are removed oldest-used first (a hit touches
  the file's modification time, which mounts with ``noatime`` keep too) until the folder
  holds at most ``max_bytes`` (:data:`DEFAULT_MAX_BYTES`, or ``$EYELAB_CACHE_MAX_MB``).
* **Never in the way**: a folder that cannot be made, read or written means the result is
  computed as without the cache; nothing is printed or warned, the returned
  :class:`Status` says why.
"""

from __future__ import annotations

import dataclasses
import hashlib
import io
import json
import os
import struct
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from eyelab.core.cache import content_key
from eyelab.core.fileio import TMP_PREFIX, json_default

#: The cache folder's environment variable (overrides the XDG rule).
DIR_ENV = "EYELAB_CACHE_DIR"
#: ``EYELAB_NO_CACHE=1`` (any value but "", "0", "false", "no", "off") turns the cache off.
OFF_ENV = "EYELAB_NO_CACHE"
#: The size bound's environment variable, in MB (10^6 bytes).
MAX_ENV = "EYELAB_CACHE_MAX_MB"
#: The folder's size bound (bytes): 256 MB — tens of thousands of optimised designs (~5 kB
#: each), or some 1800 ``eyelab maps`` runs' maps (31 x 31: ~130 kB) and figures (~8 kB).
DEFAULT_MAX_BYTES = 256 * 10**6
#: First bytes of every entry (the format's version is its last digit).
MAGIC = b"eyelab-cache 1\n"
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
    ``path`` the entry's file (None when the cache is off or its folder unusable);
    ``note`` why the cache was not used, or what was wrong with the entry found (None when
    all went well)."""

    source: str
    path: str | None = None
    note: str | None = None

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


def cache_dir() -> Path:
    """The cache folder (module text): ``$EYELAB_CACHE_DIR``, else
    ``$XDG_CACHE_HOME/eyelab`` (an absolute ``XDG_CACHE_HOME`` only, as the specification
    asks), else ``~/.cache/eyelab``. Not created here. OSError when there is no home to
    put it in."""
    own = os.environ.get(DIR_ENV, "")
    if own:
        return Path(own).expanduser()
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
    """The folder's size bound (bytes): ``$EYELAB_CACHE_MAX_MB`` x 10^6 when it is a
    non-negative number, else :data:`DEFAULT_MAX_BYTES`."""
    try:
        mb = float(os.environ.get(MAX_ENV, ""))
    except ValueError:
        return DEFAULT_MAX_BYTES
    return int(mb * 10**6) if mb >= 0 else DEFAULT_MAX_BYTES


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


def _pack(namespace: str, key: str, version: str, arrays: dict, meta: dict) -> bytes:
    """An entry's bytes (module text). Arrays of numbers and booleans only: an object
    array would be pickled."""
    arrays = {k: np.asarray(v) for k, v in arrays.items()}
    bad = [k for k, v in arrays.items() if v.dtype.kind not in "biufc" or k == "__meta__"]
    if bad:
        raise TypeError(f"cache entries hold numeric arrays only; refused {bad}")
    buf = io.BytesIO()
    text = json.dumps(meta, default=json_default)
    extra = {"__meta__": np.frombuffer(text.encode(), np.uint8)}
    np.savez(buf, **arrays, **extra)
    payload = buf.getvalue()
    header = json.dumps({"namespace": namespace, "key": key, "version": version,
                         "payload_bytes": len(payload),
                         "blake2b": hashlib.blake2b(payload).hexdigest()}).encode()
    return MAGIC + struct.pack(">Q", len(header)) + header + payload


def _unpack(data: bytes, namespace: str, key: str) -> tuple:
    """(arrays, meta) of an entry's bytes; ValueError saying what is wrong."""
    n = len(MAGIC)
    if data[:n] != MAGIC or len(data) < n + 8:
        raise ValueError("not an eyelab cache entry (or truncated)")
    (hlen,) = struct.unpack(">Q", data[n:n + 8])
    if n + 8 + hlen > len(data):
        raise ValueError("truncated header")
    try:
        header = json.loads(data[n + 8:n + 8 + hlen])
    except (UnicodeDecodeError, json.JSONDecodeError):
        raise ValueError("corrupt header") from None
    if not isinstance(header, dict) or header.get("namespace") != namespace \
            or header.get("key") != key:
        raise ValueError("header names another entry")
    payload = data[n + 8 + hlen:]
    if len(payload) != header.get("payload_bytes"):
        raise ValueError(f"payload is {len(payload)} bytes, header says "
                         f"{header.get('payload_bytes')}")
    if hashlib.blake2b(payload).hexdigest() != header.get("blake2b"):
        raise ValueError("checksum mismatch")
    try:
        with np.load(io.BytesIO(payload), allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
        meta = json.loads(arrays.pop("__meta__").tobytes())
    except (ValueError, KeyError, OSError, EOFError) as e:   # checksummed, so unlikely
        raise ValueError(f"unreadable payload: {e}") from None
    return arrays, meta


def _remove(path: Path) -> None:
    try:
        path.unlink()
    except OSError:                # gone already (another process), or not ours
        pass


def load(namespace: str, key: str, *, folder=None) -> tuple:
    """(arrays, meta, status) of the entry ``key``, or (None, None, status) on a miss:
    the cache off (``status.note`` "off"), no entry, an unusable folder, or an entry
    that fails verification (deleted; ``status.note`` says why)."""
    if not enabled():
        return None, None, Status("computed", note="off")
    try:
        path = _entry_path(_folder(folder), namespace, key)
    except OSError as e:
        return None, None, Status("computed", note=f"cannot read the cache: {e}")
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return None, None, Status("computed", str(path))
    except OSError as e:
        return None, None, Status("computed", str(path), f"cannot read the cache: {e}")
    try:
        arrays, meta = _unpack(data, namespace, key)
    except ValueError as e:
        _remove(path)
        return None, None, Status("computed", str(path), f"bad entry removed: {e}")
    try:
        os.utime(path)             # used now: the last to be evicted
    except OSError:
        pass
    return arrays, meta, Status("disk", str(path))


def store(namespace: str, key: str, arrays: dict, meta: dict, *, folder=None,
          version: str | None = None) -> Status:
    """Write the entry ``key`` (``arrays``: name -> numeric numpy array; ``meta``: a dict
    JSON can write) atomically, then trim the folder to its bound (:func:`max_bytes`).
    Returns the status of a computed result: its path, or why it was not written."""
    if not enabled():
        return Status("computed", note="off")
    if version is None:
        from eyelab import __version__ as version
    data = _pack(namespace, key, version, arrays, meta)
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
    trim(folder)
    return Status("computed", str(path))


def trim(folder=None, limit: int | None = None) -> int:
    """Remove entries oldest-used first until those left hold at most ``limit`` bytes
    (default :func:`max_bytes`), and temporaries older than :data:`STALE_TMP_S`. Returns
    the bytes removed. Files another process removes meanwhile are skipped."""
    limit = max_bytes() if limit is None else limit
    entries, removed, now = [], 0, time.time()
    try:
        folder = _folder(folder)
        names = list(os.scandir(folder))
    except OSError:
        return 0
    for e in names:
        try:
            st = e.stat()
        except OSError:
            continue
        if e.name.startswith(TMP_PREFIX):
            if now - st.st_mtime > STALE_TMP_S:
                _remove(Path(e.path))
        elif e.name.endswith(SUFFIX):
            entries.append((st.st_mtime, e.name, st.st_size, Path(e.path)))
    total = sum(e[2] for e in entries)
    for _, _, size, path in sorted(entries):
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
    dtype and bytes); meta read back is what JSON gives back (tuples become lists)."""
    key = entry_key(namespace, parts, version=version, code=code)
    arrays, meta, status = load(namespace, key, folder=folder)
    if arrays is not None:
        return arrays, meta, status
    arrays, meta = compute()
    written = store(namespace, key, arrays, meta, folder=folder, version=version)
    note = "; ".join(dict.fromkeys(n for n in (status.note, written.note) if n)) or None
    return arrays, meta, Status("computed", written.path, note)


def info(folder=None) -> dict:
    """The folder, whether the cache is on, its bound, and its entries' count and bytes."""
    sizes, where = [], None
    try:
        where = _folder(folder)
        sizes = [p.stat().st_size for p in where.glob(f"*{SUFFIX}")]
    except OSError:
        pass
    return {"folder": None if where is None else str(where), "enabled": enabled(),
            "max_bytes": max_bytes(), "entries": len(sizes), "bytes": sum(sizes)}


def clear(folder=None) -> int:
    """Remove every entry (and stale temporary); returns the bytes removed."""
    return trim(folder, limit=0)
