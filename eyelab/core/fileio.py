"""Output files written whole or not at all, and JSON for numpy values.

Every file eyelab writes (images, reports, blur fields, cached references) goes through
:func:`atomic_path`: a bad input or a crash never leaves a partial file under a final name;
a process killed mid-write leaves a recognisable temporary that the next write of the same
file sweeps (:func:`sweep_for`). Output sets (an image and its report) are written as
temporaries first and renamed last, back to back (:func:`atomic_group`).
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from eyelab.core.errors import SpecError
from eyelab.core.interrupt import check as check_interrupt

#: Temporaries are named ``.eyelab-tmp.<final name>.<random><suffix>`` beside the final
#: file (random: mkstemp's 8 characters of [a-z0-9_]; suffix: one extension or none):
#: recognisable, and swept by the next write of the same file (:func:`sweep_for`).
TMP_PREFIX = ".eyelab-tmp."


def is_temporary_of(name: str, final: str) -> bool:
    """Whether the file ``name`` is a temporary of the final file name ``final`` — and not
    of a sibling whose name starts with it (``A.json``'s are not ``A.json.npy``'s)."""
    import re

    return re.fullmatch(re.escape(TMP_PREFIX + final) + r"\.[a-z0-9_]{8}(\.[^.]*)?",
                        name) is not None


def sweep_for(*paths) -> int:
    """Remove the temporaries a killed process left for these final paths (only theirs:
    another file's temporaries may belong to a process still writing). Returns how many."""
    n = 0
    for path in paths:
        p = Path(path)
        if not p.parent.is_dir():
            continue
        for t in p.parent.glob(f"{TMP_PREFIX}{p.name}.*"):
            if not is_temporary_of(t.name, p.name):
                continue
            try:
                t.unlink()
                n += 1
            except OSError:       # already gone (another sweep) or not ours to remove
                pass
    return n


@contextmanager
def atomic_path(path, suffix: str = ".tmp"):
    """Yield a temporary file name beside ``path`` (ending in ``suffix``, so writers that
    pick a format by extension still can); when the block ends without an exception the
    file replaces ``path`` with the usual permissions (umask), otherwise it is removed.
    Parent folders are created. The temporary's name starts with :data:`TMP_PREFIX`;
    those a killed earlier write of the same file left are swept first."""
    p = Path(path)
    if p.exists() and not p.is_file():     # never rename over a device or a folder
        raise SpecError("output", f"{str(p)!r} is not a regular file")
    p.parent.mkdir(parents=True, exist_ok=True)
    sweep_for(p)
    fd, tmp = tempfile.mkstemp(dir=p.parent, prefix=f"{TMP_PREFIX}{p.name}.", suffix=suffix)
    os.close(fd)
    try:
        yield tmp
        check_interrupt()         # an interrupted command publishes nothing
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


def read_input(field: str, path, max_bytes: int, what: str = "file") -> bytes:
    """The bytes of the input file at ``path``, or a one-line :class:`SpecError` naming
    ``field``: it must exist and be a regular file — a FIFO would block the read forever
    and a device (``/dev/zero``) never end it, so neither is opened — of at most
    ``max_bytes`` bytes, which is all that is read (a file growing meanwhile included).
    ``what`` names the kind of file in the messages."""
    import stat

    p = Path(path)
    try:
        st = os.stat(p)
    except OSError as e:
        raise SpecError(field, f"cannot read {str(path)[:80]!r}: {e.strerror}") from None
    if not stat.S_ISREG(st.st_mode):
        raise SpecError(field, f"{str(path)[:80]!r} is not a regular file (a folder, device, "
                               f"pipe or socket); a {what} is read from a file")
    if st.st_size > max_bytes:
        raise SpecError(field, f"{p.name} is {st.st_size:,} bytes; a {what} has at most "
                               f"{max_bytes:,}")
    try:
        with open(p, "rb") as f:
            data = f.read(max_bytes + 1)
    except OSError as e:
        raise SpecError(field, f"cannot read {str(path)[:80]!r}: {e.strerror}") from None
    if len(data) > max_bytes:
        raise SpecError(field, f"{p.name} has more than {max_bytes:,} bytes; a {what} has at "
                               f"most {max_bytes:,}")
    return data


def check_output(flag: str, path) -> Path:
    """Fail early, before any work: ``path`` must not be a folder, its parent must be a
    folder (or creatable) that this process may write in. Returns the path."""
    if not str(path):
        raise SpecError(flag, "must be a file path, got ''")
    p = Path(path)
    if p.is_dir():
        raise SpecError(flag, f"{str(p)!r} is a folder, not a file")
    if p.exists() and not p.is_file():
        raise SpecError(flag, f"{str(p)!r} is not a regular file (a device, pipe or socket); "
                              "outputs replace whole files")
    _check_creatable(flag, p, p.parent)
    return p


def _check_creatable(flag: str, p: Path, parent: Path) -> None:
    """``p`` can be made: its nearest existing ancestor from ``parent`` up is a folder this
    process may write in."""
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        raise SpecError(flag, f"cannot create {str(p)!r}: {str(parent)!r} is not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise SpecError(flag, f"cannot write in {str(parent)!r}")


def user_path(field: str, value) -> Path:
    """``value`` as a :class:`Path` with ``~`` / ``~user`` expanded; an unknown user is a
    :class:`SpecError` naming ``field``."""
    try:
        return Path(value).expanduser()
    except RuntimeError as e:              # "Could not determine home directory"
        raise SpecError(field, f"cannot expand {str(value)!r}: {e}") from None


def check_output_folder(flag: str, path) -> Path:
    """Fail early, before any work: ``path`` must be a folder, or creatable as one, that
    this process may write in. Returns it absolute (workers in other folders, e.g. on a
    Dask cluster, then write where the caller meant)."""
    if not str(path):
        raise SpecError(flag, "must be a folder path, got ''")
    p = user_path(flag, path).absolute()
    if p.exists() and not p.is_dir():
        raise SpecError(flag, f"{str(p)!r} exists and is not a folder")
    _check_creatable(flag, p, p)
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


def atomic_group(writers: dict) -> None:
    """Write several files as one set: {path: write(tmp_path)}; every file is written to
    its temporary first, and only when all succeeded are they renamed into place, in the
    given order, back to back (a failure while writing leaves the old set untouched; a
    kill can only fall between two renames — microseconds — where the set is mixed).
    Leftover temporaries of the same paths are swept first."""
    sweep_for(*writers)
    stack = []
    try:
        for path, write in writers.items():
            cm = atomic_path(path, suffix=Path(path).suffix or ".tmp")
            tmp = cm.__enter__()
            stack.append((cm, tmp))
            write(tmp)
        check_interrupt()
    except BaseException:
        for cm, _ in reversed(stack):
            cm.__exit__(RuntimeError, RuntimeError("aborted"), None)
        raise
    for cm, _ in stack:
        cm.__exit__(None, None, None)


#: cHRM of the sRGB / Rec. 709 primaries and D65 white (x, y x 100000: white, r, g, b).
_SRGB_CHRM = (31270, 32900, 64000, 33000, 30000, 60000, 15000, 6000)


def png_bytes(image: np.ndarray) -> bytes:
    """An (h, w, 3) image as PNG bytes, deterministic (zlib level 6, filter 0), with the
    colour chunks that say how to read it:

    - uint8: sRGB-encoded, 24-bit RGB with an ``sRGB`` chunk (perceptual intent) and the
      ``gAMA`` (1/2.2) and ``cHRM`` an sRGB encoder writes beside it for older readers;
    - uint16: *linear* light (0-65535 = 0-1 relative to white), 48-bit RGB with ``gAMA``
      1.0 and the sRGB primaries' ``cHRM`` (Pillow cannot write 16-bit RGB, hence this
      encoder, used for both depths)."""
    import struct
    import zlib

    a = np.asarray(image)
    if a.ndim != 3 or a.shape[2] != 3 or a.dtype not in (np.uint8, np.uint16):
        raise ValueError(f"png_bytes takes an (h, w, 3) uint8 or uint16 image, got "
                         f"{a.shape} {a.dtype}")
    h, w = a.shape[:2]
    depth = 8 * a.dtype.itemsize
    rows = np.ascontiguousarray(a.astype(">u2") if depth == 16 else a).reshape(h, -1)
    raw = np.concatenate([np.zeros((h, 1), np.uint8), rows.view(np.uint8)], axis=1)

    def chunk(tag, data):
        return (struct.pack(">I", len(data)) + tag + data
                + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF))

    colour = ([chunk(b"sRGB", b"\x00"), chunk(b"gAMA", struct.pack(">I", 45455))]
              if depth == 8 else [chunk(b"gAMA", struct.pack(">I", 100000))])
    return b"".join([b"\x89PNG\r\n\x1a\n",
                     chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, depth, 2, 0, 0, 0)),
                     *colour, chunk(b"cHRM", struct.pack(">8I", *_SRGB_CHRM)),
                     chunk(b"IDAT", zlib.compress(raw.tobytes(), 6)), chunk(b"IEND", b"")])


