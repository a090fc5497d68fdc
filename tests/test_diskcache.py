"""The on-disk cache (eyelab/core/diskcache.py): entries round-trip bit for bit, are keyed
by eyelab's version, are never trusted when truncated, corrupt or pickled, survive
concurrent writers whole, stay within their bound and are not written when the cache is
off; an optimised progressive design read back in a fresh process is the computed lens,
and a damaged entry is optimised again."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import numpy as np
import pytest

import eyelab
from eyelab.core import diskcache
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
    assert s2.note.startswith("bad entry removed"), s2.note
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


def test_an_unusable_folder_means_computing_quietly(tmp_path, monkeypatch, capsys):
    """A cache "folder" that is a file: the result is computed, nothing printed or warned
    (the suite turns warnings into errors), the status says why."""
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    monkeypatch.setenv(diskcache.DIR_ENV, str(blocker))
    f = Counter()
    arrays, _, status = diskcache.fetch(NS, {}, f)
    assert arrays is not None and status.source == "computed" and status.path is None
    assert "cannot write the cache" in status.note, status.note
    assert capsys.readouterr() == ("", "")


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
    if how == "deleted":
        assert o["cache"]["note"] is None, o
    else:
        assert o["cache"]["note"].startswith("bad entry removed: checksum"), o
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
