"""The code versions that key prepared-texture entries (app/textures/versions.py): each
kind's GLSL is every file its program splices, found by reading the includes, and an
edit to any file of a kind's makers changes the kind's version."""

from __future__ import annotations

from pathlib import Path

import pytest

from app.gl.shaders import _expand_file
from app.resources import glsl_closure, glsl_dir
from app.textures import versions


def _spliced(relative: str) -> set[str]:
    """The files the shader assembler reads for ``relative``: its lines' origins."""
    _, origins = _expand_file(relative, glsl_dir(), set())
    return {name for name, _ in origins}


@pytest.mark.parametrize("kind", [k for k, m in versions.MAKERS.items() if m.glsl])
def test_a_kinds_glsl_is_what_its_program_splices(kind: str) -> None:
    """The closure of a GL-drawn kind's GLSL is the set of files the assembler splices
    into its programs: the two read the same include lines."""
    makers = versions.MAKERS[kind]
    spliced = set().union(*(_spliced(name) for name in makers.glsl))
    closure = {p.relative_to(glsl_dir()).as_posix() for p in glsl_closure(*makers.glsl)}
    assert closure == spliced


def test_the_chain_pass_reaches_its_includes() -> None:
    """The GL chain's version reads the chain's and the footprints' GLSL, which its pass
    includes without the makers' table naming them."""
    names = {p.name for p in glsl_closure(*versions.MAKERS["gl chain"].glsl)}
    assert {"normal_chain.frag", "chain.glsl", "footprint.glsl", "fullscreen.vert"} <= names


def test_every_maker_file_exists() -> None:
    """A makers' table naming a moved or renamed file fails here, not by a key that no
    longer follows the code."""
    for kind in versions.MAKERS:
        assert len(versions.version(kind)) == 16


def test_a_generated_include_is_refused(tmp_path: Path, monkeypatch) -> None:
    """A GLSL file including a generated text (no file: its Python declarations would not
    be in a key over files) is named, not skipped."""
    root = tmp_path / "glsl"
    (root / "passes").mkdir(parents=True)
    (root / "passes" / "x.frag").write_text('#include "generated/extension_maps.glsl"\n')
    monkeypatch.setattr("app.resources.glsl_dir", lambda: root)
    with pytest.raises(FileNotFoundError, match=r"generated/extension_maps\.glsl"):
        glsl_closure("passes/x.frag")


def test_an_edit_to_an_include_changes_the_version(tmp_path: Path, monkeypatch) -> None:
    """A version over a pass follows its includes' bytes, two levels down."""
    root = tmp_path / "glsl"
    for name, text in {
        "passes/p.frag": '#include "a/one.glsl"\nvoid main() {}\n',
        "a/one.glsl": '  #include "a/two.glsl"\nfloat one() { return two(); }\n',
        "a/two.glsl": "float two() { return 2.0; }\n",
    }.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(text)
    monkeypatch.setattr("app.resources.glsl_dir", lambda: root)
    driver = tmp_path / "driver.py"
    driver.write_text("x = 1\n")
    make = versions.code_version.__wrapped__  # unmemoised: the files are edited between
    before = make(driver, glsl=("passes/p.frag",))
    assert make(driver, glsl=("passes/p.frag",)) == before
    (root / "a" / "two.glsl").write_text("float two() { return 2.5; }\n")
    assert make(driver, glsl=("passes/p.frag",)) != before
    driver.write_text("x = 2\n")
    assert len({before, make(driver, glsl=("passes/p.frag",))}) == 2
