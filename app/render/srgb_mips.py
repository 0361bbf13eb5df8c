"""A colour map's mips drawn by the project's own program (glsl/passes/srgb_mips.frag)
in place of glGenerateMipmap: each level from the one above, each texel the mean of its
footprint's texels in linear light (the mips' footprints of app/textures/mips.py), written
through the framebuffer's sRGB encoding into the map's own texture.

The GL's own call gives the same means for a map of power-of-two sides, to its sRGB
rounding (tests/test_srgb_mips.py), but llvmpipe compiles the blit behind it in every
process, since its internal program is not in Mesa's shader cache, where this program's
machine code comes from the cache (docs/performance.md). Footprints are taken in image
rows, as the CPU's mips take them (an odd last row of the image joins the pair above it).
The map's levels are kept in the prepared-texture cache (app/render/texture_upload.py
``_srgb_mips``).
"""

from __future__ import annotations

import moderngl

from app.gl.fullscreen import LevelDraws
from app.gl.shaders import ShaderCache
from app.gl.texture_storage import set_level_range
from app.textures.versions import version

FRAGMENT = "passes/srgb_mips.frag"
GL_FRAMEBUFFER_SRGB = 0x8DB9


def code_version() -> str:
    """The code version of the mips drawn here (app/textures/versions.py)."""
    return version("srgb mips")


def draw_srgb_mips(
    ctx: moderngl.Context, texture: moderngl.Texture, shaders: ShaderCache | None = None
) -> None:
    """Levels 1 .. 1x1 of ``texture`` (GL_SRGB8_ALPHA8, every level's storage allocated,
    level 0 written, rows bottom first) drawn from level 0; its level range left 0 .. the
    last. ``shaders``: a cache of the same context for the program (else one of its own,
    released here). ``LevelFramebufferError`` where the GL refused a level or reported an
    error."""
    w, h = texture.size
    count = max(w, h).bit_length()
    if count < 2:
        return
    draws = LevelDraws(ctx, shaders)
    filters = texture.filter
    texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
    ctx.enable_direct(GL_FRAMEBUFFER_SRGB)
    try:
        above = (w, h)
        for k in range(1, count):
            size = (max(1, w >> k), max(1, h >> k))
            set_level_range(ctx, texture, k - 1, k - 1)  # read level k - 1, write level k
            uniforms = {"u_size0": (w, h), "u_child_size": above, "u_size": size, "u_level": k}
            draws.draw(FRAGMENT, {}, [(texture, k)], uniforms, {"u_above": texture})
            above = size
        draws.check()
    finally:
        ctx.disable_direct(GL_FRAMEBUFFER_SRGB)
        draws.release()
        set_level_range(ctx, texture, 0, count - 1)
        texture.filter = filters
