"""The tone maps of ``render.tonemap``: names in the order of their GLSL codes."""

from __future__ import annotations

TONEMAPS = ("linear", "neutral", "aces", "reinhard")
TONEMAP_CODE = {name: code for code, name in enumerate(TONEMAPS)}


def glsl_constants() -> dict[str, int]:
    """``TONEMAP_LINEAR 0``, ``TONEMAP_NEUTRAL 1``, ... for glsl/passes/post.frag."""
    return {f"TONEMAP_{name.upper()}": code for name, code in TONEMAP_CODE.items()}
