"""The step text's small Markdown subset, to HTML (docs/walkthrough.md).

Paragraphs are separated by blank lines; a block whose first line starts with ``- `` is a
bullet list (a line that does not start with ``- `` continues the item above it).
Inline: ``**bold**``, ``*italic*``, ```code```, and ``$...$`` math, drawn as inline
SVG by ``app.walkthrough.mathsvg``; ``\\$`` is a literal dollar sign. Everything else is
text, HTML-escaped. The Markdown version of the handout keeps the text as written.
"""

from __future__ import annotations

import html
import re
from collections.abc import Callable

# A code span, or math between unescaped dollars (on one line).
_SPAN = re.compile(r"(`[^`\n]+`|(?<!\\)\$(?:[^$\n\\]|\\.)+?(?<!\\)\$)")
_BOLD = re.compile(r"\*\*(.+?)\*\*")
# A single * opens and closes inside words too (CommonMark's rule for *, not for _):
# Korean attaches particles to the emphasised word, as in *반사*되고.
_ITALIC = re.compile(r"(?<!\*)\*(?![\s*])(.+?)(?<![\s*])\*(?!\*)")
_BLANK = re.compile(r"\n[ \t]*\n")


def blocks(text: str) -> list[tuple[str, list[str]]]:
    """``text`` as ("p", [paragraph]) and ("ul", [item, ...]) blocks, lines joined."""
    out: list[tuple[str, list[str]]] = []
    for block in _BLANK.split(text.strip()):
        lines = [line.strip() for line in block.splitlines() if line.strip()]
        if not lines:
            continue
        if lines[0].startswith("- "):
            items: list[str] = []
            for line in lines:
                if line.startswith("- "):
                    items.append(line[2:].strip())
                else:
                    items[-1] += " " + line
            out.append(("ul", items))
        else:
            out.append(("p", [" ".join(lines)]))
    return out


def problem(text: str) -> str | None:
    """Why ``text`` is not valid step text (an unpaired ``$``, math mathtext refuses),
    or None."""
    from app.walkthrough.mathsvg import check_latex

    for _, lines in blocks(text):
        for line in lines:
            for part in _SPAN.split(line):
                if part.startswith("$"):
                    why = check_latex(part[1:-1])
                    if why is not None:
                        return f"math ${part[1:-1]}$: {why}"
                elif not part.startswith("`") and re.search(r"(?<!\\)\$", part):
                    return f"an unpaired '$' in: {part.strip()[:60]!r} (write \\$ for a dollar)"
    return None


def _inline(text: str, math: Callable[[str], str]) -> str:
    out = []
    for part in _SPAN.split(text):
        if part.startswith("`") and part.endswith("`") and len(part) > 1:
            out.append(f"<code>{html.escape(part[1:-1])}</code>")
        elif part.startswith("$") and part.endswith("$") and len(part) > 1:
            out.append(math(part[1:-1]))
        else:
            escaped = html.escape(part, quote=False).replace("\\$", "$")
            escaped = _BOLD.sub(r"<strong>\1</strong>", escaped)
            out.append(_ITALIC.sub(r"<em>\1</em>", escaped))
    return "".join(out)


def to_html(text: str, math: Callable[[str], str]) -> str:
    """``text`` as HTML; ``math(latex)`` gives the markup of each inline formula."""
    parts = []
    for kind, lines in blocks(text):
        if kind == "ul":
            items = "".join(f"<li>{_inline(item, math)}</li>" for item in lines)
            parts.append(f"<ul>{items}</ul>")
        else:
            parts.append(f"<p>{_inline(lines[0], math)}</p>")
    return "\n".join(parts)


def spans(text: str) -> list[tuple[str, str]]:
    """One line of step text as ("text" | "code" | "math", content) pieces, for a
    renderer that lays text out itself (the viewer's panel): the ``**`` and ``*``
    markers are dropped (bold and italic read as plain text there), ``\\$`` becomes
    ``$``, code loses its backticks and math its dollars."""
    out: list[tuple[str, str]] = []
    for part in _SPAN.split(text):
        if part.startswith("`") and part.endswith("`") and len(part) > 1:
            out.append(("code", part[1:-1]))
        elif part.startswith("$") and part.endswith("$") and len(part) > 1:
            out.append(("math", part[1:-1]))
        elif part:
            plain = _ITALIC.sub(r"\1", _BOLD.sub(r"\1", part)).replace("\\$", "$")
            out.append(("text", plain))
    return out
