"""The README stays true: its example runs and CI runs exactly its test command (its spec
reference is checked by tests/test_specdoc.py)."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def test_the_interface_example_runs():
    section = (ROOT / "docs" / "guide" / "renderers.md").read_text()
    section = section[section.index("## Renderers: one interface"):]
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
