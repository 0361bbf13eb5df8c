"""EGL itself, through ctypes on libEGL.so.1: the devices it enumerates, the device a
display is on, and GL entry points by ``eglGetProcAddress``.

moderngl's EGL backend (glcontext) makes the contexts; this module answers what it does
not: which devices exist (``EGL_EXT_device_enumeration``), what kind each is
(``EGL_EXT_device_query``: the extensions a device names, its DRM device file), which one
a context's display is on, and the address of a GL function for an EGL context without
the GLX ``libGL`` (a GLX-less server, NVIDIA's EGL-only installs have none). It imports
nothing of the GL stack, so ``pbs devices`` starts fast.

libEGL is opened once a process by its soname: ``ctypes.util.find_library`` would run
``ldconfig -p`` in a child process on every call. Function addresses from
``eglGetProcAddress`` do not depend on the display or the current context (EGL 1.5
§3.10), so each name is looked up once a process.
"""

from __future__ import annotations

import atexit
import ctypes
import functools
import os
import re
import threading
from dataclasses import dataclass

from app.errors import InputError

LIBEGL = "libEGL.so.1"

# Tokens (EGL/egl.h, EGL/eglext.h).
_EGL_EXTENSIONS = 0x3055
_EGL_NONE = 0x3038
_EGL_SURFACE_TYPE = 0x3033
_EGL_PBUFFER_BIT = 0x0001
_EGL_RENDERABLE_TYPE = 0x3040
_EGL_OPENGL_BIT = 0x0008
_EGL_OPENGL_API = 0x30A2
_EGL_CONTEXT_MAJOR_VERSION = 0x3098
_EGL_CONTEXT_MINOR_VERSION = 0x30FB
_EGL_CONTEXT_OPENGL_PROFILE_MASK = 0x30FD
_EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT = 0x0001
_EGL_DRAW = 0x3059
_EGL_READ = 0x305A
_EGL_PLATFORM_DEVICE_EXT = 0x313F
_EGL_DEVICE_EXT = 0x322C
_EGL_DRM_DEVICE_FILE_EXT = 0x3233
_EGL_DRM_RENDER_NODE_FILE_EXT = 0x3377
_EGL_CUDA_DEVICE_NV = 0x323A
_GL_VENDOR = 0x1F00
_GL_RENDERER = 0x1F01
_GL_VERSION = 0x1F02

_handle = ctypes.c_void_p
_boolean = ctypes.c_uint
_int = ctypes.c_int32


DEVICE_ENV = "PBS_EGL_DEVICE"
# glcontext's own variable: it overrides the device_index it is given.
GLCONTEXT_DEVICE_ENV = "GLCONTEXT_DEVICE_INDEX"


@dataclass(frozen=True)
class DeviceRequest:
    """An EGL device asked for, and by what (``--device``, ``PBS_EGL_DEVICE``), for the
    one-line refusal of an index EGL does not enumerate."""

    index: int
    asked_by: str

    @property
    def named(self) -> str:
        """How the user wrote it: ``--device 3``, ``PBS_EGL_DEVICE=3``."""
        joint = "=" if self.asked_by == DEVICE_ENV else " "
        return f"{self.asked_by}{joint}{self.index}"

    def refused(self, count: int) -> InputError:
        have = f"{count} device" + ("" if count == 1 else "s")
        valid = "" if not count else " (index 0)" if count == 1 else f" (0..{count - 1})"
        return InputError(self.named, "", f"out of range: EGL enumerates {have}{valid}")


def device_request(device: int | None, option: str = "device") -> DeviceRequest | None:
    """The device asked for: ``device`` (named ``option`` in errors) over the
    ``PBS_EGL_DEVICE`` environment variable; None where neither asks (EGL's first device).
    A variable that is not a whole number >= 0 is bad input."""
    if device is not None:
        if device < 0:
            raise InputError(f"{option} {device}", "", "expected a device index >= 0")
        return DeviceRequest(device, option)
    text = os.environ.get(DEVICE_ENV, "").strip()
    if not text:
        return None
    if not re.fullmatch(r"\d+", text):
        raise InputError(
            f"{DEVICE_ENV}={text}", "", "expected a device index (0, 1, ...; pbs devices)"
        )
    return DeviceRequest(int(text), DEVICE_ENV)


