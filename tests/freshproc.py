"""A script run in a fresh Python process whose on-disk cache is a given folder: what a
second `eyelab` command, or a Dask worker, sees of the cache."""

import json
import os
import subprocess
import sys
import textwrap

from eyelab.core import diskcache


def run_fresh(script: str, folder) -> dict:
    """The JSON that ``script`` (dedented) prints last, run with ``EYELAB_CACHE_DIR`` =
    ``folder``; the process must succeed."""
    env = dict(os.environ, **{diskcache.DIR_ENV: str(folder)})
    r = subprocess.run([sys.executable, "-c", textwrap.dedent(script)], capture_output=True,
                       text=True, env=env, timeout=120)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)
