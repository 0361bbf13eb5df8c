"""Twin of glsl/lights/illumination.glsl and the G-buffer decode of the lighting pass: the
illumination sum over a read-back G-buffer.

``L_o(v) = pi sum_i f(l_i, v) c_light_i (n.l_i)+`` (RTR4 §9.4, eq. 9.13), in float64,
from the very G-buffer values the GPU shaded, so the comparison isolates the lighting pass.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from app.common.camera import CameraFrame
from app.common.extension_maps import FACTOR_TARGETS, scale_row
from app.common.gbuffer import GBufferData
from app.common.lights import AREA_TYPES, PunctualLight
from app.common.models import Model, ModelParams, unpack_model_params
from app.reference._vec import dot, normalize
from app.reference.area_lights import area_light_exact, area_light_term
from app.reference.cloth import CLOTH_WRAP_MIN_N_DOT_L
from app.reference.constants import PI
from app.reference.encoding import oct_decode
from app.reference.environment_uniform import uniform_environment_radiance
from app.reference.material import (
    ShadingPoint,
    Surface,
    brdf_eval,
    brdf_eval_layered_cos,
    cloth_wrapped_term,
    sanitize_direction,
    sanitize_surface,
)
from app.reference.position import reconstruct_position
from app.reference.punctual import light_at
from app.reference.shadows import ShadowMaps, face_normals, light_visibilities


def illumination_sum(
    point: ShadingPoint,
    model: Model,
    lights: list[PunctualLight],
    terms: str = "all",
    visibility: list[np.ndarray | None] | None = None,
    area: str = "ltc",
) -> np.ndarray:
    """RTR4 §9.4: pi sum_i f(l_i, v) c_light_i (n.l_i)+ at the points ``point.position``
    (..., 3); ``terms`` as in ``brdf_eval``. An empirical cloth with wrap w > 0 takes the
    light past its terminator, down to n.l = -w (RTR4 §9.10, ``cloth_wrapped_term``).
    ``point.nc``: the clear coat's normals where
    the G-buffer has them (RT4): a coated model's layers then take their own cosines
    (``brdf_eval_layered_cos``), as the GLSL does with GBUFFER_COAT_NORMAL.
    ``visibility``: per light, None or (...,) in [0, 1], the fraction of the light that
    reaches each point (a shadow; glsl/lights/illumination.glsl multiplies c_light by it
    under SHADOWS, docs/shadows.md), or (..., 3) per channel (glass in front:
    SHADOW_GLASS). An area light adds its integral over the light
    (app/reference/area_lights.py): by ``area`` "ltc" as the GLSL does, "exact" by the
    float64 integral (the ray-caster's truth)."""
    p, n = point.position, point.n
    Lo = np.zeros(np.shape(p), np.float64)
    for k, light in enumerate(lights):
        if light.type in AREA_TYPES:
            term = area_light_exact if area == "exact" else area_light_term
            Lo += term(point, model, light, terms)
            continue
        c_light, l = light_at(light, p)
        if visibility is not None and visibility[k] is not None:
            v = np.asarray(visibility[k], np.float64)
            c_light = c_light * (v if v.ndim == np.ndim(p) else v[..., None])
        if point.nc is not None and model.clearcoat != "none":
            layered = brdf_eval_layered_cos(point, model, l, terms=terms)
            Lo += layered * c_light
            continue
        NoL = dot(n, l)
        lit = NoL > 0.0
        if model.diffuse == "cloth_empirical" and float(point.params.cloth_wrap) > 0.0:
            # wrap lighting (RTR4 §9.10): the wrapped lobes' f (n.l) at and below 1e-4
            past = NoL <= CLOTH_WRAP_MIN_N_DOT_L
            lit = ~past
            wrapped = cloth_wrapped_term(point, model, NoL, terms)
            Lo += np.where(past[..., None], wrapped * c_light, 0.0)
        if not np.any(lit):
            continue
        f = brdf_eval(point, model, l, terms=terms)
        Lo += np.where(lit[..., None], f * c_light * NoL[..., None], 0.0)
    return PI * Lo


def pixel_ndc(height: int, width: int) -> np.ndarray:
    """NDC (x, y) of pixel centres, (H, W, 2), row 0 at the top of the image."""
    x = (np.arange(width) + 0.5) / width * 2.0 - 1.0
    y = 1.0 - (np.arange(height) + 0.5) / height * 2.0
    return np.stack(np.broadcast_arrays(x[None, :], y[:, None]), axis=-1)


@dataclass
class DecodedGBuffer:
    """The covered pixels of a G-buffer as the lighting pass decodes them (C of them, in
    row-major order): sanitised surface, world position, view, normal and tangent."""

    covered: np.ndarray  # (H, W) bool
    surface: Surface  # fields (C,) or (C, 3)
    material_id: np.ndarray  # (C,) int64
    p: np.ndarray  # (C, 3) world position
    v: np.ndarray  # (C, 3) unit, towards the camera
    n: np.ndarray  # (C, 3) unit normal (v where the stored normal is lost)
    t: np.ndarray  # (C, 3) tangent as stored (brdf_eval orthonormalises it)
    nc: np.ndarray | None = None  # (C, 3) unit coat normal (n where lost); None without RT4
    # (C, 4) emitted radiance and occlusion factor; None without RT5 (glTF 2.0 core)
    emission: np.ndarray | None = None
    # G-buffer factor target (app/common/extension_maps.py FACTOR_TARGETS: RT6
    # "layer_maps", RT8 "coat_film_maps") -> its (C, 4) factors on the row, sanitised; a
    # target the G-buffer lacks is not a key (the rows' numbers as they are)
    factors: dict[str, np.ndarray] = field(default_factory=dict)

    def point(self, sel: np.ndarray, params: ModelParams) -> ShadingPoint:
        """The ShadingPoint of the pixels ``sel`` picks (one material: ``params``), as the
        GLSL's decode_gbuffer returns it per pixel (with RT6 and RT8, the row's numbers
        times the pixels' factors: scale_row, SCALE_BY_GBUFFER_FACTORS's twin)."""
        for target, factors in self.factors.items():
            params = scale_row(params, target, factors[sel])
        return ShadingPoint(
            self.surface.select(sel), params, self.n[sel],
            None if self.nc is None else self.nc[sel], self.t[sel], self.v[sel], self.p[sel],
        )  # fmt: skip


def surface_positions(gbuffer: GBufferData, camera: CameraFrame) -> tuple[np.ndarray, np.ndarray]:
    """(covered (H, W) bool, world positions (C, 3) of the covered pixels, row-major): the
    view depth at each pixel centre taken back to the world (glsl/common/position.glsl)."""
    depth = gbuffer.depth
    covered = gbuffer.covered
    p = reconstruct_position(
        pixel_ndc(*depth.shape)[covered], depth[covered], camera.position,
        camera.camera_to_world, camera.tan_half_fov,
    )  # fmt: skip
    return covered, p


def decode_gbuffer(gbuffer: GBufferData, camera: CameraFrame) -> DecodedGBuffer:
    """Twin of the G-buffer decode every lighting pass runs (glsl/gbuffer/): each covered
    pixel's surface, sanitised as the GLSL sanitises it (docs/stability.md), and its
    position reconstructed from the view depth at the pixel centre."""
    covered, p = surface_positions(gbuffer, camera)
    a = np.asarray(gbuffer.base_color, np.float64)[covered]
    b = np.asarray(gbuffer.normal, np.float64)[covered]
    c = np.asarray(gbuffer.tangent, np.float64)[covered]
    s = sanitize_surface(Surface(a[:, :3], a[:, 3], b[:, 2], b[:, 3], c[:, 2]))
    v = normalize(camera.position - p)
    n = sanitize_direction(oct_decode(b[:, :2]), v)
    ids = gbuffer.material_id[covered].astype(np.int64)
    nc = None  # no RT4: every coat shades with n
    if gbuffer.coat_normal is not None:
        nc = sanitize_direction(oct_decode(np.asarray(gbuffer.coat_normal, np.float64)[covered]), n)
    emission = None  # no RT5: nothing emits, nothing is occluded
    if gbuffer.emission is not None:
        emission = np.asarray(gbuffer.emission, np.float64)[covered]
    factors = {}  # RT6, RT8 where present (GBufferData's field of each factor target)
    for target in FACTOR_TARGETS:
        stored = getattr(gbuffer, target.name) if target.gbuffer else None
        if stored is not None:
            f = np.asarray(stored, np.float64)[covered]
            factors[target.name] = np.where(np.isfinite(f), np.clip(f, 0.0, 1.0), 1.0)
    return DecodedGBuffer(covered, s, ids, p, v, n, oct_decode(c[:, :2]), nc, emission, factors)


def shade_gbuffer(
    gbuffer: GBufferData,
    camera: CameraFrame,
    lights: list[PunctualLight],
    background: np.ndarray,
    models: list[Model],
    table: np.ndarray,
    terms: str = "all",
    shadows: ShadowMaps | None = None,
    environment: tuple[np.ndarray, int] | None = None,
) -> np.ndarray:
    """The HDR image the lighting pass should produce, (H, W, 3) float64 (``terms``: the
    scene's render.terms; ``shadows``: the shadow maps read back from the GPU, whose
    visibility multiplies each shadowed light's term, app/reference/shadows.py;
    ``environment``: a uniform environment's (radiance, directions), whose light
    ``uniform_environment_radiance`` adds per pixel, times the G-buffer's occlusion factor
    (RT5; glTF 2.0: occlusion applies to indirect light)).

    ``table`` is the material table as packed for the GPU ((M, 4, 4) float32, whose row
    [3][0] is the material's index into ``models``); each pixel's row is its material id.
    """
    g = decode_gbuffer(gbuffer, camera)
    out = np.broadcast_to(np.asarray(background, np.float64), (*g.covered.shape, 3)).copy()
    shaded = np.zeros((len(g.material_id), 3))
    visibility: list[np.ndarray | None] = [None] * len(lights)
    if shadows is not None:  # offset along the geometric normal, not a mapped one
        ng = g.n
        if shadows.face_normal:
            ng = face_normals(gbuffer.depth, camera.camera_to_world, camera.tan_half_fov, g.v, g.n)
        visibility = light_visibilities(shadows, lights, g.p, ng)
    for row in np.unique(g.material_id):
        sel = g.material_id == row
        model = models[int(table[row, 3, 0])]
        point = g.point(sel, unpack_model_params(table[row]))
        shaded[sel] = illumination_sum(
            point, model, lights, terms, [None if x is None else x[sel] for x in visibility]
        )
        if environment is not None:  # after the sum, as the lighting pass adds it
            L_env = uniform_environment_radiance(
                environment[0], point, model, environment[1], terms
            )
            if g.emission is not None:
                L_env = g.emission[sel, 3:4] * L_env
            shaded[sel] += L_env
    if g.emission is not None:  # emitted radiance, once per pixel after the sum
        shaded += g.emission[:, :3]
    out[g.covered] = shaded
    return out
