"""Shadow maps (issue 18, app/render/shadows.py, glsl/lights/shadows.glsl) against the
float64 ray-caster's shadow rays (app/reference/raycast.py light_visibility).

The GPU's visibility of one light at a pixel is read as the ratio of two renders of a
scene lit by that light alone, with and without ``shadow = true`` (a shadowed light's term
is its unshadowed term times its visibility); lit means a ratio over 0.5. The reference's
is its shadow ray through the same pixel centre. Numbers: docs/shadows.md.
"""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

from app.cli import main
from app.errors import EXIT_BAD_INPUT, InputError
from app.frame.camera import camera_frame
from app.frame.lights import frame_lights
from app.frame.raycast import primitive
from app.reference.illumination import decode_gbuffer, shade_gbuffer
from app.reference.raycast import cast, interior_mask, shadow_visibility
from app.reference.shadows import light_visibilities
from app.render.renderer import Renderer
from app.render.shadows import atlas_layout, check_shadow_resolutions
from app.scene.loader import LoadedScene, load_scene, parse_scene

REPO = Path(__file__).resolve().parent.parent
SIZE = (160, 96)
RADIUS = 0.5
SUN = {"type": "directional", "direction": [-1.0, -0.6, -0.3], "intensity": 2.0}
SPOT = {
    "type": "spot", "position": [0.8, 3.0, 1.2], "direction": [-0.1, -1.0, -0.2],
    "intensity": 12.0, "range": 8.0, "inner_angle": 30.0, "outer_angle": 40.0,
}  # fmt: skip
POINT = {"type": "point", "position": [0.9, 2.0, 0.9], "intensity": 10.0, "range": 9.0}
SPHERES = [
    {"shape": "sphere", "radius": RADIUS, "position": [-0.8, RADIUS, 0.0], "material": "m"},
    {"shape": "sphere", "radius": 0.35, "position": [0.7, 0.8, -0.4], "material": "m"},
]
FLOOR = {"shape": "plane", "size": [8.0, 8.0], "material": "m"}


def scene_data(objects: list[dict], light: dict, camera: dict | None = None) -> dict:
    cam = camera or {"position": [0.0, 2.5, 5.0], "target": [0.0, 0.3, 0.0], "fov_y": 40.0}
    return {
        "render": {"width": SIZE[0], "height": SIZE[1]},
        "camera": cam,
        "materials": {"m": {"base_color": [0.8, 0.8, 0.8], "roughness": 0.6}},
        "objects": objects,
        "lights": [light],
    }


def loaded(data: dict) -> LoadedScene:
    return parse_scene(copy.deepcopy(data), REPO / "scenes" / "t.toml")


def render_hdr(gl, data: dict) -> tuple[np.ndarray, float]:
    """The HDR image and the world size of the first shadow map's texel (0 without)."""
    renderer = Renderer(gl, loaded(data))
    try:
        renderer.render()
        texel = renderer.shadows.texels[0] if renderer.shadows is not None else 0.0
        return renderer.read_hdr().astype(np.float64), texel
    finally:
        renderer.release()


def gpu_visibility(gl, data: dict, **shadow: object) -> tuple[np.ndarray, np.ndarray, float]:
    """(ratio of the shadowed to the unshadowed render, where the unshadowed one is lit,
    the shadow map's texel size)."""
    plain, _ = render_hdr(gl, data)
    shadowed = copy.deepcopy(data)
    shadowed["lights"][0].update(shadow=True, **shadow)
    dark, texel = render_hdr(gl, shadowed)
    lum, lum_plain = dark.sum(axis=-1), plain.sum(axis=-1)
    lit = lum_plain > 1e-3 * lum_plain.max()
    return np.where(lit, lum / np.maximum(lum_plain, 1e-30), 1.0), lit, texel


def reference_visibility(data: dict) -> tuple[np.ndarray, np.ndarray, object]:
    """(visibility, primitive ids, hits) of the ray-caster at the renderer's pixel centres."""
    scene = loaded(data).scene
    prims = [primitive(i, obj) for i, obj in enumerate(scene.objects)]
    hits = cast(prims, camera_frame(scene.camera, *SIZE), SIZE)
    light = dict(scene.lights[0].model_dump(), shadow=True)
    lights = frame_lights([type(scene.lights[0]).model_validate(light)])
    return shadow_visibility(prims, hits, lights)[0], hits.ids, hits


def away_from_boundaries(vis: np.ndarray, ids: np.ndarray, margin: int) -> np.ndarray:
    """Pixels whose (2 margin + 1)^2 neighbourhood shows one primitive and one reference
    shadow state: the reference's penumbra-free interior, eroded by ``margin`` pixels."""
    state = np.where(ids >= 0, ids * 2 + (vis > 0.5), -1)
    return interior_mask(state, margin)


