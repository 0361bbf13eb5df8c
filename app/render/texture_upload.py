"""GPU textures of the material maps: a ``Texture`` (app/textures/maps.py: its levels, colour
space, filters and wrap) uploaded once per pass, with the project's mips and glTF 2.0's
sampler state. The G-buffer pass, the shadow pass's masked casters and the blend pass draw
with these (app/render/mesh_drawable.py); app/render/limits.py counts their bytes.
"""

from __future__ import annotations

import ctypes
from collections.abc import Iterable, Sequence

import moderngl
import numpy as np

from app.gl.context import gl_function
from app.textures.cache import prepared_cache
from app.textures.maps import PreparedLevels, Texture, upload_levels

# Isotropic trilinear filtering. llvmpipe's anisotropic filter (GL_EXT_texture_filter_
# anisotropic) stepped between mip levels on the receding floor of
# scenes/sec13_filtering.toml: bands of constant roughness, one per level (seen, and gone at
# 1); it would also pick the roughness of the minor axis's footprint. docs/filtering.md.
MAX_ANISOTROPY = 1.0


class TextureUploads:
    """The GL textures of one pass's material maps, one per ``Texture`` object: parts that
    share a layer (a glTF mesh drawn by many nodes, one material on many primitives)
    share its textures instead of each uploading its own copy. The owner releases them."""

    def __init__(self, ctx: moderngl.Context) -> None:
        self.ctx = ctx
        self._made: dict[int, tuple[Texture, moderngl.Texture]] = {}
        # Prepared maps whose storage is allocated and whose levels are written at the
        # first draw that binds them (``upload_ready_first(later=True)``, ``finish``).
        self._later: list[tuple[Texture, moderngl.Texture]] = []

    def get(self, tex: Texture) -> moderngl.Texture:
        made = self._made.get(id(tex))
        if made is None:  # the Texture is kept, so its id is not reused while we hold it
            made = self._made[id(tex)] = (tex, upload_texture(self.ctx, tex))
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
            preparing = isinstance(levels, PreparedLevels) and not levels.ready()
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
            _write_half_levels(gl_tex, upload_levels(tex))

    def release(self) -> None:
        for _, gl_tex in self._made.values():
            gl_tex.release()
        self._made.clear()


def upload_texture(ctx: moderngl.Context, tex: Texture) -> moderngl.Texture:
    """A material map with its mips: sRGB colour data decoded by the GL, which builds its
    mips; every other map with the levels the project built (app/textures/), never the
    GL's. Non-colour data is stored as 16-bit floats."""
    if tex.srgb:
        level0 = tex.levels[0]
        h, w = level0.shape[:2]
        if len(tex.levels) > 1:  # the mips made on the CPU (maps.colour_texture)
            gl_tex = _allocated(ctx, (w, h), 4, len(tex.levels), GL_SRGB8_ALPHA8)
            _write_level0(gl_tex, 4, np.ascontiguousarray(level0[::-1]), GL_UNSIGNED_BYTE)
            rows_up = [np.ascontiguousarray(level[::-1]) for level in tex.levels[1:]]
            _define_levels(gl_tex, 4, rows_up, GL_SRGB8_ALPHA8)
        elif tex.source_key is None:
            data = level0[::-1].tobytes()
            gl_tex = ctx.texture((w, h), 4, data, internal_format=GL_SRGB8_ALPHA8)
            gl_tex.build_mipmaps()
        else:  # every level's storage at once: the GL's mips go into it, no second copy
            gl_tex = _allocated(ctx, (w, h), 4, max(w, h).bit_length(), GL_SRGB8_ALPHA8)
            _write_level0(gl_tex, 4, np.ascontiguousarray(level0[::-1]), GL_UNSIGNED_BYTE)
            _srgb_mips(ctx, gl_tex, tex.source_key)
        mipmapped = True
    else:  # float16 rows bottom first (a prepared chain's kept as such: maps.PreparedLevels)
        levels = upload_levels(tex)
        h, w = levels[0].shape[:2]
        comps = 1 if levels[0].ndim == 2 else levels[0].shape[2]
        gl_tex = _allocated(ctx, (w, h), comps, len(levels), GL_HALF_FORMATS[comps])
        _write_half_levels(gl_tex, levels)
        mipmapped = len(levels) > 1
    _sampler_state(gl_tex, tex, mipmapped)
    return gl_tex


