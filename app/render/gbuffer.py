"""The G-buffer pass: rasterise every object's material parameters into render targets.

Layout and precision are documented in docs/gbuffer.md:
  RT0 ``base_color`` RGBA16F|16|32F  base_color.rgb (linear), metallic
  RT1 ``normal``  RGBA16F|16|32F  octahedral normal (x, y), perceptual roughness, F0
  RT2 ``depth``   RG32F        linear view depth in metres (0 where nothing was drawn),
                               material id (an exact integer)
  RT3 ``tangent`` RGBA16F|16|32F  octahedral tangent (x, y), anisotropy, 0; only where a
                               material of the scene is anisotropic (``tangents``)
  RT4 ``coat_normal`` RG16F|16|32F  octahedral clear-coat normal (x, y); only where a coat's
                               normal differs from its base's (``coat_normals``, RTR4 §9.12)
  RT5 ``emission`` RGBA16F|32F  emitted radiance RGB, occlusion factor; only where a
                               material emits or has an occlusion map (``emission``; glTF 2.0)
  z-test          DEPTH24      a renderbuffer, never sampled
The storage of RT0 and of RT1/RT3/RT4 is the scene's ``render.gbuffer`` (app/common/gbuffer.py
ENCODINGS): float16, 16-bit unorm (signed values mapped to [0, 1]) or float32.
With constant surfaces (every part's surface numbers are its material's constants, float32
targets) RT0 is not allocated and RT1 is RG32F, the normal alone: the decode reads base
colour, metallic, roughness and F0 from the pixel's row of the material table
(``GBUFFER_CONSTANT_SURFACES``; docs/gbuffer.md, "Constant surfaces").
"""

from __future__ import annotations

import ctypes
import math
from collections.abc import Callable

import moderngl
import numpy as np

from app.common.camera import CameraFrame
from app.common.gbuffer import ENCODINGS, GBufferData, encoding_defines
from app.frame.camera import gl_bytes
from app.gl.context import gl_function, wait_before_read
from app.gl.shaders import ShaderCache
from app.reference.encoding import unorm_to_snorm
from app.scene.geometry import VERTEX_ATTRIBUTES, VERTEX_FORMAT, MeshPart
from app.textures.maps import SurfaceLayer, Texture, UvTransform


