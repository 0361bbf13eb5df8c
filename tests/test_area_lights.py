"""Area lights by linearly transformed cosines (docs/area_lights.md): the polygon integral
is Lambert's, the LTC twin matches the float64 truth within the stated budgets and is no
point light, and the GLSL matches its twin on a real GL frame."""

from __future__ import annotations

import math

import numpy as np
import pytest

from app.common.lights import LightType, PunctualLight
from app.common.models import DEFAULT_MODEL
from app.reference import area_lights
from app.reference.area_light_sets import ZERO, floor_points, sample_lights, unit_light
from app.reference.area_lights import (
    _hit_distance,
    _light_samples,
    area_light_exact,
    area_light_term,
    clipped_form_factor,
    light_polygon,
    polygon_sides,
    sphere_diffuse,
)
from app.reference.material import ShadingPoint
from tests.agreement import hdr_and_twin, relative_error
from tests.conftest import REPO

# Budgets (docs/area_lights.md, "Error against the truth"): the LTC's radiance against the
# exact integral, |LTC - exact| over the set's largest value, (largest, mean) per roughness.
LTC_BUDGET = {0.1: (0.03, 0.004), 0.3: (0.30, 0.03), 0.6: (0.10, 0.025), 1.0: (0.03, 0.006)}
EXACT_SAMPLES = 2048  # per strategy: the truth's noise is under 0.5 % of the largest value
TWIN_RTOL = 2e-3  # GLSL against the twin, float32 against float64 (relative, above a floor)


def _cosine_truth(light: PunctualLight, p: np.ndarray, samples: int = 200_000) -> float:
    """integral (n.l)+ dl over the light from p with n = +z, by points on its surface."""
    pts, nrm, area = _light_samples(light, samples)
    d = pts - p
    d2 = np.sum(d * d, axis=-1)
    l = d / np.sqrt(d2)[:, None]
    cos_l = -np.sum(l * nrm, axis=-1)
    hit = _hit_distance(light, p[None], l[None])[0]
    seen = (cos_l > 0.0) & (hit >= np.sqrt(d2) * (1.0 - 1e-9))
    return float(
        np.sum(np.where(seen, np.maximum(l[:, 2], 0.0) * cos_l / d2, 0.0)) * area / len(pts)
    )


def test_polygon_integral_is_lamberts_with_the_horizon_clipped() -> None:
    """The clamped-cosine integral of a rectangle (Lambert's edge formula), crossing the
    horizon or not, is the integral over its surface to 1e-3 (the sampling's noise); a
    sphere's silhouette polygon within 1 %, a tube's stadium within 3 %
    (docs/area_lights.md)."""
    rect = unit_light(LightType.RECT, [0.3, 0.2, 0.1], [0.5, 0.0, 0.0], [0.0, 0.4, 0.3])
    above = unit_light(LightType.RECT, [0.3, 0.2, 1.0], [0.5, 0.0, 0.0], [0.0, -0.3, 0.0])
    sphere = unit_light(LightType.SPHERE, [0.3, 0.2, 0.2], radius=0.4)
    tube = unit_light(LightType.TUBE, [0.3, 0.2, 0.5], [0.5, 0.2, 0.1], radius=0.1)
    for light, tol in ((rect, 1e-3), (above, 1e-3), (sphere, 1e-2), (tube, 3e-2)):
        got, _ = clipped_form_factor(light_polygon(light, np.zeros((1, 3))))
        want = _cosine_truth(light, ZERO)
        assert want > 0.05
        assert abs(got[0] - want) <= tol * want, (light.type.name, got[0], want)


def test_sphere_diffuse_closed_form_is_the_integral() -> None:
    """The sphere's clamped-cosine integral in closed form (Snyder 1996) is the integral
    over its visible surface to 2e-3, wholly above the horizon, crossing it (its centre a
    little above and a little below) and mostly below; and the direction the diffuse model
    is taken at is never below the horizon."""
    n = np.array([[0.0, 0.0, 1.0]])
    for centre, radius in (
        ([0.3, 0.2, 0.8], 0.3),  # wholly above
        ([0.9, 0.1, 0.15], 0.4),  # crossing, centre above
        ([0.8, -0.3, -0.1], 0.35),  # crossing, centre below
        ([0.2, 0.5, -0.3], 0.5),  # mostly below
    ):
        light = unit_light(LightType.SPHERE, centre, radius=radius)
        got, l_rep = sphere_diffuse(light, np.zeros((1, 3)), n)
        want = _cosine_truth(light, ZERO)
        assert want > 0.01
        assert abs(got[0] - want) <= 2e-3 * max(want, 0.1), (centre, got[0], want)
        assert l_rep[0, 2] >= 0.0


# The LTC at polygon_sides' count against a 96-gon's (the circle's), relative to the set's
# largest value, per roughness band (docs/area_lights.md, "Polygon sides"): 24 sides
# below 0.15, 12 to 0.25, 8 above.
SIDES_BUDGET = {0.05: 0.07, 0.1: 0.012, 0.2: 0.004, 0.3: 0.008, 0.6: 0.001}


