"""GL texture storage the project writes itself, level by level, through the GL's entry
points (app/gl/context.py ``gl_function``): every level's storage allocated at once
(glTexStorage2D), level 0 and the mips written or read without the GIL, which moderngl's
own ``write``, ``build_mipmaps`` and ``read`` hold. The material maps (app/render/
texture_upload.py) and the normal/roughness chains built on the GL (app/render/
normal_chain.py) are made with these.
"""

from __future__ import annotations

import ctypes
from collections.abc import Sequence

import moderngl
import numpy as np

from app.gl.context import gl_function

GL_TEXTURE_2D = 0x0DE1
GL_TEXTURE_BASE_LEVEL, GL_TEXTURE_MAX_LEVEL = 0x813C, 0x813D
GL_UNPACK_ALIGNMENT, GL_PACK_ALIGNMENT = 0x0CF5, 0x0D05
GL_HALF_FLOAT = 0x140B
GL_UNSIGNED_BYTE = 0x1401
GL_SRGB8_ALPHA8 = 0x8C43  # colour maps: decoded to linear on fetch
GL_RGBA8, GL_R8, GL_RGBA32F = 0x8058, 0x8229, 0x8814  # 8-bit maps' texels, float moments
# 16-bit float internal formats and the client formats of 1-4 components.
GL_HALF_FORMATS = {1: 0x822D, 2: 0x822F, 3: 0x881B, 4: 0x881A}  # R16F ... RGBA16F
GL_FRAMEBUFFER = 0x8D40
GL_FRAMEBUFFER_COMPLETE = 0x8CD5
GL_COLOR_ATTACHMENT0 = 0x8CE0
GL_CLIENT_FORMATS = {1: 0x1903, 2: 0x8227, 3: 0x1907, 4: 0x1908}  # RED, RG, RGB, RGBA


class AllocatedTexture(moderngl.Texture):
    """A texture whose every level's storage was allocated at once (``allocated``), which
    its ``release`` deletes (moderngl leaves a texture it did not make to its maker)."""

    def release(self) -> None:
        if not isinstance(self.mglo, moderngl.InvalidObject):
            name = ctypes.c_uint(self.glo)
            super().release()
            uint, size = ctypes.c_uint, ctypes.c_int
            delete = gl_function(self.ctx, "glDeleteTextures", [size, ctypes.POINTER(uint)])
            delete(1, ctypes.byref(name))


def has_texture_storage(ctx: moderngl.Context) -> bool:
    """Whether the GL allocates a texture's levels at once (glTexStorage2D)."""
    return ctx.version_code >= 420 or "GL_ARB_texture_storage" in ctx.extensions


def allocated(
    ctx: moderngl.Context,
    size: tuple[int, int],
    comps: int,
    levels: int,
    internal: int,
    dtype: str | None = None,
) -> moderngl.Texture:
    """A texture of ``levels`` levels (GL sizes) with the storage of all of them allocated
    at once (glTexStorage2D, GL 4.2 or ARB_texture_storage), ready for their texels.
    ``dtype``: moderngl's name of its texel type (``"f1"`` for GL_SRGB8_ALPHA8, else
    ``"f2"`` where not given).

    ``ctx.texture`` allocates level 0 alone; the GL then keeps each further level that
    ``define_levels`` or glGenerateMipmap makes apart and, at the first draw, allocates
    the whole chain again and copies every level into it: twice the pages and a second
    copy of each map (page faults are dear on a virtual machine: docs/performance.md).
    Where the GL has no texture storage, ``ctx.texture`` as before."""
    w, h = size
    byte = internal == GL_SRGB8_ALPHA8
    dtype = dtype or ("f1" if byte else "f2")
    if not has_texture_storage(ctx):
        if byte:
            return ctx.texture(size, comps, None, internal_format=internal)
        return ctx.texture(size, comps, None, dtype="f2")
    uint, enum, size_t = ctypes.c_uint, ctypes.c_uint, ctypes.c_int
    name = uint(0)
    gl_function(ctx, "glGenTextures", [size_t, ctypes.POINTER(uint)])(1, ctypes.byref(name))
    gl_function(ctx, "glBindTexture", [enum, uint])(GL_TEXTURE_2D, name.value)
    storage = gl_function(ctx, "glTexStorage2D", [enum, size_t, enum, size_t, size_t])
    storage(GL_TEXTURE_2D, levels, internal, w, h)
    gl_tex = ctx.external_texture(name.value, size, comps, 0, dtype)
    gl_tex.__class__ = AllocatedTexture
    return gl_tex


def write_level0(gl_tex: moderngl.Texture, comps: int, level: np.ndarray, kind: int) -> None:
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


