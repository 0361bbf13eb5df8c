"""Glass casts coloured, lighter shadows (docs/shadows.md, "Glass"): a transmissive sphere
on a floor under a shadowed sun leaves on the floor a shadow whose light is the sphere's
transmittance (transmission, Fresnel at normal incidence, base colour, Beer-Lambert over
its thickness), checked against the float64 twin (app/reference/glass_shadows.py); an
opaque sphere's shadow is dark; a scene without glass builds no glass target.

The scene: a 0.5 m sphere resting on an 8 m floor, a sun travelling along (-1, -1, 0)
(its shadow's centre at x = -0.5 on the floor), no environment light, so that a floor
pixel's light is the sun's alone and its ratio to the unshadowed render is the visibility.
"""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pygltflib
import pytest

from app.reference.glass_shadows import glass_transmittance, transmittance_product
from app.render.renderer import Renderer
from app.render.shadows import _TexturedGlassCaster
from app.scene.loader import parse_scene

pytestmark = pytest.mark.gl

REPO = Path(__file__).resolve().parent.parent
SIZE = (96, 64)
AMBER = {
    "base_color": [1.0, 1.0, 1.0], "roughness": 0.05, "ior": 1.5, "transmission": 1.0,
    "thickness": 0.3, "attenuation_color": [0.95, 0.7, 0.35], "attenuation_distance": 0.3,
}  # fmt: skip
OPAQUE = {"base_color": [0.8, 0.8, 0.8], "roughness": 0.6}
# floor points inside the shadow of the sphere, away from its edge and not hidden by it
PROBES = [(-0.85, 0.0, 0.1), (-0.95, 0.0, -0.1), (-0.8, 0.0, -0.2)]


# The lights, each along (-1, -1, 0) through the sphere's centre: a spot and a point light
# 4.2 m from it (a spot's map and a cube face take the glass target as a sun's does).
LIGHTS = {
    "directional": {"type": "directional", "direction": [-1.0, -1.0, 0.0], "intensity": 2.0},
    "spot": {
        "type": "spot", "position": [3.0, 3.5, 0.0], "direction": [-1.0, -1.0, 0.0],
        "intensity": 30.0, "range": 10.0, "inner_angle": 20.0, "outer_angle": 30.0,
    },
    "point": {"type": "point", "position": [3.0, 3.5, 0.0], "intensity": 30.0, "range": 10.0},
}  # fmt: skip


def scene(ball: dict, shadow: bool = True, light: str = "directional") -> dict:
    sun = dict(LIGHTS[light])
    if shadow:
        sun.update(shadow=True, shadow_resolution=512)
    return {
        "render": {"width": SIZE[0], "height": SIZE[1]},
        "camera": {"position": [-0.6, 4.0, 3.0], "target": [-0.6, 0.0, 0.0], "fov_y": 40.0},
        "materials": {"ball": ball, "floor": {"base_color": [0.8, 0.8, 0.8], "roughness": 0.6}},
        "objects": [
            {"shape": "plane", "size": [8.0, 8.0], "material": "floor"},
            {"shape": "sphere", "radius": 0.5, "position": [0.0, 0.5, 0.0], "material": "ball"},
        ],
        "lights": [sun],
    }  # fmt: skip


def render(gl, data: dict) -> tuple[np.ndarray, list[tuple[int, int]], object]:
    """The HDR image, the probes' pixels (row from the top, column) and the glass target
    read back (None without one)."""
    loaded = parse_scene(copy.deepcopy(data), REPO / "scenes" / "t.toml")
    renderer = Renderer(gl, loaded)
    try:
        renderer.render()
        hdr = renderer.read_hdr().astype(np.float64)
        view_proj = np.asarray(renderer.proj, np.float64) @ np.asarray(renderer.view, np.float64)
        pixels = []
        for p in PROBES:
            clip = view_proj @ np.array([*p, 1.0])
            ndc = clip[:3] / clip[3]
            col = int((ndc[0] * 0.5 + 0.5) * SIZE[0])
            row = int((0.5 - ndc[1] * 0.5) * SIZE[1])
            pixels.append((row, col))
        shadows = renderer.shadows
        glass = None
        if shadows is not None and shadows.glass_atlas is not None:
            glass = shadows.read_glass()
        return hdr, pixels, glass
    finally:
        renderer.release()


