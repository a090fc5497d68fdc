"""One eye state: [eye] accommodation_d is honoured by analyze and render alike (and
survives command-line overrides); the old keys say where they moved."""

from __future__ import annotations

import numpy as np
import pytest

from eyelab.blur import compute_blur_field
from eyelab.core.errors import SpecError
from eyelab.optics.chain.analysis import analyze_points
from eyelab.optics.rays.paths import ObjectPoints
from eyelab.spec import parse_spec

SPEC = {"eye": {"accommodation_max_d": 4.0, "accommodation_d": 2.5},
        "render": {"scene": "chart", "width": 96, "height": 72, "fov_y_deg": 4.0,
                   "samples": 4}}


def test_render_blurs_the_far_chart_as_analyze_says():
    """An emmetrope holding 2.5 D of accommodation looks at the 6 m chart: the render's blur
    field at the chart is analyze's blur for the chart's centre (the same state reaches
    both), ~17' rather than the sharp chart of best effort."""
    spec = parse_spec(SPEC)
    assert spec.accommodation == 2.5 and spec.render.view.focus_d == 2.5
    point = ObjectPoints.from_positions([[0.0, 0.0, -6.0]])
    res = analyze_points(spec.eye, None, point, accommodation=spec.accommodation)
    blur = float(res.to_arcmin(res.blur_axes()[0])[0])
    assert blur > 10.0
    view = spec.render.view
    cam = view.camera(spec.eye.rotation_centre)
    field = compute_blur_field(spec.eye, None, cam, shape=(64, 9, 9), focus=view.focus_d,
                               wavelength_nm=587.56)
    depth = field.slice_depths()
    k = int(np.argmin(np.abs(depth - 6.0)))
    f_major = max(abs(field.a[k, 4, 4]), abs(field.b[k, 4, 4]))
    assert float(res.to_arcmin(f_major)) == pytest.approx(blur, rel=0.02)
    # and the renderer was given that state (its report's view)
    from eyelab.jobs.render import render_spec

    assert render_spec(spec).report["view"]["focus_d"] == 2.5


def test_overrides_keep_the_eye_state():
    spec = parse_spec(SPEC)
    rs = spec.render.with_changes(renderer="reference", width=32, height=24)
    assert rs.view.focus_d == 2.5


@pytest.mark.parametrize("data, field", [
    ({"analysis": {"accommodation_d": 1.0}}, "analysis.accommodation_d"),
    ({"render": {"focus_d": 1.0}}, "render.focus_d"),
])
def test_old_keys_say_where_they_moved(data, field):
    with pytest.raises(SpecError) as e:
        parse_spec(data)
    assert e.value.field == field and "moved to eye.accommodation_d" in e.value.message
