"""The glTF reader (app/scene/gltf.py): each feature of a file the test writes
(tests/gltf_builder.py) arrives exactly in MeshPart / SurfaceLayer, and a normal map
tilts the real G-buffer's normal as the file says."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pygltflib
import pytest

from app.errors import InputError
from app.gl.context import GLContext
from app.reference.encoding import oct_decode
from app.render.renderer import Renderer
from app.scene.geometry import MeshPart, build_parts
from app.scene.gltf import GltfFile, _triangles
from app.scene.gltf_document import GltfError
from app.scene.loader import load_scene
from app.textures.maps import UvTransform
from tests.gltf_builder import (
    QUAD_INDICES,
    QUAD_POSITIONS,
    QUAD_UV,
    SHORT,
    GltfBuilder,
    png_rgb,
)
from tests.test_gltf import SCENE  # camera 3 m from the origin, one light, one mesh


def _parts(folder: Path, b: GltfBuilder, name: str = "m.glb", extra: str = "") -> list[MeshPart]:
    b.save(folder / name)
    scene = folder / "scene.toml"
    scene.write_text(SCENE.format(file=name) + extra, encoding="utf-8")
    return build_parts(load_scene(scene))


PBR = pygltflib.PbrMetallicRoughness


def test_factors_keep_full_float64_precision(tmp_path: Path) -> None:
    """Factors off every 8-bit and float16 grid come through to the last bit (trimesh
    passed them through 8 bits)."""
    base = [0.123456789012345, 0.5000001, 0.987654321, 0.3333333333]
    b = GltfBuilder()
    mat = pygltflib.Material(
        pbrMetallicRoughness=PBR(
            baseColorFactor=base, metallicFactor=0.314159265358979, roughnessFactor=0.271828182
        ),
        emissiveFactor=[0.1, 0.2, 0.3],
        extensions={"KHR_materials_emissive_strength": {"emissiveStrength": 7.5}},
        alphaMode="MASK",
        alphaCutoff=0.625,
        doubleSided=True,
    )
    b.quad(b.material(mat))
    (part,) = _parts(tmp_path, b)
    layer = part.layers[0]
    assert layer.params.base_color == tuple(base[:3])
    assert layer.params.metallic == 0.314159265358979
    assert layer.params.roughness == 0.271828182
    assert layer.alpha == base[3]
    assert layer.emissive == (0.1 * 7.5, 0.2 * 7.5, 0.3 * 7.5)
    assert (layer.alpha_mode, layer.alpha_cutoff) == ("mask", 0.625)
    assert part.closed is False  # doubleSided


def test_single_sided_by_default_and_default_material(tmp_path: Path) -> None:
    b = GltfBuilder()
    b.quad(b.material(pygltflib.Material()))
    b.quad(None, translation=[3.0, 0.0, 0.0])
    one, two = _parts(tmp_path, b)
    assert one.closed and two.closed  # glTF 2.0: doubleSided defaults to false
    assert one.layers[0].params.base_color == (1.0, 1.0, 1.0)  # glTF's default factors
    assert (one.layers[0].params.metallic, one.layers[0].params.roughness) == (1.0, 1.0)
    assert two.layers[0].params.base_color == (0.8, 0.8, 0.8)  # the project's default


def test_scene_material_overrides_and_stays_two_sided(tmp_path: Path) -> None:
    b = GltfBuilder()
    b.quad(b.material(pygltflib.Material(pbrMetallicRoughness=PBR(baseColorFactor=[1, 0, 0, 1]))))
    extra = 'material = "mine"\n\n[materials.mine]\nbase_color = [0.1, 0.9, 0.3]\n'
    (part,) = _parts(tmp_path, b, extra=extra)
    assert part.layers[0].params.base_color == (0.1, 0.9, 0.3)
    assert part.closed is False


def test_vertex_attributes_arrive_exactly(tmp_path: Path) -> None:
    """COLOR_0 (unorm8 VEC3 -> linear RGBA with A = 1), TEXCOORD_1 (v flipped like
    TEXCOORD_0), the file's TANGENT (w kept) and positions/normals/UVs."""
    colors = np.array([[255, 0, 0], [0, 255, 0], [0, 0, 255], [51, 102, 204]], np.uint8)
    uv1 = np.array([[0.25, 0.5], [0.75, 0.5], [0.75, 0.0], [0.25, 0.125]], np.float32)
    tangents = np.tile(np.float32([0, 1, 0, -1]), (4, 1))
    b = GltfBuilder()
    b.quad(None, uv1=uv1, colors=colors, tangents=tangents)
    (part,) = _parts(tmp_path, b)
    np.testing.assert_array_equal(part.colors[:, :3], colors / np.float32(255.0))
    np.testing.assert_array_equal(part.colors[:, 3], 1.0)
    np.testing.assert_array_equal(part.uv1, np.stack([uv1[:, 0], 1.0 - uv1[:, 1]], axis=1))
    v = part.vertices
    np.testing.assert_array_equal(v[:, 0:3], QUAD_POSITIONS)
    np.testing.assert_array_equal(v[:, 3:6], np.tile([0, 0, 1], (4, 1)))
    np.testing.assert_array_equal(v[:, 6:8], np.stack([QUAD_UV[:, 0], 1 - QUAD_UV[:, 1]], 1))
    np.testing.assert_array_equal(v[:, 8:12], tangents)
    np.testing.assert_array_equal(part.indices, QUAD_INDICES)


