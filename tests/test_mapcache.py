"""As-worn maps and figures of merit on disk (eyelab/optics/lens/mapcache.py): a fresh process
reads back the maps bit for bit and the very figures this one computed, a damaged entry
(a flipped bit, a FIFO, a link to /dev/zero) is computed again and written over, and an
eye or lens without a complete content key is never cached (eyelab/core/cache.py:
complete_key refuses what only a repr could stand for)."""

from __future__ import annotations

import dataclasses
import os
import signal
from pathlib import Path

import numpy as np
import pytest

from eyelab.core import diskcache
from eyelab.core.cache import complete_key, content_key
from eyelab.jobs.maps import figures_and_origin, named_maps, origin_summary
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.thin import Eye
from eyelab.optics.lens import mapcache
from eyelab.optics.lens.optimise import Settings, optimised_progressive
from eyelab.optics.rays.surfaces import FreeForm, Surface

#: A coarse optimised design (tests/test_diskcache.py's), small grids: the path is the same.
SMALL = Settings(n=9, knots=5, max_iterations=2)
GRID = {"half_angle_deg": 40.0, "n": 11}
MAPS = {"half_angle_deg": 30.0, "n": 5}
FRESH = f"""
import json
from eyelab.jobs.maps import figures_and_origin, named_maps
from eyelab.optics.eye.thin import Eye
from eyelab.optics.lens.optimise import Settings, optimised_progressive
from eyelab.optics.eye.prescription import Prescription
lens, _, _ = optimised_progressive(Prescription(-2.0, add=2.0), 2.0, "soft",
                                   settings=Settings(n=9, knots=5, max_iterations=2))
maps, maps_origin = named_maps(Eye(), lens, **{MAPS!r})
figures, figures_origin = figures_and_origin(Eye(), lens, **{GRID!r})
print(json.dumps({{"figures": figures, "figures_origin": figures_origin,
                  "maps_origin": maps_origin, "mean_error_d": maps.mean_error_d.tolist(),
                  "surface": {{k: v.tolist() for k, v in maps.surface.items()}},
                  "marks": maps.marks, "ok": maps.ok.tolist()}}))
"""


@pytest.fixture(autouse=True)
def folder(tmp_path, monkeypatch):
    """A cache folder of the test's own, the cache on."""
    d = tmp_path / "cache"
    monkeypatch.setenv(diskcache.DIR_ENV, str(d))
    monkeypatch.delenv(diskcache.OFF_ENV, raising=False)
    monkeypatch.setattr(diskcache, "_enabled", None)
    return d


@pytest.fixture(scope="module")
def lens():
    return optimised_progressive(Prescription(-2.0, add=2.0), 2.0, "soft", settings=SMALL)[0]


def _fresh_process(folder) -> dict:
    from freshproc import run_fresh

    return run_fresh(FRESH, folder)


def test_a_fresh_process_reads_the_same_maps_and_figures(folder, lens):
    maps, m_origin = named_maps(Eye(), lens, **MAPS)
    figures, f_origin = figures_and_origin(Eye(), lens, **GRID)
    assert (m_origin["source"], f_origin["source"]) == ("computed", "computed")
    assert m_origin["note"] is None and os.path.exists(f_origin["path"])
    assert origin_summary("figures of merit", f_origin)[0].endswith(f"cached in "
                                                                     f"{f_origin['path']}")
    fresh = _fresh_process(folder)
    assert fresh["maps_origin"] == dict(m_origin, source="disk")
    assert fresh["figures_origin"] == dict(f_origin, source="disk")
    assert fresh["figures"] == figures                          # every number, exactly
    assert figures["kind"] == "progressive" and figures["grid"]["step_deg"] == 8.0
    np.testing.assert_array_equal(np.array(fresh["mean_error_d"], float), maps.mean_error_d)
    for k, v in maps.surface.items():
        np.testing.assert_array_equal(np.array(fresh["surface"][k], float), v)
    np.testing.assert_array_equal(np.array(fresh["ok"]), maps.ok)
    assert {k: tuple(v) for k, v in fresh["marks"].items()} == maps.marks
    # and in this process: the maps as the computed ones, field by field
    again, origin = named_maps(Eye(), lens, **MAPS)
    assert origin["source"] == "disk" and again.model == maps.model
    for f in dataclasses.fields(maps):
        a, b = getattr(again, f.name), getattr(maps, f.name)
        if isinstance(a, np.ndarray):
            assert a.dtype == b.dtype
            np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(again.objects.distance, maps.objects.distance)
    np.testing.assert_array_equal(again.objects.direction, maps.objects.direction)
    assert origin_summary("maps", origin) == [f"maps: from the on-disk cache ({origin['path']})"]


