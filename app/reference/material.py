"""Twin of glsl/brdf/material.glsl: the metallic-roughness material and its BRDF under a
``Model``. Each branch below mirrors one preprocessor branch of the GLSL, in the same
order of operations, so GLSL and twin differ only by float32 rounding."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from app.common.models import (
    BRDF_TERMS,
    DEFAULT_MODEL,
    TERM_DIFFUSE,
    TERM_SPECULAR,
    Model,
    ModelParams,
)
from app.reference import (
    clearcoat,
    cloth,
    diffraction,
    diffuse,
    fiber,
    fresnel,
    masking,
    thin_film,
)
from app.reference._vec import dot
from app.reference.constants import MIN_N_DOT_L, MIN_N_DOT_V, MIN_PERCEPTUAL_ROUGHNESS
from app.reference.specular import D_selected, D_selected_aniso, G2_selected, Lambda_selected


@dataclass
class Surface:
    """Decoded G-buffer values; each field broadcasts (base_color has a last axis of 3)."""

    base_color: np.ndarray
    metallic: np.ndarray
    perceptual_roughness: np.ndarray
    f0_dielectric: np.ndarray
    anisotropy: np.ndarray | float = 0.0

    def select(self, sel: np.ndarray) -> Surface:
        """The points ``sel`` picks out of per-point fields (scalars are kept)."""

        def pick(x: np.ndarray | float) -> np.ndarray | float:
            return x[sel] if np.ndim(x) else x

        return Surface(
            pick(self.base_color), pick(self.metallic), pick(self.perceptual_roughness),
            pick(self.f0_dielectric), pick(self.anisotropy),
        )  # fmt: skip


@dataclass(frozen=True)
class ShadingPoint:
    """One point (or array of points) being shaded: what the composition layer of the BRDF,
    the lights and the environments takes, whole. Twin of the GLSL's ``ShadingPoint``
    (glsl/brdf/material.glsl), same fields; the vectors broadcast like every twin's arrays
    (last axis 3). The model stays an argument of its own, as in the GLSL, where it is
    compile-time constants.

    ``nc`` None: no coat normal of its own (the GLSL without GBUFFER_COAT_NORMAL, where nc
    is n); the coat shades with n and the lights take one cosine. ``position`` None: a
    BRDF-only probe with no place in a scene (the lights need one)."""

    s: Surface  # sanitised where it came from a G-buffer
    params: ModelParams  # the material's numbers (one material: scalars and RGB)
    n: np.ndarray  # unit shading normal
    nc: np.ndarray | None  # unit clear-coat normal, or None (n)
    t: np.ndarray  # tangent as stored; orthonormal_tangent takes it against n
    v: np.ndarray  # unit, from the point towards the eye
    position: np.ndarray | None = None  # world position


# --- sanitising what a G-buffer texel delivers (see the GLSL for why and where) ---

# (lo, hi, fallback) of each Surface field: finite values are clamped to [lo, hi], NaN and
# +-Inf become the fallback.
SANITIZE_BASE_COLOR = (0.0, 1.0, 0.0)
SANITIZE_METALLIC = (0.0, 1.0, 0.0)
SANITIZE_ROUGHNESS = (0.0, 1.0, 1.0)
SANITIZE_F0 = (0.0, 1.0, 0.04)
SANITIZE_ANISOTROPY = (-1.0, 1.0, 0.0)


def is_finite(x: np.ndarray) -> np.ndarray:
    """True unless x is NaN or +-Inf (the GLSL reads the exponent bits)."""
    return np.isfinite(np.asarray(x, np.float64))


def sanitize_value(x: np.ndarray, lo: float, hi: float, fallback: float) -> np.ndarray:
    """x clamped to [lo, hi]; ``fallback`` where x is NaN or +-Inf."""
    x = np.asarray(x, np.float64)
    with np.errstate(invalid="ignore"):
        return np.where(is_finite(x), np.clip(x, lo, hi), fallback)


def sanitize_surface(s: Surface) -> Surface:
    """Every field clamped to its valid range, non-finite values replaced by the fallbacks:
    base colour 0, metallic 0, roughness 1 (the flattest lobe), F0 0.04, anisotropy 0."""
    return Surface(
        sanitize_value(s.base_color, *SANITIZE_BASE_COLOR),
        sanitize_value(s.metallic, *SANITIZE_METALLIC),
        sanitize_value(s.perceptual_roughness, *SANITIZE_ROUGHNESS),
        sanitize_value(s.f0_dielectric, *SANITIZE_F0),
        sanitize_value(s.anisotropy, *SANITIZE_ANISOTROPY),
    )


def sanitize_direction(d: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    """d normalised, or ``fallback`` (unit) where d has a non-finite component or |d|^2 is
    not in (1e-12, inf) (in float32, as the GLSL squares it)."""
    d = np.asarray(d, np.float64)
    fallback = np.broadcast_to(np.asarray(fallback, np.float64), d.shape)
    finite = np.all(is_finite(d), axis=-1)
    safe = np.where(finite[..., None], d, 0.0)
    len2 = dot(safe, safe)
    ok = finite & (len2 > 1e-12) & (len2 <= float(np.finfo(np.float32).max))
    with np.errstate(divide="ignore", invalid="ignore"):
        unit = safe / np.sqrt(len2)[..., None]
    return np.where(ok[..., None], unit, fallback)


def material_F0(s: Surface, p: ModelParams) -> np.ndarray:
    """glTF 2.0 Appendix B; Burley 2012: F0 = mix(f0_dielectric specular_color, base_color,
    metallic); the material's specular_color (glTF KHR_materials_specular) colours the
    dielectric's F0, white leaves it f0_dielectric."""
    m = np.asarray(s.metallic, np.float64)[..., None]
    f0 = np.asarray(s.f0_dielectric, np.float64)[..., None] * np.asarray(
        p.specular_color, np.float64
    )
    return f0 * (1.0 - m) + np.asarray(s.base_color, np.float64) * m


