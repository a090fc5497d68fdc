import os
import sys

import pytest

sys.path.insert(0, os.path.dirname(__file__))
os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkOSOpenGLRenderWindow")


@pytest.fixture(autouse=True)
def _close_the_default_session():
    """Each test starts without the public API's default session and leaves none: the
    renderers (GL contexts) that ``eyelab.render`` kept for it are closed when it ends, so
    that nothing of one test's GL state lives into the next."""
    yield
    session = sys.modules.get("eyelab.jobs.session")
    if session is not None:
        session.close_default_session()
