"""An independent float64 ray-caster: the pipeline's reference image of a scene of analytic
primitives.

It shares nothing with the rasteriser but the shading twins: rays leave the camera through
the pixel centres the lighting pass reconstructs positions at (app/reference/position.py),
each ray is intersected here, from the maths, with every primitive
(app/common/primitives.py: spheres through their model matrix, so scaled spheres are
ellipsoids, and finite two-sided rectangles), and the nearest hit is shaded by the twins'
illumination sum (app/reference/illumination.py, RTR4 §9.4) with the surface sanitised as
the G-buffer decode sanitises it. No G-buffer, no tessellation and no GLSL are involved,
so the difference between this image and the GPU's is the whole pipeline's error:
geometry, G-buffer encodings and float32 shading together.

The ray through pixel centre ``ndc`` is ``camera + t R (ndc.x tan_x, ndc.y tan_y, -1)``,
whose parameter ``t`` is the view depth (the distance along the view axis), so a hit's
``t`` compares directly with the G-buffer's depth and with the near and far planes.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from app.common.camera import CameraFrame
from app.common.lights import LightType, PunctualLight
from app.common.models import Model, ModelParams
from app.common.primitives import Primitive
from app.reference._vec import dot, normalize
from app.reference.environment_uniform import uniform_environment_radiance
from app.reference.illumination import illumination_sum, pixel_ndc
from app.reference.material import ShadingPoint, Surface, sanitize_surface
from app.reference.normal_mapping import rotate_tangent

NO_HIT = -1  # primitive id of a pixel that hits nothing
MIXED = -2  # primitive id of a supersampled pixel whose samples disagree


@dataclass(frozen=True)
class PrimitiveMaterial:
    """A primitive's material as the twins take it: the G-buffer's surface values (scalar
    fields, base_color a 3-vector) and the material table row's model and parameters."""

    surface: Surface
    params: ModelParams
    model: Model
    # The direction of anisotropy turned about n from t towards b, radians (the scene key
    # anisotropy_rotation; the G-buffer pass turns its tangent the same way)
    anisotropy_rotation: float = 0.0


@dataclass
class Hits:
    """The nearest hit of each pixel's ray; every image is (H, W) or (H, W, k), with zeros
    where nothing is hit (``ids == NO_HIT``)."""

    ids: np.ndarray  # (H, W) int64: index of the primitive hit, NO_HIT where none
    depth: np.ndarray  # (H, W) view depth t (0 where no hit, as in the G-buffer)
    p: np.ndarray  # (H, W, 3) world position
    n: np.ndarray  # (H, W, 3) unit normal (a plane's faces the viewer)
    t: np.ndarray  # (H, W, 3) unit tangent (app/common/primitives.py)
    uv: np.ndarray  # (H, W, 2)

    @property
    def covered(self) -> np.ndarray:
        """(H, W) bool: the pixels whose ray hits a primitive."""
        return self.ids >= 0


@dataclass
class RaycastImage:
    """A rendered reference: linear HDR radiance and what the error metrics need."""

    hdr: np.ndarray  # (H, W, 3) float64
    covered: np.ndarray  # (H, W) bool: some sample of the pixel hits a primitive
    ids: np.ndarray  # (H, W) int64: the primitive all samples hit, NO_HIT or MIXED

    def interior(self, margin: int = 2) -> np.ndarray:
        """``interior_mask(self.ids, margin)``."""
        return interior_mask(self.ids, margin)


def camera_rays(camera: CameraFrame, width: int, height: int) -> np.ndarray:
    """World directions (H, W, 3) of the rays through the pixel centres, not normalised:
    R (ndc.x tan_x, ndc.y tan_y, -1), whose parameter is the view depth (the ray the
    lighting pass reconstructs positions along, app/reference/position.py)."""
    return ndc_rays(camera, pixel_ndc(height, width))


