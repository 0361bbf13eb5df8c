"""Scene objects -> triangle meshes and analytic primitives ready for the G-buffer pass.

A sphere without ``subdivisions`` is analytic (``MeshPart.analytic``): its vertices are a
convex proxy around it, and the G-buffer pass intersects each pixel's view ray with the
exact sphere (glsl/geometry/analytic.glsl), so that its normals, UVs, depth and silhouette
are the sphere's own (docs/gbuffer.md, "Analytic primitives"). A plane is built here and a
mesh sphere's icosphere by app/scene/icosphere.py, neither importing trimesh; the other
primitives come from trimesh; OBJ, PLY and STL files are read through trimesh (an OBJ's
MTL material comes through: base colour, PBR roughness, metallic and normal maps,
emission, dissolve; ``_mtl_material``), glTF/GLB through the project's own reader
(app/scene/gltf.py: every primitive, attribute and core material field); the files a mesh
file names are checked first (app/scene/references.py). Every mesh ends up as
interleaved float32 ``position, normal, uv`` vertices and uint32 triangle indices, in
object space, with its model matrix. Tangents come from the UVs where a mesh has usable
ones and from the direction around the object's Y axis otherwise (so anisotropic
highlights on primitives run along lines of latitude).
"""

from __future__ import annotations

import functools
import io
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from PIL import Image

from app.common.material_checks import material_problems
from app.common.models import MaterialParams
from app.common.primitives import Primitive
from app.errors import InputError
from app.scene.icosphere import unit_icosphere
from app.scene.layers import LayerBuilder
from app.scene.loader import LoadedScene
from app.scene.model import SceneObject
from app.scene.placement import model_matrix
from app.textures.bake import bake_blend
from app.textures.maps import (
    SurfaceLayer,
    Texture,
    colour_texture,
    decode_normals,
    linear_channel,
    normal_roughness_chain,
    prefetch_uploads,
    read_image,
    resample,
    scalar_texture,
)
from app.untrusted import RefusedError, files
from app.untrusted.budget import Budget

VERTEX_FORMAT = "3f 3f 2f 4f"
VERTEX_ATTRIBUTES = ("in_position", "in_normal", "in_uv", "in_tangent")

if TYPE_CHECKING:  # trimesh is imported where a mesh needs it: a glTF file never does
    import trimesh

    from app.scene.references import MtlMap


@dataclass
class BlendMask:
    """A mask painting ``MeshPart.layers[1]`` over ``layers[0]`` (RTR4 §9.13)."""

    mask: Texture  # red channel, sampled with layer 0's UV scale
    threshold: float
    softness: float


@dataclass
class MeshPart:
    """One drawable: vertices, indices, its material layers and where it stands.

    ``layers[0]`` is the material; a second layer is painted over it by ``blend`` at run
    time, or, for a baked blend, is only the material-table row its ``select`` map picks.
    """

    vertices: np.ndarray  # (N, 12) float32: position, normal, uv, tangent (xyz, handedness)
    indices: np.ndarray  # (M*3,) uint32
    layers: list[SurfaceLayer]
    model: np.ndarray  # (4, 4) float64 object -> world
    blend: BlendMask | None = None
    # Closed primitives are drawn with back faces culled: at a silhouette a back face lies
    # within the 24-bit depth buffer's resolution of the front face and could win the depth
    # test with a normal facing away. Planes and mesh files (possibly open) stay two-sided.
    closed: bool = False
    object_index: int = -1  # the scene object (index into scene.objects) it was built from
    # An analytic primitive drawn through the proxy ``vertices`` (its model is ``model``).
    analytic: Primitive | None = None
    # Optional per-vertex attributes of mesh files (glTF TEXCOORD_1 and COLOR_0): (N, 2)
    # and (N, 4) float32, linear RGBA; None where the file has none.
    uv1: np.ndarray | None = None
    colors: np.ndarray | None = None
    # A glTF part's own material by its ``file_materials`` key (app/scene/file_materials.py)
    # where the file's material is drawn; None otherwise (the viewer's pick names it).
    file_material: str | None = None

    @property
    def material(self) -> MaterialParams:
        """The constants of the part's (first) material."""
        return self.layers[0].params

    def surface_points(self) -> np.ndarray:
        """(N, 3) object-space points on the surface, for bounds and screen boxes: the
        vertices, or for an analytic sphere its proxy's directions on the sphere itself."""
        points = self.vertices[:, :3].astype(np.float64)
        if self.analytic is not None and self.analytic.kind == "sphere":
            length = np.linalg.norm(points, axis=1, keepdims=True)
            points = points / length * self.analytic.radius
        return points

    def triangles(self) -> tuple[np.ndarray, np.ndarray]:
        """(vertices, indices) of a triangle mesh of the surface, for consumers that need
        triangles (the bench's pyrender scene, picking): the part's own, or for an analytic
        sphere an icosphere of 5,120 triangles (the mesh sphere's default)."""
        if self.analytic is None:
            return self.vertices, self.indices
        return _sphere_triangles(self.analytic.radius)


@functools.lru_cache(maxsize=64)
def _sphere_triangles(radius: float) -> tuple[np.ndarray, np.ndarray]:
    """An analytic sphere's triangles (``MeshPart.triangles``), read-only, built once per
    radius: the shadow pass asks for every shadowed sphere's, and a scene's spheres
    mostly share a few radii (the showcase: 21 spheres, 2 radii)."""
    vertices, indices = _interleave(_icosphere(radius, ICOSPHERE_SUBDIVISIONS))
    vertices.setflags(write=False)
    indices.setflags(write=False)
    return vertices, indices


