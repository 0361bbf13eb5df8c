"""Image-based lighting in float64 (docs/ibl.md): the split-sum approximation's parts and
the brute-force reference it is measured against.

Every function takes an equirectangular map (app/reference/environment.py's convention)
and a rotation in radians, and sums over the map's texels with their exact solid angles,
so "the integral" below always means the sum over the map at its resolution.

* ``reference_radiance``: L_o(v) = integral f(l, v) L(l) (n.l)+ dl with the project's
  whole BRDF (``brdf_eval``), by brute force over every texel.
* The split sum (Karis 2013, "Real Shading in Unreal Engine 4", SIGGRAPH course):
  integral f L (n.l) ~ L_pre(R, r) * integral f (n.l), with

  - ``prefiltered_radiance``: L_pre(R) = integral L(l) D(h) (R.l)+ dl / integral D(h)
    (R.l)+ dl, the GGX lobe with n = v = R (Karis's assumption, which the GPU's
    importance sampling estimates with weights n.l);
  - ``dfg_terms``: integral f_spec (n.l) with Schlick's F = F0 + (1 - F0) Fc,
    Fc = (1 - l.h)^5, split as F0 A + B: A = E - B, B = the albedo with F0 = 0, computed
    for the project's own G2 (height-correlated Smith) and D (GGX) with the same
    quadrature as the Kulla-Conty table (app/reference/multiscatter.py), so A + B is E;
  - diffuse: rho_ss E(n) / pi with the irradiance E(n) from 9 spherical-harmonic
    coefficients (Ramamoorthi & Hanrahan 2001, "An Efficient Representation for
    Irradiance Environment Maps", eq. 13);
  - multiple scattering (Kulla & Conty 2017, as the lights get it): the added lobe
    colour (1 - E(n.l)) (1 - E(n.v)) / (pi (1 - E_avg)) integrated against L, with
    1 - E(n.l) replaced by its cosine-weighted mean 1 - E_avg: colour (1 - E(n.v)) E(n)/pi.
    Exact for a uniform environment (the white furnace), approximate elsewhere (the same
    idea as Fdez-Aguera 2019, "A Multiple-Scattering Microfacet Model for Real-Time
    Image-based Lighting").
"""

from __future__ import annotations

import math

import numpy as np

from app.common.models import DEFAULT_MODEL, Model, ModelParams
from app.reference.constants import MIN_N_DOT_V, MIN_PERCEPTUAL_ROUGHNESS
from app.reference.environment import rotate_y, texel_directions
from app.reference.material import (
    F_film_selected,
    ShadingPoint,
    Surface,
    brdf_eval,
    material_F0,
    material_rho_ss,
    orthonormal_tangent,
)
from app.reference.multiscatter import (
    QUAD_PHI,
    QUAD_PSI,
    F_avg_schlick,
    grid_bilinear,
    ms_E,
    ms_E_avg,
    mu_grid,
    roughness_grid,
)
from app.reference.ndf import D_GGX
from app.reference.quadrature import N, directional_albedo, reflected_rule
from app.reference.specular import f_spec_GGX

# --- the map as texels ---------------------------------------------------------------------


def map_texels(env: np.ndarray, rotation: float) -> tuple[np.ndarray, np.ndarray]:
    """World directions (T, 3) of the map's texels (turned ``rotation`` radians about +Y)
    and their radiance times solid angle, L dOmega (T, 3)."""
    d, omega = texel_directions(*env.shape[:2])
    d = rotate_y(d, rotation).reshape(-1, 3)
    return d, np.asarray(env, np.float64).reshape(-1, 3) * omega.reshape(-1, 1)


# --- the brute-force reference ---------------------------------------------------------------