def test_missing_normals_are_flat(tmp_path: Path) -> None:
    """Without NORMAL each triangle gets its own vertices and its face normal."""
    b = GltfBuilder()
    p = QUAD_POSITIONS.copy()
    p[2, 2] = 1.0  # lift one corner: the two triangles are no longer coplanar
    b.node(
        mesh=b.mesh(
            pygltflib.Primitive(
                attributes=pygltflib.Attributes(POSITION=b.accessor(p)),
                indices=b.accessor(QUAD_INDICES),
            )
        )
    )
    (part,) = _parts(tmp_path, b)
    assert len(part.vertices) == 6
    n = part.vertices[:, 3:6].astype(np.float64)
    for tri in range(2):
        c = p[QUAD_INDICES[3 * tri : 3 * tri + 3]].astype(np.float64)
        want = np.cross(c[1] - c[0], c[2] - c[0])
        np.testing.assert_allclose(
            n[3 * tri : 3 * tri + 3], [want / np.linalg.norm(want)] * 3, atol=1e-7
        )


def test_node_hierarchy_and_mirroring(tmp_path: Path) -> None:
    """A child's world matrix is parent @ child (then the object's model matrix); a
    mirrored node keeps its negative determinant for the renderer's winding and
    u_tangent_sign."""
    b = GltfBuilder()
    child = b.quad(None, root=False, scale=[-2.0, 1.0, 1.0])
    b.node(
        translation=[1.0, 2.0, 3.0],
        rotation=[0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4)],
        children=[child],
    )
    (part,) = _parts(tmp_path, b)
    rot = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    want = np.eye(4)
    want[:3, :3] = rot @ np.diag([-2.0, 1.0, 1.0])
    want[:3, 3] = [1.0, 2.0, 3.0]
    np.testing.assert_allclose(part.model, want, atol=1e-12)
    assert np.linalg.det(part.model[:3, :3]) < 0.0


def test_strip_and_fan_become_triangles() -> None:
    idx = np.arange(6, dtype=np.int64)
    np.testing.assert_array_equal(_triangles(idx, 5), [[0, 1, 2], [1, 3, 2], [2, 3, 4], [3, 5, 4]])
    np.testing.assert_array_equal(_triangles(idx, 6), [[1, 2, 0], [2, 3, 0], [3, 4, 0], [4, 5, 0]])
    np.testing.assert_array_equal(_triangles(idx[:2], 5), np.zeros((0, 3)))


@pytest.mark.parametrize(("mode", "order"), [(5, [0, 1, 3, 2]), (6, [0, 1, 2, 3])])
def test_strip_and_fan_in_a_file(tmp_path: Path, mode: int, order: list[int]) -> None:
    """The quad as a non-indexed strip or fan: two front-facing (+Z) triangles."""
    b = GltfBuilder()
    b.node(
        mesh=b.mesh(
            pygltflib.Primitive(
                attributes=pygltflib.Attributes(POSITION=b.accessor(QUAD_POSITIONS[order])),
                mode=mode,
            )
        )
    )
    (part,) = _parts(tmp_path, b)
    v = part.vertices[:, :3].astype(np.float64)
    tris = v[part.indices.reshape(-1, 3)]
    normals = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    assert len(tris) == 2 and np.all(normals[:, 2] > 0.0)


