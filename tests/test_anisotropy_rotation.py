"""The direction of anisotropy turned per material and per texel (glTF
KHR_materials_anisotropy's anisotropyRotation and anisotropyTexture RG; RTR4 §9.8), with
the real GLSL: the G-buffer pass writes the turned tangent (glsl/material/layers.glsl), so
the lighting pass needs nothing new.

The plane of tests/test_material_core.py is seen from above: normal +Y, tangent +X (+u),
and +v along -Z, which is n x t: the bitangent, towards which the rotation turns t.
At the end, the generated stand-in of Khronos' AnisotropyRotationTest (tests/assets/
anisotropy_rotation/): its turned spheres' highlights against its plain ones', and its
grooved sphere's highlight by normal filter.
"""

from __future__ import annotations

import io
import math
from pathlib import Path

import numpy as np
import pygltflib
import pytest
from PIL import Image

from app.gl.context import GLContext
from app.reference.encoding import oct_decode
from app.reference.normal_mapping import anisotropy_direction, rotate_tangent
from app.render.renderer import Renderer
from app.scene.gltf_extensions import map_material_extensions
from app.scene.loader import load_scene, parse_scene
from scripts.anisotropy_rotation_standin import (
    NODES,
    VIEW_SCALE,
    VIEW_SIZE,
    build,
    highlight_shape,
    node_centre,
    view_scene,
)
from tests.gltf_builder import GltfBuilder, png_rgb
from tests.test_gltf import SCENE

SIZE = (24, 24)
F32 = np.finfo(np.float32).eps


def plane(material: dict, shape: str = "plane") -> dict:
    """An anisotropic plane filling a 90-degree view from 1 m above (or a sphere, 1.5 m
    below the camera, inside it)."""
    height, size = (1.0, SIZE[0]) if shape == "plane" else (1.5, 48)
    obj = {"shape": "plane", "size": [2.2, 2.2]} if shape == "plane" else {
        "shape": "sphere", "radius": 0.6,
    }  # fmt: skip
    return {
        "camera": {"position": [0, height, 0], "target": [0, 0, 0], "up": [0, 0, -1], "fov_y": 90},
        "materials": {"m": {"roughness": 0.4, "anisotropy": 0.7, "metallic": 1.0, **material}},
        "objects": [{**obj, "material": "m"}],
        "lights": [
            {"type": "directional", "direction": [0.3, -1, 0.2], "intensity": 2.0},
            {"type": "point", "position": [-0.4, 1.2, 0.5], "intensity": 2.0, "range": 6.0},
        ],
        "render": {"width": size, "height": size, "gbuffer": "f32"},
    }


def render(gl: GLContext, data: dict, tmp_path: Path):
    """(HDR image, G-buffer) of a scene dict."""
    r = Renderer(gl, parse_scene(data, tmp_path / "inline.toml"))
    try:
        r.render()
        return r.read_hdr().astype(np.float64), r.read_gbuffer()
    finally:
        r.release()


def tangents(g) -> np.ndarray:
    """The G-buffer's unit tangents (H, W, 3), float64."""
    return oct_decode(g.tangent[..., :2].astype(np.float64))


def about(n: np.ndarray, t: np.ndarray, angle: float) -> np.ndarray:
    """t turned about the unit n by ``angle`` radians (Rodrigues), t perpendicular to n."""
    return math.cos(angle) * t + math.sin(angle) * np.cross(n, t)


def direction_png(tmp_path: Path, rg: tuple[int, int]) -> str:
    Image.fromarray(np.full((8, 8, 3), (*rg, 255), np.uint8)).save(tmp_path / "dir.png")
    return "dir.png"


@pytest.mark.parametrize(
    ("material", "key"),
    [({"anisotropy": 0.0, "anisotropy_rotation": 30.0}, "anisotropy_rotation"),
     ({"anisotropy": 0.0, "anisotropy_direction_map": "dir.png"}, "anisotropy_direction_map"),
     ({"anisotropy_rotation": 400.0}, "anisotropy_rotation")],
)  # fmt: skip
def test_keys_without_anisotropy_are_refused(tmp_path, material, key):
    """A turn of an isotropic lobe would silently do nothing: the keys need a non-zero
    anisotropy (and the angle lies within +-360 degrees)."""
    from app.errors import InputError

    direction_png(tmp_path, (218, 218))  # the map exists: only the missing anisotropy is wrong
    data = plane(material)
    data["materials"]["m"].update(material)
    with pytest.raises(InputError, match=f"{key}: (turns the anisotropy|Input should be)"):
        parse_scene(data, tmp_path / "inline.toml")