def _half_storage(ctx: moderngl.Context, tex: Texture) -> moderngl.Texture:
    """``upload_texture``'s texture of a prepared map, its levels not yet written: the
    storage of the levels its declared layout gives (maps.PreparedLevels ``layout``,
    ``upload_bytes``'s sizes), its sampler state set."""
    h, w, comps, single = tex.levels.layout  # type: ignore[union-attr]
    count = 1 if single else max(h, w).bit_length()
    gl_tex = _allocated(ctx, (w, h), comps, count, GL_HALF_FORMATS[comps])
    _sampler_state(gl_tex, tex, count > 1)
    return gl_tex


def _write_half_levels(gl_tex: moderngl.Texture, levels: Sequence[np.ndarray]) -> None:
    """Float16 levels (rows bottom first) into ``gl_tex``, made for them."""
    comps = gl_tex.components
    _write_level0(gl_tex, comps, levels[0], GL_HALF_FLOAT)
    if len(levels) > 1:
        _define_levels(gl_tex, comps, levels[1:])


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
GL_TEXTURE_2D = 0x0DE1
GL_TEXTURE_BASE_LEVEL, GL_TEXTURE_MAX_LEVEL = 0x813C, 0x813D
GL_UNPACK_ALIGNMENT, GL_PACK_ALIGNMENT = 0x0CF5, 0x0D05
GL_HALF_FLOAT = 0x140B
GL_UNSIGNED_BYTE = 0x1401
GL_SRGB8_ALPHA8 = 0x8C43  # colour maps: decoded to linear on fetch
# 16-bit float internal formats and the client formats of 1-4 components.
GL_HALF_FORMATS = {1: 0x822D, 2: 0x822F, 3: 0x881B, 4: 0x881A}  # R16F ... RGBA16F
GL_CLIENT_FORMATS = {1: 0x1903, 2: 0x8227, 3: 0x1907, 4: 0x1908}  # RED, RG, RGB, RGBA
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


class AllocatedTexture(moderngl.Texture):
    """A texture whose every level's storage was allocated at once (``_allocated``), which
    its ``release`` deletes (moderngl leaves a texture it did not make to its maker)."""

    def release(self) -> None:
        if not isinstance(self.mglo, moderngl.InvalidObject):
            name = ctypes.c_uint(self.glo)
            super().release()
            uint, size = ctypes.c_uint, ctypes.c_int
            delete = gl_function(self.ctx, "glDeleteTextures", [size, ctypes.POINTER(uint)])
            delete(1, ctypes.byref(name))


def _allocated(
    ctx: moderngl.Context, size: tuple[int, int], comps: int, levels: int, internal: int
) -> moderngl.Texture:
    """A texture of ``levels`` levels (GL sizes) with the storage of all of them allocated
    at once (glTexStorage2D, GL 4.2 or ARB_texture_storage), ready for their texels.

    ``ctx.texture`` allocates level 0 alone; the GL then keeps each further level that
    ``_define_levels`` or glGenerateMipmap makes apart and, at the first draw, allocates
    the whole chain again and copies every level into it: twice the pages and a second
    copy of each map (page faults are dear on a virtual machine: docs/performance.md).
    Where the GL has no texture storage, ``ctx.texture`` as before."""
    w, h = size
    byte = internal == GL_SRGB8_ALPHA8
    if ctx.version_code < 420 and "GL_ARB_texture_storage" not in ctx.extensions:
        if byte:
            return ctx.texture(size, comps, None, internal_format=internal)
        return ctx.texture(size, comps, None, dtype="f2")
    uint, enum, size_t = ctypes.c_uint, ctypes.c_uint, ctypes.c_int
    name = uint(0)
    gl_function(ctx, "glGenTextures", [size_t, ctypes.POINTER(uint)])(1, ctypes.byref(name))
    gl_function(ctx, "glBindTexture", [enum, uint])(GL_TEXTURE_2D, name.value)
    storage = gl_function(ctx, "glTexStorage2D", [enum, size_t, enum, size_t, size_t])
    storage(GL_TEXTURE_2D, levels, internal, w, h)
    gl_tex = ctx.external_texture(name.value, size, comps, 0, "f1" if byte else "f2")
    gl_tex.__class__ = AllocatedTexture
    return gl_tex


