"""Headless OpenGL contexts: EGL first, OSMesa as the fallback.

EGL (through moderngl/glcontext) reaches Mesa's llvmpipe on machines without a GPU and
the GPU's driver elsewhere. OSMesa renders into client memory with no display at all;
moderngl accepts any object with ``load_opengl_function(name) -> address`` through
``moderngl.init_context(loader=...)``, and OSMesa gives those addresses through
``OSMesaGetProcAddress``. OpenGL 3.3 core is the baseline either way.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import os
from dataclasses import dataclass, field
from typing import Literal

import moderngl

Backend = Literal["auto", "egl", "osmesa"]
REQUIRED_GL = 330
# The GALLIUM_DRIVER values OSMesa can draw with ("" = unset: llvmpipe).
OSMESA_DRIVERS = ("", "llvmpipe", "softpipe")

# OSMesa attribute tokens (GL/osmesa.h).
_OSMESA_FORMAT = 0x22
_OSMESA_RGBA = 0x1908
_OSMESA_DEPTH_BITS = 0x30
_OSMESA_PROFILE = 0x33
_OSMESA_CORE_PROFILE = 0x34
_OSMESA_CONTEXT_MAJOR_VERSION = 0x36
_OSMESA_CONTEXT_MINOR_VERSION = 0x37
_GL_UNSIGNED_BYTE = 0x1401


class ContextError(RuntimeError):
    """No headless OpenGL 3.3 context could be created."""


class _OSMesaLoader:
    """A moderngl loader backed by an OSMesa context made current on a 1x1 buffer.

    The renderer draws only into its own framebuffer objects, so the OSMesa colour
    buffer is a single pixel kept alive for the context's lifetime.
    """

    def __init__(self) -> None:
        # OSMesa draws with a software rasteriser only: Mesa 22.3's OSMesaCreateContextAttribs
        # crashes the process (SIGSEGV) under any other GALLIUM_DRIVER (zink, a misspelt
        # name), which is where `auto` lands when EGL refuses that driver (docs/drivers.md).
        driver = os.environ.get("GALLIUM_DRIVER", "")
        if driver not in OSMESA_DRIVERS:
            raise ContextError(
                f"OSMesa renders with llvmpipe or softpipe, not GALLIUM_DRIVER={driver}"
            )
        name = ctypes.util.find_library("OSMesa") or "libOSMesa.so.8"
        try:
            lib = ctypes.CDLL(name)
        except OSError as exc:
            raise ContextError(f"OSMesa library not found ({exc})") from None
        lib.OSMesaCreateContextAttribs.restype = ctypes.c_void_p
        lib.OSMesaCreateContextAttribs.argtypes = [ctypes.POINTER(ctypes.c_int), ctypes.c_void_p]
        lib.OSMesaMakeCurrent.restype = ctypes.c_ubyte
        lib.OSMesaMakeCurrent.argtypes = [
            ctypes.c_void_p,
            ctypes.c_void_p,
            ctypes.c_uint,
            ctypes.c_int,
            ctypes.c_int,
        ]
        lib.OSMesaGetProcAddress.restype = ctypes.c_void_p
        lib.OSMesaGetProcAddress.argtypes = [ctypes.c_char_p]
        lib.OSMesaDestroyContext.argtypes = [ctypes.c_void_p]
        attrs = (ctypes.c_int * 11)(
            _OSMESA_FORMAT, _OSMESA_RGBA,
            _OSMESA_DEPTH_BITS, 24,
            _OSMESA_PROFILE, _OSMESA_CORE_PROFILE,
            _OSMESA_CONTEXT_MAJOR_VERSION, 3,
            _OSMESA_CONTEXT_MINOR_VERSION, 3,
            0,
        )  # fmt: skip
        handle = lib.OSMesaCreateContextAttribs(attrs, None)
        if not handle:
            raise ContextError("OSMesaCreateContextAttribs failed (no OpenGL 3.3 core)")
        self._lib = lib
        self._handle = handle
        self._buffer = (ctypes.c_ubyte * 4)()
        if not lib.OSMesaMakeCurrent(handle, self._buffer, _GL_UNSIGNED_BYTE, 1, 1):
            lib.OSMesaDestroyContext(handle)
            raise ContextError("OSMesaMakeCurrent failed")

    def load_opengl_function(self, name: str) -> int:
        return self._lib.OSMesaGetProcAddress(name.encode()) or 0

    def release(self) -> None:
        if self._handle:
            self._lib.OSMesaDestroyContext(self._handle)
            self._handle = None

    def __enter__(self) -> None:
        return None

    def __exit__(self, *args: object) -> None:
        return None


@dataclass
class GLContext:
    """A moderngl context and the backend that made it."""

    ctx: moderngl.Context
    backend: str
    _keepalive: object = field(default=None, repr=False)

    @property
    def renderer(self) -> str:
        return str(self.ctx.info.get("GL_RENDERER", "?"))

    def release(self) -> None:
        """Destroy the context (OSMesa's too)."""
        global _osmesa_changes
        self.ctx.release()
        if isinstance(self._keepalive, _OSMesaLoader):
            self._keepalive.release()
            _osmesa_changes += 1


# OSMesa and EGL contexts share Mesa's GL dispatch: creating or destroying an OSMesa
# context leaves an EGL context made current before it not current any more, while EGL
# still reports it current (so making it current again does nothing), and its next
# program fails ("cannot create program"). A holder of a long-lived context (app.brdf's
# default one) compares this count with the one it saw and makes a fresh context when
# it changed (tests/conftest.py mixes the two backends in one process; a user rarely does).
_osmesa_changes = 0


def osmesa_changes() -> int:
    """How many OSMesa contexts this process has created and destroyed so far."""
    return _osmesa_changes


def _create_egl() -> GLContext:
    ctx = moderngl.create_context(standalone=True, backend="egl", require=REQUIRED_GL)
    return GLContext(ctx, "egl")


def _create_osmesa() -> GLContext:
    loader = _OSMesaLoader()
    try:
        moderngl.init_context(loader=loader)
        ctx = moderngl.get_context()
    except Exception:
        loader.release()
        raise
    if ctx.version_code < REQUIRED_GL:
        loader.release()
        raise ContextError(f"OSMesa gave OpenGL {ctx.version_code}, need {REQUIRED_GL}")
    ctx.extra = loader  # gl_function: GL entry points moderngl does not wrap
    global _osmesa_changes
    _osmesa_changes += 1
    return GLContext(ctx, "osmesa", loader)


def wait_before_read(ctx: moderngl.Context) -> None:
    """Wait for every queued pass before a texture is read back on the CPU. llvmpipe
    waits on its own only for the current framebuffer's targets (and textures the queued
    passes sample count as read, not written): a G-buffer target read right after the
    frame could come back half-written (measured: 1-2 frames in 40 of
    tests/test_material_core.py's alpha-mode edit once the post pass was fused into
    lighting, which left one framebuffer change fewer between them)."""
    ctx.finish()


def gl_function(ctx: moderngl.Context, name: str, argtypes: list[type]) -> ctypes._CFuncPtr:
    """A GL entry point of ``ctx`` that moderngl does not wrap (e.g. glTexParameteri for
    GL_MIRRORED_REPEAT), called with ``argtypes``: OSMesa's own address for an OSMesa
    context; else the system libGL's, which glvnd dispatches to the current EGL context."""
    if isinstance(ctx.extra, _OSMesaLoader):
        address = ctx.extra.load_opengl_function(name)
        return ctypes.CFUNCTYPE(None, *argtypes)(address)
    function = getattr(_system_gl(), name)
    function.argtypes, function.restype = argtypes, None
    return function


@functools.cache
def _system_gl() -> ctypes.CDLL:
    """The system libGL, looked up once a process: ``ctypes.util.find_library`` runs
    ``ldconfig -p`` in a child process on every call (tens of milliseconds on a loaded
    machine, and a render asks for a few dozen entry points)."""
    return ctypes.CDLL(ctypes.util.find_library("GL") or "libGL.so.1")


def create_context(backend: Backend = "auto") -> GLContext:
    """A headless OpenGL >= 3.3 core context. ``auto`` tries EGL, then OSMesa."""
    if backend == "egl":
        return _create_egl()
    if backend == "osmesa":
        return _create_osmesa()
    errors = []
    for make in (_create_egl, _create_osmesa):
        try:
            return make()
        except Exception as exc:  # each backend fails in its own way; report both
            errors.append(f"{make.__name__[8:]}: {exc}")
    raise ContextError("no headless OpenGL 3.3 context: " + "; ".join(errors))
