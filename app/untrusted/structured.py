"""JSON and TOML parsed with bounded nesting and finite numbers only.

Python's parsers recurse once per nesting level: ``[[[[...]]]]`` a few thousand deep is a
``RecursionError`` (a traceback, not bad input), and data a little less deep still makes
every later recursive walk (validation, deep copies) fragile. So a parse that recurses too
deep is refused, and so is a result nested deeper than ``Limits.max_nesting``, checked
without recursion. JSON's non-standard ``NaN`` and ``Infinity``, which Python's parser
accepts, are refused; TOML's ``nan`` and ``inf`` are left to each schema (scene files
refuse them with the key that holds one).
"""

from __future__ import annotations

import json
from typing import Any

from app.untrusted import RefusedError


def depth(data: Any) -> int:
    """How deeply lists and dicts nest in ``data`` (a scalar is 0), without recursion."""
    deepest, stack = 0, [(data, 1)]
    while stack:
        value, level = stack.pop()
        if isinstance(value, dict):
            children = value.values()
        elif isinstance(value, list | tuple):
            children = value
        else:
            continue
        deepest = max(deepest, level)
        stack.extend((child, level + 1) for child in children)
    return deepest


def _bounded(data: Any, max_nesting: int) -> Any:
    if depth(data) > max_nesting:
        raise RefusedError(f"nests deeper than {max_nesting} levels")
    return data


def _no_constant(name: str) -> float:
    raise RefusedError(f"holds {name}, which is not JSON")


def parse_json(text: str | bytes, max_nesting: int, constants: bool = False) -> Any:
    """JSON ``text``; ``RefusedError`` where it is malformed, nests past ``max_nesting`` or
    holds NaN / Infinity (with ``constants``, those are parsed as floats, for a schema
    that refuses non-finite numbers naming their key)."""
    try:
        data = json.loads(text, parse_constant=float if constants else _no_constant)
    except RecursionError:
        raise RefusedError(f"nests deeper than {max_nesting} levels") from None
    except UnicodeDecodeError as exc:
        raise RefusedError(f"not UTF-8 text ({exc.reason})") from None
    except json.JSONDecodeError as exc:
        raise RefusedError(f"malformed JSON: {exc}") from None
    return _bounded(data, max_nesting)


def parse_toml(text: str, max_nesting: int) -> dict[str, Any]:
    """TOML ``text``; ``RefusedError`` where it is malformed or nests past ``max_nesting``."""
    import tomllib  # here: a model file's render reads no TOML

    try:
        data = tomllib.loads(text)
    except RecursionError:
        raise RefusedError(f"nests deeper than {max_nesting} levels") from None
    except tomllib.TOMLDecodeError as exc:
        raise RefusedError(f"malformed TOML: {exc}") from None
    return _bounded(data, max_nesting)
