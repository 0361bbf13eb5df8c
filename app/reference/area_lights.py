"""Twin of glsl/lights/area.glsl: rectangle, disk, sphere and tube lights by linearly
transformed cosines (Heitz, Dupuy, Hill and Neubelt 2016), and their exact integral.

An area light of uniform radiance L adds to the reflectance equation (RTR4 §9.3, eq. 9.3)

    L_o = integral over the light of f(l, v) L (n.l)+ dl.

Both lobes reduce to the clamped-cosine integral of a polygon (Lambert's edge formula,
RTR4 §10.1's form factor: I(P) = 1/2 sum_edges angle_e (n_e . z) after the polygon is clipped
to the horizon), the specular one after the polygon is transformed by the LTC's M^-1 that
scripts/ltc_tables.py fitted to the project's GGX lobe (height-correlated Smith G2):

    L_o ~ L [ f_diffuse(l_rep) I(P) + (F0 (n_D - f_b) + f_b) I(M^-1 P) / pi ]

f_diffuse at the representative direction l_rep (the clipped polygon's vector form factor):
exact for Lambert, whose LTC is the cosine itself. Shapes as polygons: a rectangle exactly;
a disk as a regular polygon of the same area, its sides by roughness (``polygon_sides``:
24, 12 or 8); a sphere as its silhouette disk (the cone of directions it subtends from the
point: the same set of directions, so exact but for the polygon), its diffuse lobe in
closed form (``sphere_form_factor``, Snyder 1996); a tube (a capsule) as a stadium: its
axis segment widened, perpendicular to the direction to the point, by the cylinder's
silhouette half-width, with half-polygon caps of ``TUBE_CAP_SIDES`` sides (exact for the
cylinder's straight part, an approximation at the caps, measured in docs/area_lights.md).
A clear coat adds its own lobe, a second LTC at the coat's roughness (``coat_lobe``), and
weights the base's lobes through the coat (``coat_weight``). Not included: sheen, fibre
and grating layers, multiple scattering, other NDFs and anisotropy (the base's lobe is
the isotropic GGX of the material's roughness and F0).

``area_light_exact`` is the ray-caster's truth: the same integral sampled over the light's
surface and the GGX lobe in float64 (balance heuristic), with the whole BRDF.
"""

from __future__ import annotations

import math
from functools import lru_cache
from pathlib import Path

import numpy as np

from app.common.lights import LightType, PunctualLight
from app.common.models import Model
from app.common.tables import DATA_DIR
from app.reference import clearcoat
from app.reference._vec import dot, normalize
from app.reference.constants import MIN_N_DOT_L, MIN_PERCEPTUAL_ROUGHNESS, PI
from app.reference.material import (
    ShadingPoint,
    Surface,
    brdf_eval,
    brdf_factors,
    clearcoat_base_point,
    material_F0,
    selected_terms,
    shading_cosines,
)
from app.reference.punctual import window_falloff

LTC_SIZE = 32  # the table's cells per axis (roughness, sqrt(1 - n.v))
LTC_MIN_NOV = 1e-3  # the grazing column's n.v (the fit's and the lookup's floor)
# A disk's (and a sphere's silhouette's) polygon's sides by perceptual roughness: a smooth
# lobe sees the polygon's corners, a rough one does not (polygon_sides; the error against
# sides is scripts/area_light_errors.py's, docs/area_lights.md "Polygon sides").
POLYGON_SIDES = 24  # roughness < SIDES_ROUGH_12
SIDES_ROUGH_12 = 0.15  # from here 12 sides
SIDES_ROUGH_8 = 0.25  # from here 8 sides
TUBE_CAP_SIDES = 4  # each of a tube's two half-polygon caps
MAX_POLYGON = max(POLYGON_SIDES, 2 * (TUBE_CAP_SIDES + 1))  # the most vertices a shape has
# The exact integral's samples per strategy (area_light_exact; the ray-caster's default)
EXACT_SAMPLES = 1024


def ltc_table_path(size: int = LTC_SIZE) -> Path:
    """The shipped table (scripts/ltc_tables.py writes it)."""
    return DATA_DIR / f"ltc_ggx_{size}.npy"


@lru_cache(maxsize=2)
def ltc_table(size: int = LTC_SIZE) -> np.ndarray:
    """(size, size, 8) float64, read-only: M^-1's a, b, c, d, n_D, f_b, the fit's L1 error."""
    table = np.load(ltc_table_path(size))
    table.flags.writeable = False
    return table