@pytest.mark.parametrize("degrees", [30.0, -115.0])
def test_rotation_turns_the_gbuffer_tangent_about_n(gl_egl, tmp_path, degrees):
    """anisotropy_rotation = 30 degrees: every G-buffer tangent is the unrotated one
    turned about the normal by 30 degrees towards the bitangent +v, to float32 precision;
    every other channel is unchanged bit for bit."""
    _, g0 = render(gl_egl, plane({}), tmp_path)
    _, g = render(gl_egl, plane({"anisotropy_rotation": degrees}), tmp_path)
    cov = g.covered
    assert cov.all()
    n = oct_decode(g0.normal[..., :2].astype(np.float64))
    t0 = tangents(g0)
    np.testing.assert_allclose(n[cov], np.broadcast_to([0, 1, 0], n[cov].shape), atol=1e-7)
    np.testing.assert_allclose(t0[cov], np.broadcast_to([1, 0, 0], t0[cov].shape), atol=1e-7)
    # +v runs along -Z = n x t: the bitangent the rotation turns towards
    want = about(n, t0, math.radians(degrees))
    err = np.linalg.norm(tangents(g) - want, axis=-1)[cov]
    assert err.max() <= 8 * F32, err.max()
    assert np.array_equal(g.tangent[..., 2], g0.tangent[..., 2])  # anisotropy
    assert np.array_equal(g.normal, g0.normal) and np.array_equal(g.base_color, g0.base_color)


@pytest.mark.parametrize(
    ("rg", "degrees", "rotation"),
    [((218, 218), 45.0, 0.0), ((37, 218), 135.0, 0.0), ((218, 37), -45.0, 0.0),
     ((218, 218), 75.0, 30.0)],
)  # fmt: skip
def test_direction_map_is_the_same_as_the_rotation(gl_egl, tmp_path, rg, degrees, rotation):
    """A direction map of constant (cos t, sin t) (8-bit RG, decoded 2 rg - 1) gives the
    G-buffer of anisotropy_rotation = t, to float32 precision; with a rotation as well
    the two angles add (the rotation turns the map's direction). The angles are those
    an 8-bit texel holds exactly: (218, 218) decodes to (0.7098, 0.7098), 45 degrees
    once renormalised (2 rg - 1 is never 0, so no texel points exactly along t or b)."""
    tex = direction_png(tmp_path, rg)
    _, g_map = render(
        gl_egl, plane({"anisotropy_direction_map": tex, "anisotropy_rotation": rotation}),
        tmp_path,
    )  # fmt: skip
    _, g_rot = render(gl_egl, plane({"anisotropy_rotation": degrees}), tmp_path)
    cov = g_map.covered
    assert cov.all()
    err = np.linalg.norm(tangents(g_map) - tangents(g_rot), axis=-1)[cov]
    assert err.max() <= 8 * F32, err.max()
    # ... and both are turned: +X about +Y towards +v (-Z) by the angle
    want = about(np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0]), math.radians(degrees))
    assert np.linalg.norm(tangents(g_map) - want, axis=-1)[cov].max() <= 8 * F32
    for name in ("normal", "base_color", "depth"):
        assert np.array_equal(getattr(g_map, name), getattr(g_rot, name)), name


@pytest.mark.parametrize("mode", ["runtime", "baked"])
def test_blend_keeps_the_base_direction(gl_egl, tmp_path, mode):
    """A mask blend (RTR4 §9.13) has one tangent per pixel: the base material's rotation
    and direction map turn it wherever the mask paints the top layer on, whether the
    layers mix per pixel or are baked into one (app/textures/bake.py carries both)."""
    mask = tmp_path / "mask.png"
    Image.fromarray(np.tile(np.uint8([0, 255]), (8, 4))).save(mask)  # stripes of both
    data = plane({"anisotropy_rotation": 30.0, "anisotropy_direction_map": direction_png(
        tmp_path, (218, 218)), "blend": {"material": "top", "mask": "mask.png"}})  # fmt: skip
    data["materials"]["top"] = {"roughness": 0.2, "anisotropy": -0.5, "metallic": 1.0}
    data["render"]["blend"] = mode
    _, g = render(gl_egl, data, tmp_path)
    cov = g.covered
    assert cov.all() and np.ptp(g.tangent[..., 2][cov]) > 0.5  # both layers are on screen
    want = about(np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0]), math.radians(75.0))
    assert np.linalg.norm(tangents(g) - want, axis=-1)[cov].max() <= 8 * F32