def _srgb_mips(ctx: moderngl.Context, gl_tex: moderngl.Texture, source_key: str) -> None:
    """The GL's own mips of a colour map, kept in the prepared-texture cache
    (app/textures/cache.py) by the image file's content and the GL's renderer and version:
    built and read back the first time, defined from the kept bytes after that (the same
    bytes, so the same texture, without the GL's filtering pass over a 2048^2 map)."""
    info = ctx.info
    parts = ("srgb8 mips", source_key, str(info.get("GL_RENDERER")), str(info.get("GL_VERSION")))

    def build() -> list[np.ndarray]:
        # glGenerateMipmap and glGetTexImage through ctypes, which lets go of the GIL for
        # the call (moderngl's build_mipmaps and read hold it): llvmpipe's mips of a 2048^2
        # map take a few tenths of a second, during which the cache's background thread
        # goes on preparing the model's other maps.
        uint, enum = ctypes.c_uint, ctypes.c_uint
        gl_function(ctx, "glBindTexture", [enum, uint])(GL_TEXTURE_2D, gl_tex.glo)
        gl_function(ctx, "glGenerateMipmap", [enum])(GL_TEXTURE_2D)
        w, h = gl_tex.size
        count = max(w, h).bit_length()  # levels 1 .. floor(log2(max side))
        return [read_level(gl_tex, k).reshape(-1) for k in range(1, count)]

    built: list[bool] = []
    levels = prepared_cache().arrays("srgb_mips", parts, lambda: built.append(True) or build())
    if not built:
        _define_levels(gl_tex, 4, list(levels), GL_SRGB8_ALPHA8)


def _write_level0(gl_tex: moderngl.Texture, comps: int, level: np.ndarray, kind: int) -> None:
    """Level 0's texels (rows bottom first, contiguous) into ``gl_tex``, made without data,
    through ctypes: the GL's copy of a 2048^2 map (16-32 MiB, a tenth of a second on
    llvmpipe) runs without the GIL, which moderngl's ``texture(..., data)`` holds, so the
    cache's background thread is not held up meanwhile."""
    uint, enum, int_ = ctypes.c_uint, ctypes.c_uint, ctypes.c_int
    level = np.ascontiguousarray(level)
    w, h = gl_tex.size
    texel = 1 if kind == GL_UNSIGNED_BYTE else 2
    assert level.nbytes == w * h * comps * texel, "level 0 of another size"
    bind = gl_function(gl_tex.ctx, "glBindTexture", [enum, uint])
    store = gl_function(gl_tex.ctx, "glPixelStorei", [enum, int_])
    sub_image = gl_function(
        gl_tex.ctx,
        "glTexSubImage2D",
        [enum, int_, int_, int_, ctypes.c_int, ctypes.c_int, enum, enum, ctypes.c_void_p],
    )
    bind(GL_TEXTURE_2D, gl_tex.glo)
    store(GL_UNPACK_ALIGNMENT, 1)
    sub_image(GL_TEXTURE_2D, 0, 0, 0, w, h, GL_CLIENT_FORMATS[comps], kind, level.ctypes.data)


