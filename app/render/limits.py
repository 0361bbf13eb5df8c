"""Render sizes the GL can allocate, and the GPU memory of a scene: refused up front,
before any target exists or anything is uploaded.

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

And the whole: the decoded input the frame keeps, the scene's geometry and textures as
the G-buffer pass uploads them, the render targets and the shadow atlas add up to at most
``Limits.max_memory`` (the policy's ``--max-memory``; ``check_memory``), since a small
file can name thousands of drawn copies of one mesh, each with its own buffers.
"""

from __future__ import annotations

from collections.abc import Iterable

import moderngl

from app.common.gbuffer import GBufferLayout
from app.errors import InputError
from app.scene.geometry import MeshPart
from app.textures.maps import Texture, upload_bytes
from app.untrusted.budget import describe

MAX_TARGET_BYTES = 4 << 30

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
    layout: GBufferLayout, depth_of_field: bool, transmission: bool = False
) -> int:
    """Bytes a render-size pixel takes in the targets of app/render/gbuffer.py ``GBuffer``
    of ``layout`` (its colour targets, ``GBufferLayout.bytes_per_pixel``, and the z-test's
    renderbuffer), the lighting pass's HDR target, the depth-of-field target and the
    transmission pass's copy of the HDR image with its mip chain (a third more), as they
    are allocated."""
    total = layout.bytes_per_pixel() + _DEPTH_BUFFER + _HDR
    total += _HDR if depth_of_field else 0
    return total + (_HDR + _HDR // 3 if transmission else 0)


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


def texture_bytes(tex: Texture) -> int:
    """The GPU bytes of a map as ``upload_texture`` (app/render/texture_upload.py) stores it:
    RGBA8 with the GL's mips (4/3 of level 0) for colour, 16-bit floats per level else."""
    if tex.srgb:
        level0 = tex.levels[0]
        return level0.shape[0] * level0.shape[1] * 4 * 4 // 3
    return upload_bytes(tex)  # what upload reads, known before a chain is built


def _sampled(part: MeshPart) -> list[Texture]:
    """The maps the G-buffer pass uploads for a part (its layers' and its blend mask)."""
    layers = part.layers[:2] if part.blend else part.layers[:1]
    maps = [tex for layer in layers for tex in layer.maps.values()]
    return maps + ([part.blend.mask] if part.blend is not None else [])


def gpu_bytes(parts: Iterable[MeshPart]) -> tuple[int, int]:
    """(geometry, textures): the GPU bytes of the parts' vertex, index and extra attribute
    buffers, and of their maps, each ``Texture`` once (the G-buffer pass uploads a map
    that parts share once, ``TextureUploads`` in app/render/texture_upload.py)."""
    geometry, textures = 0, {}
    for part in parts:
        geometry += part.vertices.nbytes + part.indices.nbytes
        geometry += sum(a.nbytes for a in (part.uv1, part.colors) if a is not None)
        for tex in _sampled(part):
            textures.setdefault(id(tex), texture_bytes(tex))
    return geometry, sum(textures.values())


def check_memory(
    parts: Iterable[MeshPart],
    decoded: int,
    target_bytes: int,
    shadow_bytes: int,
    limit: int,
    file: str,
) -> None:
    """``InputError`` where the scene's decoded input that stays in memory (``decoded``:
    the budget's total, app/untrusted/budget.py) and its GPU resources (geometry, maps,
    render targets, shadow atlas) pass ``limit`` bytes together: under a software
    rasteriser both are system memory, and on a GPU the decoded copies stay besides."""
    geometry, textures = gpu_bytes(parts)
    total = decoded + geometry + textures + target_bytes + shadow_bytes
    if total > limit:
        raise InputError(
            file,
            "",
            f"the scene needs about {describe(total)} of memory (decoded input "
            f"{describe(decoded)}, GPU meshes {describe(geometry)}, textures "
            f"{describe(textures)}, render targets {describe(target_bytes)}, shadow maps "
            f"{describe(shadow_bytes)}), past the limit of {describe(limit)} (--max-memory)",
        )


def check_multisampling(ctx: moderngl.Context, samples: int, file: str, key: str) -> None:
    """InputError naming ``key`` where this GL cannot draw ``samples`` samples a pixel
    with per-sample coverage written by the fragment shader (``GL_MAX_SAMPLES`` and
    ``gl_SampleMask``: GL_ARB_sample_shading, core from OpenGL 4.0), which the geometry
    samples of ``render.antialiasing = "sraa"`` need; refused before anything is built,
    rather than a shader or framebuffer error later."""
    most = int(ctx.info.get("GL_MAX_SAMPLES", 0) or 0)
    shading = ctx.version_code >= 400 or "GL_ARB_sample_shading" in ctx.extensions
    if most < samples or not shading:
        why = f"at most {most} samples a pixel" if most < samples else "no sample shading"
        raise InputError(
            file, key, f"needs {samples} samples a pixel and sample shading; this GL has {why}"
        )