@pytest.mark.parametrize("roughness", sorted(SIDES_BUDGET))
def test_polygon_sides_by_roughness_keep_the_circle(roughness: float) -> None:
    """A disk's and a sphere's specular lobe with the sides ``polygon_sides`` gives them is
    within SIDES_BUDGET of the 96-gon's at each roughness (8 sides everywhere fails the
    smooth bands)."""
    point = floor_points(roughness, 64)
    assert len(np.unique(polygon_sides(np.full(64, roughness)))) == 1
    for light in sample_lights()[1:3]:
        got = area_light_term(point, DEFAULT_MODEL, light, terms="specular")
        fine = area_light_term(point, DEFAULT_MODEL, light, terms="specular", sides=96)
        err = np.abs(got - fine).max() / fine.max()
        assert err <= SIDES_BUDGET[roughness], (light.type.name, err)


def test_polygon_sides_follow_a_smoother_clear_coat() -> None:
    """A smooth coat (0.05) over a rough base (0.6) takes the coat's sides: the coated
    specular lobes over a sphere light within SIDES_BUDGET[0.05] of the 96-gon's (the
    base's 8 sides miss it sevenfold)."""
    from dataclasses import replace

    model = replace(DEFAULT_MODEL, clearcoat="filament")
    point = floor_points(0.6, 64)
    point = replace(point, params=replace(point.params, clearcoat=1.0, clearcoat_roughness=0.05))
    sphere = sample_lights()[2]
    got = area_light_term(point, model, sphere, terms="specular")
    fine = area_light_term(point, model, sphere, terms="specular", sides=96)
    err = np.abs(got - fine).max() / fine.max()
    assert err <= SIDES_BUDGET[0.05], err


@pytest.mark.parametrize("roughness", sorted(LTC_BUDGET))
def test_ltc_matches_the_exact_integral(roughness: float) -> None:
    """Every shape's LTC radiance on a dielectric floor against the float64 integral over
    the light (both strategies, balance heuristic), within the roughness band's budget,
    relative to the set's largest value. A point light of the same power at the centre
    fails it (test_a_point_light_is_not_an_area_light)."""
    point = floor_points(roughness)
    top, mean = LTC_BUDGET[roughness]
    for light in sample_lights():
        got = area_light_term(point, DEFAULT_MODEL, light)
        want = area_light_exact(point, DEFAULT_MODEL, light, samples=EXACT_SAMPLES)
        err = np.abs(got - want) / want.max()
        assert err.max() <= top and err.mean() <= mean, (light.type.name, err.max(), err.mean())


# The clear coat over area lights (docs/area_lights.md, "The clear coat"): (largest, mean)
# |LTC - exact| over the set's largest value, a coated metal at base roughness 0.6 and
# coat roughness 0.15, Filament's coat model.
COAT_BUDGET = (0.08, 0.015)


def test_clear_coat_lobe_over_area_lights() -> None:
    """A coated surface's LTC radiance (the coat's own lobe, a second LTC at the coat's
    roughness, plus the base's lobes weighted through the coat) against the exact integral
    of the whole coated BRDF, every shape, within COAT_BUDGET; the same without the coat's
    lobe misses it by far."""
    from dataclasses import replace

    model = replace(DEFAULT_MODEL, clearcoat="filament")
    point = floor_points(0.6)
    point = replace(
        point,
        s=replace(point.s, metallic=np.ones(16), base_color=np.tile([0.7, 0.05, 0.03], (16, 1))),
        params=replace(point.params, clearcoat=1.0, clearcoat_roughness=0.15),
    )
    top, mean = COAT_BUDGET
    bare_fails = []
    for light in sample_lights():
        want = area_light_exact(point, model, light, samples=EXACT_SAMPLES)
        got = area_light_term(point, model, light)
        err = np.abs(got - want) / want.max()
        assert err.max() <= top and err.mean() <= mean, (light.type.name, err.max(), err.mean())
        bare = got - area_lights.coat_lobe(point, light_polygon(light, point.position))[:, None]
        bare_err = np.abs(bare - want) / want.max()
        bare_fails.append(bare_err.max() > top or bare_err.mean() > mean)
    assert all(bare_fails), bare_fails


def test_a_point_light_is_not_an_area_light(monkeypatch: pytest.MonkeyPatch) -> None:
    """The budget is tight enough to tell: the rectangle's term replaced by a point light of
    its power at its centre misses the exact integral by more than the budget."""
    rect = sample_lights()[0]
    point = floor_points(0.3)

    def as_point(sp: ShadingPoint, model, light, terms="all") -> np.ndarray:
        from app.reference.material import brdf_eval

        d = light.position - sp.position
        d2 = np.sum(d * d, axis=-1)
        l = d / np.sqrt(d2)[:, None]
        power = light.color * 4.0 * np.linalg.norm(light.axis_u) * np.linalg.norm(light.axis_v)
        cos_l = np.abs(l @ np.cross(light.axis_u, light.axis_v)) / np.linalg.norm(
            np.cross(light.axis_u, light.axis_v)
        )
        nol = np.maximum(np.sum(l * sp.n, axis=-1), 0.0)
        return brdf_eval(sp, model, l) * power * (nol * cos_l / d2)[:, None] / math.pi

    want = area_light_exact(point, DEFAULT_MODEL, rect, samples=EXACT_SAMPLES)
    monkeypatch.setattr(area_lights, "area_light_term", as_point)
    got = area_lights.area_light_term(point, DEFAULT_MODEL, rect)
    err = np.abs(got - want) / want.max()
    assert err.max() > LTC_BUDGET[0.3][0] or err.mean() > LTC_BUDGET[0.3][1]