def _expired(signum, frame):
    raise TimeoutError("still reading the entry after 30 s")


@pytest.mark.parametrize("how, why", [
    ("flipped bit", "checksum mismatch"), ("fifo", "not a regular file (a FIFO)"),
    ("link to /dev/zero", "not a regular file (a symbolic link)")])
def test_a_damaged_figures_entry_is_computed_again(folder, lens, how, why):
    """A flipped bit, a FIFO (a read would block for ever), a link to /dev/zero (a read
    would never end): the figures are computed again and written over it — and said so
    (tests/test_diskcache.py damages entries every other way)."""
    figures, origin = figures_and_origin(Eye(), lens, **GRID)
    path = Path(origin["path"])
    if how == "flipped bit":
        data = bytearray(path.read_bytes())
        data[len(data) // 2] ^= 0x01
        path.write_bytes(bytes(data))
    else:
        path.unlink()
        if how == "fifo":
            os.mkfifo(path)
        else:
            path.symlink_to("/dev/zero")
    signal.signal(signal.SIGALRM, _expired)           # fail, never hang
    signal.alarm(30)
    try:
        again, origin2 = figures_and_origin(Eye(), lens, **GRID)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, signal.SIG_DFL)
    assert origin2 == dict(origin, replaced=f"bad entry removed: {why}"), origin2
    assert origin_summary("figures of merit", origin2) == [
        f"figures of merit: computed in this run; cached in {path} (replacing a bad entry: "
        f"bad entry removed: {why})"]
    assert again == figures and path.is_file() and not path.is_symlink()
    third, origin3 = figures_and_origin(Eye(), lens, **GRID)   # written again, whole
    assert origin3 == dict(origin, source="disk") and third == figures


class Unkeyed(Surface):
    """Another surface's shape behind an object with no content key."""

    def __init__(self, inner):
        self.inner = inner

    @property
    def seed_curvature(self) -> float:
        return self.inner.seed_curvature

    def derivatives(self, x, y):
        return self.inner.derivatives(x, y)


def test_an_eye_or_lens_without_a_complete_key_is_never_cached(folder, lens):
    odd = dataclasses.replace(lens, back=Unkeyed(lens.back))
    assert complete_key(lens=odd) is None
    origins = [named_maps(Eye(), odd, **MAPS)[1] for _ in range(2)]
    origins.append(figures_and_origin(Eye(), odd, **GRID)[1])
    assert origins == [diskcache.Status("computed", note=mapcache.INCOMPLETE).to_json()] * 3
    assert not folder.exists()
    origin = origins[0]
    assert origin_summary("maps", origin) == [f"maps: computed in this run; "
                                              f"{mapcache.INCOMPLETE}"]


class Rounded:
    """A value whose repr rounds it."""

    def __init__(self, v: float):
        self.v = v

    def __repr__(self):
        return f"Rounded({self.v:.2f})"


def test_a_complete_key_takes_nothing_by_its_repr():
    """What content_key takes by its repr, which may round or abridge (two different
    values, one key), gets no complete key; a FreeForm keys by its whole grid (its repr
    shows only the grid's ends and a digest prefix of its sags); numbers that compute
    differently (a float32, an int) and text keep their types."""
    assert content_key(x=Rounded(1.001)) == content_key(x=Rounded(1.002))
    assert complete_key(x=Rounded(1.001)) is None
    g = np.linspace(-0.03, 0.03, 9)
    g2 = g.copy()
    g2[3] += 1e-4
    a, b = (FreeForm(x, g, np.zeros((9, 9))) for x in (g, g2))
    assert repr(a) == repr(b) and None is not complete_key(s=a) != complete_key(s=b)
    assert complete_key(f=len) is None and complete_key(d={1: 2.0}) is None
    assert complete_key(a=np.array([object()], dtype=object)) is None
    assert len({complete_key(x=v) for v in (1.0, 1, np.float32(1.0), True, "1.0")}) == 5
