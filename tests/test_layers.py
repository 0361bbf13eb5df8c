"""The package's layers point one way (docs/architecture.md): every ``import`` of every module
under app/, read with ``ast`` (function-level and TYPE_CHECKING imports included), names
only its own package or a lower layer.

    shared definitions (app.common) and utilities
      -> float64 twins (app.reference) | GL plumbing (app.gl)
      -> CPU texture maps (app.textures)
      -> scene (app.scene)
      -> frame data (app.frame)
      -> passes (app.render)
      -> the Python API (app.api)
      -> tools on top: BRDF probe, walkthrough, viewer, bench, CLI, screenshots
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from tests.conftest import REPO

APP = REPO / "app"

# Packages (or modules) in layer order. Within a layer, peers may not import each other:
# the twins and the GL plumbing know nothing of one another.
LAYERS: list[tuple[str, ...]] = [
    ("app.common", "app.errors", "app.resources", "app.output", "app.progress"),
    ("app.untrusted",),  # every input file opened, parsed and budgeted (docs/stability.md)
    ("app.reference", "app.gl"),
    ("app.textures",),
    ("app.scene",),
    ("app.frame",),
    ("app.render",),
    ("app.api",),  # the public Python API (docs/api.md): a renderer that changes, into numpy
    ("app.brdf", "app.assets", "app.batch"),
    ("app.walkthrough",),  # the classroom lesson: renders, plots, labels, handout
    ("app.viewer",),
    ("app.bench",),  # it measures the viewer too
    ("app.cli", "app.screenshots"),
    ("app.__main__",),
]


def unit_of(module: str) -> str:
    """The layer entry ``module`` belongs to (``app.render.lighting`` -> ``app.render``)."""
    for layer in LAYERS:
        for unit in layer:
            if module == unit or module.startswith(unit + "."):
                return unit
    raise AssertionError(f"{module} is in no layer of tests/test_layers.py: add it")


def level(unit: str) -> int:
    return next(i for i, layer in enumerate(LAYERS) if unit in layer)


def module_name(path: Path) -> str:
    parts = path.relative_to(REPO).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports(path: Path) -> list[tuple[int, str]]:
    """(line, module) of every import of an ``app`` module in the file, relative ones
    resolved."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = module_name(path)
    if path.name != "__init__.py":
        package = package.rsplit(".", 1)[0]
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                name = f"{base}.{node.module}" if node.module else base
            else:
                name = node.module or ""
            found.append((node.lineno, name))
            # `from app import x` / `from app.reference import ndf` import submodules
            found += [(node.lineno, f"{name}.{alias.name}") for alias in node.names]
    return [(line, name) for line, name in found if name == "app" or name.startswith("app.")]


def known(module: str) -> bool:
    """Whether ``module`` is a module or package of app/ (not a name inside a module)."""
    rel = Path(*module.split("."))
    return (REPO / rel).with_suffix(".py").is_file() or (REPO / rel / "__init__.py").is_file()


def violations() -> list[str]:
    bad = []
    for path in sorted(APP.rglob("*.py")):
        me = module_name(path)
        if me == "app":
            continue
        mine = unit_of(me)
        for line, target in imports(path):
            if target == "app" or not known(target):
                continue
            theirs = unit_of(target)
            if theirs == mine:
                continue
            if level(theirs) >= level(mine):
                rel = path.relative_to(REPO)
                bad.append(f"{rel}:{line}: {mine} (layer {level(mine)}) imports {target}")
    return bad


def test_layers_point_one_way() -> None:
    bad = violations()
    assert not bad, "imports against the layers:\n" + "\n".join(bad)


def test_every_package_has_a_layer() -> None:
    for path in APP.rglob("*.py"):
        if module_name(path) != "app":
            unit_of(module_name(path))


@pytest.mark.parametrize(
    ("source", "expect"),
    [
        ("from app.render.renderer import Renderer\n", "app.reference"),
        ("def f():\n    from app.scene.model import Scene\n", "app.reference"),
        ("import app.frame\n", "app.scene"),
        ("from app.gl import shaders\n", "app.reference"),
    ],
)
def test_the_check_catches_an_upward_import(tmp_path, monkeypatch, source, expect) -> None:
    """A module planted in a lower layer that imports upwards (at the top, inside a
    function, or a peer) is reported."""
    package = tmp_path / "app"
    target = package / Path(*expect.split(".")[1:])
    target.mkdir(parents=True)
    (package / "__init__.py").write_text("")
    (target / "__init__.py").write_text("")
    (target / "planted.py").write_text(source)
    for name in ("render", "scene", "frame", "gl"):
        (package / name).mkdir(exist_ok=True)
        (package / name / "__init__.py").write_text("")
    for module in ("render/renderer.py", "scene/model.py", "gl/shaders.py"):
        (package / module).write_text("")
    monkeypatch.setattr(f"{__name__}.REPO", tmp_path)
    monkeypatch.setattr(f"{__name__}.APP", package)
    found = violations()
    assert found and all("planted.py" in line for line in found), found
