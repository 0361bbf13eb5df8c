"""Normal/roughness mip chains built on the GL: the ``variance`` chain of a glTF material's
normal map and roughness (app/textures/mips.py; RTR4 §9.13) drawn level by level by
glsl/passes/normal_chain.frag into the texture the G-buffer pass samples, where the CPU
would build it in float64 and upload it.

The GL's float32 moments give the twin's levels to float16's rounding (tests/
test_normal_chain.py holds them to the float64 chain on maps of odd sizes, steep normals
and scaled ones); what a render uploads is float16 either way. The drawing is the fragment
stage's work, on every core where the GL is llvmpipe, in place of numpy's passes over
float64 planes, and it writes into the map's own texture: nothing is uploaded but the two
images' 8-bit texels. Its levels are read back for the prepared-texture cache (app/render/
texture_upload.py), under a key of their own (``GL_BUILT``), so a second render uploads
them as it uploads a chain built on the CPU.

Which chains: ``variance`` (the filter ``auto`` picks for a normal map whose spread has no
direction) of a normal map, with no roughness map or one of the normal map's size
(``maps.ChainSource``); the others (``lean``'s slope covariance, ``toksvig``, ``naive``,
``none``, a roughness map to resample) are built on the CPU as before.
"""

from __future__ import annotations

from collections.abc import Sequence

import moderngl
import numpy as np

from app.gl.context import wait_before_read
from app.gl.fullscreen import LevelDraws
from app.gl.shaders import ShaderCache
from app.gl.texel_buffer import PinnedMemoryError, PinnedTexels, has_pinned_memory
from app.gl.texture_storage import (
    GL_HALF_FORMATS,
    GL_R8,
    GL_RGBA8,
    GL_RGBA32F,
    GL_UNSIGNED_BYTE,
    allocated,
    has_texture_storage,
    read_level,
    set_level_range,
    write_level0,
)
from app.textures.maps import ChainSource

FRAGMENT = "passes/normal_chain.frag"


def supported(ctx: moderngl.Context) -> bool:
    """Whether this GL can build a chain: every level's storage at once (the levels are
    drawn into as framebuffer attachments)."""
    return has_texture_storage(ctx)


def build_chain(
    ctx: moderngl.Context,
    source: ChainSource,
    shaders: ShaderCache | None = None,
    texel_buffers: bool | None = None,
) -> moderngl.Texture:
    """The chain of ``source`` as an RGBA16F texture of levels ``source.first`` .. 1x1 of
    the map (its level 0 the map's level ``first``), rows bottom first; its sampler state is
    the caller's. ``shaders``: a cache of the same context for the three programs (else
    one of its own, released here). ``LevelFramebufferError`` where the GL refused a level
    or reported an error (nothing is returned then: the caller builds on the CPU).

    ``texel_buffers``: the maps' texels read in place, from the decoded images' storage
    (app/gl/texel_buffer.py: no texture allocated, cleared and copied into), or uploaded as
    textures (False); None: in place where the GL can and the images' storage is exported
    (``ChainSource.texels_in_place``). The same texels either way, so the same levels."""
    h, w = source.shape
    first = source.first
    count = max(h, w).bit_length()  # levels 0 .. 1x1
    made: list = []  # textures or PinnedTexels
    draws: LevelDraws | None = None
    chain: moderngl.Texture | None = None
    try:
        draws = LevelDraws(ctx, shaders)
        chain = allocated(ctx, (max(1, w >> first), max(1, h >> first)), 4, count - first,
                          GL_HALF_FORMATS[4])  # fmt: skip
        in_place = _texels_in_place(ctx, source, texel_buffers)
        if in_place is not None:
            made.extend(in_place)
            normals, rough = in_place[0], in_place[-1]
            roughness = rough if source.roughness_image is not None else None
        else:
            normals = _source_texture(ctx, source.normal_texels())
            made.append(normals)
            roughness = source.roughness_texels()
            rough = _source_texture(ctx, roughness) if roughness is not None else normals
            if roughness is not None:
                made.append(rough)
        buffers = {"CHAIN_TEXEL_BUFFERS": 1} if in_place is not None else {}
        moments = None
        if count > 1:
            moments = allocated(ctx, (max(1, w >> 1), max(1, h >> 1)), 4, count - 1,
                                GL_RGBA32F, "f4")  # fmt: skip
            moments.filter = (moderngl.NEAREST, moderngl.NEAREST)
            made.append(moments)
        common = {
            "u_has_roughness": roughness is not None,
            "u_factor": float(source.factor),
            "u_scale": float(source.scale),
            "u_size0": (w, h),
        }
        maps = {"u_normals": normals, "u_roughness": rough}
        if first == 0:
            level0 = {**common, "u_child_size": (w, h), "u_size": (w, h), "u_level": 0}
            draws.draw(FRAGMENT, {"CHAIN_STAGE": 0, **buffers}, [(chain, 0)], level0, maps)
        child = (w, h)
        for k in range(1, count):
            size = (max(1, w >> k), max(1, h >> k))
            into = [(moments, k - 1)] + ([(chain, k - first)] if k >= first else [])
            uniforms = {**common, "u_child_size": child, "u_size": size, "u_level": k}
            if k == 1:
                draws.draw(FRAGMENT, {"CHAIN_STAGE": 1, **buffers}, into, uniforms, maps)
            else:  # read: the level before, alone; written: level k - 1 of the moments
                set_level_range(ctx, moments, k - 2, k - 2)
                draws.draw(FRAGMENT, {"CHAIN_STAGE": 2}, into, uniforms, {"u_moments": moments})
            child = size
        set_level_range(ctx, chain, 0, count - first - 1)
        draws.check()
    except BaseException:
        if chain is not None:
            chain.release()
        raise
    finally:
        if draws is not None:
            draws.release()
        for texture in made:
            texture.release()
    return chain


