"""A warm public API: :class:`Session` keeps open renderers and built scenes between calls.

Every :func:`eyelab.render` call used to make a new renderer (GL contexts, shaders, its
caches of blur fields, refined meshes and lens texture coordinates) and build the scene
again. A session keeps them:

- **renderers**, by name and quality options (``content_key(renderer, quality)``), at most
  ``max_renderers`` (default 2) and together within a memory bound (below), the least
  recently used idle one closed to make room; a renderer is used by one call at a time
  (calls on the same renderer wait for each other; calls on different ones may overlap);
- **scenes**, by the content of what ``[render] scene`` names (the
  :class:`~eyelab.scene.scene.SceneSource`'s fields; a mesh file's resolved path,
  modification time and size too, so an edited file is loaded again), at most
  ``max_scenes`` (default 4), least recently used first out.

A renderer's caches are keyed by content, so a warm render is the same image as a fresh
renderer's (``tests/test_session.py``), and a spec that changes only the eye or the lens
reuses the scene and the renderer. Each render's report says what the session reused:
``report["cache"]["session"] = {"renderer": "hit" | "miss", "scene": "hit" | "miss"}``
(both eyes' reports for a two-eye spec), and the labels ``"session: renderer"`` and
``"session: scene"`` join the report's ``cache.hits`` or ``cache.misses``.

**Memory bound.** The renderers a session keeps are, by the memory estimate of the largest
render each has done (:func:`eyelab.imaging.memory.estimate_memory`: its base, image,
blur-field and scene parts), together within ``max_memory_gb`` (default
:func:`eyelab.imaging.memory.memory_limit`: ``$EYELAB_MAX_MEMORY_GB``, else half the
machine's memory — the limit one render is checked against); before a render, idle
renderers are closed, least recently used first, until the kept ones and this render's fit.
Scenes are bounded by count only (their arrays are counted in each renderer's estimate).

**Threads.** One lock guards the session's tables and counters; each open renderer has its
own lock, held by the call that uses it. A renderer in use is never closed: one evicted or
closed meanwhile is closed when its call returns. :meth:`Session.close` (or leaving a
``with`` block) closes the idle renderers at once, releasing their GL contexts, and drops
the scenes; afterwards the session refuses work (:class:`SessionClosedError`).

The functions of :mod:`eyelab.jobs.api` (``eyelab.render``, ``analyze``, ``maps``,
``psf``) use :func:`default_session` unless given ``session=``: one per process, made on
first use and closed at interpreter exit (or by :func:`close_default_session`, after which
the next call makes a new one).

>>> import eyelab
>>> with eyelab.Session(max_renderers=1) as session:              # doctest: +SKIP
...     a = session.render(None, width=96, height=72, samples=2)
...     b = session.render({"eye": {"rx": "-1.00 DS"}}, width=96, height=72, samples=2)
>>> a.report["cache"]["session"], b.report["cache"]["session"]   # doctest: +SKIP
({'renderer': 'miss', 'scene': 'miss'}, {'renderer': 'hit', 'scene': 'hit'})
>>> Session().stats()["renderers"]["open"]
0
"""

from __future__ import annotations

import atexit
import contextlib
import dataclasses
import threading
from collections import OrderedDict
from pathlib import Path

from eyelab.core.cache import LRUCache, content_key
from eyelab.core.parallel import close_all
from eyelab.jobs.psf import PITCH_ARCMIN, SIZE
from eyelab.spec import Spec, load_spec, parse_spec

#: Default bounds of a session: open renderers (each holds GL contexts and its caches:
#: about 0.5-1 GiB at 1024 x 768) and built scenes.
MAX_RENDERERS = 2
MAX_SCENES = 4
#: The ranges of a session's bounds (the renderers' memory is bounded apart).
SESSION_LIMITS = {"max_renderers": (1, 64), "max_scenes": (1, 1024)}


class SessionClosedError(RuntimeError):
    """Work asked of a :class:`Session` after :meth:`Session.close`."""


def as_spec(spec=None) -> Spec:
    """A :class:`~eyelab.spec.Spec` from a path (str or :class:`~pathlib.Path`), a spec's
    dict (the TOML's tables), a Spec (returned as is) or None (the built-in default)."""
    if spec is None or isinstance(spec, (str, Path)):
        return load_spec(spec)
    if isinstance(spec, Spec):
        return spec
    if isinstance(spec, dict):
        return parse_spec(spec, "<dict>")
    raise TypeError(f"a spec is a path, a dict, a Spec or None, got {type(spec).__name__}")


