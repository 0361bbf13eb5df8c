"""The walkthrough as an offline handout: ``index.html`` and ``walkthrough.md``.

The HTML page is self-contained within its folder: images from ``images/``, equations
and inline math as SVG drawn by matplotlib's mathtext, one stylesheet in the page. It
names no network address (no web font, no script, no MathJax), so it opens and prints
with the network off. The print stylesheet sets A4 pages, one step per page, images
scaled to the page width. Korean text is set in Noto Sans CJK KR (Debian's
``fonts-noto-cjk``), with ``word-break: keep-all`` so lines break between words.
"""

from __future__ import annotations

import html
from pathlib import Path

from app.output import atomic_write
from app.walkthrough.build import RenderedStep
from app.walkthrough.markup import to_html
from app.walkthrough.mathsvg import latex_to_svg
from app.walkthrough.model import Lang, Question
from app.walkthrough.questions import formatted

WORDS: dict[str, dict[Lang, str]] = {
    "title": {
        "en": "Physically Based Shading: a classroom walkthrough",
        "ko": "물리 기반 셰이딩: 단계별 수업 자료",
    },
    "subtitle": {
        "en": "Real-Time Rendering, 4th edition, chapter 9, section by section, "
        "rendered by the pbs lab",
        "ko": "실시간 렌더링(Real-Time Rendering) 4판 9장을 절마다 따라가며, "
        "pbs 실습 렌더러로 그린 그림",
    },
    "equations": {"en": "Equations", "ko": "수식"},
    "contents": {"en": "Contents", "ko": "목차"},
    "questions": {"en": "Predict, then reveal", "ko": "예측하고 확인하기"},
    "reveal": {"en": "Reveal", "ko": "정답 보기"},
    "answer": {"en": "Answer", "ko": "정답"},
    "fold": {
        "en": "Fold here: the answers below are printed upside down",
        "ko": "여기를 접으세요: 아래 정답은 거꾸로 인쇄되어 있습니다",
    },
}

# Latin first for English (DejaVu Sans, the labels' font), Noto Sans CJK KR first for
# Korean: its Latin glyphs match its Hangul in weight.
FONTS: dict[Lang, str] = {
    "en": '"DejaVu Sans", "Noto Sans CJK KR", sans-serif',
    "ko": '"Noto Sans CJK KR", "Noto Sans CJK", "DejaVu Sans", sans-serif',
}

STYLE = """
body { font-family: FONTS; line-height: 1.55; color: #111; background: #fff;
       max-width: 62em; margin: 0 auto; padding: 1.5em; }
html:lang(ko) body { word-break: keep-all; }
h1 { font-size: 1.7em; margin-bottom: 0.2em; }
h2 { font-size: 1.35em; border-bottom: 1px solid #bbb; padding-bottom: 0.2em; }
.subtitle { color: #444; margin-top: 0; }
nav ol { columns: 2; }
code { font-family: "DejaVu Sans Mono", monospace; background: #f2f2f2; padding: 0 0.2em; }
.equation { text-align: center; margin: 0.8em 0; }
.equation figcaption, figure.image figcaption { font-size: 0.9em; color: #333; }
.math svg { vertical-align: middle; }
.equation svg { max-width: 100%; height: auto; }
figure.image { margin: 1em 0; break-inside: avoid; }
figure.image img { display: block; max-width: 100%; height: auto; margin: 0 auto; }
.questions { border: 1px solid #bbb; border-radius: 6px; padding: 0.2em 1em 0.6em;
             margin: 1.2em 0; background: #fafafa; break-inside: avoid; }
.questions h3 { font-size: 1.1em; margin: 0.6em 0 0.3em; }
.question { margin: 0.6em 0; }
.question ol.choices { margin: 0.2em 0; }
input.reveal { position: absolute; opacity: 0; }
label.reveal { display: inline-block; cursor: pointer; border: 1px solid #666;
               border-radius: 4px; padding: 0.1em 0.7em; font-size: 0.9em; background: #fff; }
input.reveal:focus-visible + label.reveal { outline: 2px solid #36c; }
.question .answer { display: none; border-left: 3px solid #4a4; padding-left: 0.8em;
                    margin-top: 0.4em; }
input.reveal:checked + label.reveal + .answer { display: block; }
.answer img { max-width: 70%; height: auto; display: block; margin: 0.4em 0; }
.answer-key { display: none; }
@page { size: A4; margin: 14mm; }
@media print {
  label.reveal, .question .answer { display: none !important; }
  .answer-key { display: block; margin-top: 0.8em; }
  .answer-key .fold { border-top: 1px dashed #666; text-align: center; font-size: 0.85em;
                      color: #444; padding-top: 0.2em; }
  .answer-key .upside-down { transform: rotate(180deg); font-size: 0.92em; }
  body { max-width: none; padding: 0; font-size: 10.5pt; }
  nav { display: none; }
  section.step { break-before: page; }
  figure.image img { max-width: 100%; max-height: 200mm; }
  h2 { break-after: avoid; }
}
"""


