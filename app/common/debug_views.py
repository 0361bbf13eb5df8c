"""The debug views a GLSL pass computes (glsl/passes/debug.frag): names in the order of
their ``DEBUG_VIEW`` codes. app/render/debug_views.py describes and runs them."""

from __future__ import annotations

GPU_DEBUG_VIEWS = (
    "base_color",
    "normal",
    "roughness",
    "metallic",
    "f0",
    "depth",
    "material_id",
    "coat_normal",
    "fresnel",
    "ndf",
    "g2",
    "specular",
    "diffuse",
    "light",
    "tiles",
    "emission",
    "occlusion",
)
DEBUG_VIEW_CODE = {name: code for code, name in enumerate(GPU_DEBUG_VIEWS)}


def glsl_constants() -> dict[str, int]:
    """``DEBUG_BASE_COLOR 0``, ``DEBUG_NORMAL 1``, ... for the ``DEBUG_VIEW`` define."""
    return {f"DEBUG_{name.upper()}": code for name, code in DEBUG_VIEW_CODE.items()}
