"""The warm public API (:class:`eyelab.Session`): renderers and scenes kept between calls
give the same images as a fresh renderer, the reports say what was reused, the bounds
close what they evict, a closed session refuses work, and threads share one session.

Images are small (96 x 72, S = 2) and every test holds its own session (closed when it
ends), except those of the default session, which ``conftest.py`` closes after each test.
"""

from __future__ import annotations

import threading

import numpy as np
import pytest

import eyelab
from eyelab.imaging.contract import RenderResult, new_report
from eyelab.imaging.memory import GIB, estimate_memory
from eyelab.imaging.registry import make_renderer
from eyelab.jobs import session as session_module
from eyelab.jobs.render import build_scene, render_binocular_spec, render_spec
from eyelab.jobs.session import Session, SessionClosedError, as_spec, with_render

SMALL = dict(width=96, height=72, samples=2)


def _spec(rx: str = "-1.00 DS") -> dict:
    """A one-eye spec (dict) whose eye and lens have ``rx``."""
    return {"eye": {"rx": rx}, "lens": {"rx": rx}}


def fresh(spec, **overrides):
    """The image a new renderer and a newly built scene give (what ``eyelab.render`` gave
    before sessions): one eye's (h, w, 3) uint8, or both eyes' as a pair."""
    s = with_render(as_spec(spec), dict(SMALL, **overrides))
    if s.binocular is not None:
        res = render_binocular_spec(s)
        return res.right.srgb, res.left.srgb
    return render_spec(s).srgb


def reuse(result) -> dict:
    return result.report["cache"]["session"]


class Spy:
    """``make_renderer`` for a session that remembers what it made and counts closes."""

    def __init__(self):
        self.made, self.closed = [], []

    def __call__(self, name, quality):
        r = make_renderer(name, quality)
        close = r.close

        def spied_close():
            self.closed.append(r)
            close()

        r.close = spied_close
        self.made.append(r)
        return r


class FakeRenderer:
    """A renderer without GL (for the bounds): a black image of the view's size."""

    name = "raster"

    def __init__(self, quality):
        self.quality = quality
        self.open = True

    def render(self, scene, eye, lens, view, quality=None):
        srgb = np.zeros((view.height, view.width, 3), np.uint8)
        return RenderResult(new_report(self.name, view, quality or self.quality), srgb=srgb)

    def close(self):
        self.open = False


def fakes() -> tuple:
    made = []

    def make(name, quality):
        made.append(FakeRenderer(quality))
        return made[-1]

    return made, make


# ------------------------------------------------------------------- same images
def test_first_and_second_render_are_a_fresh_renderers_image_and_the_second_reuses():
    expected = fresh(None)
    with Session() as session:
        first = session.render(None, **SMALL)
        second = session.render(None, **SMALL)
    np.testing.assert_array_equal(first.srgb, expected)
    np.testing.assert_array_equal(second.srgb, expected)
    assert reuse(first) == {"renderer": "miss", "scene": "miss"}
    assert reuse(second) == {"renderer": "hit", "scene": "hit"}
    assert {"session: renderer", "session: scene"} <= set(second.report["cache"]["hits"])
    assert {"session: renderer", "session: scene"} <= set(first.report["cache"]["misses"])


def test_a_spec_that_changes_only_the_eyes_rx_reuses_the_scene_and_the_renderer():
    with Session() as session:
        a = session.render(_spec("-1.00 DS"), **SMALL)
        b = session.render(_spec("-2.50 / -0.75 x 90"), **SMALL)
    assert reuse(a) == {"renderer": "miss", "scene": "miss"}
    assert reuse(b) == {"renderer": "hit", "scene": "hit"}
    # the warm renderer's caches are keyed by content: the new eye's image is a fresh one's
    np.testing.assert_array_equal(b.srgb, fresh(_spec("-2.50 / -0.75 x 90")))
    assert not np.array_equal(a.srgb, b.srgb)


def test_a_two_eye_spec_gives_the_same_images_and_both_reports_say_what_was_reused():
    spec = {"binocular": {"pd_mm": 64}, "eye": {"rx": "-1.00 DS"}, "lens": {"rx": "-1.00 DS"}}
    right, left = fresh(spec)
    with Session() as session:
        session.render(spec, **SMALL)
        again = session.render(spec, **SMALL)
    np.testing.assert_array_equal(again.right.srgb, right)
    np.testing.assert_array_equal(again.left.srgb, left)
    for side in ("right", "left"):
        assert again.report[side]["cache"]["session"] == {"renderer": "hit", "scene": "hit"}


def test_another_scene_is_a_scene_miss_on_the_same_renderer():
    with Session() as session:
        session.render(None, **SMALL)
        chart = session.render(None, scene="chart", **SMALL)
    assert reuse(chart) == {"renderer": "hit", "scene": "miss"}


# ------------------------------------------------------------------ the default one
def test_the_api_functions_share_the_default_session_unless_given_one():
    a = eyelab.render(None, **SMALL)
    b = eyelab.render(None, **SMALL)
    assert (reuse(a), reuse(b)) == ({"renderer": "miss", "scene": "miss"},
                                    {"renderer": "hit", "scene": "hit"})
    default = session_module.default_session()
    with eyelab.Session() as own:
        c = eyelab.render(None, session=own, **SMALL)
        assert reuse(c) == {"renderer": "miss", "scene": "miss"}
        assert own.stats()["renderers"]["open"] == 1
    np.testing.assert_array_equal(c.srgb, a.srgb)
    assert session_module.close_default_session() and default.closed
    assert session_module.default_session() is not default     # a new one on next use
    assert reuse(eyelab.render(None, **SMALL))["renderer"] == "miss"
    with pytest.raises(TypeError, match="eyelab.Session"):
        eyelab.render(None, session="mine")


