"""Shadow maps for directional, spot and point lights (RTR4 §7.4): depth-only
passes into one shared depth atlas (maps packed in rows), read by glsl/lights/shadows.glsl
in the lighting pass (compiled in only where a light has ``shadow = true``: ``SHADOWS``).

Frusta. A directional light gets an orthographic frustum fitted to the light-space bounds
of every opaque part's vertices (an analytic sphere's enclosing proxy), so every caster and
receiver lies inside its map and a large floor spreads the texels thinly; with
``shadow_cascades`` it gets several, each fitted to a slice of the camera's view and
refitted when the camera moves (``cascade_frusta``; docs/shadows.md). A spot light gets a
perspective frustum along its axis whose field of view is the outer cone plus one degree,
from ``near_plane`` to its range (the window falloff is exactly 0 beyond it). A point
light gets six 90-degree perspective maps, the faces of a cube around it (same near and
far), each in its own place in the atlas; the lookup reads the one face along the major
axis of the direction from the light.

Geometry. Mesh parts are drawn as they are. An analytic sphere, whose exact depth the
G-buffer pass writes per pixel from the camera's ray, is drawn here as the icosphere of
``MeshPart.triangles`` (5,120 triangles, vertices on the sphere): its faces lie inside
the sphere by at most 1 - (the nearest face plane's distance from the centre), at 4
subdivisions 0.11 % of the radius (measured; docs/shadows.md), so its shadow is that
much smaller. Alpha-masked parts cast the shadow of their whole surface; blended parts
cast none. Transmissive parts (glass) cast no depth: where a frame has them, a second
target beside the atlas (RGBA float32, same layout) holds per texel the product of the
transmittances of the glass surfaces in front of the opaque depth and the nearest glass
depth, and the lookup multiplies a receiver behind that depth by the product: a coloured,
lighter shadow (``_run_glass``, glsl/passes/shadow_glass.frag; docs/shadows.md, "Glass").

Sides. A single-sided surface (a glTF material without ``doubleSided``, a closed
primitive) casts only with the faces that face the light: the camera pass culls its back
faces, so a surface invisible from one side also lets through the light arriving from
that side (``cull_back_faces``; docs/shadows.md, "Single-sided surfaces"). A closed mesh's
map is unchanged by this (its nearest surface seen from outside is a front face); an open
single-sided one (TextureSettingsTest's reversed panel) no longer shadows what the camera
sees through it. Two-sided parts and analytic proxies cast with both sides.

Culling. A map is rendered only once its light is culled in: its reach (``light_bounds``)
meets the camera's frustum (``culled_in``); a light outside lights no visible point.

Lookup. Where no map uses PCSS and this GL's LINEAR depth comparison is the weighted
2 x 2 average (``probe_hardware_pcf``, once per GL per process; softpipe's is not), the
atlas has compare mode and the PCF takes four hardware comparisons; otherwise texel reads
(``ShadowPass.hardware_pcf``; docs/shadows.md, "Hardware PCF, where it is exact").

Bias. The pass offsets depth by glPolygonOffset(slope, 1): ``slope`` times the triangle's
depth slope plus one depth unit (the slope-scaled bias); the lighting pass moves the
shaded point along its normal by ``normal_offset`` shadow texels (normal offset). Both
per light (``shadow_bias``); defaults and why in docs/shadows.md.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import os
import time

import moderngl
import numpy as np

from app.common.extension_maps import FACTOR_TARGETS, targets_of
from app.common.lights import LightType, PunctualLight
from app.errors import InputError
from app.frame.camera import gl_bytes
from app.gl.context import release_objects, wait_before_read
from app.gl.fullscreen import FullscreenDraw
from app.gl.shaders import ShaderCache, assemble
from app.reference.shadows import ShadowMaps
from app.render.inputs import SHADOWS, ShaderInput
from app.render.limits import max_dimension
from app.render.mesh_drawable import MeshDrawable, masked
from app.render.texture_upload import TextureUploads
from app.scene.geometry import MeshPart
from app.scene.model import Light

# A spot's map covers its outer cone plus this margin (degrees a side), so that the PCF
# kernel at the cone's edge reads inside the map.
SPOT_MARGIN_DEG = 1.0


# A point light's six cube faces: forward axes of 90-degree perspective maps.
CUBE_FACES = (
    (1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 1.0, 0.0),
    (0.0, -1.0, 0.0), (0.0, 0.0, 1.0), (0.0, 0.0, -1.0),
)  # fmt: skip


# A perspective map's near plane: range / 1000, but no farther than 5 cm from the light,
# so that a light of a huge range (up to 1e6 m) still sees casters near it; a DEPTH24 map
# with a 5 cm near plane resolves depth to z^2 / (0.05 m * 2^24), 30 um at 5 m.
NEAR_MAX = 0.05


def near_plane(light_range: float) -> float:
    """The near plane (metres) of a spot's or cube face's perspective map."""
    return min(light_range * 1e-3, NEAR_MAX)


def map_count(light_type: str) -> int:
    """Shadow maps a shadowed light takes: six cube faces for a point light, else one."""
    return 6 if light_type == "point" else 1


def atlas_layout(sizes: list[int], limit: int) -> tuple[list[tuple[int, int]], int, int]:
    """Square maps of ``sizes`` packed in rows (shelves) no wider than ``limit``: each
    map's first texel (x, y), and the atlas's width and height (the height may exceed
    ``limit``; the caller refuses that)."""
    origins, x, y, row, width = [], 0, 0, 0, 0
    for size in sizes:
        if x > 0 and x + size > limit:  # the next shelf
            x, y, row = 0, y + row, 0
        origins.append((x, y))
        x += size
        row = max(row, size)
        width = max(width, x)
    return origins, width, y + row


def shadow_map_sizes(lights: list[Light]) -> list[tuple[int, int]]:
    """(light index, resolution) of every map the shadowed lights take, in atlas order:
    six for a point light, one per cascade for a directional light, else one."""
    out = []
    for i, light in enumerate(lights):
        if light.shadow:
            count = map_count(light.type) * max(light.shadow_cascades, 1)
            out += [(i, light.shadow_resolution)] * count
    return out


def shadow_atlas_bytes(lights: list[Light], glass: bool = False) -> int:
    """The bytes of the shadow atlas's depth texels (4 each) for ``lights``' maps, and of
    the glass target's (RGBA float32, 16 each) where ``glass`` (a transmissive part)."""
    per_texel = 4 + (16 if glass else 0)
    return sum(per_texel * size * size for _, size in shadow_map_sizes(lights))