def test_quarter_turn_is_the_opposite_anisotropy(gl_egl, tmp_path):
    """The project's anisotropic GGX (Burley 2012) has alpha_x = alpha (1 + a) along t and
    alpha_y = alpha (1 - a) along b, and its D and Smith Lambda read (h.t)^2 and (h.b)^2
    only. Turning t by 90 degrees makes t' = b and b' = n x b = -t, so the widths swap,
    which is what a -> -a does: the sphere's highlights agree to float32 rounding (the
    turned tangent carries cos(pi/2) = 6e-17 and one rounding per component)."""
    turned, g = render(gl_egl, plane({"anisotropy_rotation": 90.0}, "sphere"), tmp_path)
    opposite, _ = render(gl_egl, plane({"anisotropy": -0.7}, "sphere"), tmp_path)
    straight, _ = render(gl_egl, plane({}, "sphere"), tmp_path)
    cov = g.covered
    assert 100 < cov.sum() < cov.size  # the sphere, with background around it
    peak = opposite[cov].max()
    diff = np.abs(turned - opposite)[cov]
    assert diff.max() <= 1e-5 * peak, diff.max() / peak
    # ... and the comparison can fail: the unrotated highlight differs
    assert np.abs(straight - opposite)[cov].max() > 0.05 * peak


def test_twins_match_the_gbuffer(gl_egl, tmp_path):
    """The float64 twins (app/reference/normal_mapping.py rotate_tangent and
    anisotropy_direction) of the GLSL functions, on the plane's frame (n = +Y, t = +X,
    w = +1): a direction map texel off the 45-degree diagonal, (200, 90) -> (0.569,
    -0.294) (stored as float16), turned by 20 degrees."""
    tex = direction_png(tmp_path, (200, 90))
    _, g = render(
        gl_egl, plane({"anisotropy_direction_map": tex, "anisotropy_rotation": 20.0}),
        tmp_path,
    )  # fmt: skip
    texel = np.float16(2.0 * np.array([200.0, 90.0]) / 255.0 - 1.0).astype(np.float64)
    d = anisotropy_direction(texel)
    a = math.radians(20.0)
    d = np.array([math.cos(a) * d[0] - math.sin(a) * d[1], math.sin(a) * d[0] + math.cos(a) * d[1]])
    want = rotate_tangent(np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0]), 1.0, d)
    err = np.linalg.norm(tangents(g) - want, axis=-1)[g.covered]
    assert err.max() <= 8 * F32, err.max()
    assert anisotropy_direction(np.zeros(2)).tolist() == [1.0, 0.0]  # length 0: along t