def test_sparse_and_quantized_accessors(tmp_path: Path) -> None:
    """POSITION as normalized int16 (KHR_mesh_quantization) with a sparse accessor moving
    vertex 2; byteStride on the sparse base's view is honoured."""
    b = GltfBuilder()
    q = np.round(QUAD_POSITIONS * 16384).astype(np.int16)
    padded = np.zeros((4, 4), np.int16)  # 8-byte stride: xyz + one unused short
    padded[:, :3] = q
    view = b.view(padded.tobytes(), stride=8)
    where = b.view(np.array([2], np.uint8).tobytes())
    values = b.view(np.array([[0, 32767, -32768]], np.int16).tobytes())  # -32768: -1
    b.doc.accessors.append(
        pygltflib.Accessor(
            bufferView=view,
            componentType=SHORT,
            normalized=True,
            count=4,
            type="VEC3",
            sparse=pygltflib.Sparse(
                count=1,
                indices=pygltflib.AccessorSparseIndices(bufferView=where, componentType=5121),
                values=pygltflib.AccessorSparseValues(bufferView=values),
            ),
        )
    )
    b.node(
        mesh=b.mesh(
            pygltflib.Primitive(
                attributes=pygltflib.Attributes(POSITION=0), indices=b.accessor(QUAD_INDICES)
            )
        )
    )
    (part,) = _parts(tmp_path, b)
    want = q / 32767.0
    want[2] = [0.0, 1.0, -1.0]
    got = part.vertices[:, :3][part.indices]  # no NORMAL: flat, one vertex per corner
    np.testing.assert_allclose(got, want[QUAD_INDICES], rtol=1e-7)


def test_textures_samplers_and_transforms(tmp_path: Path) -> None:
    """Each map arrives under its key with its sampler state and UvTransform; occlusion
    keeps R and its strength; emissive is sRGB."""
    b = GltfBuilder()
    clamp = {"wrapS": 33071, "wrapT": 33648, "minFilter": 9728, "magFilter": 9728}
    base = b.texture(png_rgb((200, 100, 30)), clamp)
    occ = b.texture(png_rgb((64, 255, 255)), how="data")
    emit = b.texture(png_rgb((10, 20, 30)), {"minFilter": 9986})
    transform = {"offset": [0.25, -0.5], "rotation": 0.3, "scale": [2.0, 3.0], "texCoord": 1}
    mat = pygltflib.Material(
        pbrMetallicRoughness=PBR(
            baseColorTexture=pygltflib.TextureInfo(
                index=base, extensions={"KHR_texture_transform": transform}
            )
        ),
        occlusionTexture=pygltflib.OcclusionTextureInfo(index=occ, strength=0.375),
        emissiveTexture=pygltflib.TextureInfo(index=emit, texCoord=1),
        emissiveFactor=[1.0, 1.0, 1.0],  # the default, black, would leave the texture unread
    )
    b.quad(b.material(mat), uv1=QUAD_UV)
    (part,) = _parts(tmp_path, b)
    layer = part.layers[0]
    t = layer.maps["base_color"]
    assert (t.wrap, t.min_filter, t.mag_filter, t.srgb) == (
        ("clamp", "mirror"),
        "nearest",
        "nearest",
        True,
    )
    np.testing.assert_array_equal(t.pixels[0, 0], [200, 100, 30, 255])
    assert layer.uv_transforms["base_color"] == UvTransform(1, (0.25, -0.5), 0.3, (2.0, 3.0))
    assert layer.uv_transforms["emissive"] == UvTransform(uv_set=1)
    assert "occlusion" not in layer.uv_transforms
    e = layer.maps["emissive"]
    assert (e.srgb, e.wrap, e.min_filter) == (True, ("repeat", "repeat"), "nearest_mipmap_linear")
    o = layer.maps["occlusion"]
    assert o.pixels.shape == (4, 4, 1) and o.pixels[0, 0, 0] == pytest.approx(64 / 255)
    assert layer.occlusion_strength == 0.375


