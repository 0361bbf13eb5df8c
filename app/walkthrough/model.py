"""The walkthrough's step format (docs/walkthrough.md) and its loader.

A step is validated like a scene: unknown keys, missing ``en``/``ko``, a section outside
1..13, a scene that does not exist, a key path the scene does not have or a value it
refuses, an object label naming no object, LaTeX that mathtext cannot lay out, a BRDF
plot material ``pbs brdf`` refuses: each is one ``InputError`` naming the step file and
the key (``comparisons[0].key``), which the CLI prints on one line and exits 2.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from app.errors import InputError
from app.scene.edits import KeyPathError, edited, parse_key
from app.scene.loader import (
    LoadedScene,
    describe_error,
    key_path,
    load_scene,
    read_toml,
)
from app.untrusted import RefusedError, files
from app.untrusted.policy import DEFAULT_POLICY
from app.walkthrough.questions import Quantity

LANGUAGES: tuple[str, ...] = ("en", "ko")
Lang = Literal["en", "ko"]
SECTIONS = range(1, 14)  # RTR4 §9.1 .. §9.13, the seed's 13 sections
MAX_SWEEP_STEPS = 9
MAX_QUESTIONS = 2  # per step: predict, then reveal (docs/walkthrough.md, "Questions")
# A number's place in a question's answer: {=0}, {=1}, ... (braces alone are LaTeX's)
NUMBER_SLOT = re.compile(r"\{=(\d+)\}")

# A loc part that pydantic adds for a union member (``list[Label]``), not a key of the file.
_KEY_PART = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, frozen=True)


class Text(_Strict):
    """A human-readable string in both languages."""

    en: Annotated[str, Field(min_length=1)]
    ko: Annotated[str, Field(min_length=1)]

    def get(self, lang: Lang) -> str:
        return self.en if lang == "en" else self.ko


class Equation(_Strict):
    """One equation of the section, LaTeX (matplotlib's mathtext subset)."""

    latex: Annotated[str, Field(min_length=1)]
    caption: Text | None = None


class Label(_Strict):
    """An explicit label: ``object`` is an index into the scene's [[objects]] or a name."""

    object: Annotated[int, Field(strict=True, ge=0)] | str
    text: Text


class View(_Strict):
    """A plain image of a scene with its objects labelled."""

    scene: str
    caption: Text | None = None
    labels: Literal["names", "none"] | list[Label] = "names"


class Comparison(_Strict):
    """An A/B pair: the scene with ``key`` set to ``a`` and to ``b`` (docs/compare.md)."""

    scene: str
    key: str
    a: Any
    b: Any
    label_a: Text
    label_b: Text
    caption: Text | None = None


class Sweep(_Strict):
    """``steps`` images with every key of ``keys`` set to values from ``from`` to ``to``.
    Under each frame: ``label`` in the handout's language, a format of the value
    (``{ en = "roughness {:.2f}", ko = "거칠기 {:.2f}" }``), or, without one, the first
    key's last name and the value in ``format``."""

    model_config = ConfigDict(populate_by_name=True)

    scene: str
    keys: Annotated[list[str], Field(min_length=1)]
    start: Annotated[float, Field(alias="from")]
    to: float
    steps: Annotated[int, Field(strict=True, ge=2, le=MAX_SWEEP_STEPS)]
    caption: Text | None = None
    format: str = "{:.2f}"
    label: Text | None = None

    @model_validator(mode="after")
    def _check(self) -> Sweep:
        if self.label is not None and "format" in self.model_fields_set:
            raise ValueError("label: give either label (the whole text) or format, not both")
        try:
            self.format.format(self.start)
        except (ValueError, IndexError, KeyError) as exc:
            raise ValueError(f"format: not a Python format for one number ({exc})") from None
        return self

    def values(self) -> list[float]:
        """The swept values, ``from`` to ``to`` in ``steps`` even steps."""
        return [float(v) for v in np.linspace(self.start, self.to, self.steps)]

    def value_text(self, value: float, lang: Lang) -> str:
        """The text under a frame: ``label`` in ``lang`` with the value (``거칠기 0.50``),
        else the first key's last name and the value in ``format`` (``roughness = 0.50``)."""
        if self.label is not None:
            return self.label.get(lang).format(value)
        names = [p for p in parse_key(self.keys[0]) if isinstance(p, str)]
        return f"{names[-1]} = {self.format.format(value)}"


class Plot(_Strict):
    """BRDF lobes and albedo of materials, as ``pbs brdf`` plots them (``kind = "lobes"``);
    or a figure of app/brdf/figures.py: ``"vndf"``, the visible-normal sample clouds and the
    albedo estimators' variance at the materials' roughnesses and the ``theta`` views;
    ``"layered_furnace"``, the coated materials' white furnace beside the random walk;
    ``"prefilter"``, the environment prefilter's Monte Carlo at several sample counts
    against its exact integral, at the materials' roughnesses."""

    kind: Literal["lobes", "vndf", "layered_furnace", "prefilter"] = "lobes"
    materials: Annotated[list[str], Field(min_length=1)]
    theta: Annotated[list[Annotated[float, Field(ge=0.0, le=90.0)]], Field(min_length=1)] | None = (
        None
    )
    caption: Text | None = None


class Question(_Strict):
    """Predict, then reveal: ``ask`` the class, with ``choices`` (``correct`` the right
    one's index) or none (a short answer said aloud); the reveal is ``answer`` with the
    step's view ``view`` and the ``numbers`` the twins compute, each in its place
    ``{=k}`` of the answer in its ``format`` (app/walkthrough/questions.py)."""

    ask: Text
    choices: Annotated[list[Text], Field(min_length=2, max_length=4)] | None = None
    correct: Annotated[int, Field(strict=True, ge=0)] | None = None
    answer: Text
    view: Annotated[int, Field(strict=True, ge=0)] | None = None
    numbers: list[Quantity] = []

    @model_validator(mode="after")
    def _check(self) -> Question:
        if (self.choices is None) != (self.correct is None):
            raise ValueError("correct: give choices and the correct one's index together")
        if (
            self.choices is not None
            and self.correct is not None
            and (self.correct >= len(self.choices))
        ):
            raise ValueError(f"correct: {self.correct} is past the {len(self.choices)} choices")
        if self.view is None and not self.numbers:
            raise ValueError("answer: a reveal shows a view of the step or a computed number")
        for lang in LANGUAGES:
            used = {int(k) for k in NUMBER_SLOT.findall(self.answer.get(lang))}  # type: ignore[arg-type]
            wanted = set(range(len(self.numbers)))
            if used != wanted:
                raise ValueError(
                    f"answer: the {lang} text places {sorted(used)} for {len(self.numbers)} "
                    "numbers (each number once or more as {=0}, {=1}, ...)"
                )
        for i, number in enumerate(self.numbers):
            try:
                number.format.format(1.0)
            except (ValueError, IndexError, KeyError) as exc:
                why = f"numbers: number {i}'s format does not format a number ({exc})"
                raise ValueError(why) from None
        return self

    def answer_text(self, lang: Lang, values: list[str]) -> str:
        """The answer in ``lang`` with the formatted numbers in their places."""
        return NUMBER_SLOT.sub(lambda m: values[int(m.group(1))], self.answer.get(lang))


class Step(_Strict):
    """One step of the walkthrough: one section of RTR4 chapter 9."""

    section: Annotated[int, Field(strict=True, ge=SECTIONS.start, le=SECTIONS.stop - 1)]
    title: Text
    text: Text
    equations: list[Equation] = []
    views: list[View] = []
    comparisons: list[Comparison] = []
    sweeps: list[Sweep] = []
    plots: list[Plot] = []
    questions: Annotated[list[Question], Field(max_length=MAX_QUESTIONS)] = []

    @model_validator(mode="after")
    def _check(self) -> Step:
        if not (self.views or self.comparisons or self.sweeps or self.plots):
            raise ValueError(
                "views: a step needs at least one of views, comparisons, sweeps, plots"
            )
        return self


@dataclass(frozen=True)
class LoadedStep:
    """A validated step, its file, and every scene it names (loaded once, by reference)."""

    step: Step
    path: Path
    scenes: dict[str, LoadedScene]

    @property
    def slug(self) -> str:
        """The file's name without ``.toml`` (``05-fresnel``): names the step's images."""
        return self.path.stem

    def scene(self, ref: str) -> LoadedScene:
        return self.scenes[ref]


def resolve_scene_ref(ref: str, step_path: Path) -> Path:
    """A step's scene reference: a bundled scene's name (``sec8_ndf``), or a path ending
    in ``.toml`` relative to the step file."""
    from app.resources import scenes_dir

    if ref.endswith(".toml") or "/" in ref or "\\" in ref:
        # Confined like every reference: a step file reads only its own folder's scenes
        # (and the bundled ones) (app/untrusted/files.py).
        return files.confine(ref, step_path, DEFAULT_POLICY)
    return scenes_dir() / f"{ref}.toml"


def _error(path: Path, key: str, message: str) -> InputError:
    return InputError(str(path), key, message)


def _load_scenes(step: Step, path: Path) -> dict[str, LoadedScene]:
    scenes: dict[str, LoadedScene] = {}
    for kind in ("views", "comparisons", "sweeps"):
        for i, item in enumerate(getattr(step, kind)):
            ref = item.scene
            if ref in scenes:
                continue
            try:
                file = resolve_scene_ref(ref, path)
            except RefusedError as exc:
                raise _error(path, f"{kind}[{i}].scene", str(exc)) from None
            if not file.is_file():
                raise _error(
                    path,
                    f"{kind}[{i}].scene",
                    f"no such scene '{ref}' (a bundled scene's name like sec8_ndf, or a "
                    f".toml path relative to the step file; looked for {file})",
                )
            try:
                scenes[ref] = load_scene(file)
            except InputError as exc:
                why = f"the scene does not load: {exc}"
                raise _error(path, f"{kind}[{i}].scene", why) from None
    return scenes


def _check_labels(view: View, loaded: LoadedScene, path: Path, where: str) -> None:
    if not isinstance(view.labels, list):
        return
    objects = loaded.scene.objects
    names = [obj.name for obj in objects]
    for j, label in enumerate(view.labels):
        key = f"{where}.labels[{j}].object"
        if isinstance(label.object, int):
            if label.object >= len(objects):
                raise _error(path, key, f"no object {label.object}: the scene has {len(objects)}")
        elif label.object not in names:
            known = ", ".join(repr(n) for n in names if n) or "no named objects"
            raise _error(path, key, f"no object named {label.object!r} (named: {known})")


def with_values(
    loaded: LoadedScene, keys: list[str], value: object, path: Path, where: str, origin: str
) -> LoadedScene:
    """``loaded`` with every key path set to ``value``, validated as a scene file: a
    missing key is an error at ``where``'s key, a refused value at ``origin``'s."""
    # The step's field of each key.
    fields = [
        f"{where}.keys[{j}]" if where.startswith("sweeps") else f"{where}.key"
        for j in range(len(keys))
    ]
    try:
        return edited(loaded, [(key, value) for key in keys], where)
    except KeyPathError as exc:  # malformed, or a step missing: the key is wrong
        raise _error(path, fields[exc.edit or 0], f"{exc.key}: {exc.message}") from None
    except InputError as exc:
        scene = loaded.path.stem
        # A misspelt last name is added as a new key, which the scene refuses as unknown:
        # the key is wrong, not the value.
        named = {key_path(parse_key(k)): field for k, field in zip(keys, fields, strict=True)}
        unknown = exc.message == "unknown key" and exc.key in named
        raise _error(
            path,
            named[exc.key] if unknown else origin,
            f"{exc.key}: {exc.message} (scene {scene}, value {value!r})",
        ) from None


def _check_keys(step: Step, scenes: dict[str, LoadedScene], path: Path) -> None:
    for i, view in enumerate(step.views):
        _check_labels(view, scenes[view.scene], path, f"views[{i}]")
    for i, comp in enumerate(step.comparisons):
        where = f"comparisons[{i}]"
        for side in ("a", "b"):
            value = getattr(comp, side)
            with_values(scenes[comp.scene], [comp.key], value, path, where, f"{where}.{side}")
    for i, sweep in enumerate(step.sweeps):
        where = f"sweeps[{i}]"
        values = sweep.values()
        for k, value in enumerate(values):
            end = "to" if k == len(values) - 1 else "from"
            with_values(scenes[sweep.scene], sweep.keys, value, path, where, f"{where}.{end}")


def _check_math(step: Step, path: Path) -> None:
    from app.walkthrough.markup import problem
    from app.walkthrough.mathsvg import check_latex

    for lang in LANGUAGES:
        why = problem(step.text.get(lang))
        if why is not None:
            raise _error(path, f"text.{lang}", why)
    for i, equation in enumerate(step.equations):
        why = check_latex(equation.latex)
        if why is not None:
            raise _error(path, f"equations[{i}].latex", f"mathtext cannot lay it out: {why}")
    for i, question in enumerate(step.questions):
        texts = [("ask", question.ask), ("answer", question.answer)]
        texts += [(f"choices[{j}]", c) for j, c in enumerate(question.choices or [])]
        for key, text in texts:
            for lang in LANGUAGES:
                why = problem(text.get(lang))  # type: ignore[arg-type]
                if why is not None:
                    raise _error(path, f"questions[{i}].{key}.{lang}", why)
    for kind in ("equations", "views", "comparisons", "sweeps", "plots"):
        for i, item in enumerate(getattr(step, kind)):
            if item.caption is None:
                continue
            for lang in LANGUAGES:
                why = problem(item.caption.get(lang))
                if why is not None:
                    raise _error(path, f"{kind}[{i}].caption.{lang}", why)


def _check_sweep_labels(step: Step, path: Path) -> None:
    for i, sweep in enumerate(step.sweeps):
        if sweep.label is None:
            continue
        for lang in LANGUAGES:
            try:
                sweep.label.get(lang).format(sweep.start)
            except (ValueError, IndexError, KeyError) as exc:
                why = f"not a Python format for one number ({exc})"
                raise _error(path, f"sweeps[{i}].label.{lang}", why) from None


def _check_plots(step: Step, path: Path) -> None:
    from app.brdf.plot import parse_material_arg

    for i, question in enumerate(step.questions):
        for j, number in enumerate(question.numbers):
            material = getattr(number, "material", None)
            if material is None:
                continue
            try:
                parse_material_arg(material)
            except InputError as exc:
                raise _error(path, f"questions[{i}].numbers[{j}].material", str(exc)) from None
    for i, plot in enumerate(step.plots):
        for j, material in enumerate(plot.materials):
            try:
                parse_material_arg(material)
            except InputError as exc:
                raise _error(path, f"plots[{i}].materials[{j}]", str(exc)) from None


def parse_step(data: dict, path: Path) -> LoadedStep:
    """Validate a step's parsed TOML: the format, then everything it names."""
    try:
        step = Step.model_validate(data)
    except ValidationError as exc:
        error = exc.errors()[0]
        loc = tuple(p for p in error["loc"] if isinstance(p, int) or _KEY_PART.match(p))
        key, message = describe_error({**error, "loc": loc})
        raise _error(path, key, message) from None
    for i, question in enumerate(step.questions):
        if question.view is not None and question.view >= len(step.views):
            why = f"no view {question.view}: the step has {len(step.views)}"
            raise _error(path, f"questions[{i}].view", why)
    _check_math(step, path)
    _check_sweep_labels(step, path)
    scenes = _load_scenes(step, path)
    _check_keys(step, scenes, path)
    _check_plots(step, path)
    return LoadedStep(step, path, scenes)


def load_step(path: str | Path) -> LoadedStep:
    """Read and validate one step file (``walkthrough/NN-slug.toml``)."""
    path = Path(path)
    return parse_step(read_toml(path, "step file"), path)


def load_walkthrough(folder: str | Path, sections: set[int] | None = None) -> list[LoadedStep]:
    """Every step file ``*.toml`` of ``folder`` in file-name order (NN-slug: lesson
    order), validated; with ``sections``, only the steps of those sections (one that no
    step has is an error)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise _error(folder, "", "no such folder of walkthrough steps")
    steps = [load_step(file) for file in sorted(folder.glob("*.toml"))]
    if not steps:
        raise _error(folder, "", "no step files (*.toml) in the folder")
    if sections is not None:
        missing = sorted(sections - {s.step.section for s in steps})
        if missing:
            have = ", ".join(str(s.step.section) for s in steps)
            raise _error(folder, "--steps", f"no step for section(s) {missing} (steps: {have})")
        steps = [s for s in steps if s.step.section in sections]
    return steps