def reference_radiance(
    env: np.ndarray,
    rotation: float,
    surface: Surface,
    n: np.ndarray,
    v: np.ndarray,
    model: Model = DEFAULT_MODEL,
    params: ModelParams | None = None,
    ms_table: np.ndarray | None = None,
    t: np.ndarray | None = None,
) -> np.ndarray:
    """L_o(v) = sum over texels f(l, v) L(l) (n.l)+ dOmega for one shading point (3,).
    ``t``: the tangent of an anisotropic model (None: any perpendicular to n)."""
    d, l_domega = map_texels(env, rotation)
    n = np.asarray(n, np.float64)
    lit = d @ n > 0.0
    d, l_domega = d[lit], l_domega[lit]
    if t is None:
        t = np.cross(n, [0.0, 0.0, 1.0] if abs(n[2]) < 0.9 else [1.0, 0.0, 0.0])
    point = ShadingPoint(surface, params or ModelParams(), n, None, t, v)
    f = brdf_eval(point, model, d, ms_table)
    return np.sum(f * l_domega * (d @ n)[:, None], axis=0)


# --- the split sum's parts -------------------------------------------------------------------


def prefiltered_radiance(
    env: np.ndarray, rotation: float, R: np.ndarray, perceptual_roughness: float
) -> np.ndarray:
    """L_pre(R, r) = sum L D_GGX(h) (R.l)+ dOmega / sum D_GGX(h) (R.l)+ dOmega, h the half
    vector of R and l (n = v = R), for directions R (..., 3) -> (..., 3)."""
    d, l_domega = map_texels(env, rotation)
    _, omega = texel_directions(*env.shape[:2])
    omega = omega.reshape(-1)
    r = max(perceptual_roughness, MIN_PERCEPTUAL_ROUGHNESS)
    R = np.asarray(R, np.float64)
    flat = R.reshape(-1, 3)
    out = np.empty_like(flat)
    for i, Ri in enumerate(flat):
        cos = d @ Ri
        keep = cos > 0.0
        h = d[keep] + Ri
        h /= np.linalg.norm(h, axis=-1, keepdims=True)
        w = D_GGX(Ri, h, r * r) * cos[keep]
        out[i] = (w[:, None] * l_domega[keep]).sum(0) / np.sum(w * omega[keep])
    return out.reshape(R.shape)


def dfg_terms(mu: float, perceptual_roughness: float) -> tuple[float, float]:
    """(A, B) with integral f_spec (n.l) dl = F0 A + B for Schlick's F, at n.v = mu; the
    quadrature of single_scatter_albedo (A + B = E). mu = 0: the limit (E = 1, all in B:
    Fc = 1 at grazing)."""
    if mu <= 0.0:
        return 0.0, 1.0
    r = max(perceptual_roughness, MIN_PERCEPTUAL_ROUGHNESS)
    alpha = r * r
    v = np.array([math.sqrt(max(1.0 - mu * mu, 0.0)), 0.0, mu])
    ls, w = reflected_rule(v, alpha, QUAD_PSI, QUAD_PHI)  # f is reciprocal: l <-> v
    E = directional_albedo(f_spec_GGX(1.0, alpha, N, v, ls), ls, w)[0]
    B = directional_albedo(f_spec_GGX(0.0, alpha, N, v, ls), ls, w)[0]
    return float(E - B), float(B)


def compute_dfg_table(size: int) -> np.ndarray:
    """float32 (size, size, 2) of (A, B) on the Kulla-Conty table's grids (rows roughness,
    columns mu), so that the same bilinear look-up serves both."""
    mus, rs = mu_grid(size), roughness_grid(size)
    table = np.array([[dfg_terms(m, r) for m in mus] for r in rs])
    return table.astype(np.float32)


def dfg_lookup(table: np.ndarray, mu: np.ndarray, r: np.ndarray) -> np.ndarray:
    """(A, B) (..., 2), bilinear in the grid coordinates (as ms_loss), float64."""
    return grid_bilinear(table, mu, r)


# --- spherical harmonics (Ramamoorthi & Hanrahan 2001) -----------------------------------

