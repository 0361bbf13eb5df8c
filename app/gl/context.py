"""Headless OpenGL contexts: EGL first, OSMesa as the fallback.

EGL (through moderngl/glcontext) reaches Mesa's llvmpipe on machines without a GPU and
the GPU's driver elsewhere. OSMesa renders into client memory with no display at all;
moderngl accepts any object with ``load_opengl_function(name) -> address`` through
``moderngl.init_context(loader=...)``, and OSMesa gives those addresses through
``OSMesaGetProcAddress``. OpenGL 3.3 core is the baseline either way.

The EGL device: EGL enumerates devices (``eglQueryDevicesEXT``: Mesa's software device,
each GPU) and glcontext makes the context on the N-th, the first by default. ``device``
(the CLI's ``--device``) chooses it, else the ``PBS_EGL_DEVICE`` environment variable;
an index EGL does not enumerate is bad input. OSMesa has no devices: a device asked of it
is ignored, with a note. GL entry points come through the context's own loader: EGL's
``eglGetProcAddress`` (app/gl/egl.py), OSMesa's ``OSMesaGetProcAddress``, never the GLX
``libGL`` (a GLX-less server has none).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import logging
import os
import weakref
from dataclasses import dataclass, field
from typing import Literal

import moderngl

from app.errors import InputError
from app.gl import egl
from app.gl.egl import GLCONTEXT_DEVICE_ENV, DeviceRequest, device_request

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
    device: int | None = None  # the EGL device its display is on, as EGL reports it

    @property
    def renderer(self) -> str:
        return str(self.ctx.info.get("GL_RENDERER", "?"))

    @property
    def described(self) -> str:
        """The backend, the renderer and the EGL device where known, for a summary line:
        ``egl (llvmpipe (LLVM 15.0.6, 256 bits)) on device 1``."""
        on = "" if self.device is None else f" on device {self.device}"
        return f"{self.backend} ({self.renderer}){on}"

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


_log = logging.getLogger("pbs.gl")


def check_device(request: DeviceRequest) -> None:
    """Refuse (``InputError``) an index that EGL does not enumerate; where EGL cannot
    enumerate at all, the context's creation says so."""
    try:
        count = egl.device_count()
    except egl.EGLUnavailableError:
        return
    if request.index >= count:
        raise request.refused(count)


def device_requests(
    devices: int | tuple[int, ...] | None, option: str, backend: Backend = "auto"
) -> tuple[int, ...]:
    """The EGL devices a batch's workers spread over: ``devices`` (one index or several,
    named ``option``) over ``PBS_EGL_DEVICE``; () where neither asks. Each is checked
    against what EGL enumerates (``InputError`` naming the first out of range); with
    ``backend`` osmesa they are ignored, with a note."""
    asked = devices if isinstance(devices, tuple) else (devices,)
    requests = [r for index in asked if (r := device_request(index, option)) is not None]
    if backend == "osmesa" and requests:
        listed = ",".join(str(r.index) for r in requests)
        _ignored(requests[0].named if len(requests) == 1 else f"{option} {listed}")
        return ()
    for request in requests:
        check_device(request)
    return tuple(r.index for r in requests)


class _EGLEntryPoints:
    """``gl_function``'s loader for an EGL context: ``eglGetProcAddress``."""

    @staticmethod
    def load_opengl_function(name: str) -> int:
        return egl.proc_address(name)


def _create_egl(request: DeviceRequest | None = None) -> GLContext:
    if request is not None:
        check_device(request)
    # glcontext opens the library it loads GL functions from ("libgl") by name, and runs
    # find_library (ldconfig -p) for any it is not given. libEGL for both: every GL
    # function comes through eglGetProcAddress (libEGL exports none), never the GLX libGL.
    ctx = moderngl.create_context(
        standalone=True, backend="egl", require=REQUIRED_GL, libgl=egl.LIBEGL,
        libegl=egl.LIBEGL, device_index=0 if request is None else request.index,
    )  # fmt: skip
    ctx.extra = _EGLEntryPoints()
    device = egl.current_device()
    if request is not None and device is not None and device != request.index:
        ctx.release()
        raise ContextError(
            f"{request.named} asked for, but the context is on device "
            f"{device} ({GLCONTEXT_DEVICE_ENV} is set?)"
        )
    return GLContext(ctx, "egl", device=device)


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