def test_forward_pass_turns_the_tangent_too(gl_egl, tmp_path):
    """The bench's forward pass shares layers.glsl: its image of the rotated sphere is the
    deferred one (to float32 rounding through the f32 G-buffer), and not the unrotated."""
    from app.bench.forward import ForwardRenderer

    def images(material: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        loaded = parse_scene(plane(material, "sphere"), tmp_path / "inline.toml")
        deferred, forward = Renderer(gl_egl, loaded), ForwardRenderer(gl_egl, loaded, (48, 48))
        try:
            deferred.render()
            forward.render()
            covered = deferred.read_gbuffer().covered
            return deferred.read_hdr().astype(np.float64), forward.read_hdr(), covered
        finally:
            deferred.release()
            forward.release()

    deferred, forward, cov = images({"anisotropy_rotation": 50.0})
    _, straight, _ = images({})
    peak = deferred[cov].max()
    assert np.abs(forward - deferred)[cov].max() <= 2e-5 * peak
    assert np.abs(straight - deferred)[cov].max() > 0.05 * peak


def test_renderer_meets_the_raycaster_with_rotations(gl_egl, tmp_path):
    """The float64 ray-caster (app/reference/raycast.py) turns its tangent with the twin
    rotate_tangent; the renderer's image of anisotropic spheres turned by 0, 35, -70 and
    90 degrees meets the accuracy targets against it."""
    from app.bench.raycast import raycast_errors
    from tests.test_raycast import TARGET_MEDIAN, TARGET_P99

    rotations = [0.0, 35.0, -70.0, 90.0]
    data = {
        "camera": {"position": [0, 0, 300], "target": [0, 0, 0], "fov_y": 0.55,
                   "near": 250.0, "far": 350.0},
        "materials": {
            f"m{i}": {"roughness": 0.4, "anisotropy": 0.7, "metallic": 1.0,
                      "base_color": [0.9, 0.8, 0.6], "anisotropy_rotation": r}
            for i, r in enumerate(rotations)
        },
        "objects": [
            {"shape": "sphere", "radius": 0.5, "position": [1.2 * i - 1.8, 0, 0],
             "material": f"m{i}"}
            for i in range(4)
        ],
        "lights": [
            {"type": "directional", "direction": [0.45, -0.45, -0.77], "intensity": 1.0},
            {"type": "directional", "direction": [-0.35, 0.3, -0.89], "intensity": 0.5},
        ],
    }  # fmt: skip
    loaded = parse_scene(data, tmp_path / "inline.toml")
    errors = raycast_errors(gl_egl, loaded, (200, 60), flip=False)
    assert errors["median"] <= TARGET_MEDIAN, errors
    assert errors["p99"] <= TARGET_P99, errors
    assert errors["coverage_mismatch"] == 0.0, errors


def test_rotation_edit_recompiles(gl_egl, tmp_path):
    """Renderer.set_materials keeps the programs for a constants-only edit; the rotation
    is compiled in only where it is not 0, so 0 -> 30 degrees rebuilds the G-buffer pass
    and 30 -> -60 only sets the uniform: each frame holds its own turned tangent."""
    from app.scene.model import Material

    base = {"roughness": 0.4, "anisotropy": 0.7, "metallic": 1.0}
    r = Renderer(gl_egl, parse_scene(plane({}), tmp_path / "inline.toml"))
    try:
        for degrees in (30.0, -60.0, 0.0):
            m = Material.model_validate({**base, "anisotropy_rotation": degrees})
            r.set_materials({"m": m})
            r.render()
            g = r.read_gbuffer()
            want = about(np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0]),
                         math.radians(degrees))  # fmt: skip
            err = np.linalg.norm(tangents(g) - want, axis=-1)[g.covered]
            assert err.max() <= 8 * F32, (degrees, err.max())
    finally:
        r.release()


def gltf_quad(tmp_path: Path, ext: dict, texture_rg: tuple[int, int] | None = None) -> Path:
    """A scene with the glTF test quad (XY plane facing +Z, +u along +x; tangents derived
    by the project, bitangent n x t = +y: up the image, the normal map's +Y) carrying
    KHR_materials_anisotropy ``ext`` (and an anisotropyTexture of constant RG, B = 255)."""
    b = GltfBuilder()
    ext = dict(ext)
    if texture_rg is not None:
        ext["anisotropyTexture"] = {"index": b.texture(png_rgb((*texture_rg, 255)))}
    mat = pygltflib.Material(
        pbrMetallicRoughness=pygltflib.PbrMetallicRoughness(
            metallicFactor=1.0, roughnessFactor=0.4
        ),
        extensions={"KHR_materials_anisotropy": {"anisotropyStrength": 0.6, **ext}},
    )
    b.doc.extensionsUsed = ["KHR_materials_anisotropy"]
    b.quad(b.material(mat))
    b.save(tmp_path / "a.glb")
    scene = tmp_path / "scene.toml"
    text = SCENE.format(file="a.glb").replace('gbuffer = "f16"', 'gbuffer = "f32"')
    scene.write_text(text, encoding="utf-8")
    return scene


def gltf_gbuffer(gl: GLContext, scene: Path):
    r = Renderer(gl, load_scene(scene), SIZE)
    try:
        r.render()
        return r.read_gbuffer()
    finally:
        r.release()


