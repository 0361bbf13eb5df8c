"""Predict, then reveal (docs/walkthrough.md, "Questions"): every step asks one or two
questions in both languages; each number a reveal quotes is computed by the float64 twins
and recomputed here through another path (the GLSL the renderer runs, or the closed form
the quantity names) to the digits shown; the handout shows every question, hides its
answer behind a "Reveal" control and prints the answers below a fold; a broken question is
one error naming its key.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from app.errors import InputError
from app.walkthrough.build import Figure, RenderedStep
from app.walkthrough.handout import handout_html, handout_markdown
from app.walkthrough.model import NUMBER_SLOT, load_step, load_walkthrough, parse_step
from app.walkthrough.questions import formatted, value
from tests.conftest import REPO

# Words a question may take, per language: the prompt and its choices, and the answer
# (the step's text has its own limit, 250, in tests/test_walkthrough_content.py).
ASK_WORDS = 70
ANSWER_WORDS = 90


@pytest.fixture(scope="module")
def steps():
    return load_walkthrough(REPO / "walkthrough")


def _numbers(steps):
    return [
        (f"{s.slug}:questions[{i}].numbers[{j}]", n)
        for s in steps
        for i, q in enumerate(s.step.questions)
        for j, n in enumerate(q.numbers)
    ]


def test_every_step_asks_one_or_two_questions_in_both_languages(steps) -> None:
    assert len(steps) == 13
    for s in steps:
        questions = s.step.questions
        assert 1 <= len(questions) <= 2, (s.slug, len(questions))
        for i, q in enumerate(questions):
            where = f"{s.slug}:questions[{i}]"
            assert q.view is not None or q.numbers, where  # a reveal shows something
            for lang in ("en", "ko"):
                asked = [q.ask.get(lang), *(c.get(lang) for c in q.choices or [])]
                words = sum(len(t.split()) for t in asked)
                assert words <= ASK_WORDS, f"{where}.ask.{lang}: {words} words"
                answer = len(q.answer.get(lang).split())
                assert answer <= ANSWER_WORDS, f"{where}.answer.{lang}: {answer} words"
                assert f"RTR4 §9.{s.step.section}" in q.ask.get(lang), f"{where}.ask.{lang}"
            assert re.search("[\uac00-\ud7a3]", q.ask.ko) and re.search(
                "[\uac00-\ud7a3]", q.answer.ko
            )


def _closed_form(number) -> float:
    """The quantity by its textbook formula, written here apart from the twins."""
    kind = number.quantity
    if kind == "f0":
        return ((number.ior - number.medium_ior) / (number.ior + number.medium_ior)) ** 2
    if kind == "critical_angle":
        return math.degrees(math.asin(number.medium_ior / number.ior))
    if kind == "fresnel":
        c = math.cos(math.radians(number.theta))
        n1, n2 = number.medium_ior, number.ior
        if number.form == "schlick":
            f0 = ((n2 - n1) / (n2 + n1)) ** 2
            return f0 + (1 - f0) * (1 - c) ** 5
        s = n1 / n2 * math.sin(math.radians(number.theta))
        ct = math.sqrt(1 - s * s)
        rs = (n1 * c - n2 * ct) / (n1 * c + n2 * ct)
        rp = (n2 * c - n1 * ct) / (n2 * c + n1 * ct)
        return 0.5 * (rs * rs + rp * rp)
    if kind == "falloff":

        def at(d: float) -> float:
            return max(1 - (d / number.range) ** 4, 0) ** 2 / (d * d)

        return at(number.distance) / at(number.reference_distance)
    if kind == "display":
        x = number.radiance * 2**number.exposure
        assert number.tonemap == "linear", "the closed form here is the linear one"
        x = min(x, 1.0)
        srgb = 12.92 * x if x <= 0.0031308 else 1.055 * x ** (1 / 2.4) - 0.055
        return round(srgb * 255)
    raise AssertionError(kind)


def _same_digits(shown: str, fmt: str, other: float) -> bool:
    """``other`` written in ``fmt`` is ``shown``, or one unit of the last digit away (a
    value on a rounding boundary)."""
    if fmt.format(other) == shown:
        return True
    digits = len(shown.split(".")[1]) if "." in shown else 0
    return abs(float(shown) - other) <= 1.0001 * 10.0**-digits


def test_closed_form_numbers_recomputed(steps) -> None:
    """Every Fresnel, F0, critical-angle, falloff and (linear) display number of a reveal,
    as shown, equals the closed form's value in the same format."""
    checked = 0
    for where, n in _numbers(steps):
        if n.quantity in ("albedo", "reflected") or getattr(n, "tonemap", "linear") != "linear":
            continue
        shown = n.format.format(value(n))
        assert _same_digits(shown, n.format, _closed_form(n)), (where, shown, _closed_form(n))
        checked += 1
    assert checked >= 8


@pytest.mark.gl
def test_furnace_and_light_numbers_recomputed_by_the_glsl(steps) -> None:
    """Every albedo (white furnace) and reflected-light number of a reveal, computed by the
    float64 twin, is what the renderer's GLSL BRDF gives to the digits shown."""
    checked = 0
    for where, n in _numbers(steps):
        if n.quantity not in ("albedo", "reflected"):
            continue
        shown = n.format.format(value(n))
        glsl = n.compute("glsl")
        assert _same_digits(shown, n.format, glsl), (where, shown, glsl)
        checked += 1
    assert checked >= 20


def test_neutral_display_number_is_the_post_pass_twin(steps) -> None:
    from app.reference.tonemap import tonemap_khronos_neutral

    for where, n in _numbers(steps):
        if getattr(n, "tonemap", None) == "neutral":
            x = tonemap_khronos_neutral(np.full(3, n.radiance * 2**n.exposure))[0]
            srgb = 1.055 * x ** (1 / 2.4) - 0.055
            assert n.format.format(value(n)) == f"{round(srgb * 255):.0f}", where