class GBuffer:
    """The render targets of the G-buffer pass."""

    def __init__(
        self,
        ctx: moderngl.Context,
        size: tuple[int, int],
        encoding: str,
        tangents: bool = True,
        coat_normals: bool = False,
        emission: bool = False,
        constant_surfaces: bool = False,
    ) -> None:
        """``encoding``: a ``render.gbuffer`` value (app/common/gbuffer.py ENCODINGS);
        ``tangents``: allocate RT3 (only anisotropic materials read a tangent);
        ``coat_normals``: allocate RT4 (only a coat whose normal is not its base's reads it);
        ``emission``: allocate RT5 (emitted radiance and occlusion; float16 with the f16
        encoding, else float32: radiance has no upper bound a unorm could hold);
        ``constant_surfaces``: no RT0 and a two-channel RT1 (the material table carries
        the surface numbers; ``MaterialTable.constant_surfaces``).
        The targets are bound in this order, each at the first location the absent ones
        leave free (passes/gbuffer.frag, ``defines``)."""
        base, directions = (STORAGE_DTYPES[s] for s in ENCODINGS[encoding])
        self.encoding = encoding
        self.size = size
        self.constant_surfaces = constant_surfaces
        self.base_color = None if constant_surfaces else ctx.texture(size, 4, dtype=base)
        self.normal = ctx.texture(size, 2 if constant_surfaces else 4, dtype=directions)
        self.depth = ctx.texture(size, 2, dtype="f4")
        self.tangent = ctx.texture(size, 4, dtype=directions) if tangents else None
        self.coat_normal = ctx.texture(size, 2, dtype=directions) if coat_normals else None
        emission_dtype = "f2" if encoding == "f16" else "f4"
        self.emission = ctx.texture(size, 4, dtype=emission_dtype) if emission else None
        self.zbuffer = ctx.depth_renderbuffer(size)
        targets = [
            t for t in (self.base_color, self.normal, self.depth, self.tangent,
                        self.coat_normal, self.emission)
            if t is not None
        ]  # fmt: skip
        self._targets = targets
        for tex in targets:
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
            tex.repeat_x = tex.repeat_y = False
        self.fbo = ctx.framebuffer(targets, self.zbuffer)
        # What a frame clears: RT2 and the z-buffer. Every pass that reads the other
        # targets reads them only where RT2's depth says a surface was drawn (decode.glsl,
        # debug.frag discard the rest), and every drawn fragment writes every target, so
        # their background texels are never read on the GPU; ``read`` gives them the
        # cleared value. Clearing all six took 3.7x as long as these two here
        # (docs/performance.md).
        self.clear_fbo = ctx.framebuffer([self.depth], self.zbuffer)

    def clear(self) -> None:
        """Start a frame: no surface anywhere (RT2's depth 0) and the far z."""
        self.clear_fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)

    def defines(self) -> dict[str, int]:
        """The defines of every pass that writes or decodes these targets: which optional
        ones exist (those of ``MaterialTable.gbuffer_defines``, which chose them), the
        encoding's, GBUFFER_CONSTANT_SURFACES where RT0 is absent, and the location of each
        optional target present (GBUFFER_LOCATION_TANGENT, _COAT_NORMAL, _EMISSION: its
        index in the framebuffer; a layout location must be a literal)."""
        out = {
            "GBUFFER_TANGENT": int(self.tangent is not None),
            "GBUFFER_COAT_NORMAL": int(self.coat_normal is not None),
        }
        if self.emission is not None:  # named only where present, as the table names it
            out["GBUFFER_EMISSION"] = 1
        out |= encoding_defines(self.encoding)
        if self.constant_surfaces:
            out["GBUFFER_CONSTANT_SURFACES"] = 1
        for name, tex in (("TANGENT", self.tangent), ("COAT_NORMAL", self.coat_normal),
                          ("EMISSION", self.emission)):  # fmt: skip
            if tex is not None:
                out[f"GBUFFER_LOCATION_{name}"] = self._targets.index(tex)
        return out

    def depth_at(self, x: int, y: int) -> float:
        """RT2's view depth at pixel (x, y), rows bottom up: one texel, for picking."""
        wait_before_read(self.fbo.ctx)
        attachment = self._targets.index(self.depth)  # RT2's location: 1 without RT0
        raw = self.fbo.read(viewport=(x, y, 1, 1), components=2, attachment=attachment,
                            dtype="f4")  # fmt: skip
        return float(np.frombuffer(raw, np.float32)[0])

    def read(self, surfaces: np.ndarray | None = None) -> GBufferData:
        """The targets with GBufferData's float meaning: a unorm target's signed channels
        (octahedral coordinates, anisotropy) mapped back to [-1, 1] as decode.glsl maps
        them (float64 here, then float32: within an ulp of the GLSL's float32). With
        constant surfaces, ``surfaces`` (``MaterialTable.surface_texels()``) gives each
        pixel's base colour, metallic, roughness and F0 by its material id, as the decode
        reads them."""
        wait_before_read(self.fbo.ctx)
        w, h = self.size
        depth_id = np.frombuffer(self.depth.read(), np.float32).reshape(h, w, 2)
        empty = depth_id[..., 0] == 0.0  # no surface: the other targets were not cleared

        def read(tex: moderngl.Texture, signed: tuple[int, ...], components: int) -> np.ndarray:
            texels = _read_float(tex, signed, components).reshape(h, w, components).copy()
            texels[empty] = _read_float_of_zero(tex.dtype, signed, components)
            return texels

        if self.base_color is not None:
            base_color = read(self.base_color, (), 4)
            normal = read(self.normal, (0, 1), 4)
        else:  # constant surfaces: RT0 and RT1's B, A from the table's rows
            if surfaces is None:
                raise ValueError("a G-buffer of constant surfaces reads with the table's")
            rows = surfaces[np.where(empty, 0, depth_id[..., 1]).astype(np.int64)]
            base_color = np.where(empty[..., None], np.float32(0.0), rows[..., 0, :])
            normal = np.concatenate(
                [read(self.normal, (0, 1), 2),
                 np.where(empty[..., None], np.float32(0.0), rows[..., 1, :2])], axis=-1
            )  # fmt: skip
        if self.tangent is not None:
            tangent = read(self.tangent, (0, 1, 2), 4)
        else:
            tangent = np.zeros((h, w, 4), np.float32)
        coat_normal = None
        if self.coat_normal is not None:
            coat_normal = read(self.coat_normal, (0, 1), 2)[::-1].copy()
        emission = None
        if self.emission is not None:
            emission = read(self.emission, (), 4)[::-1].copy()
        return GBufferData(
            base_color=base_color[::-1].copy(),
            normal=normal[::-1].copy(),
            depth=depth_id[::-1, :, 0].copy(),
            tangent=tangent[::-1].copy(),
            material_id=depth_id[::-1, :, 1].copy(),
            coat_normal=coat_normal,
            emission=emission,
        )

    def samplers(self) -> list[tuple[str, moderngl.Texture]]:
        """(uniform, texture) of every target a pass decodes (gbuffer/decode.glsl), the
        optional ones only where they exist."""
        named = [
            ("g_base_color", self.base_color), ("g_normal", self.normal), ("g_depth", self.depth),
            ("g_tangent", self.tangent), ("g_coat_normal", self.coat_normal),
            ("g_emission", self.emission),
        ]  # fmt: skip
        return [(name, tex) for name, tex in named if tex is not None]

    def release(self) -> None:
        for obj in (self.fbo, self.clear_fbo, *(tex for _, tex in self.samplers()), self.zbuffer):
            obj.release()