def test_metallic_roughness_and_normal_share_one_chain(tmp_path: Path) -> None:
    """MR: B -> metallic map, G x roughnessFactor -> the chain's alpha; the normal map's
    scale tilts the chain's normals; normal_mapped set. The chain takes the normal map's
    sampler and UVs (here untransformed, clamped); the metallic map keeps the MR
    texture's own transform and sampler (docs/scene-format.md, "One chain")."""
    b = GltfBuilder()
    mr = b.texture(png_rgb((0, 128, 64)), {"wrapS": 33648})
    n = b.texture(png_rgb((218, 128, 238)), {"wrapS": 33071})  # ~30 degrees towards +u
    moved = {"KHR_texture_transform": {"offset": [0.5, 0.0]}}
    mat = pygltflib.Material(
        pbrMetallicRoughness=PBR(
            roughnessFactor=0.5,
            metallicRoughnessTexture=pygltflib.TextureInfo(index=mr, extensions=moved),
        ),
        normalTexture=pygltflib.NormalMaterialTexture(index=n, scale=0.5),
    )
    b.quad(b.material(mat))
    (part,) = _parts(tmp_path, b)
    layer = part.layers[0]
    assert layer.normal_mapped
    assert layer.maps["metallic"].pixels[0, 0, 0] == pytest.approx(64 / 255)
    chain = layer.maps["normal_roughness"].pixels[0, 0]
    assert chain[3] == pytest.approx(0.5 * 128 / 255, abs=1e-6)
    raw = np.array([218, 128, 238]) / 255.0 * 2.0 - 1.0
    want = raw * [0.5, 0.5, 1.0]
    np.testing.assert_allclose(chain[:3], want / np.linalg.norm(want), atol=2e-3)
    assert layer.uv_transforms["metallic"] == UvTransform(offset=(0.5, 0.0))
    assert "normal_roughness" not in layer.uv_transforms
    assert layer.maps["metallic"].wrap == ("mirror", "repeat")
    assert layer.maps["normal_roughness"].wrap == ("clamp", "repeat")


def test_draco_round_trip(tmp_path: Path) -> None:
    """A Draco-compressed quad (DracoPy.encode) decodes to the same triangles."""
    b = GltfBuilder()
    b.draco_quad()
    (part,) = _parts(tmp_path, b)
    got = part.vertices[:, :3][part.indices.reshape(-1, 3)]
    want = QUAD_POSITIONS[QUAD_INDICES.reshape(-1, 3)]
    np.testing.assert_allclose(got, want, atol=1e-4)  # 16-bit quantisation
    uv = QUAD_UV.astype(np.float64)
    want_uv = np.stack([uv[:, 0], 1 - uv[:, 1]], 1)[QUAD_INDICES]
    np.testing.assert_allclose(part.vertices[:, 6:8][part.indices], want_uv, atol=1e-4)


def test_meshopt_round_trip(tmp_path: Path) -> None:
    """Vertex and index views compressed with meshoptimizer's own encoders decode back."""
    meshopt = pytest.importorskip("meshoptimizer", reason="the optional meshopt extra")
    b = GltfBuilder()
    b.quad(None)
    fallback = len(b.blob)
    for view_index, acc in ((0, 0), (3, 3)):  # POSITION (12-byte vertices), indices
        view = b.doc.bufferViews[view_index]
        raw = bytes(b.blob[view.byteOffset : view.byteOffset + view.byteLength])
        if acc == 0:
            packed = meshopt.encode_vertex_buffer(np.frombuffer(raw, np.float32).reshape(4, 3))
            ext = {"byteStride": 12, "count": 4, "mode": "ATTRIBUTES"}
        else:
            packed = meshopt.encode_index_buffer(
                np.frombuffer(raw, np.uint16).astype(np.uint32), 6, 4
            )
            ext = {"byteStride": 2, "count": 6, "mode": "TRIANGLES"}
        b.blob[view.byteOffset : view.byteOffset + view.byteLength] = b"\xee" * view.byteLength
        start = len(b.blob)
        b.blob += packed + b"\0" * (-len(packed) % 4)
        view.extensions = {
            "EXT_meshopt_compression": {
                "buffer": 0,
                "byteOffset": start,
                "byteLength": len(packed),
                **ext,
            }
        }
    assert len(b.blob) > fallback
    b.doc.extensionsUsed = b.doc.extensionsRequired = ["EXT_meshopt_compression"]
    (part,) = _parts(tmp_path, b)
    np.testing.assert_array_equal(part.vertices[:, :3], QUAD_POSITIONS)
    np.testing.assert_array_equal(part.indices, QUAD_INDICES)