def release_objects(*objects: object) -> None:
    """Release moderngl objects (None skipped). A framebuffer moderngl holds as bound (the
    last ``use``) is unbound first, the GL's default framebuffer bound in its place:
    moderngl binds the framebuffer it holds as bound again whenever it makes another, and
    a deleted name there is a GL_INVALID_OPERATION (tests/test_gl_errors.py)."""
    for obj in objects:
        if obj is None:
            continue
        if isinstance(obj, moderngl.Framebuffer) and obj.ctx.fbo is obj:
            _default_framebuffer(obj.ctx).use()
        obj.release()  # type: ignore[attr-defined]


def _default_framebuffer(ctx: moderngl.Context) -> moderngl.Framebuffer:
    """The context's default framebuffer as moderngl's object: its window's, else name 0
    (a headless context's, which nothing draws into), made once a context."""
    if ctx.screen is not None:
        return ctx.screen
    made = _DEFAULT_FRAMEBUFFERS.get(ctx)
    if made is None:
        made = _DEFAULT_FRAMEBUFFERS[ctx] = ctx.detect_framebuffer(0)
    return made


_DEFAULT_FRAMEBUFFERS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def gl_function(
    ctx: moderngl.Context, name: str, argtypes: list[type], restype: type | None = None
) -> ctypes._CFuncPtr:
    """A GL entry point of ``ctx`` that moderngl does not wrap (e.g. glTexParameteri for
    GL_MIRRORED_REPEAT), called with ``argtypes`` and returning ``restype`` (None: no
    value), from the loader of the backend that made the context: ``eglGetProcAddress``
    for EGL (looked up once per name), OSMesa's ``OSMesaGetProcAddress``. A context made
    elsewhere (the viewer's glfw window, GLX) gets the system libGL's."""
    loader = ctx.extra
    if isinstance(loader, _EGLEntryPoints | _OSMesaLoader):
        address = loader.load_opengl_function(name)
        if not address:
            raise ContextError(f"no GL entry point {name}")
        return ctypes.CFUNCTYPE(restype, *argtypes)(address)
    function = getattr(_system_gl(), name)
    function.argtypes, function.restype = argtypes, restype
    return function


@functools.cache
def _system_gl() -> ctypes.CDLL:
    """The system libGL (a window's GLX context), looked up once a process:
    ``ctypes.util.find_library`` runs ``ldconfig -p`` in a child process on every call
    (tens of milliseconds on a loaded machine, and a render asks for a few dozen)."""
    return ctypes.CDLL(ctypes.util.find_library("GL") or "libGL.so.1")


def _ignored(named: str) -> None:
    """The note that OSMesa ignores a device, once a process per device asked for."""
    if named not in _ignored_noted:
        _ignored_noted.add(named)
        _log.warning("OSMesa has no devices: %s is ignored", named)


_ignored_noted: set[str] = set()


def _osmesa_ignoring(request: DeviceRequest | None) -> GLContext:
    """An OSMesa context; a note where a device was asked for (OSMesa has none)."""
    if request is not None:
        _ignored(request.named)
    return _create_osmesa()


def create_context(
    backend: Backend = "auto", device: int | None = None, option: str = "device"
) -> GLContext:
    """A headless OpenGL >= 3.3 core context. ``auto`` tries EGL, then OSMesa.

    ``device``: the EGL device's index in ``eglQueryDevicesEXT``'s order (``pbs devices``),
    over ``PBS_EGL_DEVICE``; default EGL's first. One EGL does not enumerate is an
    ``InputError`` naming ``option`` (or the variable) and the count, whatever the
    backend would have fallen back to."""
    request = device_request(device, option)
    if backend == "egl":
        return _create_egl(request)
    if backend == "osmesa":
        return _osmesa_ignoring(request)
    errors = []
    try:
        return _create_egl(request)
    except InputError:
        raise
    except Exception as exc:  # each backend fails in its own way; report both
        errors.append(f"egl: {exc}")
    try:
        return _osmesa_ignoring(request)
    except Exception as exc:
        errors.append(f"osmesa: {exc}")
    raise ContextError("no headless OpenGL 3.3 context: " + "; ".join(errors))
