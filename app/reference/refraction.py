"""Exact refraction through analytic spheres: the reference that measures the screen-space
transmission pass (app/render/transmission.py; docs/transmission.md).

The float64 ray-caster (app/reference/raycast.py) sends each pixel's ray to its nearest
primitive; where that is a transmissive sphere, this module follows the light behind it
exactly, as the screen-space method cannot:

* thin-walled (``thickness`` 0, glTF's thin-walled semantics): the ray passes straight on
  (the two parallel interfaces of a thin shell cancel their bending), weighted by
  transmission (1 - F_schlick(n.v)) base_color, as the GLSL's weight;
* a solid sphere (``thickness`` > 0; the sphere's own geometry sets the path, not the
  thickness number): Snell refraction in (Walter et al. 2007's m for a rough surface, a
  GGX visible normal), the far intersection inside, Beer-Lambert over the true path length,
  Snell refraction out (total internal reflection ends the path: no light), weighted by
  the exact dielectric Fresnel of both interfaces, (1 - F_1)(1 - F_2).

A rough surface's lobe is integrated by ``samples`` x ``samples`` stratified GGX visible
normals (Heitz 2018) at the entry (both interfaces of a thin shell share it: the ray
leaves mirrored through the surface plane from the reflected direction, the glTF
thin-walled BTDF); what each ray reaches is shaded by the twins' illumination sum, seen
from the direction it arrives from, or is the background colour.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from app.common.camera import CameraFrame
from app.common.lights import PunctualLight
from app.common.primitives import Primitive
from app.reference._vec import dot, normalize
from app.reference.environment_uniform import sample_ggx_vndf
from app.reference.fresnel import F_dielectric
from app.reference.illumination import illumination_sum
from app.reference.material import ShadingPoint, Surface, sanitize_surface
from app.reference.raycast import (
    NO_HIT,
    PrimitiveMaterial,
    _frame,
    _to_object,
    cast,
    intersect_plane,
    intersect_sphere,
)
from app.reference.transmission import beer_lambert, refracted_direction, transmission_weight

# A ray leaving a surface starts this far along it (metres): clears the surface it leaves
# (float64 hits lie within ~1e-15 relative of it).
RAY_OFFSET = 1e-9


def _surface(mat: PrimitiveMaterial, count: int, diffuse_scale: float = 1.0) -> Surface:
    s = mat.surface
    return sanitize_surface(
        Surface(
            np.broadcast_to(np.asarray(s.base_color, np.float64) * diffuse_scale, (count, 3)),
            np.full(count, float(s.metallic)),
            np.full(count, float(s.perceptual_roughness)),
            np.full(count, float(s.f0_dielectric)),
            np.full(count, float(s.anisotropy)),
        )
    )


def trace(
    primitives: list[Primitive], origin: np.ndarray, d: np.ndarray, skip: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The nearest hit of the rays origin + t d (one each, (N, 3)) over every primitive but
    ``skip``: (ids (N,), NO_HIT where none; positions, normals, tangents (N, 3))."""
    best = np.full(len(d), np.inf)
    ids = np.full(len(d), NO_HIT, np.int64)
    for i, prim in enumerate(primitives):
        if i == skip:
            continue
        o, d_obj = _to_object(prim, origin, d)
        if prim.kind == "sphere":
            t = intersect_sphere(prim.radius, o, d_obj, 0.0, np.inf)
        else:
            t = intersect_plane(prim.size, o, d_obj, 0.0, np.inf)
        nearer = t < best
        best = np.where(nearer, t, best)
        ids = np.where(nearer, i, ids)
    p = np.zeros_like(d)
    n = np.zeros_like(d)
    tangent = np.zeros_like(d)
    for i, prim in enumerate(primitives):
        sel = ids == i
        if not np.any(sel):
            continue
        o, d_obj = _to_object(prim, origin[sel], d[sel])
        p[sel] = origin[sel] + best[sel, None] * d[sel]
        q = o + best[sel, None] * d_obj
        n[sel], tangent[sel], _ = _frame(prim, q, d[sel])
    return ids, p, n, tangent