def with_render(spec: Spec, overrides: dict) -> Spec:
    """``spec`` with ``[render]`` keys replaced (validated again, errors naming the key)."""
    if not overrides:
        return spec
    gaze = overrides.get("gaze_deg")
    if isinstance(gaze, tuple):
        overrides = dict(overrides, gaze_deg=list(gaze))   # as a TOML array; else checked as is
    return dataclasses.replace(spec, render=spec.render.with_changes(**overrides))


def scene_key(source) -> str:
    """Content key of what ``[render] scene`` names (a
    :class:`~eyelab.scene.scene.SceneSource`, or a bare name or path): the source's fields
    and, for a mesh file, its resolved path, modification time (ns) and size (bytes)."""
    name = str(getattr(source, "name", source))
    path = Path(name)
    stamp = None
    if path.is_file():
        st = path.stat()
        stamp = [str(path.resolve()), st.st_mtime_ns, st.st_size]
    return content_key(source=source, file=stamp)


@dataclasses.dataclass(eq=False)
class _OpenRenderer:
    """A session's renderer: made on first use (``renderer`` None until then), used under
    ``use`` by one call at a time (re-entrant: a thread holding it may render with it
    again). ``bytes``: the largest memory estimate of a render asked
    of it; ``users``: calls holding or waiting for it; ``retired``: out of the session's
    table (evicted or the session closed), closed when its last user is done."""

    name: str
    quality: object
    renderer: object = None
    bytes: float = 0.0
    users: int = 0
    retired: bool = False
    use: threading.RLock = dataclasses.field(default_factory=threading.RLock)

    def close(self) -> None:
        r, self.renderer = self.renderer, None
        if r is not None:
            r.close()