# moderngl's dtype of each storage: "nu2" is GL_RGBA16 (16-bit unsigned normalised),
# colour-renderable in GL 3.3.
STORAGE_DTYPES = {"f16": "f2", "unorm16": "nu2", "f32": "f4"}


def _read_float(
    tex: moderngl.Texture, signed: tuple[int, ...] = (), components: int = 4
) -> np.ndarray:
    """A texture's texels as float32: float16 widens exactly; a unorm16 texel ``u`` reads
    as u / 65535 (the GL's conversion), and its ``signed`` channels through
    unorm_to_snorm."""
    if tex.dtype != "nu2":
        return np.frombuffer(tex.read(), np.dtype(tex.dtype)).astype(np.float32)
    texels = np.frombuffer(tex.read(), np.uint16).reshape(-1, components) / 65535.0
    texels[:, signed] = unorm_to_snorm(texels[:, signed])
    return texels.astype(np.float32).reshape(-1)


def _read_float_of_zero(dtype: str, signed: tuple[int, ...], components: int) -> np.ndarray:
    """What ``_read_float`` gives for a texel cleared to 0: 0, or -1 in a unorm target's
    signed channels (unorm_to_snorm(0))."""
    value = np.zeros(components, np.float64)
    if dtype == "nu2":
        value[list(signed)] = unorm_to_snorm(value[list(signed)])
    return value.astype(np.float32)


# Bit of each map in a layer's LAYER<i>_MAPS define (glsl/material/layers.glsl).
MAP_BITS = {
    "base_color": 1,
    "metallic": 2,
    "anisotropy": 4,
    "normal_roughness": 8,
    "f0": 16,
    "select": 32,
    "coat_normal": 64,
    "emissive": 128,
    "occlusion": 256,
    "anisotropy_direction": 512,
}
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

    def get(self, tex: Texture) -> moderngl.Texture:
        made = self._made.get(id(tex))
        if made is None:  # the Texture is kept, so its id is not reused while we hold it
            made = self._made[id(tex)] = (tex, upload_texture(self.ctx, tex))
        return made[1]

    def release(self) -> None:
        for _, gl_tex in self._made.values():
            gl_tex.release()
        self._made.clear()


