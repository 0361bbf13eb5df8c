"""glTF file -> real Renderer -> image and G-buffer.

Each test writes a glTF file through pygltflib (tests/gltf_builder.py), loads it as a
scene's mesh object and renders it with the real GLSL on EGL, then checks one feature of
the file in the G-buffer or the HDR image: emission, occlusion, alpha mask, texture
transforms, TEXCOORD_1, samplers, COLOR_0, doubleSided, the KHR_materials_* extensions'
material table rows and coat normal, Draco. (tests/test_material_core.py checks the same
renderer features from TOML keys; tests/test_gltf_reader.py what the reader builds and the
normal map's tilt.)

The view: the test quad (2 m x 2 m facing +Z, glTF UV (0, 0) at its top left) seen from
1 m in front with a 90-degree field of view fills the image exactly, so pixel (row i,
column j) of an N x N image reads glTF UV ((j + 0.5) / N, (i + 0.5) / N).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pygltflib
import pytest

from app.common.gbuffer import GBufferData
from app.common.models import MaterialParams
from app.gl.context import GLContext
from app.reference.encoding import oct_decode
from app.render.renderer import Renderer
from app.scene.gltf_extensions import map_material_extensions
from app.scene.loader import load_scene
from app.scene.model import Environment, Light
from tests.gltf_builder import GltfBuilder, png_rgb

N = 32  # image size (pixels); the quad fills it
PBR = pygltflib.PbrMetallicRoughness
NEAREST, LINEAR = 9728, 9729
REPEAT, CLAMP, MIRROR = 10497, 33071, 33648
EXTRA_NODE_X = 1.0  # where two-quad files put their quads: x = -1 and +1

SCENE = """\
[camera]
position = {position}
target = [0.0, 0.0, 0.0]
fov_y = {fov}

[[objects]]
shape = "mesh"
file = "m.glb"
"""


def renderer(
    gl: GLContext, tmp_path: Path, b: GltfBuilder, position=(0.0, 0.0, 1.0), fov: float = 90.0
) -> Renderer:
    """A Renderer of a scene holding ``b``'s file (no lights: tests set them)."""
    b.save(tmp_path / "m.glb")
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE.format(position=list(position), fov=fov), encoding="utf-8")
    return Renderer(gl, load_scene(scene), (N, N))


def frame(r: Renderer) -> tuple[np.ndarray, GBufferData]:
    r.render()
    return r.read_hdr().astype(np.float64), r.read_gbuffer()


def render_once(gl: GLContext, tmp_path: Path, b: GltfBuilder, **view: object):
    """(HDR image, G-buffer) of one frame of ``b``'s file (``view``: ``renderer``'s)."""
    r = renderer(gl, tmp_path, b, **view)
    try:
        return frame(r)
    finally:
        r.release()


def white_base() -> PBR:
    return PBR(baseColorFactor=[0.8, 0.8, 0.8, 1.0], metallicFactor=0.0, roughnessFactor=0.5)


def pair(b: GltfBuilder, left: int, right: int) -> None:
    """Two quads side by side (x = -1 and +1), seen whole from 2 m away: pixel column j of
    the left one mirrors column N - 1 - j of the right one in a scene symmetric about the
    YZ plane (lights on the axis), so their shading is the same there."""
    b.quad(left, translation=[-EXTRA_NODE_X, 0.0, 0.0])
    b.quad(right, translation=[EXTRA_NODE_X, 0.0, 0.0])


def mirrored(image: np.ndarray) -> np.ndarray:
    return image[:, ::-1]


ON_AXIS = Light(type="point", position=[0.0, 0.0, 1.5], intensity=2.0, range=10.0)
AXIS_SUN = Light(type="directional", direction=[0.2, 0.1, -1.0], intensity=1.5)