def ltc_coords(roughness: np.ndarray, NoV: np.ndarray, size: int = LTC_SIZE) -> tuple:
    """(row, column) fractional cell indices of (perceptual roughness, n.v)."""
    r = np.clip(np.asarray(roughness, np.float64), MIN_PERCEPTUAL_ROUGHNESS, 1.0)
    nov = np.clip(np.asarray(NoV, np.float64), LTC_MIN_NOV, 1.0)
    x = (r - MIN_PERCEPTUAL_ROUGHNESS) / (1.0 - MIN_PERCEPTUAL_ROUGHNESS) * (size - 1)
    y = np.sqrt(1.0 - nov) * (size - 1)
    return x, y


def ltc_lookup(roughness: np.ndarray, NoV: np.ndarray, size: int = LTC_SIZE) -> np.ndarray:
    """(..., 6) the table bilinearly interpolated between cell centres (as the GLSL's four
    texelFetch reads): a, b, c, d, n_D, f_b."""
    table = ltc_table(size)[..., :6]
    x, y = ltc_coords(roughness, NoV, size)
    x0 = np.clip(np.floor(x).astype(int), 0, size - 2)
    y0 = np.clip(np.floor(y).astype(int), 0, size - 2)
    fx = (x - x0)[..., None]
    fy = (y - y0)[..., None]
    top = table[x0, y0] * (1.0 - fy) + table[x0, y0 + 1] * fy
    bottom = table[x0 + 1, y0] * (1.0 - fy) + table[x0 + 1, y0 + 1] * fy
    return top * (1.0 - fx) + bottom * fx


# --- the light's shape as a polygon seen from the shaded points ---


