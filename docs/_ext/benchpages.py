"""A Sphinx extension that writes the benchmark page (``_generated/benchmarks``) from
docs/bench/*.json before each build: per benchmark file, its summary lines as written by
``eyelab bench ... -o`` and the plot saved beside it, so the page shows what the last
recorded run measured and never a number typed by hand."""

from __future__ import annotations

import json
from pathlib import Path


def page(bench: Path) -> str:
    """The Markdown page for the JSON files in ``bench``."""
    out = ["# Benchmark results", "",
           "Each section is one JSON file of `docs/bench/`, written by `eyelab bench ... -o`; "
           "the lines are its `summary`, as the benchmark printed them. How each is run is "
           "in [How eyelab is checked](../checking/index.md).", ""]
    for f in sorted(bench.glob("*.json")):
        data = json.loads(f.read_text())
        title = data.get("benchmark") or f.stem
        out += [f"## `{f.name}`", "", f"Benchmark: {title}.", ""]
        summary = data.get("summary")
        if isinstance(summary, str):
            summary = [summary]
        if isinstance(summary, list) and summary:
            out += ["```text", *[str(s) for s in summary], "```", ""]
        else:
            keys = ", ".join(f"`{k}`" for k in list(data)[:12])
            out += [f"No summary lines; its keys: {keys}.", ""]
        plot = f.with_suffix(".png")
        if plot.exists():
            out += [f"![{f.stem}](../bench/{plot.name})", ""]
    return "\n".join(out)


def _write(app) -> None:
    src = Path(app.srcdir)
    gen = src / "_generated"
    gen.mkdir(exist_ok=True)
    text = page(src / "bench")
    target = (gen / "benchmarks").with_suffix(".md")
    if not target.exists() or target.read_text() != text:
        target.write_text(text)


def setup(app):
    app.connect("builder-inited", _write)
    return {"version": "1", "parallel_read_safe": True}
