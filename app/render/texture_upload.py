"""GPU textures of the material maps: a ``Texture`` (app/textures/maps.py: its levels, colour
space, filters and wrap) uploaded once per pass, with the project's mips and glTF 2.0's
sampler state. The G-buffer pass, the shadow pass's masked casters and the blend pass draw
with these (app/render/mesh_drawable.py); app/render/limits.py counts their bytes.
"""

from __future__ import annotations

import ctypes
import logging
import threading
from collections.abc import Callable, Iterable, Sequence
from typing import TypeVar

import moderngl
import numpy as np

from app.gl.context import gl_function, wait_before_read
from app.gl.shaders import ShaderCache
from app.gl.texture_storage import (
    GL_HALF_FLOAT,
    GL_HALF_FORMATS,
    GL_SRGB8_ALPHA8,
    GL_TEXTURE_2D,
    GL_UNSIGNED_BYTE,
    LevelFramebufferError,
    allocated,
    define_levels,
    has_texture_storage,
    read_level,
    write_level0,
)
from app.render import normal_chain, srgb_mips
from app.render.srgb_mips import draw_srgb_mips
from app.textures.cache import prepared_cache
from app.textures.maps import PreparedLevels, Texture, upload_levels

_LOG = logging.getLogger(__name__)
_Drawn = TypeVar("_Drawn")  # what a GL draw of kept levels made (a texture)

# Isotropic trilinear filtering. llvmpipe's anisotropic filter (GL_EXT_texture_filter_
# anisotropic) stepped between mip levels on the receding floor of
# scenes/sec13_filtering.toml: bands of constant roughness, one per level (seen, and gone at
# 1); it would also pick the roughness of the minor axis's footprint. docs/filtering.md.
MAX_ANISOTROPY = 1.0


class TextureUploads:
    """The GL textures of one pass's material maps, one per ``Texture`` object: parts that
    share a layer (a glTF mesh drawn by many nodes, one material on many primitives)
    share its textures instead of each uploading its own copy. The owner releases them."""

    def __init__(self, ctx: moderngl.Context, shaders: ShaderCache | None = None) -> None:
        self.ctx = ctx
        self.shaders = shaders  # the chains the GL builds draw with its programs
        self._made: dict[int, tuple[Texture, moderngl.Texture]] = {}
        # Prepared maps whose storage is allocated and whose levels are written at the
        # first draw that binds them (``upload_ready_first(later=True)``, ``finish``).
        self._later: list[tuple[Texture, moderngl.Texture]] = []

    def get(self, tex: Texture) -> moderngl.Texture:
        made = self._made.get(id(tex))
        if made is None:  # the Texture is kept, so its id is not reused while we hold it
            made = self._made[id(tex)] = (tex, upload_texture(self.ctx, tex, self.shaders))
        return made[1]

    def upload_ready_first(self, maps: Iterable[Texture], later: bool = False) -> None:
        """Upload ``maps`` (a pass's, mesh_drawable.drawn_maps), those with nothing to wait
        for first: a colour map (its texels at hand, its GL mips made here) before a
        prepared chain, which may still be being built on the cache's background thread
        (maps.PreparedLevels): the GL's work on the colour maps runs while the chain is
        made, not after it. The drawables then find every map uploaded.

        ``later``: a prepared map still being made gets its texture now, its storage
        allocated (its levels' sizes are its declared layout), and its levels written at
        the first draw that binds it (``finish``, from ``MeshDrawable.bind_material``):
        the renderer's other passes and programs are made meanwhile instead of after it."""
        unique = list({id(t): t for t in maps}.values())
        for tex in sorted(unique, key=lambda t: isinstance(t.levels, PreparedLevels)):
            levels = tex.levels
            if isinstance(levels, PreparedLevels) and not normal_chain.supported(self.ctx):
                levels.prefetch(gl=False)  # built on the CPU's background thread
            preparing = (
                isinstance(levels, PreparedLevels)
                and not levels.ready()
                and not _gl_builds(self.ctx, levels)
            )
            if later and preparing and id(tex) not in self._made:
                gl_tex = _half_storage(self.ctx, tex)
                self._made[id(tex)] = (tex, gl_tex)
                self._later.append((tex, gl_tex))
                continue
            self.get(tex)

    def finish(self) -> None:
        """Write the levels of the maps ``upload_ready_first`` left for later (waiting for
        them where they are still being made)."""
        while self._later:
            tex, gl_tex = self._later.pop(0)
            _write_half_levels(gl_tex, _half_levels(self.ctx, tex, self.shaders))

    def release(self) -> None:
        for _, gl_tex in self._made.values():
            gl_tex.release()
        self._made.clear()