def upload_texture(ctx: moderngl.Context, tex: Texture) -> moderngl.Texture:
    """A material map with its mips: sRGB colour data decoded by the GL, which builds its
    mips; every other map with the levels the project built (app/textures/), never the
    GL's. Non-colour data is stored as 16-bit floats."""
    level0 = tex.levels[0]
    h, w = level0.shape[:2]
    if tex.srgb:
        internal = 0x8C43  # GL_SRGB8_ALPHA8: decoded to linear on fetch
        gl_tex = ctx.texture((w, h), 4, level0[::-1].tobytes(), internal_format=internal)
        gl_tex.build_mipmaps()
    else:
        comps = 1 if level0.ndim == 2 else level0.shape[2]

        def data(level: np.ndarray) -> bytes:
            return np.ascontiguousarray(level[::-1], np.float16).tobytes()

        gl_tex = ctx.texture((w, h), comps, data(level0), dtype="f2")
        if len(tex.levels) > 1:
            gl_tex.build_mipmaps(0, len(tex.levels) - 1)  # allocates the levels ...
            for k, level in enumerate(tex.levels[1:], start=1):
                gl_tex.write(data(level), level=k)  # ... which ours then replace
    mipmapped = tex.srgb or len(tex.levels) > 1
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
    return gl_tex


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


def layer_maps_define(layer: SurfaceLayer) -> int:
    """The LAYER<i>_MAPS bitmask of a layer's maps."""
    return sum(MAP_BITS[name] for name in layer.maps)


# Map keys in the order of their MAP_INDEX_* (glsl/material/layers.glsl): bit = 1 << index.
MAP_INDEX = {name: bit.bit_length() - 1 for name, bit in MAP_BITS.items()}


def uv_matrix(t: UvTransform) -> np.ndarray:
    """KHR_texture_transform's uv' = T(offset) R(rotation) S(scale) uv as a 3x3 matrix in
    this project's UV space. The extension defines it in glTF's, whose v runs down the
    image (origin top left); ours runs up (textures are uploaded bottom row first), so the
    matrix is conjugated by the flip F: v -> 1 - v (F = F^-1): M = F T R S F. The rotation
    is R = [[cos, sin], [-sin, cos]] by rows in glTF's UV space: the one the extension's
    worked example needs (offset [0, 1], rotation pi/2, scale 0.5 reads "only the lower
    left quadrant of the source image, rotated clockwise 90 degrees"; glTF
    KHR_texture_transform, Khronos 2018) and Blender, Babylon.js and the sample model
    TextureTransformTest use. The README's GLSL listing, mat3(cos, sin, 0, -sin, cos, 0,
    0, 0, 1), read column-major is its transpose (KhronosGroup/glTF issue #1563); this
    function used it before, and rotated every texture the wrong way."""
    c, s = np.cos(t.rotation), np.sin(t.rotation)
    translate = np.array([[1.0, 0.0, t.offset[0]], [0.0, 1.0, t.offset[1]], [0.0, 0.0, 1.0]])
    rotate = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    scale = np.diag([t.scale[0], t.scale[1], 1.0])
    flip = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 1.0], [0.0, 0.0, 1.0]])
    return flip @ translate @ rotate @ scale @ flip


def uv_defines(part: MeshPart) -> dict[str, int]:
    """UV_TRANSFORM_MAPS0 (layer 0's maps with a UV set or transform of their own) and
    UV_SET1_MAPS0 (those reading TEXCOORD_1), VERTEX_UV1 where one does and the part has
    TEXCOORD_1, VERTEX_COLOR where it has COLOR_0; nothing for a part without either
    whose maps all read TEXCOORD_0 untransformed."""
    layer = part.layers[0]
    moved = {k: t for k, t in layer.uv_transforms.items() if k in layer.maps and not t.identity}
    set1 = {k for k, t in moved.items() if t.uv_set == 1 and part.uv1 is not None}
    defines: dict[str, int] = {}
    if moved:
        defines["UV_TRANSFORM_MAPS0"] = sum(MAP_BITS[k] for k in moved)
    if set1:
        defines["UV_SET1_MAPS0"] = sum(MAP_BITS[k] for k in set1)
        defines["VERTEX_UV1"] = 1
    if part.colors is not None and part.analytic is None:
        defines["VERTEX_COLOR"] = 1
    return defines


