"""Content keys and bounded, thread-safe caches.

A cache entry is keyed by a hash of exactly the inputs it was computed from (eye, lens,
camera, scene geometry, options), never by ``id()``: ids are reused by CPython, and an
object edited in place keeps its id. Caches are LRU-bounded and emptied by their owner's
``close()``.
"""

from __future__ import annotations

import hashlib
import json
import threading
from collections import OrderedDict

import numpy as np


class Incomplete(TypeError):
    """A part of a key that only its ``repr`` could stand for (:func:`complete_key`)."""


def content_key(**parts) -> str:
    """Stable hex key of every input that matters: dataclasses (field by field), numpy
    arrays (their bytes, dtype and shape), numbers, strings, lists and dicts. An object
    with a ``content_key`` attribute (e.g. a scene mesh, which caches the digest of its
    read-only arrays) contributes that instead of being re-hashed; anything else, its
    ``repr`` (which may leave things out: :func:`complete_key` refuses it).

    >>> content_key(a=1.0, b="x") == content_key(b="x", a=1.0)
    True
    >>> content_key(a=np.zeros(3)) == content_key(a=np.zeros(4))
    False
    """
    return _key(parts, strict=False)


def complete_key(**parts) -> str | None:
    """A key of ``parts`` as :func:`content_key`'s when every part is given by its whole
    content — a dataclass (field by field; its class named with its module) of such
    parts, a numpy array of numbers or text, a number (a numpy scalar with its dtype), a
    string, bool or None, a list or tuple of them, a dict of them by strings, or an
    object's own ``content_key`` — else None: a part that only its ``repr`` could stand
    for (a rounded or abridged text may be the same for two different inputs) gets no
    key. For results kept beyond the process (:mod:`eyelab.core.diskcache`), where two
    inputs sharing a key would read each other's results.

    >>> complete_key(a=1.0) == complete_key(a="1.0")
    False
    >>> complete_key(f=len) is None
    True
    """
    try:
        return _key(parts, strict=True)
    except Incomplete:
        return None


def _key(parts: dict, strict: bool) -> str:
    def enc(o):
        key = getattr(o, "content_key", None)
        if isinstance(key, str):
            return {"_type": _type_name(o, strict), "_key": key}
        if hasattr(o, "__dataclass_fields__"):
            return {"_type": _type_name(o, strict),
                    **{k: enc(getattr(o, k)) for k in o.__dataclass_fields__}}
        if isinstance(o, np.ndarray):
            if strict and o.dtype.kind not in "biufcSU":     # object arrays: pointers
                raise Incomplete(f"an array of {o.dtype}")
            return {"_array": array_digest(o), "shape": o.shape, "dtype": str(o.dtype)}
        if isinstance(o, (list, tuple)):
            return [enc(x) for x in o]
        if isinstance(o, dict):
            if strict and not all(isinstance(k, str) for k in o):
                raise Incomplete("a dict with keys other than strings")   # 1 and "1"
            return {str(k): enc(v) for k, v in sorted(o.items())}
        return _scalar(o, strict)

    blob = json.dumps(enc(parts), sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:24]


def _type_name(o, strict: bool) -> str:
    """A part's class: with its module when ``strict`` (two classes of one name apart)."""
    t = type(o)
    return f"{t.__module__}.{t.__qualname__}" if strict else t.__name__


def _scalar(o, strict: bool):
    """The encoding of a key's leaf: numbers exactly (a float by ``repr``, which reads back
    to the same double), text, bools, None; anything else by ``repr`` (refused when
    ``strict``)."""
    if strict and isinstance(o, (np.floating, np.integer)) and not isinstance(o, float):
        return {"_type": str(o.dtype), "value": repr(o.item())}   # a float32 computes so
    if isinstance(o, (float, np.floating)):
        return {"_float": repr(float(o))} if strict else repr(float(o))   # not the text
    if isinstance(o, np.integer):
        return int(o)
    if isinstance(o, (int, str, bool, type(None))):
        return o
    if strict and not isinstance(o, np.bool_):
        raise Incomplete(f"{type(o).__name__} has no content key")
    return repr(o)


def array_digest(a: np.ndarray) -> str:
    """blake2b digest (hex, 16 bytes) of an array's bytes, dtype and shape."""
    a = np.ascontiguousarray(a)
    h = hashlib.blake2b(digest_size=16)
    h.update(f"{a.dtype.str}{a.shape}".encode())
    h.update(memoryview(a).cast("B"))
    return h.hexdigest()


class LRUCache:
    """A bounded least-recently-used map with hit/miss counters, safe to share between
    threads (every read, insert and counter update holds one lock).

    >>> c = LRUCache(2)
    >>> c.get_or_create("a", lambda: 1), c.get_or_create("a", lambda: 2)
    ((1, False), (1, True))
    >>> _ = c.get_or_create("b", lambda: 3); _ = c.get_or_create("c", lambda: 4)
    >>> sorted(c.keys()), c.hits, c.misses
    (['b', 'c'], 1, 3)
    """

    def __init__(self, maxsize: int, name: str = "cache"):
        if maxsize < 1:
            raise ValueError(f"{name}: maxsize must be >= 1, got {maxsize}")
        self.maxsize = maxsize
        self.name = name
        self._data: OrderedDict = OrderedDict()
        self._lock = threading.Lock()
        self.hits = 0
        self.misses = 0

    def get(self, key, default=None):
        with self._lock:
            if key in self._data:
                self._data.move_to_end(key)
                self.hits += 1
                return self._data[key]
            self.misses += 1
            return default

    def put(self, key, value) -> None:
        with self._lock:
            self._data[key] = value
            self._data.move_to_end(key)
            while len(self._data) > self.maxsize:
                self._data.popitem(last=False)

    def get_or_create(self, key, factory):
        """(value, hit): the cached value, or ``factory()`` computed (outside the lock) and
        stored."""
        sentinel = object()
        value = self.get(key, sentinel)
        if value is not sentinel:
            return value, True
        value = factory()
        self.put(key, value)
        return value, False

    def keys(self):
        with self._lock:
            return list(self._data)

    def __contains__(self, key):
        with self._lock:
            return key in self._data

    def __len__(self):
        with self._lock:
            return len(self._data)

    def clear(self) -> None:
        with self._lock:
            self._data.clear()

    def stats(self) -> dict:
        with self._lock:
            return {"entries": len(self._data), "maxsize": self.maxsize, "hits": self.hits,
                    "misses": self.misses}
