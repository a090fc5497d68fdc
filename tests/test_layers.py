"""The layer rules of docs/ARCHITECTURE.md, kept by walking every import statement (module
and function level) of the package's source with ``ast``: each package imports only the
packages below it, VTK only inside ``eyelab/render/`` (through ``_vtk.py``), no private name
crosses a package, and no two modules import each other, directly or in a circle.
"""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: The packages from the bottom: a module may import its own package or the ones below it.
#: Packages on one row are independent of each other.
LAYERS = (
    ("eyelab.core",),
    ("eyelab.optics",),
    ("eyelab.blur",),
    ("eyelab.scene",),
    ("eyelab.imaging",),
    ("eyelab.render", "eyelab.reference"),
    ("eyelab.spec",),
    ("eyelab.jobs",),
    ("eyelab.bench",),
    ("eyelab.apps", "eyelab.data_generators"),
)
#: Within the optics layer, its sub-packages from the bottom, the same rule one level down:
#: rays and wavefronts; the eye and camera lenses (independent of each other); an eye behind
#: a lens; spectacle lenses and their designs. ``eyelab/optics/__init__.py`` re-exports
#: names from them all and sits above them.
OPTICS_LAYERS = (
    ("eyelab.optics.rays",),
    ("eyelab.optics.eye", "eyelab.optics.cameralens"),
    ("eyelab.optics.chain",),
    ("eyelab.optics.lens",),
)
#: The package's own top modules: ``eyelab/__init__.py`` (the public API, whose heavy names
#: are imported lazily inside functions) sits above everything.
TOP = ("eyelab",)
GL = ("vtk", "vtkmodules", "pyvista")


def _modules():
    """(module name, path) of every source file of the installed package's tree."""
    out = []
    for top, name in ((ROOT / "eyelab", "eyelab"), (ROOT / "apps", "eyelab.apps"),
                      (ROOT / "data_generators", "eyelab.data_generators")):
        for p in sorted(top.rglob("*.py")):
            rel = p.relative_to(top).with_suffix("")
            parts = [x for x in rel.parts if x != "__init__"]
            out.append((".".join([name, *parts]), p))
    return out


def _imports(path: Path, module: str):
    """(imported module, names, line) of every import in the file, at any depth; for
    ``from a import b`` where ``a.b`` is a module, that module is named too."""
    tree = ast.parse(path.read_text())
    pkg = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                yield a.name, (), node.lineno
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg.split(".")
                base = base[: len(base) - node.level + 1]
                name = ".".join(base + ([node.module] if node.module else []))
            else:
                name = node.module
            yield name, tuple(a.name for a in node.names), node.lineno


def _package(name: str):
    """The layer package of a module name (``eyelab.optics.lens.spectacle`` -> ``eyelab.optics``);
    None for the top modules and for names outside eyelab."""
    if name in TOP or not name.startswith("eyelab."):
        return None
    return ".".join(name.split(".")[:2])


def _layer(package: str | None):
    for i, row in enumerate(LAYERS):
        if package in row:
            return i
    return None


def _optics_layer(name: str):
    """(row, sub-package) of a module of the optics layer; None for others and for
    ``eyelab.optics`` itself."""
    sub = ".".join(name.split(".")[:3])
    for i, row in enumerate(OPTICS_LAYERS):
        if sub in row:
            return i, sub
    return None


def _outside_violations(top: str, here, module: str, where: str) -> list:
    """VTK outside eyelab/render (or not through _vtk.py); the repository's folders
    imported by their folder names."""
    bad = []
    if top in GL and here != "eyelab.render":
        bad.append(f"{where}: VTK/PyVista outside eyelab/render")
    if top in ("vtk", "vtkmodules") and module != "eyelab.render._vtk":
        bad.append(f"{where}: VTK is imported through eyelab/render/_vtk.py only")
    if top in ("apps", "data_generators"):
        bad.append(f"{where}: the repository folders ship as eyelab.apps / "
                   f"eyelab.data_generators")
    return bad


def _optics_violations(module: str, name: str, where: str) -> list:
    """The optics layer's own rule for ``module`` importing ``name`` (both in it)."""
    mine, theirs = _optics_layer(module), _optics_layer(name)
    if mine is None:
        return [f"{where}: every optics module lives in a sub-package"]
    if theirs is None:
        return [f"{where}: eyelab.optics itself is above its sub-packages"]
    if theirs[1] != mine[1] and theirs[0] >= mine[0]:
        return [f"{where}: {theirs[1]} is not below {mine[1]}"]
    return []


def _graph(modules):
    """Module -> set of eyelab modules it imports (``from pkg import mod`` counts as mod)."""
    known = {m for m, _ in modules}
    graph = {}
    for module, path in modules:
        edges = set()
        for name, names, _ in _imports(path, module):
            if not name.startswith("eyelab"):
                continue
            subs = {f"{name}.{n}" for n in names} & known
            edges |= subs or ({name} & known)
        graph[module] = edges - {module}
    return graph


def _cycles(graph):
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index, low, on, stack, out, counter = {}, {}, set(), [], [], [0]
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter[0]
        counter[0] += 1
        stack.append(root)
        on.add(root)
        while work:
            v, it = work[-1]
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter[0]
                    counter[0] += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(graph.get(w, ())))))
                    break
                if w in on:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on.discard(w)
                        comp.append(w)
                        if w == v:
                            break
                    if len(comp) > 1:
                        out.append(sorted(comp))
    return out


