"""8-bit texels the GL reads where they lie: a buffer texture over the caller's own memory
(GL_AMD_pinned_memory), fetched by texel index, for a pass that only ``texelFetch``es a
map once (the normal/roughness chain's first level, app/render/normal_chain.py).

A texture made for such a map costs a copy of its texels and, on llvmpipe, storage that
the driver clears when it is allocated: a 2048^2 RGBA8 map is 16 MiB of memory first
written twice, dear on a virtual machine whose fresh pages cost a fault each
(docs/performance.md, "A real asset against f3d"). Pinned, the GL reads the decoded
image's own storage (app/textures/pillow_view.py ``rgbx_view``): nothing is allocated,
copied or cleared. Where the GL lacks the extension the caller makes textures as before.
"""

from __future__ import annotations

import ctypes

import moderngl
import numpy as np

from app.gl.context import gl_function
from app.gl.texture_storage import GL_RGBA8

GL_EXTERNAL_VIRTUAL_MEMORY_BUFFER_AMD = 0x9160
GL_TEXTURE_BUFFER = 0x8C2A
GL_TEXTURE0 = 0x84C0
GL_STATIC_DRAW = 0x88E4
GL_NO_ERROR = 0


class PinnedMemoryError(RuntimeError):
    """The GL refused to read the memory in place (the caller makes a texture instead)."""


def has_pinned_memory(ctx: moderngl.Context) -> bool:
    """Whether ``ctx`` reads buffer objects from the caller's memory (GL_AMD_pinned_memory)
    and has buffer textures (GL 3.1)."""
    return ctx.version_code >= 310 and "GL_AMD_pinned_memory" in ctx.extensions


class PinnedTexels:
    """A C-contiguous uint8 array of (H, W, 4) texels read by the GL in place, as a buffer
    texture of GL_RGBA8 texels: texel (x, y) is ``texelFetch(sampler, y * W + x)`` of a
    ``samplerBuffer``. The array is kept alive until ``release``, which
    waits for the GL's queued passes first (they may still read it). ``use(unit)`` binds
    it as ``moderngl.Texture.use`` binds a texture (app/gl/fullscreen.py
    ``bind_textures``). ``PinnedMemoryError`` where the GL refuses the memory."""

    def __init__(self, ctx: moderngl.Context, texels: np.ndarray) -> None:
        if texels.dtype != np.uint8 or not texels.flags.c_contiguous:
            raise ValueError("pinned texels must be C-contiguous uint8")
        if texels.ndim != 3 or texels.shape[2] != 4:
            raise ValueError(f"pinned texels of shape {texels.shape}: (H, W, 4) expected")
        self.ctx = ctx
        self._texels: np.ndarray | None = texels
        self._buffer = self._texture = 0  # the GL's names, 0 until made
        uint, enum, size = ctypes.c_uint, ctypes.c_uint, ctypes.c_int
        self._bind_texture = gl_function(ctx, "glBindTexture", [enum, uint])
        self._active = gl_function(ctx, "glActiveTexture", [enum])
        error = gl_function(ctx, "glGetError", [], enum)
        bind_buffer = gl_function(ctx, "glBindBuffer", [enum, uint])
        buffer, texture = uint(0), uint(0)
        error()  # an error left by an earlier call is not this one's
        gl_function(ctx, "glGenBuffers", [size, ctypes.POINTER(uint)])(1, ctypes.byref(buffer))
        bind_buffer(GL_EXTERNAL_VIRTUAL_MEMORY_BUFFER_AMD, buffer.value)
        data = gl_function(ctx, "glBufferData", [enum, ctypes.c_ssize_t, ctypes.c_void_p, enum])
        data(GL_EXTERNAL_VIRTUAL_MEMORY_BUFFER_AMD, texels.nbytes, texels.ctypes.data,
             GL_STATIC_DRAW)  # fmt: skip
        bind_buffer(GL_EXTERNAL_VIRTUAL_MEMORY_BUFFER_AMD, 0)
        self._buffer = buffer.value
        if error() != GL_NO_ERROR:
            self._delete()
            raise PinnedMemoryError("the GL did not take the texels' memory in place")
        gl_function(ctx, "glGenTextures", [size, ctypes.POINTER(uint)])(1, ctypes.byref(texture))
        self._texture = texture.value
        self._bind_texture(GL_TEXTURE_BUFFER, self._texture)
        gl_function(ctx, "glTexBuffer", [enum, enum, uint])(
            GL_TEXTURE_BUFFER, GL_RGBA8, self._buffer
        )
        self._bind_texture(GL_TEXTURE_BUFFER, 0)
        if error() != GL_NO_ERROR:
            self._delete()
            raise PinnedMemoryError("the GL did not make a buffer texture of the texels")

    def use(self, location: int = 0) -> None:
        """Bind the buffer texture to texture unit ``location`` (moderngl's own unit active
        again after, as its calls expect)."""
        self._active(GL_TEXTURE0 + location)
        self._bind_texture(GL_TEXTURE_BUFFER, self._texture)
        self._active(GL_TEXTURE0 + self.ctx.default_texture_unit)

    def release(self) -> None:
        """Delete the buffer and its texture once the GL has read the texels."""
        if self._texels is None:
            return
        self.ctx.finish()  # queued draws may still read the memory
        self._delete()

    def _delete(self) -> None:
        uint, size = ctypes.c_uint, ctypes.c_int
        if self._texture:
            name = uint(self._texture)
            gl_function(self.ctx, "glDeleteTextures", [size, ctypes.POINTER(uint)])(
                1, ctypes.byref(name)
            )
            self._texture = 0
        if self._buffer:
            name = uint(self._buffer)
            gl_function(self.ctx, "glDeleteBuffers", [size, ctypes.POINTER(uint)])(
                1, ctypes.byref(name)
            )
            self._buffer = 0
        self._texels = None