@pytest.mark.gl
def test_glsl_area_lights_match_their_twin(gl_egl) -> None:
    """A frame with one light of each shape over a floor and a metal sphere, culled by
    tiles: the lighting pass's HDR against the twin's shading of the same G-buffer, within
    TWIN_RTOL (float32 against float64)."""
    from app.render.inputs import AREA_LIGHTS, TILES
    from app.render.renderer import Renderer
    from app.scene.loader import parse_scene

    data = {
        "camera": {"position": [0, 2.5, 4], "target": [0, 0.3, 0], "fov_y": 45.0},
        "render": {"gbuffer": "f32", "antialiasing": "none", "light_culling": "tiled"},
        "materials": {
            "floor": {"base_color": [0.5, 0.5, 0.5], "roughness": 0.2},
            "metal": {"base_color": [0.9, 0.6, 0.3], "metallic": 1.0, "roughness": 0.4},
            "coated": {"base_color": [0.7, 0.05, 0.03], "metallic": 1.0, "roughness": 0.5,
                       "clearcoat": 1.0, "clearcoat_roughness": 0.1,
                       "clearcoat_color": [0.95, 0.8, 0.55]},
        },
        "objects": [
            {"shape": "plane", "size": [8, 8], "material": "floor"},
            {"shape": "sphere", "radius": 0.4, "position": [-0.6, 0.4, 0], "material": "metal"},
            {"shape": "sphere", "radius": 0.3, "position": [0.5, 0.3, 0.6], "material": "coated"},
        ],
        "lights": [
            {"type": "rect", "position": [0.8, 1.2, 0], "direction": [0, -1, 0.2],
             "size": [1.0, 0.4], "intensity": 2.0},
            {"type": "disk", "position": [-1.0, 1.4, -0.6], "direction": [0.2, -1, 0.3],
             "radius": 0.3, "intensity": 2.0},
            {"type": "sphere", "position": [0.0, 0.9, 0.9], "radius": 0.15, "intensity": 1.0},
            {"type": "tube", "position": [0.0, 1.6, -1.0], "direction": [1, 0, 0],
             "radius": 0.04, "length": 1.5, "intensity": 2.0},
        ],
    }  # fmt: skip
    loaded = parse_scene(data, REPO / "inline.toml")
    r = Renderer(gl_egl, loaded, (96, 64))
    try:
        hdr, ref, g = hdr_and_twin(r, loaded.scene.background)
        # through the tile masks, with the area input's table compiled in
        assert TILES in r.shading and AREA_LIGHTS in r.shading
        assert r.shading.defines()["AREA_LIGHTS"] == 1
    finally:
        r.release()
    sel = g.covered
    err = relative_error(hdr[sel], ref[sel], floor=0.02 * ref[sel].max())
    assert ref[sel].max() > 0.1
    assert err.max() <= TWIN_RTOL, err.max()


def test_area_light_keys_are_checked() -> None:
    """Each shape needs its size keys, refuses the others' and a shadow map, one line
    naming the key; the viewer's new lights (AREA_LIGHT_DEFAULTS) are valid as they are."""
    from app.errors import InputError
    from app.scene.loader import parse_scene
    from app.viewer.window import AREA_LIGHT_DEFAULTS

    def scene(light: dict) -> dict:
        return {"materials": {"m": {}}, "objects": [{"shape": "sphere", "material": "m"}],
                "lights": [light]}  # fmt: skip

    bad = [
        ({"type": "rect", "position": [0, 1, 0], "direction": [0, -1, 0]}, "size"),
        ({"type": "sphere", "position": [0, 1, 0], "radius": 0.1, "size": [1, 1]}, "size"),
        ({"type": "tube", "position": [0, 1, 0], "direction": [1, 0, 0], "radius": 0.1}, "length"),
        ({"type": "disk", "position": [0, 1, 0], "direction": [0, -1, 0], "radius": 0.2,
          "shadow": True}, "shadow"),
    ]  # fmt: skip
    for light, key in bad:
        with pytest.raises(InputError, match=key):
            parse_scene(scene(light), REPO / "inline.toml")
    for kind, keys in AREA_LIGHT_DEFAULTS.items():
        light = {"type": kind, "position": [0, 2, 0], **keys}
        if kind != "sphere":
            light["direction"] = [0.0, -1.0, -0.2]
        parse_scene(scene(light), REPO / "inline.toml")