def level_shapes(source: ChainSource) -> list[tuple[int, int, int]]:
    """The (h, w, 4) shape of each level ``build_chain`` makes of ``source``, known before
    it is drawn (the prepared-texture entry the levels are read back into)."""
    h, w = source.shape
    cw, ch = max(1, w >> source.first), max(1, h >> source.first)
    return [(max(1, ch >> k), max(1, cw >> k), 4) for k in range(max(cw, ch).bit_length())]


def gpu_bytes(source: ChainSource) -> int:
    """The GL memory ``build_chain`` allocates for ``source`` at most: its float16 levels,
    the float32 moments from level 1 down, and the maps' 8-bit texels where uploaded
    rather than read in place."""
    h, w = source.shape
    chain = sum(8 * lh * lw for lh, lw, _ in level_shapes(source))
    moments = sum(16 * max(1, h >> k) * max(1, w >> k) for k in range(1, max(h, w).bit_length()))
    return chain + moments + 2 * 4 * h * w


def read_chain_levels(
    chain: moderngl.Texture, into: Sequence[np.ndarray] | None = None
) -> list[np.ndarray]:
    """Every level of a built chain as the GL holds it: float16, rows bottom first (what a
    prepared chain's upload takes, maps.PreparedLevels ``upload_levels``), once every
    queued draw is done (llvmpipe waits on its own only for the current framebuffer);
    read into ``into``'s arrays where given (``level_shapes``)."""
    wait_before_read(chain.ctx)
    w, h = chain.size
    count = max(w, h).bit_length()
    if into is None:
        return [read_level(chain, k) for k in range(count)]
    return [read_level(chain, k, out) for k, out in zip(range(count), into, strict=True)]


def _texels_in_place(
    ctx: moderngl.Context, source: ChainSource, wanted: bool | None
) -> list[PinnedTexels] | None:
    """The normal map's texels and, where ``source`` has one, the roughness image's, read
    in place (``build_chain``'s ``texel_buffers``); None where they are uploaded instead."""
    if wanted is False or not has_pinned_memory(ctx):
        if wanted:
            raise ValueError("this GL cannot read texels in place (GL_AMD_pinned_memory)")
        return None
    views = source.texels_in_place()
    if views is None:
        if wanted:
            raise ValueError("the maps' decoded storage cannot be read in place")
        return None
    made: list[PinnedTexels] = []
    try:
        for view in views:
            made.append(PinnedTexels(ctx, view))
    except PinnedMemoryError:
        for texels in made:
            texels.release()
        if wanted:
            raise
        return None
    return made


def _source_texture(ctx: moderngl.Context, texels: np.ndarray) -> moderngl.Texture:
    """One level of 8-bit texels (H, W) or (H, W, 4), image rows as they are (the chain's
    program indexes them so), for ``texelFetch``."""
    h, w = texels.shape[:2]
    comps = 1 if texels.ndim == 2 else texels.shape[2]
    internal = GL_R8 if comps == 1 else GL_RGBA8  # RGB texels padded by the GL
    texture = allocated(ctx, (w, h), comps, 1, internal, "f1")
    write_level0(texture, comps, np.ascontiguousarray(texels), GL_UNSIGNED_BYTE)
    texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
    return texture