def uv_transform_bytes(layer: SurfaceLayer) -> bytes:
    """u_uv_transform0[len(MAP_INDEX)]: each map index's matrix (identity where the map has
    none), as the GL's column-major float32 mat3s."""
    out = np.tile(np.eye(3), (len(MAP_INDEX), 1, 1))
    for key, t in layer.uv_transforms.items():
        if key in MAP_INDEX:
            out[MAP_INDEX[key]] = uv_matrix(t)
    return np.ascontiguousarray(out.transpose(0, 2, 1), np.float32).tobytes()


def vertex_extras(part: MeshPart) -> tuple[np.ndarray, str, tuple[str, ...]] | None:
    """The second vertex buffer of a part with COLOR_0 and/or a TEXCOORD_1 that a map
    reads: (interleaved float32 data, moderngl format, attribute names); None otherwise,
    so that every other part keeps the one 12-float buffer."""
    defines = uv_defines(part)
    columns, fmt, names = [], [], []
    if defines.get("VERTEX_COLOR"):
        columns.append(np.asarray(part.colors, np.float32).reshape(-1, 4))
        fmt.append("4f")
        names.append("in_color")
    if defines.get("VERTEX_UV1"):
        columns.append(np.asarray(part.uv1, np.float32).reshape(-1, 2))
        fmt.append("2f")
        names.append("in_uv1")
    if not columns:
        return None
    return np.ascontiguousarray(np.hstack(columns), np.float32), " ".join(fmt), tuple(names)


def masked(part: MeshPart) -> bool:
    """Whether the part's fragments are alpha-tested: glTF alphaMode MASK on its (first)
    layer. "blend" parts are not drawn here but by the blend pass (app/render/blend.py)."""
    return part.layers[0].alpha_mode == "mask"


def rotated(part: MeshPart) -> bool:
    """Whether the part turns its tangent by a constant angle: layer 0's
    anisotropy_rotation, compiled in (ANISOTROPY_ROTATION) only where it is not 0, so
    that every other part's program is the one it was before the rotation existed."""
    return part.layers[0].anisotropy_rotation != 0.0