def _crease_normals(mesh: trimesh.Trimesh, crease_deg: float = 40.0) -> trimesh.Trimesh:
    """Split vertices where faces meet at more than ``crease_deg``: hard edges stay hard.

    Each face corner gets the area-weighted mean of the normals of the faces around
    its vertex that lie within the crease angle of its own face.
    """
    import trimesh

    faces = mesh.faces
    fn = mesh.face_normals * mesh.area_faces[:, None]
    unit = mesh.face_normals
    cos_crease = math.cos(math.radians(crease_deg))
    around: dict[int, list[int]] = {}
    for f, tri in enumerate(faces):
        for v in tri:
            around.setdefault(int(v), []).append(f)
    corner_normals = np.empty((len(faces), 3, 3))
    for f, tri in enumerate(faces):
        for c, v in enumerate(tri):
            group = np.array(around[int(v)])
            keep = group[unit[group] @ unit[f] >= cos_crease]
            n = fn[keep].sum(axis=0)
            corner_normals[f, c] = n / np.linalg.norm(n)
    positions = mesh.vertices[faces].reshape(-1, 3)
    normals = corner_normals.reshape(-1, 3)
    new_faces = np.arange(len(positions)).reshape(-1, 3)
    out = trimesh.Trimesh(positions, new_faces, vertex_normals=normals, process=False)
    out.merge_vertices(merge_norm=True)
    return out


@dataclass(frozen=True)
class PrimitiveMesh:
    """A primitive's triangles with the normals and UVs it is made with: what ``_interleave``
    reads of a trimesh mesh, without importing trimesh for a plane or a sphere."""

    vertices: np.ndarray  # (N, 3) float64
    faces: np.ndarray  # (M, 3) int64
    vertex_normals: np.ndarray  # (N, 3) float64
    uv: np.ndarray  # (N, 2) float64


def _plane(size: list[float]) -> PrimitiveMesh:
    """A quad in the XZ plane facing +Y, with UVs over [0, 1]^2."""
    sx, sz = size[0] / 2.0, size[1] / 2.0
    v = np.array([[-sx, 0, -sz], [-sx, 0, sz], [sx, 0, sz], [sx, 0, -sz]], np.float64)
    uv = np.array([[0, 1], [0, 0], [1, 0], [1, 1]], np.float64)
    faces = np.array([[0, 1, 2], [0, 2, 3]], np.int64)
    return PrimitiveMesh(v, faces, np.tile([0.0, 1.0, 0.0], (4, 1)), uv)


def _sphere_uv(unit: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Equirectangular UVs of a unit sphere's vertices (u = longitude around +Y from +Z,
    v = latitude, both in [0, 1]), with the vertices on the seam duplicated so that no
    triangle's u runs backwards across it (which would squeeze the whole texture into one
    strip of triangles)."""
    u = np.arctan2(unit[:, 0], unit[:, 2]) / (2.0 * np.pi) + 0.5
    v = np.arcsin(np.clip(unit[:, 1], -1.0, 1.0)) / np.pi + 0.5
    positions, uv, faces = list(unit), list(np.stack([u, v], axis=1)), faces.copy()
    fu = u[faces]
    wraps = fu.max(axis=1) - fu.min(axis=1) > 0.5
    copies: dict[int, int] = {}
    for f in np.nonzero(wraps)[0]:
        for c in range(3):
            i = int(faces[f, c])
            if u[i] < 0.5:  # the low side of the seam moves to u + 1
                if i not in copies:
                    copies[i] = len(positions)
                    positions.append(unit[i])
                    uv.append(np.array([u[i] + 1.0, v[i]]))
                faces[f, c] = copies[i]
    return np.asarray(positions), faces, np.asarray(uv)


ICOSPHERE_SUBDIVISIONS = 4  # a mesh sphere's tessellation where a consumer needs triangles
# The analytic sphere's proxy: an icosphere of 80 triangles pushed out until its faces
# enclose the sphere, drawn with its front faces culled (GBufferPass.run), so that its back
# faces cover every pixel of the sphere once even with the camera inside the proxy. Which
# pixels run the ray test is all the proxy decides; 80 faces (15 % more area than the
# sphere's outline) drew the G-buffer faster than 320 (4 %) and 20 (58 %) on every scene
# measured, the close-up included (docs/performance.md, "Fewer G-buffer bytes").
PROXY_SUBDIVISIONS = 1


@functools.cache
def _unit_sphere(subdivisions: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The unit icosphere's seam-split positions (its exact normals too), faces and UVs,
    read-only, built once per process and count (a shadowed scene's analytic spheres each
    ask for their triangles)."""
    unit, faces = unit_icosphere(subdivisions)
    # The exact sphere normal, not an average of facet normals.
    normals = unit / np.linalg.norm(unit, axis=1, keepdims=True)
    positions, faces, uv = _sphere_uv(normals, np.asarray(faces))
    for array in (positions, faces, uv):
        array.setflags(write=False)
    return positions, faces, uv


def _icosphere(radius: float, subdivisions: int) -> PrimitiveMesh:
    """An icosphere mesh with exact sphere normals and seam-split equirectangular UVs."""
    # A unit icosphere scaled here (app/scene/icosphere.py: trimesh's, without trimesh):
    # trimesh's radius divides by the vertices' lengths, 0/0 for a radius under ~1e-15 m
    # (NaN vertices and a RuntimeWarning on stderr; found by tests/test_fuzz_scenes.py).
    positions, faces, uv = _unit_sphere(subdivisions)
    return PrimitiveMesh(positions * radius, faces, positions, uv)


