"""The glTF 2.0 core material in the renderer (issue 17): emission, occlusion, alpha mask
and sampler wrap modes, on scenes built from TOML keys, with the real GLSL.

Each test renders a plane seen from above (u along +x, v along the image's rows) with and
without the feature and checks the difference is exactly what glTF 2.0 specifies; the
lighting pass is also held to its float64 twin (app/reference/illumination.py) with the
new G-buffer channel (RT5) read back.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

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
            r._build_gbuffer_pass()  # upload the map again with its new sampler state
        r.render()
        g = r.read_gbuffer()
        ref = shade_gbuffer(
            g, r.camera, r.lights, np.zeros(3), r.materials.models, r.materials.packed()
        )
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


def test_occlusion_darkens_only_the_environment(gl, tmp_path):
    """glTF 2.0: occlusion applies to indirect light. With an occlusion map of 0 and
    strength 0.75 (factor 1 + 0.75 (0 - 1) = 0.25) the environment's part of the image
    scales by 0.25 and a point light's part is unchanged, bit for bit."""
    ao = {
        "occlusion_map": save(tmp_path, "ao.png", np.zeros((8, 8, 3))),
        "occlusion_strength": 0.75,
    }
    env, _, _ = render(gl, scene_data({}, [], environment=True), tmp_path)
    env_ao, g_env, _ = render(gl, scene_data(ao, [], environment=True), tmp_path)
    point, _, _ = render(gl, scene_data({}, [POINT]), tmp_path)
    point_ao, _, _ = render(gl, scene_data(ao, [POINT]), tmp_path)
    both_ao, g, ref = render(gl, scene_data(ao, [POINT], environment=True), tmp_path)
    covered = g.covered
    assert covered.all()
    np.testing.assert_array_equal(g_env.emission[..., 3], 0.25)
    np.testing.assert_array_equal(g_env.emission[..., :3], 0.0)  # occlusion emits nothing
    assert env[covered].min() > 0.0
    np.testing.assert_allclose(env_ao[covered], 0.25 * env[covered], rtol=1e-6)
    np.testing.assert_array_equal(point_ao, point)
    np.testing.assert_allclose(both_ao[covered], (0.25 * env + point)[covered], rtol=1e-5)
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
    # "opaque" ignores alpha; "blend" is drawn opaque until a forward pass exists.
    for mode in ("opaque", "blend"):
        material = {"base_color_map": base, "alpha": alpha, "alpha_mode": mode}
        _, g, _ = render(gl, scene_data(material, [SUN]), tmp_path)
        assert g.covered.all()


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
