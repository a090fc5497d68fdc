"""The stability benchmark catches wrong answers, not only NaN and crashes: each of four
faults injected into the engine's results is reported (the bench re-derives a random
subset of rows with real-ray bundles, Eq. 13 on the measured wave, rim rays through the
thin eye and an exhaustive path search)."""

from __future__ import annotations

import numpy as np
import pytest

from eyelab.bench import stability
from eyelab.optics.chain.analysis import analyze_points
from eyelab.optics.rays.trace import FATAL, Status

SMALL = {"cases": 1000, "field_configs": 0, "reference_configs": 0}


def _blur_doubled(res):
    res.a *= 2.0
    res.b *= 2.0


def _accommodation_plus_1(res):
    res.accommodation += 1.0


def _vergence_signs_flipped(res):
    for k in ("k11", "k12", "k22"):
        setattr(res.wave_eye, k, -getattr(res.wave_eye, k))


def _half_ok_marked_missed(res):
    ok = np.flatnonzero((res.status & np.uint8(FATAL)) == 0)
    res.status[ok[::2]] |= np.uint8(Status.MISSED)


@pytest.mark.parametrize("fault, counter", [
    (_blur_doubled, "blur_wrong"),
    (_accommodation_plus_1, "accommodation_wrong"),
    (_vergence_signs_flipped, "vergence_wrong"),
    (_half_ok_marked_missed, "missed_wrong"),
])
def test_each_injected_fault_is_reported(monkeypatch, fault, counter):
    def faulty(*args, **kwargs):
        res = analyze_points(*args, **kwargs)
        fault(res)
        return res

    monkeypatch.setattr(stability, "analyze_points", faulty)
    out = stability.run_stability_bench(**SMALL)
    assert out["rederived"][counter] > 0, out["summary"]
    assert not out["all_clear"] and out["summary"][-1] == "FAILURES FOUND"


def test_the_same_run_without_a_fault_is_clear():
    out = stability.run_stability_bench(**SMALL)
    assert out["all_clear"], out["summary"]
    assert out["rederived"]["vergence_checked"] >= 20
