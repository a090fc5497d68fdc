"""One on-disk cache entry (:mod:`eyelab.core.diskcache`): its bytes, and reading them back
without trusting the file.

An entry is a magic line (:data:`MAGIC`), the length of a JSON header (8 bytes,
big-endian; at most :data:`HEADER_MAX_BYTES`), the header — namespace, key, version,
payload length (bytes, at most :data:`PAYLOAD_MAX_BYTES`) and blake2b digest of the
payload — and the payload: an uncompressed ``.npz`` archive of numeric numpy arrays plus
the caller's JSON dict (``__meta__``).

Reading (:func:`read_entry`) opens only a regular file — never following a symbolic link
(``O_NOFOLLOW``) nor waiting on a FIFO (``O_NONBLOCK``), and never opening a device: the
file's type is checked before it is opened (``lstat``) and again on what was opened
(``fstat``) — whose size must be exactly what its header says, so that no more than
:data:`ENTRY_MAX_BYTES` is ever read. The blake2b digest over the whole payload is
checked before any of it is parsed, and the archive is read with ``allow_pickle=False``
(no pickle, so no code runs) and only when every member is stored, not compressed (no
archive inflates beyond its bytes).
"""

from __future__ import annotations

import errno
import hashlib
import io
import json
import os
import stat
import struct
import zipfile

import numpy as np

from eyelab.core.fileio import json_default

#: First bytes of every entry (the format's version is its last digit).
MAGIC = b"eyelab-cache 1\n"
#: The JSON header's bound (bytes): a real one is some 250 bytes.
HEADER_MAX_BYTES = 64 * 1024
#: The payload's bound (bytes): 256 MB, far above any entry eyelab writes (a 201 x 201
#: ``eyelab maps`` grid's maps: ~7 MB); a larger entry is neither written nor read.
PAYLOAD_MAX_BYTES = 256 * 10**6
#: The whole file's bound (bytes).
ENTRY_MAX_BYTES = len(MAGIC) + 8 + HEADER_MAX_BYTES + PAYLOAD_MAX_BYTES
#: Bytes read (and hashed) at a time.
_CHUNK = 1 << 20

_KINDS = ((stat.S_ISLNK, "a symbolic link"), (stat.S_ISFIFO, "a FIFO"),
          (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISSOCK, "a socket"), (stat.S_ISDIR, "a folder"))


class BadEntry(ValueError):
    """An entry that is not to be used (and is to be removed): what is wrong with it."""


class TooLarge(ValueError):
    """A result too large for an entry (:data:`PAYLOAD_MAX_BYTES`): not written."""


def kind(mode: int) -> str | None:
    """None for a regular file's ``st_mode``, else what the file is ("a FIFO", ...)."""
    if stat.S_ISREG(mode):
        return None
    return next((name for test, name in _KINDS if test(mode)), "not a regular file")


def pack(namespace: str, key: str, version: str, arrays: dict, meta: dict) -> bytes:
    """An entry's bytes. Arrays of numbers and booleans only (an object array would be
    pickled): TypeError otherwise. :class:`TooLarge` when the payload would exceed
    :data:`PAYLOAD_MAX_BYTES`."""
    arrays = {k: np.asarray(v) for k, v in arrays.items()}
    bad = [k for k, v in arrays.items() if v.dtype.kind not in "biufc" or k == "__meta__"]
    if bad:
        raise TypeError(f"cache entries hold numeric arrays only; refused {bad}")
    buf = io.BytesIO()
    text = json.dumps(meta, default=json_default)
    extra = {"__meta__": np.frombuffer(text.encode(), np.uint8)}
    np.savez(buf, **arrays, **extra)
    payload = buf.getvalue()
    if len(payload) > PAYLOAD_MAX_BYTES:
        raise TooLarge(f"an entry of {len(payload):,} bytes is over the "
                         f"{PAYLOAD_MAX_BYTES:,} an entry may hold")
    header = json.dumps({"namespace": namespace, "key": key, "version": version,
                         "payload_bytes": len(payload),
                         "blake2b": hashlib.blake2b(payload).hexdigest()}).encode()
    return MAGIC + struct.pack(">Q", len(header)) + header + payload