@functools.cache
def _unit_proxy() -> tuple[np.ndarray, np.ndarray, float]:
    """The proxy's unit directions, faces and inradius, built once per process."""
    unit, faces = unit_icosphere(PROXY_SUBDIVISIONS)
    v = unit / np.linalg.norm(unit, axis=1, keepdims=True)
    f = np.array(faces)
    normals = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    inradius = float(np.min(np.abs(np.sum(normals * v[f[:, 0]], axis=1))))
    v.setflags(write=False)
    f.setflags(write=False)
    return v, f, inradius


def sphere_proxy(radius: float) -> tuple[np.ndarray, np.ndarray]:
    """(vertices, indices) of a convex polyhedron that encloses the sphere of ``radius``:
    the icosphere scaled by 1 / its inradius (the distance of its nearest face plane), with
    a relative margin of 1e-4 so that float32 rasterisation cannot cut a silhouette pixel."""
    v, f, inradius = _unit_proxy()
    positions = v * (radius / inradius * (1.0 + 1e-4))
    vertices = np.zeros((len(v), 12), np.float32)
    vertices[:, 0:3] = positions
    vertices[:, 3:6] = v  # unused by the analytic pass; the direction, for completeness
    vertices[:, 8:12] = (1.0, 0.0, 0.0, 1.0)
    return vertices, f.astype(np.uint32).ravel()


def _primitive(obj: SceneObject) -> trimesh.Trimesh | PrimitiveMesh:
    if obj.shape == "sphere":
        subdivisions = ICOSPHERE_SUBDIVISIONS if obj.subdivisions is None else obj.subdivisions
        return _icosphere(obj.radius or 0.5, subdivisions)
    if obj.shape == "plane":
        return _plane(obj.size or [10.0, 10.0])
    import trimesh  # the other primitives (a plane or sphere alone does not import it)

    if obj.shape == "box":
        return _crease_normals(trimesh.creation.box(extents=obj.size or [1.0, 1.0, 1.0]))
    if obj.shape == "cylinder":
        mesh = trimesh.creation.cylinder(
            radius=obj.radius or 0.5, height=obj.height or 1.0, sections=64
        )
        return _crease_normals(mesh)
    if obj.shape == "capsule":
        return trimesh.creation.capsule(
            radius=obj.radius or 0.5, height=obj.height or 1.0, count=[64, 32]
        )
    raise AssertionError(obj.shape)


def vertex_normals(mesh: trimesh.Trimesh | PrimitiveMesh) -> np.ndarray:
    """The mesh's own vertex normals, or area-weighted face normals summed per vertex.

    Computed here rather than by trimesh, whose fallback without scipy is O(V*F) and
    logs a traceback; a vertex no face touches gets +Y rather than NaN.
    """
    if isinstance(mesh, PrimitiveMesh) or "vertex_normals" in mesh._cache:  # given
        # by our primitives or by the file
        return np.asarray(mesh.vertex_normals, np.float64)
    v = np.asarray(mesh.vertices, np.float64)
    f = np.asarray(mesh.faces, np.int64)
    face_n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])  # |.| = 2 area
    acc = np.zeros_like(v)
    for corner in range(3):
        np.add.at(acc, f[:, corner], face_n)
    length = np.linalg.norm(acc, axis=1, keepdims=True)
    return np.where(length > 0.0, acc / np.where(length > 0.0, length, 1.0), [0.0, 1.0, 0.0])


def vertex_tangents(
    positions: np.ndarray, normals: np.ndarray, uv: np.ndarray | None, faces: np.ndarray
) -> np.ndarray:
    """Per-vertex unit tangents (N, 4): xyz along +u, w = +-1 the handedness of (t, b, n).

    Lengyel's method: each triangle's dP/du and dP/dv from its UVs, area-weighted sums per
    vertex, Gram-Schmidt against the normal. Where there are no UVs, or they are
    degenerate at a vertex, the tangent is Y x n (around the object's vertical axis), and
    X x n at the poles where that vanishes.
    """
    n = np.asarray(normals, np.float64)
    fallback = np.cross([0.0, 1.0, 0.0], n)
    pole = np.linalg.norm(fallback, axis=1) < 1e-6
    fallback[pole] = np.cross([1.0, 0.0, 0.0], n[pole])
    t_acc = np.zeros_like(n)
    b_acc = np.zeros_like(n)
    if uv is not None:
        f = np.asarray(faces, np.int64)
        p = np.asarray(positions, np.float64)
        w = np.asarray(uv, np.float64)
        e1, e2 = p[f[:, 1]] - p[f[:, 0]], p[f[:, 2]] - p[f[:, 0]]
        d1, d2 = w[f[:, 1]] - w[f[:, 0]], w[f[:, 2]] - w[f[:, 0]]
        det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
        # dP/du = (e1 dv2 - e2 dv1)/det; multiplying by |det| (the UV area) weights each
        # face by its size and leaves faces with degenerate UVs (det = 0) out.
        sign = np.where(np.abs(det) > 1e-12, np.sign(det), 0.0)[:, None]
        dpdu = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) * sign
        dpdv = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) * sign
        for corner in range(3):
            np.add.at(t_acc, f[:, corner], dpdu)
            np.add.at(b_acc, f[:, corner], dpdv)
    t = t_acc - n * np.sum(n * t_acc, axis=1, keepdims=True)
    length = np.linalg.norm(t, axis=1, keepdims=True)
    usable = length[:, 0] > 1e-9
    t = np.where(usable[:, None], t / np.where(usable, length[:, 0], 1.0)[:, None], fallback)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    handed = np.where(np.sum(np.cross(n, t) * b_acc, axis=1) < 0.0, -1.0, 1.0)
    return np.hstack([t, handed[:, None]])