FAR_POINT = dict(POINT, range=1e5)  # a near plane of range / 1000 = 100 m would see nothing


@pytest.mark.parametrize(
    "light", [SUN, SPOT, POINT, FAR_POINT], ids=["directional", "spot", "point", "range 1e5"]
)
def test_lit_and_unlit_pixels_match_the_ray_caster_away_from_the_boundary(gl_egl, light):
    data = scene_data([FLOOR, *SPHERES], light)
    ratio, lit, _ = gpu_visibility(gl_egl, data, shadow_resolution=1024)
    vis, ids, _ = reference_visibility(data)
    region = away_from_boundaries(vis, ids, margin=2) & lit
    shadowed = vis[region] < 0.5
    assert shadowed.sum() > 60 and (~shadowed).sum() > 2000  # both states are tested
    wrong = (ratio[region] > 0.5) != (vis[region] > 0.5)
    assert wrong.mean() == 0.0, f"{wrong.sum()} of {region.sum()} pixels differ"


def test_no_acne_on_a_flat_floor_at_a_grazing_light(gl_egl):
    """A floor alone under a light 8 degrees above the horizon: nothing may shadow it."""
    light = {"type": "directional", "direction": [-1.0, -0.1405, 0.0], "intensity": 3.0}
    data = scene_data([FLOOR], light, {"position": [0.0, 1.5, 4.0], "target": [0, 0, 0]})
    ratio, lit, _ = gpu_visibility(gl_egl, data)
    assert lit.sum() > 0.5 * lit.size
    unlit = ratio[lit] < 0.999
    assert unlit.sum() == 0, f"{unlit.sum()} of {lit.sum()} floor pixels in shadow"


@pytest.mark.parametrize("light", [SUN, SPOT, POINT], ids=["directional", "spot", "point"])
def test_no_acne_on_the_lit_side_of_the_spheres(gl_egl, light):
    """Sphere pixels the ray-caster sees lit (2 px from any edge) keep 99 % of their light:
    on curved receivers either bias alone leaves acne (slope only: 105 of 265 pixels under
    the directional light; normal offset only: 39), the default pair none."""
    data = scene_data([FLOOR, *SPHERES], light)
    ratio, lit, _ = gpu_visibility(gl_egl, data, shadow_resolution=1024)
    vis, ids, _ = reference_visibility(data)
    region = away_from_boundaries(vis, ids, margin=2) & lit & (vis > 0.5) & (ids > 0)
    assert region.sum() > 200
    darkened = ratio[region] < 0.99
    assert darkened.sum() == 0, f"{darkened.sum()} of {region.sum()} lit sphere pixels"


def test_no_peter_panning_at_a_sphere_contact(gl_egl):
    """A sphere touching the floor under a 45-degree sun, seen from low down on the
    shadow's side: no floor pixel near the contact that the ray-caster puts in shadow by
    more than one shadow texel is lit on the GPU (a slope bias of 100 leaves 14 texels)."""
    light = {"type": "directional", "direction": [-1.0, -1.0, 0.0], "intensity": 2.0}
    sphere = dict(SPHERES[0], position=[0.0, RADIUS, 0.0])
    cam = {"position": [-2.2, 0.9, 1.6], "target": [-0.2, 0.1, 0.0], "fov_y": 40.0}
    data = scene_data([FLOOR, sphere], light, cam)
    ratio, lit, texel = gpu_visibility(gl_egl, data, shadow_resolution=1024)
    _, ids, hits = reference_visibility(data)
    # The shadow on the floor of a sphere of centre c under a light along u: the points
    # whose line towards the light passes within RADIUS of c; RADIUS - that distance is
    # how deep a point lies inside the shadow (metres on the floor, at least).
    u = -np.asarray(light["direction"]) / np.linalg.norm(light["direction"])
    rel = hits.p - np.array([0.0, RADIUS, 0.0])
    depth = RADIUS - np.linalg.norm(rel - (rel @ u)[..., None] * u, axis=-1)
    near_contact = (ids == 0) & (np.linalg.norm(hits.p, axis=-1) < 1.5 * RADIUS) & lit
    inside = near_contact & (depth > 0.0)
    assert inside.sum() > 100
    gap = depth[inside & (ratio > 0.5)]
    worst = float(gap.max()) / texel if gap.size else 0.0
    assert worst <= 1.0, f"lit {worst:.2f} shadow texels inside the shadow at the contact"


# The lookup's float32 error: a texel position of a 2048 map resolves to about 1e-4 texel,
# which moves a PCF weight by as much; in a deep penumbra (visibility 0.035) that is 1.9e-4
# of the pixel (measured on scenes/shadows.toml at 320x180, one pixel over 1e-4).
TWIN_MAX_REL_ERR = 5e-4