def floor_visibility(gl, ball: dict, light: str = "directional") -> np.ndarray:
    """(probes, 3) the shadowed render over the unshadowed one at the probes."""
    lit, pixels, _ = render(gl, scene(ball, shadow=False, light=light))
    dark, _, _ = render(gl, scene(ball, light=light))
    return np.array([dark[r, c, :3] / lit[r, c, :3] for r, c in pixels])


def amber_transmittance() -> np.ndarray:
    f0 = ((1.5 - 1.0) / (1.5 + 1.0)) ** 2
    return glass_transmittance(
        AMBER["base_color"], 1.0, 0.0, f0, AMBER["thickness"],
        np.array(AMBER["attenuation_color"]), AMBER["attenuation_distance"],
    )  # fmt: skip


@pytest.mark.parametrize("light", list(LIGHTS))
def test_a_glass_sphere_s_shadow_is_lighter_and_amber(gl_egl, light):
    opaque = floor_visibility(gl_egl, OPAQUE, light)
    glass = floor_visibility(gl_egl, AMBER, light)
    want = amber_transmittance()  # 0.912, 0.672, 0.336
    assert opaque.max() < 0.05, opaque
    assert glass.mean() > opaque.mean() + 0.3, (glass, opaque)
    # tinted: red passes twice as well as blue, as the attenuation colour says
    assert np.all(glass[:, 0] > 2.0 * glass[:, 2]), glass
    # and the light is the twin's transmittance (the sun's alone: no environment)
    np.testing.assert_allclose(glass, np.broadcast_to(want, glass.shape), rtol=2e-3)


def test_the_glass_target_holds_the_twin_s_transmittance(gl_egl):
    _, _, target = render(gl_egl, scene(AMBER))
    assert target is not None
    rgb, depth = target[..., :3], target[..., 3]
    covered = depth < 1.0
    assert covered.sum() > 100  # the sphere's disc in the 512 map
    want = transmittance_product([(0.5, amber_transmittance())], 0.9)
    np.testing.assert_allclose(rgb[covered], np.broadcast_to(want, rgb[covered].shape), rtol=1e-5)
    np.testing.assert_allclose(rgb[~covered], 1.0)


def test_the_twin_s_product_and_its_receiver_test():
    a, b = np.array([0.5, 0.6, 0.7]), np.array([0.9, 0.8, 0.1])
    np.testing.assert_allclose(transmittance_product([(0.4, a), (0.6, b)], 0.7), a * b)
    np.testing.assert_allclose(transmittance_product([(0.4, a), (0.6, b)], 0.3), 1.0)
    np.testing.assert_allclose(transmittance_product([], 0.3), 1.0)
    # thin-walled clear glass: only the Fresnel share at normal incidence is lost
    clear = glass_transmittance([1.0, 1.0, 1.0], 1.0, 0.0, 0.04, 0.0, np.ones(3), 0.0)
    np.testing.assert_allclose(clear, 0.96)


def test_a_scene_without_glass_builds_no_glass_target(gl_egl):
    loaded = parse_scene(copy.deepcopy(scene(OPAQUE)), REPO / "scenes" / "t.toml")
    renderer = Renderer(gl_egl, loaded)
    try:
        renderer.render()
        assert renderer.shadows is not None
        assert renderer.shadows.glass_atlas is None
        assert "SHADOW_GLASS" not in renderer.shadows.defines()
    finally:
        renderer.release()


# --- a textured pane: its maps shape the tint as they shape the transmission pass ---

# Floor points under the pane's left (u < 0.5) and right halves, in the sun's shadow of a
# 1 m pane 1 m above the floor, centred on the origin (the sun along (-1, -1, 0) moves the
# shadow 1 m to -x), and seen past the pane by the camera.
PANE_PROBES = [(-1.3, 0.0, 0.0), (-0.7, 0.0, 0.0)]


def pane_scene(tmp_path: Path, ext: dict, texture: np.ndarray, key: str) -> dict:
    """The scene of a .glb glass pane over the floor (white, ``ext`` and a 4 x 4 nearest
    ``texture`` as its ``key`` map: "baseColorTexture" or the extension's textureInfo)."""
    from PIL import Image

    from tests.gltf_builder import GltfBuilder
    from tests.test_transmission import NEAREST

    b = GltfBuilder()
    assert b.texture(Image.fromarray(texture), NEAREST) == 0
    pbr = pygltflib.PbrMetallicRoughness(
        baseColorFactor=[1.0, 1.0, 1.0, 1.0], metallicFactor=0.0, roughnessFactor=0.0
    )
    if key == "baseColorTexture":
        pbr.baseColorTexture = pygltflib.TextureInfo(index=0)
    b.quad(b.material(pygltflib.Material(pbrMetallicRoughness=pbr, extensions=ext)))
    b.doc.extensionsUsed = list(ext)
    path = b.save(tmp_path / "pane.glb")
    data = scene(OPAQUE)
    data["camera"] = {"position": [-1.0, 5.0, 5.0], "target": [-1.0, 0.0, 0.0], "fov_y": 30.0}
    pane = {"shape": "mesh", "file": str(path), "position": [0.0, 1.0, 0.0],
            "rotation": [-90.0, 0.0, 0.0], "scale": 0.5}  # fmt: skip
    data["objects"] = [data["objects"][0], pane]
    return data


