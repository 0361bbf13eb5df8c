"""One mesh part on the GPU, ready to draw: its program (the shader pair with the part's
maps, blend and options as defines), vertex and index buffers, textures and per-part
matrices and uniforms. The G-buffer pass (app/render/gbuffer.py), the blend pass's forward
drawables (app/render/blend.py), the shadow pass's masked casters and the bench's forward
renderer all draw with ``MeshDrawable``.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import moderngl
import numpy as np

from app.common.camera import CameraFrame
from app.frame.camera import gl_bytes
from app.gl.shaders import ShaderCache
from app.render.adjacency import adjacency_indices
from app.render.texture_upload import TextureUploads, upload_texture
from app.render.uv import layer_maps_define, uv_defines, uv_transform_bytes
from app.scene.geometry import VERTEX_ATTRIBUTES, VERTEX_FORMAT, MeshPart
from app.textures.lean import lean_defines
from app.textures.maps import Texture


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


def drawn_maps(part: MeshPart) -> list[tuple[str, Texture]]:
    """(sampler uniform, map) of every map a part's drawable samples: its material's
    (and the painted layer's and the mask, where it blends), in texture-unit order."""
    maps = []
    for i, layer in enumerate(part.layers[:2] if part.blend else part.layers[:1]):
        for name, tex in layer.maps.items():
            maps.append((f"u_{name}_map{i}", tex))
    if part.blend is not None:
        maps.append(("u_blend_mask", part.blend.mask))
    return maps


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
        drawn = part.layers[:2] if part.blend else part.layers[:1]
        defines.update(lean_defines([(layer.params, layer.maps) for layer in drawn]))
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
        # render.antialiasing = "gbaa": a mesh's triangles carry their barycentrics to the
        # fragment stage (its edges' distances); an analytic part finds its own silhouette
        geometry = None
        indices = part.indices
        self.mode, self.per_triangle = moderngl.TRIANGLES, 3
        if defines.get("GBUFFER_EDGE") and part.analytic is None:
            defines["GBUFFER_EDGE_GEOMETRY"] = 1
            geometry = "passes/gbuffer_edge.geom"
            # each triangle with its neighbours' far vertices (app/render/adjacency.py)
            indices = adjacency_indices(part.vertices[:, :3], part.indices)
            self.mode, self.per_triangle = moderngl.TRIANGLES_ADJACENCY, 6
        self.program = shaders.program(*shader_pair, defines, geometry)
        # The uniforms the compiler kept: ``name in program`` walks every member, which
        # took a tenth of the G-buffer pass's Python time for twelve analytic spheres.
        self.uniforms = frozenset(self.program)
        # bind_camera's float64 values for the last (camera, image size) it was given
        self._camera_values: tuple[CameraFrame, tuple[int, int], list, bytes, bytes] | None = None
        self.vbo = ctx.buffer(part.vertices.tobytes())
        self.ibo = ctx.buffer(indices.tobytes())
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
        self._uploads = uploads  # its maps left for the first draw: ``bind_material``
        upload = (lambda tex: upload_texture(ctx, tex, shaders)) if uploads is None else uploads.get
        for uniform, tex in drawn_maps(part):
            self.textures.append((uniform, upload(tex)))
        self.part = part
        self.material_ids = material_ids
        normal_matrix = np.linalg.inv(part.model[:3, :3]).T
        self.model_bytes = gl_bytes(part.model)
        self.normal_bytes = gl_bytes(normal_matrix)
        # A matrix with a negative determinant mirrors the triangles' winding.
        self.mirrored = bool(np.linalg.det(part.model[:3, :3]) < 0.0)
        # The volume's object-to-world scale (KHR_materials_volume's thickness is in object
        # units): the cube root of |det|, a uniform scale exactly; float64, once per part.
        self.thickness_scale = float(np.cbrt(abs(np.linalg.det(part.model[:3, :3]))))
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
            if "u_image_size" in self.uniforms:  # the edge stage's window space ("gbaa")
                self.program["u_image_size"].value = tuple(float(x) for x in image_size)
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
        # camera space (a jittered frame's camera_to_world is sheared: its inverse, not .T)
        to_camera = rotation.T if camera.jitter == (0.0, 0.0) else np.linalg.inv(rotation)
        centre = to_camera @ (self.part.model[:3, 3] - camera.position)
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
        if self._uploads is not None:
            self._uploads.finish()  # levels left to the first draw (texture_upload.py)
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
        if "u_thickness_scale" in self.uniforms:  # the transmission pass's volumes
            prog["u_thickness_scale"].value = self.thickness_scale
        if "u_tangent_sign" in self.uniforms:  # used only where a layer has a normal map
            prog["u_tangent_sign"].value = -1.0 if self.mirrored else 1.0

    def draw(
        self,
        view_bytes: bytes,
        proj_bytes: bytes,
        camera: CameraFrame,
        size: tuple[int, int],
        between: Callable[[int], None] | None = None,
        run_triangles: int = 0,
    ) -> None:
        """Bind the part's state and draw its triangles; with ``between``, in runs of at
        most ``run_triangles`` triangles, in their order, calling ``between(triangles
        drawn)`` after each run (``GBufferPass.run`` flushes there, app/render/gbuffer.py
        DRAW_RUN)."""
        self.bind_transform(view_bytes, proj_bytes)
        self.bind_camera(camera, size)
        self.bind_material()
        if between is None:
            self.vao.render(self.mode)
            return
        per = self.per_triangle
        count = len(self.part.indices) // 3 * per
        for first in range(0, count, per * run_triangles):
            run = min(per * run_triangles, count - first)
            self.vao.render(self.mode, vertices=run, first=first)
            between(run // per)

    def release(self) -> None:
        owned = [t for _, t in self.textures] if self._owns_textures else []
        for obj in (self.vao, self.vbo, self.ibo, *owned):
            obj.release()
        if self.extra_vbo is not None:
            self.extra_vbo.release()