# Their eq. 3 normalisation constants and eq. 13 irradiance constants.
SH_Y = (0.282095, 0.488603, 1.092548, 0.315392, 0.546274)
SH_C = (0.429043, 0.511664, 0.743125, 0.886227, 0.247708)


def sh9_basis(d: np.ndarray) -> np.ndarray:
    """The 9 real SH basis functions at unit directions d (..., 3) -> (..., 9), ordered
    L00, L1-1 (y), L10 (z), L11 (x), L2-2 (xy), L2-1 (yz), L20, L21 (xz), L22."""
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    y0, y1, y2, y3, y4 = SH_Y
    return np.stack(
        [np.full_like(x, y0), y1 * y, y1 * z, y1 * x, y2 * x * y, y2 * y * z,
         y3 * (3.0 * z * z - 1.0), y2 * x * z, y4 * (x * x - y * y)],
        axis=-1,
    )  # fmt: skip


def sh9_project(env: np.ndarray, rotation: float) -> np.ndarray:
    """L_lm = sum over texels L Y_lm dOmega: (9, 3)."""
    d, l_domega = map_texels(env, rotation)
    return sh9_basis(d).T @ l_domega


def sh9_irradiance(L: np.ndarray, n: np.ndarray) -> np.ndarray:
    """E(n) from the 9 coefficients L (9, 3) (Ramamoorthi & Hanrahan 2001, eq. 13), for
    unit normals n (..., 3) -> (..., 3)."""
    c1, c2, c3, c4, c5 = SH_C
    x, y, z = (np.asarray(n, np.float64)[..., i, None] for i in range(3))
    return (
        c1 * L[8] * (x * x - y * y) + c3 * L[6] * z * z + c4 * L[0] - c5 * L[6]
        + 2.0 * c1 * (L[4] * x * y + L[7] * x * z + L[5] * y * z)
        + 2.0 * c2 * (L[3] * x + L[1] * y + L[2] * z)
    )  # fmt: skip


# --- the split-sum estimate of one shading point --------------------------------------------


def specular_dominant_direction(n: np.ndarray, R: np.ndarray, alpha: float) -> np.ndarray:
    """The direction the prefiltered map is read along: the mirror direction R turned
    towards the normal n as roughness grows, where the true lobe's peak lies (the
    off-specular peak the split sum's n = v = R assumption loses at grazing view).
    Lagarde & de Rousiers 2014, "Moving Frostbite to Physically Based Rendering", sec.
    4.9.3 (listing 22): lerp(n, R, s (sqrt(s) + alpha)) with s = 1 - alpha, alpha = r^2,
    their fit for GGX with (height-)correlated Smith G, the project's G2. Normalised here
    (the paper leaves it to the cube fetch). Head-on (R = n) it changes nothing."""
    s = 1.0 - alpha
    t = s * (math.sqrt(s) + alpha)
    d = (1.0 - t) * np.asarray(n, np.float64) + t * np.asarray(R, np.float64)
    return d / np.linalg.norm(d)


def specular_centroid_direction(
    n: np.ndarray, R: np.ndarray, alpha: float, NoV: float
) -> np.ndarray:
    """``specular_dominant_direction``'s turn made to follow the view: its lerp factor times
    (1 - 0.87 alpha^0.7 (1 - n.v)^1.6). Fitted here (docs/ibl.md) to the direction of the
    centroid of the GGX lobe f (n.l) (height-correlated G2, F = 1) in the plane of
    incidence, over r = 0.1..1 and n.v = 0.05..0.97: RMS 0.03 in the lerp factor, where the
    view-independent fit is 0.11 from it (it bends too little at grazing view, too much
    near normal incidence)."""
    s = 1.0 - alpha
    t = s * (math.sqrt(s) + alpha) * (1.0 - 0.87 * alpha**0.7 * (1.0 - NoV) ** 1.6)
    d = (1.0 - t) * np.asarray(n, np.float64) + t * np.asarray(R, np.float64)
    return d / np.linalg.norm(d)


