"""The README stays true: its spec table lists every [render] key, its example runs, and
CI runs exactly its test command."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def test_every_render_key_is_documented():
    from eyelab.options import RENDERERS
    from eyelab.spec import renderer_keys

    table = README[README.index("`[render]` keys"):]
    table = table[table.index("\n| key"):]
    table = table[: table.index("\n\n")]
    documented = set(re.findall(r"^\| `([a-z_]+)`(?:, `([a-z_]+)`)?", table, re.M))
    names = {n for pair in documented for n in pair if n}
    keys = {k for r in RENDERERS for k in renderer_keys(r)}
    assert keys - names == set()
    assert names - keys == set()


def test_the_interface_example_runs():
    section = README[README.index("## Renderers: one interface"):]
    code = section[section.index("```python") + len("```python"): section.index("```\n", 10)]
    scope = {}
    exec(compile(code, "README.md", "exec"), scope)
    res, ref = scope["res"], scope["ref"]
    assert res.srgb.shape == ref.srgb.shape == (120, 160, 3)
    assert tuple(res.report) == tuple(ref.report)


def test_ci_runs_the_readme_test_command():
    block = README[README.index("## Tests"):]
    cmd = block[block.index("```bash\n") + 8: block.index("\n```", 10)].strip()
    ci = (ROOT / ".ci" / "run").read_text()
    assert ci.rstrip().splitlines()[-1].strip() == cmd