class MeshDrawable:
    """One mesh part on the GPU: its program (the shader pair, with the part's maps, blend
    and options as defines), vertex and index buffers, textures and per-part matrices.
    The G-buffer pass and the forward renderer (app/bench/forward.py) both draw with it."""

    def __init__(
        self,
        ctx: moderngl.Context,
        shaders: ShaderCache,
        part: MeshPart,
        material_ids: list[int],
        shader_pair: tuple[str, str] = ("passes/gbuffer.vert", "passes/gbuffer.frag"),
        defines: dict[str, object] | None = None,
        specular_aa: tuple[float, float] | None = None,
        uploads: TextureUploads | None = None,
    ) -> None:
        """``uploads``: the pass's shared textures (its owner releases them); without it
        the drawable uploads and releases its own."""
        defines = dict(defines or {})
        for i, layer in enumerate(part.layers):
            if layer.maps:
                defines[f"LAYER{i}_MAPS"] = layer_maps_define(layer)
        if part.blend is not None:
            defines["BLEND"] = 1
        if specular_aa is not None:
            defines["SPECULAR_AA"] = 1
        if part.analytic is not None:
            defines[f"ANALYTIC_{part.analytic.kind.upper()}"] = 1
        self.rotated = rotated(part)
        if self.rotated:
            defines["ANISOTROPY_ROTATION"] = 1
        self.alpha_mask = masked(part)
        if self.alpha_mask:
            defines["ALPHA_MASK"] = 1
        defines.update(uv_defines(part))
        extra = vertex_extras(part)
        self.specular_aa = specular_aa
        self.program = shaders.program(*shader_pair, defines)
        # The uniforms the compiler kept: ``name in program`` walks every member, which
        # took a tenth of the G-buffer pass's Python time for twelve analytic spheres.
        self.uniforms = frozenset(self.program)
        # bind_camera's float64 values for the last (camera, image size) it was given
        self._camera_values: tuple[CameraFrame, tuple[int, int], list, bytes, bytes] | None = None
        self.vbo = ctx.buffer(part.vertices.tobytes())
        self.ibo = ctx.buffer(part.indices.tobytes())
        buffers = [(self.vbo, VERTEX_FORMAT, *VERTEX_ATTRIBUTES)]
        self.extra_vbo = None  # COLOR_0 / TEXCOORD_1: a second buffer, only where present
        if extra is not None:
            data, fmt, names = extra
            self.extra_vbo = ctx.buffer(data.tobytes())
            buffers.append((self.extra_vbo, fmt, *names))
        self.vao = ctx.vertex_array(self.program, buffers, self.ibo, skip_errors=True)
        # (uniform name, texture) in the order they take texture units.
        self.textures: list[tuple[str, moderngl.Texture]] = []
        self._owns_textures = uploads is None
        upload = (lambda tex: upload_texture(ctx, tex)) if uploads is None else uploads.get
        for i, layer in enumerate(part.layers[:2] if part.blend else part.layers[:1]):
            for name, tex in layer.maps.items():
                self.textures.append((f"u_{name}_map{i}", upload(tex)))
        if part.blend is not None:
            self.textures.append(("u_blend_mask", upload(part.blend.mask)))
        self.part = part
        self.material_ids = material_ids
        normal_matrix = np.linalg.inv(part.model[:3, :3]).T
        self.model_bytes = gl_bytes(part.model)
        self.normal_bytes = gl_bytes(normal_matrix)
        # A matrix with a negative determinant mirrors the triangles' winding.
        self.mirrored = bool(np.linalg.det(part.model[:3, :3]) < 0.0)
        self.world_to_object = np.linalg.inv(part.model)

    def cull(self, ctx: moderngl.Context) -> None:
        """Set the winding and face culling the part draws with: closed meshes cull their
        back faces; an analytic primitive's proxy its front faces, so that its back faces
        cover each of its pixels once, wherever the camera is."""
        # A mirroring matrix reverses the winding: front faces stay front faces (for
        # gl_FrontFacing, which two-sided surfaces use, as well as for culling).
        ctx.front_face = "cw" if self.mirrored else "ccw"
        if self.part.closed:
            ctx.cull_face = "front" if self.part.analytic is not None else "back"
            ctx.enable(moderngl.CULL_FACE)
        else:
            ctx.disable(moderngl.CULL_FACE)

    def bind_camera(self, camera: CameraFrame, image_size: tuple[int, int]) -> None:
        """The camera uniforms of an analytic part's ray (geometry/analytic.glsl): the
        camera in world and object space, the pixel rays' frame, the target's size."""
        if self.part.analytic is None:
            return
        prog, cached = self.program, self._camera_values
        if cached is None or cached[0] is not camera or cached[1] != image_size:
            cached = (camera, image_size, *self._camera_uniforms(camera, image_size))
            self._camera_values = cached
        _, _, values, camera_to_world, camera_to_object = cached
        for name, value in values:
            prog[name].value = value
        if "u_camera_to_world" in self.uniforms:
            prog["u_camera_to_world"].write(camera_to_world)
        prog["u_camera_to_object"].write(camera_to_object)

    def _camera_uniforms(
        self, camera: CameraFrame, image_size: tuple[int, int]
    ) -> tuple[list[tuple[str, object]], bytes, bytes]:
        """bind_camera's values, computed in float64 once per camera (a CameraFrame is
        frozen; the renderer makes a new one for a new camera): the (name, value) pairs
        the program uses, and the two matrices' bytes."""
        inverse = self.world_to_object
        rotation = np.asarray(camera.camera_to_world, np.float64)
        object_camera = inverse[:3, :3] @ camera.position + inverse[:3, 3]  # float64
        # The ray through the centre (geometry/analytic.glsl, pixel_ray), in float64: its
        # view depth, window pixel and object-space direction (view-axis component 1).
        centre = rotation.T @ (self.part.model[:3, 3] - camera.position)  # camera space
        depth = float(-centre[2])
        tan = np.asarray(camera.tan_half_fov, np.float64)
        use_centre = depth > 0.5 * camera.near
        along = centre / depth if use_centre else np.array([0.0, 0.0, -1.0])
        pixel = (along[:2] / tan + 1.0) * 0.5 * np.asarray(image_size, np.float64)
        to_object = inverse[:3, :3] @ rotation
        values = {
            "u_camera_pos": tuple(float(x) for x in camera.position),
            "u_tan_half_fov": tuple(float(x) for x in camera.tan_half_fov),
            "u_image_size": (float(image_size[0]), float(image_size[1])),
            "u_object_camera": tuple(float(x) for x in object_camera),
            "u_radius": float(self.part.analytic.radius),
            "u_centre_depth": depth if use_centre else 0.0,
            "u_centre_pixel": tuple(float(x) for x in pixel),
            "u_centre_direction": tuple(float(x) for x in to_object @ along),
        }
        kept = [(name, value) for name, value in values.items() if name in self.uniforms]
        return kept, gl_bytes(rotation), gl_bytes(to_object)

    @property
    def material_id(self) -> int:
        """The row of the part's (first) material."""
        return self.material_ids[0]

    def bind_material(self, first_unit: int = 0) -> None:
        """Set the layers' constants and bind their maps from texture unit ``first_unit``."""
        prog = self.program
        values: dict[str, object] = {}
        for i, layer in enumerate(self.part.layers):
            m = layer.params
            values.update(
                {
                    f"u_layer{i}.base_color": m.base_color,
                    f"u_layer{i}.metallic": m.metallic,
                    f"u_layer{i}.roughness": m.roughness,
                    f"u_layer{i}.f0": m.f0,
                    f"u_layer{i}.anisotropy": m.anisotropy,
                    f"u_layer{i}.uv_scale": layer.uv_scale,
                    f"u_material_id{i}": float(self.material_ids[i]),
                }
            )
        first = self.part.layers[0]  # glTF 2.0 core material: layer 0's only
        if "u_uv_transform0" in self.uniforms:  # UV_TRANSFORM_MAPS0: identity for the others
            uniform = prog["u_uv_transform0"]  # the GL may trim the array past its last use
            uniform.write(uv_transform_bytes(first)[: uniform.array_length * 36])
        values.update(
            {
                "u_emissive0": first.emissive,
                "u_occlusion_strength0": first.occlusion_strength,
                "u_alpha0": first.alpha,
                "u_alpha_cutoff0": first.alpha_cutoff,
                # cos and sin in float64, rounded once to float32 by the GL
                "u_anisotropy_rotation0": (
                    math.cos(first.anisotropy_rotation),
                    math.sin(first.anisotropy_rotation),
                ),
            }
        )
        if (blend := self.part.blend) is not None:
            values["u_blend"] = (blend.threshold, blend.softness)
        if self.specular_aa is not None:
            values["u_specular_aa"] = self.specular_aa
        for name, value in values.items():
            if name in self.uniforms:  # the compiler drops what a permutation does not use
                prog[name].value = value
        for unit, (name, tex) in enumerate(self.textures, start=first_unit):
            tex.use(unit)
            if name in self.uniforms:
                prog[name].value = unit

    def bind_transform(self, view_bytes: bytes, proj_bytes: bytes) -> None:
        """Set the part's matrices and the camera's."""
        prog = self.program
        for name, data in (
            ("u_model", self.model_bytes), ("u_normal_matrix", self.normal_bytes),
            ("u_view", view_bytes), ("u_proj", proj_bytes),
        ):  # fmt: skip
            if name in self.uniforms:  # an analytic fragment may use the model, a proxy not
                prog[name].write(data)
        if "u_tangent_sign" in self.uniforms:  # used only where a layer has a normal map
            prog["u_tangent_sign"].value = -1.0 if self.mirrored else 1.0

    def draw(
        self,
        view_bytes: bytes,
        proj_bytes: bytes,
        camera: CameraFrame,
        size: tuple[int, int],
        between: Callable[[int], None] | None = None,
    ) -> None:
        """Bind the part's state and draw its triangles; with ``between``, in runs of at
        most ``DRAW_RUN`` triangles, in their order, calling ``between(triangles drawn)``
        after each run (``GBufferPass.run`` flushes there)."""
        self.bind_transform(view_bytes, proj_bytes)
        self.bind_camera(camera, size)
        self.bind_material()
        if between is None:
            self.vao.render(moderngl.TRIANGLES)
            return
        count = len(self.part.indices)
        for first in range(0, count, 3 * DRAW_RUN):
            run = min(3 * DRAW_RUN, count - first)
            self.vao.render(moderngl.TRIANGLES, vertices=run, first=first)
            between(run // 3)

    def release(self) -> None:
        owned = [t for _, t in self.textures] if self._owns_textures else []
        for obj in (self.vao, self.vbo, self.ibo, *owned):
            obj.release()
        if self.extra_vbo is not None:
            self.extra_vbo.release()


# llvmpipe shades vertices and bins triangles on the calling thread and rasterises a
# frame's binned triangles on its worker threads only at a flush. The G-buffer pass
# flushes once FLUSH_TRIANGLES have been drawn since the last flush, so that the workers
# rasterise those while this thread bins the next ones; a part larger than DRAW_RUN
# triangles is drawn in runs of that many, in its order. The triangles, their order and
# so every target's texels are the same as in one flush at the end; measured on the
# 35-sphere scene in docs/performance.md ("Fixed costs").
FLUSH_TRIANGLES = 4096
DRAW_RUN = 8192


class GBufferPass:
    """Draws every mesh part into a ``GBuffer``; ``material_ids[i]`` are part i's rows of the
    lighting pass's material table, one per layer."""

    def __init__(
        self,
        ctx: moderngl.Context,
        shaders: ShaderCache,
        parts: list[MeshPart],
        material_ids: list[list[int]],
        specular_aa: tuple[float, float] | None = None,
        defines: dict[str, int] | None = None,
    ) -> None:
        """``defines``: the targets to write, ``GBuffer.defines()`` of the target it
        draws into."""
        self.ctx = ctx
        self._gl_flush = gl_function(ctx, "glFlush", [])
        self._unflushed = 0  # triangles drawn since the last flush
        self.flush_triangles = FLUSH_TRIANGLES  # 0: one flush at the end (the bench's "before")
        defines = dict(defines or {"GBUFFER_TANGENT": 1})
        self.uploads = TextureUploads(ctx)
        self.drawables = [
            MeshDrawable(
                ctx,
                shaders,
                p,
                ids,
                defines=defines,
                specular_aa=specular_aa,
                uploads=self.uploads,
            )
            for p, ids in zip(parts, material_ids, strict=True)
        ]

    def run(
        self,
        target: GBuffer,
        view: np.ndarray,
        proj: np.ndarray,
        camera: CameraFrame,
    ) -> None:
        """Draw every part; ``camera`` is the lighting pass's frame (the analytic parts'
        rays must be the lighting pass's)."""
        ctx = self.ctx
        target.fbo.use()
        ctx.viewport = (0, 0, *target.size)
        ctx.enable_only(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        target.clear()
        target.fbo.use()
        view_bytes, proj_bytes = gl_bytes(view), gl_bytes(proj)
        self._unflushed = 0
        between = self._drawn if self.flush_triangles else None
        for d in self.drawables:
            d.cull(ctx)
            d.draw(view_bytes, proj_bytes, camera, target.size, between)
        ctx.disable(moderngl.CULL_FACE)
        ctx.cull_face = "back"
        ctx.front_face = "ccw"

    def _drawn(self, triangles: int) -> None:
        """Count ``triangles`` drawn; flush once FLUSH_TRIANGLES are waiting (see there)."""
        self._unflushed += triangles
        if self._unflushed >= self.flush_triangles:
            self._gl_flush()
            self._unflushed = 0

    def release(self) -> None:
        for d in self.drawables:
            d.release()
        self.uploads.release()