def _perpendicular(a: np.ndarray) -> np.ndarray:
    """A unit vector perpendicular to unit ``a`` (..., 3)."""
    helper = np.where((np.abs(a[..., 0]) < 0.9)[..., None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    return normalize(np.cross(a, helper))


def _ring(sides: int, start: float, stop: float, closed: bool) -> tuple[np.ndarray, np.ndarray]:
    """cos, sin of ``sides`` angles from start to stop (stop included unless ``closed``)."""
    count = sides if closed else sides + 1
    a = start + (stop - start) * np.arange(count) / sides
    return np.cos(a), np.sin(a)


def disk_scale(sides: int = POLYGON_SIDES) -> float:
    """The circumradius of the regular ``sides``-gon of a unit disk's area."""
    return math.sqrt(2.0 * math.pi / (sides * math.sin(2.0 * math.pi / sides)))


def polygon_sides(roughness: np.ndarray) -> np.ndarray:
    """A disk's or sphere's polygon's sides at these perceptual roughnesses (24, 12, 8)."""
    r = np.asarray(roughness, np.float64)
    return np.where(r < SIDES_ROUGH_12, POLYGON_SIDES, np.where(r < SIDES_ROUGH_8, 12, 8))


def cap_scale(sides: int) -> float:
    """The radius, over the tube's, of a half-polygon cap's inner vertices (``sides`` edges,
    its two ends at the tube's radius so the straight sides keep its width) that gives the
    cap a half-disk's area: the root of (sides - 2)/2 sin(d) s^2 + sin(d) s = pi/2, d = pi /
    sides (the fan of triangles from the end's centre)."""
    sin_d = math.sin(math.pi / sides)
    qa = 0.5 * (sides - 2) * sin_d
    if qa == 0.0:
        return 0.5 * math.pi / sin_d
    return (-sin_d + math.sqrt(sin_d * sin_d + 2.0 * math.pi * qa)) / (2.0 * qa)


def light_polygon(
    light: PunctualLight, p: np.ndarray, sides: int | np.ndarray | None = None
) -> np.ndarray:
    """(N, K, 3) the light's polygon's vertices relative to the points ``p`` (N, 3), in the
    order the GLSL builds them (area_polygon). ``sides``: a disk's or sphere's polygon's
    sides, twice a tube's caps' (by default ``POLYGON_SIDES``, a tube's 2 TUBE_CAP_SIDES;
    the error against sides is scripts/area_light_errors.py's); one per point (N,) gives
    each its own polygon, padded by its last vertex repeated (an edge of no length adds
    nothing to the integral)."""
    p = np.asarray(p, np.float64)
    if sides is None:
        sides = 2 * TUBE_CAP_SIDES if light.type == LightType.TUBE else POLYGON_SIDES
    per_point = np.broadcast_to(np.asarray(sides, int), (len(p),))
    counts = np.unique(per_point)
    if len(counts) == 1:
        return _polygon(light, p, int(counts[0]))
    width = max(int(k) + (2 if light.type == LightType.TUBE else 0) for k in counts)
    out = np.zeros((len(p), width, 3))
    for k in counts:
        rows = per_point == k
        poly = _polygon(light, p[rows], int(k))
        out[rows, : poly.shape[1]] = poly
        out[rows, poly.shape[1] :] = poly[:, -1:]
    return out


def _polygon(light: PunctualLight, p: np.ndarray, sides: int) -> np.ndarray:
    """light_polygon's (N, K, 3) for one ``sides`` at every point."""
    p = np.asarray(p, np.float64)
    c = np.asarray(light.position, np.float64)
    u = np.asarray(light.axis_u, np.float64)
    w = np.asarray(light.axis_v, np.float64)
    if light.type == LightType.RECT:
        corners = np.array([c - u - w, c + u - w, c + u + w, c - u + w])
        return corners[None] - p[:, None]
    if light.type == LightType.DISK:
        cs, sn = _ring(sides, 0.0, 2.0 * math.pi, True)
        k = disk_scale(sides)
        ring = c + k * (cs[:, None] * u + sn[:, None] * w)
        return ring[None] - p[:, None]
    d = c - p  # towards the centre
    dist = np.linalg.norm(d, axis=-1)
    axis = d / np.maximum(dist, 1e-300)[:, None]
    r = light.radius
    if light.type == LightType.SPHERE:
        # the silhouette circle: centre at dist - r^2/dist along the axis, radius
        # r sqrt(dist^2 - r^2) / dist (the cone tangent to the sphere); inside: none
        d2 = np.maximum(dist * dist - r * r, 0.0)
        back = (r * r / np.maximum(dist, 1e-300))[:, None] * axis
        rad = (r * np.sqrt(d2) / np.maximum(dist, 1e-300)) * disk_scale(sides)
        e1 = _perpendicular(axis)
        e2 = np.cross(axis, e1)
        cs, sn = _ring(sides, 0.0, 2.0 * math.pi, True)
        return (d - back)[:, None] + rad[:, None, None] * (
            cs[None, :, None] * e1[:, None] + sn[None, :, None] * e2[:, None]
        )
    # tube: the axis segment c +- u widened by r perpendicular to it and to the point
    length = np.linalg.norm(u)
    t = u / max(length, 1e-300)
    side = np.cross(t, axis)
    side_len = np.linalg.norm(side, axis=-1)
    side = np.where(
        (side_len > 1e-9)[:, None], side / np.maximum(side_len, 1e-300)[:, None],
        _perpendicular(np.broadcast_to(t, axis.shape)),
    )  # fmt: skip
    # the half-width: the tangent planes' from the point to the cylinder meet the plane
    # through the axis at r D / sqrt(D^2 - r^2), D the point's distance to the axis line
    off_axis = d - dot(d, t)[:, None] * t
    D2 = np.maximum(dot(off_axis, off_axis), 4.0 * r * r)
    width = r * np.sqrt(D2 / (D2 - r * r))
    cap = max(sides // 2, 2)
    k = np.full(cap + 1, cap_scale(cap))
    k[0] = k[-1] = 1.0  # the straight sides keep the width
    cs, sn = _ring(cap, -0.5 * math.pi, 0.5 * math.pi, False)
    ring = (width[:, None] * k[None, :])[..., None] * (
        cs[None, :, None] * t + sn[None, :, None] * side[:, None]
    )
    cap_b = (d + u)[:, None] + ring
    cap_a = (d - u)[:, None] - ring
    return np.concatenate([cap_b, cap_a], axis=1)


# --- the clamped-cosine integral of a polygon (Lambert; Arvo 1995's edge integral) ---


def _edge(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The edge's vector integral: angle(a, b) times the unit normal of the plane through
    a and b (atan2 of |a x b| and a.b: accurate for short edges, where acos is not)."""
    c = np.cross(a, b)
    s = np.linalg.norm(c, axis=-1)
    angle = np.arctan2(s, dot(a, b))
    return np.where((s > 0.0)[..., None], c * (angle / np.where(s > 0.0, s, 1.0))[..., None], 0.0)


def clipped_form_factor(verts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(I, F): the integral of max(z, 0) over the directions of the convex polygon ``verts``
    (N, K, 3) (its vertices' directions from the origin, in either winding), and its vector
    form factor F (N, 3), whose z is I. The polygon is clipped to the horizon z >= 0 edge by
    edge (a crossing edge keeps its upper part; the horizon arc from where the boundary
    leaves to where it comes back closes it)."""
    n, k, _ = verts.shape
    total = np.zeros((n, 3))
    exit_pt = np.zeros((n, 3))
    entry_pt = np.zeros((n, 3))
    crossed = np.zeros(n, bool)
    for i in range(k):
        a = verts[:, i]
        b = verts[:, (i + 1) % k]
        za, zb = a[:, 2], b[:, 2]
        denom = np.where(za - zb == 0.0, 1.0, za - zb)
        x = a + (b - a) * (za / denom)[:, None]
        x[:, 2] = 0.0
        above_a, above_b = za >= 0.0, zb >= 0.0
        start = np.where(above_a[:, None], a, x)
        stop = np.where(above_b[:, None], b, x)
        keep = above_a | above_b
        total += np.where(keep[:, None], _edge(start, stop), 0.0)
        leaving = above_a & ~above_b
        coming = ~above_a & above_b
        exit_pt = np.where(leaving[:, None], x, exit_pt)
        entry_pt = np.where(coming[:, None], x, entry_pt)
        crossed |= leaving
    total += np.where(crossed[:, None], _edge(exit_pt, entry_pt), 0.0)
    F = 0.5 * total
    sign = np.where(F[:, 2] < 0.0, -1.0, 1.0)
    F = F * sign[:, None]
    return F[:, 2], F


# --- the light's term ---


def area_radiance(kind: LightType, c_light: np.ndarray, u: np.ndarray, w: np.ndarray, r: float):
    """The emitted radiance L of an area light whose power matches a point light of
    c_light (RTR4 §9.4's c_light at 1 m): far away, head-on (a rectangle or disk facing
    the point, a tube seen side-on), both give a white Lambert surface c_light / d^2:
    L = pi c_light / A with A the projected area (4 |u| |w|, pi |u| |w|, pi r^2,
    4 r |u| + pi r^2)."""
    area = {
        LightType.RECT: 4.0 * float(np.linalg.norm(u) * np.linalg.norm(w)),
        LightType.DISK: math.pi * float(np.linalg.norm(u) * np.linalg.norm(w)),
        LightType.SPHERE: math.pi * r * r,
        LightType.TUBE: 4.0 * r * float(np.linalg.norm(u)) + math.pi * r * r,
    }[kind]
    return np.asarray(c_light, np.float64) * (math.pi / area)


def emitting_side(light: PunctualLight, p: np.ndarray) -> np.ndarray:
    """(N,) bool: the points a one-sided rectangle or disk shines on (in front of it, its
    normal u x w the way it emits); every point for a sphere or a tube."""
    if light.type in (LightType.SPHERE, LightType.TUBE):
        return np.ones(len(p), bool)
    normal = np.cross(light.axis_u, light.axis_v)
    return dot(np.asarray(p, np.float64) - light.position, normal) > 0.0


def sphere_form_factor(cos_theta: np.ndarray, sin2_sigma: np.ndarray) -> np.ndarray:
    """The clamped-cosine integral of a sphere's directions (a cone of half-angle sigma
    around a direction at angle theta from the normal), clipped to the horizon, in closed
    form (Snyder 1996, "Area Light Sources for Real-Time Graphics", MSR-TR-96-11; as in
    Lagarde and de Rousiers 2014, "Moving Frostbite to PBR", section 4.7.2):
    pi sin^2 sigma cos theta when the cone is wholly above the horizon, 0 when wholly
    below, and between, with x = cot sigma, y = -x cot theta,
    sin^2 sigma (cos theta acos y - x sin theta sqrt(1 - y^2))
    + atan(sin theta sqrt(1 - y^2) / x)."""
    c = np.clip(np.asarray(cos_theta, np.float64), -1.0, 1.0)
    s2 = np.clip(np.asarray(sin2_sigma, np.float64), 1e-300, 1.0)
    sin_t = np.sqrt(np.maximum(1.0 - c * c, 1e-300))
    x = np.sqrt(np.maximum(1.0 / s2 - 1.0, 0.0))
    y = np.clip(-x * c / sin_t, -1.0, 1.0)
    q = sin_t * np.sqrt(1.0 - y * y)
    crossing = s2 * (c * np.arccos(y) - x * q) + np.arctan2(q, x)
    whole = math.pi * s2 * np.maximum(c, 0.0)
    return np.maximum(np.where(c * c > s2, whole, crossing), 0.0)


def sphere_diffuse(light: PunctualLight, p: np.ndarray, n: np.ndarray) -> tuple:
    """(I, l_rep): a sphere light's clamped-cosine integral at the points (closed form,
    ``sphere_form_factor``; 0 inside it, as the truth, which sees no surface from there)
    and the direction the diffuse model is taken at: the centre's, moved up to the horizon
    where it is below (exact for Lambert, which does not use it)."""
    d = np.asarray(light.position, np.float64) - p
    d2 = dot(d, d)
    axis = d / np.sqrt(np.maximum(d2, 1e-300))[:, None]
    r2 = light.radius * light.radius
    cos_t = dot(axis, n)
    I = np.where(d2 > r2, sphere_form_factor(cos_t, r2 / np.maximum(d2, 1e-300)), 0.0)
    lifted = axis - n * np.minimum(cos_t, 0.0)[:, None]
    length = np.linalg.norm(lifted, axis=-1)
    l_rep = np.where((length > 1e-6)[:, None], lifted / np.maximum(length, 1e-300)[:, None], n)
    return I, l_rep


def _local(verts: np.ndarray, t1: np.ndarray, t2: np.ndarray, n: np.ndarray) -> np.ndarray:
    return np.stack([dot(verts, t1[:, None]), dot(verts, t2[:, None]), dot(verts, n[:, None])], -1)


def coat_weight(point: ShadingPoint, model: Model, l: np.ndarray) -> np.ndarray:
    """(N, 3) what reaches the base's specular lobe through the coat and back, at the
    direction ``l`` (the light's representative one), as the punctual coated BRDF weights
    it (material.clearcoat_factors' w: the coat's two Fresnel crossings, Weidlich-Wilkie's
    solid-angle compression, Beer-Lambert absorption), the coat's normal nc's cosines."""
    p = point.params
    nc = point.n if point.nc is None else point.nc
    _, _, NoV, _ = shading_cosines(nc, l, point.v)
    NoL = np.clip(dot(nc, l), MIN_N_DOT_L, 1.0)
    c = p.clearcoat
    F0c = clearcoat.clearcoat_F0(p.clearcoat_eta)
    compression = 1.0
    refracts = model.clearcoat in ("weidlich_wilkie", "weidlich_wilkie_series")
    if refracts and np.any(np.asarray(c) > 0.0):
        eta_c = 1.0 - c + p.clearcoat_eta * c
        compression = clearcoat.clearcoat_solid_angle_compression(eta_c)
    T = clearcoat.T_clearcoat_filament(c, F0c, NoL, NoV)
    A = clearcoat.A_clearcoat_beer_lambert(p.clearcoat_color, p.clearcoat_eta, NoL, NoV)
    c_rgb = np.asarray(c, np.float64)[..., None] if np.ndim(c) else c
    return (T * compression)[..., None] * (1.0 - c_rgb + A * c_rgb)


def coat_lobe(point: ShadingPoint, verts: np.ndarray) -> np.ndarray:
    """(N,) the clear coat's own lobe over the light's polygon ``verts`` (N, K, 3, from the
    points): c f_coat(l, v) (nc.l)+ integrated, by the same LTC table at the coat's
    roughness and nc.v in the frame of the coat's normal nc (the coat's lobe is the
    table's GGX with the height-correlated G2 and Schlick's F at F0c), divided by pi."""
    p = point.params
    n, v = point.n, point.v
    nc = n if point.nc is None else np.broadcast_to(point.nc, n.shape)
    count = len(n)
    t1, t2 = view_frame(nc, v)
    local = _local(verts, t1, t2, nc)
    rc = np.broadcast_to(np.maximum(p.clearcoat_roughness, MIN_PERCEPTUAL_ROUGHNESS), (count,))
    fit = ltc_lookup(rc, np.clip(dot(nc, v), LTC_MIN_NOV, 1.0))
    minv = np.zeros((count, 3, 3))
    minv[:, 0, 0], minv[:, 0, 2], minv[:, 1, 1] = fit[:, 0], fit[:, 1], fit[:, 2]
    minv[:, 2, 0], minv[:, 2, 2] = fit[:, 3], 1.0
    I_c, _ = clipped_form_factor(np.einsum("nij,nkj->nki", minv, local))
    F0c = clearcoat.clearcoat_F0(p.clearcoat_eta)
    return p.clearcoat * (F0c * (fit[:, 4] - fit[:, 5]) + fit[:, 5]) * I_c / PI


def view_frame(n: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(t1, t2): t1 the unit tangent towards v (any where v is n), t2 = n x t1."""
    t1 = v - n * dot(n, v)[..., None]
    length = np.linalg.norm(t1, axis=-1)
    t1 = np.where(
        (length > 1e-6)[..., None], t1 / np.maximum(length, 1e-300)[..., None], _perpendicular(n)
    )
    return t1, np.cross(n, t1)


def area_light_term(
    point: ShadingPoint,
    model: Model,
    light: PunctualLight,
    terms: str = "all",
    sides: int | None = None,
) -> np.ndarray:
    """(N, 3) the light's L_o / pi at the points (the illumination sum multiplies by pi),
    by LTC (the module docstring); ``sides`` as ``light_polygon``'s."""
    p, n, v = point.position, point.n, point.v
    count = len(p)
    if sides is None and light.type in (LightType.DISK, LightType.SPHERE):
        # by the smoothest lobe that sees the polygon (a clear coat's, if smoother)
        roughness = np.broadcast_to(point.s.perceptual_roughness, (count,))
        if model.clearcoat != "none":
            coated = np.broadcast_to(point.params.clearcoat, (count,)) > 0.0
            coat_r = np.broadcast_to(point.params.clearcoat_roughness, (count,))
            roughness = np.where(coated, np.minimum(roughness, coat_r), roughness)
        sides = polygon_sides(roughness)
    verts = light_polygon(light, p, sides)
    t1, t2 = view_frame(n, v)
    local = _local(verts, t1, t2, n)
    if light.type == LightType.SPHERE:
        I_d, l_rep = sphere_diffuse(light, p, n)
    else:
        I_d, F_d = clipped_form_factor(local)
        # f_diffuse at the representative direction: the form factor's, in the world
        l_rep = F_d[:, 0:1] * t1 + F_d[:, 1:2] * t2 + F_d[:, 2:3] * n
        length = np.linalg.norm(l_rep, axis=-1)
        l_rep = np.where((length > 0.0)[:, None], l_rep / np.maximum(length, 1e-300)[:, None], n)
    NoV = np.clip(dot(n, v), LTC_MIN_NOV, 1.0)
    fit = ltc_lookup(point.s.perceptual_roughness, NoV)
    a, b, c, d = (fit[..., i] for i in range(4))
    minv = np.zeros((count, 3, 3))
    minv[:, 0, 0], minv[:, 0, 2], minv[:, 1, 1], minv[:, 2, 0], minv[:, 2, 2] = a, b, c, d, 1.0
    I_s, _ = clipped_form_factor(np.einsum("nij,nkj->nki", minv, local))
    F0 = material_F0(point.s, point.params)
    if model.clearcoat != "none":
        base = clearcoat_base_point(point, v)  # the base's F0 relative to the coat
        F0 = material_F0(base.s, base.params)
    spec = (F0 * (fit[..., 4:5] - fit[..., 5:6]) + fit[..., 5:6]) * (I_s / PI)[:, None]
    if model.clearcoat != "none":
        spec = coat_weight(point, model, l_rep) * spec + coat_lobe(point, verts)[:, None]
    f_d = brdf_factors(point, model, l_rep).f_diffuse
    Lo = selected_terms(f_d * I_d[:, None], spec, terms)
    window = window_falloff(dot(light.position - p, light.position - p), light.range)
    lit = emitting_side(light, p) & (I_d > 0.0)
    return np.where(lit[:, None], Lo * light.color * window[:, None], 0.0) / PI


# --- the exact integral (the ray-caster's truth) ---


def _light_samples(light: PunctualLight, count: int) -> tuple[np.ndarray, np.ndarray, float]:
    """``count`` stratified points on the light's surface (world), their unit normals and
    the surface's area (uniform in area). A sphere or tube: the whole closed surface."""
    side = math.ceil(math.sqrt(count))
    i, j = np.meshgrid(np.arange(side), np.arange(side), indexing="ij")
    rng = np.random.default_rng(7)
    s = ((i.ravel() + rng.random(side * side)) / side)[:, None]
    t = ((j.ravel() + rng.random(side * side)) / side)[:, None]
    c = np.asarray(light.position, np.float64)
    u = np.asarray(light.axis_u, np.float64)
    w = np.asarray(light.axis_v, np.float64)
    r = light.radius
    if light.type == LightType.RECT:
        normal = normalize(np.cross(u, w))
        pts = c + (2.0 * s - 1.0) * u + (2.0 * t - 1.0) * w
        return pts, np.broadcast_to(normal, pts.shape), 4.0 * np.linalg.norm(u) * np.linalg.norm(w)
    if light.type == LightType.DISK:
        normal = normalize(np.cross(u, w))
        rad, phi = np.sqrt(s), 2.0 * math.pi * t
        pts = c + rad * np.cos(phi) * u + rad * np.sin(phi) * w
        return pts, np.broadcast_to(normal, pts.shape), math.pi * float(np.linalg.norm(u)) ** 2
    if light.type == LightType.SPHERE:
        z = 1.0 - 2.0 * s
        q = np.sqrt(np.maximum(0.0, 1.0 - z * z))
        phi = 2.0 * math.pi * t
        nrm = np.concatenate([q * np.cos(phi), q * np.sin(phi), z], axis=1)
        return c + r * nrm, nrm, 4.0 * math.pi * r * r
    # tube: the cylinder and the two hemispheres, each by its share of the area
    length = 2.0 * float(np.linalg.norm(u))
    ax = u / max(np.linalg.norm(u), 1e-300)
    e1 = _perpendicular(ax[None])[0]
    e2 = np.cross(ax, e1)
    area_cyl = 2.0 * math.pi * r * length
    area = area_cyl + 4.0 * math.pi * r * r
    on_cyl = s[:, 0] < area_cyl / area
    s_c = s / (area_cyl / area)
    s_s = (s - area_cyl / area) / (1.0 - area_cyl / area)
    phi = 2.0 * math.pi * t
    ring = np.cos(phi) * e1 + np.sin(phi) * e2
    cyl = c + (2.0 * s_c - 1.0) * u + r * ring
    z = 1.0 - 2.0 * s_s
    q = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    nrm = z * ax + q * ring
    cap = c + np.where(z >= 0.0, 1.0, -1.0) * u + r * nrm
    pts = np.where(on_cyl[:, None], cyl, cap)
    return pts, np.where(on_cyl[:, None], ring, nrm), area


def _hit_distance(light: PunctualLight, o: np.ndarray, d: np.ndarray) -> np.ndarray:
    """(N, S) distance along unit d (N, S, 3) from o (N, 3) to the light's front surface,
    inf where the ray misses it (a one-sided shape from behind: a miss)."""
    c = np.asarray(light.position, np.float64)
    u = np.asarray(light.axis_u, np.float64)
    w = np.asarray(light.axis_v, np.float64)
    r = light.radius
    oc = (o - c)[:, None, :]
    inf = np.inf
    if light.type in (LightType.RECT, LightType.DISK):
        normal = normalize(np.cross(u, w))
        den = d @ normal
        with np.errstate(divide="ignore", invalid="ignore"):
            tt = -(oc @ normal) / den
        q = oc + tt[..., None] * d
        x = (q @ u) / (u @ u)
        y = (q @ w) / (w @ w)
        inside = (np.abs(x) <= 1) & (np.abs(y) <= 1)
        if light.type == LightType.DISK:
            inside = x * x + y * y <= 1.0
        return np.where((den < 0.0) & (tt > 0.0) & inside, tt, inf)

    def sphere_hit(centre_offset: np.ndarray) -> np.ndarray:
        oo = oc - centre_offset
        bq = np.sum(oo * d, axis=-1)
        cq = np.sum(oo * oo, axis=-1) - r * r
        disc = bq * bq - cq
        tt = -bq - np.sqrt(np.maximum(disc, 0.0))
        return np.where((disc >= 0.0) & (tt > 0.0), tt, inf)

    if light.type == LightType.SPHERE:
        return sphere_hit(np.zeros(3))
    # capsule: the infinite cylinder clipped to the segment, and the end spheres
    half = float(np.linalg.norm(u))
    ax = u / max(half, 1e-300)
    dp = d - (d @ ax)[..., None] * ax
    op = oc - (oc @ ax)[..., None] * ax
    qa = np.sum(dp * dp, axis=-1)
    qb = np.sum(dp * op, axis=-1)
    qc = np.sum(op * op, axis=-1) - r * r
    disc = qb * qb - qa * qc
    with np.errstate(divide="ignore", invalid="ignore"):
        tt = (-qb - np.sqrt(np.maximum(disc, 0.0))) / qa
    along = (oc @ ax) + tt * (d @ ax)
    cyl = np.where((disc >= 0.0) & (qa > 0.0) & (tt > 0.0) & (np.abs(along) <= half), tt, inf)
    return np.minimum(cyl, np.minimum(sphere_hit(u), sphere_hit(-u)))


def area_light_exact(
    point: ShadingPoint,
    model: Model,
    light: PunctualLight,
    terms: str = "all",
    samples: int | None = None,
) -> np.ndarray:
    """(N, 3) the light's L_o / pi at the points: integral f(l, v) L (n.l)+ dl over the
    light in float64, by ``samples`` points on its surface (solid-angle pdf d^2 / (A cos_l))
    and as many GGX-reflected directions (pdf D (n.h) / (4 v.h); ``samples`` by default
    ``EXACT_SAMPLES``), balance heuristic; the whole BRDF of ``model``; the light occludes
    itself (a sphere's or tube's far side, a one-sided shape's back), nothing else does.
    The window falloff is the centre's, as in the renderer."""
    p, n, v = point.position, point.n, point.v
    count = len(p)
    samples = EXACT_SAMPLES if samples is None else samples
    L = np.asarray(light.color, np.float64)
    pts, nrm, area = _light_samples(light, samples)
    out = np.zeros((count, 3))
    alpha = (
        np.maximum(np.asarray(point.s.perceptual_roughness, np.float64), MIN_PERCEPTUAL_ROUGHNESS)
        ** 2
    )
    alpha = np.broadcast_to(alpha, (count,))
    t1, t2 = view_frame(n, v)
    side = math.ceil(math.sqrt(samples))
    i, j = np.meshgrid(np.arange(side), np.arange(side), indexing="ij")
    rng = np.random.default_rng(11)
    xi1 = (i.ravel() + rng.random(side * side)) / side
    xi2 = (j.ravel() + rng.random(side * side)) / side
    chunk = max(1, 2_000_000 // max(len(pts), 1))
    for start in range(0, count, chunk):
        sl = slice(start, min(start + chunk, count))
        pp, nn, vv = p[sl], n[sl], v[sl]
        sub = ShadingPoint(
            _spread(point.s, sl, count), point.params, nn[:, None], None,
            np.asarray(point.t, np.float64)[sl][:, None], vv[:, None], pp[:, None],
        )  # fmt: skip
        # strategy 1: points on the light
        d = pts[None] - pp[:, None]
        dist2 = np.sum(d * d, axis=-1)
        l1 = d / np.sqrt(dist2)[..., None]
        cos_l = -np.sum(l1 * nrm[None], axis=-1)
        t_hit = _hit_distance(light, pp, l1)
        visible = (cos_l > 0.0) & (t_hit >= np.sqrt(dist2) * (1.0 - 1e-9))
        pdf_light = np.where(visible, dist2 / (area * np.maximum(cos_l, 1e-300)), 0.0)
        # strategy 2: GGX-reflected directions
        a = alpha[sl][:, None]
        tan2 = a * a * xi1[None] / np.maximum(1.0 - xi1[None], 1e-300)
        ct = 1.0 / np.sqrt(1.0 + tan2)
        st = np.sqrt(np.maximum(0.0, 1.0 - ct * ct))
        ph = 2.0 * math.pi * xi2[None]
        h = (
            (st * np.cos(ph))[..., None] * t1[sl][:, None]
            + (st * np.sin(ph))[..., None] * t2[sl][:, None]
            + ct[..., None] * nn[:, None]
        )
        voh = np.sum(vv[:, None] * h, axis=-1)
        l2 = 2.0 * voh[..., None] * h - vv[:, None]
        t2_hit = _hit_distance(light, pp, l2)
        hit2 = np.isfinite(t2_hit)

        for l, pdf_self, other, ok in (
            (l1, pdf_light, _ggx_pdf(l1, vv, nn, a), visible),
            (l2, _ggx_pdf(l2, vv, nn, a), _light_pdf(light, pp, l2, t2_hit, area), hit2),
        ):
            f = brdf_eval(sub, model, l, terms=terms)
            nol = np.maximum(np.sum(l * nn[:, None], axis=-1), 0.0)
            denom = pdf_self + other
            weight = np.where(ok & (denom > 0.0), nol / np.where(denom > 0.0, denom, 1.0), 0.0)
            out[sl] += np.sum(f * weight[..., None], axis=1) / (side * side)
    window = window_falloff(dot(light.position - p, light.position - p), light.range)
    return out * L * window[:, None] / PI


def _ggx_pdf(l: np.ndarray, v: np.ndarray, n: np.ndarray, a: np.ndarray) -> np.ndarray:
    """(N, S) the solid-angle pdf of GGX-reflected directions l (N, S, 3): D (n.h) / (4 v.h)."""
    hh = normalize(l + v[:, None])
    noh = np.sum(hh * n[:, None], axis=-1)
    vh = np.sum(hh * v[:, None], axis=-1)
    a2 = a * a
    dd = noh * noh * (a2 - 1.0) + 1.0
    pdf = a2 / (math.pi * dd * dd) * noh / (4.0 * np.maximum(vh, 1e-300))
    return np.where((noh > 0.0) & (vh > 0.0), pdf, 0.0)


def _light_pdf(
    light: PunctualLight, p: np.ndarray, l: np.ndarray, t_hit: np.ndarray, area: float
) -> np.ndarray:
    """(N, S) the solid-angle pdf of uniform points on the light's surface towards l from
    p, at the surface point the ray reaches first (t_hit; 0 where it misses)."""
    hit = np.isfinite(t_hit)
    t = np.where(hit, t_hit, 0.0)
    q = p[:, None] + t[..., None] * l
    cosq = np.abs(np.sum(_normal_at(light, q) * l, axis=-1))
    return np.where(hit, t * t / (area * np.maximum(cosq, 1e-300)), 0.0)


def _spread(s: Surface, sl: slice, count: int) -> Surface:
    """The points ``sl`` of ``s`` with an axis for the samples: (m, 1) and (m, 1, 3)."""

    def pick(x: np.ndarray | float, width: int) -> np.ndarray:
        x = np.asarray(x, np.float64)
        shape = (count, 3) if width == 3 else (count,)
        return np.broadcast_to(x, shape)[sl][:, None]

    return Surface(
        pick(s.base_color, 3), pick(s.metallic, 1), pick(s.perceptual_roughness, 1),
        pick(s.f0_dielectric, 1), pick(s.anisotropy, 1),
    )  # fmt: skip


def _normal_at(light: PunctualLight, q: np.ndarray) -> np.ndarray:
    """Unit outward normals of the light's surface at points q (..., 3) on it."""
    c = np.asarray(light.position, np.float64)
    u = np.asarray(light.axis_u, np.float64)
    if light.type in (LightType.RECT, LightType.DISK):
        return np.broadcast_to(normalize(np.cross(u, light.axis_v)), q.shape)
    if light.type == LightType.SPHERE:
        return normalize(q - c)
    half = float(np.linalg.norm(u))
    ax = u / max(half, 1e-300)
    s = np.clip((q - c) @ ax, -half, half)
    return normalize(q - (c + s[..., None] * ax))
