import json
import os
from pathlib import Path

import numpy as np
import pytest

from eyelab.core.fileio import atomic_path, json_default


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


def test_atomic_group_writes_all_or_none_and_sweeps(tmp_path):
    from eyelab.core.fileio import TMP_PREFIX, atomic_group

    a, b = tmp_path / "a.txt", tmp_path / "b.txt"
    stale = tmp_path / f"{TMP_PREFIX}a.txt.k1lled_8.txt"          # mkstemp's shape
    stale.write_text("x")
    def text(t):
        return lambda p: Path(p).write_text(t)

    atomic_group({a: text("1"), b: text("2")})
    assert a.read_text() == "1" and b.read_text() == "2" and not stale.exists()

    def fail(p):
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError):
        atomic_group({a: text("new"), b: fail})
    assert a.read_text() == "1" and b.read_text() == "2"      # the old set, untouched
    assert not list(tmp_path.glob(TMP_PREFIX + "*"))


def test_one_name_a_prefix_of_the_other_writes_both(tmp_path):
    """A.json's temporaries are not A.json.npy's: the group writes both (the sweep of the
    one left the other's temporary alone), and a killed write of either is still swept."""
    from eyelab.core.fileio import TMP_PREFIX, atomic_group, is_temporary_of

    a, b = tmp_path / "A.json.npy", tmp_path / "A.json"
    atomic_group({a: lambda p: Path(p).write_text("array"), b: lambda p: Path(p).write_text("{}")})
    assert a.read_text() == "array" and b.read_text() == "{}"
    assert not list(tmp_path.glob(TMP_PREFIX + "*"))
    assert is_temporary_of(f"{TMP_PREFIX}A.json.abcd_123.json", "A.json")
    assert is_temporary_of(f"{TMP_PREFIX}A.json.abcd_123", "A.json")
    assert not is_temporary_of(f"{TMP_PREFIX}A.json.npy.abcd_123.npy", "A.json")
    assert not is_temporary_of(f"{TMP_PREFIX}A.json.abcdefgh.abcd_123.abcdefgh", "A.json")


@pytest.mark.slow
def test_kill_9_during_render_demo_and_bench_leaves_whole_files(tmp_path):
    """`eyelab demo`, `eyelab render --report` and `eyelab bench` killed (SIGKILL) at 30
    random moments: each final file is either absent or whole (the PNG decodes, the JSON
    parses), and the next complete run leaves no temporary."""
    import json
    import os
    import random
    import signal
    import subprocess
    import sys
    import time

    import matplotlib.image as mpimg

    from eyelab.core.fileio import TMP_PREFIX

    env = dict(os.environ, VTK_DEFAULT_OPENGL_WINDOW="vtkOSOpenGLRenderWindow")
    cli = [sys.executable, "-P", "-m", "eyelab.apps.cli"]
    size = ["--width", "160", "--height", "120", "--samples", "2"]
    cmds = {"demo": cli + ["demo", "-o", str(tmp_path / "d.png")] + size,
            "render": cli + ["render", "-o", str(tmp_path / "r.png"), "--report",
                             str(tmp_path / "r.json")] + size,
            "bench": cli + ["bench", "optics", "--points", "100000", "--repeats", "2",
                            "-o", str(tmp_path / "b.json")]}
    rng = random.Random(3)
    for i in range(30):
        name = ("demo", "render", "bench")[i % 3]
        proc = subprocess.Popen(cmds[name], env=env, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
        time.sleep(rng.uniform(1.0, 4.5))
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        for png in (tmp_path / "d.png", tmp_path / "r.png"):
            if png.exists():
                assert mpimg.imread(png).shape[2] in (3, 4)
        for js in (tmp_path / "d.json", tmp_path / "r.json", tmp_path / "b.json"):
            if js.exists():
                json.loads(js.read_text())
    for cmd in cmds.values():
        subprocess.run(cmd, env=env, check=True, capture_output=True, timeout=300)
    assert not list(tmp_path.glob(TMP_PREFIX + "*"))


def _chunks(data: bytes) -> dict:
    """The PNG's chunks {tag: [payloads]}, read independently of the writer."""
    import struct

    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    out, i = {}, 8
    while i < len(data):
        n, = struct.unpack(">I", data[i:i + 4])
        out.setdefault(data[i + 4:i + 8].decode(), []).append(data[i + 8:i + 8 + n])
        i += 12 + n
    return out


def test_pngs_say_how_to_read_them(tmp_path):
    """8-bit: sRGB (an ``sRGB`` chunk, no text chunks such as a "Software" tag), RGB
    without alpha; 16-bit: linear light (``gAMA`` 1.0 and the sRGB primaries), which
    Pillow reads as linear (gamma 1.0) and whose samples are the linear codes."""
    import io
    import zlib

    from PIL import Image

    from eyelab.core.fileio import linear_to_png16, write_png

    rng = np.random.default_rng(3)
    srgb = rng.integers(0, 256, (6, 7, 3)).astype(np.uint8)
    write_png(tmp_path / "a.png", srgb)
    data = (tmp_path / "a.png").read_bytes()
    c = _chunks(data)
    assert c["sRGB"] == [b"\x00"] and not {"tEXt", "iTXt", "zTXt"} & set(c)
    with Image.open(io.BytesIO(data)) as im:
        assert im.mode == "RGB" and "srgb" in im.info
        np.testing.assert_array_equal(np.asarray(im), srgb)
    linear = rng.random((6, 7, 3))
    write_png(tmp_path / "l.png", linear_to_png16(linear))
    data = (tmp_path / "l.png").read_bytes()
    c = _chunks(data)
    assert "sRGB" not in c and c["IHDR"][0][8:10] == bytes([16, 2])      # 16-bit RGB
    with Image.open(io.BytesIO(data)) as im:
        assert im.info["gamma"] == 1.0
        assert im.info["chromaticity"] == pytest.approx(
            (0.3127, 0.329, 0.64, 0.33, 0.3, 0.6, 0.15, 0.06))
        high = np.asarray(im)                  # Pillow keeps 16-bit RGB's high bytes
    raw = np.frombuffer(zlib.decompress(b"".join(c["IDAT"])), np.uint8).reshape(6, -1)
    assert (raw[:, 0] == 0).all()              # filter 0: the rows as written
    codes = raw[:, 1:].copy().view(">u2").reshape(6, 7, 3)
    np.testing.assert_allclose(codes / 65535.0, linear, atol=0.5 / 65535)
    np.testing.assert_array_equal(high, (codes >> 8).astype(np.uint8))
