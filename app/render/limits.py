"""Render sizes the GL can allocate: refused up front, before any target exists.

A size past the GL's limits does not fail where it is asked for: ``ctx.texture`` or the
framebuffer fails later with a GL error or an incomplete framebuffer (a traceback, exit 1),
or, under llvmpipe, the allocation succeeds and takes the machine's memory. So every
``Renderer`` checks the size its passes will run at (``size`` x ``render.supersample``)
against this context's limits before it builds its targets, and refuses with an
``InputError`` naming the size and the limit (exit 2 in the CLI).

The rule (docs/scene-format.md, "Image size limits"):

- width and height at most ``GL_MAX_TEXTURE_SIZE``, ``GL_MAX_RENDERBUFFER_SIZE`` (the
  depth buffer) and ``GL_MAX_VIEWPORT_DIMS``, whichever is smallest (the machine's own);
- the render-size targets (the G-buffer's attachments, its depth buffer, the HDR target
  and, with depth of field, its target) at most ``MAX_TARGET_BYTES``. OpenGL has no portable
  query of free memory, so the ceiling is fixed: 4 GiB holds 8192 x 8192 with the default
  f32 G-buffer (60 bytes a pixel, 3.75 GiB) and refuses 16384 x 16384 (15 GiB), which no
  GPU of the project's users can hold next to its meshes and which under llvmpipe would
  come out of system memory.
"""

from __future__ import annotations

import moderngl

from app.common.gbuffer import ENCODINGS
from app.errors import InputError

MAX_TARGET_BYTES = 4 << 30

# Bytes of one texel component per G-buffer storage (app/common/gbuffer.py ENCODINGS).
_STORAGE_BYTES = {"f16": 2, "unorm16": 2, "f32": 4}
_DEPTH_BUFFER = 4  # DEPTH24 (with its padding byte: drivers store it in 32 bits)
_HDR = 16  # RGBA32F: the lighting pass's target, and the depth of field's


def max_dimension(ctx: moderngl.Context) -> int:
    """The largest width or height of a render target on this context: the smallest of
    ``GL_MAX_TEXTURE_SIZE``, ``GL_MAX_RENDERBUFFER_SIZE`` and ``GL_MAX_VIEWPORT_DIMS``."""
    info = ctx.info
    return int(
        min(
            info["GL_MAX_TEXTURE_SIZE"],
            info["GL_MAX_RENDERBUFFER_SIZE"],
            *info["GL_MAX_VIEWPORT_DIMS"],
        )
    )


def target_bytes_per_pixel(
    encoding: str,
    tangents: bool,
    coat_normals: bool,
    depth_of_field: bool,
    emission: bool = False,
    constant_surfaces: bool = False,
) -> int:
    """Bytes a render-size pixel takes in the targets of app/render/gbuffer.py ``GBuffer``,
    the lighting pass's HDR target and the depth-of-field target, as they are allocated
    (``constant_surfaces``: no RT0, and RT1 two channels)."""
    base, directions = (_STORAGE_BYTES[s] for s in ENCODINGS[encoding])
    surface = 2 * directions if constant_surfaces else 4 * base + 4 * directions  # RT0, RT1
    total = surface + 2 * 4 + _DEPTH_BUFFER + _HDR  # RT2, z, HDR
    total += 4 * directions if tangents else 0
    total += 2 * directions if coat_normals else 0
    total += 4 * (2 if encoding == "f16" else 4) if emission else 0  # RT5 (glTF 2.0 core)
    return total + (_HDR if depth_of_field else 0)


def check_render_size(
    ctx: moderngl.Context,
    size: tuple[int, int],
    supersample: int,
    bytes_per_pixel: int,
    file: str,
    key: str,
) -> None:
    """Raise ``InputError(file, key, ...)`` where the render size (``size`` x
    ``supersample``) is past this context's dimension limit or ``MAX_TARGET_BYTES``."""
    w, h = size[0] * supersample, size[1] * supersample
    how = f"{w}x{h}"
    if supersample > 1:
        how = f"{size[0]}x{size[1]} x {supersample} supersampling = {how}"
    limit = max_dimension(ctx)
    if max(w, h) > limit:
        raise InputError(
            file,
            key,
            f"render size {how} is past this GL's largest render target, {limit} pixels a "
            "side (GL_MAX_TEXTURE_SIZE, GL_MAX_RENDERBUFFER_SIZE, GL_MAX_VIEWPORT_DIMS)",
        )
    total = w * h * bytes_per_pixel
    if total > MAX_TARGET_BYTES:
        raise InputError(
            file,
            key,
            f"render size {how} needs {total / 2**30:.1f} GiB of render targets "
            f"({bytes_per_pixel} bytes a pixel), past the limit of "
            f"{MAX_TARGET_BYTES / 2**30:g} GiB",
        )