def material_rho_ss(s: Surface) -> np.ndarray:
    """rho_ss = (1 - metallic) base_color."""
    return (1.0 - np.asarray(s.metallic, np.float64))[..., None] * np.asarray(
        s.base_color, np.float64
    )


def material_alpha(s: Surface) -> np.ndarray:
    """alpha = r^2 (Burley 2012), r floored at MIN_PERCEPTUAL_ROUGHNESS."""
    r = np.maximum(np.asarray(s.perceptual_roughness, np.float64), MIN_PERCEPTUAL_ROUGHNESS)
    return r * r


def _mix(a: np.ndarray, b: np.ndarray, t: np.ndarray) -> np.ndarray:
    t = np.asarray(t, np.float64)[..., None]
    return a * (1.0 - t) + b * t


def F_base_selected(point: ShadingPoint, model: Model, LoH: np.ndarray) -> np.ndarray:
    """F(h, l) of the model's Fresnel term, (..., 3)."""
    s, p = point.s, point.params
    if model.fresnel == "schlick_generalized":
        return fresnel.F_schlick_generalized(material_F0(s, p), p.f90, p.fresnel_exponent, LoH)
    if model.fresnel in ("dielectric", "conductor"):
        dielectric = np.asarray(fresnel.F_dielectric(p.eta_dielectric, LoH), np.float64)
        dielectric = np.broadcast_to(dielectric[..., None], (*dielectric.shape, 3))
        metal = (
            fresnel.F_schlick(s.base_color, LoH)
            if model.fresnel == "dielectric"
            else fresnel.F_conductor(p.eta, p.k, LoH)
        )
        return _mix(dielectric, metal, s.metallic)
    if model.internal:
        return fresnel.F_schlick(
            material_F0(s, p), fresnel.cos_theta_schlick(p.eta_dielectric, LoH)
        )
    return fresnel.F_schlick(material_F0(s, p), LoH)


# --- thin film (RTR4 §9.11) ---