def upload_texture(
    ctx: moderngl.Context, tex: Texture, shaders: ShaderCache | None = None
) -> moderngl.Texture:
    """A material map with its mips: sRGB colour data decoded by the GL, its mips drawn
    (app/render/srgb_mips.py); a ``variance`` normal/roughness chain drawn by the GL where
    it can (app/render/normal_chain.py, with ``shaders``' programs); every other map with
    the levels the project built (app/textures/). Non-colour data is stored as 16-bit
    floats."""
    if tex.srgb:
        level0 = tex.levels[0]
        h, w = level0.shape[:2]
        if len(tex.levels) > 1:  # the mips made on the CPU (maps.colour_texture)
            gl_tex = allocated(ctx, (w, h), 4, len(tex.levels), GL_SRGB8_ALPHA8)
            write_level0(gl_tex, 4, np.ascontiguousarray(level0[::-1]), GL_UNSIGNED_BYTE)
            rows_up = [np.ascontiguousarray(level[::-1]) for level in tex.levels[1:]]
            define_levels(gl_tex, 4, rows_up, GL_SRGB8_ALPHA8)
        elif not has_texture_storage(ctx):  # levels the GL makes one by one
            data = level0[::-1].tobytes()
            gl_tex = ctx.texture((w, h), 4, data, internal_format=GL_SRGB8_ALPHA8)
            gl_tex.build_mipmaps()
        else:  # every level's storage at once: the mips are drawn into it, no second copy
            gl_tex = allocated(ctx, (w, h), 4, max(w, h).bit_length(), GL_SRGB8_ALPHA8)
            write_level0(gl_tex, 4, np.ascontiguousarray(level0[::-1]), GL_UNSIGNED_BYTE)
            try:
                if tex.source_key is None:  # none to keep
                    draw_srgb_mips(ctx, gl_tex, shaders)
                else:
                    _srgb_mips(ctx, gl_tex, tex.source_key, shaders)
            except LevelFramebufferError:  # nothing kept; the GL's own box filter instead
                _LOG.warning("the GL did not draw a colour map's mips; generated by the GL")
                gl_tex.build_mipmaps()
        mipmapped = True
    elif isinstance(tex.levels, PreparedLevels) and _gl_builds(ctx, tex.levels):
        gl_tex = _drawn_ahead(ctx, tex.levels) or _gl_chain(ctx, tex.levels, shaders)
        mipmapped = max(gl_tex.size) > 1  # levels down to 1x1
    else:  # float16 rows bottom first (a prepared chain's kept as such: maps.PreparedLevels)
        levels = _half_levels(ctx, tex, shaders)
        h, w = levels[0].shape[:2]
        comps = 1 if levels[0].ndim == 2 else levels[0].shape[2]
        gl_tex = allocated(ctx, (w, h), comps, len(levels), GL_HALF_FORMATS[comps])
        _write_half_levels(gl_tex, levels)
        mipmapped = len(levels) > 1
    _sampler_state(gl_tex, tex, mipmapped)
    return gl_tex


# Chains drawn before a renderer asked for them (``draw_chain_ahead``), by the identity of
# their levels (held in the entry, so the identity is not reused): (context, levels,
# texture). ``upload_texture`` takes its own; one not taken goes with its context.
_AHEAD: dict[int, tuple[moderngl.Context, PreparedLevels, moderngl.Texture]] = {}
_AHEAD_LOCK = threading.Lock()