def _violations(modules=None):
    modules = _modules() if modules is None else modules
    bad = []
    for module, path in modules:
        here = _package(module)
        rel = path.relative_to(ROOT) if path.is_relative_to(ROOT) else path
        for name, names, line in _imports(path, module):
            top = name.split(".")[0]
            where = f"{rel}:{line} imports {name}"
            bad += _outside_violations(top, here, module, where)
            if top != "eyelab" or here is None:
                continue
            there = _package(name)
            if there is None:
                if name == "eyelab" and set(names) - {"__version__"}:
                    bad.append(f"{where}: the public API imports the packages, not back")
                continue
            a, b = _layer(here), _layer(there)
            if a is not None and b is not None and there != here and b >= a:
                bad.append(f"{where}: {there} is not below {here}")
            if here == there == "eyelab.optics" and module != "eyelab.optics":
                bad += _optics_violations(module, name, where)
            if there != here:
                private = [n for n in (*name.split(".")[2:], *names)
                           if n.startswith("_") and not n.startswith("__")]
                if private:
                    bad.append(f"{where}: private {private} of another package")
    bad += [f"import circle: {' -> '.join(c)}" for c in _cycles(_graph(modules))]
    return bad


def test_every_package_has_a_layer():
    missing = sorted({_package(m) for m, _ in _modules()
                      if _package(m) is not None and _layer(_package(m)) is None})
    assert missing == []
    loose = sorted(m for m, _ in _modules() if m.startswith("eyelab.optics.")
                   and _optics_layer(m) is None)
    assert loose == [], "every optics module lives in a sub-package of OPTICS_LAYERS"


def test_eyelab_holds_packages_only():
    """The package's top level: packages plus ``__init__.py`` / ``__main__.py``."""
    loose = sorted(p.name for p in (ROOT / "eyelab").glob("*.py")
                   if p.name not in ("__init__.py", "__main__.py"))
    assert loose == []


def test_import_layers_are_respected():
    assert _violations() == []


def test_the_rule_checker_sees_each_violation(tmp_path):
    """The checker itself can fail: a function-level VTK import and an upward import in
    the optics layer, a private name across packages, and an injected import circle
    between two modules (one of them through a function-level import)."""
    fake = tmp_path / "fake.py"
    fake.write_text("def f():\n    import vtk\n    from eyelab.render import raster\n"
                    "from eyelab.core.fileio import _private\n")
    a = tmp_path / "a.py"
    a.write_text("from eyelab.optics.rays import b\n")
    b = tmp_path / "b.py"
    b.write_text("def g():\n    from eyelab.optics.rays.a import h\n"
                 "from eyelab.optics.lens.spectacle import SpectacleLens\n")
    found = _violations([("eyelab.optics.rays.fake", fake), ("eyelab.optics.rays.a", a),
                         ("eyelab.optics.rays.b", b)])
    kinds = [re.sub(r".*: ", "", f) if "circle" not in f else "circle" for f in found]
    assert len(found) == 6, found
    assert any("eyelab.optics.lens is not below eyelab.optics.rays" in f for f in found)
    assert "circle" in kinds and any("private" in k for k in kinds), found
    assert any("not below" in f for f in found) and any("outside" in f for f in found)


def test_no_module_over_500_lines():
    long = [f"{p.relative_to(ROOT)}: {n}" for _, p in _modules()
            if (n := len(p.read_text().splitlines())) > 500]
    assert long == []


@pytest.mark.parametrize("package", ["eyelab", "eyelab.core", "eyelab.optics", "eyelab.blur",
                                     "eyelab.scene", "eyelab.imaging", "eyelab.reference",
                                     "eyelab.spec", "eyelab.jobs"])
def test_pure_layers_import_without_vtk(package):
    """Importing the numpy layers (the reference renderer, the jobs and the public API
    included: they load the GL renderers only when one is asked for) loads no VTK."""
    code = (f"import sys, {package}; bad = [m for m in sys.modules if m.split('.')[0] in "
            f"{GL!r}]; print(bad); sys.exit(1 if bad else 0)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr


def test_the_maps_list_every_package():
    """README's Layout tree and docs/ARCHITECTURE.md name every package of eyelab/ (and
    no package that is not there); the layer table here names them all too."""
    pkgs = sorted(p.parent.name for p in (ROOT / "eyelab").glob("*/__init__.py"))
    readme = (ROOT / "README.md").read_text()
    tree = readme[readme.index("## Layout"):].split("```")[1]
    listed = sorted(re.findall(r"^  (\w+)/", tree, flags=re.M))
    assert listed == sorted([*pkgs, "data"]), listed
    arch = (ROOT / "docs" / "ARCHITECTURE.md").read_text()
    in_arch = sorted(set(re.findall(r"`eyelab/(\w+)/`", arch)))
    assert in_arch == pkgs
    assert sorted(p.removeprefix("eyelab.") for row in LAYERS for p in row
                  if p.count(".") == 1 and p not in ("eyelab.apps", "eyelab.data_generators")
                  ) == pkgs


def test_the_wheel_lists_every_package():
    """pyproject.toml names every package of the tree (a missing one would ship a wheel
    without it)."""
    import tomllib

    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
                 ["packages"])
    found = {".".join(["eyelab", *p.parent.relative_to(ROOT / "eyelab").parts])
             for p in (ROOT / "eyelab").rglob("__init__.py")}
    found |= {"eyelab.apps", "eyelab.data_generators"}
    assert listed == found
