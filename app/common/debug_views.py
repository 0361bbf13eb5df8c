"""The debug views: the names a GLSL pass computes (glsl/passes/debug.frag) in the order of
their ``DEBUG_VIEW`` codes, and every view's one-line description. app/render/debug_views.py
runs them; the names and lines are declared here, in a module that imports nothing, so
that ``pbs render --help`` and its ``--debug`` choices need no GL (docs/performance.md,
"Start-up")."""

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

# Name -> one line for ``pbs render --help``, in the order the help lists them.
DEBUG_VIEWS: dict[str, str] = {
    "base_color": "G-buffer base colour (linear; sRGB-encoded)",
    "normal": "world normal as n*0.5+0.5",
    "roughness": "perceptual roughness, grey 0..1",
    "metallic": "metallic, grey 0..1",
    "f0": "F0 as lit, RGB: dielectric F0 x specular colour, a metal's base colour (sRGB)",
    "depth": "linear view depth: the frame's nearest white, farthest dark grey",
    "material_id": "material table row, one colour per id",
    "coat_normal": "clear-coat normal as n*0.5+0.5 (the normal where RT4 is absent)",
    "fresnel": "F of the --debug-light light, RGB (sRGB-encoded)",
    "ndf": "D of that light's half vector, grey log scale 1e-3..1e3",
    "g2": "masking-shadowing G2 for that light, grey 0..1",
    "specular": "f_spec for that light, shown as x/(1+x) of x = pi f_spec",
    "diffuse": "f_diffuse for that light, as x/(1+x) of x = pi f_diffuse",
    "light": "that light's pi f c_light (n.l)+ alone, shown as x/(1+x)",
    "tiles": "local lights per 8x8 tile of the culler, fixed heat ramp",
    "emission": "emitted radiance (glTF emissive), shown as x/(1+x)",
    "occlusion": "occlusion factor on environment light, grey 0..1 (1 without a map)",
    "nan": "NaN/Inf/negative HDR pixels in colours, counts printed (even -q)",
}
assert tuple(DEBUG_VIEWS)[: len(GPU_DEBUG_VIEWS)] == GPU_DEBUG_VIEWS

# The views that evaluate one light (the ``light`` argument of ``run``).
LIGHT_VIEWS = ("fresnel", "ndf", "g2", "specular", "diffuse", "light")


def glsl_constants() -> dict[str, int]:
    """``DEBUG_BASE_COLOR 0``, ``DEBUG_NORMAL 1``, ... for the ``DEBUG_VIEW`` define."""
    return {f"DEBUG_{name.upper()}": code for name, code in DEBUG_VIEW_CODE.items()}