def test_meshopt_without_the_package_names_the_extra(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import app.scene.gltf as gltf

    monkeypatch.setattr(gltf, "meshopt_available", lambda: False)
    b = GltfBuilder()
    b.quad(None)
    b.doc.bufferViews[0].extensions = {
        "EXT_meshopt_compression": {
            "buffer": 0,
            "byteLength": 4,
            "byteStride": 12,
            "count": 4,
            "mode": "ATTRIBUTES",
        }
    }
    with pytest.raises(
        InputError, match=r"EXT_meshopt_compression.*pip install 'pbs-lab\[meshopt\]'"
    ):
        _parts(tmp_path, b)


@pytest.mark.parametrize(
    ("damage", "fragment"),
    [
        (lambda d: setattr(d.accessors[0], "count", 5), "NORMAL: 4 elements, POSITION has 5"),
        (lambda d: setattr(d.bufferViews[0], "byteLength", 10**6), "bufferViews[0]: bytes"),
        (lambda d: setattr(d.meshes[0].primitives[0], "material", 3), "material: 3 is not one"),
        (lambda d: setattr(d.accessors[0], "type", "VEC2"), "cannot be POSITION"),
        (lambda d: setattr(d.accessors[-1], "count", 7), "accessors[3]: 7 elements"),
    ],
    ids=["count", "view-past-buffer", "material", "type", "index-count"],
)
def test_damage_is_one_input_error(tmp_path: Path, damage, fragment: str) -> None:
    b = GltfBuilder()
    b.quad(None)
    damage(b.doc)
    with pytest.raises(InputError, match=r"objects\[0\]\.file: .*m\.glb: ") as err:
        _parts(tmp_path, b)
    assert fragment in str(err.value)


def test_index_past_vertices_and_nan_positions(tmp_path: Path) -> None:
    b = GltfBuilder()
    b.quad(None)
    start = b.doc.bufferViews[3].byteOffset
    b.blob[start : start + 2] = np.uint16(9).tobytes()
    with pytest.raises(InputError, match="an index is not below the 4 vertices"):
        _parts(tmp_path, b)
    b = GltfBuilder()
    b.quad(None)
    b.blob[0:4] = np.float32(np.nan).tobytes()
    with pytest.raises(InputError, match="POSITION holds NaN"):
        _parts(tmp_path, b, "n.gltf")


def test_gltf_file_with_data_uri_and_external_image(tmp_path: Path) -> None:
    b = GltfBuilder()
    tex = b.image(png_rgb((1, 2, 3)), "file", tmp_path)
    b.doc.textures.append(pygltflib.Texture(source=tex))
    b.quad(
        b.material(
            pygltflib.Material(
                pbrMetallicRoughness=PBR(baseColorTexture=pygltflib.TextureInfo(index=0))
            )
        )
    )
    b.save(tmp_path / "d.gltf", buffer="data")
    prims = GltfFile(tmp_path / "d.gltf").primitives()
    assert len(prims) == 1
    layer = GltfFile(tmp_path / "d.gltf").layer(0, load_scene_default(), "naive")
    np.testing.assert_array_equal(layer.maps["base_color"].pixels[0, 0], [1, 2, 3, 255])
    (tmp_path / "image0.png").unlink()
    with pytest.raises(GltfError, match=r"images\[0\]\.uri"):
        GltfFile(tmp_path / "d.gltf").layer(0, load_scene_default(), "naive")


def load_scene_default():
    from app.scene.geometry import _DEFAULT_MATERIAL

    return _DEFAULT_MATERIAL


TILT = math.radians(30.0)
S, C = math.sin(TILT), math.cos(TILT)


@pytest.mark.parametrize(
    ("mirrored", "w", "texel", "world"),
    [
        (False, None, (S, 0.0, C), (S, 0.0, C)),
        (True, None, (S, 0.0, C), (-S, 0.0, C)),
        (False, None, (0.0, S, C), (0.0, S, C)),
        (False, 1.0, (0.0, S, C), (0.0, S, C)),
        (False, -1.0, (0.0, S, C), (0.0, -S, C)),
    ],
    ids=["derived-u", "derived-u-mirrored", "derived-v", "file-tangent-v", "file-tangent-w-1"],
)
def test_normal_map_tilts_the_gbuffer_normal(
    gl_egl: GLContext,
    tmp_path: Path,
    mirrored: bool,
    w: float | None,
    texel: tuple,
    world: tuple,
) -> None:
    """A constant normal map tilted 30 degrees towards +u (the quad's +x; in a mirrored
    node -x) or +v (glTF: up the image, the quad's +y) tilts the rendered G-buffer normal
    the same way: with tangents derived by the project (``w`` None) or the file's TANGENT
    (+x, ``w`` its handedness: the bitangent is w (n x t), so w = -1 turns +v to -y)."""
    rgb = np.round((np.array(texel) * 0.5 + 0.5) * 255)
    b = GltfBuilder()
    n = b.texture(png_rgb(tuple(int(c) for c in rgb)))
    base = b.texture(png_rgb((255, 255, 255)))
    mat = pygltflib.Material(
        pbrMetallicRoughness=PBR(
            baseColorTexture=pygltflib.TextureInfo(index=base), metallicFactor=0.0
        ),
        normalTexture=pygltflib.NormalMaterialTexture(index=n),
    )
    tangents = None if w is None else np.tile(np.float32([1, 0, 0, w]), (4, 1))
    b.quad(b.material(mat), tangents=tangents, scale=[-1.0, 1.0, 1.0] if mirrored else None)
    b.save(tmp_path / "n.glb")
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE.format(file="n.glb"), encoding="utf-8")
    r = Renderer(gl_egl, load_scene(scene), (32, 32))
    try:
        r.render()
        g = r.read_gbuffer()
    finally:
        r.release()
    assert g.depth[16, 16] > 0.0, "the quad (single-sided) was culled"
    got = oct_decode(g.normal[16, 16, :2].astype(np.float64))
    want = np.array(world)
    assert np.degrees(np.arccos(np.clip(got @ want, -1, 1))) < 0.5, (got, want)