def check_shadow_resolutions(ctx: moderngl.Context, lights: list[Light], file: str) -> None:
    """InputError naming ``lights[i].shadow_resolution`` where one map, or the atlas of all
    of them (cascades and cube faces included) packed in rows, is larger than this GL's
    largest texture."""
    limit = max_dimension(ctx)
    sizes: list[int] = []
    for i, light in enumerate(lights):
        if not light.shadow:
            continue
        sizes += [light.shadow_resolution] * map_count(light.type) * max(light.shadow_cascades, 1)
        _, _, height = atlas_layout(sizes, limit)
        if light.shadow_resolution > limit or height > limit:
            what = (
                f"{light.shadow_resolution}"
                if light.shadow_resolution > limit
                else f"{len(sizes)} maps of up to {max(sizes)}"
            )
            raise InputError(
                file,
                f"lights[{i}].shadow_resolution",
                f"{what} texels is past this GL's largest texture, {limit} a side",
            )


def look_along(eye: np.ndarray, forward: np.ndarray) -> np.ndarray:
    """World -> view (looking down -Z along ``forward``), any up that is not parallel."""
    f = np.asarray(forward, np.float64) / np.linalg.norm(forward)
    up = np.array([0.0, 1.0, 0.0]) if abs(f[1]) < 0.99 else np.array([1.0, 0.0, 0.0])
    r = np.cross(f, up)
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    m = np.eye(4)
    m[0, :3], m[1, :3], m[2, :3] = r, u, -f
    m[:3, 3] = -m[:3, :3] @ np.asarray(eye, np.float64)
    return m