def ndc_rays(camera: CameraFrame, ndc: np.ndarray) -> np.ndarray:
    """World directions (..., 3) of the rays through the image points ``ndc`` (..., 2), as
    ``camera_rays`` makes them for pixel centres: any point of a pixel's area."""
    tan = np.asarray(camera.tan_half_fov, np.float64)
    local = np.concatenate([ndc * tan, -np.ones((*ndc.shape[:-1], 1))], axis=-1)
    return local @ np.asarray(camera.camera_to_world, np.float64).T


def _to_object(prim: Primitive, origin: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, ...]:
    """The ray in the primitive's object space: the inverse model matrix applied to the
    origin (a point, (3,) or one per ray) and the direction (a vector). The map is affine,
    so a point's ray parameter is the same in both spaces and stays the view depth."""
    inv = np.linalg.inv(np.asarray(prim.model, np.float64))
    o = np.asarray(origin, np.float64) @ inv[:3, :3].T + inv[:3, 3]
    return o, d @ inv[:3, :3].T


def intersect_sphere(
    radius: float, o: np.ndarray, d: np.ndarray, near: float, far: float
) -> np.ndarray:
    """Ray parameter of the front surface of the sphere |x| = radius centred on the origin
    (object space) along o + t d, or inf where that surface is not hit in (near, far).

    Haines, Guenther & Akenine-Moeller 2019, "Precision Improvements for Ray/Sphere
    Intersection" (Ray Tracing Gems, ch. 7): with f = o (centre to origin),
    a t^2 + 2 b t + c = 0, a = d.d, b = f.d, c = f.f - r^2, the discriminant
    b^2 - a c is computed as a (r^2 - |f - (b/a) d|^2) from the ray's closest point to
    the centre (no cancellation between b^2 and a c far from the sphere), and the roots
    as c / q and q / a with q = -b - sign(b) sqrt(disc) (no cancellation in -b + sqrt).

    Only the nearer root counts: the far root is the sphere's back face, which the
    rasteriser culls, so a camera inside the sphere, or a sphere cut by the near plane,
    shows nothing of it.
    """
    a = dot(d, d)
    b = dot(d, o)  # o (3,) for camera rays, or one origin per ray (shadow rays)
    c = dot(o, o) - radius * radius
    closest = o - (b / a)[..., None] * d
    disc = a * (radius * radius - dot(closest, closest))
    hit = disc >= 0.0
    root = np.sqrt(np.where(hit, disc, 0.0))
    q = -b - np.where(b >= 0.0, 1.0, -1.0) * root
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = c / q, q / a
    t = np.minimum(t0, t1)
    ok = hit & (q != 0.0) & (t > near) & (t < far)
    return np.where(ok, t, np.inf)


def intersect_plane(
    size: tuple[float, float], o: np.ndarray, d: np.ndarray, near: float, far: float
) -> np.ndarray:
    """Ray parameter of the rectangle |x| <= sx/2, |z| <= sz/2 of the plane y = 0 (object
    space) along o + t d, or inf where it is missed or outside (near, far); both faces
    count (planes are two-sided)."""
    dy = d[..., 1]
    parallel = dy == 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -o[..., 1] / np.where(parallel, 1.0, dy)
    x = o[..., 0] + t * d[..., 0]
    z = o[..., 2] + t * d[..., 2]
    inside = (np.abs(x) <= 0.5 * size[0]) & (np.abs(z) <= 0.5 * size[1])
    ok = ~parallel & inside & (t > near) & (t < far)
    return np.where(ok, t, np.inf)


