"""The walkthrough's lesson content (walkthrough/NN-slug.toml), checked without
the engine that renders it: the files follow the step format (docs of the format: the
``section`` / ``title`` / ``text`` tables, ``equations``, ``views``, ``comparisons``,
``sweeps``, ``plots``), there is exactly one step per section 1..13 of the seed, every
human-readable table has both languages, every equation and every inline ``$...$`` of the
texts renders with matplotlib's mathtext (what the handout and the viewer draw them with,
offline), every scene named exists, every key path of a comparison or sweep can be set on
its scene to both of its values (validated as a scene file is, by the same code as
``pbs render --compare``), every label names an object of its scene, and every plot
argument parses as ``pbs brdf`` reads it.

No GL: scenes are parsed, never rendered (the engine's tests render them).
"""

from __future__ import annotations

import io
import re
import tomllib
from pathlib import Path
from typing import Any

import pytest
from matplotlib import mathtext

from app.brdf.plot import parse_material_arg
from app.render.compare import CompareSpec
from app.scene.loader import load_scene

REPO = Path(__file__).resolve().parent.parent
STEP_DIR = REPO / "walkthrough"
SCENE_DIR = REPO / "scenes"
STEPS = sorted(STEP_DIR.glob("*.toml"))
SECTIONS = range(1, 14)
LANGS = {"en", "ko"}

# The keys the step format allows at each level (unknown keys are errors there too).
TOP_KEYS = {
    "section", "title", "text", "equations", "views", "comparisons", "sweeps", "plots",
    "questions",
}  # fmt: skip
ITEM_KEYS = {
    "equations": ({"latex"}, {"caption"}),
    "views": ({"scene"}, {"caption", "labels"}),
    "comparisons": ({"scene", "key", "a", "b", "label_a", "label_b"}, {"caption"}),
    "sweeps": ({"scene", "keys", "from", "to", "steps"}, {"caption", "format", "label"}),
    "plots": ({"materials"}, {"theta", "caption", "kind"}),
    "questions": ({"ask", "answer"}, {"choices", "correct", "view", "numbers"}),
}
LANG_KEYS = {"title", "text", "caption", "label_a", "label_b", "label", "ask", "answer"}
# Words per language in a step's text: the brief asks for 120-250 in English; Korean
# counts space-separated eojeol, which carry a particle each, so fewer of them say as much.
EN_WORDS = (120, 250)
KO_EOJEOL = (70, 250)
INLINE_MATH = re.compile(r"\$([^$]+)\$")
HANGUL = re.compile("[\uac00-\ud7a3]")
# The project's LaTeX subset: what every mathtext renders, and what the handout's other
# renderings can take. matplotlib 3.11 accepts \text, older releases do not: use \mathrm.
FORBIDDEN = re.compile(r"\\(text|begin|end|operatorname)(?![a-zA-Z])")


def _load(path: Path) -> dict[str, Any]:
    with path.open("rb") as f:
        return tomllib.load(f)


def _ids(paths: list[Path]) -> list[str]:
    return [p.name for p in paths]


def _renders(latex: str) -> None:
    """Raise if mathtext cannot typeset ``latex`` (without the dollars)."""
    mathtext.math_to_image(f"${latex}$", io.BytesIO(), format="svg")


def _lang_tables(step: dict[str, Any]) -> list[tuple[str, Any]]:
    """Every human-readable table of a step, with where it sits."""
    found: list[tuple[str, Any]] = [("title", step.get("title")), ("text", step.get("text"))]
    for group in ITEM_KEYS:
        for i, item in enumerate(step.get(group, [])):
            for key in LANG_KEYS & set(item):
                found.append((f"{group}[{i}].{key}", item[key]))
            for j, choice in enumerate(item.get("choices", []) if group == "questions" else []):
                found.append((f"{group}[{i}].choices[{j}]", choice))
            labels = item.get("labels")
            if isinstance(labels, list):
                for j, label in enumerate(labels):
                    found.append((f"{group}[{i}].labels[{j}].text", label.get("text")))
    return found


def _scene_path(step_path: Path, scene: str) -> Path:
    """A bundled scene's name, or a path relative to the step file."""
    if scene.endswith(".toml"):
        return (step_path.parent / scene).resolve()
    return SCENE_DIR / f"{scene}.toml"


def test_one_step_per_section() -> None:
    """Sections 1..13 each exactly once, in files named NN-slug.toml after the section."""
    assert STEPS, "no walkthrough/*.toml"
    sections = []
    for path in STEPS:
        match = re.fullmatch(r"(\d\d)-[a-z0-9-]+\.toml", path.name)
        assert match, f"{path.name}: not NN-slug.toml"
        section = _load(path)["section"]
        assert section == int(match.group(1)), f"{path.name}: section {section}"
        sections.append(section)
    assert sorted(sections) == list(SECTIONS)