class EGLUnavailableError(RuntimeError):
    """No libEGL, or one without device enumeration (EGL_EXT_device_enumeration)."""


@functools.cache
def _library() -> ctypes.CDLL:
    """libEGL with the prototypes this module calls, opened once a process."""
    try:
        lib = ctypes.CDLL(LIBEGL)
    except OSError as exc:
        raise EGLUnavailableError(f"{LIBEGL} not loaded ({exc})") from None
    prototypes = {
        "eglGetProcAddress": (ctypes.c_void_p, [ctypes.c_char_p]),
        "eglGetError": (_int, []),
        "eglInitialize": (_boolean, [_handle, ctypes.c_void_p, ctypes.c_void_p]),
        "eglBindAPI": (_boolean, [ctypes.c_uint]),
        "eglChooseConfig": (
            _boolean,
            [_handle, ctypes.POINTER(_int), ctypes.POINTER(_handle), _int, ctypes.POINTER(_int)],
        ),
        "eglCreateContext": (_handle, [_handle, _handle, _handle, ctypes.POINTER(_int)]),
        "eglDestroyContext": (_boolean, [_handle, _handle]),
        "eglMakeCurrent": (_boolean, [_handle, _handle, _handle, _handle]),
        "eglGetCurrentDisplay": (_handle, []),
        "eglGetCurrentContext": (_handle, []),
        "eglGetCurrentSurface": (_handle, [_int]),
    }
    for name, (restype, argtypes) in prototypes.items():
        function = getattr(lib, name)
        function.restype, function.argtypes = restype, argtypes
    return lib


@functools.cache
def proc_address(name: str) -> int:
    """``eglGetProcAddress(name)``: the address of a GL (or EGL extension) function, 0
    where EGL has none. Looked up once a process per name."""
    return _library().eglGetProcAddress(name.encode()) or 0


def _extension(name: str, restype: type, argtypes: list[type]) -> ctypes._CFuncPtr:
    """An EGL extension function (``eglQueryDevicesEXT``...), or ``EGLUnavailableError``."""
    address = proc_address(name)
    if not address:
        raise EGLUnavailableError(f"{LIBEGL} has no {name}")
    return ctypes.CFUNCTYPE(restype, *argtypes)(address)


@functools.cache
def _device_handles() -> tuple[int, ...]:
    """Every ``EGLDeviceEXT`` that ``eglQueryDevicesEXT`` enumerates, in its order (the
    order ``device_index`` counts in); the list is fixed for a process."""
    query = _extension(
        "eglQueryDevicesEXT", _boolean, [_int, ctypes.POINTER(_handle), ctypes.POINTER(_int)]
    )
    count = _int(0)
    if not query(0, None, ctypes.byref(count)):
        raise EGLUnavailableError(f"eglQueryDevicesEXT failed (0x{_library().eglGetError():x})")
    handles = (_handle * max(count.value, 1))()
    if not query(count.value, handles, ctypes.byref(count)):
        raise EGLUnavailableError(f"eglQueryDevicesEXT failed (0x{_library().eglGetError():x})")
    return tuple(handles[i] for i in range(count.value))


def device_count() -> int:
    """How many devices EGL enumerates; ``EGLUnavailableError`` where it cannot."""
    return len(_device_handles())


def current_device() -> int | None:
    """The index (in ``eglQueryDevicesEXT``'s order) of the device that the current EGL
    context's display is on, asked of EGL (``eglQueryDisplayAttribEXT(EGL_DEVICE_EXT)``);
    None without a current EGL display or where EGL cannot say."""
    try:
        lib = _library()
        query = _extension(  # EGLAttrib is intptr_t: a pointer-sized slot
            "eglQueryDisplayAttribEXT", _boolean, [_handle, _int, ctypes.POINTER(_handle)]
        )
        handles = _device_handles()
    except EGLUnavailableError:
        return None
    display = lib.eglGetCurrentDisplay()
    device = _handle()
    if not display or not query(display, _EGL_DEVICE_EXT, ctypes.byref(device)):
        return None
    return handles.index(device.value) if device.value in handles else None


