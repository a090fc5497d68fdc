"""The default-quality frames, old against new: the built-in spec's eye (at 1024 x 768 in
``eyelab bench render``) uncorrected, through its lens and made emmetropic, warm frames,
and the public API's first and second call (:data:`FRAME_KINDS`), each code version in
its own process, the versions' processes interleaved so that they share the machine's
noise (``eyelab bench render --against REF``). An earlier version is checked out with ``git
worktree`` into a temporary folder and imported from there (``PYTHONPATH``; this version
likewise from its own folder); it must have ``eyelab.jobs.api.as_spec`` / ``with_render``,
``eyelab.jobs.render.render_spec`` and ``eyelab.imaging.registry.make_renderer``, or the
run stops with a one-line error naming ``--against``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from contextlib import contextmanager, nullcontext, suppress
from pathlib import Path

import eyelab
from eyelab.core.errors import SpecError

#: The frame measured: the built-in spec at this size, at its renderer's defaults.
DEFAULT_FRAME_SIZE = (1024, 768)

#: The frames timed, each a warm frame of the built-in spec: its eye uncorrected (a
#: blurred far field), through its lens (the wearer corrected: blur below a pixel over most
#: of the view), and its emmetrope (everything but the nearest floor in focus); and
#: ``eyelab.render`` of the spec called twice in a row (the public API: the second call is
#: what a notebook pays for each new image); and the Navarro schematic eye of the spec's
#: spherical equivalent through its lens (its retinal image: ray-aberration fields).
FRAME_KINDS = ("uncorrected", "corrected_through_lens", "emmetrope", "api_first_call",
               "api_second_call", "schematic_through_lens")

#: Run in a fresh process of one code version: warm frames of the default spec (uncorrected,
#: through the lens, the emmetrope), alternating; then the public API called twice; prints
#: one JSON line (all times, the quality).
FRAME_SCRIPT = r"""
import dataclasses, json, sys, time
import eyelab
from eyelab.jobs.api import as_spec, with_render
from eyelab.jobs.render import render_spec, _emmetrope
from eyelab.imaging.registry import make_renderer
w, h, repeats = json.loads(sys.argv[1])
spec = with_render(as_spec(None), dict(width=w, height=h))
emm = dataclasses.replace(spec, eye=_emmetrope(spec.eye))
rs = spec.render
cases = (("uncorrected", spec, True), ("corrected_through_lens", spec, False),
         ("emmetrope", emm, True))
times = {k: [] for k, _, _ in cases}
from eyelab.jobs.render import build_scene
from eyelab.optics.eye.prescription import Prescription
from eyelab.optics.eye.schematic import SchematicEye
from eyelab.optics.lens.spectacle import SpectacleLens
se = Prescription(spec.lens.rx.sphere + spec.lens.rx.cylinder / 2)
schematic = (SchematicEye.from_rx(se, pupil_diameter=spec.eye.pupil_diameter,
                                  accommodation_max=min(10.0, spec.eye.accommodation_max)),
             SpectacleLens.from_rx(se, pose=spec.lens.pose), build_scene(rs.scene))
times["schematic_through_lens"] = []
# the schematic eye on a renderer of its own (its caches apart from the thin eye's)
with make_renderer(rs.renderer, rs.quality) as r, \
        make_renderer(rs.renderer, rs.quality) as rsch:
    for _, s, no_lens in cases:                       # cold frames: caches and shaders
        render_spec(s, no_lens=no_lens, renderer=r)
    rsch.render(schematic[2], schematic[0], schematic[1], rs.view)
    for _ in range(repeats):
        for label, s, no_lens in cases:
            t = time.perf_counter()
            render_spec(s, no_lens=no_lens, renderer=r)
            times[label].append(time.perf_counter() - t)
        t = time.perf_counter()
        rsch.render(schematic[2], schematic[0], schematic[1], rs.view)
        times["schematic_through_lens"].append(time.perf_counter() - t)
for label in ("api_first_call", "api_second_call"):
    t = time.perf_counter()
    eyelab.render(None, width=w, height=h)
    times[label] = [time.perf_counter() - t]
q = rs.quality
print(json.dumps({"times_s": times,
                  "quality": {k: getattr(q, k) for k in ("samples", "reconstruct",
                                                         "env_oversample", "chromatic")
                              if hasattr(q, k)}}))