def anisotropic_bent_normal(
    n: np.ndarray, t: np.ndarray, v: np.ndarray, anisotropy: float, alpha: float
) -> np.ndarray:
    """The normal an anisotropic surface reflects the prefiltered (isotropic) map about:
    n bent towards v with its component along the smoother direction removed (the
    bitangent for anisotropy >= 0, where alpha_x = alpha (1 + a) along t is the rougher),
    by |a| min(5 alpha, 1). The bent reflection vector of Revie 2011 ("Implementing Fur
    Using Deferred Shading", GPU Pro 2) and McAuley 2015 ("Rendering the World of Far Cry
    4", GDC), in the form Guy & Agopian's "Physically Based Rendering in Filament"
    documents (Filament's roughness there is alpha). An approximation: the stretched
    lobe's reflections streak across the smoother direction, which reading the map about a
    normal leaning towards the view imitates; a = 0 gives n."""
    n = np.asarray(n, np.float64)
    tn = orthonormal_tangent(n, t)
    d = np.cross(n, tn) if anisotropy >= 0.0 else tn
    v = np.asarray(v, np.float64)
    towards_v = v - (v @ d) * d  # cross(cross(d, v), d) for a unit d
    bend = abs(anisotropy) * min(5.0 * alpha, 1.0)
    b = (1.0 - bend) * n + bend * towards_v
    return b / np.linalg.norm(b)


def split_sum_radiance(
    env: np.ndarray,
    rotation: float,
    surface: Surface,
    n: np.ndarray,
    v: np.ndarray,
    dfg_table: np.ndarray,
    sh: np.ndarray,
    ms_table: np.ndarray | None = None,
    dominant: bool = True,
    t: np.ndarray | None = None,
    bent: bool = True,
    params: ModelParams | None = None,
    model: Model | None = None,
) -> np.ndarray:
    """The standard model's environment term by the split sum (module docstring), (3,):
    rho_ss E(n)/pi + L_pre(R', r) (F0 A + B) [+ the Kulla-Conty colour (1 - E(n.v)) E(n)/pi
    with ``ms_table``]. ``sh``: sh9_project of the same map. R' is the mirror direction
    turned towards n by ``specular_dominant_direction`` (``dominant=False``: R itself, the
    plain split sum, kept to measure the correction in docs/ibl.md). With a tangent ``t``
    (an anisotropic model) R is reflected about ``anisotropic_bent_normal`` instead of n
    (``bent=False``: about n, the isotropic split sum). ``params``: the material's row
    (its specular_color colours F0; None: the defaults). ``model`` with ``thin_film``: the
    film's Fresnel at n.v times the lobe's albedo A + B replaces F0 A + B, mixed over it
    as ``F_film_selected`` mixes (glsl/lights/ibl.glsl)."""
    n, v = np.asarray(n, np.float64), np.asarray(v, np.float64)
    NoV = float(np.clip(n @ v, MIN_N_DOT_V, 1.0))
    r = float(np.maximum(surface.perceptual_roughness, MIN_PERCEPTUAL_ROUGHNESS))
    a = float(surface.anisotropy)
    nb = anisotropic_bent_normal(n, t, v, a, r * r) if t is not None and bent else n
    R = 2.0 * (nb @ v) * nb - v
    if dominant:
        R = specular_dominant_direction(n, R, r * r)
    F0 = material_F0(surface, params if params is not None else ModelParams())
    A, B = dfg_lookup(dfg_table, NoV, r)
    E_n = np.maximum(sh9_irradiance(sh, n), 0.0)  # as the GLSL: SH ringing can dip below 0
    out = material_rho_ss(surface) * E_n / math.pi
    scale = F0 * A + B
    if model is not None and model.thin_film:
        albedo = max(A + B, 1e-6)
        point = ShadingPoint(
            surface, params if params is not None else ModelParams(), n, None,
            t if t is not None else n, v,
        )  # fmt: skip
        scale = F_film_selected(point, model, np.float64(NoV), scale / albedo) * albedo
    out = out + prefiltered_radiance(env, rotation, R, r) * scale
    if ms_table is not None:
        E_avg = ms_E_avg(ms_table, r)
        F_avg = F_avg_schlick(F0)
        colour = F_avg * F_avg * E_avg / (1.0 - F_avg * (1.0 - E_avg))
        out = out + colour * (1.0 - ms_E(ms_table, NoV, r)) * E_n / math.pi
    return out