def _smoothstep(e0: float, e1: float, x: np.ndarray) -> np.ndarray:
    t = np.clip((np.asarray(x, np.float64) - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def F_film_selected(
    point: ShadingPoint, model: Model, LoH: np.ndarray, F_base: np.ndarray
) -> np.ndarray:
    """The thin film over the material's base (see the GLSL): the dielectric part's index
    eta_dielectric, the metal part's the conductor's eta + i k or the F0 of base_color as a
    real index, mixed by metallic, faded in over F_base up to FILM_FADE_NM and weighed by
    the film's strength film_factor."""
    s, p = point.s, point.params
    LoH = np.asarray(LoH, np.float64)
    film = (p.film_eta, p.film_ior, p.film_thickness)
    zero = np.zeros(3)
    dielectric = thin_film.F_thin_film(*film, np.full(3, p.eta_dielectric), zero, LoH)
    if model.fresnel == "conductor":
        metal_eta, metal_k = p.eta, p.k
    else:
        metal_eta = thin_film.ior_from_f0_rgb(s.base_color)
        metal_k = np.zeros_like(metal_eta)
    metal = thin_film.F_thin_film(*film, metal_eta, metal_k, LoH)
    fade = _smoothstep(0.0, thin_film.FILM_FADE_NM, p.film_thickness)
    # film_factor: glTF iridescenceFactor, the film's strength
    return _mix(F_base, _mix(dielectric, metal, s.metallic), fade * np.asarray(p.film_factor))


def F_selected(point: ShadingPoint, model: Model, LoH: np.ndarray) -> np.ndarray:
    """F(h, l) of the material: the base's (F_base_selected), or with ``model.thin_film``
    a thin film's over it (F_film_selected). (..., 3)."""
    F = F_base_selected(point, model, LoH)
    if model.thin_film:
        F = F_film_selected(point, model, LoH, F)
    return F


def F_avg_selected(point: ShadingPoint, model: Model) -> np.ndarray:
    """F_avg = 2 int F mu dmu of the material's Fresnel for the multiple-scattering lobe
    (twin of the GLSL's), (..., 3): the exact models average the exact Fresnel of their
    dielectric part (eta_dielectric) and of their metal part (the conductor's eta + i k, or
    Schlick's of the base colour), mixed by metallic; the generalised Schlick
    F0 + (F90 - F0) 2 / ((e + 1)(e + 2)); Schlick's F0 + (1 - F0)/21 otherwise."""
    from app.reference import multiscatter

    s, p = point.s, point.params
    if model.fresnel in ("conductor", "dielectric"):
        d = multiscatter.F_avg_dielectric(p.eta_dielectric)
        d = np.broadcast_to(d[..., None], (*d.shape, 3))
        metal = (
            multiscatter.F_avg_conductor(p.eta, p.k)
            if model.fresnel == "conductor"
            else multiscatter.F_avg_schlick(s.base_color)
        )
        return _mix(d, metal, s.metallic)
    F0 = material_F0(s, p)
    if model.fresnel == "schlick_generalized":
        e = np.asarray(p.fresnel_exponent, np.float64)[..., None]
        return F0 + (np.asarray(p.f90, np.float64) - F0) * (2.0 / ((e + 1.0) * (e + 2.0)))
    return multiscatter.F_avg_schlick(F0)


def f_diffuse_selected(
    point: ShadingPoint,
    model: Model,
    alpha: np.ndarray,
    l: np.ndarray,
    NoL: np.ndarray,
    NoV: np.ndarray,
    NoH: np.ndarray,
    LoH: np.ndarray,
) -> np.ndarray:
    """The model's diffuse lobe towards point.v, (..., 3)."""
    s, p, n, v = point.s, point.params, point.n, point.v
    rho = material_rho_ss(s)
    match model.diffuse:
        case "shirley":
            return diffuse.Fd_shirley(rho, material_F0(s, p), NoL, NoV)
        case "ashikhmin_shirley":
            return diffuse.Fd_ashikhmin_shirley(rho, material_F0(s, p), NoL, NoV)
        case "burley":
            r = np.clip(np.asarray(s.perceptual_roughness, np.float64), 0.0, 1.0)
            return diffuse.Fd_burley(rho, r, NoL, NoV, LoH)
        case "burley_renormalized":
            r = np.clip(np.asarray(s.perceptual_roughness, np.float64), 0.0, 1.0)
            return diffuse.Fd_burley_renormalized(rho, r, NoL, NoV, LoH)
        case "oren_nayar":
            return diffuse.Fd_oren_nayar(rho, alpha, n, l, v)
        case "hammon":
            return diffuse.Fd_hammon(rho, material_F0(s, p), alpha, NoL, NoV, NoH, dot(l, v))
        case "none":
            return np.zeros_like(rho)
        case "cloth_empirical":  # RTR4 §9.10 (app/reference/cloth.py)
            return cloth.f_cloth_empirical(
                model.cloth_wrap_form == "rtr4", rho, p.cloth_rim_inner, p.cloth_diffuse,
                p.cloth_scatter, p.cloth_wrap, p.cloth_sheen, NoL, NoV, LoH,
            )  # fmt: skip
    return diffuse.Fd_lambert(rho)


def orthonormal_tangent(n: np.ndarray, t: np.ndarray) -> np.ndarray:
    """A unit tangent perpendicular to n (t's normal component removed, or any perpendicular)."""
    n = np.asarray(n, np.float64)
    t = np.asarray(t, np.float64)
    u = t - n * dot(n, t)[..., None]
    len2 = dot(u, u)
    a = np.where((np.abs(n[..., 2]) < 0.999)[..., None], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0])
    fallback = np.cross(a, n)
    fallback = fallback / np.linalg.norm(fallback, axis=-1, keepdims=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        unit = u / np.sqrt(len2)[..., None]
    return np.where((len2 > 1e-8)[..., None], unit, fallback)


# --- diffraction grating (RTR4 §9.11) ---


def grating_lobe(
    point: ShadingPoint, model: Model, alpha, l: np.ndarray, v: np.ndarray
) -> np.ndarray:
    """The material's single-scattering lobe F D V at any pair (l, v) of upper-hemisphere
    directions, not only at point.v (the orders shift both; the clamps and half vector of
    base_brdf_factors; the fused height-correlated GGX visibility, the only G2 a grating
    takes), (..., 3)."""
    n = point.n
    NoL = np.clip(dot(n, l), MIN_N_DOT_L, 1.0)
    NoV = np.clip(dot(n, v), MIN_N_DOT_V, 1.0)
    hv = l + v
    hv2 = dot(hv, hv)
    with np.errstate(divide="ignore", invalid="ignore"):
        h = np.where((hv2 > 1e-12)[..., None], hv / np.sqrt(hv2)[..., None], n)
    LoH = np.clip(dot(l, h), 0.0, 1.0)
    F = F_selected(point, model, LoH)
    D = D_selected(model, n, h, alpha, point.params.gtr_gamma)
    return F * (D * masking.V_height_correlated_GGX(NoL, NoV, alpha))[..., None]


def f_spec_grating_selected(point: ShadingPoint, model: Model, l, NoL, NoV, alpha) -> np.ndarray:
    """The grating's orders over the lobe (app/reference/diffraction.py) at point.v,
    grooves along the tangent t: g = n x t."""
    n, p = point.n, point.params
    g = diffraction.grating_direction(n, orthonormal_tangent(n, point.t))
    return diffraction.f_spec_grating(
        lambda a, b: grating_lobe(point, model, alpha, a, b),
        n, g, l, point.v, NoL, NoV, p.grating_period, p.grating_depth,
    )  # fmt: skip


@dataclass
class BrdfFactors:
    """The factors of f(l, v) apart (glsl/brdf/material.glsl ``BrdfFactors``); values at
    points that ``lit`` leaves out are placeholders (brdf_eval makes f 0 there)."""

    lit: np.ndarray  # (...,) bool: n.l > 0
    F: np.ndarray  # (..., 3) Fresnel reflectance F(h, l), RTR4 §9.5
    D: np.ndarray  # (...,) NDF D(h), RTR4 §9.7-9.8
    G2: np.ndarray  # (...,) joint masking-shadowing G2(l, v, h), RTR4 §9.7
    f_spec: np.ndarray  # (..., 3) F G2 D / (4 n.l n.v) (+ f_ms), RTR4 §9.8
    f_diffuse: np.ndarray  # (..., 3) the subsurface lobe, RTR4 §9.9
    f_coat: np.ndarray | float = 0.0  # (...,) a clear coat's own reflection, RTR4 §9.12


def surface_reflection(b: BrdfFactors) -> np.ndarray:
    """The surface reflection of the factors, (..., 3): the coat's lobe plus the base's
    specular lobe, f_coat + f_spec (the GLSL's ``surface_reflection``)."""
    return np.asarray(b.f_coat, np.float64)[..., None] + b.f_spec


def shading_cosines(
    n: np.ndarray, l: np.ndarray, v: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(lit, n.l, n.v, h), clamped as every BRDF evaluation clamps them (the GLSL's
    base_brdf_factors and clearcoat_factors): n.l floored at MIN_N_DOT_L (1/(n.l) and D G2
    underflowed for n.l = 1e-36; 1.0 where unlit, masked later), n.v at MIN_N_DOT_V, and
    h = n where l = -v has no half vector."""
    NoL_raw = dot(n, l)
    lit = NoL_raw > 0.0
    NoL = np.where(lit, np.clip(NoL_raw, MIN_N_DOT_L, 1.0), 1.0)
    NoV = np.clip(dot(n, v), MIN_N_DOT_V, 1.0)
    hv = l + v
    hv2 = dot(hv, hv)
    with np.errstate(divide="ignore", invalid="ignore"):
        h = np.where((hv2 > 1e-12)[..., None], hv / np.sqrt(hv2)[..., None], n)
    return lit, NoL, NoV, h


def base_brdf_factors(
    point: ShadingPoint, model: Model, l: np.ndarray, ms_table: np.ndarray | None = None
) -> BrdfFactors:
    """F, D, G2, f_spec and f_diffuse of ``model`` without its clear coat at each point,
    lit from l (twin of the GLSL's ``base_brdf_factors``). Where the model has a fused
    visibility V = G2/(4 n.l n.v), f_spec is computed from V and G2 is V 4 n.l n.v, as in
    the GLSL. ``ms_table`` as in brdf_eval."""
    s, p = point.s, point.params
    n, t, l, v = (np.asarray(x, np.float64) for x in (point.n, point.t, l, point.v))
    point = replace(point, n=n, t=t, v=v)
    lit, NoL, NoV, h = shading_cosines(n, l, v)
    NoH = np.clip(dot(n, h), 0.0, 1.0)
    LoH = np.clip(dot(l, h), 0.0, 1.0)
    alpha = material_alpha(s)
    F = F_selected(point, model, LoH)

    if model.anisotropic:
        tn = orthonormal_tangent(n, t)
        bn = np.cross(n, tn)
        alpha_min = MIN_PERCEPTUAL_ROUGHNESS * MIN_PERCEPTUAL_ROUGHNESS
        a = np.asarray(s.anisotropy, np.float64)
        alpha_x = np.maximum(alpha * (1.0 + a), alpha_min)
        alpha_y = np.maximum(alpha * (1.0 - a), alpha_min)
        D = D_selected_aniso(model, n, tn, bn, h, alpha_x, alpha_y)
        alpha_v = masking.alpha_in_direction(tn, bn, v, alpha_x, alpha_y)
        alpha_l = masking.alpha_in_direction(tn, bn, l, alpha_x, alpha_y)
    else:
        D = D_selected(model, n, h, alpha, p.gtr_gamma)
        alpha_v = alpha_l = alpha

    fused = model.g2 == "hammon" or (
        model.g2 == "height_correlated" and model.ndf == "ggx" and not model.anisotropic
    )
    if fused:
        V = (
            masking.V_hammon_GGX(NoL, NoV, alpha)
            if model.g2 == "hammon"
            else masking.V_height_correlated_GGX(NoL, NoV, alpha)
        )
        f_spec = F * (D * V)[..., None]
        G2 = V * (4.0 * NoL * NoV)
    else:
        G2 = G2_selected(
            model,
            Lambda_selected(model, NoV, alpha_v, p.gtr_gamma),
            Lambda_selected(model, NoL, alpha_l, p.gtr_gamma),
            n,
            l,
            v,
        )
        f_spec = F * (D * G2 / (4.0 * NoL * NoV))[..., None]
    if model.diffraction == "grating":  # RTR4 §9.11: the orders replace the lobe
        f_spec = f_spec_grating_selected(point, model, l, NoL, NoV, alpha)
    if model.multiscatter:
        from app.reference import multiscatter  # its tables load only when a model uses them

        f_spec = f_spec + multiscatter.f_ms_kulla_conty_F_avg(
            multiscatter.table_for(model, ms_table),  # the table of the model's own G2
            F_avg_selected(point, model),
            s.perceptual_roughness,
            NoL,
            NoV,
        )
    f_diffuse = f_diffuse_selected(point, model, alpha, l, NoL, NoV, NoH, LoH)
    if model.fiber != "none":
        # micro-cylinder fibres (RTR4 §9.10, app/reference/fiber.py): the thread along the
        # tangent turned by fiber_rotation replaces both lobes; gamma_s = alpha.
        tf = fiber.fiber_rotate(n, orthonormal_tangent(n, t), p.fiber_rotation)
        f_spec, f_diffuse = fiber.f_fiber(
            model.fiber == "sadeghi", n, tf, l, v, NoL, material_rho_ss(s), material_F0(s, p),
            p.eta_dielectric, alpha, p.fiber_curvature, p.fiber_gamma_v, p.fiber_kd,
        )  # fmt: skip
    if model.sheen != "none":
        # sheen (RTR4 §9.10, app/reference/sheen.py): the cloth layer over the whole base,
        # f = f_sheen + f_base (1 - max(sheen_color) max(E(n.l), E(n.v))), in f_spec.
        from app.reference import sheen  # its table loads only when a model uses it

        table = sheen.load_table()
        E_l = sheen.sheen_E(table, model.sheen, NoL, p.sheen_roughness)
        E_v = sheen.sheen_E(table, model.sheen, NoV, p.sheen_roughness)
        scale = sheen.sheen_scaling(p.sheen_color, E_l, E_v)[..., None]
        alpha_sheen = sheen.sheen_alpha(p.sheen_roughness)
        f_spec = f_spec * scale + sheen.f_sheen(
            model.sheen, p.sheen_color, alpha_sheen, n, h, NoL, NoV
        )
        f_diffuse = f_diffuse * scale
    return BrdfFactors(lit, F, np.asarray(D, np.float64), np.asarray(G2, np.float64), f_spec,
                       f_diffuse)  # fmt: skip


# --- clear coat (RTR4 §9.12) ---


def clearcoat_base_surface(s: Surface, p: ModelParams) -> Surface:
    """The base under the coat: its dielectric F0 against the coat, mixed in by strength."""
    f0 = np.asarray(s.f0_dielectric, np.float64)
    under = clearcoat.f0_under_clearcoat(f0, p.clearcoat_eta)
    c = p.clearcoat
    return replace(s, f0_dielectric=f0 * (1.0 - c) + under * c)


def clearcoat_base_params(p: ModelParams) -> ModelParams:
    """The base under the coat: the exact Fresnel models' indices divided by the coat's,
    mixed in by strength (exact at 0 and 1)."""
    c, eta_c = np.asarray(p.clearcoat, np.float64), p.clearcoat_eta
    c_rgb = c[..., None]  # a strength per point (the G-buffer's RT6) against RGB indices

    def mix(x: np.ndarray | float, c: np.ndarray) -> np.ndarray:
        x = np.asarray(x, np.float64)
        return x * (1.0 - c) + (x / eta_c) * c

    eta_d = mix(p.eta_dielectric, c)
    return replace(
        p, eta_dielectric=float(eta_d) if eta_d.ndim == 0 else eta_d,
        eta=mix(p.eta, c_rgb if c.ndim else c), k=mix(p.k, c_rgb if c.ndim else c),
    )  # fmt: skip


def clearcoat_base_point(point: ShadingPoint, v_base: np.ndarray) -> ShadingPoint:
    """The base as the coat's underside sees it: its surface and parameters under the coat
    and the view ``v_base`` (refracted into the coat for Weidlich-Wilkie, else point.v)."""
    return replace(
        point, s=clearcoat_base_surface(point.s, point.params),
        params=clearcoat_base_params(point.params), v=v_base,
    )  # fmt: skip


def clearcoat_factors(
    point: ShadingPoint, model: Model, l: np.ndarray, ms_table: np.ndarray | None = None
) -> BrdfFactors:
    """The coated BRDF's factors (twin of the GLSL's ``clearcoat_factors``): F, D, G2 the
    base's, f_coat the coat's lobe; "filament":
    f = c f_coat + (1 - c F(nc.l)) (1 - c F(nc.v)) mix(1, A(l, v), c) f_base;
    "weidlich_wilkie" (Weidlich & Wilkie 2007), the base with the directions refracted
    about the coat's normal: f = c f_coat + (...) f_base(l_t, v_t) / eta_c^2.
    Two normals (RTR4 §9.12, "layers may have different normals"; glTF
    KHR_materials_clearcoat): the coat's lobe, its crossings and the absorption's path
    lengths take the coat's nc, the base's lobes its own n; nc = n (or None) is the single
    normal."""
    p = point.params
    nc = point.n if point.nc is None else point.nc
    n, nc, l, v = (np.asarray(x, np.float64) for x in (point.n, nc, l, point.v))
    coat_lit, _, NoV, h = shading_cosines(nc, l, v)  # the coat's cosines; n.l as the GLSL
    NoL = np.clip(dot(nc, l), MIN_N_DOT_L, 1.0)  # clamps it where l is below nc only
    LoH = np.clip(dot(l, h), 0.0, 1.0)
    c = p.clearcoat
    F0c = clearcoat.clearcoat_F0(p.clearcoat_eta)
    rc = np.maximum(p.clearcoat_roughness, MIN_PERCEPTUAL_ROUGHNESS)  # per point with RT8
    alpha_c = rc * rc

    base = replace(model, clearcoat="none")
    l_base, v_base, compression = l, v, 1.0
    refracts = model.clearcoat in ("weidlich_wilkie", "weidlich_wilkie_series")
    if refracts and np.any(np.asarray(c) > 0.0):
        # Weidlich & Wilkie 2007: the base sees the directions refracted into the coat (about
        # the coat's normal: its interface refracts), at eta_c = mix(1, eta, c), and the
        # result is compressed by 1/eta_c^2 (GLSL's comment).
        eta_c = 1.0 - c + p.clearcoat_eta * c
        l_base = clearcoat.clearcoat_refract_in(eta_c, nc, l)
        v_base = clearcoat.clearcoat_refract_in(eta_c, nc, v)
        compression = clearcoat.clearcoat_solid_angle_compression(eta_c)
    b = base_brdf_factors(clearcoat_base_point(point, v_base), base, l_base, ms_table)
    T = clearcoat.T_clearcoat_filament(c, F0c, NoL, NoV)
    A = clearcoat.A_clearcoat_beer_lambert(p.clearcoat_color, p.clearcoat_eta, NoL, NoV)
    # a strength per point (the G-buffer's RT6) or the row's one number
    c_rgb = np.asarray(c, np.float64)[..., None] if np.ndim(c) else c
    A = 1.0 - c_rgb + A * c_rgb
    w = (T * compression)[..., None] * A
    # chi+(nc.l): no coat lobe for a light below the coat's horizon (GLSL's comment)
    f_coat = np.where(
        coat_lit, c * clearcoat.f_clearcoat_ggx(alpha_c, F0c, nc, h, NoL, NoV, LoH), 0.0
    )
    lit = dot(n, l) > 0.0  # brdf_eval's test, on the base's normal and the light itself
    f_diffuse = w * b.f_diffuse
    if model.clearcoat == "weidlich_wilkie_series":
        f_diffuse = f_diffuse + w * clearcoat_series(point, c) / np.pi
    return replace(b, lit=lit, f_coat=f_coat, f_spec=w * b.f_spec, f_diffuse=f_diffuse)


def clearcoat_series(point: ShadingPoint, c: np.ndarray | float) -> np.ndarray:
    """K of the coat-base inter-reflection series (twin of the GLSL's ``clearcoat_series``),
    (..., 3): the light the coat's top reflects back down, summed over its bounces, leaves
    as the lobe w K / pi (w: the crossings, absorption and 1/eta_c^2 of the single pass).
    With the base's average albedo R = R_d + R_s (R_d its diffuse albedo rho_ss, R_s =
    F_avg E_avg(r) its specular one, Schlick's F_avg of its F0 under the coat; both scaled
    down together where they sum past 1), the
    share of it trapped on the first return Q = R_d r_i + R_s r_s (r_i the coat's
    hemispherical internal reflectance, r_s a GGX lobe's), and a round trip's absorption
    A_rt = T0^4 (the mean path of diffuse light is 2/cos per leg):
    K = Q A_rt R / (1 - R r_i A_rt), the geometric sum of the bounces after the first."""
    s, p = point.s, point.params
    base = clearcoat_base_surface(s, p)
    c = np.asarray(c, np.float64)
    eta_c = 1.0 - c + p.clearcoat_eta * c
    F0c = clearcoat.clearcoat_F0(p.clearcoat_eta)
    r_i = clearcoat.clearcoat_internal_reflectance(c, F0c, eta_c)
    r_s = clearcoat.clearcoat_lobe_trapping(c, F0c, eta_c, r_i, material_alpha(base))
    F0 = material_F0(base, clearcoat_base_params(p))
    R_s = (F0 + (1.0 - F0) / 21.0) * clearcoat.E_avg_ggx_fit(base.perceptual_roughness)[..., None]
    R_d = material_rho_ss(base)
    # a base that reflects more than it receives (Lambert beside an unweighted specular
    # lobe) counts as white: both albedos scaled by the same factor
    scale = 1.0 / np.maximum(R_d + R_s, 1.0)
    R_d, R_s = R_d * scale, R_s * scale
    R = R_d + R_s
    Q = R_d * r_i[..., None] + R_s * r_s[..., None]
    c_rgb = c[..., None]
    T0 = np.asarray(p.clearcoat_color, np.float64)
    A_rt = 1.0 - c_rgb + (T0 * T0) * (T0 * T0) * c_rgb
    return Q * A_rt * R / (1.0 - R * r_i[..., None] * A_rt)


def brdf_factors(
    point: ShadingPoint, model: Model, l: np.ndarray, ms_table: np.ndarray | None = None
) -> BrdfFactors:
    """F, D, G2, f_coat, f_spec and f_diffuse of ``model`` at each point, lit from l (twin
    of the GLSL's ``brdf_factors``): the base's, or with a clear coat the coated ones."""
    if model.clearcoat != "none":
        return clearcoat_factors(point, model, l, ms_table)
    return base_brdf_factors(point, model, l, ms_table)


def selected_terms(f_diffuse: np.ndarray, f_surface: np.ndarray, terms: str) -> np.ndarray:
    """The reflections ``terms`` (a key of BRDF_TERMS, RTR4 §9.1) keeps, (..., 3)."""
    mask = BRDF_TERMS[terms]
    if mask == TERM_SPECULAR:
        return f_surface
    return f_diffuse + f_surface if mask & TERM_SPECULAR else f_diffuse


def brdf_eval(
    point: ShadingPoint,
    model: Model,
    l: np.ndarray,
    ms_table: np.ndarray | None = None,
    terms: str = "all",
) -> np.ndarray:
    """f(l, v) = f_diffuse + f_spec (+ f_ms) under ``model`` at the point (v = point.v),
    (..., 3); 0 where n.l <= 0.

    ``ms_table`` is the stack of multiple-scattering tables
    (app.reference.multiscatter.load_tables; a single (n, n, 2) table is used as it is;
    None: the shipped ones); the model's G2 picks its table (``table_for``). ``terms`` (a
    key of BRDF_TERMS, RTR4 §9.1) keeps only the specular or only the diffuse reflection.
    """
    b = brdf_factors(point, model, l, ms_table)
    f = selected_terms(b.f_diffuse, surface_reflection(b), terms)
    return np.where(b.lit[..., None], f, 0.0)


def cloth_wrapped_term(
    point: ShadingPoint, model: Model, NoL: np.ndarray, terms: str = "all"
) -> np.ndarray:
    """Wrap lighting past the terminator (RTR4 §9.10; twin of the GLSL's
    ``cloth_wrapped_term``): f (n.l) of a light at n.l <= CLOTH_WRAP_MIN_N_DOT_L on an
    empirical cloth with wrap w > 0, the wrapped lobes alone, (..., 3); zero where ``terms``
    leaves the diffuse out."""
    p = point.params
    rho = material_rho_ss(point.s)
    if not BRDF_TERMS[terms] & TERM_DIFFUSE:
        return np.zeros(np.broadcast_shapes(np.shape(rho), (*np.shape(NoL), 3)))
    NoV = np.clip(dot(np.asarray(point.n, np.float64), np.asarray(point.v, np.float64)),
                  MIN_N_DOT_V, 1.0)  # fmt: skip
    return cloth.f_cloth_empirical_past_terminator(
        model.cloth_wrap_form == "rtr4", rho, p.cloth_rim_inner, p.cloth_diffuse,
        p.cloth_scatter, p.cloth_wrap, NoL, NoV,
    )  # fmt: skip


def brdf_eval_layered_cos(
    point: ShadingPoint,
    model: Model,
    l: np.ndarray,
    ms_table: np.ndarray | None = None,
    terms: str = "all",
) -> np.ndarray:
    """f(l, v) times the cosine for a coat whose normal nc is not the base's n (twin of the
    GLSL's ``brdf_eval_layered_cos``): the coat's lobe times (nc.l)+, the base's lobes seen
    through the coat times (n.l)+ (Filament's surface shading with a clear-coat normal;
    glTF KHR_materials_clearcoat: the coat's normal "affects the top layer, but not the
    base"), (..., 3); 0 where the light is below both (point.nc None: n)."""
    nc = point.n if point.nc is None else point.nc
    NoL = dot(np.asarray(point.n, np.float64), np.asarray(l, np.float64))
    NoLc = dot(np.asarray(nc, np.float64), np.asarray(l, np.float64))
    b = brdf_factors(point, model, l, ms_table)
    base = selected_terms(b.f_diffuse, b.f_spec, terms)
    coat = np.asarray(b.f_coat, np.float64) if BRDF_TERMS[terms] & TERM_SPECULAR else 0.0
    result = np.where((NoL > 0.0)[..., None], base * NoL[..., None], 0.0)
    return result + np.where(NoLc > 0.0, coat * NoLc, 0.0)[..., None]


def brdf_standard(s: Surface, n: np.ndarray, l: np.ndarray, v: np.ndarray) -> np.ndarray:
    """f(l, v) under the standard model (Lambert + GGX, height-correlated Smith, Schlick)."""
    return brdf_eval(ShadingPoint(s, ModelParams(), n, None, n, v), DEFAULT_MODEL, l)