@dataclass(frozen=True)
class Device:
    """One EGL device: its index, kind, extensions and what a context on it reports."""

    index: int
    kind: str
    extensions: tuple[str, ...]
    gl_vendor: str | None
    gl_renderer: str | None
    gl_version: str | None
    error: str | None = None  # why no context could be made on it

    def line(self) -> str:
        """``pbs devices``'s line for this device."""
        if self.error is not None:
            gl = f"no OpenGL 3.3 core context ({self.error})"
        else:
            gl = f"GL_VENDOR {self.gl_vendor}; GL_RENDERER {self.gl_renderer}"
        return f"{self.index}: {self.kind}; {gl}"


def _kind(handle: int, extensions: tuple[str, ...]) -> str:
    """The device's kind by the extensions it names: Mesa's software rasterizer, a DRM
    device (its device file, and render node where named), a CUDA device."""
    query = _extension("eglQueryDeviceStringEXT", ctypes.c_char_p, [_handle, _int])
    parts = []
    if "EGL_MESA_device_software" in extensions:
        parts.append("software (EGL_MESA_device_software)")
    if "EGL_EXT_device_drm" in extensions:
        path = query(handle, _EGL_DRM_DEVICE_FILE_EXT)
        parts.append(f"DRM {path.decode(errors='replace') if path else '?'} (EGL_EXT_device_drm)")
    if "EGL_EXT_device_drm_render_node" in extensions:
        node = query(handle, _EGL_DRM_RENDER_NODE_FILE_EXT)
        if node:  # Mesa's software device names the extension with no node
            parts.append(f"render node {node.decode(errors='replace')}")
    if "EGL_NV_device_cuda" in extensions:
        attribute = _extension(
            "eglQueryDeviceAttribEXT", _boolean, [_handle, _int, ctypes.POINTER(ctypes.c_ssize_t)]
        )
        cuda = ctypes.c_ssize_t(-1)
        ok = attribute(handle, _EGL_CUDA_DEVICE_NV, ctypes.byref(cuda))
        parts.append(f"CUDA device {cuda.value if ok else '?'} (EGL_NV_device_cuda)")
    return ", ".join(parts) or "unknown kind (" + (" ".join(extensions) or "no extensions") + ")"


def initialize_device(index: int) -> None:
    """``eglInitialize`` of the display of device ``index``, the display moderngl's EGL
    backend makes its context on (``eglGetPlatformDisplayEXT`` of the device, no
    attributes): EGL loads the device's driver and makes its screen (llvmpipe: LLVM's
    library loaded and its code generator set up, some 40 ms) here, through ctypes, which
    lets go of the GIL while it waits; moderngl's backend holds the GIL throughout. The
    context made later on that display finds it initialized (EGL 1.5 §3.2: initializing
    an initialized display does nothing more). ``RuntimeError`` where EGL cannot."""
    handles = _device_handles()
    if not 0 <= index < len(handles):
        raise EGLUnavailableError(f"no EGL device {index}")
    _initialized_display(handles[index])


def _initialized_display(handle: int) -> int:
    """The EGLDisplay of device ``handle`` (``eglGetPlatformDisplayEXT``, no attributes),
    initialized; ``RuntimeError`` naming the step that failed."""
    lib = _library()
    platform_display = _extension(
        "eglGetPlatformDisplayEXT", _handle, [ctypes.c_uint, _handle, ctypes.POINTER(_int)]
    )
    display = platform_display(_EGL_PLATFORM_DEVICE_EXT, handle, None)
    if not display:
        raise RuntimeError(f"eglGetPlatformDisplayEXT failed (0x{lib.eglGetError():x})")
    if not lib.eglInitialize(display, None, None):
        raise RuntimeError(f"eglInitialize failed (0x{lib.eglGetError():x})")
    return display