# --- the split sum's error -----------------------------------------------------------------

GOLD = (1.0, 0.782, 0.344)  # RTR4's gold F0 (app/scene/presets.py), linear


def view_direction(n: np.ndarray, degrees: float) -> np.ndarray:
    """A unit view direction ``degrees`` from n, tilted towards +Z (or +X where n is
    near +-Z)."""
    n = np.asarray(n, np.float64)
    side = np.array([0.0, 0.0, 1.0]) if abs(n[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    side = side - (side @ n) * n
    side /= np.linalg.norm(side)
    a = math.radians(degrees)
    return math.cos(a) * n + math.sin(a) * side


def split_sum_errors(
    env: np.ndarray,
    angles: tuple[float, ...],
    roughnesses: tuple[float, ...],
    base_color: tuple[float, float, float] = GOLD,
    metallic: float = 1.0,
    n: tuple[float, float, float] = (0.0, 1.0, 0.0),
    dfg_table: np.ndarray | None = None,
    dominant: bool = True,
    model: Model = DEFAULT_MODEL,
    params: ModelParams | None = None,
    split_roughness: float = 1.0,
    anisotropy: float = 0.0,
    t: tuple[float, float, float] | None = None,
    bent: bool = True,
) -> np.ndarray:
    """Relative error (split sum - reference) / reference, averaged over RGB, per
    (roughness, view angle from n): (len(roughnesses), len(angles)). ``dominant``: as
    split_sum_radiance's. ``model``/``params``: the BRDF of the reference (another NDF
    measures the error of lighting it with GGX's prefiltered map and DFG table);
    ``split_roughness``: the split sum's perceptual roughness is r times this (a
    remapping to GGX, capped at 1). ``anisotropy``, ``t``: an anisotropic surface and its
    tangent (pass an anisotropic ``model``); ``bent``: as split_sum_radiance's."""
    from app.common.tables import read_dfg_table

    nn = np.asarray(n, np.float64)
    sh = sh9_project(env, 0.0)
    dfg = read_dfg_table() if dfg_table is None else dfg_table
    out = np.zeros((len(roughnesses), len(angles)))
    for i, r in enumerate(roughnesses):
        s = Surface(np.asarray(base_color, np.float64), metallic, r, 0.04, anisotropy)
        r_split = min(r * split_roughness, 1.0)
        s_split = Surface(s.base_color, metallic, r_split, 0.04, anisotropy)
        tt = None if t is None else np.asarray(t, np.float64)
        for j, a in enumerate(angles):
            v = view_direction(nn, a)
            split = split_sum_radiance(
                env, 0.0, s_split, nn, v, dfg, sh,
                dominant=dominant, t=tt, bent=bent, params=params,
            )  # fmt: skip
            ref = reference_radiance(env, 0.0, s, nn, v, model, params, t=tt)
            out[i, j] = np.mean((split - ref) / ref)
    return out


# --- a Monte Carlo truth ---------------------------------------------------------------------


def _ggx_vndf_directions(v: np.ndarray, alpha: np.ndarray, u1: np.ndarray, u2: np.ndarray):
    """Visible normals of isotropic GGX for local views v (P, 3), one per (u1, u2) (P,):
    Heitz 2018, "Sampling the GGX Distribution of Visible Normals", listing 1."""
    a = alpha[:, None]
    vh = np.stack([a[:, 0] * v[:, 0], a[:, 0] * v[:, 1], v[:, 2]], axis=-1)
    vh /= np.linalg.norm(vh, axis=-1, keepdims=True)
    len2 = vh[:, 0] ** 2 + vh[:, 1] ** 2
    inv = np.where(len2 > 0.0, 1.0 / np.sqrt(np.where(len2 > 0.0, len2, 1.0)), 0.0)
    t1v = np.where(
        (len2 > 0.0)[:, None],
        np.stack([-vh[:, 1] * inv, vh[:, 0] * inv, np.zeros_like(inv)], axis=-1),
        np.array([1.0, 0.0, 0.0]),
    )
    t2v = np.cross(vh, t1v)
    r, phi = np.sqrt(u1), 2.0 * math.pi * u2
    t1, t2 = r * np.cos(phi), r * np.sin(phi)
    s = 0.5 * (1.0 + vh[:, 2])
    t2 = (1.0 - s) * np.sqrt(np.maximum(1.0 - t1 * t1, 0.0)) + s * t2
    nz = np.sqrt(np.maximum(1.0 - t1 * t1 - t2 * t2, 0.0))
    nh = t1[:, None] * t1v + t2[:, None] * t2v + nz[:, None] * vh
    m = np.stack([a[:, 0] * nh[:, 0], a[:, 0] * nh[:, 1], np.maximum(nh[:, 2], 0.0)], axis=-1)
    return m / np.linalg.norm(m, axis=-1, keepdims=True)


class _MapSampler:
    """Directions drawn in proportion to the map's luminance times the texel's solid angle
    (a tenth of the draws uniform over the texels' solid angle, so every direction has a
    density), uniform in (u, v) inside the texel: density p_texel W H / (2 pi^2 sin theta)
    per steradian (equirect_uv's convention)."""

    def __init__(self, env: np.ndarray, rotation: float) -> None:
        from app.reference.environment import equirect_uv

        self.h, self.w = env.shape[:2]
        self.rotation = rotation
        self.uv = equirect_uv
        _, omega = texel_directions(self.h, self.w)
        lum = np.maximum(env[..., :3] @ np.array([0.2126, 0.7152, 0.0722]), 0.0)
        weight = lum * omega
        p = 0.9 * weight / weight.sum() + 0.1 * omega / omega.sum()
        self.p = p.reshape(-1)
        self.cdf = np.cumsum(self.p)
        self.cdf /= self.cdf[-1]

    def sample(self, rng: np.random.Generator, count: int) -> np.ndarray:
        """``count`` world directions (count, 3)."""
        idx = np.minimum(np.searchsorted(self.cdf, rng.random(count)), self.p.size - 1)
        j, i = np.divmod(idx, self.w)
        u = (i + rng.random(count)) / self.w
        v = (j + rng.random(count)) / self.h
        theta, phi = v * math.pi, (u - 0.5) * 2.0 * math.pi
        # invert equirect_uv: u = 1/2 + atan2(d.x, -d.z)/(2 pi), v = acos(d.y)/pi
        d = np.stack([np.sin(theta) * np.sin(phi), np.cos(theta), -np.sin(theta) * np.cos(phi)], -1)
        return rotate_y(d, self.rotation)

    def pdf(self, d: np.ndarray) -> np.ndarray:
        """The density per steradian of drawing world directions ``d`` (..., 3)."""
        uv = self.uv(d, self.rotation)
        i = np.clip((uv[..., 0] * self.w).astype(int), 0, self.w - 1)
        j = np.clip((uv[..., 1] * self.h).astype(int), 0, self.h - 1)
        sin = np.maximum(np.sin(uv[..., 1] * math.pi), 1e-12)
        return self.p[j * self.w + i] * self.w * self.h / (2.0 * math.pi**2 * sin)


def monte_carlo_radiance(
    env: np.ndarray,
    rotation: float,
    point: ShadingPoint,
    samples: int,
    seed: int = 0,
    model: Model = DEFAULT_MODEL,
) -> np.ndarray:
    """L_o(v) = integral f(l, v) L(l) (n.l)+ dl for P isotropic shading points (``point``'s
    fields (P, ...)) by Monte Carlo, the map read bilinearly (``sample_bilinear``, as a
    continuous function, not as the texel sum's constant patches): ``samples`` directions
    per point and strategy in all, GGX visible normals (Heitz 2018), cosine directions and
    directions drawn from the map's luminance (``_MapSampler``: the compact bright windows
    and lamps), combined by Veach's balance heuristic; each point's Hammersley set turned
    by its own random offset (Cranley-Patterson), so the points' errors are independent.
    Returns (2, P, 3): two independent estimates of ``samples // 2`` directions per
    strategy each (their mean is the estimate; their difference measures its noise)."""
    from app.reference.environment import equirect_uv, sample_bilinear
    from app.reference.environment_uniform import ggx_vndf_pdf, hammersley

    n = np.asarray(point.n, np.float64)
    v = np.asarray(point.v, np.float64)
    count = n.shape[0]
    r = np.maximum(np.asarray(point.s.perceptual_roughness, np.float64), MIN_PERCEPTUAL_ROUGHNESS)
    alpha = np.broadcast_to(r * r, (count,))
    # the frame: z = n, x along v's projection on the surface
    x = v - np.sum(v * n, -1, keepdims=True) * n
    norm = np.linalg.norm(x, axis=-1, keepdims=True)
    other = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    x = np.where(norm > 1e-9, x / np.maximum(norm, 1e-300), np.cross(n, other))
    x /= np.linalg.norm(x, axis=-1, keepdims=True)
    y = np.cross(n, x)
    frame = np.stack([x, y, n], axis=-1)  # columns
    v_local = np.einsum("pij,pi->pj", frame, v)
    v_local[:, 2] = np.maximum(v_local[:, 2], MIN_N_DOT_V)
    v_local /= np.linalg.norm(v_local, axis=-1, keepdims=True)
    rng = np.random.default_rng(seed)
    sampler = _MapSampler(np.asarray(env, np.float64), rotation)
    halves = np.zeros((2, count, 3))
    per_half = max(samples // 2, 1)
    for k in range(2):  # two independent estimates: a Hammersley set each, own offsets
        offset = rng.random((count, 2))
        for i in range(per_half):
            h1, h2 = hammersley(i, per_half)
            u1, u2 = (h1 + offset[:, 0]) % 1.0, (h2 + offset[:, 1]) % 1.0
            m = _ggx_vndf_directions(v_local, alpha, u1, u2)
            l_ggx = 2.0 * np.sum(v_local * m, -1, keepdims=True) * m - v_local
            rc, phi = np.sqrt(u1), 2.0 * math.pi * u2
            z = np.sqrt(np.maximum(1.0 - u1, 0.0))
            l_cos = np.stack([rc * np.cos(phi), rc * np.sin(phi), z], -1)
            l_map = np.einsum("pij,pi->pj", frame, sampler.sample(rng, count))
            for l_local in (l_ggx, l_cos, l_map):
                l = np.einsum("pij,pj->pi", frame, l_local)
                cos = l_local[:, 2]
                pdf = ggx_vndf_pdf(v_local, l_local, alpha, alpha) + np.maximum(cos, 0) / math.pi
                pdf = pdf + sampler.pdf(l)
                f = brdf_eval(point, model, l)
                radiance = sample_bilinear(env, equirect_uv(l, rotation))
                ok = (cos > 0.0) & (pdf > 0.0)
                w = np.where(ok, np.maximum(cos, 0.0) / np.where(ok, pdf, 1.0), 0.0) / per_half
                halves[k] += f * radiance * w[:, None]
    return halves