"""


def _git(*args, cwd) -> str:
    """git's output; a failure (or no git) is a SpecError naming ``--against``, with the
    last line git wrote."""
    try:
        out = subprocess.run(["git", *args], cwd=cwd, capture_output=True, text=True)
    except OSError as e:
        raise SpecError("--against", f"cannot run git: {e.strerror or e}") from None
    if out.returncode != 0:
        last = (out.stderr.strip().splitlines() or ["failed"])[-1]
        raise SpecError("--against", f"git {args[0]}: {last}")
    return out.stdout.strip()


def _checkout() -> Path:
    """The folder eyelab is imported from (a git checkout's top, for ``--against``)."""
    return Path(eyelab.__file__).resolve().parent.parent


@contextmanager
def worktree(ref: str):
    """A temporary ``git worktree`` of ``ref`` of the checkout eyelab is imported from;
    yields (its folder, the commit). Refused (SpecError) outside a git checkout. Worktrees
    left registered by an interrupted run are pruned first."""
    here = _checkout()
    if not (here / ".git").exists():
        raise SpecError("--against", f"needs eyelab imported from a git checkout, not {here}")
    commit = _git("rev-parse", "--verify", f"{ref}^{{commit}}", cwd=here)
    _git("worktree", "prune", cwd=here)
    with tempfile.TemporaryDirectory(prefix="eyelab-against-") as tmp:
        path = Path(tmp) / "tree"
        _git("worktree", "add", "--detach", str(path), commit, cwd=here)
        try:
            yield path, commit
        finally:            # never masks what happened inside; prune sweeps up after
            with suppress(SpecError):
                _git("worktree", "remove", "--force", str(path), cwd=here)


def _frames(root, size, repeats, ref=None) -> dict:
    """One process of the code at ``root`` (put first on ``PYTHONPATH``): FRAME_SCRIPT's
    result. A failure of an earlier version's process (``ref``) is a SpecError naming
    ``--against`` with the process's last line."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(root)] + [p for p in env.get(
        "PYTHONPATH", "").split(os.pathsep) if p])
    with tempfile.TemporaryDirectory() as cwd:
        out = subprocess.run([sys.executable, "-P", "-c", FRAME_SCRIPT,
                              json.dumps([size[0], size[1], repeats])],
                             cwd=cwd, env=env, capture_output=True, text=True)
    if out.returncode != 0:
        last = (out.stderr.strip().splitlines() or ["no output"])[-1]
        if ref is not None:
            raise SpecError("--against", f"{ref}: cannot time its default frame: {last}")
        raise RuntimeError(f"the default-frame process failed: {last}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def default_frames(against: str | None = None, *, size=DEFAULT_FRAME_SIZE, repeats=3,
                   rounds=2, progress=None) -> dict:
    """Best time (s) of each of :data:`FRAME_KINDS` for this code ("new") and, with
    ``against`` (a git ref), for that version ("old"), with each version's
    :func:`frame_ratios` and the ratios new / old. ``rounds`` processes per version,
    interleaved (old, new, old, new, ...), ``repeats`` frames of each kind in each."""
    runs = {"new": []}
    with (worktree(against) if against else nullcontext()) as tree:
        roots = {"new": _checkout()}
        if tree is not None:
            roots = {"old": tree[0], "new": _checkout()}
            runs["old"] = []
        for _ in range(rounds):
            for label, root in roots.items():
                runs[label].append(_frames(root, size, repeats,
                                           against if label == "old" else None))
                if progress is not None:
                    progress.update(1)
    out = {"size": list(size), "repeats": repeats, "rounds": rounds, "kinds": FRAME_KINDS}
    for label, results in runs.items():
        out[label] = {kind: min(t for r in results for t in r["times_s"][kind])
                      for kind in FRAME_KINDS}
        out[label]["quality"] = results[0]["quality"]
        out[label]["ratios"] = frame_ratios(out[label])
    if against:
        out["against"] = {"ref": against, "commit": tree[1]}
        out["new_over_old"] = {k: out["new"][k] / out["old"][k] for k in FRAME_KINDS}
    return out


def frame_ratios(best: dict) -> dict:
    """What the frames say about cost following the scene (best times of one version): the
    emmetrope's frame over the uncorrected one (a sharp view should cost a fraction of a
    blurred one), and the API's second call over the warm frame through the lens (the
    same image: a warm API adds next to nothing)."""
    return {"emmetrope_over_uncorrected": best["emmetrope"] / best["uncorrected"],
            "api_second_over_warm": best["api_second_call"] / best["corrected_through_lens"],
            "api_first_over_warm": best["api_first_call"] / best["corrected_through_lens"]}