@pytest.mark.parametrize("path", STEPS, ids=_ids(STEPS))
def test_format(path: Path) -> None:
    """Only the format's keys, its required ones present, at least one kind of image."""
    step = _load(path)
    assert set(step) <= TOP_KEYS, set(step) - TOP_KEYS
    assert {"section", "title", "text"} <= set(step)
    assert {"views", "comparisons", "sweeps", "plots"} & set(step), "no images"
    for group, (required, optional) in ITEM_KEYS.items():
        for i, item in enumerate(step.get(group, [])):
            where = f"{group}[{i}]"
            assert required <= set(item), f"{where}: missing {required - set(item)}"
            assert set(item) <= required | optional, f"{where}: {set(item) - required - optional}"
    for i, sweep in enumerate(step.get("sweeps", [])):
        assert 2 <= sweep["steps"] <= 9, f"sweeps[{i}].steps"
        assert sweep["keys"], f"sweeps[{i}].keys"
        if "format" in sweep:
            sweep["format"].format(sweep["from"])
        assert not {"format", "label"} <= set(sweep), f"sweeps[{i}]: label and format"
        for lang in ("en", "ko") if "label" in sweep else ():
            sweep["label"][lang].format(sweep["from"])
    for i, view in enumerate(step.get("views", [])):
        labels = view.get("labels", "names")
        assert isinstance(labels, list) or labels in ("names", "none"), f"views[{i}].labels"


@pytest.mark.parametrize("path", STEPS, ids=_ids(STEPS))
def test_both_languages(path: Path) -> None:
    """Every human-readable table has non-empty English and Korean, the Korean prose in
    Hangul (a label may be a name both languages share), and the text is of lesson length
    in each."""
    step = _load(path)
    for where, table in _lang_tables(step):
        assert isinstance(table, dict) and set(table) == LANGS, f"{where}: {table!r}"
        for lang in LANGS:
            assert isinstance(table[lang], str) and table[lang].strip(), f"{where}.{lang}"
        prose = "label" not in where  # a label may be a name both share: "GGX"
        assert not prose or HANGUL.search(table["ko"]), f"{where}.ko has no Hangul"
    text = step["text"]
    en, ko = len(text["en"].split()), len(text["ko"].split())
    assert EN_WORDS[0] <= en <= EN_WORDS[1], f"text.en: {en} words"
    assert KO_EOJEOL[0] <= ko <= KO_EOJEOL[1], f"text.ko: {ko} eojeol"


@pytest.mark.parametrize("path", STEPS, ids=_ids(STEPS))
def test_math_renders(path: Path) -> None:
    """Every equation and every inline $...$ of every text typesets with mathtext, and
    keeps to the subset (no \\text, \\begin, \\operatorname)."""
    step = _load(path)
    formulas = [(f"equations[{i}]", e["latex"]) for i, e in enumerate(step.get("equations", []))]
    for where, table in _lang_tables(step):
        for lang in LANGS:
            body = table[lang]
            assert body.count("$") % 2 == 0, f"{where}.{lang}: unbalanced $"
            formulas += [(f"{where}.{lang}", m) for m in INLINE_MATH.findall(body)]
    for where, latex in formulas:
        bad = FORBIDDEN.search(latex)
        assert bad is None, f"{where}: {bad.group()} is outside the subset (use \\mathrm)"
        try:
            _renders(latex)
        except ValueError as exc:
            pytest.fail(f"{path.name}: {where}: {latex!r}: {exc}")


@pytest.mark.parametrize("path", STEPS, ids=_ids(STEPS))
def test_scenes_keys_and_labels(path: Path) -> None:
    """Every scene exists; every compared or swept key takes both of its values on that
    scene (all of a sweep's keys together, as the sweep sets them); every label names an
    object of its view's scene by index or name."""
    step = _load(path)
    for group in ("views", "comparisons", "sweeps"):
        for i, item in enumerate(step.get(group, [])):
            scene_path = _scene_path(path, item["scene"])
            assert scene_path.is_file(), f"{group}[{i}].scene: {item['scene']}"
            base = load_scene(scene_path)
            if group == "comparisons":
                spec = CompareSpec(item["key"], item["a"], item["b"])
                spec.scenes(base)
            elif group == "sweeps":
                for side in ("a", "b"):
                    scene = base
                    for key in item["keys"]:
                        scene = CompareSpec(key, item["from"], item["to"]).scene_for(scene, side)
            elif isinstance(item.get("labels"), list):
                objects = base.scene.objects
                names = {o.name for o in objects if o.name}
                for j, label in enumerate(item["labels"]):
                    target = label["object"]
                    ok = 0 <= target < len(objects) if isinstance(target, int) else target in names
                    assert ok, f"views[{i}].labels[{j}].object: {target!r}"


@pytest.mark.parametrize("path", STEPS, ids=_ids(STEPS))
def test_plot_arguments_parse(path: Path) -> None:
    """Every plot's materials parse as ``pbs brdf`` arguments; its angles are in [0, 90]."""
    step = _load(path)
    for plot in step.get("plots", []):
        for arg in plot["materials"]:
            assert parse_material_arg(arg), arg
        for theta in plot.get("theta", []):
            assert 0.0 <= theta <= 90.0, theta
