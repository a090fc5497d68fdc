"""The layer rules of ARCHITECTURE.md, kept by walking every import statement (module and
function level) of the package's source with ``ast``."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: Layers from the bottom: a module may import eyelab modules of its own layer or below,
#: never above. Keys are module-name prefixes (the longest match wins).
LAYERS = {
    "eyelab": 0, "eyelab.errors": 0, "eyelab.constants": 0, "eyelab.vecmath": 0,
    "eyelab.sampling": 0, "eyelab.parallel": 0, "eyelab.fileio": 0, "eyelab.cache": 0,
    "eyelab.color": 0, "eyelab.progress": 0,
    "eyelab.optics": 1,
    "eyelab.imaging": 2, "eyelab.options": 2, "eyelab.resources": 2,
    "eyelab.blur": 3, "eyelab.scene": 3,
    "eyelab.spec": 4, "eyelab.analyze": 4, "eyelab.specdoc": 4, "eyelab.binocular": 4,
    "eyelab.imagebased": 4,
    "eyelab.render": 5, "eyelab.reference": 5,
    "eyelab.jobs": 6, "eyelab.inspect": 6, "eyelab.batch": 6, "eyelab.maps": 4,
    "eyelab.bench": 7,
    "eyelab.apps": 8, "eyelab.data_generators": 8,
}
#: Packages of one layer that must not import each other.
APART = [("eyelab.render", "eyelab.reference")]
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
    tree = ast.parse(path.read_text())
    pkg = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                yield a.name, node.lineno
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg.split(".")
                base = base[: len(base) - node.level + 1]
                yield ".".join(base + ([node.module] if node.module else [])), node.lineno
            else:
                yield node.module, node.lineno


def _layer(name: str):
    best = max((k for k in LAYERS if name == k or name.startswith(k + ".")), key=len,
               default=None)
    return None if best is None else LAYERS[best]


def _violations():
    bad = []
    for module, path in _modules():
        here = _layer(module)
        rel = path.relative_to(ROOT) if path.is_relative_to(ROOT) else path
        for name, line in _imports(path, module):
            top = name.split(".")[0]
            where = f"{rel}:{line} imports {name}"
            if top in GL and not module.startswith("eyelab.render"):
                bad.append(f"{where}: VTK/PyVista outside eyelab/render")
            if top in ("vtk", "vtkmodules") and module != "eyelab.render._vtk":
                bad.append(f"{where}: VTK is imported through eyelab/render/_vtk.py only")
            if top in ("apps", "data_generators"):
                bad.append(f"{where}: the repository folders ship as eyelab.apps / "
                           f"eyelab.data_generators")
            if top != "eyelab":
                continue
            there = _layer(name)
            if there is not None and here is not None and there > here:
                bad.append(f"{where}: layer {there} above its own {here}")
            for a, b in APART + [(y, x) for x, y in APART]:
                if module.startswith(a) and (name == b or name.startswith(b + ".")):
                    bad.append(f"{where}: {a} and {b} are independent")
    return bad


def test_every_module_has_a_layer():
    missing = [m for m, _ in _modules() if _layer(m) is None]
    assert missing == []


def test_import_layers_are_respected():
    assert _violations() == []


def test_the_rule_checker_sees_a_violation(tmp_path, monkeypatch):
    """The checker itself can fail: a VTK import in the optics layer is reported."""
    fake = tmp_path / "mod.py"
    fake.write_text("def f():\n    import vtk\n    from eyelab.render import raster\n")
    import sys

    monkeypatch.setattr(sys.modules[__name__], "_modules",
                        lambda: [("eyelab.optics.fake", fake)])
    found = _violations()
    assert len(found) == 3, found


def test_private_helpers_are_not_imported_across_packages():
    """A name starting with one underscore is private to its package."""
    bad = []
    for module, path in _modules():
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module and not node.level:
                src_pkg = node.module.rsplit(".", 1)[0]
                for a in node.names:
                    if (a.name.startswith("_") and not a.name.startswith("__")
                            and not module.startswith(src_pkg) and node.module != "eyelab.render"
                            and not node.module.endswith("._vtk")):
                        bad.append(f"{path.relative_to(ROOT)}: {node.module}.{a.name}")
    assert bad == []


@pytest.mark.parametrize("package", ["eyelab.optics", "eyelab.blur", "eyelab.scene",
                                     "eyelab.reference", "eyelab.spec", "eyelab.jobs"])
def test_pure_layers_import_without_vtk(package):
    """Importing the numpy layers (and the reference renderer) loads no VTK."""
    import subprocess
    import sys

    code = (f"import sys, {package}; bad = [m for m in sys.modules if m.split('.')[0] in "
            f"{GL!r}]; print(bad); sys.exit(1 if bad else 0)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
