"""The on-disk cache (eyelab/core/diskcache.py): entries round-trip bit for bit, keyed by
eyelab's version, never trusted truncated, corrupt, pickled or bit-flipped, never read
unless regular files (not FIFOs, devices, links); concurrent writers, the bound, the cache
off, bad settings (one line, exit status 2); an optimised design read back in a fresh
process is the computed lens, and a damaged entry is optimised again."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import stat
import struct
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import eyelab
from eyelab.core import cacheentry, diskcache
from eyelab.core.errors import SpecError
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.lens import optimise
from eyelab.optics.lens.optimise import Settings, optimised_progressive

NS = "test"
#: The folder tests/conftest.py gives the whole suite (read before any fixture changes it).
SUITE_FOLDER = os.environ.get(diskcache.DIR_ENV)


@pytest.fixture(autouse=True)
def folder(tmp_path, monkeypatch):
    """A cache folder of the test's own, the cache on, no size override."""
    d = tmp_path / "cache"
    monkeypatch.setenv(diskcache.DIR_ENV, str(d))
    monkeypatch.delenv(diskcache.OFF_ENV, raising=False)
    monkeypatch.delenv(diskcache.MAX_ENV, raising=False)
    monkeypatch.setattr(diskcache, "_enabled", None)
    return d


class Counter:
    """compute() for :func:`diskcache.fetch`: counts its calls."""

    def __init__(self, n=1000, value=1.5):
        self.calls, self.n, self.value = 0, n, value

    def __call__(self):
        self.calls += 1
        a = np.linspace(0.0, self.value, self.n) ** 1.5          # not round numbers
        return {"a": a, "i": np.arange(7, dtype=np.int32)}, {"note": "x", "t": [1, 2.5]}


def entries(folder):
    return sorted(p.name for p in folder.iterdir()) if folder.exists() else []


def test_a_result_round_trips_bit_for_bit(folder):
    f = Counter()
    a1, m1, s1 = diskcache.fetch(NS, {"x": 1.0}, f)
    a2, m2, s2 = diskcache.fetch(NS, {"x": 1.0}, f)
    assert (s1.source, s2.source, f.calls) == ("computed", "disk", 1)
    assert s1.path == s2.path and s2.note is None
    for k in a1:
        assert a2[k].dtype == a1[k].dtype
        np.testing.assert_array_equal(a2[k], a1[k])
    assert m2 == m1
    _, _, s3 = diskcache.fetch(NS, {"x": 2.0}, f)               # other inputs: a miss
    assert s3.source == "computed" and f.calls == 2 and len(entries(folder)) == 2


def test_the_key_holds_the_version_and_the_code():
    assert diskcache.entry_key(NS, {}) == diskcache.entry_key(NS, {},
                                                              version=eyelab.__version__)
    f = Counter()
    diskcache.fetch(NS, {}, f, version="0.1.0")
    assert diskcache.fetch(NS, {}, f, version="0.1.0")[2].source == "disk"
    assert diskcache.fetch(NS, {}, f, version="0.2.0")[2].source == "computed"
    assert f.calls == 2
    here = os.path.dirname(diskcache.__file__)
    assert diskcache.entry_key(NS, {}, code=[here]) != diskcache.entry_key(NS, {})