def define_levels(
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
    set_level_range(gl_tex.ctx, gl_tex, 0, len(levels))


def read_level(gl_tex: moderngl.Texture, level: int, out: np.ndarray | None = None) -> np.ndarray:
    """Level ``level`` of a 16-bit float (or 8-bit) texture as the GL holds it, (h, w,
    comps) float16 (uint8) rows bottom first (glGetTexImage: moderngl's ``read`` refuses
    levels it did not make with ``build_mipmaps``, and ``define_levels`` makes them
    without it); into ``out`` where given (C-contiguous, of that many values and that
    dtype: a prepared-texture entry made in place, app/textures/cache.py ``filled``)."""
    uint, enum, int_ = ctypes.c_uint, ctypes.c_uint, ctypes.c_int
    comps = gl_tex.components
    w, h = max(1, gl_tex.width >> level), max(1, gl_tex.height >> level)
    byte = gl_tex.dtype == "f1"
    dtype = np.uint8 if byte else np.float16
    if out is None:
        out = np.empty((h, w, comps), dtype)
    elif out.dtype != dtype or out.size != h * w * comps or not out.flags.c_contiguous:
        raise ValueError(f"level {level} takes {h * w * comps} C-ordered {np.dtype(dtype)}")
    bind = gl_function(gl_tex.ctx, "glBindTexture", [enum, uint])
    store = gl_function(gl_tex.ctx, "glPixelStorei", [enum, int_])
    get = gl_function(gl_tex.ctx, "glGetTexImage", [enum, int_, enum, enum, ctypes.c_void_p])
    bind(GL_TEXTURE_2D, gl_tex.glo)
    store(GL_PACK_ALIGNMENT, 1)
    kind = GL_UNSIGNED_BYTE if byte else GL_HALF_FLOAT
    get(GL_TEXTURE_2D, level, GL_CLIENT_FORMATS[comps], kind, out.ctypes.data)
    return out


def set_level_range(ctx: moderngl.Context, texture: moderngl.Texture, base: int, top: int) -> None:
    """Sampling of ``texture`` limited to levels ``base`` .. ``top``: a level outside them
    can be a framebuffer's attachment while the texture is read, no feedback loop."""
    uint, enum, int_ = ctypes.c_uint, ctypes.c_uint, ctypes.c_int
    gl_function(ctx, "glBindTexture", [enum, uint])(GL_TEXTURE_2D, texture.glo)
    set_parameter = gl_function(ctx, "glTexParameteri", [enum, enum, int_])
    set_parameter(GL_TEXTURE_2D, GL_TEXTURE_BASE_LEVEL, base)
    set_parameter(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, top)


def _gl_errors(ctx: moderngl.Context) -> bool:
    """Whether the GL has error flags set, each cleared (glGetError)."""
    error = gl_function(ctx, "glGetError", [], ctypes.c_uint)
    found = False
    for _ in range(16):  # each flag once; a lost context would report its own forever
        if error() == 0:
            break
        found = True
    return found


class LevelFramebufferError(RuntimeError):
    """The GL refused a level framebuffer (incomplete) or reported an error while one was
    drawn into: what was drawn is not to be used."""


class LevelFramebuffer:
    """One framebuffer object whose colour attachments are levels of textures (moderngl
    attaches level 0 alone), bound for the draws that follow ``attach`` with the viewport
    of the first attachment's level and every colour channel written. moderngl's own
    state is left as it was: its framebuffer is bound again at ``release`` (moderngl sets
    that framebuffer's viewport and colour mask on ``use``)."""

    def __init__(self, ctx: moderngl.Context) -> None:
        uint = ctypes.c_uint
        self.ctx = ctx
        self._previous = ctx.fbo
        self._name = uint(0)
        _gl_errors(ctx)  # what ``check`` reports are the errors from here on
        gl_function(ctx, "glGenFramebuffers", [ctypes.c_int, ctypes.POINTER(uint)])(
            1, ctypes.byref(self._name)
        )
        self._attached = 0

    def attach(self, levels: Sequence[tuple[moderngl.Texture, int]]) -> None:
        """Bind the framebuffer with ``levels`` (texture, level) as its colour attachments
        0, 1, ...; ``LevelFramebufferError`` where the GL finds it incomplete."""
        uint, enum, int_ = ctypes.c_uint, ctypes.c_uint, ctypes.c_int
        ctx = self.ctx
        gl_function(ctx, "glBindFramebuffer", [enum, uint])(GL_FRAMEBUFFER, self._name.value)
        attach = gl_function(ctx, "glFramebufferTexture2D", [enum, enum, enum, uint, int_])
        for i in range(max(len(levels), self._attached)):
            texture, level = levels[i] if i < len(levels) else (None, 0)
            name = texture.glo if texture is not None else 0
            attach(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0 + i, GL_TEXTURE_2D, name, level)
        self._attached = len(levels)
        buffers = (uint * len(levels))(*(GL_COLOR_ATTACHMENT0 + i for i in range(len(levels))))
        gl_function(ctx, "glDrawBuffers", [int_, ctypes.c_void_p])(len(levels), buffers)
        status = gl_function(ctx, "glCheckFramebufferStatus", [enum], enum)
        if status(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE:
            raise LevelFramebufferError("a level framebuffer the GL finds incomplete")
        texture, level = levels[0]
        w, h = max(1, texture.width >> level), max(1, texture.height >> level)
        gl_function(ctx, "glViewport", [int_, int_, int_, int_])(0, 0, w, h)
        gl_function(ctx, "glColorMask", [ctypes.c_ubyte] * 4)(1, 1, 1, 1)

    def check(self) -> None:
        """``LevelFramebufferError`` where the GL reports an error since the last check
        (an allocation it could not make, a draw it refused)."""
        if _gl_errors(self.ctx):
            raise LevelFramebufferError("the GL reported an error while levels were drawn")

    def release(self) -> None:
        uint, enum = ctypes.c_uint, ctypes.c_uint
        gl_function(self.ctx, "glBindFramebuffer", [enum, uint])(GL_FRAMEBUFFER, 0)
        gl_function(self.ctx, "glDeleteFramebuffers", [ctypes.c_int, ctypes.POINTER(uint)])(
            1, ctypes.byref(self._name)
        )
        previous = self._previous  # the framebuffer moderngl had bound, bound again
        if previous is not None and not isinstance(previous.mglo, moderngl.InvalidObject):
            previous.use()