def draw_chain_ahead(ctx: moderngl.Context, levels: PreparedLevels, limit: int) -> None:
    """Draw the chain ``levels`` on ``ctx`` now, as ``upload_texture`` would (its levels
    read back into the prepared-texture cache), and keep its texture for that call to
    take: ``pbs render`` does this where the scene's reader waits for another map
    (app/cli.py), where the main thread would otherwise sit idle, not in the renderer's
    set-up after the scene is read. Nothing where the GL does not draw this chain, or
    where its GL memory and its maps' texels would pass ``limit`` bytes (the render's
    ``--max-memory``: the renderer's own check, app/render/limits.py, comes after the
    scene is read and names it then)."""
    if not _gl_builds(ctx, levels):
        return
    source = levels.gl_source
    assert source is not None
    h, w = source.shape
    decoded = 2 * 4 * h * w  # the two maps' decoded texels, held while the GL draws
    if normal_chain.gpu_bytes(source) + decoded > limit:  # an upper bound of both
        return
    texture = _gl_chain(ctx, levels, None)
    with _AHEAD_LOCK:
        _AHEAD[id(levels)] = (ctx, levels, texture)


def forget_chains_ahead(ctx: moderngl.Context) -> None:
    """Forget the chains drawn ahead on ``ctx`` that no upload took (a render refused after
    its scene was read): their textures go with the context, released by its owner."""
    with _AHEAD_LOCK:
        for key in [key for key, (made_on, _, _) in _AHEAD.items() if made_on is ctx]:
            del _AHEAD[key]


def _drawn_ahead(
    ctx: moderngl.Context, levels: PreparedLevels, take: bool = True
) -> moderngl.Texture | None:
    """The chain of ``levels`` drawn ahead on ``ctx`` (``draw_chain_ahead``), taken unless
    ``take`` is False; None where there is none."""
    with _AHEAD_LOCK:
        made = _AHEAD.get(id(levels))
        if made is None or made[0] is not ctx:
            return None
        if take:
            del _AHEAD[id(levels)]
    return made[2]


def _gl_builds(ctx: moderngl.Context, levels: PreparedLevels) -> bool:
    """Whether the upload of ``levels`` is the GL's to build: a chain it drew ahead
    (``draw_chain_ahead``), or one it can draw whose kept levels are not being read
    already (``PreparedLevels.prefetch``)."""
    if _drawn_ahead(ctx, levels, take=False) is not None:
        return True
    return levels.gl_source is not None and not levels.prefetched() and normal_chain.supported(ctx)


def _half_levels(
    ctx: moderngl.Context, tex: Texture, shaders: ShaderCache | None
) -> list[np.ndarray]:
    """``upload_levels(tex)``, but a chain the GL draws whose GL-drawn levels a prefetch
    found kept and then could not read (``PreparedLevels.upload_levels``) is drawn again
    (``_redrawn_chain``), so that a damaged or evicted entry gives the image a cold render
    gives, not the CPU's levels."""
    levels = tex.levels
    drawn = isinstance(levels, PreparedLevels) and levels.gl_source is not None
    if drawn and normal_chain.supported(ctx):
        return levels.upload_levels(lambda: _redrawn_chain(ctx, levels, shaders))
    return upload_levels(tex)


def _redrawn_chain(
    ctx: moderngl.Context, levels: PreparedLevels, shaders: ShaderCache | None
) -> list[np.ndarray]:
    """The chain's float16 levels drawn by the GL, as a cold render draws them, for the
    storage made before them: those read back into its entry (``_chain_drawn_or_kept``),
    read back here only where the cache keeps none; the CPU's where the GL refuses to
    draw it."""
    try:
        chain, kept = _chain_drawn_or_kept(ctx, levels, shaders)
    except LevelFramebufferError:
        _LOG.warning("the GL did not draw a normal/roughness chain; built on the CPU")
        return levels.upload_levels()
    if chain is None:  # kept meanwhile (another process wrote it)
        return list(kept)
    try:
        return list(kept) if kept else normal_chain.read_chain_levels(chain)
    finally:
        chain.release()


