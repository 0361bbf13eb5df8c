"""glTF 2.0 alphaMode BLEND: blended parts shaded forward after lighting and composited
"over" the HDR image (app/render/blend.py), with the real GLSL.

The float64 twin shades G-buffer pixels only; the blended image is checked by linearity
instead: a quad of coverage a over a background must give exactly
a * (the image with the quad opaque) + (1 - a) * (the image without it), to float32
rounding, because both sides evaluate the same light_contribution at the same positions
(render.gbuffer = "f32": the opaque side's G-buffer holds the material unquantised).
(tests/test_blend.py is the RTR4 §9.13 material blend, an unrelated feature.)
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pygltflib
import pytest
from PIL import Image

from app.gl.context import GLContext
from app.render.renderer import Renderer
from app.scene.loader import parse_scene
from tests.conftest import REPO
from tests.gltf_builder import GltfBuilder

SIZE = (40, 32)
BACKGROUND = [0.1, 0.2, 0.3]
# float32 shading of values around 1 on both sides, and the blend unit's float32 a*x+(1-a)*y.
TOLERANCE = 2e-5

SUN = {"type": "directional", "direction": [0.3, -1.0, -0.4], "intensity": 2.0}
POINT = {"type": "point", "position": [0.4, 0.8, 0.9], "intensity": 1.5, "range": 6.0}


def quad(material: str, z: float, x: float = 0.0, size: float = 1.0) -> dict:
    """A quad facing the camera (+z) at depth z, centred at (x, 0.5)."""
    return {
        "shape": "plane", "size": [size, size], "position": [x, 0.5, z],
        "rotation": [90.0, 0.0, 0.0], "material": material,
    }  # fmt: skip


def scene(materials: dict, objects: list[dict], lights: list[dict], env: bool = False) -> dict:
    data: dict = {
        "background": BACKGROUND,
        "camera": {"position": [0.0, 0.6, 3.0], "target": [0.0, 0.5, 0.0], "fov_y": 40.0},
        "materials": {"floor": {"base_color": [0.5, 0.45, 0.4], "roughness": 0.7}, **materials},
        "objects": [{"shape": "plane", "size": [6.0, 6.0], "material": "floor"}, *objects],
        "lights": lights,
        "render": {"width": SIZE[0], "height": SIZE[1], "gbuffer": "f32"},
    }
    if env:
        data["environment"] = {"radiance": [0.4, 0.45, 0.5], "samples": 16}
    return data


def render(gl: GLContext, data: dict, tmp_path: Path) -> np.ndarray:
    r = Renderer(gl, parse_scene(data, tmp_path / "inline.toml"))
    try:
        r.render()
        return r.read_hdr().astype(np.float64)
    finally:
        r.release()


def check_over(
    gl: GLContext, tmp_path: Path, material: dict, alpha: float, env: bool, supersample: int = 1
) -> None:
    """The blended image against a * opaque + (1 - a) * without."""
    lights = [SUN, POINT]
    m = {"roughness": 0.4, **material}
    glass = {"pane": {**m, "alpha": alpha, "alpha_mode": "blend"}}
    solid = {"pane": {**m, "alpha_mode": "opaque"}}
    images = []
    for materials, objects in (
        (glass, [quad("pane", 0.3)]),
        (solid, [quad("pane", 0.3)]),
        ({}, []),
    ):
        data = scene(materials, objects, lights, env)
        data["render"]["supersample"] = supersample
        images.append(render(gl, data, tmp_path))
    blended, opaque, without = images
    expected = alpha * opaque + (1.0 - alpha) * without
    covered = np.abs(opaque - without).max(axis=2) > 1e-3
    assert covered.mean() > 0.1  # the quad is in view and differs from what is behind it
    np.testing.assert_allclose(blended, expected, rtol=0, atol=TOLERANCE * max(1, expected.max()))


@pytest.mark.parametrize("alpha", [0.25, 0.5])
def test_blended_quad_is_the_linear_combination(gl_egl, tmp_path, alpha):
    """C = a C_opaque + (1 - a) C_without, lit by a sun and a point light. Fails with the
    blend disabled (the quad drawn opaque: off by (1 - a)(opaque - without)) or with the
    quad still drawn into the G-buffer (the floor behind it is not lit)."""
    check_over(gl_egl, tmp_path, {"base_color": [0.8, 0.3, 0.2], "metallic": 0.2}, alpha, False)


def test_composite_is_resolved_with_the_rest(gl_egl, tmp_path):
    """With render.supersample = 2 the blend runs at the render size, before the resolve:
    the box filter is linear, so the linear combination still holds at the output size.
    Fails if the pass ran on the wrong target (after the resolve, or at the output size)."""
    check_over(gl_egl, tmp_path, {"base_color": [0.2, 0.7, 0.9]}, 0.5, False, supersample=2)


def gltf_pane(tmp_path: Path, mode: str) -> Path:
    """A .glb of the builder's 2 m quad with alphaMode ``mode``, baseColorFactor A 0.4."""
    b = GltfBuilder()
    pbr = pygltflib.PbrMetallicRoughness(
        baseColorFactor=[0.9, 0.4, 0.1, 0.4], metallicFactor=0.0, roughnessFactor=0.5
    )
    b.quad(b.material(pygltflib.Material(pbrMetallicRoughness=pbr, alphaMode=mode)))
    return b.save(tmp_path / f"pane_{mode.lower()}.glb")