@pytest.mark.parametrize("shadow_filter", ["pcf", "none"])
def test_lighting_pass_matches_its_twin_with_the_shadow_maps(gl_egl, shadow_filter):
    """glsl/lights/shadows.glsl against app/reference/shadows.py on the maps read back:
    the whole lighting pass of scenes/shadows.toml, pixel for pixel."""
    scene = load_scene(REPO / "scenes" / "shadows.toml")
    lights = [
        x.model_copy(update={"shadow_filter": shadow_filter}) if x.shadow else x
        for x in scene.scene.lights
    ]
    scene = LoadedScene(scene.scene.model_copy(update={"lights": lights}), scene.path)
    r = Renderer(gl_egl, scene, (320, 180))
    try:
        r.render()
        hdr, g, maps = r.read_hdr().astype(np.float64), r.read_gbuffer(), r.shadows.read()
        ref = shade_gbuffer(
            g, r.camera, r.lights, scene.scene.background, r.materials.models,
            r.materials.packed(), shadows=maps,
        )  # fmt: skip
        d = decode_gbuffer(g, r.camera)
        vis = [v for v in light_visibilities(maps, r.lights, d.p, d.n) if v is not None]
    finally:
        r.release()
    # the sun, the spot and the point light (six faces) all shadow something
    assert len(vis) == 3 and all((v == 0.0).sum() > 500 for v in vis)
    if shadow_filter == "pcf":
        assert sum(((v > 0.0) & (v < 1.0)).sum() for v in vis) > 1000  # penumbrae tested
    covered = g.depth > 0.0
    peak = ref[covered].max()
    rel = np.abs(hdr - ref)[covered] / np.maximum(ref[covered], 1e-3 * peak)
    assert rel.max() <= TWIN_MAX_REL_ERR, f"max relative error {rel.max():.2e}"


def test_scene_keys_are_validated():
    def bad(light: dict, message: str) -> None:
        with pytest.raises(InputError, match=message):
            loaded(scene_data([FLOOR], light))

    bad(dict(SUN, shadow_resolution=512), "shadow_resolution: needs shadow = true")
    bad(dict(SPOT, outer_angle=85.0, shadow=True), "covers an outer_angle up to 80")
    bad(dict(SUN, shadow=1), "shadow")
    bad(dict(SUN, shadow=True, shadow_filter="pcss"), "shadow_filter")


def test_a_dumped_scene_validates_again():
    """Renderer edits re-validate ``model_dump()`` (every key written): a light without
    shadows, whose shadow keys are then present at their defaults, stays valid."""
    scene = loaded(scene_data([FLOOR], SPOT)).scene
    again = type(scene).model_validate(scene.model_dump())
    assert again.lights == scene.lights and not again.lights[0].shadow


def test_the_atlas_packs_maps_in_rows_no_wider_than_the_limit():
    origins, width, height = atlas_layout([2048, 2048, 1024, 1024, 1024], 4096)
    assert origins == [(0, 0), (2048, 0), (0, 2048), (1024, 2048), (2048, 2048)]
    assert (width, height) == (4096, 3072)


def test_a_point_light_s_six_faces_count_against_the_limit(gl_egl):
    """Six faces of half the GL's largest texture need three rows of two: refused."""
    limit = gl_egl.ctx.info["GL_MAX_TEXTURE_SIZE"]
    light = dict(POINT, shadow=True, shadow_resolution=limit // 2)
    scene = loaded(scene_data([FLOOR], light)).scene
    with pytest.raises(InputError, match=r"lights\[0\]\.shadow_resolution: 6 maps"):
        check_shadow_resolutions(gl_egl.ctx, scene.lights, "t.toml")


def test_a_resolution_past_the_gl_limit_is_refused_naming_the_key(gl_egl):
    data = scene_data([FLOOR], dict(SUN, shadow=True, shadow_resolution=1 << 20))
    with pytest.raises(InputError, match=r"lights\[0\]\.shadow_resolution"):
        check_shadow_resolutions(gl_egl.ctx, loaded(data).scene.lights, "t.toml")
    with pytest.raises(InputError, match=r"lights\[0\]\.shadow_resolution"):
        Renderer(gl_egl, loaded(data))


def test_pbs_render_exits_2_naming_the_key(tmp_path, capsys):
    """The scene file's spot (its third light) asks for a map past any GL's texture size."""
    text = (REPO / "scenes" / "shadows.toml").read_text()
    spot = "outer_angle = 35.0\nshadow = true\n"
    assert text.count(spot) == 1
    path = tmp_path / "big.toml"
    path.write_text(text.replace(spot, spot + "shadow_resolution = 1000000\n"))
    capsys.readouterr()
    rc = main(["render", str(path), "-o", str(tmp_path / "out.png")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == EXIT_BAD_INPUT
    assert len(err) == 1 and "lights[2].shadow_resolution" in err[0], err
    assert not (tmp_path / "out.png").exists()