def _drawn_or_kept(
    kind: str,
    parts: tuple[str, ...],
    layout: list[tuple[tuple[int, ...], type]],
    draw: Callable[[], _Drawn],
    read_back: Callable[[_Drawn, tuple[np.ndarray, ...]], None],
    release: Callable[[_Drawn], None] = lambda _: None,
) -> tuple[_Drawn | None, tuple[np.ndarray, ...]]:
    """The flow of the levels the GL draws that the prepared-texture cache keeps (the
    normal/roughness chain, a colour map's mips): with the cache off, ``draw()`` alone
    and nothing read back; else the entry (``kind``, ``parts``) of ``layout``'s arrays,
    on a miss drawn now and read back into it (``PreparedCache.filled``) and returned
    with what ``draw`` made, on a hit its kept arrays alone (None drawn), which the
    caller defines its texture from. What ``draw`` made is released where the entry
    fails after it."""
    cache = prepared_cache()
    if not cache.enabled:
        return draw(), ()
    made: list[_Drawn] = []

    def fill(into: tuple[np.ndarray, ...]) -> None:
        made.append(draw())
        read_back(made[0], into)

    try:
        kept = cache.filled(kind, parts, layout, fill)
    except BaseException:
        for drawn in made:
            release(drawn)
        raise
    return (made[0] if made else None), kept


def _chain_drawn_or_kept(
    ctx: moderngl.Context, levels: PreparedLevels, shaders: ShaderCache | None
) -> tuple[moderngl.Texture | None, tuple[np.ndarray, ...]]:
    """``_drawn_or_kept`` of the chain ``levels`` the GL draws (``normal_chain``)."""
    assert levels.gl_source is not None
    source = levels.gl_source
    return _drawn_or_kept(
        levels.gl_kind,
        levels.gl_parts,
        [(shape, np.float16) for shape in normal_chain.level_shapes(source)],
        lambda: normal_chain.build_chain(ctx, source, shaders),
        normal_chain.read_chain_levels,
        lambda texture: texture.release(),
    )


def _gl_chain(
    ctx: moderngl.Context, levels: PreparedLevels, shaders: ShaderCache | None
) -> moderngl.Texture:
    """The chain's texture: the levels the GL built before where the prepared-texture
    cache keeps them (uploaded), else drawn now (``_chain_drawn_or_kept``); built on the
    CPU where the GL refuses to draw it."""
    try:
        chain, kept = _chain_drawn_or_kept(ctx, levels, shaders)
        if chain is not None:
            return chain
    except LevelFramebufferError:
        _LOG.warning("the GL did not draw a normal/roughness chain; built on the CPU")
        kept = levels.upload_levels()
    h, w = kept[0].shape[:2]
    gl_tex = allocated(ctx, (w, h), 4, len(kept), GL_HALF_FORMATS[4])
    _write_half_levels(gl_tex, kept)
    return gl_tex


def _half_storage(ctx: moderngl.Context, tex: Texture) -> moderngl.Texture:
    """``upload_texture``'s texture of a prepared map, its levels not yet written: the
    storage of the levels its declared layout gives (maps.PreparedLevels ``layout``,
    ``upload_bytes``'s sizes), its sampler state set."""
    h, w, comps, single = tex.levels.layout  # type: ignore[union-attr]
    count = 1 if single else max(h, w).bit_length()
    gl_tex = allocated(ctx, (w, h), comps, count, GL_HALF_FORMATS[comps])
    _sampler_state(gl_tex, tex, count > 1)
    return gl_tex


def _write_half_levels(gl_tex: moderngl.Texture, levels: Sequence[np.ndarray]) -> None:
    """Float16 levels (rows bottom first) into ``gl_tex``, made for them."""
    comps = gl_tex.components
    write_level0(gl_tex, comps, levels[0], GL_HALF_FLOAT)
    if len(levels) > 1:
        define_levels(gl_tex, comps, levels[1:])


def _sampler_state(gl_tex: moderngl.Texture, tex: Texture, mipmapped: bool) -> None:
    """The map's filters, anisotropy and wrap on ``gl_tex``."""
    if tex.min_filter == "linear_mipmap_linear" and tex.mag_filter == "linear":
        gl_tex.filter = (  # the default: trilinear where there are mips
            moderngl.LINEAR_MIPMAP_LINEAR if mipmapped else moderngl.LINEAR,
            moderngl.LINEAR,
        )
    else:  # glTF 2.0 sampler filters; a mip filter without mips falls back to its base
        minify = tex.min_filter if mipmapped else tex.min_filter.split("_mipmap_")[0]
        gl_tex.filter = (GL_FILTERS[minify], GL_FILTERS[tex.mag_filter])
    gl_tex.anisotropy = MAX_ANISOTROPY
    if tex.wrap != ("repeat", "repeat"):
        set_wrap(gl_tex, tex.wrap)