def start_device(device: int | None) -> None:
    """Initialize, on a daemon thread, the display of the device a context will be asked
    for (``device`` over ``PBS_EGL_DEVICE``, as ``device_request``; glcontext's own
    ``GLCONTEXT_DEVICE_INDEX`` over both, as it takes it): ``initialize_device`` while the
    caller's thread goes on importing and reading the scene (``pbs render``). Nothing is
    reported: an index or an EGL that cannot be used is the context's creation's to name.
    The interpreter's exit waits for it (at most ``EXIT_WAIT_S``): the C library's exit
    runs the driver's and LLVM's destructors, which must not meet their initialization
    on this thread (a command refused right after its start)."""

    def initialize() -> None:
        try:
            request = device_request(device)
            index = 0 if request is None else request.index
            override = os.environ.get(GLCONTEXT_DEVICE_ENV, "").strip()
            initialize_device(int(override) if override.isdigit() else index)
        except Exception:  # the context's creation reports it, in its order
            return

    thread = threading.Thread(target=initialize, name="pbs-gl-device", daemon=True)
    thread.start()
    atexit.register(thread.join, EXIT_WAIT_S)


EXIT_WAIT_S = 10.0  # how long an exit waits for ``start_device``'s initialization


def _gl_strings(handle: int) -> tuple[str, str, str]:
    """GL_VENDOR, GL_RENDERER and GL_VERSION of an OpenGL 3.3 core context made on the
    device (no surface: EGL_KHR_surfaceless_context), destroyed after; the context current
    before is made current again. ``RuntimeError`` naming the step that failed."""
    lib = _library()

    def failed(step: str) -> RuntimeError:
        return RuntimeError(f"{step} failed (0x{lib.eglGetError():x})")

    display = _initialized_display(handle)
    wanted = (_int * 5)(_EGL_SURFACE_TYPE, _EGL_PBUFFER_BIT, _EGL_RENDERABLE_TYPE, _EGL_OPENGL_BIT,
                        _EGL_NONE)  # fmt: skip
    config, found = _handle(), _int(0)
    if not lib.eglChooseConfig(display, wanted, ctypes.byref(config), 1, ctypes.byref(found)):
        raise failed("eglChooseConfig")
    if not found.value:
        raise RuntimeError("no EGL config renders OpenGL")
    if not lib.eglBindAPI(_EGL_OPENGL_API):
        raise failed("eglBindAPI")
    attributes = (_int * 7)(
        _EGL_CONTEXT_MAJOR_VERSION, 3, _EGL_CONTEXT_MINOR_VERSION, 3,
        _EGL_CONTEXT_OPENGL_PROFILE_MASK, _EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, _EGL_NONE,
    )  # fmt: skip
    context = lib.eglCreateContext(display, config, None, attributes)
    if not context:
        raise failed("eglCreateContext")
    before = (
        lib.eglGetCurrentDisplay(),
        lib.eglGetCurrentSurface(_EGL_DRAW),
        lib.eglGetCurrentSurface(_EGL_READ),
        lib.eglGetCurrentContext(),
    )
    try:
        if not lib.eglMakeCurrent(display, None, None, context):
            raise failed("eglMakeCurrent")
        get_string = ctypes.CFUNCTYPE(ctypes.c_char_p, ctypes.c_uint)(proc_address("glGetString"))
        strings = [get_string(name) for name in (_GL_VENDOR, _GL_RENDERER, _GL_VERSION)]
    finally:
        if before[3]:
            lib.eglMakeCurrent(*before)
        else:
            lib.eglMakeCurrent(display, None, None, None)
        lib.eglDestroyContext(display, context)
    vendor, renderer, version = (s.decode(errors="replace") if s else "?" for s in strings)
    return vendor, renderer, version


def devices() -> list[Device]:
    """Every device EGL enumerates, each with its kind and the GL strings of a context
    made on it; ``EGLUnavailableError`` where EGL cannot enumerate devices."""
    query = _extension("eglQueryDeviceStringEXT", ctypes.c_char_p, [_handle, _int])
    found = []
    for index, handle in enumerate(_device_handles()):
        names = query(handle, _EGL_EXTENSIONS)
        extensions = tuple(names.decode(errors="replace").split()) if names else ()
        kind = _kind(handle, extensions)
        try:
            vendor, renderer, version = _gl_strings(handle)
        except RuntimeError as exc:
            found.append(Device(index, kind, extensions, None, None, None, str(exc)))
            continue
        found.append(Device(index, kind, extensions, vendor, renderer, version))
    return found
