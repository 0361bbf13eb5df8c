"""The glTF 2.0 core material in the renderer: emission, occlusion, alpha mask
and sampler wrap modes, on scenes built from TOML keys, with the real GLSL.

Each test renders a plane seen from above (u along +x, v along the image's rows) with and
without the feature and checks the difference is exactly what glTF 2.0 specifies; the
lighting pass is also held to its float64 twin (app/reference/illumination.py) with the
new G-buffer channel (RT5) read back.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from app.frame.materials import material_table
from app.gl.context import GLContext
from app.reference.illumination import shade_gbuffer
from app.render.renderer import Renderer
from app.scene.loader import parse_scene

SIZE = (48, 48)
# The lighting pass against its float64 twin (tests/test_reference_agreement.py's bound).
MAX_REL_ERR = 1e-4


def scene_data(material: dict, lights: list[dict], environment: bool = False) -> dict:
    """A 2 m plane filling a 90-degree view from 1 m above, lit by ``lights``."""
    data: dict = {
        "camera": {"position": [0, 1, 0], "target": [0, 0, 0], "up": [0, 0, -1], "fov_y": 90},
        "materials": {"m": {"roughness": 0.5, **material}},
        "objects": [{"shape": "plane", "size": [2.2, 2.2], "material": "m"}],
        "lights": lights,
        "render": {"width": SIZE[0], "height": SIZE[1]},
    }
    if environment:
        data["environment"] = {"radiance": [0.5, 0.5, 0.5], "samples": 64}
    return data


SUN = {"type": "directional", "direction": [0.3, -1, 0.2], "intensity": 2.0}
POINT = {"type": "point", "position": [0.3, 0.6, 0.1], "intensity": 1.5, "range": 5.0}


def render(gl: GLContext, data: dict, tmp_path: Path, wrap: tuple[str, str] | None = None):
    """(HDR image, G-buffer, twin's image) of a scene dict. ``wrap``: the base colour map's
    sampler wrap modes (glTF samplers; no TOML key sets them, the glTF reader does)."""
    r = Renderer(gl, parse_scene(data, tmp_path / "inline.toml"))
    try:
        if wrap is not None:
            r.frame.parts[0].layers[0].maps["base_color"].wrap = wrap
            r.invalidate("gbuffer_pass")  # upload the map again with its new sampler state
        r.render()
        g = r.read_gbuffer()
        ref = shade_gbuffer(
            g, r.camera, r.lights, np.zeros(3), r.materials.models, r.materials.packed(),
            environment=r.uniform_environment,
        )  # fmt: skip
        return r.read_hdr().astype(np.float64), g, ref
    finally:
        r.release()


def save(tmp_path: Path, name: str, pixels: np.ndarray) -> str:
    Image.fromarray(np.asarray(pixels, np.uint8)).save(tmp_path / name)
    return name


def assert_matches_twin(hdr: np.ndarray, ref: np.ndarray, covered: np.ndarray) -> None:
    peak = ref[covered].max()
    rel = np.abs(hdr - ref)[covered] / np.maximum(ref[covered], 1e-3 * peak)
    assert rel.max() <= MAX_REL_ERR, f"max relative error {rel.max():.2e}"


@pytest.mark.parametrize("lights", [[], [SUN, POINT]], ids=["unlit", "lit"])
def test_emissive_adds_exactly_its_radiance(gl, tmp_path, lights):
    """L_o + L_e: the image minus the image without emission is the emission, once per
    pixel, whatever lights there are (not multiplied by any of them)."""
    emission = np.array([0.5, 0.25, 2.0]) * 3.0
    base, g0, _ = render(gl, scene_data({}, lights), tmp_path)
    material = {"emissive": [0.5, 0.25, 2.0], "emissive_strength": 3.0}
    lit, g, ref = render(gl, scene_data(material, lights), tmp_path)
    covered = g.covered
    assert covered.all() and g0.emission is None and g.emission is not None
    np.testing.assert_allclose(
        g.emission[covered][:, :3], np.broadcast_to(emission, (covered.sum(), 3))
    )
    np.testing.assert_allclose(g.emission[covered][:, 3], 1.0)  # no occlusion map: 1
    diff = (lit - base)[covered]
    # float32 rounding of PI * Lo + e only
    tol = 4 * np.finfo(np.float32).eps * np.maximum(np.abs(lit[covered]), 1.0)
    assert np.all(np.abs(diff - emission) <= tol)
    assert_matches_twin(lit, ref, covered)


def test_emissive_map_multiplies_emissive(gl, tmp_path):
    """The emissive map is sRGB colour: a texel of 188 emits emissive x decode(188/255)."""
    tex = save(tmp_path, "e.png", np.full((8, 8, 3), (188, 255, 0)))
    material = {"emissive": [2.0, 1.0, 4.0], "emissive_map": tex}
    hdr, g, ref = render(gl, scene_data(material, []), tmp_path)
    c = 188 / 255
    decoded = ((c + 0.055) / 1.055) ** 2.4  # the sRGB transfer function (IEC 61966-2-1)
    expected = np.array([2.0 * decoded, 1.0, 0.0])
    assert np.abs(hdr[g.covered] - expected).max() <= 2e-3  # the GL's 8-bit sRGB decode
    assert_matches_twin(hdr, ref, g.covered)


@pytest.mark.parametrize("culling", ["tiled", "none"])
def test_occlusion_darkens_only_the_environment(gl, tmp_path, culling):
    """glTF 2.0: occlusion applies to indirect light. With an occlusion map of 0 and
    strength 0.75 (factor 1 + 0.75 (0 - 1) = 0.25) the environment's part of the image
    scales by 0.25 and the part of a directional and a point light is unchanged, bit for
    bit, with tiled light culling (the directional loop, then the masked one) and without
    (one loop over every light)."""
    ao_map = save(tmp_path, "ao.png", np.zeros((8, 8, 3)))
    ao = {"occlusion_map": ao_map, "occlusion_strength": 0.75}

    def image(material: dict, lights: list[dict], environment: bool):
        data = scene_data(material, lights, environment)
        data["render"]["light_culling"] = culling
        return render(gl, data, tmp_path)

    env, _, _ = image({}, [], True)
    env_ao, g_env, _ = image(ao, [], True)
    direct, _, _ = image({}, [SUN, POINT], False)
    direct_ao, _, _ = image(ao, [SUN, POINT], False)
    both_ao, g, ref = image(ao, [SUN, POINT], True)
    covered = g.covered
    assert covered.all()
    np.testing.assert_array_equal(g_env.emission[..., 3], 0.25)
    np.testing.assert_array_equal(g_env.emission[..., :3], 0.0)  # occlusion emits nothing
    assert env[covered].min() > 0.0
    np.testing.assert_allclose(env_ao[covered], 0.25 * env[covered], rtol=1e-6)
    np.testing.assert_array_equal(direct_ao, direct)
    np.testing.assert_allclose(both_ao[covered], (0.25 * env + direct)[covered], rtol=1e-5)
    assert_matches_twin(both_ao, ref, covered)


def blocks(values: list[float], size: int = 64) -> np.ndarray:
    """(size, size) 8-bit texels: len(values) vertical bands of constant value along u."""
    band = np.repeat(np.round(np.asarray(values) * 255.0), size // len(values))
    return np.broadcast_to(band[None, :], (size, size)).astype(np.uint8)


def test_alpha_mask_cuts_at_the_cutoff(gl, tmp_path):
    """alphaMode MASK: a pixel is covered exactly where its coverage (alpha x the base
    colour map's A) reaches the cutoff. The same bands as a metallic map (linear R, read
    back from the G-buffer of an opaque render) say where that is; pixels whose metallic is
    within 0.05 of the cutoff lie on a band's filtered edge and may go either way."""
    bands = [0.2, 0.9, 0.5, 0.7]
    a = blocks(bands)
    rgba = np.dstack([np.full_like(a, 255)] * 3 + [a])
    base = save(tmp_path, "rgba.png", rgba)
    metal = save(tmp_path, "metal.png", np.dstack([a] * 3))
    _, g_ref, _ = render(gl, scene_data({"metallic": 1.0, "metallic_map": metal}, [SUN]), tmp_path)
    alpha = 0.8  # scales every band: coverages 0.16, 0.72, 0.4, 0.56
    cutoff = 0.5
    material = {
        "base_color_map": base,
        "alpha": alpha,
        "alpha_mode": "mask",
        "alpha_cutoff": cutoff,
    }
    _, g, _ = render(gl, scene_data(material, [SUN]), tmp_path)
    coverage = alpha * g_ref.base_color[..., 3]
    sure = np.abs(coverage - cutoff) > 0.05 * alpha
    assert sure.sum() > 0.8 * coverage.size
    np.testing.assert_array_equal(g.covered[sure], (coverage >= cutoff)[sure])
    assert 0.2 < g.covered.mean() < 0.8  # both sides are present
    # "opaque" ignores alpha; a "blend" part is not in the G-buffer at all (it is shaded
    # forward after lighting: app/render/blend.py, tests/test_alpha_blend.py).
    for mode, covered in (("opaque", True), ("blend", False)):
        material = {"base_color_map": base, "alpha": alpha, "alpha_mode": mode}
        _, g, _ = render(gl, scene_data(material, [SUN]), tmp_path)
        assert g.covered.all() if covered else not g.covered.any()


@pytest.mark.parametrize("wrap", ["repeat", "clamp", "mirror"])
def test_sampler_wrap_modes(gl, tmp_path, wrap):
    """uv_scale 2 reads u, v over [0, 2]: REPEAT shows the texture twice, CLAMP_TO_EDGE
    its last texel over the second half, MIRRORED_REPEAT it mirrored. A ramp of 16 texels
    along u (a dark half and a bright half) tells them apart."""
    ramp = np.where(np.arange(16) < 8, 40, 220)[None, :].repeat(16, 0)
    tex = save(tmp_path, "ramp.png", np.dstack([ramp] * 3))
    data = scene_data({"base_color_map": tex, "uv_scale": [2.0, 2.0]}, [])
    data["environment"] = {"radiance": [1.0, 1.0, 1.0], "samples": 16}
    _, g, _ = render(gl, data, tmp_path, wrap=(wrap, wrap))
    row = g.base_color[SIZE[1] // 2, :, 0]
    # u = 0.5 + (x - centre) / 2.2 * 2 across the image (the plane is 2.2 m, the view 2 m)
    u_centres = [int(SIZE[0] * f) for f in (0.17, 0.38, 0.62, 0.83)]
    dark, bright = row.min(), row.max()
    seen = ["d" if abs(row[x] - dark) < abs(row[x] - bright) else "b" for x in u_centres]
    expected = {"repeat": "dbdb", "clamp": "dbbb", "mirror": "dbbd"}[wrap]
    assert "".join(seen) == expected


def render_part(gl: GLContext, data: dict, tmp_path: Path, edit) -> tuple:
    """Like ``render``, with ``edit(part, layer)`` applied to the first mesh part before
    the material table and the G-buffer are built again: the glTF reader fills
    MeshPart.colors/uv1 and SurfaceLayer.uv_transforms, which no TOML key sets (and a part
    with COLOR_0 has no constant surface, so the G-buffer's layout follows the edit)."""
    r = Renderer(gl, parse_scene(data, tmp_path / "inline.toml"))
    try:
        part = r.frame.parts[0]
        edit(part, part.layers[0])
        table, ids = material_table(r.frame.parts)
        r.frame = dataclasses.replace(r.frame, materials=table, material_ids=ids)
        r.invalidate("gbuffer_pass")  # the part's buffers; the keys see the new table
        r.render()
        return r.read_hdr().astype(np.float64), r.read_gbuffer()
    finally:
        r.release()


def view_filling_plane(material: dict) -> dict:
    """The plane exactly filling the view: u and v span the image, 48 pixels each."""
    data = scene_data(material, [SUN])
    data["objects"][0]["size"] = [2.0, 2.0]
    return data


def test_vertex_colors_multiply_base_color_and_coverage(gl, tmp_path):
    """glTF COLOR_0 multiplies the base colour (RGB) and the coverage (A)."""
    data = view_filling_plane({"base_color": [0.8, 0.6, 0.4]})
    color = np.array([0.5, 0.25, 1.0, 0.4], np.float32)

    def paint(part, layer):
        part.colors = np.tile(color, (len(part.vertices), 1))

    _, g = render_part(gl, data, tmp_path, paint)
    expected = np.array([0.8, 0.6, 0.4], np.float32) * color[:3]
    np.testing.assert_allclose(
        g.base_color[..., :3], np.broadcast_to(expected, (*SIZE, 3)), rtol=1e-6
    )
    data["materials"]["m"].update({"alpha_mode": "mask", "alpha_cutoff": 0.5, "alpha": 1.0})
    _, g = render_part(gl, data, tmp_path, paint)
    assert not g.covered.any()  # coverage 0.4 < 0.5 everywhere
    data["materials"]["m"]["alpha_cutoff"] = 0.4
    _, g = render_part(gl, data, tmp_path, paint)
    assert g.covered.all()


def test_texcoord1_is_read(gl, tmp_path):
    """A map whose UvTransform names uv_set 1 reads MeshPart.uv1 (TEXCOORD_1): with every
    vertex's TEXCOORD_1 at one texel's centre the whole plane takes that texel."""
    from app.textures.maps import UvTransform

    quadrants = np.zeros((2, 2), np.uint8)
    quadrants[0, 1] = 200  # the top-right texel (u > 0.5, v > 0.5 in OpenGL's UVs)
    metal = save(tmp_path, "q.png", np.dstack([quadrants] * 3))
    data = view_filling_plane({"metallic": 1.0, "metallic_map": metal})

    def second_set(part, layer):
        part.uv1 = np.tile(np.float32([0.75, 0.75]), (len(part.vertices), 1))
        layer.uv_transforms["metallic"] = UvTransform(uv_set=1)

    _, g0 = render_part(gl, data, tmp_path, lambda part, layer: None)
    _, g1 = render_part(gl, data, tmp_path, second_set)
    assert g0.base_color[..., 3].std() > 0.1  # TEXCOORD_0 spans the map
    np.testing.assert_allclose(g1.base_color[..., 3], 200 / 255, atol=1e-3)


def row_ramp(axis: int) -> np.ndarray:
    """16 x 16 8-bit texels rising by 16 per texel along ``axis`` (0: down the image's
    rows, 1: along its columns): a linear ramp, which bilinear filtering reproduces
    exactly between texel centres."""
    ramp = (16 * np.arange(16) + 8).astype(np.uint8)
    grid = np.broadcast_to(ramp[:, None] if axis == 0 else ramp[None, :], (16, 16))
    return np.dstack([grid] * 3)


@pytest.mark.parametrize("axis", [0, 1], ids=["v", "u"])
def test_texture_transform_offset_moves_by_texels(gl, tmp_path, axis):
    """KHR_texture_transform: uv' = uv + offset. An offset of 2/16 on a 16-texel ramp
    makes every pixel read the value 2 texels further along the image (down its rows for
    v: glTF's v runs down the image), i.e. the ramp's value plus 2 steps of 16/255, away
    from the wrap seam."""
    from app.textures.maps import UvTransform

    metal = save(tmp_path, "ramp.png", row_ramp(axis))
    data = view_filling_plane({"metallic": 1.0, "metallic_map": metal})
    offset = (0.0, 2 / 16) if axis == 0 else (2 / 16, 0.0)

    def move(part, layer):
        layer.uv_transforms["metallic"] = UvTransform(offset=offset)

    _, g0 = render_part(gl, data, tmp_path, lambda part, layer: None)
    _, g1 = render_part(gl, data, tmp_path, move)
    a, b = g0.base_color[..., 3], g1.base_color[..., 3]
    step = 16 / 255
    # Away from the wrap seam: a's at the image's edges (where repeat blends the first and
    # last texels), b's where a is within 2.5 texels of the ramp's end.
    inner = np.zeros(a.shape, bool)
    inner[3:-3, 3:-3] = True
    inner &= a < 13.4 * step
    assert inner.mean() > 0.5
    np.testing.assert_allclose(b[inner], a[inner] + 2 * step, atol=2e-3)


def test_texture_transform_on_an_analytic_sphere(gl, tmp_path):
    """An analytic sphere's maps (textureGrad with its own derivatives) move too: a scale
    of 2 doubles how often the texture repeats, the same as uv_scale 2 does, down to the
    mip level: a checker of 2-texel cells is minified about 2:1, so derivatives not taken
    through the transform would pick a sharper level than uv_scale's."""
    from app.textures.maps import UvTransform

    cells = (np.indices((64, 64)) // 2).sum(axis=0) % 2
    metal = save(tmp_path, "checker.png", np.dstack([cells * 255] * 3))
    data = scene_data({"metallic": 1.0, "metallic_map": metal}, [SUN])
    data["objects"] = [{"shape": "sphere", "radius": 0.5, "material": "m"}]
    data["camera"] = {"position": [0, 0, 2], "target": [0, 0, 0]}

    def scale(part, layer):
        assert part.analytic is not None
        layer.uv_transforms["metallic"] = UvTransform(scale=(2.0, 2.0))

    _, g1 = render_part(gl, data, tmp_path, scale)
    data["materials"]["m"]["uv_scale"] = [2.0, 2.0]
    _, g2 = render_part(gl, data, tmp_path, lambda part, layer: None)
    assert g1.covered.sum() > 100 and np.array_equal(g1.covered, g2.covered)
    cov = g1.covered
    np.testing.assert_allclose(g1.base_color[cov][:, 3], g2.base_color[cov][:, 3], atol=2e-3)


@pytest.mark.parametrize(
    ("material", "key"),
    [
        ({"alpha_cutoff": 0.3}, "alpha_cutoff"),  # without alpha_mode = "mask"
        ({"alpha_mode": "cutout"}, "alpha_mode"),
        ({"alpha": 1.5}, "alpha"),
        ({"emissive": [-1.0, 0.0, 0.0]}, "emissive"),
        ({"emissive": [1.0, 1.0, 1.0], "emissive_strength": 2e15}, "emissive_strength"),
        ({"emissive_map": "e.png"}, "emissive_map"),  # multiplies a black emissive
        ({"occlusion_strength": 0.5}, "occlusion_strength"),  # without occlusion_map
        ({"occlusion_map": "missing.png"}, "occlusion_map"),
    ],
)
def test_bad_core_material_keys_name_the_key(tmp_path, material, key):
    """Bad input is one InputError naming the material key (exit 2 on the command line)."""
    from app.errors import InputError

    save(tmp_path, "e.png", np.zeros((4, 4, 3)))
    with pytest.raises(InputError) as caught:
        parse_scene(scene_data(material, []), tmp_path / "inline.toml")
    assert key in str(caught.value)


def test_debug_views_show_emission_and_occlusion(gl, tmp_path):
    """``--debug emission`` shows RT5's radiance and ``--debug occlusion`` its factor, the
    very values read back from the G-buffer."""
    from app.render.debug_views import DebugPass

    ao = save(tmp_path, "ao.png", np.full((8, 8, 3), 128))
    material = {"emissive": [0.5, 0.2, 0.1], "occlusion_map": ao, "occlusion_strength": 0.5}
    r = Renderer(gl, parse_scene(scene_data(material, [SUN]), tmp_path / "inline.toml"))
    try:
        r.render()
        g = r.read_gbuffer()
        debug = DebugPass(r)
        try:
            debug.run("emission")
            emission = debug.read_values()
            debug.run("occlusion")
            occlusion = debug.read_values()
        finally:
            debug.release()
    finally:
        r.release()
    np.testing.assert_array_equal(emission[..., :3], g.emission[..., :3])
    np.testing.assert_array_equal(occlusion[..., 0], g.emission[..., 3])
    np.testing.assert_allclose(g.emission[..., 3], 1.0 + 0.5 * (128 / 255 - 1.0), atol=1e-3)


def test_alpha_mode_edit_recompiles_the_alpha_test(gl, tmp_path):
    """Renderer.set_materials with a new alpha_mode rebuilds the G-buffer pass (the alpha
    test is compiled in or out): "mask" with coverage below the cutoff empties the frame,
    "opaque" fills it again."""
    from app.scene.model import Material

    data = scene_data({"alpha": 0.2}, [SUN])
    r = Renderer(gl, parse_scene(data, tmp_path / "inline.toml"))
    try:
        r.render()
        assert r.read_gbuffer().covered.all()
        masked = Material.model_validate({"roughness": 0.5, "alpha": 0.2, "alpha_mode": "mask"})
        r.set_materials({"m": masked})
        r.render()
        assert not r.read_gbuffer().covered.any()
        r.set_materials({"m": Material.model_validate({"roughness": 0.5, "alpha": 0.2})})
        r.render()
        assert r.read_gbuffer().covered.all()
    finally:
        r.release()


def test_raycaster_refuses_emission(tmp_path):
    """The float64 ray-caster shades material constants only: an emitting material is
    refused by key rather than drawn without its emission."""
    from app.frame.raycast import primitive_material
    from app.scene.model import Material

    with pytest.raises(ValueError, match="emissive"):
        primitive_material("m", Material.model_validate({"emissive": [1.0, 0.0, 0.0]}))


def test_forward_pass_cuts_the_same_pixels(gl, tmp_path):
    """The bench's forward pass runs the same alpha test: its uncovered pixels (exactly the
    background) are the deferred G-buffer's."""
    from app.bench.forward import ForwardRenderer

    a = blocks([0.2, 0.9, 0.5, 0.7])
    base = save(tmp_path, "rgba.png", np.dstack([np.full_like(a, 255)] * 3 + [a]))
    material = {"base_color_map": base, "alpha_mode": "mask", "alpha_cutoff": 0.6}
    data = scene_data(material, [SUN])
    data["background"] = [0.25, 0.5, 0.75]
    loaded = parse_scene(data, tmp_path / "inline.toml")
    deferred, forward = Renderer(gl, loaded), ForwardRenderer(gl, loaded, SIZE)
    try:
        deferred.render()
        forward.render()
        covered = deferred.read_gbuffer().covered
        background = np.all(forward.read_hdr() == np.float32([0.25, 0.5, 0.75]), axis=-1)
    finally:
        deferred.release()
        forward.release()
    assert 0.2 < covered.mean() < 0.8
    np.testing.assert_array_equal(background, ~covered)