def _frame(
    prim: Primitive, q: np.ndarray, d: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World normal, world tangent and UV at object-space hit points ``q`` (N, 3) of rays
    with world directions ``d``, by the conventions of app/common/primitives.py."""
    m = np.asarray(prim.model, np.float64)[:3, :3]
    normal_matrix = np.linalg.inv(m).T  # normals go by the inverse transpose
    if prim.kind == "sphere":
        n_obj = q / prim.radius
        n_obj = normalize(n_obj)  # |q| = r up to rounding
        t_obj = np.cross([0.0, 1.0, 0.0], n_obj)
        pole = np.linalg.norm(t_obj, axis=-1) < 1e-6
        t_obj[pole] = np.cross([1.0, 0.0, 0.0], n_obj[pole])
        u = np.arctan2(n_obj[:, 0], n_obj[:, 2]) / (2.0 * np.pi) + 0.5
        v = np.arcsin(np.clip(n_obj[:, 1], -1.0, 1.0)) / np.pi + 0.5
        n = normalize(n_obj @ normal_matrix.T)
    else:
        n = normalize(np.broadcast_to(normal_matrix @ [0.0, 1.0, 0.0], q.shape))
        n = np.where((dot(n, d) > 0.0)[:, None], -n, n)  # two-sided: towards the viewer
        t_obj = np.broadcast_to([1.0, 0.0, 0.0], q.shape)
        u = q[:, 0] / prim.size[0] + 0.5
        v = 0.5 - q[:, 2] / prim.size[1]
    t = normalize(t_obj @ m.T)
    return n, t, np.stack([u, v], axis=-1)


def cast(
    primitives: list[Primitive],
    camera: CameraFrame,
    size: tuple[int, int],
    ndc: np.ndarray | None = None,
) -> Hits:
    """The nearest hit over all primitives of the ray through each pixel centre of an image
    of ``size`` (width, height), with t in (camera.near, camera.far) as the rasteriser
    clips. A tie goes to the earlier primitive. ``ndc`` (h, w, 2): the rays through those
    image points instead (``size`` unused), e.g. samples spread over pixels' areas."""
    if ndc is None:
        d = camera_rays(camera, size[0], size[1])
    else:
        d = ndc_rays(camera, np.asarray(ndc, np.float64))
    height, width = d.shape[:2]
    origin = np.asarray(camera.position, np.float64)
    best = np.full((height, width), np.inf)
    ids = np.full((height, width), NO_HIT, np.int64)
    for i, prim in enumerate(primitives):
        o, d_obj = _to_object(prim, origin, d)
        if prim.kind == "sphere":
            t = intersect_sphere(prim.radius, o, d_obj, camera.near, camera.far)
        elif prim.kind == "plane":
            t = intersect_plane(prim.size, o, d_obj, camera.near, camera.far)
        else:
            raise ValueError(f"primitive {i}: kind {prim.kind!r} is not supported")
        nearer = t < best
        best = np.where(nearer, t, best)
        ids = np.where(nearer, i, ids)
    depth = np.where(ids >= 0, best, 0.0)
    p = np.zeros((height, width, 3))
    n = np.zeros((height, width, 3))
    tangent = np.zeros((height, width, 3))
    uv = np.zeros((height, width, 2))
    for i, prim in enumerate(primitives):
        sel = ids == i
        if not np.any(sel):
            continue
        o, d_obj = _to_object(prim, origin, d[sel])
        tt = best[sel]
        p[sel] = origin + tt[:, None] * d[sel]
        q = o + tt[:, None] * d_obj  # the hit in object space, without a round trip
        n[sel], tangent[sel], uv[sel] = _frame(prim, q, d[sel])
    return Hits(ids, depth, p, n, tangent, uv)


# A shadow ray leaves its hit this far along the hit's normal (metres). A float64 hit lies
# within about 1e-15 relative of its surface, so 1e-9 m clears the surface it starts on
# and moves no shadow boundary by anything a pixel could show.
SHADOW_RAY_OFFSET = 1e-9


def occluded(
    primitives: list[Primitive], origin: np.ndarray, d: np.ndarray, far: np.ndarray
) -> np.ndarray:
    """(N,) bool: the ray origin + t d (one origin and direction per ray) hits some
    primitive with 0 < t < far."""
    blocked = np.zeros(len(d), bool)
    for i, prim in enumerate(primitives):
        o, d_obj = _to_object(prim, origin, d)
        if prim.kind == "sphere":
            t = intersect_sphere(prim.radius, o, d_obj, 0.0, np.inf)
        elif prim.kind == "plane":
            t = intersect_plane(prim.size, o, d_obj, 0.0, np.inf)
        else:
            raise ValueError(f"primitive {i}: kind {prim.kind!r} is not supported")
        blocked |= t < far
    return blocked


def light_visibility(
    primitives: list[Primitive], p: np.ndarray, n: np.ndarray, light: PunctualLight
) -> np.ndarray:
    """(N,) 1.0 where the shadow ray from ``p`` (N, 3) towards ``light`` reaches it, 0.0
    where a primitive blocks it: the exact hard shadow of a punctual light (RTR4 §7.1),
    the reference the shadow maps are measured against (docs/shadows.md)."""
    if light.type == LightType.DIRECTIONAL:
        d = np.broadcast_to(-np.asarray(light.direction, np.float64), p.shape)
        far = np.full(len(p), np.inf)
    else:
        to_light = np.asarray(light.position, np.float64) - p
        far = np.linalg.norm(to_light, axis=-1)
        d = to_light / np.maximum(far, 1e-300)[:, None]
    origin = p + SHADOW_RAY_OFFSET * n
    return np.where(occluded(primitives, origin, d, far), 0.0, 1.0)


def area_light_visibility(
    primitives: list[Primitive],
    p: np.ndarray,
    n: np.ndarray,
    light: PunctualLight,
    size: float,
    samples: int = 1024,
) -> np.ndarray:
    """(N,) the fraction of an area light that points ``p`` (N, 3) see unblocked, by
    ``samples`` shadow rays each (RTR4 §7.1's visibility integrated over the light): the
    reference for PCSS's penumbra (docs/shadows.md). A point or spot light is a sphere of
    radius ``size`` metres, seen from each point as its silhouette disc (perpendicular to
    the direction to its centre; exact for a disc facing the point, the sphere's to
    (size / distance)^2), sampled uniformly in area; a directional light is a cone of
    directions of angular radius atan(``size``), sampled uniformly in solid angle. Samples:
    a Vogel disc (Vogel 1979), the same for every point, so a profile is smooth."""
    p = np.asarray(p, np.float64)
    k = np.arange(samples)
    r = np.sqrt((k + 0.5) / samples)
    a = k * (math.pi * (3.0 - math.sqrt(5.0)))
    disc = np.stack([r * np.cos(a), r * np.sin(a)], axis=1)  # unit disc
    origin = p + SHADOW_RAY_OFFSET * np.asarray(n, np.float64)
    if light.type == LightType.DIRECTIONAL:
        axis = np.broadcast_to(-np.asarray(light.direction, np.float64), p.shape)
    else:
        axis = np.asarray(light.position, np.float64) - p
        centre_dist = np.linalg.norm(axis, axis=-1)
        axis = axis / np.maximum(centre_dist, 1e-300)[:, None]
    axis = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
    helper = np.where((np.abs(axis[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    u = np.cross(axis, helper)
    u /= np.linalg.norm(u, axis=-1, keepdims=True)
    v = np.cross(axis, u)
    seen = np.zeros(len(p))
    for x, y in disc:
        if light.type == LightType.DIRECTIONAL:
            # uniform in solid angle over the cone: cos theta uniform in [cos a, 1]
            cos_max = 1.0 / math.sqrt(1.0 + size * size)
            radius2 = x * x + y * y  # in [0, 1): the disc's area fraction
            cos_t = 1.0 - radius2 * (1.0 - cos_max)
            sin_t = math.sqrt(max(0.0, 1.0 - cos_t * cos_t))
            scale = sin_t / math.sqrt(radius2) if radius2 > 0.0 else 0.0
            d = cos_t * axis + scale * (x * u + y * v)
            far = np.full(len(p), np.inf)
        else:
            target = np.asarray(light.position, np.float64) + size * (x * u + y * v)
            d = target - origin
            far = np.linalg.norm(d, axis=-1)
            d = d / far[:, None]
        seen += ~occluded(primitives, origin, d, far)
    return seen / samples


def shadow_visibility(
    primitives: list[Primitive], hits: Hits, lights: list[PunctualLight]
) -> list[np.ndarray | None]:
    """Per light: None for a light without ``shadow``, else (H, W) visibility of every
    covered pixel (``light_visibility``; 1.0 where nothing is hit)."""
    out: list[np.ndarray | None] = []
    covered = hits.covered
    for light in lights:
        if light.shadow is None:
            out.append(None)
            continue
        vis = np.ones(hits.ids.shape)
        vis[covered] = light_visibility(primitives, hits.p[covered], hits.n[covered], light)
        out.append(vis)
    return out


def shade(
    hits: Hits,
    materials: list[PrimitiveMaterial],
    camera: CameraFrame,
    lights: list[PunctualLight],
    background: np.ndarray,
    terms: str = "all",
    visibility: list[np.ndarray | None] | None = None,
    environment: tuple[np.ndarray, int] | None = None,
) -> np.ndarray:
    """Linear HDR radiance (H, W, 3): each hit shaded by ``illumination_sum`` with its
    primitive's material (sanitised as the G-buffer decode does), the background where
    nothing is hit. ``visibility``: ``shadow_visibility``'s images, each multiplying its
    light's term (None: no shadows). ``environment``: a uniform environment's (radiance,
    directions), added by the lighting pass's own quadrature (``uniform_environment_radiance``,
    docs/ibl.md); the environment casts no shadow here, as in the renderer."""
    out = np.broadcast_to(np.asarray(background, np.float64), (*hits.ids.shape, 3)).copy()
    for i, mat in enumerate(materials):
        sel = hits.ids == i
        count = int(sel.sum())
        if count == 0:
            continue
        s = mat.surface
        surface = sanitize_surface(
            Surface(
                np.broadcast_to(np.asarray(s.base_color, np.float64), (count, 3)),
                np.full(count, float(s.metallic)),
                np.full(count, float(s.perceptual_roughness)),
                np.full(count, float(s.f0_dielectric)),
                np.full(count, float(s.anisotropy)),
            )
        )
        p = hits.p[sel]
        v = normalize(np.asarray(camera.position, np.float64) - p)
        t = hits.t[sel]
        if mat.anisotropy_rotation != 0.0:  # as glsl/material/layers.glsl turns it
            # b = n x t (handedness +1): a scene's scale is positive, so no primitive
            # mirrors (the G-buffer pass's u_tangent_sign is 1)
            a = mat.anisotropy_rotation
            t = rotate_tangent(hits.n[sel], t, 1.0, np.array([math.cos(a), math.sin(a)]))
        vis = None if visibility is None else [x if x is None else x[sel] for x in visibility]
        point = ShadingPoint(surface, mat.params, hits.n[sel], None, t, v, p)
        # area lights by their exact float64 integral (app/reference/area_lights.py)
        out[sel] = illumination_sum(point, mat.model, lights, terms, visibility=vis, area="exact")
        if environment is not None:
            out[sel] += uniform_environment_radiance(
                environment[0], point, mat.model, environment[1], terms
            )
    return out


def _blocks(a: np.ndarray, factor: int) -> np.ndarray:
    """(H*f, W*f, ...) -> (H, W, f*f, ...): each output pixel's block of samples."""
    h, w = a.shape[0] // factor, a.shape[1] // factor
    b = a.reshape(h, factor, w, factor, *a.shape[2:])
    b = np.moveaxis(b, 2, 1)
    return b.reshape(h, w, factor * factor, *a.shape[2:])


def render_reference(
    primitives: list[Primitive],
    materials: list[PrimitiveMaterial],
    camera: CameraFrame,
    size: tuple[int, int],
    lights: list[PunctualLight],
    background: np.ndarray,
    terms: str = "all",
    supersample: int = 1,
    environment: tuple[np.ndarray, int] | None = None,
) -> RaycastImage:
    """The reference image of ``size`` (width, height). With ``supersample = n`` the rays
    go through the pixel centres of an image n x n times larger (``camera`` must be that
    image's frame, as the renderer's is) and each pixel is the box average of its n x n
    block of linear radiance, as the renderer's resolve averages (glsl/passes/
    downsample.frag). ``ids`` is the primitive every sample of a pixel hits, NO_HIT where
    none does, MIXED where they differ. ``environment``: as in ``shade``."""
    width, height = size
    hits = cast(primitives, camera, (width * supersample, height * supersample))
    visibility = None
    if any(light.shadow is not None for light in lights):  # shadow rays (docs/shadows.md)
        visibility = shadow_visibility(primitives, hits, lights)
    hdr = shade(hits, materials, camera, lights, background, terms, visibility, environment)
    if supersample == 1:
        return RaycastImage(hdr, hits.covered, hits.ids)
    hdr = _blocks(hdr, supersample).mean(axis=2)
    samples = _blocks(hits.ids, supersample)
    same = np.all(samples == samples[..., :1], axis=-1)
    ids = np.where(same, samples[..., 0], MIXED)
    return RaycastImage(hdr, np.any(samples >= 0, axis=-1), ids)


def multi_jittered(n: int, seed: int = 1) -> np.ndarray:
    """(n * n, 2) sample offsets (x right, y down) in pixels from a pixel's centre, within
    (-0.5, 0.5): Chiu, Shirley & Wang 1994, "Multi-jittered sampling" (Graphics Gems IV):
    one sample in each cell of an n x n grid over the pixel and at once one in each of its
    n^2 columns and n^2 rows (the canonical arrangement with the sub-columns shuffled within
    each column of cells and the sub-rows within each row of cells, by a fixed seed so
    every run is the same), each at its sub-cell's centre."""
    rng = np.random.default_rng(seed)
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")  # cell column i, row j
    sx, sy = j.copy(), i.copy()  # the canonical arrangement's sub-column and sub-row
    for col in range(n):
        sx[col, :] = rng.permutation(sx[col, :])
    for row in range(n):
        sy[:, row] = rng.permutation(sy[:, row])
    x = (i + (sx + 0.5) / n) / n
    y = (j + (sy + 0.5) / n) / n
    return np.stack([x.ravel(), y.ravel()], axis=1) - 0.5


# A pixel whose samples' radiance spreads over more than this share of its mean (or of
# RELATIVE_SPREAD_FLOOR of the image's peak, where darker) is refined like an edge pixel:
# its shading, not only its coverage, changes within it.
SPREAD = 0.5
RELATIVE_SPREAD_FLOOR = 1e-3

Background = Callable[[np.ndarray], np.ndarray]  # image points (..., 2) NDC -> radiance


# Rays cast and shaded at once by ``area_reference``: a few dozen float64 values each,
# so a batch stays near a hundred MB.
BATCH_RAYS = 1 << 18


def _sample_mean(
    primitives: list[Primitive],
    materials: list[PrimitiveMaterial],
    camera: CameraFrame,
    centres: np.ndarray,
    pixel: tuple[float, float],
    pattern: np.ndarray,
    lights: list[PunctualLight],
    background: np.ndarray | Background,
    terms: str,
    environment: tuple[np.ndarray, int] | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Mean radiance (P, 3) over ``pattern``'s offsets around each NDC point of
    ``centres`` (P, 2) (``pixel``: a pixel's NDC width and height), whether any sample
    hits a surface, the primitive all samples hit (``MIXED`` where they differ) and the
    spread (largest minus smallest) of the samples' mean over channels; the samples of a
    batch of offsets are cast as one (offsets, P) image."""
    count = len(centres)
    total = np.zeros((count, 3))
    low, high = np.full(count, np.inf), np.full(count, -np.inf)
    covered = np.zeros(count, bool)
    first = np.full(count, NO_HIT, np.int64)
    same = np.ones(count, bool)
    step = max(1, BATCH_RAYS // max(count, 1))
    scale = np.array([pixel[0], -pixel[1]])
    for start in range(0, len(pattern), step):
        offsets = pattern[start : start + step] * scale  # (k, 2) NDC
        ndc = centres[None, :, :] + offsets[:, None, :]  # (k, P, 2)
        hits = cast(primitives, camera, (0, 0), ndc)
        bg = background(ndc) if callable(background) else background
        visibility = None
        if any(light.shadow is not None for light in lights):  # shadow rays, as render_reference
            visibility = shadow_visibility(primitives, hits, lights)
        radiance = shade(hits, materials, camera, lights, bg, terms, visibility, environment)
        total += radiance.sum(axis=0)
        level = radiance.mean(axis=-1)
        low, high = np.minimum(low, level.min(axis=0)), np.maximum(high, level.max(axis=0))
        covered |= hits.covered.any(axis=0)
        if start == 0:
            first = hits.ids[0]
        same &= np.all(hits.ids == first, axis=0)
    return total / len(pattern), covered, np.where(same, first, MIXED), high - low


def area_reference(
    primitives: list[Primitive],
    materials: list[PrimitiveMaterial],
    camera: CameraFrame,
    size: tuple[int, int],
    lights: list[PunctualLight],
    background: np.ndarray | Background,
    terms: str = "all",
    samples: int = 8,
    edge_samples: int = 32,
    environment: tuple[np.ndarray, int] | None = None,
) -> RaycastImage:
    """The pixel-area-integrated reference of ``size`` (width, height): each pixel the
    mean, in linear radiance, of rays spread over its whole area, surfaces and background
    alike, so that a pixel a silhouette crosses holds its true coverage mix (the box
    filter over the pixel, integrated). Every pixel takes ``samples`` x ``samples``
    (``multi_jittered``); the pixels where that converges slowest are cast again with
    ``edge_samples`` x ``edge_samples``: the edge pixels (``edge_mask``: some of those
    samples disagree on the primitive, and their neighbours) and the pixels whose samples'
    radiance spreads over more than ``SPREAD`` of the pixel's mean (a highlight smaller
    than the pixel), and their neighbours. ``background``: a colour, or a function of the
    samples' NDC giving the environment drawn behind the scene. Shadows as
    ``render_reference`` casts them (exact hard shadows). ``ids``: as
    ``render_reference``'s, over the first ``samples`` x ``samples``."""
    width, height = size
    centres = pixel_ndc(height, width).reshape(-1, 2)
    pixel = (2.0 / width, 2.0 / height)
    args = (lights, background, terms, environment)
    hdr, covered, ids, spread = _sample_mean(
        primitives, materials, camera, centres, pixel, multi_jittered(samples), *args
    )
    hdr, covered, ids = (
        hdr.reshape(height, width, 3),
        covered.reshape(height, width),
        ids.reshape(height, width),
    )
    if edge_samples > samples:
        level = hdr.mean(axis=-1)
        floor = RELATIVE_SPREAD_FLOOR * max(float(level.max()), np.finfo(np.float64).tiny)
        varied = spread.reshape(height, width) > SPREAD * np.maximum(level, floor)
        edge = edge_mask(np.where(varied, MIXED, ids))
        fine, fine_covered, _, _ = _sample_mean(
            primitives, materials, camera, centres.reshape(height, width, 2)[edge], pixel,
            multi_jittered(edge_samples), *args,
        )  # fmt: skip
        hdr[edge] = fine
        covered[edge] |= fine_covered
    return RaycastImage(hdr, covered, ids)


def edge_mask(ids: np.ndarray, margin: int = 1) -> np.ndarray:
    """The edge pixels: those whose samples disagree (``MIXED``: a silhouette or a
    boundary between primitives crosses the pixel) and every pixel within ``margin`` of
    one. The rest are whole pixels of one primitive or of the background, where shading
    rather than coverage decides the error."""
    h, w = ids.shape
    mixed = np.pad(ids == MIXED, margin, constant_values=False)
    out = np.zeros((h, w), bool)
    for dy in range(2 * margin + 1):
        for dx in range(2 * margin + 1):
            out |= mixed[dy : dy + h, dx : dx + w]
    return out


def interior_mask(ids: np.ndarray, margin: int = 2) -> np.ndarray:
    """Covered pixels (ids >= 0) whose every neighbour within ``margin`` pixels (the
    (2 margin + 1)^2 square around them) shows the same primitive: away from silhouettes,
    from boundaries between primitives and from the image's edge, where the rasteriser's
    coverage and the ray-caster's may differ by a pixel."""
    h, w = ids.shape
    padded = np.pad(ids, margin, constant_values=NO_HIT)
    out = ids >= 0
    for dy in range(2 * margin + 1):
        for dx in range(2 * margin + 1):
            out &= padded[dy : dy + h, dx : dx + w] == ids
    return out