def test_emissive_factor_times_strength_adds_exactly_its_radiance(gl_egl, tmp_path):
    """emissiveFactor x KHR_materials_emissive_strength is added once per pixel: unlit, the
    image is the emission; lit by a light on the axis, the emitting quad minus its
    non-emitting mirror twin is the emission. Fails with the strength ignored (factor
    only) or the emission multiplied by the light."""
    b = GltfBuilder()
    plain = b.material(pygltflib.Material(pbrMetallicRoughness=white_base()))
    glow = b.material(
        pygltflib.Material(
            pbrMetallicRoughness=white_base(),
            emissiveFactor=[0.5, 0.25, 1.0],
            extensions={"KHR_materials_emissive_strength": {"emissiveStrength": 3.0}},
        )
    )
    pair(b, plain, glow)
    emission = np.array([1.5, 0.75, 3.0])
    r = renderer(gl_egl, tmp_path, b, position=(0.0, 0.0, 2.0))
    try:
        unlit, g = frame(r)
        r.set_lights([ON_AXIS])
        lit, _ = frame(r)
    finally:
        r.release()
    covered = g.covered
    right = covered.copy()
    right[:, : N // 2] = False
    left = covered & ~right
    assert right.sum() > 100 and np.array_equal(left, mirrored(right))
    np.testing.assert_array_equal(unlit[right], np.broadcast_to(emission, (right.sum(), 3)))
    np.testing.assert_array_equal(unlit[left], 0.0)
    np.testing.assert_array_equal(
        g.emission[right][:, :3], np.broadcast_to(emission, (right.sum(), 3))
    )
    diff = (lit - mirrored(lit))[right]
    assert mirrored(lit)[right].min() > 0.01  # the light reaches the plain quad
    np.testing.assert_allclose(diff, np.broadcast_to(emission, diff.shape), atol=1e-5)


def test_emissive_texture_multiplies_the_factor(gl_egl, tmp_path):
    """emissiveTexture is sRGB: a texel of (188, 255, 0) emits factor x strength x
    decode(texel)."""
    b = GltfBuilder()
    tex = b.texture(png_rgb((188, 255, 0)))
    mat = pygltflib.Material(
        pbrMetallicRoughness=white_base(),
        emissiveFactor=[0.5, 0.25, 1.0],
        emissiveTexture=pygltflib.TextureInfo(index=tex),
        extensions={"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}},
    )
    b.quad(b.material(mat))
    hdr, g = render_once(gl_egl, tmp_path, b)
    c = 188 / 255
    decoded = ((c + 0.055) / 1.055) ** 2.4  # the sRGB transfer function (IEC 61966-2-1)
    assert g.covered.all()
    np.testing.assert_allclose(hdr[..., 0], 2.0 * decoded, atol=2e-3)  # GL's 8-bit decode
    np.testing.assert_allclose(hdr[..., 1], 1.0, atol=1e-6)
    np.testing.assert_array_equal(hdr[..., 2], 0.0)


def test_occlusion_texture_darkens_only_the_environment(gl_egl, tmp_path):
    """occlusionTexture (R = 0) with strength 0.75: factor 1 + 0.75 (0 - 1) = 0.25 on the
    environment's light; a point and a directional light's part is unchanged (the tiled
    lighting loop meets the directional light beside the environment's directions). The
    quad with and without the occlusion texture (two Renderers: the environment's
    lattice of directions is not mirror-symmetric, so a mirror twin differs by 0.3 %),
    each under the environment alone, the two lights alone and all of them. Fails with
    occlusion applied to every light (OCCLUSION(i) = ao in lighting.frag) or with the
    strength ignored (factor 0)."""
    sky = Environment(radiance=[0.5, 0.5, 0.5], samples=64)
    images = []
    for occluded in (False, True):
        b = GltfBuilder()
        mat = pygltflib.Material(pbrMetallicRoughness=white_base())
        if occluded:
            ao = b.texture(png_rgb((0, 0, 0)))
            mat.occlusionTexture = pygltflib.OcclusionTextureInfo(index=ao, strength=0.75)
        b.quad(b.material(mat))
        r = renderer(gl_egl, tmp_path, b)
        try:
            r.set_lights([], sky)
            env, g = frame(r)
            r.set_lights([ON_AXIS, AXIS_SUN], None)
            direct, _ = frame(r)
            r.set_lights([ON_AXIS, AXIS_SUN], sky)
            both, _ = frame(r)
        finally:
            r.release()
        assert g.covered.all()
        images.append((env, direct, both, g))
    (env, direct, _, _), (env_ao, direct_ao, both_ao, g) = images
    np.testing.assert_array_equal(g.emission[..., 3], 0.25)
    assert env.min() > 0.0 and direct.min() > 0.0
    np.testing.assert_allclose(env_ao, 0.25 * env, rtol=1e-6)
    np.testing.assert_array_equal(direct_ao, direct)
    np.testing.assert_allclose(both_ao, 0.25 * env + direct, rtol=1e-5)


def alpha_ramp() -> np.ndarray:
    """N 8-bit alphas rising along u, one texel per pixel column (texel centres are pixel
    centres, so bilinear filtering returns each texel exactly)."""
    return np.round(np.linspace(0.0, 1.0, N) * 255.0).astype(np.uint8)


@pytest.mark.parametrize(("factor", "cutoff"), [(1.0, 0.5), (0.6, 0.3), (0.6, 0.45)])
def test_mask_cuts_at_the_cutoff(gl_egl, tmp_path, factor, cutoff):
    """alphaMode MASK: a pixel is drawn exactly where baseColorFactor's A x the base colour
    texture's A reaches alphaCutoff; a ramp of alphas along u puts the cut at a known
    column (the factor moves it). Fails with the factor's A or the texture's A ignored, or
    the cutoff left at its default 0.5."""
    a = alpha_ramp()
    rgba = np.dstack([np.full((N, N), 255, np.uint8)] * 3 + [np.broadcast_to(a, (N, N))])
    b = GltfBuilder()
    tex = b.texture(png_rgb(rgba), sampler={"magFilter": NEAREST, "minFilter": NEAREST})
    base = PBR(baseColorTexture=pygltflib.TextureInfo(index=tex), baseColorFactor=[1, 1, 1, factor])
    mat = pygltflib.Material(pbrMetallicRoughness=base, alphaMode="MASK", alphaCutoff=cutoff)
    b.quad(b.material(mat))
    _, g = render_once(gl_egl, tmp_path, b)
    coverage = factor * a / 255.0
    assert np.abs(coverage - cutoff).min() > 1e-3  # no column sits on the cut
    expected = np.broadcast_to(coverage >= cutoff, (N, N))
    assert 0 < expected.sum() < N * N
    np.testing.assert_array_equal(g.covered, expected)


def id_texture() -> np.ndarray:
    """A 4 x 4 texture whose texel (row r, column c) has B = 16 (4 r + c) + 8: a
    metallicRoughnessTexture read back from the G-buffer's metallic says which texel each
    pixel sampled (B is metallic, linear)."""
    k = np.arange(16).reshape(4, 4)
    rgb = np.zeros((4, 4, 3), np.uint8)
    rgb[..., 1] = 128
    rgb[..., 2] = 16 * k + 8
    return rgb


def texel_ids(g: GBufferData) -> np.ndarray:
    """(N, N) texel index (4 row + column) each pixel read from ``id_texture``."""
    return np.round((g.base_color[..., 3] * 255.0 - 8.0) / 16.0).astype(int)


def spec_matrix(offset=(0.0, 0.0), rotation: float = 0.0, scale=(1.0, 1.0)) -> np.ndarray:
    """KHR_texture_transform's T R S in glTF's UV space (v down the image), from the
    specification's worked example: offset [0, 1], rotation pi/2 and scale 0.5 must read
    "only the lower left quadrant of the source image, rotated clockwise 90 degrees"
    (KhronosGroup/glTF, extensions/2.0/Khronos/KHR_texture_transform/README.md). That
    fixes R = [[cos, sin], [-sin, cos]] by rows, the rotation Blender, Babylon.js and the
    sample model TextureTransformTest use; the README's GLSL listing read column-major is
    its transpose, which reads the top right quadrant instead."""
    c, s = math.cos(rotation), math.sin(rotation)
    t = np.array([[1.0, 0.0, offset[0]], [0.0, 1.0, offset[1]], [0.0, 0.0, 1.0]])
    rot = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    return t @ rot @ np.diag([scale[0], scale[1], 1.0])


def wrapped(x: np.ndarray, mode: int) -> np.ndarray:
    """A coordinate after the sampler's wrap (glTF 2.0 samplers, OpenGL's definitions)."""
    if mode == REPEAT:
        return x - np.floor(x)
    if mode == MIRROR:
        t = x - 2.0 * np.floor(x / 2.0)
        return np.where(t < 1.0, t, 2.0 - t)
    return np.clip(x, 0.0, 1.0 - 1e-9)


def expected_ids(
    matrix: np.ndarray, wrap=(REPEAT, REPEAT), uv: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """(texel index each pixel should read with nearest filtering, pixels whose
    transformed UV is at least 0.05 texel from a texel edge)."""
    if uv is None:
        centres = (np.arange(N) + 0.5) / N
        uv = np.stack(np.meshgrid(centres, centres), axis=-1)  # (i, j) -> (u_j, v_i)
    moved = np.einsum("ab,ijb->ija", matrix, np.dstack([uv, np.ones((N, N))]))[..., :2]
    texels, clear = [], np.ones((N, N), bool)
    for axis in (0, 1):
        x = moved[..., axis]
        w = wrapped(x, wrap[axis]) * 4.0
        near = np.abs(w - np.round(w)) <= 0.05
        if wrap[axis] == CLAMP:  # outside [0, 1] the edge texel is read, unambiguously
            near &= (x > 0.0) & (x < 1.0)
        clear &= ~near
        texels.append(np.clip(np.floor(w), 0, 3).astype(int))
    return 4 * texels[1] + texels[0], clear


TRANSFORMS = {
    "offset": {"offset": [0.25, -0.5]},
    "scale": {"scale": [2.0, 0.5]},
    "quarter_turn": {"rotation": math.pi / 2},
    "small_angle": {"rotation": 0.2},
    "spec_example": {"offset": [0.0, 1.0], "rotation": math.pi / 2, "scale": [0.5, 0.5]},
    "all_anisotropic": {"offset": [0.1, 0.3], "rotation": 0.5, "scale": [1.5, 0.75]},
}


def id_quad(tmp_path, gl, info: dict, sampler: dict | None = None, **quad) -> GBufferData:
    """The quad with ``id_texture`` as its metallicRoughnessTexture (textureInfo fields
    ``info``), nearest filtering unless ``sampler`` says otherwise; its G-buffer."""
    b = GltfBuilder()
    s = {"magFilter": NEAREST, "minFilter": NEAREST} | (sampler or {})
    tex = b.texture(png_rgb(id_texture()), sampler=s)
    pbr = PBR(metallicRoughnessTexture=pygltflib.TextureInfo(index=tex, **info))
    b.quad(b.material(pygltflib.Material(pbrMetallicRoughness=pbr)), **quad)
    if "extensions" in info:
        b.doc.extensionsUsed = ["KHR_texture_transform"]
    _, g = render_once(gl, tmp_path, b)
    assert g.covered.all()
    return g


@pytest.mark.parametrize("name", list(TRANSFORMS))
def test_texture_transform_moves_the_texture(gl_egl, tmp_path, name):
    """KHR_texture_transform offset, scale and rotation: each pixel reads the texel the
    specification's T R S puts under it (nearest filtering, REPEAT). The quarter turn and
    0.2 rad fail with the rotation's sign flipped (the README listing's transpose);
    offset and scale fail with v measured up the image instead of down."""
    ext = TRANSFORMS[name]
    g = id_quad(tmp_path, gl_egl, {"extensions": {"KHR_texture_transform": ext}})
    want, clear = expected_ids(spec_matrix(**ext))
    assert clear.mean() > 0.7
    np.testing.assert_array_equal(texel_ids(g)[clear], want[clear])
    if name == "spec_example":  # the README's words: the lower left quadrant only
        ids = texel_ids(g)
        assert set(np.unique(ids)) == {8, 9, 12, 13}


def test_texcoord1_reads_the_second_uv_set(gl_egl, tmp_path):
    """textureInfo.texCoord 1 reads TEXCOORD_1 (here the first set mirrored left to right),
    and the transform's texCoord overrides it back to 0."""
    uv1 = np.array([[1, 1], [0, 1], [0, 0], [1, 0]], np.float32)
    g = id_quad(tmp_path, gl_egl, {"texCoord": 1}, uv1=uv1)
    want, clear = expected_ids(np.array([[-1.0, 0.0, 1.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]))
    np.testing.assert_array_equal(texel_ids(g)[clear], want[clear])
    override = {"texCoord": 1, "extensions": {"KHR_texture_transform": {"texCoord": 0}}}
    g = id_quad(tmp_path, gl_egl, override, uv1=uv1)
    want, clear = expected_ids(np.eye(3))
    np.testing.assert_array_equal(texel_ids(g)[clear], want[clear])


@pytest.mark.parametrize(
    ("wrap_s", "wrap_t"), [(REPEAT, REPEAT), (CLAMP, CLAMP), (MIRROR, MIRROR), (MIRROR, CLAMP)]
)
def test_sampler_wrap_modes(gl_egl, tmp_path, wrap_s, wrap_t):
    """Sampler wrapS/wrapT with a scale of 2 (UV over [0, 2]): REPEAT shows the texture
    twice, CLAMP_TO_EDGE its last texels over the second half, MIRRORED_REPEAT it
    mirrored; per axis."""
    scale = {"extensions": {"KHR_texture_transform": {"scale": [2.0, 2.0]}}}
    g = id_quad(tmp_path, gl_egl, scale, sampler={"wrapS": wrap_s, "wrapT": wrap_t})
    want, clear = expected_ids(spec_matrix(scale=(2.0, 2.0)), (wrap_s, wrap_t))
    np.testing.assert_array_equal(texel_ids(g)[clear], want[clear])


def test_linear_filter_blends_where_nearest_does_not(gl_egl, tmp_path):
    """magFilter LINEAR reads blends of neighbouring texels between their centres (values
    that are no texel's), NEAREST only texel values."""
    ids = id_texture()[..., 2].astype(np.float64)
    linear = id_quad(tmp_path, gl_egl, {}, sampler={"magFilter": LINEAR, "minFilter": LINEAR})
    values = linear.base_color[..., 3] * 255.0
    off_grid = np.abs(values[..., None] - ids.reshape(-1)).min(axis=-1) > 1.0
    assert off_grid.mean() > 0.5
    nearest = id_quad(tmp_path, gl_egl, {})
    values = nearest.base_color[..., 3] * 255.0
    # within the G-buffer's storage rounding of metallic (0.04 of 255 measured)
    assert (np.abs(values[..., None] - ids.reshape(-1)).min(axis=-1) < 0.25).all()


def test_color_0_multiplies_base_color_and_alpha(gl_egl, tmp_path):
    """COLOR_0 (unsigned-byte normalised, RGBA) multiplies baseColorFactor, its A the
    coverage: with A 0.4 and MASK at 0.5 nothing is drawn (checked on an RGB copy)."""
    colors = np.tile(np.array([128, 64, 255, 102], np.uint8), (4, 1))
    base = PBR(baseColorFactor=[0.8, 0.6, 0.4, 1.0], metallicFactor=0.0)
    b = GltfBuilder()
    b.quad(b.material(pygltflib.Material(pbrMetallicRoughness=base)), colors=colors)
    _, g = render_once(gl_egl, tmp_path, b)
    want = np.array([0.8, 0.6, 0.4]) * colors[0, :3] / 255.0
    np.testing.assert_allclose(g.base_color[..., :3], np.broadcast_to(want, (N, N, 3)), rtol=1e-6)
    mask = pygltflib.Material(pbrMetallicRoughness=base, alphaMode="MASK", alphaCutoff=0.5)
    b = GltfBuilder()
    b.quad(b.material(mask), colors=colors)
    _, g = render_once(gl_egl, tmp_path, b)
    assert not g.covered.any()


@pytest.mark.parametrize("double_sided", [False, True])
def test_double_sided(gl_egl, tmp_path, double_sided):
    """Seen from behind, a single-sided quad is culled (background); a double-sided one is
    drawn with its normal flipped towards the camera (-Z)."""
    b = GltfBuilder()
    mat = pygltflib.Material(pbrMetallicRoughness=white_base(), doubleSided=double_sided)
    b.quad(b.material(mat))
    r = renderer(gl_egl, tmp_path, b, position=(0.0, 0.0, -1.0))
    try:
        r.set_lights([Light(type="point", position=[0, 0, -1.5], intensity=2.0)])
        hdr, g = frame(r)
    finally:
        r.release()
    if not double_sided:
        assert not g.covered.any()
        return
    assert g.covered.all()
    normals = oct_decode(g.normal[..., :2].reshape(-1, 2).astype(np.float64))
    np.testing.assert_allclose(normals, np.broadcast_to([0.0, 0.0, -1.0], normals.shape), atol=1e-3)
    assert hdr.min() > 0.01  # lit from the camera's side


def sphere(b: GltfBuilder, material: int, rings: int = 12, segments: int = 24) -> int:
    """A UV sphere of radius 0.8 (positions, normals, TEXCOORD_0) as a node."""
    from app.assets.material_sampler import uv_sphere

    positions, normals, uv, indices = uv_sphere(0.8, rings, segments)
    attrs = pygltflib.Attributes(
        POSITION=b.accessor(positions), NORMAL=b.accessor(normals), TEXCOORD_0=b.accessor(uv)
    )
    prim = pygltflib.Primitive(attributes=attrs, indices=b.accessor(indices), material=material)
    return b.node(mesh=b.mesh(prim))


EXTENSIONS = {
    "KHR_materials_ior": {"ior": 1.7},
    "KHR_materials_clearcoat": {"clearcoatFactor": 0.8, "clearcoatRoughnessFactor": 0.15},
    "KHR_materials_sheen": {"sheenColorFactor": [0.6, 0.3, 0.9], "sheenRoughnessFactor": 0.4},
    "KHR_materials_iridescence": {
        "iridescenceFactor": 1.0,
        "iridescenceIor": 1.4,
        "iridescenceThicknessMaximum": 420.0,
    },
}


@pytest.mark.parametrize("names", [("KHR_materials_ior",), tuple(EXTENSIONS)], ids=["ior", "all"])
def test_extension_parameters_reach_the_material_table(gl_egl, tmp_path, names):
    """A sphere whose material carries KHR_materials_* extensions: the material table row
    its pixels name is exactly (model, params) of map_material_extensions applied to the
    core values, its model group's lighting program is compiled with that model's
    defines (thin film, sheen, clear coat), and the G-buffer's F0 is the ior's
    ((1.7 - 1) / (1.7 + 1))^2. Fails with the reader keeping the core parameters instead
    of the mapped ones (``params = mapping.params`` removed in app/scene/gltf.py)."""
    ext = {n: EXTENSIONS[n] for n in names}
    b = GltfBuilder()
    base = PBR(baseColorFactor=[0.7, 0.5, 0.3, 1.0], metallicFactor=0.0, roughnessFactor=0.35)
    sphere(b, b.material(pygltflib.Material(pbrMetallicRoughness=base, extensions=ext)))
    b.doc.extensionsUsed = list(names)
    r = renderer(gl_egl, tmp_path, b, position=(0.0, 0.0, 3.0), fov=45.0)
    try:
        r.set_lights([ON_AXIS])
        hdr, g = frame(r)
        table = r.materials
        compiled = [dict(k[2]) for k in r.shaders._programs if k[1] == "passes/lighting.frag"]
    finally:
        r.release()
    core = MaterialParams(base_color=(0.7, 0.5, 0.3), metallic=0.0, roughness=0.35, f0=0.04)
    want = map_material_extensions(ext, core, "materials[0]")
    assert set(want.applied) == set(names) and not want.notes
    ids = np.unique(g.material_id[g.covered])
    assert len(ids) == 1 and g.covered.sum() > 200
    model, params = table.rows[int(ids[0])]
    assert model == want.params.model
    for f in dataclasses.fields(params):
        assert np.array_equal(getattr(params, f.name), getattr(want.params.params, f.name)), f.name
    assert table.models[table.groups[int(ids[0])]] == model
    np.testing.assert_allclose(g.normal[g.covered][:, 3], ((1.7 - 1) / (1.7 + 1)) ** 2, rtol=1e-6)
    defines = model.defines()
    assert any(defines.items() <= d.items() for d in compiled)  # the group's program
    if len(names) > 1:
        assert defines["THIN_FILM"] == 1
        assert defines["SHEEN_MODEL"] != 0 and defines["CLEARCOAT_MODEL"] != 0
        assert params.clearcoat == 0.8 and params.clearcoat_roughness == 0.15
        np.testing.assert_array_equal(params.sheen_color, [0.6, 0.3, 0.9])
    assert np.isfinite(hdr).all() and hdr[g.covered].max() > 0.0


def test_clearcoat_normal_texture_reaches_the_coat_normal(gl_egl, tmp_path):
    """clearcoatNormalTexture becomes the layer's maps["coat_normal"] and tilts the
    G-buffer's coat normal (RT4) as the file says (30 degrees towards +u = +x), while the
    base normal stays flat."""
    tilt = math.radians(30.0)
    texel = np.array([math.sin(tilt), 0.0, math.cos(tilt)])
    rgb = tuple(int(c) for c in np.round((texel * 0.5 + 0.5) * 255))
    b = GltfBuilder()
    n = b.texture(png_rgb(rgb))
    coat = {"clearcoatFactor": 1.0, "clearcoatNormalTexture": {"index": n}}
    mat = pygltflib.Material(
        pbrMetallicRoughness=white_base(), extensions={"KHR_materials_clearcoat": coat}
    )
    b.quad(b.material(mat))
    b.doc.extensionsUsed = ["KHR_materials_clearcoat"]
    r = renderer(gl_egl, tmp_path, b)
    try:
        assert "coat_normal" in r.frame.parts[0].layers[0].maps
        _, g = frame(r)
    finally:
        r.release()
    assert g.coat_normal is not None
    coat_n = oct_decode(g.coat_normal[N // 2, N // 2].astype(np.float64))
    base_n = oct_decode(g.normal[N // 2, N // 2, :2].astype(np.float64))
    assert np.degrees(np.arccos(np.clip(coat_n @ texel, -1, 1))) < 0.5, coat_n
    np.testing.assert_allclose(base_n, [0.0, 0.0, 1.0], atol=1e-3)


def test_draco_file_renders_as_the_uncompressed_one(gl_egl, tmp_path):
    """A KHR_draco_mesh_compression quad (16-bit positions and UVs) beside the same quad
    uncompressed (2 m apart), both with the id texture as metallic-roughness, lit by a
    directional light: the camera filling its view with one quad and then moved 2 m to
    the other sees the same HDR image and G-buffer (a directional light shades alike
    under a translation). Fails with the Draco stream's UVs flipped, or its positions
    dropped (background only)."""
    pytest.importorskip("DracoPy")
    from app.scene.model import Camera

    b = GltfBuilder()
    tex = b.texture(png_rgb(id_texture()), sampler={"magFilter": NEAREST, "minFilter": NEAREST})
    pbr = PBR(metallicRoughnessTexture=pygltflib.TextureInfo(index=tex))
    mat = b.material(pygltflib.Material(pbrMetallicRoughness=pbr))
    b.draco_quad()
    b.doc.meshes[-1].primitives[0].material = mat
    b.doc.nodes[-1].translation = [-EXTRA_NODE_X, 0.0, 0.0]
    b.quad(mat, normals=False, translation=[EXTRA_NODE_X, 0.0, 0.0])
    r = renderer(gl_egl, tmp_path, b)
    images = []
    try:
        r.set_lights([AXIS_SUN])
        for x in (-EXTRA_NODE_X, EXTRA_NODE_X):
            r.set_camera(Camera(position=[x, 0.0, 1.0], target=[x, 0.0, 0.0], fov_y=90.0))
            images.append(frame(r))
    finally:
        r.release()
    (draco, g_draco), (plain, g_plain) = images
    assert g_draco.covered.all() and g_plain.covered.all()
    assert len(np.unique(texel_ids(g_draco))) == 16
    np.testing.assert_array_equal(g_draco.base_color, g_plain.base_color)
    np.testing.assert_allclose(g_draco.normal, g_plain.normal, atol=1e-6)
    np.testing.assert_allclose(draco, plain, rtol=1e-5, atol=1e-7)
    assert plain.std() > 0.01  # the texture shows in the image