def test_gltf_blend_primitive_goes_through_the_blend_pass(gl_egl, tmp_path):
    """A glTF file's alphaMode BLEND primitive is left out of the G-buffer and composited
    with its baseColorFactor's A: the same linear combination as the TOML key's. Fails
    with the glTF reader's alpha mode dropped (the pane is then drawn opaque)."""
    lights = [SUN]
    images = []
    for objects in (
        [{"shape": "mesh", "file": str(gltf_pane(tmp_path, "BLEND")), "position": [0, 0.5, 0.3]}],
        [{"shape": "mesh", "file": str(gltf_pane(tmp_path, "OPAQUE")), "position": [0, 0.5, 0.3]}],
        [],
    ):
        r = Renderer(gl_egl, parse_scene(scene({}, objects, lights), tmp_path / "inline.toml"))
        try:
            if objects and "BLEND" in objects[0]["file"]:
                assert r.blend is not None and len(r.gbuffer_pass.drawables) == 1  # the floor
            r.render()
            images.append(r.read_hdr().astype(np.float64))
        finally:
            r.release()
    blended, opaque, without = images
    assert (np.abs(opaque - without).max(axis=2) > 1e-3).mean() > 0.1
    expected = 0.4 * opaque + 0.6 * without
    np.testing.assert_allclose(blended, expected, rtol=0, atol=TOLERANCE * max(1, expected.max()))


def test_emission_and_occlusion_blend(gl_egl, tmp_path):
    """Emission is part of C_src, and the occlusion map darkens the environment's lights
    only, as the lighting pass does. Fails with forward.frag's emission left out of the
    blend output or its occlusion factor dropped (both checked)."""
    material = {
        "base_color": [0.3, 0.5, 0.7], "emissive": [0.6, 0.3, 0.1], "emissive_strength": 2.0,
        "occlusion_map": str(REPO / "scenes" / "textures" / "noise.png"),
    }  # fmt: skip
    check_over(gl_egl, tmp_path, material, 0.5, True)


def emitter(color: list[float], alpha: float) -> dict:
    """A black, unlit surface that emits ``color``: its C_src is exactly ``color``."""
    return {
        "base_color": [0.0, 0.0, 0.0], "metallic": 0.0, "emissive": color,
        "alpha": alpha, "alpha_mode": "blend",
    }  # fmt: skip


def test_back_to_front_regardless_of_scene_order(gl_egl, tmp_path):
    """Two overlapping panes composite far first, whichever the scene lists first; the
    overlap is a_n C_n + (1 - a_n)(a_f C_f + (1 - a_f) C_bg). Fails without the sort
    (the scene order would then decide, and one of the two orders is wrong)."""
    materials = {"near": emitter([1.0, 0.0, 0.0], 0.5), "far": emitter([0.0, 1.0, 0.0], 0.7)}
    panes = [quad("near", 0.8, size=4.0), quad("far", 0.2, size=4.0)]
    # No floor in view of the overlap: the camera looks straight at the panes.
    data = scene(materials, panes, [])
    data["objects"] = data["objects"][1:]
    data["camera"] = {"position": [0.0, 0.5, 3.0], "target": [0.0, 0.5, 0.0], "fov_y": 30.0}
    first = render(gl_egl, data, tmp_path)
    data["objects"] = data["objects"][::-1]
    second = render(gl_egl, data, tmp_path)
    bg = np.array(BACKGROUND)
    far = 0.7 * np.array([0.0, 1.0, 0.0]) + 0.3 * bg
    expected = 0.5 * np.array([1.0, 0.0, 0.0]) + 0.5 * far
    for image in (first, second):
        np.testing.assert_allclose(image, np.broadcast_to(expected, image.shape), atol=1e-6)


def test_blended_part_behind_an_opaque_one_is_hidden(gl_egl, tmp_path):
    """A blended pane wholly behind an opaque quad changes no pixel the quad covers, and
    the opaque quad is still lit as it was. Fails without the depth test against the
    G-buffer's depth."""
    materials = {"solid": {"base_color": [0.2, 0.6, 0.3]}, "glass": emitter([5.0, 5.0, 5.0], 0.5)}
    lights = [SUN]
    front = quad("solid", 0.6, size=1.2)
    hidden = render(
        gl_egl, scene(materials, [front, quad("glass", 0.1, size=0.8)], lights), tmp_path
    )
    alone = render(gl_egl, scene(materials, [front], lights), tmp_path)
    np.testing.assert_array_equal(hidden, alone)


