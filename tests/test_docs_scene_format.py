"""docs/scene-format.md lists every value the scene model accepts for a key with a fixed
set of values (a ``Literal``): a value the code takes but the page leaves out is a feature
no reader finds."""

from __future__ import annotations

import re
import typing
from pathlib import Path

import pytest

from app.scene.model import Camera, Environment, Light, Material, RenderSettings, SceneObject

PAGE = Path(__file__).resolve().parent.parent / "docs" / "scene-format.md"
TABLES = {
    "[render]": RenderSettings,
    "[camera]": Camera,
    "[materials.NAME]": Material,
    "[environment]": Environment,
    "[[lights]]": Light,
    "[[objects]]": SceneObject,
}


def _choices(annotation: object) -> tuple[str, ...]:
    """The string values of a ``Literal`` annotation (inside Optional or Annotated)."""
    if typing.get_origin(annotation) is typing.Literal:
        return tuple(v for v in typing.get_args(annotation) if isinstance(v, str))
    return tuple(v for arg in typing.get_args(annotation) for v in _choices(arg))


def _section(heading: str) -> str:
    """The text of the page's ``## `heading` ...`` section, to the next ``## ``."""
    text = PAGE.read_text(encoding="utf-8")
    start = text.index(f"## `{heading}`")
    end = text.find("\n## ", start + 1)
    return text[start : end if end >= 0 else None]


@pytest.mark.parametrize("heading", TABLES)
def test_every_literal_value_is_in_its_keys_row(heading: str) -> None:
    """Each value of a key's ``Literal`` is in the key's row of its table's section (quoted
    or as code), or as code elsewhere in the section (the area lights' types)."""
    section = _section(heading)
    missing = []
    for name, field in TABLES[heading].model_fields.items():
        choices = _choices(field.annotation)
        rows = re.findall(rf"^\| `{re.escape(name)}` \|.*$", section, re.MULTILINE)
        if not choices or not rows:
            continue
        row = " ".join(rows)
        missing += [
            f"{name} = {v!r}"
            for v in choices
            if f"`{v}`" not in row
            and f'"{v}"' not in row
            and f'`"{v}"`' not in section
            and f'{name} = "{v}"' not in section
        ]
    assert not missing, f"docs/scene-format.md {heading} leaves out: {', '.join(missing)}"