# glTF 2.0 sampler filters by name -> the GL's (moderngl's constants are the GL enums).
GL_FILTERS = {
    "nearest": moderngl.NEAREST,
    "linear": moderngl.LINEAR,
    "nearest_mipmap_nearest": moderngl.NEAREST_MIPMAP_NEAREST,
    "linear_mipmap_nearest": moderngl.LINEAR_MIPMAP_NEAREST,
    "nearest_mipmap_linear": moderngl.NEAREST_MIPMAP_LINEAR,
    "linear_mipmap_linear": moderngl.LINEAR_MIPMAP_LINEAR,
}
GL_TEXTURE_WRAP = {"s": 0x2802, "t": 0x2803}
GL_MIRRORED_REPEAT = 0x8370


def set_wrap(gl_tex: moderngl.Texture, wrap: tuple[str, str]) -> None:
    """glTF 2.0 wrapS/wrapT on a texture: "repeat", "clamp" (CLAMP_TO_EDGE) or "mirror"
    (MIRRORED_REPEAT). moderngl's repeat_x/y choose only between REPEAT and CLAMP_TO_EDGE,
    so a mirrored axis sets the GL parameter itself (``_gl_mirror``)."""
    for axis, mode in zip(("x", "y"), wrap, strict=True):
        setattr(gl_tex, f"repeat_{axis}", mode != "clamp")
    mirrored = [
        GL_TEXTURE_WRAP[axis] for axis, mode in zip("st", wrap, strict=True) if mode == "mirror"
    ]
    if mirrored:
        _gl_mirror(gl_tex, mirrored)


def _gl_mirror(gl_tex: moderngl.Texture, parameters: list[int]) -> None:
    """GL_MIRRORED_REPEAT on the given wrap parameters of ``gl_tex``, through the GL
    entry points (app/gl/context.py gl_function). moderngl binds its textures
    again before every use, so the binding changed here is never relied on."""
    uint, enum, int_ = ctypes.c_uint, ctypes.c_uint, ctypes.c_int
    bind = gl_function(gl_tex.ctx, "glBindTexture", [enum, uint])
    set_parameter = gl_function(gl_tex.ctx, "glTexParameteri", [enum, enum, int_])
    bind(GL_TEXTURE_2D, gl_tex.glo)
    for parameter in parameters:
        set_parameter(GL_TEXTURE_2D, parameter, GL_MIRRORED_REPEAT)


def _srgb_mips(
    ctx: moderngl.Context, gl_tex: moderngl.Texture, source_key: str, shaders: ShaderCache | None
) -> None:
    """A colour map's mips (app/render/srgb_mips.py), kept in the prepared-texture cache
    (app/textures/cache.py) by the image file's content and the GL's renderer and version:
    drawn and read back the first time, defined from the kept bytes after that (the same
    bytes, so the same texture, without a pass over a 2048^2 map): ``_drawn_or_kept``."""
    info = ctx.info
    parts = (
        "srgb8 mips",
        source_key,
        str(info.get("GL_RENDERER")),
        str(info.get("GL_VERSION")),
        srgb_mips.code_version(),  # the program that draws them
    )
    w, h = gl_tex.size
    count = max(w, h).bit_length()  # levels 1 .. floor(log2(max side))
    sizes = [max(1, w >> k) * max(1, h >> k) * gl_tex.components for k in range(1, count)]

    def draw() -> moderngl.Texture:
        draw_srgb_mips(ctx, gl_tex, shaders)
        return gl_tex

    def read_back(drawn: moderngl.Texture, into: tuple[np.ndarray, ...]) -> None:
        wait_before_read(ctx)  # llvmpipe waits on its own only for the bound framebuffer
        for k, out in zip(range(1, count), into, strict=True):
            read_level(drawn, k, out)

    layout = [((size,), np.uint8) for size in sizes]
    drawn, kept = _drawn_or_kept("srgb_mips", parts, layout, draw, read_back)
    if drawn is None:
        define_levels(gl_tex, 4, list(kept), GL_SRGB8_ALPHA8)