def pane_visibility(gl, tmp_path: Path, ext: dict, texture: np.ndarray, key: str) -> np.ndarray:
    """(2, 3) the floor's light at ``PANE_PROBES`` with the pane of ``pane_scene`` over it
    over the light without the pane."""
    data = pane_scene(tmp_path, ext, texture, key)
    bare = copy.deepcopy(data)
    bare["objects"] = bare["objects"][:1]
    out = []
    for d in (data, bare):
        loaded = parse_scene(copy.deepcopy(d), tmp_path / "t.toml")
        r = Renderer(gl, loaded)
        try:
            r.render()
            hdr = r.read_hdr().astype(np.float64)
            view_proj = np.asarray(r.proj, np.float64) @ np.asarray(r.view, np.float64)
        finally:
            r.release()
        values = []
        for p in PANE_PROBES:
            ndc = view_proj @ np.array([*p, 1.0])
            ndc = ndc[:3] / ndc[3]
            col, row = int((ndc[0] * 0.5 + 0.5) * SIZE[0]), int((0.5 - ndc[1] * 0.5) * SIZE[1])
            values.append(hdr[row, col, :3])
        out.append(np.array(values))
    return out[0] / out[1]


def halves(left: tuple[int, int, int], right: tuple[int, int, int]) -> np.ndarray:
    texels = np.zeros((4, 4, 3), np.uint8)
    texels[:, :2], texels[:, 2:] = left, right
    return texels


@pytest.mark.parametrize("key", ["baseColorTexture", "transmissionTexture"])
def test_a_textured_pane_tints_its_shadow_by_its_maps(gl_egl, tmp_path, key):
    """A thin white glass pane whose left half is red in its base colour map, or opaque
    (R = 0) in its transmissionTexture, casts the twin's transmittance of each half's
    texels: (0.96, 0, 0) or 0 on the left, 0.96 on the right. Fails with the pane's tint
    taken from its constants alone (0.96 on both halves)."""
    ext = {"KHR_materials_transmission": {"transmissionFactor": 1.0}}
    if key == "transmissionTexture":
        ext["KHR_materials_transmission"]["transmissionTexture"] = {"index": 0}
        texture, left = halves((0, 255, 255), (255, 0, 0)), ([1.0] * 3, 0.0)
    else:
        texture, left = halves((255, 0, 0), (255, 255, 255)), ([1.0, 0.0, 0.0], 1.0)
    seen = pane_visibility(gl_egl, tmp_path, ext, texture, key)
    want_left = glass_transmittance(left[0], left[1], 0.0, 0.04, 0.0, np.ones(3), 0.0)
    want_right = glass_transmittance([1.0] * 3, 1.0, 0.0, 0.04, 0.0, np.ones(3), 0.0)
    np.testing.assert_allclose(seen, [want_left, want_right], rtol=2e-3, atol=1e-4)


def test_a_textured_pane_s_caster_draws_with_the_transmission_pass_s_textures(gl_egl, tmp_path):
    """The pane's shadow caster samples its maps from the very GL textures the
    transmission pass draws it with (the renderer's ``glass_maps``), not a second upload.
    Fails with the caster uploading its own."""
    ext = {"KHR_materials_transmission": {"transmissionFactor": 1.0}}
    data = pane_scene(tmp_path, ext, halves((255, 0, 0), (255, 255, 255)), "baseColorTexture")
    r = Renderer(gl_egl, parse_scene(data, tmp_path / "t.toml"))
    try:
        r.render()
        (caster,) = [c for c in r.shadows.glass_casters if isinstance(c, _TexturedGlassCaster)]
        cast = {tex.glo for _, tex in caster.drawable.textures}
        drawn = {tex.glo for d in r.transmission.drawables for _, tex in d.textures}
        assert len(cast) == 1 and cast <= drawn
    finally:
        r.release()