def _define_levels(
    gl_tex: moderngl.Texture,
    comps: int,
    levels: Sequence[bytes | np.ndarray],
    internal: int | None = None,
) -> None:
    """Levels 1..n of a 16-bit float texture defined straight from the project's mips
    (glTexImage2D per level, GL sizes; glTexSubImage2D into an ``AllocatedTexture``'s
    storage), and the texture's level range set to 0..n; with ``internal``
    (GL_SRGB8_ALPHA8), 8-bit RGBA levels of that format instead.

    moderngl can write only to levels that exist, and the one way it has to make them,
    ``build_mipmaps``, first computes the GL's own mips of level 0 (a 2048^2 map's whole
    chain, under llvmpipe on the CPU) only for ours to overwrite them."""
    uint, enum, int_ = ctypes.c_uint, ctypes.c_uint, ctypes.c_int
    bind = gl_function(gl_tex.ctx, "glBindTexture", [enum, uint])
    set_parameter = gl_function(gl_tex.ctx, "glTexParameteri", [enum, enum, int_])
    store = gl_function(gl_tex.ctx, "glPixelStorei", [enum, int_])
    image = gl_function(
        gl_tex.ctx,
        "glTexImage2D",
        [enum, int_, int_, ctypes.c_int, ctypes.c_int, int_, enum, enum, ctypes.c_void_p],
    )
    sub_image = gl_function(
        gl_tex.ctx,
        "glTexSubImage2D",
        [enum, int_, int_, int_, ctypes.c_int, ctypes.c_int, enum, enum, ctypes.c_void_p],
    )
    allocated = isinstance(gl_tex, AllocatedTexture)  # its levels exist: written, not made
    w, h = gl_tex.size
    bind(GL_TEXTURE_2D, gl_tex.glo)
    store(GL_UNPACK_ALIGNMENT, 1)  # rows of 2-byte texels are not 4-byte aligned
    for k, level in enumerate(levels, start=1):
        size_w, size_h = max(1, w >> k), max(1, h >> k)
        texel = 1 if internal is not None else 2
        if isinstance(level, np.ndarray):  # its own buffer, no copy into bytes
            level = np.ascontiguousarray(level)
            nbytes, pointer = level.nbytes, level.ctypes.data
        else:
            nbytes, pointer = len(level), level
        assert nbytes == size_w * size_h * comps * texel, "a level of another size"
        kind = GL_UNSIGNED_BYTE if internal else GL_HALF_FLOAT
        if allocated:
            sub_image(
                GL_TEXTURE_2D, k, 0, 0, size_w, size_h, GL_CLIENT_FORMATS[comps], kind, pointer
            )
        else:
            image(
                GL_TEXTURE_2D, k, internal or GL_HALF_FORMATS[comps], size_w, size_h, 0,
                GL_CLIENT_FORMATS[comps], kind, pointer,
            )  # fmt: skip
    set_parameter(GL_TEXTURE_2D, GL_TEXTURE_BASE_LEVEL, 0)
    set_parameter(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, len(levels))


def read_level(gl_tex: moderngl.Texture, level: int) -> np.ndarray:
    """Level ``level`` of a 16-bit float (or 8-bit) texture as the GL holds it, (h, w,
    comps) float16 (uint8) rows bottom first (glGetTexImage: moderngl's ``read`` refuses
    levels it did not make with ``build_mipmaps``, and ``_define_levels`` makes them
    without it)."""
    uint, enum, int_ = ctypes.c_uint, ctypes.c_uint, ctypes.c_int
    comps = gl_tex.components
    w, h = max(1, gl_tex.width >> level), max(1, gl_tex.height >> level)
    byte = gl_tex.dtype == "f1"
    out = np.empty((h, w, comps), np.uint8 if byte else np.float16)
    bind = gl_function(gl_tex.ctx, "glBindTexture", [enum, uint])
    store = gl_function(gl_tex.ctx, "glPixelStorei", [enum, int_])
    get = gl_function(gl_tex.ctx, "glGetTexImage", [enum, int_, enum, enum, ctypes.c_void_p])
    bind(GL_TEXTURE_2D, gl_tex.glo)
    store(GL_PACK_ALIGNMENT, 1)
    kind = GL_UNSIGNED_BYTE if byte else GL_HALF_FLOAT
    get(GL_TEXTURE_2D, level, GL_CLIENT_FORMATS[comps], kind, out.ctypes.data)
    return out