def radiance_along(
    primitives: list[Primitive],
    materials: list[PrimitiveMaterial],
    lights: list[PunctualLight],
    background: np.ndarray,
    origin: np.ndarray,
    d: np.ndarray,
    skip: int,
) -> tuple[np.ndarray, np.ndarray]:
    """The radiance arriving along -d at ``origin`` (N, 3): what the ray hits (all
    primitives but ``skip``), shaded by the twins' illumination sum towards -d, or the
    background colour. Also the hit ids."""
    ids, p, n, t = trace(primitives, origin, d, skip)
    out = np.broadcast_to(np.asarray(background, np.float64), d.shape).copy()
    for i, mat in enumerate(materials):
        sel = ids == i
        count = int(sel.sum())
        if count == 0:
            continue
        point = ShadingPoint(_surface(mat, count), mat.params, n[sel], None, t[sel],
                             -normalize(d[sel]), p[sel])  # fmt: skip
        out[sel] = illumination_sum(point, mat.model, lights)
    return out, ids


def sphere_exit(prim: Primitive, origin: np.ndarray, d: np.ndarray) -> np.ndarray:
    """The far root t of origin + t d (a point inside the sphere, unit world d) on the
    sphere's surface: the path length inside (the model maps t unchanged)."""
    o, d_obj = _to_object(prim, origin, d)
    a = dot(d_obj, d_obj)
    b = dot(o, d_obj)
    c = dot(o, o) - prim.radius**2
    disc = np.maximum(b * b - a * c, 0.0)
    return (-b + np.sqrt(disc)) / a