def _page(steps, lang: str) -> str:
    rendered = []
    for s in steps:
        views = [
            Figure("view", f"images/{s.slug}-view-{i}.png", None, v.scene)
            for i, v in enumerate(s.step.views)
        ]
        rendered.append(RenderedStep(s, views))
    return handout_html(rendered, lang), handout_markdown(rendered, lang)


@pytest.mark.parametrize("lang", ["en", "ko"])
def test_the_handout_shows_each_question_and_its_computed_answer(steps, lang) -> None:
    page, markdown = _page(steps, lang)
    total = sum(len(s.step.questions) for s in steps)
    assert page.count('class="question"') == total
    assert page.count('<input type="checkbox" class="reveal"') == total
    assert page.count('class="answer-key"') == 13  # the print's answers, after a fold
    assert markdown.count("<details>") == total
    for s in steps:
        for q in s.step.questions:
            text = q.answer_text(lang, formatted(q.numbers))
            assert NUMBER_SLOT.search(text) is None
            for shown in formatted(q.numbers):
                assert shown in page and shown in markdown
            if q.view is not None:
                assert f"images/{s.slug}-view-{q.view}.png" in page
    assert "{=" not in page and "{=" not in markdown


def _step_with(question: str) -> str:
    return (REPO / "walkthrough" / "03-the-brdf.toml").read_text(encoding="utf-8").split(
        "[[questions]]"
    )[0] + question


@pytest.mark.parametrize(
    ("question", "key"),
    [
        # a number without its place in the answer
        ('[[questions]]\nask = { en = "a", ko = "가" }\nanswer = { en = "b", ko = "나" }\n'
         'numbers = [{ quantity = "f0", ior = 1.5 }]\n', "questions[0].answer"),
        # choices without the right one
        ('[[questions]]\nask = { en = "a", ko = "가" }\nanswer = { en = "b", ko = "나" }\n'
         'view = 0\nchoices = [{ en = "x", ko = "엑스" }, { en = "y", ko = "와이" }]\n',
         "questions[0].correct"),
        # a view the step does not have
        ('[[questions]]\nask = { en = "a", ko = "가" }\nanswer = { en = "b", ko = "나" }\n'
         "view = 9\n", "questions[0].view"),
        # a material pbs brdf refuses
        ('[[questions]]\nask = { en = "a", ko = "가" }\n'
         'answer = { en = "b {=0}", ko = "나 {=0}" }\n'
         "numbers = [{ quantity = \"albedo\", material = '{ roughnes = 0.3 }' }]\n",
         "questions[0].numbers[0].material"),
        # an unknown quantity
        ('[[questions]]\nask = { en = "a", ko = "가" }\n'
         'answer = { en = "b {=0}", ko = "나 {=0}" }\n'
         'numbers = [{ quantity = "luck" }]\n', "questions[0].numbers[0]"),
    ],
)  # fmt: skip
def test_a_broken_question_is_one_error_naming_its_key(tmp_path: Path, question, key) -> None:
    import tomllib

    path = tmp_path / "03-the-brdf.toml"
    path.write_text(_step_with(question), encoding="utf-8")
    with pytest.raises(InputError) as err:
        parse_step(
            tomllib.loads(path.read_text(encoding="utf-8")), REPO / "walkthrough" / path.name
        )
    assert err.value.key.startswith(key), (err.value.key, err.value.message)


def test_the_bundled_steps_load_with_their_questions() -> None:
    loaded = load_step(REPO / "walkthrough" / "05-fresnel-reflectance.toml")
    assert len(loaded.step.questions) == 2


_needs_chromium = pytest.mark.skipif(
    __import__("shutil").which("chromium") is None and not Path("/usr/bin/chromium").is_file(),
    reason="Debian's chromium is not installed (bash scripts/dev.sh setup)",
)

_STATE = """(() => {
  const q = document.querySelector('.question');
  const a = q.querySelector('.answer'), key = document.querySelector('.answer-key');
  return {answer: a.getBoundingClientRect().height,
          key: key.getBoundingClientRect().height,
          turn: getComputedStyle(key.querySelector('.upside-down')).transform};
})()"""


@_needs_chromium
def test_chromium_hides_the_answer_until_reveal_and_prints_it_upside_down(steps, tmp_path):
    """In headless Chromium the first answer takes no room until its Reveal label is
    clicked (no script in the page: a checkbox and its label); printed, the answers stand
    below the fold, turned 180 degrees, and the Reveal controls are gone."""
    from app.walkthrough.browser import Browser

    page, _ = _page(steps[2:3], "ko")
    path = tmp_path / "index.html"
    path.write_text(page, encoding="utf-8")
    with Browser(900, 1200) as browser:
        browser.open(path)
        before = browser.evaluate(_STATE)
        assert before["answer"] == 0 and before["key"] == 0
        browser.evaluate("document.querySelector('label.reveal').click()")
        after = browser.evaluate(_STATE)
        assert after["answer"] > 20
        browser.call("Emulation.setEmulatedMedia", {"media": "print"}, session=True)
        printed = browser.evaluate(_STATE)
        labels = browser.evaluate(
            "document.querySelector('label.reveal').getBoundingClientRect().height"
        )
    assert printed["answer"] == 0 and labels == 0
    assert printed["key"] > 20
    # rotate(180deg) as a matrix: (-1, ~0, ~0, -1, 0, 0)
    values = [float(x) for x in printed["turn"].removeprefix("matrix(").rstrip(")").split(",")]
    assert values[0] == pytest.approx(-1) and values[3] == pytest.approx(-1)
