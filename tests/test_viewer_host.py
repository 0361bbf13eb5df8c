"""The window's ``Viewer`` is what its panels and lesson take it for (app/viewer/host.py's
``ViewerHost``), checked without a display: every attribute the protocol names is set on
the viewer, every method and property it names is the viewer's with the same parameters."""

from __future__ import annotations

import ast
import inspect

from app.viewer.host import ViewerHost
from app.viewer.window import Viewer
from tests.conftest import REPO


def _protocol_members() -> tuple[set[str], set[str]]:
    """(attributes, methods and properties) that ``ViewerHost`` declares."""
    attributes = set(inspect.get_annotations(ViewerHost))
    callables = {
        name
        for name, value in vars(ViewerHost).items()
        if not name.startswith("_") and (inspect.isfunction(value) or isinstance(value, property))
    }
    return attributes, callables


def _viewer_attributes() -> set[str]:
    """The names ``Viewer``'s methods assign to ``self.<name>``."""
    tree = ast.parse((REPO / "app" / "viewer" / "window.py").read_text(encoding="utf-8"))
    viewer = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "Viewer")
    names = set()
    for node in ast.walk(viewer):
        targets = node.targets if isinstance(node, ast.Assign) else []
        if isinstance(node, ast.AnnAssign | ast.AugAssign):
            targets = [node.target]
        for target in targets:
            for sub in ast.walk(target):
                if (
                    isinstance(sub, ast.Attribute)
                    and isinstance(sub.value, ast.Name)
                    and sub.value.id == "self"
                ):
                    names.add(sub.attr)
    return names


def test_the_viewer_is_a_viewer_host() -> None:
    attributes, callables = _protocol_members()
    assert attributes and callables
    missing = attributes - _viewer_attributes()
    assert not missing, f"ViewerHost attributes the Viewer never sets: {sorted(missing)}"
    for name in callables:
        mine, theirs = getattr(ViewerHost, name), getattr(Viewer, name, None)
        assert theirs is not None, f"Viewer has no {name}"
        if isinstance(mine, property):
            assert isinstance(theirs, property), name
            continue
        want = list(inspect.signature(mine).parameters.values())
        got = list(inspect.signature(theirs).parameters.values())
        assert [(p.name, p.kind, p.default) for p in got] == [
            (p.name, p.kind, p.default) for p in want
        ], name