class Session:
    """Open renderers and built scenes, kept between calls.

    Its :meth:`render`, :meth:`analyze`, :meth:`maps` and :meth:`psf` are
    :func:`eyelab.render`, :func:`eyelab.analyze`, :func:`eyelab.maps` and
    :func:`eyelab.psf` with this session's renderers and scenes; those functions use the
    process's default session unless given ``session=``. Rendering a spec again, or with
    another eye or lens, reuses the warm renderer and the built scene: the image a new
    renderer gives, without its start-up. How much it keeps, the memory bound and
    threads: the notes of :mod:`eyelab.jobs.session`.

    Use it as a context manager, or :meth:`close` it, to release its GL contexts.

    Parameters
    ----------
    max_renderers : int
        Open renderers kept (>= 1).
    max_scenes : int
        Built scenes kept (>= 1).
    max_memory_gb : float or None
        Bound, GiB, on the kept renderers' memory estimates together (None:
        :func:`eyelab.imaging.memory.memory_limit` at each render).
    make_renderer : callable or None
        ``make_renderer(name, quality)``: how a missing renderer is made (default
        :func:`eyelab.imaging.registry.make_renderer`).
    build_scene : callable or None
        ``build_scene(source)``: how a missing scene is made (default
        :func:`eyelab.jobs.render.build_scene`).

    Examples
    --------
    >>> import eyelab
    >>> with eyelab.Session(max_renderers=1) as session:
    ...     first = session.render("examples/first.toml", width=64, height=48, samples=2)
    ...     again = session.render("examples/first.toml", width=64, height=48, samples=2)
    >>> first.report["cache"]["session"], again.report["cache"]["session"]
    ({'renderer': 'miss', 'scene': 'miss'}, {'renderer': 'hit', 'scene': 'hit'})
    >>> bool((first.srgb == again.srgb).all()), session.closed
    (True, True)
    """

    def __init__(self, *, max_renderers: int = MAX_RENDERERS, max_scenes: int = MAX_SCENES,
                 max_memory_gb: float | None = None, make_renderer=None, build_scene=None):
        from eyelab.core.checks import check_argument

        max_renderers = check_argument("max_renderers", max_renderers, *SESSION_LIMITS[
            "max_renderers"], integer=True)
        max_scenes = check_argument("max_scenes", max_scenes, *SESSION_LIMITS["max_scenes"],
                                    integer=True)
        if max_memory_gb is not None:
            from eyelab.imaging.memory import memory_limit

            memory_limit(max_memory_gb)                 # checked now, named in the error
        self.max_renderers = max_renderers
        self.max_memory_gb = max_memory_gb
        self._make_renderer = make_renderer
        self._build_scene = build_scene
        self._scenes = LRUCache(max_scenes, "session scenes")
        self._lock = threading.Lock()          # guards everything below
        self._renderers: OrderedDict = OrderedDict()    # key -> _OpenRenderer, LRU first
        self._counts = {"hits": 0, "misses": 0, "evicted": 0}
        self._closed = False

    # ------------------------------------------------------------------ the work
    def render(self, spec=None, *, no_lens: bool = False, **overrides):
        """:func:`eyelab.render` with this session's renderers and scenes: what the spec's
        eye sees (through its lens unless ``no_lens``), or both eyes' images for a two-eye
        spec; ``overrides`` are ``[render]`` keys (``width=320, samples=8``)."""
        from eyelab.imaging.memory import estimate_memory
        from eyelab.jobs.render import render_binocular_spec, render_spec

        self._check_open()
        s = with_render(as_spec(spec), overrides)
        rs = s.render
        scene, scene_hit = self.scene(rs.scene)
        need = estimate_memory(rs.renderer, rs.view, rs.quality, scene)["total"]
        with self.renderer(rs.renderer, rs.quality, estimate_bytes=need) as (r, renderer_hit):
            if s.binocular is not None:
                result = render_binocular_spec(s, no_lens=no_lens, renderer=r, scene=scene)
                reports = [result.report["right"], result.report["left"]]
            else:
                result = render_spec(s, no_lens=no_lens, renderer=r, scene=scene)
                reports = [result.report]
        for report in reports:
            _note_reuse(report, renderer_hit=renderer_hit, scene_hit=scene_hit)
        return result

    def analyze(self, spec=None, *, no_lens: bool = False) -> dict:
        """:func:`eyelab.analyze`: the point analysis of the spec's ``[[points]]`` (no
        renderer or scene: nothing of the session's is needed)."""
        from eyelab.jobs.analyze import analyze_spec

        self._check_open()
        return analyze_spec(as_spec(spec), no_lens=no_lens)

    def maps(self, spec=None, *, half_angle_deg: float = 30.0, n: int = 31,
             eye: str | None = None):
        """:func:`eyelab.maps`: as-worn maps of the spec's lens over an n x n grid of eye
        rotations within ±half_angle_deg (degrees), for its eye's centre of rotation (any
        eye model; of a two-eye spec, the ``eye`` "right" or "left")."""
        from eyelab.core.errors import SpecError
        from eyelab.jobs.maps import lens_wearer
        from eyelab.optics.lens.asworn import as_worn_maps
        from eyelab.spec import no_camera, pick_eye

        self._check_open()
        s = pick_eye(no_camera(as_spec(spec), "maps"), eye, "eyelab.maps", flag="eye")
        if s.lens is None:
            raise SpecError("lens", "the spec has no lens to map")
        return as_worn_maps(lens_wearer(s.eye), s.lens, half_angle_deg=half_angle_deg, n=n,
                            wavelength_nm=s.wavelength_nm)

    def psf(self, spec=None, *, point: int = 0, no_lens: bool = False,
            pitch_arcmin: float = PITCH_ARCMIN, size: int = SIZE, eye: str | None = None
            ) -> tuple:
        """:func:`eyelab.psf`: the eye's point-spread function at the spec's point
        ``point`` (:func:`eyelab.jobs.psf.point_psf`: (psf (3, size, size), report)); of a
        two-eye spec, the ``eye`` "right" or "left"."""
        from eyelab.jobs.psf import point_psf

        self._check_open()
        return point_psf(as_spec(spec), point=point, no_lens=no_lens,
                         pitch_arcmin=pitch_arcmin, size=size, side=eye, side_flag="eye")

    # ------------------------------------------------------------- what it keeps
    def scene(self, source) -> tuple:
        """(scene, hit): the built scene of ``source`` (a
        :class:`~eyelab.scene.scene.SceneSource`, a name or a path), kept by
        :func:`scene_key`; ``hit`` whether it was kept already."""
        self._check_open()
        build = self._build_scene
        if build is None:
            from eyelab.jobs.render import build_scene as build
        return self._scenes.get_or_create(scene_key(source), lambda: build(source))

    @contextlib.contextmanager
    def renderer(self, name: str, quality=None, *, estimate_bytes: float = 0.0):
        """Lend this session's renderer ``name`` with options ``quality`` (None: the
        defaults) for a ``with`` block, as ``(renderer, hit)`` (``hit``: it was open
        already); other calls for it wait until the block ends. ``estimate_bytes``: the
        memory estimate of what it will render (the memory bound makes room for it)."""
        from eyelab.imaging.registry import QUALITIES, make_renderer

        if quality is None and name in QUALITIES:
            quality = QUALITIES[name]()
        key = content_key(renderer=name, quality=quality)
        limit = self._memory_limit()
        with self._lock:
            self._check_open()
            entry = self._renderers.get(key)
            if entry is None:
                entry = self._renderers[key] = _OpenRenderer(name, quality)
            self._renderers.move_to_end(key)
            entry.users += 1
            entry.bytes = max(entry.bytes, float(estimate_bytes))
            stale = self._make_room(limit)
        try:
            close_all(stale)
            with entry.use:
                hit = entry.renderer is not None
                if not hit:
                    entry.renderer = (self._make_renderer or make_renderer)(name, quality)
                with self._lock:
                    self._counts["hits" if hit else "misses"] += 1
                yield entry.renderer, hit
        finally:
            with self._lock:
                entry.users -= 1
                done = entry.users == 0 and (entry.retired or entry.renderer is None)
                if done and not entry.retired:     # making it failed: forget it
                    self._renderers.pop(key, None)
            if done:
                entry.close()

    def _make_room(self, limit: float) -> list:
        """Under the lock: take idle renderers out of the table, least recently used first,
        while it holds more than ``max_renderers`` or their estimates add up to more than
        ``limit`` bytes; returns them, to be closed once the lock is released."""
        stale = []
        for key, e in list(self._renderers.items()):
            over = (len(self._renderers) > self.max_renderers
                    or sum(x.bytes for x in self._renderers.values()) > limit)
            if not over:
                break
            if e.users == 0:
                del self._renderers[key]
                e.retired = True
                stale.append(e)
                self._counts["evicted"] += 1
        return stale

    def _memory_limit(self) -> float:
        from eyelab.imaging.memory import memory_limit

        return memory_limit(self.max_memory_gb)

    def stats(self) -> dict:
        """What the session holds: {"renderers": {"open", "max", "estimate_bytes",
        "limit_bytes", "hits", "misses", "evicted", "kinds": [(name, quality), ...]
        least recently used first}, "scenes": the scene cache's
        :meth:`~eyelab.core.cache.LRUCache.stats`, "closed"}."""
        limit = self._memory_limit()
        with self._lock:
            kept = list(self._renderers.values())
            renderers = {"open": sum(e.renderer is not None for e in kept),
                         "max": self.max_renderers,
                         "estimate_bytes": sum(e.bytes for e in kept), "limit_bytes": limit,
                         **self._counts, "kinds": [(e.name, e.quality) for e in kept]}
            closed = self._closed
        return {"renderers": renderers, "scenes": self._scenes.stats(), "closed": closed}

    # ------------------------------------------------------------------ closing
    @property
    def closed(self) -> bool:
        """Whether :meth:`close` has been called."""
        return self._closed

    def _check_open(self) -> None:
        if self._closed:
            raise SessionClosedError("this eyelab.Session is closed: make a new one "
                                     "(eyelab.Session()), or pass session=None for the "
                                     "default session")

    def close(self) -> None:
        """Close the idle renderers now (their GL contexts and caches) and each one in use
        when its call returns, and drop the scenes; the session then refuses work. Safe to
        call repeatedly."""
        with self._lock:
            self._closed = True
            entries = list(self._renderers.values())
            self._renderers.clear()
            for e in entries:
                e.retired = True
            idle = [e for e in entries if e.users == 0]
        self._scenes.clear()
        close_all(idle)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __repr__(self) -> str:
        if self._closed:
            return "<eyelab.Session closed>"
        st = self.stats()
        return (f"<eyelab.Session {st['renderers']['open']} of {self.max_renderers} "
                f"renderers, {st['scenes']['entries']} of {st['scenes']['maxsize']} scenes>")


