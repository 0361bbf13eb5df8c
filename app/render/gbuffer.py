"""The G-buffer pass: rasterise every object's material parameters into render targets.

Layout and precision are documented in docs/gbuffer.md:
  RT0 ``albedo``  RGBA16F|32F  base_color.rgb (linear), metallic
  RT1 ``normal``  RGBA16F|32F  octahedral normal (x, y), perceptual roughness, F0
  RT2 ``depth``   R32F         linear view depth in metres, 0 where nothing was drawn
  RT3 ``tangent`` RGBA16F|32F  octahedral tangent (x, y), anisotropy, material id
  z-test          DEPTH24      a renderbuffer, never sampled
"""

from __future__ import annotations

from dataclasses import dataclass

import moderngl
import numpy as np

from app.gl.shaders import ShaderCache
from app.scene.camera import gl_bytes
from app.scene.geometry import VERTEX_ATTRIBUTES, VERTEX_FORMAT, MeshPart, Texture


@dataclass
class GBufferData:
    """A G-buffer read back to the CPU, rows top to bottom."""

    albedo: np.ndarray  # (H, W, 4) float32
    normal: np.ndarray  # (H, W, 4) float32
    depth: np.ndarray  # (H, W) float32 view depth in metres, 0 = background
    tangent: np.ndarray  # (H, W, 4) float32


class GBuffer:
    """The render targets of the G-buffer pass."""

    def __init__(self, ctx: moderngl.Context, size: tuple[int, int], precision: str) -> None:
        dtype = {"f16": "f2", "f32": "f4"}[precision]
        self.size = size
        self.albedo = ctx.texture(size, 4, dtype=dtype)
        self.normal = ctx.texture(size, 4, dtype=dtype)
        self.depth = ctx.texture(size, 1, dtype="f4")
        self.tangent = ctx.texture(size, 4, dtype=dtype)
        self.zbuffer = ctx.depth_renderbuffer(size)
        for tex in (self.albedo, self.normal, self.depth, self.tangent):
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
            tex.repeat_x = tex.repeat_y = False
        self.fbo = ctx.framebuffer(
            [self.albedo, self.normal, self.depth, self.tangent], self.zbuffer
        )

    def read(self) -> GBufferData:
        w, h = self.size
        albedo = _read_float(self.albedo).reshape(h, w, 4)
        normal = _read_float(self.normal).reshape(h, w, 4)
        depth = np.frombuffer(self.depth.read(), np.float32).reshape(h, w)
        tangent = _read_float(self.tangent).reshape(h, w, 4)
        return GBufferData(
            albedo[::-1].copy(), normal[::-1].copy(), depth[::-1].copy(), tangent[::-1].copy()
        )

    def release(self) -> None:
        for obj in (self.fbo, self.albedo, self.normal, self.depth, self.tangent, self.zbuffer):
            obj.release()


def _read_float(tex: moderngl.Texture) -> np.ndarray:
    """A float16/float32 texture's texels as float32 (float16 widens exactly)."""
    return np.frombuffer(tex.read(), np.dtype(tex.dtype)).astype(np.float32)


def _upload_texture(ctx: moderngl.Context, tex: Texture) -> moderngl.Texture:
    h, w = tex.pixels.shape[:2]
    internal = 0x8C43 if tex.srgb else None  # GL_SRGB8_ALPHA8: decoded to linear on fetch
    gl_tex = ctx.texture((w, h), 4, tex.pixels[::-1].tobytes(), internal_format=internal)
    gl_tex.build_mipmaps()  # colour data and glTF metallic-roughness maps only
    gl_tex.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
    return gl_tex


class MeshDrawable:
    """One mesh part on the GPU: its program (the shader pair, with the part's texture
    maps as defines), vertex and index buffers, textures and per-part matrices. The
    G-buffer pass and the forward renderer (app/render/forward.py) both draw with it."""

    def __init__(
        self,
        ctx: moderngl.Context,
        shaders: ShaderCache,
        part: MeshPart,
        material_id: int,
        shader_pair: tuple[str, str] = ("passes/gbuffer.vert", "passes/gbuffer.frag"),
        defines: dict[str, object] | None = None,
    ) -> None:
        defines = dict(defines or {})
        if "base_color" in part.maps:
            defines["MAT_BASE_COLOR_MAP"] = None
        if "metallic_roughness" in part.maps:
            defines["MAT_METALLIC_ROUGHNESS_MAP"] = None
        self.program = shaders.program(*shader_pair, defines)
        self.vbo = ctx.buffer(part.vertices.tobytes())
        self.ibo = ctx.buffer(part.indices.tobytes())
        self.vao = ctx.vertex_array(
            self.program,
            [(self.vbo, VERTEX_FORMAT, *VERTEX_ATTRIBUTES)],
            self.ibo,
            skip_errors=True,
        )
        self.textures = {name: _upload_texture(ctx, t) for name, t in part.maps.items()}
        self.part = part
        self.material_id = material_id
        normal_matrix = np.linalg.inv(part.model[:3, :3]).T
        self.model_bytes = gl_bytes(part.model)
        self.normal_bytes = gl_bytes(normal_matrix)
        # A matrix with a negative determinant mirrors the triangles' winding.
        self.mirrored = bool(np.linalg.det(part.model[:3, :3]) < 0.0)

    def draw(self, view_bytes: bytes, proj_bytes: bytes) -> None:
        prog, m = self.program, self.part.material
        prog["u_model"].write(self.model_bytes)
        prog["u_normal_matrix"].write(self.normal_bytes)
        prog["u_view"].write(view_bytes)
        prog["u_proj"].write(proj_bytes)
        prog["u_base_color"].value = m.base_color
        prog["u_metallic"].value = m.metallic
        prog["u_roughness"].value = m.roughness
        prog["u_f0"].value = m.f0
        prog["u_anisotropy"].value = m.anisotropy
        prog["u_material_id"].value = float(self.material_id)
        for unit, (name, tex) in enumerate(self.textures.items()):
            tex.use(unit)
            prog[f"u_{name}_map"].value = unit
        self.vao.render(moderngl.TRIANGLES)

    def release(self) -> None:
        for obj in (self.vao, self.vbo, self.ibo, *self.textures.values()):
            obj.release()


class GBufferPass:
    """Draws every mesh part into a ``GBuffer``; ``material_ids[i]`` is part i's row of the
    lighting pass's material table."""

    def __init__(
        self,
        ctx: moderngl.Context,
        shaders: ShaderCache,
        parts: list[MeshPart],
        material_ids: list[int],
    ) -> None:
        self.ctx = ctx
        self.drawables = [
            MeshDrawable(ctx, shaders, p, i) for p, i in zip(parts, material_ids, strict=True)
        ]

    def run(self, target: GBuffer, view: np.ndarray, proj: np.ndarray) -> None:
        ctx = self.ctx
        target.fbo.use()
        ctx.viewport = (0, 0, *target.size)
        ctx.enable_only(moderngl.DEPTH_TEST)
        ctx.depth_func = "<"
        target.fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        view_bytes, proj_bytes = gl_bytes(view), gl_bytes(proj)
        for d in self.drawables:
            if d.part.closed:
                ctx.enable(moderngl.CULL_FACE)
                ctx.front_face = "cw" if d.mirrored else "ccw"
            else:
                ctx.disable(moderngl.CULL_FACE)
            d.draw(view_bytes, proj_bytes)
        ctx.disable(moderngl.CULL_FACE)

    def release(self) -> None:
        for d in self.drawables:
            d.release()