def test_texture_alpha_varies_coverage(gl_egl, tmp_path):
    """The base colour map's A multiplies the coverage: a map whose left half has A = 0.2
    and right half A = 0.8 gives those two blends of the emission over the background
    (checked away from the seam). Fails with coverage() ignoring the map."""
    rgba = np.full((64, 64, 4), 255, np.uint8)  # a texel: 2.5 pixels, filtered near the seam
    rgba[:, :32, 3], rgba[:, 32:, 3] = 51, 204
    path = tmp_path / "alpha.png"
    Image.fromarray(rgba, "RGBA").save(path)
    material = {**emitter([2.0, 1.0, 0.5], 1.0), "base_color_map": str(path)}
    material["base_color"] = [0.0, 0.0, 0.0]
    data = scene({"pane": material}, [quad("pane", 0.0, size=8.0)], [])
    data["objects"] = data["objects"][1:]
    data["camera"] = {"position": [0.0, 0.5, 3.0], "target": [0.0, 0.5, 0.0], "fov_y": 30.0}
    image = render(gl_egl, data, tmp_path)
    e, bg = np.array([2.0, 1.0, 0.5]), np.array(BACKGROUND)
    w = SIZE[0]
    for columns, a in ((slice(2, w // 2 - 3), 51 / 255), (slice(w // 2 + 3, w - 2), 204 / 255)):
        expected = a * e + (1 - a) * bg
        np.testing.assert_allclose(
            image[:, columns], np.broadcast_to(expected, image[:, columns].shape), atol=1e-5
        )


def test_scene_without_blend_has_no_blend_pass(gl_egl, tmp_path):
    """The blend pass exists only where a part is blended (every other scene renders as
    before: scripts/same_pixels.py main), and an alpha_mode edit builds or drops it with
    the image a fresh renderer gives."""
    m = {"base_color": [0.8, 0.3, 0.2], "alpha": 0.5}
    data = scene({"pane": {**m, "alpha_mode": "opaque"}}, [quad("pane", 0.3)], [SUN])
    r = Renderer(gl_egl, parse_scene(data, tmp_path / "inline.toml"))
    try:
        assert r.blend is None
        edited = parse_scene(
            scene({"pane": {**m, "alpha_mode": "blend"}}, [quad("pane", 0.3)], [SUN]),
            tmp_path / "inline.toml",
        ).scene
        r.update(edited)
        assert r.blend is not None and len(r.gbuffer_pass.drawables) == 1
        r.render()
        updated = r.read_hdr()
    finally:
        r.release()
    fresh = render(
        gl_egl, scene({"pane": {**m, "alpha_mode": "blend"}}, [quad("pane", 0.3)], [SUN]), tmp_path
    )
    np.testing.assert_array_equal(updated, fresh.astype(np.float32))


def test_blended_part_gets_shadows_and_image_based_light(gl_egl, tmp_path):
    """The blend pass shades with the lighting pass's surface_radiance
    (glsl/lights/shading.glsl): a blended quad under a sky environment, in the shadow of an
    opaque sphere, is a * (the quad opaque) + (1 - a) * (the quad of coverage 0) where it
    covers the image, so its shadow and image-based light are the opaque quad's. Fails with
    either term left out of the blend pass (checked: without the shadow 36 of the 675
    covered channels differ; without the sky all 675, by up to 0.19). Blended parts cast no shadow,
    so the comparison is on the pixels the quad covers; they must hold a shadow. The
    coverage-0 quad (not an image without it) keeps the directional map's frustum, which
    bounds blended receivers too (app/render/shadows.py), the same in all three."""
    alpha = 0.6
    # Straight back from the camera's side: the opaque quad's own shadow on the floor lies
    # behind it, out of view, so that it does not count as covered.
    sun = {**SUN, "direction": [0.0, -0.3, -1.0], "shadow": True, "shadow_resolution": 256}
    ball = {"shape": "sphere", "radius": 0.15, "position": [0.1, 0.55, 0.9], "material": "ball"}
    m = {"base_color": [0.9, 0.6, 0.3], "roughness": 0.4}
    images = []
    for pane, lights in (
        ({**m, "alpha": alpha, "alpha_mode": "blend"}, [sun]),
        ({**m, "alpha_mode": "opaque"}, [sun]),
        ({**m, "alpha": 0.0, "alpha_mode": "blend"}, [sun]),
        ({**m, "alpha": alpha, "alpha_mode": "blend"}, [{**SUN, "direction": sun["direction"]}]),
    ):
        materials = {"ball": {"base_color": [0.8, 0.8, 0.8], "roughness": 0.5}, "pane": pane}
        data = scene(materials, [ball, quad("pane", 0.3)], lights)
        data["environment"] = {"source": "sky", "sun_direction": [0.5, 0.6, 0.6]}
        data["environment"]["intensity"] = 0.05
        images.append(render(gl_egl, data, tmp_path))
    blended, opaque, without, unshadowed = images
    covered = np.abs(opaque - without).max(axis=2) > 1e-3
    assert covered.mean() > 0.1
    expected = alpha * opaque + (1.0 - alpha) * without
    tol = TOLERANCE * max(1, expected.max())
    np.testing.assert_allclose(blended[covered], expected[covered], rtol=0, atol=tol)
    # The sphere's shadow falls on the quad: covered pixels that the shadow darkens.
    shadowed = covered & ((unshadowed - blended).max(axis=2) > 0.05)
    assert shadowed.sum() > 10
