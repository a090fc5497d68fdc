import atexit
import os
import shutil
import sys
import tempfile

import pytest

sys.path.insert(0, os.path.dirname(__file__))
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkOSOpenGLRenderWindow")
# The suite never reads or writes the user's on-disk cache (~/.cache/eyelab,
# eyelab/core/diskcache.py): one empty folder per run, removed at exit, inherited by the
# subprocesses the tests start. Set at import, before any test (or doctest) runs.
_CACHE = tempfile.mkdtemp(prefix="eyelab-test-cache-")
os.environ["EYELAB_CACHE_DIR"] = _CACHE
atexit.register(shutil.rmtree, _CACHE, ignore_errors=True)


def pytest_xdist_auto_num_workers(config):
    """``-n auto`` (pyproject's addopts): a worker per core, with at least 3 GiB of
    memory each: every worker holds its own renderers, fields and caches."""
    from eyelab.imaging.memory import physical_memory

    cores, memory = os.cpu_count() or 1, physical_memory()     # 0: the OS does not say
    return max(1, min(cores, int(memory / 3 / 2**30) if memory else cores))


@pytest.fixture(autouse=True)
def _close_the_default_session():
    """Each test starts without the public API's default session and leaves none: the
    renderers (GL contexts) that ``eyelab.render`` kept for it are closed when it ends, so
    that nothing of one test's GL state lives into the next."""
    yield
    session = sys.modules.get("eyelab.jobs.session")
    if session is not None:
        session.close_default_session()
