"""The command reference (docs/reference/cli.md), generated from the ``eyelab`` command's
own argparse parser: one section per command and subcommand, one table row per option
(its flags, value, default and help), so the reference says what the parser accepts and
nothing else. ``python -m eyelab.apps.clidoc`` prints it; ``--write PATH`` rewrites the
file (``tests/test_docs.py`` checks it is current)."""

from __future__ import annotations

import argparse

HEADER = """# Command reference

Generated from the `eyelab` command's parser (`python -m eyelab.apps.clidoc --write
docs/reference/cli.md`); `eyelab COMMAND --help` prints the same options. What each
command does is in the [guide](../guide/commands.md); every spec key is in the
[spec reference](spec.md).
"""


def _cell(text) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _value(action) -> str:
    if action.nargs == 0:
        return ""
    if action.choices is not None and not isinstance(action, argparse._SubParsersAction):
        return " \\| ".join(f"`{c}`" for c in action.choices)
    metavar = action.metavar or action.dest.upper()
    if isinstance(metavar, tuple):
        metavar = " ".join(metavar)
    n = action.nargs
    if isinstance(n, int) and n > 1 and not isinstance(action.metavar, tuple):
        metavar = " ".join([metavar] * n)
    return f"`{metavar}`" + (" (optional)" if n == "?" else " ..." if n in ("*", "+") else "")


def _default(action) -> str:
    d = action.default
    if d is None or d is False or d == argparse.SUPPRESS or action.nargs == 0:
        return ""
    return f"`{d}`"


def _table(parser) -> list:
    rows = ["| option | value | default | meaning |", "|---|---|---|---|"]
    for a in parser._actions:
        if isinstance(a, (argparse._HelpAction, argparse._SubParsersAction)):
            continue
        name = ", ".join(f"`{o}`" for o in a.option_strings) or f"`{a.dest}` (positional)"
        text = "" if a.help == argparse.SUPPRESS else (a.help or "")
        text = text % {"default": a.default, "prog": parser.prog} if "%(" in text else text
        rows.append(f"| {name} | {_value(a)} | {_default(a)} | {_cell(text)} |")
    return rows


def _subparsers(parser) -> list:
    """(name, help, parser) of ``parser``'s subcommands, in the order the parser lists."""
    out = []
    for a in parser._actions:
        if isinstance(a, argparse._SubParsersAction):
            helps = {c.dest: c.help for c in a._choices_actions}
            out += [(name, helps.get(name, ""), p) for name, p in a.choices.items()]
    return out


def _section(parser, title: str, summary: str, depth: int) -> list:
    lines = [f"{'#' * depth} `{title}`", ""]
    if summary:
        lines += [summary[0].upper() + summary[1:] + ("" if summary.endswith(".") else "."),
                  ""]
    if parser.description and depth > 2:
        lines += [parser.description, ""]
    lines += _table(parser) + [""]
    for name, text, sub in _subparsers(parser):
        lines += _section(sub, f"{title} {name}", text or "", depth + 1)
    return lines


def markdown() -> str:
    """The whole reference, as Markdown."""
    from eyelab.apps.cli import _build_parser

    ap = _build_parser()
    lines = [HEADER, ap.description or "", ""] + _table(ap) + [""]
    for name, text, sub in _subparsers(ap):
        lines += _section(sub, f"eyelab {name}", text or "", 2)
    return "\n".join(lines).rstrip() + "\n"


def write(path) -> bool:
    """Write the reference to ``path``; True if it changed."""
    from pathlib import Path

    p = Path(path)
    new = markdown()
    old = p.read_text() if p.exists() else None
    if new != old:
        p.write_text(new)
    return new != old


if __name__ == "__main__":
    import sys

    if sys.argv[1:2] == ["--write"]:
        print("updated" if write(sys.argv[2]) else "unchanged")
    else:
        print(markdown(), end="")