def linear_to_png16(linear: np.ndarray) -> np.ndarray:
    """(h, w, 3) linear values (1 = white) -> uint16 codes for :func:`png_bytes`."""
    return np.clip(np.round(np.asarray(linear, float) * 65535.0), 0, 65535).astype(np.uint16)


def png_writer(image: np.ndarray):
    """A writer (``write(path)``) of an (h, w, 3) image as PNG (:func:`png_bytes`: uint8
    sRGB, or uint16 linear light)."""
    data = png_bytes(image)

    def write(path):
        Path(path).write_bytes(data)
    return write


def json_text(obj) -> str:
    """``obj`` as indented JSON text, ending in a new line (numpy values converted; NaN and
    infinities written as null: JSON has no such numbers, RFC 8259 §6, and strict readers
    refuse Python's ``NaN``)."""
    return json.dumps(strict_json(obj), indent=2, default=json_default,
                      allow_nan=False) + "\n"


def strict_json(obj):
    """``obj`` with numpy values as Python ones and non-finite floats as None (dicts,
    lists and tuples walked)."""
    if isinstance(obj, dict):
        return {k: strict_json(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [strict_json(v) for v in obj]
    if isinstance(obj, (np.ndarray, np.generic)):
        return strict_json(obj.tolist())
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def json_writer(obj):
    """A writer (``write(path)``) of ``obj`` as JSON (numpy values converted)."""
    text = json_text(obj)

    def write(path):
        Path(path).write_text(text)
    return write


def write_png(path, image: np.ndarray) -> None:
    """Atomic PNG write of an (h, w, 3) image (:func:`png_bytes`; no partial file on
    failure)."""
    with atomic_path(path, suffix=".png") as tmp:
        png_writer(image)(tmp)


def write_json(path, obj) -> None:
    """Atomic JSON write (numpy values converted)."""
    with atomic_path(path) as tmp:
        json_writer(obj)(tmp)


#: The unit convention of every JSON report eyelab writes, its first key ("units"): the
#: spec's units, each key naming its unit by suffix.
REPORT_UNITS = ("the spec's units: dioptres (prism in prism dioptres), mm for lens, eye, pupil "
                "and PD lengths, um for retinal blur and wavefronts, m for scene distances, "
                "degrees for angles, nm for wavelengths, arcmin for angular blur, s for times, "
                "pixels for image sizes (width, height: the spec's keys); any other key with "
                "a unit names it by suffix (_d, _mm, _um, _m, _deg, _rad, _nm, _arcmin, _s, "
                "_px, _cpd)")


def with_units(report: dict) -> dict:
    """``report`` (a dict) with ``"units": REPORT_UNITS`` as its first key (a ``"units"``
    it had is replaced): what every JSON report eyelab writes starts with."""
    return {"units": REPORT_UNITS, **{k: v for k, v in report.items() if k != "units"}}


def report_text(report: dict) -> str:
    """The JSON text of a report (:func:`with_units`; numpy values converted)."""
    return json_text(with_units(report))


def report_writer(report: dict):
    """A writer (``write(path)``, for :func:`atomic_group`) of a report as JSON, its units
    first (:func:`with_units`)."""
    return json_writer(with_units(report))


def write_report(path, report: dict) -> None:
    """Atomic JSON write of a report, its units first (:func:`with_units`)."""
    write_json(path, with_units(report))