def test_gltf_rotation_renders_with_the_turned_tangent(gl_egl, tmp_path):
    """A glTF file's anisotropyRotation (0.5 rad, not a quarter turn) reaches the G-buffer:
    its tangent is the unrotated file's turned about n by 0.5 rad towards the bitangent
    b = w (n x t) = +y (the frame the normal map uses: tests/test_gltf_reader.py; the
    Khronos sample viewer's b = cross(ng, t) for this quad), counter-clockwise seen from
    +z. The anisotropyTexture's RG at 45 degrees plus the
    rotation gives the rotation 0.5 + pi/4; no note says anything is left out."""
    m = map_material_extensions(
        {"KHR_materials_anisotropy": {"anisotropyStrength": 0.6, "anisotropyRotation": 0.5}},
        pygltflib_params(), "materials[0]",
    )  # fmt: skip
    assert m.notes == () and m.anisotropy_rotation == 0.5
    g0 = gltf_gbuffer(gl_egl, gltf_quad(tmp_path, {}))
    g = gltf_gbuffer(gl_egl, gltf_quad(tmp_path, {"anisotropyRotation": 0.5}))
    cov = g.covered & g0.covered
    assert cov.sum() > 100
    t0 = tangents(g0)
    np.testing.assert_allclose(t0[cov], np.broadcast_to([1, 0, 0], t0[cov].shape), atol=1e-6)
    b_v = np.array([0.0, 1.0, 0.0])  # n x t
    want = math.cos(0.5) * t0 + math.sin(0.5) * b_v
    err = np.linalg.norm(tangents(g) - want, axis=-1)[cov]
    assert err.max() <= 8 * F32, err.max()
    g_tex = gltf_gbuffer(
        gl_egl, gltf_quad(tmp_path, {"anisotropyRotation": 0.5}, texture_rg=(218, 218))
    )
    a = 0.5 + math.pi / 4
    want = math.cos(a) * t0 + math.sin(a) * b_v
    err = np.linalg.norm(tangents(g_tex) - want, axis=-1)[cov]
    assert err.max() <= 8 * F32, err.max()


def pygltflib_params():
    """A glTF core material's parameters as the reader builds them (roughness 0.4)."""
    from app.common.models import MaterialParams

    return MaterialParams((1.0, 1.0, 1.0), 1.0, 0.4, 0.04)


# Khronos' AnisotropyRotationTest, as a stand-in built by scripts/anisotropy_rotation_standin.py
# (the original's binary files cannot be had here; docs/gltf.md): ten metal spheres in two
# columns of five, rendered through the glTF reader in the script's view_scene (from 1 km
# straight ahead, VIEW_SCALE pixels a metre, one directional light, no environment: the
# metals have no diffuse, so the image is their highlights).
STANDIN = Path(__file__).parent / "assets" / "anisotropy_rotation"


def standin_hdr(gl: GLContext, data: dict) -> np.ndarray:
    r = Renderer(gl, parse_scene(data, STANDIN / "inline.toml"))
    try:
        r.render()
        return r.read_hdr()[..., :3].astype(np.float64)
    finally:
        r.release()


def standin_centre(node: str) -> tuple[float, float]:
    """The named node's sphere centre (x, y) in metres."""
    return next(node_centre(c, r) for name, c, r, _ in NODES if name == node)


def sphere_tile(hdr: np.ndarray, node: str, half: int = 22) -> np.ndarray:
    """The square of ``hdr`` (the whole stand-in in view_scene) around the named node's
    sphere (radius 19.2 px)."""
    x, y = standin_centre(node)
    cx = round(VIEW_SIZE[0] / 2 + VIEW_SCALE * x)
    cy = round(VIEW_SIZE[1] / 2 - VIEW_SCALE * y)
    return hdr[cy - half : cy + half, cx - half : cx + half]


def test_standin_is_the_generators_output():
    """The committed stand-in is what scripts/anisotropy_rotation_standin.py writes (so the
    generator's docstring describes the file the tests render): the .gltf and .bin byte for
    byte, each PNG texel for texel (a PNG's bytes depend on the zlib that wrote it)."""
    files = build()
    assert sorted(files) == sorted(p.name for p in STANDIN.iterdir())
    for name, data in files.items():
        if name.endswith(".png"):
            got = np.asarray(Image.open(STANDIN / name))
            assert np.array_equal(got, np.asarray(Image.open(io.BytesIO(data)))), name
        else:
            assert (STANDIN / name).read_bytes() == data, name