def _math_inline(latex: str) -> str:
    """Inline ``$...$`` math: an SVG sitting on the text's baseline."""
    math = latex_to_svg(latex, size_pt=12.0)
    svg = math.svg.replace("<svg ", f'<svg style="vertical-align:-{math.depth_pt:.2f}pt" ', 1)
    return f'<span class="math">{svg}</span>'


def _section(n: int) -> str:
    return f"§9.{n}"


def _step_html(done: RenderedStep, lang: Lang) -> str:
    step = done.loaded.step
    parts = [
        f'<section class="step" id="{html.escape(done.loaded.slug)}">',
        f"<h2>{_section(step.section)} {html.escape(step.title.get(lang))}</h2>",
        f'<div class="text">{to_html(step.text.get(lang), _math_inline)}</div>',
    ]
    for equation in step.equations:
        svg = latex_to_svg(equation.latex).svg
        caption = (
            f"<figcaption>{to_html(equation.caption.get(lang), _math_inline)}</figcaption>"
            if equation.caption is not None
            else ""
        )
        parts.append(f'<figure class="equation">{svg}{caption}</figure>')
    for figure in done.figures:
        caption = (
            f"<figcaption>{to_html(figure.caption, _math_inline)}</figcaption>"
            if figure.caption
            else ""
        )
        parts.append(
            f'<figure class="image {figure.kind}"><img src="{html.escape(figure.image)}" '
            f'alt="{html.escape(figure.alt)}">{caption}</figure>'
        )
    if step.questions:
        parts.append(_questions_html(done, lang))
    parts.append("</section>")
    return "\n".join(parts)


def _letter(i: int) -> str:
    return "ABCD"[i]


def _answer_html(question: Question, lang: Lang) -> str:
    """The reveal's text: the right choice's letter, the answer with its computed numbers."""
    head = WORDS["answer"][lang]
    if question.correct is not None:
        head += f" {_letter(question.correct)}"
    text = question.answer_text(lang, formatted(question.numbers))
    return to_html(f"**{head}.** {text}", _math_inline)


def _questions_html(done: RenderedStep, lang: Lang) -> str:
    """The step's questions: each with its choices and a "Reveal" control (a checkbox and
    its label: no script) that shows the answer with its view; in print the answers move
    below a fold line, upside down."""
    step, slug = done.loaded.step, done.loaded.slug
    views = [f for f in done.figures if f.kind == "view"]
    out = [f'<div class="questions"><h3>{html.escape(WORDS["questions"][lang])}</h3>']
    key = []
    for i, q in enumerate(step.questions):
        qid = f"{slug}-q{i + 1}"
        out.append(f'<div class="question" id="{html.escape(qid)}">')
        ask = to_html(f"**Q{i + 1}.** {q.ask.get(lang)}", _math_inline)
        out.append(f'<div class="ask">{ask}</div>')
        if q.choices:
            items = "".join(f"<li>{to_html(c.get(lang), _math_inline)}</li>" for c in q.choices)
            out.append(f'<ol class="choices" type="A">{items}</ol>')
        answer = _answer_html(q, lang)
        image = ""
        if q.view is not None and q.view < len(views):
            figure = views[q.view]
            image = f'<img src="{html.escape(figure.image)}" alt="{html.escape(figure.alt)}">'
        out.append(
            f'<input type="checkbox" class="reveal" id="{html.escape(qid)}-reveal">'
            f'<label class="reveal" for="{html.escape(qid)}-reveal">'
            f"{html.escape(WORDS['reveal'][lang])}</label>"
            f'<div class="answer">{answer}{image}</div>'
        )
        out.append("</div>")
        key.append(f'<div class="key-item">{to_html(f"Q{i + 1}.", _math_inline)}{answer}</div>')
    out.append(
        f'<div class="answer-key"><div class="fold">{html.escape(WORDS["fold"][lang])}</div>'
        f'<div class="upside-down">{"".join(key)}</div></div>'
    )
    out.append("</div>")
    return "\n".join(out)