def _damage(path, how):
    data = bytearray(path.read_bytes())
    if how == "truncated":
        data = data[: len(data) // 2]
    elif how == "empty":
        data = b""
    else:
        at = {"last byte": -1, "payload": len(data) // 2, "header": len(diskcache.MAGIC) + 20,
              "magic": 0}[how]
        data[at] ^= 0x01
    path.write_bytes(bytes(data))


@pytest.mark.parametrize("how", ["truncated", "empty", "last byte", "payload", "header",
                                 "magic"])
def test_a_damaged_entry_is_recomputed_and_replaced(folder, how):
    f = Counter()
    a, _, s = diskcache.fetch(NS, {}, f)
    path = folder / os.path.basename(s.path)
    _damage(path, how)
    a2, _, s2 = diskcache.fetch(NS, {}, f)
    assert s2.source == "computed" and f.calls == 2, s2
    assert s2.note is None and s2.path == s.path, s2              # computed and written
    assert s2.replaced.startswith("bad entry removed"), s2
    np.testing.assert_array_equal(a2["a"], a["a"])
    a3, _, s3 = diskcache.fetch(NS, {}, f)             # the entry was written again, whole
    assert s3.source == "disk" and s3.path == s.path and f.calls == 2
    np.testing.assert_array_equal(a3["a"], a["a"])


def test_a_pickled_payload_is_never_loaded(folder):
    """An entry whose checksum is right but whose archive holds an object array (loading
    it would unpickle): refused, removed, recomputed — and store refuses to write one."""
    import hashlib
    import io
    import struct

    key = diskcache.entry_key(NS, {})
    buf = io.BytesIO()
    np.savez(buf, a=np.array([{"x": 1}], dtype=object),
             __meta__=np.frombuffer(b"{}", np.uint8))
    payload = buf.getvalue()
    header = json.dumps({"namespace": NS, "key": key, "version": eyelab.__version__,
                         "payload_bytes": len(payload),
                         "blake2b": hashlib.blake2b(payload).hexdigest()}).encode()
    folder.mkdir()
    path = folder / f"{NS}.{key}{diskcache.SUFFIX}"
    path.write_bytes(diskcache.MAGIC + struct.pack(">Q", len(header)) + header + payload)
    arrays, meta, status = diskcache.load(NS, key)
    assert arrays is None and "unreadable payload" in status.note
    assert not path.exists()
    with pytest.raises(TypeError, match="numeric arrays only"):
        diskcache.store(NS, key, {"a": np.array([None])}, {})


def _expired(signum, frame):
    raise TimeoutError("still running past its deadline")


@contextlib.contextmanager
def deadline(seconds: int = 10):
    """The block fails instead of hanging past ``seconds`` (s): a FIFO's read never ends."""
    old = signal.signal(signal.SIGALRM, _expired)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


#: What is put in an entry's place (``p``; ``s`` a sound copy elsewhere), why it is refused:
#: a FIFO's read blocks for ever, /dev/zero's never ends; a sparse file over the bound.
REPLACEMENTS = {
    "fifo": (lambda p, s: os.mkfifo(p), "not a regular file (a FIFO)"),
    "link to /dev/zero": (lambda p, s: p.symlink_to("/dev/zero"), "(a symbolic link)"),
    "link to a sound entry": (lambda p, s: p.symlink_to(s), "(a symbolic link)"),
    "device": (lambda p, s: os.mknod(p, stat.S_IFCHR | 0o600, os.makedev(1, 5)),
               "not a regular file (a character device)"),
    "sparse file": (lambda p, s: (p.touch(), os.truncate(p, cacheentry.ENTRY_MAX_BYTES + 1)),
                    "bytes, over the")}


@pytest.mark.parametrize("what", REPLACEMENTS)
def test_an_entry_that_is_no_sane_file_is_never_read(folder, tmp_path, what):
    """None is read; each is removed (a link itself, never its target), the result
    computed and written again, in seconds, and said so."""
    f = Counter()
    a, _, s = diskcache.fetch(NS, {}, f)
    path, sound = Path(s.path), tmp_path / "elsewhere.entry"
    sound.write_bytes(path.read_bytes())
    path.unlink()
    make, why = REPLACEMENTS[what]
    try:
        make(path, sound)
    except PermissionError:
        pytest.skip(f"making a {what} takes root")
    with deadline(10):
        a2, _, s2 = diskcache.fetch(NS, {}, f)
        a3, _, s3 = diskcache.fetch(NS, {}, f)
    assert (s2.source, s2.path, s2.note, f.calls) == ("computed", s.path, None, 2), s2
    assert s2.replaced.startswith("bad entry removed: ") and why in s2.replaced, s2
    assert path.is_file() and not path.is_symlink() and s3 == diskcache.Status("disk", s.path)
    assert sound.is_file() and os.path.exists("/dev/zero")           # targets untouched
    assert all(np.array_equal(b[k], a[k]) for b in (a2, a3) for k in a)


def test_no_flipped_bit_anywhere_in_an_entry_goes_unnoticed(folder):
    """Each byte of an entry flipped in its lowest and in its highest bit, one at a time:
    each is refused (never a result), the header's length field is bounded before any
    header is read, and the result recomputed over a damaged entry is the sound one."""
    f = Counter(n=5)
    a, m, s = diskcache.fetch(NS, {}, f)
    path = Path(s.path)
    key = path.name[len(NS) + 1:-len(diskcache.SUFFIX)]
    sound = path.read_bytes()
    for i in range(len(sound)):
        for bit in (0x01, 0x80):
            data = bytearray(sound)
            data[i] ^= bit
            path.write_bytes(bytes(data))
            arrays, _, st = diskcache.load(NS, key, version=eyelab.__version__)
            assert arrays is None and st.note.startswith("bad entry removed"), (i, bit, st)
            assert not path.exists()
    n = len(diskcache.MAGIC)
    path.write_bytes(sound[:n] + struct.pack(">Q", 2**63) + sound[n + 8:])
    assert "header length" in diskcache.load(NS, key)[2].note and not path.exists()
    path.write_bytes(sound)
    _damage(path, "payload")
    a2, m2, s2 = diskcache.fetch(NS, {}, f)
    assert s2.replaced == "bad entry removed: checksum mismatch" and f.calls == 2
    assert path.read_bytes() == sound and m2 == m
    for k in a:
        np.testing.assert_array_equal(a2[k], a[k])


#: Settings the cache refuses: (variable, value).
BAD_SETTINGS = [(diskcache.MAX_ENV, v) for v in ("inf", "1e308", "1e400", "-1", "nan",
                                                   "abc", "1000001", "-inf")] \
    + [(diskcache.DIR_ENV, "~nosuchuser9/c"), (diskcache.DIR_ENV, "d" * 5000)]
#: What each says is allowed.
RANGES = {diskcache.MAX_ENV: "must be a finite number of MB in [{}, {}], got ".format(
    *diskcache.MAX_MB_RANGE), diskcache.DIR_ENV: f"must be a folder path of at most "
    f"{diskcache.DIR_MAX_CHARS} characters ('~' or '~user' of a known user), got "}


@pytest.mark.parametrize("name, value", BAD_SETTINGS)
def test_a_bad_setting_is_one_line_and_exit_status_2(folder, monkeypatch, capsys, tmp_path,
                                                     name, value):
    """``eyelab cache`` (``--clear`` included: nothing removed), ``eyelab maps`` of a
    progressive lens and ``eyelab analyze`` of a lenslet lens: one line naming the
    variable and its range, status 2, nothing computed or written, in seconds."""
    from eyelab.apps.cli import main

    f = Counter()
    diskcache.fetch(NS, {}, f)
    before = entries(folder)
    monkeypatch.setenv(name, value)
    monkeypatch.setattr(optimise, "_DESIGNS", None)
    monkeypatch.chdir(os.path.dirname(os.path.dirname(__file__)))
    out = tmp_path / "out"
    runs = (["cache"], ["cache", "--clear", "--json"],
            ["maps", "docs/gallery/pal.toml", "--points", "5", "-o", str(out / "m.png"),
             "--json", str(out / "m.json")],
            ["analyze", "examples/halt.toml", "-o", str(out / "a.json")])
    for argv in runs:
        with deadline(10):
            assert main(argv) == 2, argv
        said = capsys.readouterr()
        assert said.out == "" and said.err.count("\n") == 1, (argv, said)
        assert said.err.startswith(f"eyelab: error: {name}: {RANGES[name]}"), said.err
    assert entries(folder) == before and not out.exists()
    with pytest.raises(SpecError, match=name):
        diskcache.fetch(NS, {"other": 1}, f)                # before computing
    monkeypatch.setenv(diskcache.OFF_ENV, "1")
    diskcache.check_environment()                           # off: not used, not checked
    with pytest.raises(SpecError, match=name):
        diskcache.check_environment(always=True)
    assert f.calls == 1


def test_good_size_bounds_and_the_docs(monkeypatch):
    for value, mb in (("0", 0), (" 12.5 ", 12.5), ("1e6", 10**6), ("", 256)):
        monkeypatch.setenv(diskcache.MAX_ENV, value)
        assert diskcache.max_bytes() == int(mb * 10**6)
    lo, hi = diskcache.MAX_MB_RANGE             # the ranges in docs/guide/python-api.md
    text = (Path(__file__).parents[1] / "docs" / "guide" / "python-api.md").read_text()
    text = " ".join(text.split())
    assert f"`{diskcache.MAX_ENV}`, a number of MB in [{lo}, {hi}]" in text
    assert f"under {diskcache.DEFAULT_MAX_BYTES // 10**6} MB" in text
    assert f"longer than {diskcache.DIR_MAX_CHARS} characters" in text

WRITER = """
import sys, numpy as np
from eyelab.core import diskcache
i, folder, key = int(sys.argv[1]), sys.argv[2], sys.argv[3]
for n in range(15):
    diskcache.store("test", key, {"a": np.full(300_000, float(i))}, {"writer": i, "n": n},
                    folder=folder)
"""


def test_concurrent_writers_leave_one_whole_entry(folder):
    """Four processes write the same entry (each its own 2.4 MB payload) 15 times over
    while this one reads it: every read is one writer's whole entry (a partial file would
    fail verification and be reported), and one valid entry is left, no temporaries."""
    key = diskcache.entry_key(NS, {"concurrent": True})
    procs = [subprocess.Popen([sys.executable, "-c", WRITER, str(i), str(folder), key])
             for i in range(4)]
    reads = 0
    while any(p.poll() is None for p in procs):
        arrays, meta, status = diskcache.load(NS, key, folder=folder)
        assert status.note is None, status.note
        if arrays is not None:
            assert np.all(arrays["a"] == meta["writer"]) and len(arrays["a"]) == 300_000
            reads += 1
    assert [p.returncode for p in procs] == [0] * 4
    assert entries(folder) == [f"{NS}.{key}{diskcache.SUFFIX}"]
    arrays, meta, status = diskcache.load(NS, key, folder=folder)
    assert status.source == "disk" and np.all(arrays["a"] == meta["writer"])
    print(f"{reads} whole reads while writing")


def test_the_folder_stays_within_its_bound_oldest_used_first(folder, monkeypatch):
    f = Counter(n=2000)                                        # ~17 kB an entry
    paths = {name: diskcache.fetch(NS, {"e": name}, f)[2].path for name in "abc"}
    size = os.path.getsize(paths["a"])
    monkeypatch.setenv(diskcache.MAX_ENV, str(3.5 * size / 1e6))
    t0 = time.time() - 100
    for i, name in enumerate("abc"):                           # used in the order a, b, c
        os.utime(paths[name], (t0 + i, t0 + i))
    assert diskcache.fetch(NS, {"e": "a"}, f)[2].source == "disk"   # a used now
    paths["d"] = diskcache.fetch(NS, {"e": "d"}, f)[2].path          # b must go
    left = {n for n, p in paths.items() if os.path.exists(p)}
    assert left == {"a", "c", "d"}
    assert sum(os.path.getsize(paths[n]) for n in left) <= diskcache.max_bytes()
    assert diskcache.clear() > 0 and entries(folder) == []


@pytest.mark.parametrize("off", ["env", "function"])
def test_the_cache_off_writes_nothing(folder, monkeypatch, off):
    if off == "env":
        monkeypatch.setenv(diskcache.OFF_ENV, "1")
    else:
        diskcache.set_enabled(False)
    f = Counter()
    for _ in range(2):
        assert diskcache.fetch(NS, {}, f)[2] == diskcache.Status("computed", None, "off")
    assert f.calls == 2 and not folder.exists()
    monkeypatch.setenv(diskcache.OFF_ENV, "0")
    diskcache.set_enabled(None)
    assert diskcache.enabled()


def test_an_unusable_folder_means_computing_quietly(folder, tmp_path, monkeypatch, capsys):
    """A cache "folder" that is a file, an entry that is a folder: the result is computed,
    nothing printed or warned (the suite turns warnings into errors), the status says why."""
    f = Counter()
    entry = Path(diskcache.fetch(NS, {}, f)[2].path)
    entry.unlink()
    entry.mkdir()
    arrays, _, status = diskcache.fetch(NS, {}, f)
    assert arrays is not None and status.source == "computed" and status.path is None
    assert status.note.startswith("bad entry left in place") and "(a folder)" in status.note
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    monkeypatch.setenv(diskcache.DIR_ENV, str(blocker))
    arrays, _, status = diskcache.fetch(NS, {}, f)
    assert arrays is not None and status.source == "computed" and status.path is None
    assert "cannot write the cache" in status.note, status.note
    assert capsys.readouterr() == ("", "") and f.calls == 3


def test_the_suite_never_touches_the_users_cache():
    """tests/conftest.py points the cache at a temporary folder of its own for the run."""
    import tempfile

    assert SUITE_FOLDER and os.path.commonpath([SUITE_FOLDER, tempfile.gettempdir()]) \
        == tempfile.gettempdir(), SUITE_FOLDER


def test_the_folder_follows_the_xdg_rule(monkeypatch, tmp_path):
    monkeypatch.delenv(diskcache.DIR_ENV)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert diskcache.cache_dir() == tmp_path / "eyelab"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/path")     # not absolute: ignored
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert diskcache.cache_dir() == tmp_path / "home" / ".cache" / "eyelab"


def test_no_cache_sets_the_switch_for_the_command_only(monkeypatch, capsys):
    from eyelab.apps import cli

    seen = []
    monkeypatch.setitem(cli._COMMANDS, "analyze", lambda a: seen.append(
        diskcache.enabled()) or 0)
    assert cli.main(["analyze", "--no-cache"]) == 0 and cli.main(["analyze"]) == 0
    assert seen == [False, True] and diskcache.enabled()
    assert cli.main(["cache", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["entries"] == 0
    diskcache.fetch(NS, {}, Counter())
    assert cli.main(["cache"]) == 0 and "entries: 1," in capsys.readouterr().out
    assert cli.main(["cache", "--clear", "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["entries"] == 0 and info["removed_bytes"] > 0


# -- optimised progressive designs -------------------------------------------------------

RX = Prescription(-2.0, add=2.0)
#: A coarse optimisation (a second, not the default's five): the cache's path is the same.
SMALL = Settings(n=9, knots=5, max_iterations=2)
FRESH = """
import json, sys
import numpy as np
from eyelab.jobs.maps import design_origin, design_summary
from eyelab.optics.lens.optimise import Settings, optimised_progressive
from eyelab.optics.eye.prescription import Prescription
lens, _, rep = optimised_progressive(Prescription(-2.0, add=2.0), 2.0, "soft",
                                     settings=Settings(n=9, knots=5, max_iterations=2))
x = np.linspace(-0.03, 0.03, 13)
print(json.dumps({"source": rep["optimised"]["source"], "z": lens.front.z.tolist(),
                  "sag": lens.front.sag(x, x[::-1]).tolist(), "t": lens.center_thickness,
                  "merit_end": rep["optimised"]["merit_end"],
                  "summary": design_summary(design_origin(lens))}))
"""


def _fresh_process(folder) -> dict:
    from freshproc import run_fresh

    return run_fresh(FRESH, folder)


def test_a_design_from_disk_in_a_fresh_process_is_the_computed_lens(folder, monkeypatch):
    monkeypatch.setattr(optimise, "_DESIGNS", None)
    lens, _, rep = optimised_progressive(RX, 2.0, "soft", settings=SMALL)
    o = rep["optimised"]
    assert o["source"] == "computed" and o["cache"]["path"] and os.path.exists(
        o["cache"]["path"])
    assert optimised_progressive(RX, 2.0, "soft", settings=SMALL)[2]["optimised"][
        "source"] == "memory"
    fresh = _fresh_process(folder)
    assert fresh["source"] == "disk"
    assert "from the on-disk cache" in fresh["summary"][0], fresh["summary"]
    np.testing.assert_array_equal(np.array(fresh["z"]), lens.front.z)   # bit for bit
    x = np.linspace(-0.03, 0.03, 13)
    np.testing.assert_array_equal(np.array(fresh["sag"]), lens.front.sag(x, x[::-1]))
    assert fresh["t"] == lens.center_thickness and fresh["merit_end"] == o["merit_end"]


@pytest.mark.parametrize("how", ["deleted", "payload"])
def test_a_missing_or_damaged_design_is_optimised_again(folder, monkeypatch, how):
    from pathlib import Path

    monkeypatch.setattr(optimise, "_DESIGNS", None)
    lens, _, rep = optimised_progressive(RX, 2.0, "soft", settings=SMALL)
    path = Path(rep["optimised"]["cache"]["path"])
    if how == "deleted":
        path.unlink()
    else:
        _damage(path, how)
    monkeypatch.setattr(optimise, "_DESIGNS", None)           # as a new process
    lens2, _, rep2 = optimised_progressive(RX, 2.0, "soft", settings=SMALL)
    o = rep2["optimised"]
    assert o["source"] == "computed" and path.exists()
    assert o["cache"]["note"] is None, o                      # computed and written again
    if how == "deleted":
        assert o["cache"]["replaced"] is None, o
    else:
        assert o["cache"]["replaced"] == "bad entry removed: checksum mismatch", o
    from eyelab.jobs.maps import design_origin, design_summary

    line = design_summary(design_origin(lens2))[0]
    said = "" if how == "deleted" else " (replacing a bad entry: bad entry removed: " \
        "checksum mismatch)"
    assert line.endswith(f"; cached in {path}{said}"), line    # not "not cached: ..."
    np.testing.assert_array_equal(lens2.front.z, lens.front.z)
    monkeypatch.setattr(optimise, "_DESIGNS", None)
    assert optimised_progressive(RX, 2.0, "soft", settings=SMALL)[2]["optimised"][
        "source"] == "disk"


def test_the_maps_command_says_where_the_design_came_from(folder, monkeypatch, tmp_path,
                                                          capsys):
    """``eyelab maps`` of docs/gallery/pal.toml (its optimisation and figures' grid made
    coarse: the path is the same): the first run optimises and says so, the next
    process's (the memory cache emptied) reads the design from disk — in its summary line
    and its JSON — and its maps and figures of merit too, the same numbers."""
    import functools

    from eyelab.apps.cli import main
    from eyelab.jobs import maps

    monkeypatch.setattr(optimise, "Settings", functools.partial(Settings, n=9, knots=5,
                                                                max_iterations=2))
    monkeypatch.setattr(maps, "FIGURES_GRID", {"half_angle_deg": 40.0, "n": 11})
    args = ["maps", "docs/gallery/pal.toml", "--points", "5", "-o", str(tmp_path / "m.png"),
            "--json", str(tmp_path / "m.json")]
    figures = []
    for source, line in (("computed", "in this run"), ("disk", "from the on-disk cache")):
        monkeypatch.setattr(optimise, "_DESIGNS", None)
        monkeypatch.chdir(os.path.dirname(os.path.dirname(__file__)))
        assert main(args) == 0
        out = capsys.readouterr().out
        assert out.startswith("design: optimised as worn (soft)") and line in out, out
        report = json.loads((tmp_path / "m.json").read_text())
        design = report["design"]
        assert design["source"] == source and design["path"].startswith(str(folder))
        for what, key in (("maps", "maps_origin"), ("figures of merit", "figures_origin")):
            assert report[key]["source"] == source
            said = "from the on-disk cache" if source == "disk" else "computed in this run"
            assert f"\n{what}: {said}" in out, out
        figures.append(report["figures"])
    assert figures[1] == figures[0]
