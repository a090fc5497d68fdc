import tomllib

import pytest

from eyelab.data_generators.prescriptions import SAMPLES, sample_spec, to_toml, write_specs
from eyelab.jobs.analyze import analyze_spec
from eyelab.spec import load_spec, parse_spec


@pytest.mark.parametrize("name", SAMPLES)
def test_samples_round_trip_through_toml_and_analyze(name):
    spec = sample_spec(name)
    assert tomllib.loads(to_toml(spec)) == spec
    rep = analyze_spec(parse_spec(spec, name))
    assert all(p["status"] == "ok" for p in rep["points"])
    if "lens" in spec:  # a lens made for the eye's Rx: far point sharp (< 0.5 arcmin)
        assert rep["points"][0]["blur"]["major_arcmin"] < 0.5


def test_write_specs(tmp_path):
    paths = write_specs(tmp_path)
    assert len(paths) == len(SAMPLES)
    assert load_spec(paths[0]).points.distance.size == 3