def orthographic(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """View -> clip of the box ``lo`` <= (x, y, -z) <= ``hi`` (OpenGL, depth [-1, 1])."""
    m = np.eye(4)
    for axis in range(3):
        m[axis, axis] = 2.0 / (hi[axis] - lo[axis])
        m[axis, 3] = -(hi[axis] + lo[axis]) / (hi[axis] - lo[axis])
    m[2, 2] = -m[2, 2]  # the view looks down -Z
    return m


def perspective(fov_y: float, near: float, far: float) -> np.ndarray:
    """View -> clip, square, OpenGL depth [-1, 1]; ``fov_y`` in radians."""
    c = 1.0 / math.tan(fov_y / 2.0)
    m = np.zeros((4, 4))
    m[0, 0] = m[1, 1] = c
    m[2, 2] = -(far + near) / (far - near)
    m[2, 3] = -2.0 * far * near / (far - near)
    m[3, 2] = -1.0
    return m


def world_points(parts: list[MeshPart]) -> np.ndarray:
    """(N, 3) world points whose bounds hold ``parts``: the vertices, for an analytic
    sphere its proxy's, which enclose it (not ``surface_points``, which divides the proxy
    by its length: 0/0 for a sphere of radius 1e-300, tests/test_fuzz_scenes.py)."""
    pts = [p.vertices[:, :3].astype(np.float64) @ p.model[:3, :3].T + p.model[:3, 3] for p in parts]
    return np.concatenate(pts) if pts else np.zeros((1, 3))


# A map's filter as glsl/lights/shadows.glsl's u_shadow_rect[k].w reads it.
FILTER_CODES = {"none": 0.0, "pcf": 1.0, "pcss": 2.0}

# A map's projection as glsl/lights/shadows.glsl's u_shadow_offset[k].y reads it: a
# cascade is orthographic, one of its light's consecutive maps, nearest slice first.
ORTHOGRAPHIC, PERSPECTIVE, CUBE, CASCADE = 0.0, 1.0, 2.0, 3.0

# Shadowed lights whose lookups glsl/lights/shadows.glsl compiles in steps of their own
# (their projection and filter as constants); any further ones share a loop. The GLSL has
# this many SHADOW_STEP lines (tests/test_shadows.py renders two lights past them).
SHADOW_UNROLLED = 8

# The practical split scheme's weight of the logarithmic split (Zhang et al. 2006,
# "Parallel-Split Shadow Maps on Programmable GPUs"): d_j = w d_log + (1 - w) d_uniform.
CASCADE_LOG_WEIGHT = 0.75


def cascade_splits(near: float, far: float, count: int) -> list[float]:
    """The ``count + 1`` view depths that cut [near, far] into cascades: the practical
    split scheme (``CASCADE_LOG_WEIGHT``)."""
    out = []
    for j in range(count + 1):
        log = near * (far / near) ** (j / count)
        uniform = near + (far - near) * j / count
        out.append(CASCADE_LOG_WEIGHT * log + (1.0 - CASCADE_LOG_WEIGHT) * uniform)
    return out


def cascade_frusta(
    light: PunctualLight, points: np.ndarray, resolution: int, count: int, view_proj: np.ndarray
) -> list[tuple[np.ndarray, float]]:
    """(world -> clip matrix, texel metres) of each of a directional light's ``count``
    cascades for the camera ``view_proj`` (a perspective world -> clip matrix): the view
    from the near plane to the farthest scene point it sees (at most its far plane) cut by
    ``cascade_splits``; each cascade an orthographic map along the light whose x, y bound
    its slice of the view and whose depth bounds the slice and every scene point (so every
    caster between the light and the slice is in it), padded as ``shadow_frustum``."""
    m = np.asarray(view_proj, np.float64)
    inv = np.linalg.inv(m)
    ends = []
    for z in (-1.0, 1.0):  # the near and far planes' corners
        c = np.array([[x, y, z, 1.0] for x in (-1.0, 1.0) for y in (-1.0, 1.0)]) @ inv.T
        ends.append(c[:, :3] / c[:, 3:])
    near_c, far_c = ends
    near = float((m[3, :3] @ near_c[0]) + m[3, 3])  # clip w: the view depth
    far = float((m[3, :3] @ far_c[0]) + m[3, 3])
    depth = points @ m[3, :3] + m[3, 3]
    reach = float(np.clip(depth.max(), near * (1.0 + 1e-6), far))
    view = look_along(np.zeros(3), light.direction)
    local_pts = points @ view[:3, :3].T
    out = []
    splits = cascade_splits(near, reach, count)
    for d0, d1 in itertools.pairwise(splits):
        t = np.array([(d0 - near) / (far - near), (d1 - near) / (far - near)])
        corners = np.concatenate([near_c + (far_c - near_c) * ti for ti in t])
        local = corners @ view[:3, :3].T
        lo, hi = local.min(axis=0), local.max(axis=0)
        z_lo = min(lo[2], local_pts[:, 2].min())
        z_hi = max(hi[2], local_pts[:, 2].max())
        extent = float(max(hi[0] - lo[0], hi[1] - lo[1], 1e-6))
        pad = 0.01 * extent + 1e-6
        lo_box = np.array([lo[0] - pad, lo[1] - pad, -z_hi - pad])
        hi_box = np.array([hi[0] + pad, hi[1] + pad, -z_lo + pad])
        texel = max(hi_box[0] - lo_box[0], hi_box[1] - lo_box[1]) / resolution
        out.append((orthographic(lo_box, hi_box) @ view, float(texel)))
    return out


def shadow_frusta(
    light: PunctualLight, points: np.ndarray, resolution: int
) -> list[tuple[np.ndarray, float, float]]:
    """(world -> clip matrix, texel size, projection kind) of each of ``light``'s maps:
    one, or a point light's six cube faces (+x, -x, +y, -y, +z, -z). The texel size is in
    metres for a directional light, in metres per metre of distance along the axis for a
    spot or a cube face."""
    if light.type == LightType.POINT:
        proj = perspective(0.5 * math.pi, near_plane(light.range), light.range)
        texel = 2.0 / resolution  # 2 tan(45 degrees) / resolution
        return [(proj @ look_along(light.position, f), texel, CUBE) for f in CUBE_FACES]
    return [shadow_frustum(light, points, resolution)]


def shadow_frustum(
    light: PunctualLight, points: np.ndarray, resolution: int
) -> tuple[np.ndarray, float, float]:
    """(world -> clip matrix, texel size, perspective) of a directional or spot light's
    map (``shadow_frusta``)."""
    if light.type == LightType.DIRECTIONAL:
        view = look_along(np.zeros(3), light.direction)
        local = points @ view[:3, :3].T
        lo, hi = local.min(axis=0), local.max(axis=0)
        extent = float(max(hi[0] - lo[0], hi[1] - lo[1], 1e-6))
        pad = 0.01 * extent + 1e-6  # keeps the fitted surfaces off the map's border
        lo_box = np.array([lo[0] - pad, lo[1] - pad, -hi[2] - pad])
        hi_box = np.array([hi[0] + pad, hi[1] + pad, -lo[2] + pad])
        texel = max(hi_box[0] - lo_box[0], hi_box[1] - lo_box[1]) / resolution
        return orthographic(lo_box, hi_box) @ view, float(texel), ORTHOGRAPHIC
    if light.type != LightType.SPOT:
        raise ValueError("a point light's maps are its cube faces (shadow_frusta)")
    half = math.acos(light.cos_outer) + math.radians(SPOT_MARGIN_DEG)  # <= 81 degrees (model)
    view = look_along(light.position, light.direction)
    proj = perspective(2.0 * half, near_plane(light.range), light.range)
    return proj @ view, 2.0 * math.tan(half) / resolution, PERSPECTIVE


def light_bounds(light: PunctualLight) -> tuple[np.ndarray, float] | None:
    """(centre, radius) of a sphere holding every point ``light`` reaches, None for a
    directional light (it reaches everything). A point light: its range sphere. A spot:
    the smaller of that and the bound of its cone, a spherical sector of half angle t (the
    outer cone) and radius R: for t <= 45 degrees the sphere through the apex and the cap's
    rim, centre R / (2 cos t) along the axis and that radius; wider, the cap's rim circle's
    sphere, centre R cos t along the axis, radius R sin t (both hold the apex, the rim and
    the cap's pole: derived, checked in tests/test_shadows.py by sampling the sector)."""
    if light.type == LightType.DIRECTIONAL:
        return None
    centre = np.asarray(light.position, np.float64)
    reach = float(light.range)
    if light.type != LightType.SPOT:
        return centre, reach
    cos_t = float(np.clip(light.cos_outer, 0.0, 1.0))
    sin_t = math.sqrt(1.0 - cos_t * cos_t)
    axis = np.asarray(light.direction, np.float64)
    axis = axis / np.linalg.norm(axis)
    if cos_t >= sin_t:  # t <= 45 degrees
        radius = reach / (2.0 * cos_t)
        offset = radius
    else:
        radius, offset = reach * sin_t, reach * cos_t
    if radius >= reach:
        return centre, reach
    return centre + axis * offset, radius


def frustum_planes(view_proj: np.ndarray) -> np.ndarray:
    """(6, 4) planes (a, b, c, d) of the frustum of a world -> clip matrix, normalised so
    that a x + b y + c z + d is the signed distance (positive inside): the rows' sums and
    differences, Gribb and Hartmann 2001, "Fast Extraction of Viewing Frustum Planes from
    the World-View-Projection Matrix"."""
    m = np.asarray(view_proj, np.float64)
    planes = np.array(
        [m[3] + m[0], m[3] - m[0], m[3] + m[1], m[3] - m[1], m[3] + m[2], m[3] - m[2]]
    )
    return planes / np.linalg.norm(planes[:, :3], axis=1, keepdims=True)


def culled_in(light: PunctualLight, view_proj: np.ndarray) -> bool:
    """Whether ``light``'s bounds (``light_bounds``) may reach the camera's frustum: the
    sphere is not wholly outside one of its six planes (conservative: a sphere off a
    corner passes, and then renders a map that nothing reads)."""
    bounds = light_bounds(light)
    if bounds is None:
        return True
    centre, radius = bounds
    distances = frustum_planes(view_proj) @ np.append(centre, 1.0)
    return bool(np.all(distances >= -radius))


def cull_back_faces(part: MeshPart) -> bool:
    """Whether ``part`` casts only with the faces that face the light: a single-sided mesh
    (``closed``: the camera pass culls its back faces), not an analytic primitive's proxy
    (whose sphere casts whole)."""
    return part.closed and part.analytic is None


def set_sides(ctx: moderngl.Context, part: MeshPart) -> None:
    """The face culling ``part`` casts with (``cull_back_faces``), its winding reversed
    where its model matrix mirrors, as in the camera pass (``MeshDrawable.cull``)."""
    _cull_back(ctx, part, cull_back_faces(part))


def _cull_back(ctx: moderngl.Context, part: MeshPart, cull: bool) -> None:
    """Back faces culled where ``cull`` (the winding reversed where ``part``'s model
    matrix mirrors), else both sides drawn."""
    if cull:
        mirrored = bool(np.linalg.det(part.model[:3, :3]) < 0.0)
        ctx.front_face = "cw" if mirrored else "ccw"
        ctx.cull_face = "back"
        ctx.enable(moderngl.CULL_FACE)
    else:
        ctx.disable(moderngl.CULL_FACE)


# The hardware PCF probe. OpenGL leaves LINEAR depth-comparison filtering to the
# implementation (OpenGL 4.6 core sec. 8.23.1: r from the 2 x 2 comparisons "in an
# implementation-dependent manner", a weighted average recommended); the lookup's four
# hardware comparisons (SHADOW_COMPARE) equal its 16 texel reads, and the float64 twin,
# only where it is that average. softpipe filters the depths and compares the filtered
# depth once (0 or 1; docs/shadows.md, "Hardware PCF, where it is exact").
# The probe: a 2 x 2 DEPTH24 texture (rows y, columns x) sampled at texel positions whose
# bilinear fractions are no multiples of 1/256 (a filter with 8-bit weights misses by up
# to 2e-3), each against four reference depths.
PROBE_DEPTHS = np.array([[0.2, 0.6], [0.4, 0.8]])
PROBE_POSITIONS = ((0.8, 1.2), (1.2, 0.6), (0.55, 1.35))  # texel i's centre at i + 0.5
PROBE_REFERENCES = (0.3, 0.45, 0.55, 0.7)
# The largest difference from the weighted average that counts as exact: float32 weights
# (a coordinate of 1.2 / 2 rounds to 6e-8 of a texel) are well inside it, 8-bit ones not.
PCF_PROBE_TOLERANCE = 1e-5
# Set to 0 or 1, the lookup's path without the probe: 1 the hardware comparisons, 0 the
# 16 texel reads (tests; a GPU whose PCF is not exact but good enough to look at).
HARDWARE_PCF_ENV = "PBS_HARDWARE_PCF"


def probe_models() -> dict[str, np.ndarray]:
    """What each known implementation of a LINEAR comparison (``<=``) returns at the
    probe's points (``PROBE_POSITIONS`` x ``PROBE_REFERENCES``, positions outer): the
    bilinearly weighted average of the four comparisons (what the lookup needs), the
    comparison of the bilinearly filtered depth (softpipe), the nearest texel's comparison
    (a NEAREST-only compare)."""
    out: dict[str, list[float]] = {"weighted": [], "filtered depth": [], "nearest": []}
    d = PROBE_DEPTHS
    for x, y in PROBE_POSITIONS:
        fx, fy = x - 0.5, y - 0.5  # both texels 0 and 1 in range: no edge clamp
        w = np.array([[(1 - fx) * (1 - fy), fx * (1 - fy)], [(1 - fx) * fy, fx * fy]])
        for z in PROBE_REFERENCES:
            out["weighted"].append(float((w * (z <= d)).sum()))
            out["filtered depth"].append(float(z <= (w * d).sum()))
            out["nearest"].append(float(z <= d[int(y), int(x)]))
    return {name: np.array(v) for name, v in out.items()}


@dataclasses.dataclass(frozen=True)
class PcfProbe:
    """What a GL's LINEAR depth comparison measured: ``exact`` where it is the weighted
    2 x 2 average within ``PCF_PROBE_TOLERANCE`` at every probe point; ``behaviour`` the
    model of ``probe_models`` it matches ("other" where none does); ``max_error`` its
    largest difference from the weighted average; ``seconds`` the probe's wall time (its
    first run in the process: later renderers reuse it)."""

    exact: bool
    behaviour: str
    max_error: float
    seconds: float


# Per GL (vendor, renderer, version): Mesa chooses its driver once per process, so one
# probe serves every context of the process.
_PCF_PROBES: dict[tuple[str, str, str], PcfProbe] = {}


def probe_hardware_pcf(ctx: moderngl.Context) -> PcfProbe:
    """Measure (once per GL per process) whether ``ctx``'s LINEAR comparison is the
    weighted 2 x 2 average: one draw of ``len(PROBE_POSITIONS) * len(PROBE_REFERENCES)``
    pixels, each a ``texture()`` of a sampler2DShadow (glsl/passes/shadow_probe.frag) on a
    texture set up as the atlas is (DEPTH24, ``<=``, LINEAR, clamped to its edge)."""
    info = ctx.info
    key = (str(info.get("GL_VENDOR")), str(info.get("GL_RENDERER")), str(info.get("GL_VERSION")))
    known = _PCF_PROBES.get(key)
    if known is None:
        known = _PCF_PROBES[key] = measure_pcf(ctx)
    return known


def measure_pcf(ctx: moderngl.Context, texture_filter: int = moderngl.LINEAR) -> PcfProbe:
    """``probe_hardware_pcf``'s draw and verdict, uncached; ``texture_filter`` the probe
    texture's (``moderngl.NEAREST`` makes any GL a nearest-only compare: the probe's own
    test)."""
    start = time.perf_counter()
    models = probe_models()
    n = len(models["weighted"])
    size = PROBE_DEPTHS.shape[1], PROBE_DEPTHS.shape[0]
    depth = ctx.depth_texture(size, PROBE_DEPTHS.astype(np.float32).tobytes())
    depth.compare_func = "<="
    depth.filter = (texture_filter, texture_filter)
    depth.repeat_x = depth.repeat_y = False
    target = ctx.texture((n, 1), 4, dtype="f4")
    fbo = ctx.framebuffer(color_attachments=[target])
    prog = ctx.program(
        vertex_shader=assemble("passes/fullscreen.vert"),
        fragment_shader=assemble("passes/shadow_probe.frag", {"PROBE_POINTS": n}),
    )
    draw = FullscreenDraw(ctx, prog, owns_program=True)
    points = [(x / size[0], y / size[1], z) for x, y in PROBE_POSITIONS for z in PROBE_REFERENCES]
    prog["u_probe"].write(np.asarray(points, np.float32).tobytes())
    try:
        draw.draw(fbo, textures={"u_depth": depth}, viewport=(0, 0, n, 1))
        wait_before_read(ctx)
        got = np.frombuffer(target.read(), np.float32).reshape(n, 4)[:, 0].astype(np.float64)
    finally:
        draw.release()
        release_objects(fbo, target, depth)
    errors = {name: float(np.abs(got - want).max()) for name, want in models.items()}
    behaviour = min(errors, key=errors.__getitem__)
    if errors[behaviour] > PCF_PROBE_TOLERANCE:
        behaviour = "other"
    exact = errors["weighted"] <= PCF_PROBE_TOLERANCE
    return PcfProbe(exact, behaviour, errors["weighted"], time.perf_counter() - start)


def hardware_pcf(ctx: moderngl.Context) -> bool:
    """Whether the PCF lookup takes the hardware comparisons (SHADOW_COMPARE) on ``ctx``:
    ``PBS_HARDWARE_PCF`` (0 or 1) where set, else the probe's verdict (exact or not)."""
    text = os.environ.get(HARDWARE_PCF_ENV, "").strip()
    if text in ("0", "1"):
        return text == "1"
    if text:
        raise InputError(f"{HARDWARE_PCF_ENV}={text}", "", "expected 0 or 1 (unset: probe)")
    return probe_hardware_pcf(ctx).exact


class _Caster:
    """One part's triangles for the shadow pass: positions only."""

    def __init__(self, ctx: moderngl.Context, prog: moderngl.Program, part: MeshPart) -> None:
        vertices, indices = part.triangles()
        self.vbo = ctx.buffer(np.ascontiguousarray(vertices, np.float32).tobytes())
        self.ibo = ctx.buffer(np.ascontiguousarray(indices, np.uint32).tobytes())
        self.vao = ctx.vertex_array(prog, [(self.vbo, "3f 36x", "in_position")], self.ibo, 4)
        self.model = gl_bytes(part.model)
        self.ctx, self.part = ctx, part

    def draw(self, prog: moderngl.Program, light_matrix: bytes) -> None:
        """Draw into the bound map; ``prog`` (the pass's) already has ``light_matrix``."""
        set_sides(self.ctx, self.part)
        prog["u_model"].write(self.model)
        self.vao.render(moderngl.TRIANGLES)

    def release(self) -> None:
        for obj in (self.vao, self.vbo, self.ibo):
            obj.release()


# The identity as the G-buffer vertex stage's u_view: a masked caster's clip position is
# then u_proj (u_model p) with u_proj the light's matrix, as passes/shadow.vert computes it
# (an identity product is exact), so an opaque texel of a mask lands on the same depth.
_IDENTITY = gl_bytes(np.eye(4))


class _MapsCaster:
    """A mesh part drawn into a shadow target by its own program, with the maps of
    ``MAPS`` it has (and its UVs, COLOR_0, TEXCOORD_1): passes/gbuffer.vert and the
    subclass's ``FRAGMENT``, the sides ``set_sides`` gives and the uniforms ``uniforms``
    writes. Only those maps are uploaded, into ``uploads`` where given (textures another
    pass draws the part with too; their owner releases them), else its own."""

    MAPS: tuple[str, ...] = ()
    FRAGMENT = ""

    def __init__(
        self,
        ctx: moderngl.Context,
        shaders: ShaderCache,
        part: MeshPart,
        defines: dict[str, object] | None = None,
        uploads: TextureUploads | None = None,
    ) -> None:
        layer = part.layers[0]
        maps = {k: v for k, v in layer.maps.items() if k in self.MAPS}
        shown = dataclasses.replace(
            part, layers=[dataclasses.replace(layer, maps=maps)], blend=None
        )
        pair = ("passes/gbuffer.vert", self.FRAGMENT)
        self.drawable = MeshDrawable(ctx, shaders, shown, [0], pair, defines, uploads=uploads)
        self.ctx = ctx

    def set_sides(self, part: MeshPart) -> None:
        set_sides(self.ctx, part)

    def uniforms(self) -> list[tuple[str, bytes]]:
        return []

    def draw(self, prog: moderngl.Program, light_matrix: bytes) -> None:
        """Draw into the bound target with its own program (``prog`` is the pass's)."""
        d = self.drawable
        self.set_sides(d.part)
        d.bind_transform(_IDENTITY, light_matrix)
        d.bind_material()
        for name, data in self.uniforms():
            if name in d.uniforms:
                d.program[name].write(data)
        d.vao.render(moderngl.TRIANGLES)

    def release(self) -> None:
        self.drawable.release()


class _MaskedCaster(_MapsCaster):
    """An alpha-masked part (glTF alphaMode MASK) for the shadow pass, drawn by
    passes/shadow_mask.frag, which discards where the coverage is below the cutoff, as the
    G-buffer pass does. Only the base colour map is uploaded (it alone carries coverage)."""

    MAPS = ("base_color",)
    FRAGMENT = "passes/shadow_mask.frag"


def set_glass_sides(ctx: moderngl.Context, part: MeshPart) -> None:
    """The faces a transmissive part casts its tint with: those facing the light where the
    part is closed (a sphere, a box, a single-sided glTF mesh), so that the light crosses
    each closed body once, as the transmission pass's one interface and one thickness
    model it (docs/shadows.md, "Glass"); both sides of an open part (one pane)."""
    _cull_back(ctx, part, part.closed)


class _GlassCaster(_Caster):
    """A transmissive part for the glass pass: its triangles and the constants of its
    transmittance (glsl/passes/shadow_glass.frag, twin app/reference/glass_shadows.py)."""

    def __init__(self, ctx: moderngl.Context, prog: moderngl.Program, part: MeshPart) -> None:
        super().__init__(ctx, prog, part)
        self.glass = self.constants(part)

    @staticmethod
    def constants(part: MeshPart) -> list[tuple[str, bytes]]:
        """The uniforms of the part's transmittance: ``u_glass`` (transmission, metallic,
        F0, thickness in metres: the object's times its scale), ``u_glass_attenuation``
        and ``u_glass_base_color``."""
        m = part.material
        extra = m.params
        scale = abs(float(np.linalg.det(part.model[:3, :3]))) ** (1.0 / 3.0)
        glass = [float(extra.transmission), float(m.metallic), float(m.f0),
                 float(extra.thickness) * scale]  # fmt: skip
        attenuation = [
            *np.asarray(extra.attenuation_color, np.float64)[:3],
            extra.attenuation_distance,
        ]
        return [
            ("u_glass", np.asarray(glass, np.float32).tobytes()),
            ("u_glass_attenuation", np.asarray(attenuation, np.float32).tobytes()),
            ("u_glass_base_color", np.asarray(m.base_color, np.float32).tobytes()),
        ]

    def draw(self, prog: moderngl.Program, light_matrix: bytes) -> None:
        set_glass_sides(self.ctx, self.part)
        prog["u_model"].write(self.model)
        for name, data in self.glass:
            if name in prog:
                prog[name].write(data)
        self.vao.render(moderngl.TRIANGLES)


# The maps of a transmissive part's layer 0 that shape its shadow's tint, as they shape
# the transmission pass's weight (glsl/passes/shadow_glass.frag GLASS_MAPS).
GLASS_MAPS = ("base_color", "transmission", "thickness")


def glass_textured(part: MeshPart) -> bool:
    """Whether a transmissive mesh's tint varies over it: a base colour, transmission or
    thickness map on layer 0, or COLOR_0 (an analytic sphere's tint stays its constants,
    as an analytic mask casts whole)."""
    layer = part.layers[0]
    colours = part.colors is not None
    return part.analytic is None and (colours or any(k in layer.maps for k in GLASS_MAPS))


class _TexturedGlassCaster(_MapsCaster):
    """A transmissive mesh whose tint varies over it (``glass_textured``), drawn by
    passes/shadow_glass.frag with GLASS_MAPS, which multiplies the constants by the texels
    the transmission pass reads at the same UV (as ``_MaskedCaster`` draws a masked part
    with its coverage). ``uploads``: the transmissive parts' maps, the transmission pass's
    textures (``ShadowPass``'s ``glass_maps``)."""

    MAPS = GLASS_MAPS
    FRAGMENT = "passes/shadow_glass.frag"

    def __init__(
        self,
        ctx: moderngl.Context,
        shaders: ShaderCache,
        part: MeshPart,
        uploads: TextureUploads | None = None,
    ) -> None:
        maps = [k for k in part.layers[0].maps if k in GLASS_MAPS]
        defines = {"GLASS_MAPS": 1, **{t.define: 1 for t in FACTOR_TARGETS
                                        if t.name in targets_of(maps)}}  # fmt: skip
        super().__init__(ctx, shaders, part, defines, uploads)
        self.constants = _GlassCaster.constants(part)

    def set_sides(self, part: MeshPart) -> None:
        set_glass_sides(self.ctx, part)

    def uniforms(self) -> list[tuple[str, bytes]]:
        return self.constants


class ShadowPass(ShaderInput):
    """The shadow maps of a frame's shadowed lights, packed in one depth atlas; to the
    lighting and blend passes a shader input (app/render/inputs.py): ``defines``, the
    atlas ``u_shadow_atlas`` and the maps' uniforms.

    ``lights``: the frame's lights (ordered); ``parts``: the opaque parts that cast and
    receive; ``receivers``: parts that only receive (the blended ones), which a directional
    frustum bounds as well, so that a blended part lies inside the map, and its map is the
    one the part would have if it were opaque. The maps depend only on these, so ``run``
    renders each map at most once, when a camera first culls its light in (docs/shadows.md);
    a renderer builds a new pass when lights or geometry change. ``glass``: the
    transmissive parts, which tint the light; ``glass_maps``: the GL textures of their
    maps, which the transmission pass draws them with too (the renderer's ``glass_maps``,
    released by it; None: the textured casters upload their own)."""

    role = SHADOWS

    def __init__(
        self,
        ctx: moderngl.Context,
        shaders: ShaderCache,
        lights: list[PunctualLight],
        parts: list[MeshPart],
        receivers: list[MeshPart] | None = None,
        glass: list[MeshPart] | None = None,
        glass_maps: TextureUploads | None = None,
    ) -> None:
        self.ctx = ctx
        points = world_points([*parts, *(receivers or [])])
        self.lights: list[int] = []  # per map: its light (six maps for a point light)
        self.matrices: list[np.ndarray] = []
        self.offsets: list[tuple[float, float]] = []
        self.slopes: list[float] = []
        # A texel's world size: metres (directional), metres per metre of distance (spot,
        # cube face).
        self.texels: list[float] = []
        sizes: list[int] = []
        pcf: list[float] = []
        # PCSS's constants per map (glsl/lights/shadows.glsl u_shadow_pcss): light size,
        # near and far (perspective) or 0 and the depth extent (orthographic), texel size.
        self.pcss: list[tuple[float, float, float, float]] = []
        self._points = points
        # A receiver whose normal is mapped: its G-buffer normal is not the surface the maps
        # hold, and the lighting pass offsets its lookups along the plane the depths give
        # (SHADOW_FACE_NORMAL, glsl/gbuffer/decode.glsl face_normal); elsewhere the G-buffer
        # normal is the geometric one and is used as it is.
        self.face_normal = any(
            "normal_roughness" in layer.maps
            for part in [*parts, *(receivers or [])]
            for layer in part.layers
        )
        # (first map, light index, cascades) of each cascaded light, refitted per camera
        self._cascaded: list[tuple[int, int, int]] = []
        self._cascade_camera: np.ndarray | None = None
        for i, light in enumerate(lights):
            s = light.shadow
            if s is None:
                continue
            frusta = shadow_frusta(light, points, s.resolution)
            if s.cascades > 1:  # fitted to the whole scene until a camera refits them
                self._cascaded.append((len(self.lights), i, s.cascades))
                frusta = [(frusta[0][0], frusta[0][1], CASCADE)] * s.cascades
            for matrix, texel, kind in frusta:
                self.lights.append(i)
                self.matrices.append(matrix)
                self.offsets.append((s.normal_offset * texel, kind))
                self.slopes.append(s.slope)
                self.texels.append(texel)
                sizes.append(s.resolution)
                pcf.append(FILTER_CODES[s.filter])
                if kind in (ORTHOGRAPHIC, CASCADE):  # a rotation: row 2 is 2 / extent long
                    near, far = 0.0, 2.0 / float(np.linalg.norm(matrix[2, :3]))
                else:
                    near, far = near_plane(light.range), float(light.range)
                self.pcss.append((s.light_size, near, far, texel))
        self.has_pcss = any(code == FILTER_CODES["pcss"] for code in pcf)
        origins, width, height = atlas_layout(sizes, max_dimension(ctx))
        self.rects = [
            (float(x), float(y), float(size), f)
            for (x, y), size, f in zip(origins, sizes, pcf, strict=True)
        ]
        self._frame_lights = lights
        # per shadowed light: its index and first map (glsl/lights/shadows.glsl u_shadowed)
        self.shadowed = [(i, self.lights.index(i)) for i in dict.fromkeys(self.lights)]
        self._pack_uniforms()
        # The lookup's path: sampler2DShadow, a bilinear 2 x 2 comparison per lookup
        # (SHADOW_COMPARE), where no map uses PCSS (its blocker search reads depths) and
        # this GL's LINEAR comparison is the weighted average (``hardware_pcf``); else
        # texelFetch, the comparisons in the shader.
        self.hardware_pcf = not self.has_pcss and hardware_pcf(ctx)
        self.atlas = ctx.depth_texture((width, height))
        if self.hardware_pcf:
            self.atlas.compare_func = "<="
            self.atlas.filter = (moderngl.LINEAR, moderngl.LINEAR)
        else:
            self.atlas.compare_func = ""
            self.atlas.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.atlas.repeat_x = self.atlas.repeat_y = False
        self.fbo = ctx.framebuffer(depth_attachment=self.atlas)
        self.prog = shaders.program("passes/shadow.vert", "passes/shadow.frag", {})
        # An alpha-masked mesh casts only what its mask keeps (an analytic sphere's mask
        # would need its ray: it casts its whole surface, docs/shadows.md).
        self.casters: list[_Caster | _MaskedCaster] = [
            _MaskedCaster(ctx, shaders, part)
            if masked(part) and part.analytic is None
            else _Caster(ctx, self.prog, part)
            for part in parts
        ]
        self.masked = any(isinstance(c, _MaskedCaster) for c in self.casters)
        # Glass (transmissive parts, ``glass``): a second target beside the depth atlas,
        # RGBA float32, rgb the product of the transmittances of the glass surfaces in front
        # of the opaque depth, alpha the nearest glass depth (docs/shadows.md, "Glass").
        # Only where the frame has glass: a scene without compiles and renders as before.
        self.glass_atlas: moderngl.Texture | None = None
        self.glass_casters: list[_GlassCaster | _TexturedGlassCaster] = []
        if glass:
            self.glass_prog = shaders.program("passes/shadow.vert", "passes/shadow_glass.frag", {})
            self.glass_casters = [
                _TexturedGlassCaster(ctx, shaders, part, glass_maps)
                if glass_textured(part)
                else _GlassCaster(ctx, self.glass_prog, part)
                for part in glass
            ]
            self.glass_atlas = ctx.texture((width, height), 4, dtype="f4")
            self.glass_atlas.filter = (moderngl.NEAREST, moderngl.NEAREST)
            self.glass_atlas.repeat_x = self.glass_atlas.repeat_y = False
            self.glass_fbo = ctx.framebuffer([self.glass_atlas], self.atlas)
        self.rendered: set[int] = set()  # the maps drawn so far (indices into the lists)
        self.maps_rendered = 0  # maps drawn over this pass's life (tests, bench)
        self._cleared = False

    @property
    def count(self) -> int:
        return len(self.lights)

    def defines(self) -> dict[str, int]:
        """The lighting and blend programs' defines: SHADOWS (maps) and SHADOW_LIGHTS
        (shadowed lights), the first SHADOW_UNROLLED lights' projection and filter
        (SHADOW_PROJ_j, SHADOW_FILTER_j: their lookup steps compile only their own kind),
        SHADOW_PCSS only where a map uses PCSS, SHADOW_COMPARE where the atlas is read
        through sampler2DShadow (``hardware_pcf``), and SHADOW_CASCADES only where a light
        has cascades (a scene without compiles as before they existed), SHADOW_FACE_NORMAL
        where a receiver's normal is mapped (``face_normal``)."""
        defines = {"SHADOWS": self.count, "SHADOW_LIGHTS": len(self.shadowed)}
        # the first SHADOW_UNROLLED lights' projection and filter, compiled into their steps
        for j, (_, k) in enumerate(self.shadowed[:SHADOW_UNROLLED]):
            defines[f"SHADOW_PROJ_{j}"] = int(self.offsets[k][1])
            defines[f"SHADOW_FILTER_{j}"] = int(self.rects[k][3])
        if self.has_pcss:
            defines["SHADOW_PCSS"] = 1
        if self.hardware_pcf:
            defines["SHADOW_COMPARE"] = 1
        if self._cascaded:
            defines["SHADOW_CASCADES"] = 1
        if self.face_normal:
            defines["SHADOW_FACE_NORMAL"] = 1
        if self.glass_atlas is not None:
            defines["SHADOW_GLASS"] = 1
        return defines

    def needed(self, view_proj: np.ndarray | None) -> list[int]:
        """The maps a camera of world -> clip ``view_proj`` needs: those of the lights
        culled in (``culled_in``), every map where ``view_proj`` is None."""
        if view_proj is None:
            return list(range(self.count))
        lights = {i for i in set(self.lights) if culled_in(self._frame_lights[i], view_proj)}
        return [k for k, i in enumerate(self.lights) if i in lights]

    def _pack_uniforms(self) -> None:
        """The lighting programs' uniforms, packed once (again only when cascades are
        refitted to a new camera)."""
        self._uniforms = {
            "u_shadow_light": np.asarray(self.lights, np.int32).tobytes(),
            "u_shadow_matrix": b"".join(gl_bytes(m) for m in self.matrices),
            "u_shadow_rect": np.asarray(self.rects, np.float32).tobytes(),
            "u_shadow_offset": np.asarray(self.offsets, np.float32).tobytes(),
            "u_shadowed": np.asarray(self.shadowed, np.int32).tobytes(),
            "u_shadow_position": np.asarray(
                [self._frame_lights[i].position for i, _ in self.shadowed], np.float32
            ).tobytes(),
        }
        if self.has_pcss:
            self._uniforms["u_shadow_pcss"] = np.asarray(self.pcss, np.float32).tobytes()

    def _fit_cascades(self, view_proj: np.ndarray) -> None:
        """Refit every cascaded light's maps to the camera ``view_proj`` (where it moved
        since the last fit) and mark them to be drawn again."""
        if not self._cascaded or (
            self._cascade_camera is not None and np.array_equal(self._cascade_camera, view_proj)
        ):
            return
        self._cascade_camera = np.array(view_proj, np.float64)
        for first, i, count in self._cascaded:
            light = self._frame_lights[i]
            s = light.shadow
            assert s is not None
            fits = cascade_frusta(light, self._points, s.resolution, count, view_proj)
            for k, (matrix, texel) in enumerate(fits, start=first):
                self.matrices[k] = matrix
                self.texels[k] = texel
                self.offsets[k] = (s.normal_offset * texel, CASCADE)
                far = 2.0 / float(np.linalg.norm(matrix[2, :3]))
                self.pcss[k] = (s.light_size, 0.0, far, texel)
                self.rendered.discard(k)
        self._pack_uniforms()

    def invalidate(self) -> None:
        """Forget every map drawn: the next ``run`` clears the atlas and draws again what
        its camera needs (the bench's shadows suite times that)."""
        self.rendered.clear()
        self._cleared = False

    def run(self, view_proj: np.ndarray | None = None) -> None:
        """Render the maps the camera ``view_proj`` needs and that are not drawn yet (each
        once: they change only with a new pass). A light outside the frustum reaches no
        visible point, so its map, left cleared (lit), changes no pixel; a later camera
        that sees its reach renders it then."""
        if view_proj is not None:
            self._fit_cascades(view_proj)
        todo = [k for k in self.needed(view_proj) if k not in self.rendered]
        if not todo and self._cleared:
            return
        ctx = self.ctx
        self.fbo.use()
        ctx.enable_only(moderngl.DEPTH_TEST)  # each caster sets its sides (set_sides)
        ctx.depth_func = "<"
        if not self._cleared:
            self.fbo.clear(depth=1.0)
            self._cleared = True
        for k in todo:
            rect = self.rects[k]
            ctx.viewport = (int(rect[0]), int(rect[1]), int(rect[2]), int(rect[2]))
            self.fbo.clear(depth=1.0, viewport=ctx.viewport)  # a refitted cascade's old depths
            ctx.polygon_offset = (self.slopes[k], 1.0)
            light_matrix = gl_bytes(self.matrices[k])
            self.prog["u_light_matrix"].write(light_matrix)
            for caster in self.casters:
                caster.draw(self.prog, light_matrix)
            self.rendered.add(k)
            self.maps_rendered += 1
        if self.glass_casters:
            self._run_glass(todo)
        ctx.polygon_offset = (0.0, 0.0)
        ctx.disable(moderngl.CULL_FACE)
        ctx.front_face = "ccw"

    def _run_glass(self, todo: list[int]) -> None:
        """The glass target of maps ``todo`` (their opaque depths drawn): cleared to
        (1, 1, 1, 1), then every glass surface in front of the opaque depth (depth test
        ``<``, no depth writes) multiplies rgb by its transmittance (blend ZERO, SRC_COLOR)
        and keeps the nearest window depth in alpha (blend equation MIN)."""
        ctx = self.ctx
        self.glass_fbo.use()
        self.glass_fbo.depth_mask = False
        ctx.enable(moderngl.BLEND)
        ctx.blend_func = (moderngl.ZERO, moderngl.SRC_COLOR, moderngl.ONE, moderngl.ONE)
        ctx.blend_equation = (moderngl.FUNC_ADD, moderngl.MIN)
        for k in todo:
            rect = self.rects[k]
            ctx.viewport = (int(rect[0]), int(rect[1]), int(rect[2]), int(rect[2]))
            self.glass_fbo.clear(1.0, 1.0, 1.0, 1.0, viewport=ctx.viewport)
            ctx.polygon_offset = (self.slopes[k], 1.0)
            light_matrix = gl_bytes(self.matrices[k])
            self.glass_prog["u_light_matrix"].write(light_matrix)
            for caster in self.glass_casters:
                caster.draw(self.glass_prog, light_matrix)
        ctx.disable(moderngl.BLEND)
        ctx.blend_func = moderngl.DEFAULT_BLENDING
        ctx.blend_equation = moderngl.FUNC_ADD
        self.glass_fbo.depth_mask = True

    def read_glass(self) -> np.ndarray:
        """The glass target (rows from the bottom, as texelFetch indexes them): (h, w, 4),
        rgb the transmittance product, alpha the nearest glass window depth."""
        assert self.glass_atlas is not None
        w, h = self.glass_atlas.size
        wait_before_read(self.ctx)
        return (
            np.frombuffer(self.glass_atlas.read(), np.float32).reshape(h, w, 4).astype(np.float64)
        )

    def samplers(self) -> list[tuple[str, moderngl.Texture]]:
        if self.glass_atlas is not None:
            return [("u_shadow_atlas", self.atlas), ("u_shadow_glass", self.glass_atlas)]
        return [("u_shadow_atlas", self.atlas)]

    def uniforms(self, prog: moderngl.Program) -> None:
        """Set a lighting program's shadow uniforms (glsl/lights/shadows.glsl)."""
        for name, data in self._uniforms.items():
            if name in prog:  # the compiler drops what a program does not read
                prog[name].write(data)

    def read(self) -> ShadowMaps:
        """The maps as the float64 twin takes them (app/reference/shadows.py): the atlas's
        window depths, row 0 at the bottom as texelFetch indexes them, the uniforms, and
        the glass target (``read_glass``) where the frame has one."""
        w, h = self.atlas.size
        wait_before_read(self.atlas.ctx)
        depth = np.frombuffer(self.atlas.read(), np.float32).reshape(h, w).astype(np.float64)
        glass = self.read_glass() if self.glass_atlas is not None else None
        return ShadowMaps(
            depth, tuple(self.lights), tuple(self.matrices), tuple(self.rects),
            tuple(self.offsets), tuple(self.pcss), self.face_normal, glass,
        )  # fmt: skip

    def release(self) -> None:
        for caster in [*self.casters, *self.glass_casters]:
            caster.release()
        if self.glass_atlas is not None:
            release_objects(self.glass_fbo, self.glass_atlas)
        release_objects(self.fbo, self.atlas)
