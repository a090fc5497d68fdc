import json
import os

import numpy as np
import pytest

from eyelab.fileio import atomic_path, json_default


def test_atomic_path_publishes_whole_files_or_nothing(tmp_path):
    out = tmp_path / "sub" / "a.json"
    with atomic_path(out) as tmp, open(tmp, "w") as fh:
        fh.write("{}")
    assert out.read_text() == "{}"
    assert oct(out.stat().st_mode & 0o777) == oct(0o666 & ~_umask())
    with pytest.raises(RuntimeError), atomic_path(out) as tmp:
        with open(tmp, "w") as fh:
            fh.write("partial")
        raise RuntimeError("writer failed")
    assert out.read_text() == "{}"                       # the old file is untouched
    assert sorted(p.name for p in out.parent.iterdir()) == ["a.json"]   # no temporary left


def test_json_default_numpy_values():
    text = json.dumps({"a": np.float32(1.5), "b": np.arange(3), "c": np.uint8(7)},
                      default=json_default)
    assert json.loads(text) == {"a": 1.5, "b": [0, 1, 2], "c": 7}


def _umask():
    m = os.umask(0)
    os.umask(m)
    return m