def test_analyze_maps_and_psf_take_a_session_and_give_what_they_gave():
    from eyelab.jobs.analyze import analyze_spec
    from eyelab.jobs.psf import point_psf

    spec = eyelab.load_spec(None)
    with Session() as session:
        assert eyelab.analyze(None, session=session) == analyze_spec(spec)
        m = eyelab.maps(None, n=5, session=session)
        image, report = eyelab.psf(None, size=33, session=session)
    assert m.mean_error_d.shape == (5, 5)
    expected, _ = point_psf(spec, size=33)
    np.testing.assert_array_equal(image, expected)
    assert report["size_px"] == 33


# ---------------------------------------------------------------------- closing
def test_close_releases_the_renderers_and_a_closed_session_refuses_work():
    spy = Spy()
    with Session(make_renderer=spy) as session:
        session.render(None, **SMALL)
        session.render(None, samples=3, width=96, height=72)
        assert len(spy.made) == 2 and spy.closed == []
    assert session.closed and sorted(map(id, spy.closed)) == sorted(map(id, spy.made))
    assert session.stats()["renderers"]["open"] == 0
    assert session.stats()["scenes"]["entries"] == 0
    for call in (lambda: session.render(None, **SMALL), lambda: session.analyze(None),
                 lambda: session.maps(None), lambda: session.psf(None),
                 lambda: eyelab.analyze(None, session=session)):
        with pytest.raises(SessionClosedError, match="Session is closed: make a new one"):
            call()
    session.close()                                       # again: nothing more to do
    assert len(spy.closed) == 2


def test_a_renderer_in_use_is_closed_when_its_call_returns():
    made, make = fakes()
    session = Session(make_renderer=make)
    with session.renderer("raster") as (r, hit):
        assert not hit
        session.close()
        assert r.open                       # still in use
    assert not r.open and made == [r]


def test_a_renderer_that_cannot_be_made_leaves_nothing_behind():
    def broken(name, quality):
        raise RuntimeError("no GL")

    with Session(make_renderer=broken) as session:
        with pytest.raises(RuntimeError, match="no GL"):
            session.render(None, **SMALL)
        assert session.stats()["renderers"]["kinds"] == []


# ----------------------------------------------------------------------- bounds
def test_more_renderer_configurations_than_the_bound_close_the_oldest():
    made, make = fakes()
    with Session(max_renderers=2, make_renderer=make) as session:
        for samples in (2, 3, 4):
            session.render(None, width=96, height=72, samples=samples)
        assert [r.open for r in made] == [False, True, True]
        st = session.stats()["renderers"]
        assert st["open"] == 2 and st["evicted"] == 1
        assert [q.samples for _, q in st["kinds"]] == [3, 4]
        again = session.render(None, width=96, height=72, samples=2)
        assert reuse(again)["renderer"] == "miss"       # it was closed: made anew
        assert [r.open for r in made] == [False, False, True, True]


def test_the_memory_bound_closes_renderers_whose_estimates_would_exceed_it():
    made, make = fakes()
    s = with_render(as_spec(None), SMALL)
    rs = s.render
    need = estimate_memory(rs.renderer, rs.view, rs.quality, build_scene(rs.scene))["total"]
    with Session(max_renderers=4, max_memory_gb=1.5 * need / GIB,
                 make_renderer=make) as session:
        session.render(None, **SMALL)
        session.render(None, width=96, height=72, samples=3)    # two would not fit
        assert [r.open for r in made] == [False, True]
        st = session.stats()["renderers"]
        assert st["estimate_bytes"] <= st["limit_bytes"] and st["evicted"] == 1


def test_scenes_are_bounded_least_recently_used_first():
    made, make = fakes()
    with Session(max_scenes=2, make_renderer=make) as session:
        for scene in ("room", "chart", "page", "room"):
            res = session.render(None, scene=scene, **SMALL)
        assert reuse(res)["scene"] == "miss"                   # "room" was pushed out
        assert session.stats()["scenes"]["entries"] == 2


def test_a_mesh_file_edited_on_disk_is_loaded_again(tmp_path):
    import os

    mesh = tmp_path / "tri.obj"
    mesh.write_text("v 0 0 -1\nv 1 0 -1\nv 0 1 -1\nf 1 2 3\n")
    with Session(make_renderer=fakes()[1]) as session:
        first, hit = session.scene(str(mesh))
        assert not hit and session.scene(str(mesh)) == (first, True)
        mesh.write_text("v 0 0 -2\nv 1 0 -2\nv 0 1 -2\nf 1 2 3\n")
        os.utime(mesh, ns=(1, 1))
        second, hit = session.scene(str(mesh))
    assert not hit and second.content_key != first.content_key


# ---------------------------------------------------------------------- threads
def test_two_threads_rendering_at_once_get_the_sequential_images():
    """Two eyes on one renderer (its calls wait for each other) and a third call on
    another renderer, all at once, from a cold session: each image is the one a fresh
    renderer gives."""
    cases = [(_spec("-1.00 DS"), 2), (_spec("-3.00 DS"), 2), (_spec("-2.00 DS"), 3)]
    out, errors = [None] * len(cases), []

    def go(i, spec, samples):
        try:
            out[i] = session.render(spec, width=96, height=72, samples=samples)
        except BaseException as e:      # re-raised below, on the test's thread
            errors.append(e)

    with Session() as session:
        threads = [threading.Thread(target=go, args=(i, *c)) for i, c in enumerate(cases)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        if errors:
            raise errors[0]
        st = session.stats()
    assert st["renderers"]["open"] == 2 and st["scenes"]["entries"] == 1
    for res, (spec, samples) in zip(out, cases, strict=True):
        np.testing.assert_array_equal(res.srgb, fresh(spec, samples=samples))