def test_an_extension_without_a_model_is_one_note_and_renders(tmp_path: Path) -> None:
    """A material with KHR_materials_diffuse_transmission (no model here) and a volume's
    thickness texture (the volume mapped, that texture not): `pbs render` writes the image,
    exits 0 and says each on one line of stderr naming the glTF file, nothing else."""
    import subprocess
    import sys

    b = GltfBuilder()
    tex = b.texture(png_rgb((200, 100, 50)))
    ext = {
        "KHR_materials_diffuse_transmission": {"diffuseTransmissionFactor": 0.5},
        "KHR_materials_volume": {
            "thicknessFactor": 0.1,
            "thicknessTexture": {"index": tex},
        },
    }
    b.quad(b.material(pygltflib.Material(extensions=ext)))
    b.save(tmp_path / "m.glb")
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE.format(file="m.glb"), encoding="utf-8")
    out = tmp_path / "o.png"
    cmd = [sys.executable, "-m", "app", "render", str(scene), "-o", str(out), "--size", "16x16"]
    result = subprocess.run(cmd, capture_output=True, text=True, timeout=120, check=False)
    if result.returncode == 1 and "no headless OpenGL" in result.stderr:
        pytest.skip("no headless OpenGL context here")
    assert result.returncode == 0, result.stderr
    assert out.is_file()
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 2, result.stderr
    assert all(str(tmp_path / "m.glb") in line for line in lines)
    assert any("KHR_materials_diffuse_transmission" in line for line in lines)
    assert any("thicknessTexture" in line for line in lines)