def _open(path) -> tuple:
    """(file object, size in bytes) of the regular file ``path``; BadEntry when it is
    anything else or larger than :data:`ENTRY_MAX_BYTES`, FileNotFoundError when there is
    none, another OSError when it cannot be read."""
    what = kind(os.lstat(path).st_mode)        # a FIFO or device is never opened
    if what is not None:
        raise BadEntry(f"not a regular file ({what})")
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0) \
        | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(path, flags)
    except OSError as e:
        if e.errno in (errno.ELOOP, errno.EMLINK):   # O_NOFOLLOW met a link (raced lstat)
            raise BadEntry("not a regular file (a symbolic link)") from None
        raise
    f = os.fdopen(fd, "rb", buffering=0)
    try:
        st = os.fstat(fd)                      # what was opened, not what lstat saw
        what = kind(st.st_mode)
        if what is not None:
            raise BadEntry(f"not a regular file ({what})")
        if st.st_size > ENTRY_MAX_BYTES:
            raise BadEntry(f"{st.st_size:,} bytes, over the {ENTRY_MAX_BYTES:,} an entry "
                           f"may hold")
    except BaseException:
        f.close()
        raise
    return f, st.st_size


def _read(f, n: int) -> bytes:
    """Exactly ``n`` bytes of ``f`` (fewer at its end)."""
    parts, left = [], n
    while left > 0:
        b = f.read(min(left, _CHUNK))
        if not b:
            break
        parts.append(b)
        left -= len(b)
    return b"".join(parts)


#: The header's keys, all of them.
_HEADER_KEYS = {"namespace", "key", "version", "payload_bytes", "blake2b"}


def _header(f, size: int, namespace: str, key: str, version: str | None) -> tuple:
    """(payload bytes, blake2b hex) of the entry's header, checked against the file's
    ``size`` and the entry sought (its ``version``, when given)."""
    n = len(MAGIC)
    head = _read(f, n + 8)
    if head[:n] != MAGIC or len(head) < n + 8:
        raise BadEntry("not an eyelab cache entry (or truncated)")
    (hlen,) = struct.unpack(">Q", head[n:])
    if hlen > HEADER_MAX_BYTES:
        raise BadEntry(f"header length {hlen:,} bytes, over the {HEADER_MAX_BYTES:,} allowed")
    raw = _read(f, hlen)
    if len(raw) != hlen:
        raise BadEntry("truncated header")
    try:
        header = json.loads(raw)
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError):
        raise BadEntry("corrupt header") from None
    if not isinstance(header, dict) or set(header) != _HEADER_KEYS:
        raise BadEntry("corrupt header")
    if header["namespace"] != namespace or header["key"] != key \
            or (version is not None and header["version"] != version):
        raise BadEntry("header names another entry")
    plen, digest = header["payload_bytes"], header["blake2b"]
    if type(plen) is not int or not 0 <= plen <= PAYLOAD_MAX_BYTES \
            or not isinstance(digest, str):
        raise BadEntry("corrupt header")
    if size != n + 8 + hlen + plen:
        raise BadEntry(f"payload is {size - n - 8 - hlen} bytes, header says {plen}")
    return plen, digest


def read_entry(path, namespace: str, key: str, version: str | None = None) -> tuple:
    """(arrays, meta) of the entry file ``path`` for ``namespace`` / ``key`` (written by
    eyelab ``version``, when given). BadEntry
    saying what is wrong (not a regular file, too large, truncated, corrupt, another
    entry's, checksum mismatch, a pickled or compressed archive): the entry is not to be
    used. FileNotFoundError when there is none; another OSError when it cannot be read."""
    f, size = _open(path)
    with f:
        plen, digest = _header(f, size, namespace, key, version)
        h, parts, left = hashlib.blake2b(), [], plen
        while left > 0:
            b = f.read(min(left, _CHUNK))
            if not b:
                raise BadEntry(f"payload is {plen - left} bytes, header says {plen}")
            h.update(b)
            parts.append(b)
            left -= len(b)
    if h.hexdigest() != digest:
        raise BadEntry("checksum mismatch")      # checked before any of it is parsed
    return _parse(b"".join(parts))


def _parse(payload: bytes) -> tuple:
    """(arrays, meta) of a verified payload."""
    try:
        with zipfile.ZipFile(io.BytesIO(payload)) as z:
            if any(i.compress_type != zipfile.ZIP_STORED for i in z.infolist()):
                raise BadEntry("unreadable payload: a compressed archive")
        with np.load(io.BytesIO(payload), allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
        meta = json.loads(arrays.pop("__meta__").tobytes())
    except BadEntry:
        raise
    except (ValueError, KeyError, OSError, EOFError, zipfile.BadZipFile,
            RecursionError) as e:                          # checksummed, so unlikely
        raise BadEntry(f"unreadable payload: {e}") from None
    if not isinstance(meta, dict):
        raise BadEntry("unreadable payload: its meta is not a dict")
    return arrays, meta
