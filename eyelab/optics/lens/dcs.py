"""Vision Council DCS records (the "OMA" lab protocol): ``LABEL=value;value;...`` lines.

The Data Communication Standard (DCS) of The Vision Council's Lens Processing & Technology
Division (v3.08, 2010; v3.12, 2018) carries lab data — prescriptions, frame traces, free-form
surface points — as text records, one per line: a label, ``=``, then values separated by
``;``. This module reads and writes those records for any DCS file (a surface points file,
:mod:`eyelab.optics.lens.pointsfile`; a frame trace); what a label's values mean is the reader
of that file's business.

Record syntax as the public implementation eeng/lens_protocol (Ruby; commit 1b44fa3, 2022)
reads it:

* ``lib/lens_protocol/oma/line.rb``: a record is split at its first ``=`` into the label
  and the data; a line without ``=`` is refused;
* ``lib/lens_protocol/oma/types/type.rb``: the data are split at every ``;``; a value ``?``
  means no value (here: refused where a number is needed, naming it);
* ``lib/lens_protocol/oma/types/trcfmt.rb``: a dataset too long for one record continues in
  further records of the same label (a trace's ``R`` records, 10 values each).

Also: CR LF or LF line ends; blank lines skipped; the packet framing characters FS, GS, RS,
SUB (0x1C-0x1E, 0x1A) and a byte-order mark ignored; labels compared in upper case. Numbers
are decimal (``-1.25``, ``.5``, ``1e-3``): Python's other float spellings (``1_000``,
``inf``, ``nan``) are refused, a ``nan`` or ``inf`` by name.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

from eyelab.core.errors import SpecError

#: Characters of a DCS packet's framing that are not part of any record.
FRAMING = "\x1a\x1c\x1d\x1e\ufeff"
#: A decimal number as DCS files write them.
NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")
#: The largest file read (bytes): a 2001 x 2001 grid at 16 characters a value.
MAX_BYTES = 80_000_000


@dataclass(frozen=True)
class Record:
    """One record: ``label`` (upper case), its ``values`` (strings, as written) and the
    1-based ``line`` of the file it is on."""

    label: str
    values: tuple
    line: int


def parse_records(text: str, field: str, name: str = "the file") -> list:
    """The records of DCS ``text`` (list of :class:`Record`); a line that is not a record
    raises :class:`SpecError` naming ``field`` and ``name`` (the file, as the user wrote
    it) with the line number."""
    out = []
    for i, raw in enumerate(lines(text), start=1):
        line = raw.strip().strip(FRAMING).strip()
        if not line:
            continue
        label, eq, data = line.partition("=")
        if not eq or not label.strip():
            shown = line if len(line) <= 40 else line[:40] + "..."
            raise SpecError(field, f"{name} line {i}: {shown!r} is not a DCS record "
                                   "(LABEL=value;value;...)")
        out.append(Record(label.strip().upper(), tuple(data.split(";")), i))
    return out


def lines(text: str) -> list:
    """``text``'s lines, split at CR LF, LF or CR only (not at the framing characters that
    :meth:`str.splitlines` also splits at)."""
    return re.split(r"\r\n|\r|\n", text)


def read_text(path, field: str) -> str:
    """The text of the DCS file at ``path`` (ASCII; UTF-8 accepted), or :class:`SpecError`
    naming ``field`` when it cannot be read, is too large or is not text."""
    from eyelab.core.fileio import read_input

    p = Path(path)
    raw = read_input(field, p, MAX_BYTES, "DCS file")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as e:
        raise SpecError(field, f"{p.name} is not a text file (byte {e.start}); a DCS file "
                               "is ASCII text") from None


def number(value: str, field: str, where: str) -> float:
    """``value`` (one record value) as a finite float; ``where`` says where it is (e.g.
    ``"s.sdf line 4, value 7"``) in the :class:`SpecError` naming ``field``."""
    v = value.strip()
    if NUMBER.fullmatch(v):
        x = float(v)
        if math.isfinite(x):
            return x
        raise SpecError(field, f"{where}: {v!r} is too large for a number")
    if v.lower().lstrip("+-") in ("nan", "inf", "infinity"):
        raise SpecError(field, f"{where}: {v!r} is not a finite number")
    what = "an unknown value ('?')" if v == "?" else "an empty value" if not v else \
        f"{v[:20]!r}, not a number"
    raise SpecError(field, f"{where}: {what}")


def format_record(label: str, values) -> str:
    """One record line (without its line end): ``LABEL=v1;v2;...`` (values as given,
    strings or numbers formatted by the caller)."""
    return f"{label}=" + ";".join(str(v) for v in values)