def _note_reuse(report: dict, *, renderer_hit: bool, scene_hit: bool) -> None:
    """State in a render's ``report`` what its session reused."""
    cache = report.setdefault("cache", {"hits": [], "misses": []})
    cache["session"] = {"renderer": "hit" if renderer_hit else "miss",
                        "scene": "hit" if scene_hit else "miss"}
    for what, hit in (("renderer", renderer_hit), ("scene", scene_hit)):
        cache.setdefault("hits" if hit else "misses", []).append(f"session: {what}")


_DEFAULT: Session | None = None
_DEFAULT_LOCK = threading.Lock()
_AT_EXIT = False


def default_session() -> Session:
    """The process's shared session (what ``session=None`` means): made on first use, or
    anew after :func:`close_default_session`; closed at interpreter exit."""
    global _DEFAULT, _AT_EXIT
    with _DEFAULT_LOCK:
        if _DEFAULT is None or _DEFAULT.closed:
            _DEFAULT = Session()
            if not _AT_EXIT:
                atexit.register(close_default_session)
                _AT_EXIT = True
        return _DEFAULT


def close_default_session() -> bool:
    """Close the default session (its renderers' GL contexts), if one is open; the next
    call without ``session=`` makes a new one. Returns whether there was one."""
    global _DEFAULT
    with _DEFAULT_LOCK:
        s, _DEFAULT = _DEFAULT, None
    if s is None:
        return False
    s.close()
    return True


def session_or_default(session: Session | None) -> Session:
    """``session``, or the default one for None."""
    if session is None:
        return default_session()
    if not isinstance(session, Session):
        raise TypeError(f"session must be an eyelab.Session or None, got "
                        f"{type(session).__name__}")
    return session