def _interleave(mesh: trimesh.Trimesh | PrimitiveMesh) -> tuple[np.ndarray, np.ndarray]:
    positions = np.asarray(mesh.vertices, np.float64)
    normals = vertex_normals(mesh)
    uv = mesh.uv if isinstance(mesh, PrimitiveMesh) else getattr(mesh.visual, "uv", None)
    uv = None if uv is None or len(uv) != len(positions) else np.asarray(uv, np.float64)
    return _vertex_array(positions, normals, uv, None, mesh.faces)


def _vertex_array(
    positions: np.ndarray,
    normals: np.ndarray,
    uv: np.ndarray | None,
    tangents: np.ndarray | None,
    faces: np.ndarray,
    tangent_uv: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Interleaved float32 vertices and uint32 indices; ``tangents`` None: derived from
    ``tangent_uv`` (the UVs the normal map reads; default ``uv``)."""
    if tangents is None:
        tangents = vertex_tangents(
            positions, normals, uv if tangent_uv is None else tangent_uv, faces
        )
    uv = np.zeros((len(positions), 2)) if uv is None else uv
    vertices = np.hstack([positions, normals, uv, tangents]).astype(np.float32)
    indices = np.asarray(faces, np.uint32).ravel()
    return vertices, indices


def _file_material(
    mesh: trimesh.Trimesh,
    fallback: MaterialParams,
    normal_filter: str,
    mtl: dict[str, dict[str, MtlMap]] | None = None,
    read: Callable[[MtlMap], Image.Image] | None = None,
) -> SurfaceLayer:
    """With ``mtl`` (an OBJ that names an MTL file: its materials' maps by name,
    ``obj_materials``), the MTL's material (``_mtl_material``; ``read`` opens its maps);
    otherwise ``fallback``. (OBJ, PLY and STL carry no other material trimesh reads; glTF
    materials come from app/scene/gltf.py.)"""
    import trimesh

    mat = getattr(mesh.visual, "material", None)
    if (
        mtl is not None
        and read is not None
        and isinstance(mat, trimesh.visual.material.SimpleMaterial)
    ):
        return _mtl_material(mat, mtl.get(mat.name, {}), fallback, normal_filter, read)
    return SurfaceLayer(fallback)


def _mtl_number(kwargs: dict, key: str) -> float | None:
    """An MTL statement's first number as trimesh keeps it (``kwargs``: the lower-cased
    keyword -> its words, or floats for ``kd``), or None where absent or not a number."""
    value = kwargs.get(key)
    word = value[0] if isinstance(value, list | tuple) and value else value
    try:
        number = float(word)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return None
    return number if math.isfinite(number) else None


def _mtl_colour(kwargs: dict, key: str) -> tuple[float, float, float] | None:
    """An MTL colour statement's three numbers (``Kd``, ``Ke``; trimesh keeps floats for
    ``kd``, words for the rest), or None where absent, short or not finite numbers."""
    value = kwargs.get(key)
    if not isinstance(value, list | tuple) or len(value) < 3:
        return None
    try:
        rgb = tuple(float(c) for c in value[:3])
    except (TypeError, ValueError):
        return None
    return rgb if all(math.isfinite(c) for c in rgb) else None  # type: ignore[return-value]


def _coverage_rgba(kd: Image.Image | None, d: Image.Image | None) -> Image.Image:
    """The base colour texture of an MTL material: ``map_Kd`` (white where absent, at
    ``map_d``'s size) with ``map_d``'s first channel (linear) as its alpha where given,
    resampled to ``map_Kd``'s size; without ``map_d``, ``map_Kd``'s own alpha."""
    if kd is None:
        assert d is not None
        rgba = np.full((d.height, d.width, 4), 255, np.uint8)
    else:
        rgba = np.array(kd.convert("RGBA"), np.uint8)
    if d is not None:
        alpha = resample(linear_channel(d), rgba.shape[:2])
        rgba[..., 3] = np.round(np.clip(alpha, 0.0, 1.0) * 255.0).astype(np.uint8)
    return Image.fromarray(rgba, "RGBA")


def _mtl_material(
    mat: trimesh.visual.material.SimpleMaterial,
    maps: dict[str, MtlMap],
    fallback: MaterialParams,
    normal_filter: str,
    read: Callable[[MtlMap], Image.Image],
) -> SurfaceLayer:
    """An OBJ's MTL material as the glTF path reads one (docs/scene-format.md, "Mesh
    files"). Each map multiplies its factor, and a map without its factor has factor 1:

    - ``Kd`` the base colour factor (linear, as glTF's baseColorFactor; read from
      trimesh's float copy, not its 8-bit ``diffuse``), ``map_Kd`` the base colour map
      (sRGB);
    - the PBR extension's ``Pr`` / ``map_Pr`` (roughness, linear first channel) and
      ``Pm`` / ``map_Pm`` (metallic, likewise), and ``norm`` (a tangent-space normal map,
      x and y scaled by its ``-bm`` option as glTF's normalTexture.scale);
    - ``Ke`` / ``map_Ke`` the emitted radiance (linear factor, sRGB map, glTF's
      emissiveFactor / emissiveTexture);
    - ``d`` / ``map_d`` (dissolve) the coverage: any ``d`` below 1 or a ``map_d`` makes
      the material ``alpha_mode = "blend"`` (dissolve is a fraction of the surface seen,
      not a cut-out threshold, so blending is what it means).

    ``maps`` come from app/scene/references.py (files relative to the MTL's folder, options
    before the name parsed), not from trimesh, which takes a ``map_Kd`` line's options for
    part of the file name and then drops the image silently. Called only for an OBJ with
    an ``mtllib``: without one trimesh makes up a grey material with a 2 x 2 image, which
    must not replace the default."""
    kwargs = getattr(mat, "kwargs", None) or {}
    kd = _mtl_colour(kwargs, "kd")
    if kd is not None:
        base = tuple(min(max(c, 0.0), 1.0) for c in kd)
    else:  # no Kd: the map alone (factor 1), or the default colour
        base = (1.0, 1.0, 1.0) if "map_kd" in maps else fallback.base_color
    roughness = _mtl_number(kwargs, "pr")
    metallic = _mtl_number(kwargs, "pm")
    if roughness is None:
        roughness = 1.0 if "map_pr" in maps else fallback.roughness
    if metallic is None:
        metallic = 1.0 if "map_pm" in maps else fallback.metallic
    params = MaterialParams(
        base_color=base,  # type: ignore[arg-type]
        metallic=min(max(metallic, 0.0), 1.0),
        roughness=min(max(roughness, 0.0), 1.0),
        f0=fallback.f0,
    )
    images = {key: read(m) for key, m in maps.items()}
    layer = SurfaceLayer(params)
    if "map_kd" in images or "map_d" in images:
        rgba = _coverage_rgba(images.get("map_kd"), images.get("map_d"))
        layer.maps["base_color"] = colour_texture(rgba)
    if "map_pm" in images:
        layer.maps["metallic"] = scalar_texture(linear_channel(images["map_pm"]))
    normals = None
    if "norm" in images:
        normals = decode_normals(images["norm"], _bump_multiplier(maps["norm"]))
    if normals is not None or "map_pr" in images:
        r = linear_channel(images["map_pr"]) if "map_pr" in images else None
        chain = normal_roughness_chain(normals, params.roughness, r, normal_filter)
        layer.maps["normal_roughness"] = chain
    layer.normal_mapped = normals is not None
    ke = _mtl_colour(kwargs, "ke")
    if ke is not None:
        layer.emissive = tuple(max(c, 0.0) for c in ke)  # type: ignore[assignment]
    elif "map_ke" in images:
        layer.emissive = (1.0, 1.0, 1.0)
    if "map_ke" in images and any(layer.emissive):
        layer.maps["emissive"] = colour_texture(images["map_ke"])
    elif "map_ke" in images:  # Ke 0 0 0 times the map: nothing is emitted (glTF's rule)
        _LOG.warning(
            "newmtl %s: map_Ke: Ke is black, so the map emits nothing; it is not used", mat.name
        )
    d = _mtl_number(kwargs, "d")
    layer.alpha = 1.0 if d is None else min(max(d, 0.0), 1.0)
    if layer.alpha < 1.0 or "map_d" in images:
        layer.alpha_mode = "blend"
    # The checks every material front-end shares (app/common/material_checks.py) on what
    # this material became; a problem names the statement it comes from.
    for problem in material_problems(layer.params, layer.maps, layer.emissive):
        statement = _MTL_STATEMENTS.get(problem.key, "newmtl")
        raise MtlMaterialError(mat.name, statement, problem.message)
    return layer


class MtlMaterialError(ValueError):
    """An MTL material the shared material checks refuse: the material's name, the
    statement (``Ke``) and the message; ``build_parts`` names the MTL file and object."""

    def __init__(self, material: str, statement: str, message: str) -> None:
        super().__init__(f"newmtl {material}: {statement}: {message}")
        self.material, self.statement, self.message = material, statement, message


# The MTL statement that gives what a resolved check's scene-file key is about
# (app/common/material_checks.py); any other: the material's ``newmtl``.
_MTL_STATEMENTS = {
    "emissive_map": "map_Ke",
    "emissive_strength": "Ke",
    "metallic": "Pm",
}


def _bump_multiplier(norm: MtlMap) -> float:
    """``norm``'s ``-bm`` option (1 where absent or not a finite number)."""
    words = norm.options.get("-bm", ())
    value = _mtl_number({"bm": list(words)}, "bm")
    return 1.0 if value is None else value


_LOG = logging.getLogger("pbs.mtl")  # what an MTL material gives that does nothing
_DEFAULT_MATERIAL = MaterialParams((0.8, 0.8, 0.8), 0.0, 0.5, 0.04)


# The map an MTL statement becomes, for what it costs (app/untrusted/budget.py).
_MTL_KINDS = {"map_kd": "colour", "map_ke": "colour", "norm": "normal", "map_pr": "normal"}
# The file types trimesh reads for the project (by suffix), from bytes pbs read itself.
MESH_SUFFIXES = (".obj", ".ply", ".stl", ".off")


def _load_file(
    loaded: LoadedScene, index: int, obj: SceneObject, budget: Budget
) -> tuple[
    list[tuple[trimesh.Trimesh, np.ndarray]], dict[str, dict[str, MtlMap]] | None, dict[str, str]
]:
    """The file's triangle meshes with their node transforms and, for an OBJ that names
    an MTL, its materials' maps by name (the materials then apply, ``_mtl_material``)
    and the MTL file (as the OBJ names it) that defines each material.

    The file is read here (confined, a plain file, within the size limit) and trimesh
    parses the bytes; an OBJ's MTL files reach it through a resolver holding only the MTL
    files this module confined and read, so trimesh opens no file itself (it would take
    any ``mtllib ../../x`` and image name it finds)."""
    import trimesh

    from app.scene.references import (
        obj_index_problem,
        obj_libraries,
        obj_materials,
        obj_mtl_files,
        obj_problem,
    )

    scene_file, key = str(loaded.path), f"objects[{index}].file"
    path = loaded.resolve_file(obj.file or "", key)
    policy = loaded.policy
    suffix = path.suffix.lower()
    try:
        if suffix not in MESH_SUFFIXES:
            raise RefusedError(
                f"{path}: not a mesh file pbs reads (.gltf, .glb, {', '.join(MESH_SUFFIXES)})"
            )
        data = files.read_bytes(path, policy.limits.max_file_bytes)
        budget.charge(len(data), "mesh file byte", f"{path.name} ({len(data)} bytes)")
    except RefusedError as exc:
        raise InputError(scene_file, key, str(exc)) from None
    # A missing texture or MTL is bad input: trimesh would load the file without it (a
    # white model).
    libraries = obj_libraries(data) if suffix == ".obj" else []
    try:
        mtls = obj_mtl_files(path, libraries, policy)
    except RefusedError as exc:
        raise InputError(scene_file, key, str(exc)) from None
    problem = obj_problem(path, mtls, policy)
    if problem is None and suffix == ".obj":  # a bad face index: the file's line, not trimesh's
        problem = obj_index_problem(path, data)  # words, nor an index 0 read as the last vertex
    if problem is not None:
        raise InputError(scene_file, key, problem)
    mtl = obj_materials(mtls) if mtls else None
    sources = {name: m.name for m in reversed(mtls) for name in m.materials}  # first wins
    resolver = {m.name: m.data for m in mtls}
    try:
        mesh_data = trimesh.load(
            io.BytesIO(data), file_type=suffix[1:], resolver=resolver, process=False
        )
    except Exception as exc:  # trimesh raises many types for unreadable files
        raise InputError(
            scene_file, key, f"cannot read mesh {path} ({type(exc).__name__}: {exc})"
        ) from None
    if isinstance(mesh_data, trimesh.Trimesh):
        if len(mesh_data.faces):
            return [(mesh_data, np.eye(4))], mtl, sources
    elif isinstance(mesh_data, trimesh.Scene):
        parts = []
        for node in mesh_data.graph.nodes_geometry:
            transform, name = mesh_data.graph[node]
            geom = mesh_data.geometry[name]
            if isinstance(geom, trimesh.Trimesh) and len(geom.faces):
                parts.append((geom, np.asarray(transform, np.float64)))
        if parts:
            return parts, mtl, sources
    raise InputError(scene_file, key, f"{path} holds no triangles")


def _image_reader(
    loaded: LoadedScene, index: int, budget: Budget
) -> Callable[[MtlMap], Image.Image]:
    """Opens an MTL map of object ``index`` once per file (parts sharing a material, or
    materials sharing a map, read it once); a file that does not decode is an InputError
    naming the object."""
    key = f"objects[{index}].file"

    @functools.cache
    def read(file: Path, kind: str) -> Image.Image:
        return read_image(file, str(loaded.path), key, budget, kind)

    return lambda m: read(m.file, _MTL_KINDS.get(m.keyword.lower(), "scalar"))


def check_extent(part: MeshPart, scene_file: str, key: str) -> None:
    """A mesh part's world-space corners finite and within ``MAX_COORDINATE`` metres (a
    file's NaN vertex, or coordinates whose squares overflow float32 in the light loop);
    an InputError naming the object otherwise."""
    from app.scene.gltf_schema import MAX_COORDINATE  # a mesh file's parts only

    p = part.vertices[:, :3]
    with np.errstate(all="ignore"):  # NaN and overflow are what is checked
        # A NaN or infinite vertex makes its box's corners NaN or infinite too.
        lo, hi = p.min(axis=0).astype(np.float64), p.max(axis=0).astype(np.float64)
        corners = np.array([[x, y, z, 1.0] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                            for z in (lo[2], hi[2])])  # fmt: skip
        world = corners @ part.model.T
    if not np.all(np.abs(world[:, :3]) <= MAX_COORDINATE):
        raise InputError(
            scene_file,
            key,
            f"its vertices are NaN, infinite or placed past {MAX_COORDINATE:g} m from the origin",
        )


GLTF_SUFFIXES = (".gltf", ".glb")


def _gltf_parts(
    loaded: LoadedScene,
    index: int,
    model: np.ndarray,
    chosen: tuple[list[SurfaceLayer], BlendMask | None] | None,
    normal_filter: str,
    budget: Budget,
) -> list[MeshPart]:
    """A glTF/GLB object's primitives (app/scene/gltf.py), each with its world matrix
    ``model @ node``. The file's material gives the layer and, through ``doubleSided``,
    whether back faces are culled; a scene material replaces it and keeps the part
    two-sided, as for other mesh files. Any problem with the file is one InputError."""
    # The glTF reader (its schema, extensions, animation) is imported by a scene that
    # names a glTF file, not by one of primitives (docs/performance.md, "Start-up").
    from app.scene import file_materials
    from app.scene.gltf import GltfFile
    from app.scene.gltf_animation import PoseError, PoseRequest
    from app.scene.gltf_document import GltfError
    from app.scene.references import gltf_problem

    scene_file, key = str(loaded.path), f"objects[{index}].file"
    path = loaded.resolve_file(loaded.scene.objects[index].file or "", key)
    parts: list[MeshPart] = []
    try:
        obj = loaded.scene.objects[index]
        pose = PoseRequest(obj.animation, obj.time, obj.variant)
        gltf = GltfFile(path, loaded.policy, budget, pose)
        problem = gltf_problem(gltf.doc, path, loaded.policy)  # missing files, extensions
        if problem is not None:
            raise InputError(scene_file, key, problem)
        materials = gltf.doc.materials or []
        names = file_materials.material_keys(materials)
        if obj.file_materials:
            gltf.factors = file_materials.resolved(
                obj.file_materials, materials, scene_file, index, path
            )
        prims = gltf.primitives()
        if loaded.still_view is not None and chosen is None and gltf.still_streamable():
            gltf.uv_lods = _still_uv_lod(loaded.still_view, prims, model, gltf)
        for prim in prims:
            blend, closed = None, False
            if chosen is not None:
                layers, blend = chosen
            else:
                layers = [gltf.layer(prim.material, _DEFAULT_MATERIAL, normal_filter)]
                closed = not gltf.double_sided(prim.material)
            sets = {t.uv_set for t in layers[0].uv_transforms.values()}
            if 1 in sets and prim.uv1 is None:
                raise GltfError(prim.key, "its material reads TEXCOORD_1, which it lacks")
            normal_uv = layers[0].uv_transforms.get("normal_roughness")
            tangent_uv = prim.uv1 if normal_uv is not None and normal_uv.uv_set == 1 else None
            vertices, indices = _vertex_array(
                prim.positions, prim.normals, prim.uv, prim.tangents, prim.faces, tangent_uv
            )
            uv1 = None if prim.uv1 is None else prim.uv1.astype(np.float32)
            colors = None if prim.colors is None else prim.colors.astype(np.float32)
            part = MeshPart(vertices, indices, layers, model @ prim.world, blend, closed, index)
            part.uv1, part.colors = uv1, colors
            if chosen is None and prim.material is not None:
                part.file_material = names[prim.material]
            parts.append(part)
    except PoseError as exc:  # an animation, time or variant the file does not have
        raise InputError(scene_file, f"objects[{index}].{exc.option}", f"{path}: {exc}") from None
    except GltfError as exc:
        raise InputError(scene_file, key, f"{path}: {exc}") from None
    if not parts:
        raise InputError(scene_file, key, f"{path} holds no triangles")
    prefetch_uploads(layer for part in parts for layer in part.layers)
    return parts


def _still_uv_lod(
    still_view: Callable[[np.ndarray], tuple[dict, tuple[int, int]]],
    prims: list,
    model: np.ndarray,
    gltf: object,
) -> np.ndarray:
    """The UV levels of detail the still frame's camera samples of a glTF file's
    primitives at its visible pixels (app/scene/sampled_levels.py ``sampled_uv_lods``),
    before their materials' images are read: the camera is the one ``still_view`` frames
    the primitives' world points with."""
    from app.scene.sampled_levels import ViewTriangles, sampled_uv_lods

    triangles = []
    for prim in prims:
        world = model @ prim.world
        # The vertices as the parts keep them (float32), so that the points framed here are
        # the ones the model file frames its camera with (model_file._surface_points).
        local = prim.positions.astype(np.float32).astype(np.float64)
        positions = local @ world[:3, :3].T + world[:3, 3]
        faces = np.asarray(prim.faces, np.int64).reshape(-1, 3)
        two_sided = gltf.double_sided(prim.material)  # type: ignore[attr-defined]
        mirrored = bool(np.linalg.det(world[:3, :3]) < 0.0)
        uv = prim.uv
        if uv is None and prim.material is not None:
            # A material without TEXCOORD_0 samples its maps at uv (0, 0): no derivative,
            # magnification, level 0 (the bound's -inf) where it is seen.
            uv = np.zeros((len(positions), 2))
        triangles.append(ViewTriangles(positions, uv, faces, two_sided, mirrored))
    points = np.concatenate(
        [t.positions[_referenced(t.faces, len(t.positions))] for t in triangles]
    )
    camera, size = still_view(points)
    return sampled_uv_lods(triangles, camera, size)


def _referenced(faces: np.ndarray, count: int) -> np.ndarray:
    """The vertex indices ``faces`` names, each once, ascending: ``np.unique(faces)``'s
    values, without its sort and the import of ``numpy.ma`` it makes (docs/performance.md)."""
    used = np.zeros(count, bool)
    used[faces.ravel()] = True
    return np.flatnonzero(used)


def _material_layers(
    builder: LayerBuilder, name: str, cache: dict
) -> tuple[list[SurfaceLayer], BlendMask | None]:
    """The layers of scene material ``name`` (and its blend), built once per material."""
    if name in cache:
        return cache[name]
    scene = builder.loaded.scene
    base = builder.layer(name)
    blend = scene.materials[name].blend
    if blend is None:
        result: tuple[list[SurfaceLayer], BlendMask | None] = ([base], None)
    else:
        top = builder.layer(blend.material)
        mask = builder.mask(name)
        if scene.render.blend == "baked":
            baked = bake_blend(
                base, top, mask, blend.threshold, blend.softness, builder.normal_filter
            )
            result = ([baked, SurfaceLayer(top.params)], None)
        else:
            chain = scalar_texture(mask)
            result = ([base, top], BlendMask(chain, blend.threshold, blend.softness))
    cache[name] = result
    return result


# What the camera, the lights and the background (its radiance, and whether the image
# keeps it or is transparent, ``--background``) change: not the parts.
_NOT_PARTS: dict = {"camera": True, "lights": True, "background": True, "render": {"background"}}


def _parts_key(loaded: LoadedScene) -> str:
    """Everything of the scene that its parts are built from (objects, materials, textures,
    render settings, the files they name), as one string."""
    return repr((str(loaded.path), loaded.scene.model_dump(exclude=_NOT_PARTS)))


def _camera_key(loaded: LoadedScene) -> str:
    """The scene's camera, as one string: what a still's parts (textures from the finest
    level its camera samples, ``LoadedScene.still_view``) are built from besides, so that
    a re-framed scene builds its own."""
    return repr(loaded.scene.camera.model_dump())


def keep_built(loaded: LoadedScene, parts: list[MeshPart], spent: int, still: bool = False) -> None:
    """Keep ``parts`` (built from ``loaded`` with ``spent`` bytes charged) for the next
    ``take_built`` of this scene or one derived from it with the same objects (and, for
    a still's parts, the same camera). One entry, keyed by (``_parts_key``, the
    ``_camera_key`` of a still's parts or None), its value ``(parts, spent)``."""
    loaded.built.clear()
    loaded.built[(_parts_key(loaded), _camera_key(loaded) if still else None)] = (parts, spent)


def take_built(loaded: LoadedScene) -> tuple[list[MeshPart], int] | None:
    """The parts ``keep_built`` kept for a scene with these objects, materials and
    settings, once (a frame may edit its parts' layers in place: a second frame builds
    its own); None where none were kept or the scene has changed since. The scene's key
    is computed once, the camera's only for a still's parts."""
    if not loaded.built:  # nothing kept: no key to compute
        return None
    ((parts_key, camera_key),) = loaded.built.keys()
    if parts_key != _parts_key(loaded):
        return None
    if camera_key is not None and camera_key != _camera_key(loaded):
        return None
    return loaded.built.pop((parts_key, camera_key))


def build_parts(loaded: LoadedScene, budget: Budget | None = None) -> list[MeshPart]:
    """Every object of the scene as drawable mesh parts. Every file is read under the
    scene's policy and every part charged to ``budget`` (one for the scene where None)
    before it is built (app/untrusted/budget.py)."""
    scene = loaded.scene
    scene_file = str(loaded.path)
    budget = budget or Budget(loaded.policy.limits)
    builder = LayerBuilder(loaded, budget)
    cache: dict = {}
    parts: list[MeshPart] = []

    def charge(vertices: int, triangles: int, key: str, what: str) -> None:
        try:
            budget.mesh(vertices, triangles, what)
        except RefusedError as exc:
            raise InputError(scene_file, key, str(exc)) from None

    for i, obj in enumerate(scene.objects):
        key = f"objects[{i}]"
        model = model_matrix(obj)
        chosen = _material_layers(builder, obj.material, cache) if obj.material else None
        if obj.shape == "sphere" and obj.subdivisions is None:  # analytic
            radius = obj.radius or 0.5
            vertices, indices = sphere_proxy(radius)
            charge(len(vertices), len(indices) // 3, key, f"{key}, a sphere")
            layers, blend = chosen or ([SurfaceLayer(_DEFAULT_MATERIAL)], None)
            analytic = Primitive("sphere", model, radius=radius)
            parts.append(MeshPart(vertices, indices, layers, model, blend, True, i, analytic))
            continue
        if obj.shape != "mesh":
            mesh = _primitive(obj)
            charge(len(mesh.vertices), len(mesh.faces), key, f"{key}, a {obj.shape}")
            vertices, indices = _interleave(mesh)
            layers, blend = chosen or ([SurfaceLayer(_DEFAULT_MATERIAL)], None)
            parts.append(MeshPart(vertices, indices, layers, model, blend, obj.shape != "plane", i))
            continue
        file_key = f"{key}.file"
        if Path(obj.file or "").suffix.lower() in GLTF_SUFFIXES:
            built = _gltf_parts(loaded, i, model, chosen, builder.normal_filter, budget)
        else:
            from app.scene.gltf_schema import MAX_COORDINATE

            meshes, mtl, sources = _load_file(loaded, i, obj, budget)
            read = _image_reader(loaded, i, budget)
            built = []
            for mesh, local in meshes:
                charge(len(mesh.vertices), len(mesh.faces), file_key, f"{obj.file}'s mesh")
                with np.errstate(invalid="ignore"):  # NaN is what is checked
                    if not np.all(np.abs(np.asarray(mesh.vertices)) <= MAX_COORDINATE):
                        raise InputError(
                            scene_file,
                            file_key,
                            f"{obj.file}: its vertices are NaN, infinite or past "
                            f"{MAX_COORDINATE:g} m",
                        )
                if chosen is not None:  # the scene's material overrides the file's
                    layers, blend = chosen
                else:
                    filt = builder.normal_filter
                    try:
                        layers = [_file_material(mesh, _DEFAULT_MATERIAL, filt, mtl, read)]
                    except MtlMaterialError as exc:
                        where = sources.get(exc.material, "its MTL file")
                        raise InputError(scene_file, file_key, f"{where}: {exc}") from None
                    blend = None
                vertices, indices = _interleave(mesh)
                built.append(MeshPart(vertices, indices, layers, model @ local, blend, False, i))
        for part in built:
            check_extent(part, scene_file, file_key)
        parts.extend(built)
    return parts