def _lobe_normals(n: np.ndarray, v: np.ndarray, alpha: float, u: tuple[float, float]):
    """A GGX visible normal about ``n`` for views ``v`` (N, 3), world space."""
    if alpha <= 0.0:
        return n
    up = np.where(np.abs(n[:, 2:3]) < 0.999, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    tx = normalize(np.cross(up, n))
    ty = np.cross(n, tx)
    local = np.stack([dot(v, tx), dot(v, ty), dot(v, n)], axis=-1)
    m = sample_ggx_vndf(local, alpha, alpha, u)
    return normalize(m[:, :1] * tx + m[:, 1:2] * ty + m[:, 2:3] * n)


def transmitted_exact(
    primitives: list[Primitive],
    materials: list[PrimitiveMaterial],
    glass: int,
    lights: list[PunctualLight],
    background: np.ndarray,
    p: np.ndarray,
    n: np.ndarray,
    v: np.ndarray,
    samples: int = 1,
    on_screen: Callable[[np.ndarray], np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The transmitted radiance towards ``v`` at the points ``p`` (N, 3, normals ``n``) of
    transmissive sphere ``glass``, and the share of each point's rays whose light comes
    from where a screen-space lookup cannot read it: the background, or a world point
    ``on_screen`` (points (N, 3) -> (N,) bool) says is outside the image (every ray that
    reaches a surface counts as seen without it). See the module's docstring."""
    mat = materials[glass]
    prim = primitives[glass]
    s = mat.surface
    params = mat.params
    eta = float(params.eta_dielectric)
    alpha = max(float(s.perceptual_roughness), 0.0) ** 2
    base = np.asarray(s.base_color, np.float64)
    tr = float(params.transmission) * (1.0 - float(s.metallic))
    thin = float(params.thickness) <= 0.0
    f0 = float(s.f0_dielectric) * np.asarray(params.specular_color, np.float64)
    strata = [((i + 0.5) / samples, (j + 0.5) / samples) for i in range(samples)
              for j in range(samples)] if alpha > 0.0 else [(0.5, 0.5)]  # fmt: skip
    total = np.zeros_like(p)
    unseen = np.zeros(len(p))

    def count_unseen(at: np.ndarray, origin: np.ndarray, d: np.ndarray, lit: np.ndarray):
        seen = at >= 0
        if on_screen is not None and np.any(seen):
            seen[seen] = on_screen(_hit_points(primitives, origin[seen], d[seen], glass))
        return lit & ~seen

    for u in strata:
        m = _lobe_normals(n, v, alpha, u)
        if thin:
            # thin shell: reflect about m, mirror through the surface plane (glTF thin-walled)
            r = -v + 2.0 * dot(v, m)[:, None] * m
            d = normalize(r - 2.0 * dot(r, n)[:, None] * n) if alpha > 0.0 else -v
            weight = transmission_weight(f0, dot(n, v), tr, 0.0)
            L, at = radiance_along(primitives, materials, lights, background,
                                   p + RAY_OFFSET * d, d, glass)  # fmt: skip
            total += weight * base * L
            unseen += count_unseen(at, p, d, np.ones(len(p), bool))
            continue
        cos1 = np.clip(dot(m, v), 0.0, 1.0)
        d1 = refracted_direction(v, m, np.full(len(v), eta))
        inside = np.sum(d1 * n, axis=-1) < 0.0
        start = p + RAY_OFFSET * d1
        length = sphere_exit(prim, start, d1)
        q = start + length[:, None] * d1
        o, _ = _to_object(prim, q, d1)
        n2, _, _ = _frame(prim, o, d1)  # outward
        # out of the glass: relative index 1 / eta, through the normal that faces inside
        cos2 = np.clip(dot(d1, n2), 0.0, 1.0)
        k = 1.0 - eta * eta * (1.0 - cos2 * cos2)
        escape = k > 0.0
        d2 = refracted_direction(-d1, -n2, np.full(len(v), 1.0 / eta))
        f1 = F_dielectric(eta, cos1)
        f2 = np.where(escape, F_dielectric(1.0 / eta, cos2), 1.0)
        T = beer_lambert(np.asarray(params.attenuation_color), params.attenuation_distance,
                         length)  # fmt: skip
        L, at = radiance_along(primitives, materials, lights, background,
                               q + RAY_OFFSET * d2, d2, glass)  # fmt: skip
        lit = escape & inside
        w = (tr * (1.0 - f1) * (1.0 - f2) * lit)[:, None]
        total += w * base * T * L
        unseen += count_unseen(at, q, d2, lit)
    return total / len(strata), unseen / len(strata)


def _hit_points(primitives: list[Primitive], origin: np.ndarray, d: np.ndarray, skip: int):
    """The points the rays origin + t d reach (``trace``'s positions)."""
    return trace(primitives, origin + RAY_OFFSET * d, d, skip)[1]


def reference_with_glass(
    primitives: list[Primitive],
    materials: list[PrimitiveMaterial],
    camera: CameraFrame,
    size: tuple[int, int],
    lights: list[PunctualLight],
    background: np.ndarray,
    samples: int = 1,
    on_screen: Callable[[np.ndarray], np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The ray-cast image (H, W, 3) of a scene whose transmissive primitives are spheres,
    and its primitive ids: every opaque hit shaded as the ray-caster shades it, every
    transmissive sphere's hit its reflected light (the diffuse base weighted by
    1 - transmission) plus ``transmitted_exact``; its primitive ids; and (H, W) the share
    of each transmissive pixel's light a screen-space lookup cannot read
    (``transmitted_exact``'s, with ``on_screen``)."""
    hits = cast(primitives, camera, size)
    h, w = hits.ids.shape
    out = np.broadcast_to(np.asarray(background, np.float64), (h, w, 3)).copy()
    origin = np.asarray(camera.position, np.float64)
    unseen = np.zeros((h, w))
    for i, mat in enumerate(materials):
        sel = hits.ids == i
        count = int(sel.sum())
        if count == 0:
            continue
        tr = float(mat.params.transmission)
        p, n, t = hits.p[sel], hits.n[sel], hits.t[sel]
        v = normalize(origin - p)
        point = ShadingPoint(_surface(mat, count, 1.0 - tr), mat.params, n, None, t, v, p)
        out[sel] = illumination_sum(point, mat.model, lights)
        if tr > 0.0:
            if primitives[i].kind != "sphere":
                raise ValueError(f"primitive {i}: only spheres refract in the ray-caster")
            L, missed = transmitted_exact(primitives, materials, i, lights, background, p, n,
                                          v, samples, on_screen)  # fmt: skip
            out[sel] += L
            unseen[sel] = missed
    return out, hits.ids, unseen