@pytest.mark.gl
def test_standin_turned_tangents_render_as_the_plain_spheres(gl_egl):
    """AnisotropyRotationTest's three turned cases: tangents tilted 30 degrees clockwise,
    undone by anisotropyRotation (+30 degrees), by the anisotropyTexture's RG (30 degrees)
    or by both (10 + 20): each sphere's highlight is its plain neighbours' in the same
    column, a horizontal streak.

    Tolerances, from the plain spheres themselves: two plain spheres two rows apart differ
    by 0.9 % (relative L1 of their squares: the 0.06-degree difference of view and the
    rasterisation), side by side by 0.14 %; their principal directions by 0.03 degrees. The
    turned spheres measured 0.5-1.0 % and 0.25 degrees (the texture's 8-bit RG holds 29.88
    and 10.14 degrees). Bounds: 3 % and 1 degree. A turn left undone leaves the streak
    tilted (measured with the reader ignoring anisotropyRotation or the RG: relative L1
    0.52-1.09, directions 17-39 degrees off; both turned the wrong way, Khronos' failure
    example: 1.31 and 64 degrees)."""
    hdr = standin_hdr(gl_egl, view_scene())
    for plain in ("Plain 1L", "Plain 3L", "Plain 5R"):
        angle, elongation = highlight_shape(sphere_tile(hdr, plain))
        assert abs(angle) < 3.0 and elongation > 2.0, (plain, angle, elongation)
    for turned, neighbours in (
        ("Tangents + Rotation", ("Plain 1L", "Plain 3L")),
        ("Tangents + Texture", ("Plain 3L", "Plain 5L")),
        ("Tangents + Texture + Rotation", ("Plain 1R", "Plain 3R")),
    ):
        tile = sphere_tile(hdr, turned)
        angle, elongation = highlight_shape(tile)
        for plain in neighbours:
            want = sphere_tile(hdr, plain)
            diff = np.abs(tile - want).sum() / np.abs(want).sum()
            plain_angle, plain_elongation = highlight_shape(want)
            assert diff <= 0.03, (turned, plain, diff)
            assert abs(angle - plain_angle) <= 1.0, (turned, plain, angle, plain_angle)
            assert abs(elongation / plain_elongation - 1.0) <= 0.02, (turned, elongation)


@pytest.mark.gl
def test_standin_grooves_spread_the_light_horizontally_with_lean(gl_egl):
    """AnisotropyRotationTest's "Normal map of grooves": no anisotropy, a normal map of 128
    vertical grooves around the sphere (slopes uniform within +-30 degrees across them),
    which should still spread a light horizontally. Seen from afar (the sphere 38 pixels
    across, some 8 texels and one groove to a pixel at its centre: mip level 3), measured
    on a 48 x 48 image of that sphere alone:

    - the reference (level 0 of the map, 16 x 16 samples a pixel): a horizontal streak,
      elongation 5.9 at -0.8 degrees (its anisotropic neighbours: 2.7);
    - ``lean``: a horizontal streak, 4.2 at -0.6 degrees (the slopes' covariance kept as
      anisotropic roughness, docs/filtering.md);
    - the default, ``auto``: the same streak as ``lean``, which it picks for this map (its
      slopes spread across the grooves alone: docs/filtering.md, "Choosing LEAN: auto");
    - ``variance``: a round grey blob, 1.03: its mips fold the directional spread into one
      isotropic roughness (docs/filtering.md, "Anisotropic filtering: LEAN").

    With the covariance zeroed in the shader, lean's highlight is the mean normal's small
    round dot (elongation 1.04); with auto's anisotropy threshold above 1 the default is
    variance's blob."""
    centre = standin_centre("Normal map of grooves")
    shapes = {
        name: highlight_shape(standin_hdr(gl_egl, view_scene((48, 48), centre, **render)))
        for name, render in (
            ("reference", {"normal_filter": "none", "supersample": 16}),
            ("lean", {"normal_filter": "lean"}),
            ("auto (default)", {}),
            ("variance", {"normal_filter": "variance"}),
        )
    }
    for name in ("reference", "lean", "auto (default)"):
        angle, elongation = shapes[name]
        assert abs(angle) <= 5.0 and elongation >= 3.0, (name, shapes[name])
    assert shapes["variance"][1] <= 1.3, shapes["variance"]