def handout_html(rendered: list[RenderedStep], lang: Lang) -> str:
    """The handout page for ``lang``."""
    toc = "".join(
        f'<li><a href="#{html.escape(d.loaded.slug)}">{_section(d.loaded.step.section)} '
        f"{html.escape(d.loaded.step.title.get(lang))}</a></li>"
        for d in rendered
    )
    body = "\n".join(_step_html(d, lang) for d in rendered)
    title = html.escape(WORDS["title"][lang])
    return (
        f'<!DOCTYPE html>\n<html lang="{lang}">\n<head>\n<meta charset="utf-8">\n'
        f'<meta name="viewport" content="width=device-width, initial-scale=1">\n'
        f"<title>{title}</title>\n<style>{STYLE.replace('FONTS', FONTS[lang])}</style>\n"
        f"</head>\n<body>\n<header><h1>{title}</h1>"
        f'<p class="subtitle">{html.escape(WORDS["subtitle"][lang])}</p></header>\n'
        f"<nav><h2>{WORDS['contents'][lang]}</h2><ol>{toc}</ol></nav>\n"
        f"{body}\n</body>\n</html>\n"
    )


def handout_markdown(rendered: list[RenderedStep], lang: Lang) -> str:
    """The Markdown version: the text as written, equations as ``$$ ... $$``, images
    linked."""
    lines = [f"# {WORDS['title'][lang]}", "", WORDS["subtitle"][lang], ""]
    for done in rendered:
        step = done.loaded.step
        heading = f"## {_section(step.section)} {step.title.get(lang)}"
        lines += [heading, "", step.text.get(lang).strip(), ""]
        for equation in step.equations:
            lines += [f"$$ {equation.latex} $$", ""]
            if equation.caption is not None:
                lines += [f"*{equation.caption.get(lang)}*", ""]
        for figure in done.figures:
            lines += [f"![{figure.caption or figure.alt}]({figure.image})", ""]
            if figure.caption:
                lines += [f"*{figure.caption}*", ""]
        if step.questions:
            lines += [f"### {WORDS['questions'][lang]}", ""]
        views = [f for f in done.figures if f.kind == "view"]
        for i, q in enumerate(step.questions):
            lines += [f"**Q{i + 1}.** {q.ask.get(lang)}", ""]
            for j, choice in enumerate(q.choices or []):
                lines.append(f"- {_letter(j)}. {choice.get(lang)}")
            head = WORDS["answer"][lang]
            if q.correct is not None:
                head += f" {_letter(q.correct)}"
            text = q.answer_text(lang, formatted(q.numbers))
            lines += ["", f"<details><summary>{WORDS['reveal'][lang]}</summary>", "",
                      f"**{head}.** {text}", ""]  # fmt: skip
            if q.view is not None and q.view < len(views):
                lines += [f"![{views[q.view].alt}]({views[q.view].image})", ""]
            lines += ["</details>", ""]
    return "\n".join(lines)


def write_handout(out: Path, rendered: list[RenderedStep], lang: Lang) -> tuple[Path, Path]:
    """Write ``out/index.html`` and ``out/walkthrough.md``; return their paths."""
    page, markdown = out / "index.html", out / "walkthrough.md"
    text = handout_html(rendered, lang)
    atomic_write(page, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    md = handout_markdown(rendered, lang)
    atomic_write(markdown, lambda tmp: tmp.write_text(md, encoding="utf-8"))
    return page, markdown
