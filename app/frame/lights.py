"""Scene lights -> the typed records (``PunctualLight``) that both the GLSL and the float64
twin consume."""

from __future__ import annotations

import math

import numpy as np

from app.common.lights import LightType, PunctualLight, ShadowSettings, order_lights
from app.scene.model import AREA_LIGHT_TYPES, Environment, Light


def area_record(light: Light) -> PunctualLight:
    """A rect, disk, sphere or tube light as its record (docs/area_lights.md): centre, half
    extents and radius, and the radiance of a point light's power (``area_radiance``)."""
    from app.reference.area_lights import area_radiance  # area-light scenes only

    kind = LightType[light.type.upper()]
    d = np.zeros(3) if light.direction is None else np.asarray(light.direction, float)
    if light.direction is not None:
        d = d / np.linalg.norm(d)
    # a rectangle's width horizontal: across d and the world's up (X where d is vertical)
    across = np.cross([0.0, 1.0, 0.0], d)
    if np.linalg.norm(across) < 1e-6:
        across = np.array([1.0, 0.0, 0.0])
    e_u = across / np.linalg.norm(across)
    e_v = np.cross(d, e_u)  # e_u x e_v = d: the side it emits to
    u = w = np.zeros(3)
    radius = float(light.radius or 0.0)
    if kind == LightType.RECT:
        u, w = 0.5 * light.size[0] * e_u, 0.5 * light.size[1] * e_v
    elif kind == LightType.DISK:
        u, w = radius * e_u, radius * e_v
    elif kind == LightType.TUBE:
        u = 0.5 * float(light.length) * d
    c_light = np.asarray(light.color, float) * light.intensity
    return PunctualLight(
        type=kind,
        position=np.asarray(light.position, float),
        direction=d,
        color=area_radiance(kind, c_light, u, w, radius),
        range=light.effective_range,
        axis_u=u,
        axis_v=w,
        radius=radius,
    )


def light_record(light: Light) -> PunctualLight:
    """One scene light as glsl/lights/punctual.glsl's PunctualLight, in float64."""
    if light.type in AREA_LIGHT_TYPES:
        return area_record(light)
    direction = np.zeros(3) if light.direction is None else np.asarray(light.direction, float)
    if light.direction is not None:
        direction = direction / np.linalg.norm(direction)
    inner, outer = light.cone
    return PunctualLight(
        type=LightType[light.type.upper()],
        position=np.zeros(3) if light.position is None else np.asarray(light.position, float),
        direction=direction,
        color=np.asarray(light.color, float) * light.intensity,
        # Directional lights ignore range; a finite stand-in keeps the texture finite.
        range=1.0 if light.type == "directional" else light.effective_range,
        cos_outer=math.cos(math.radians(outer)),
        cos_inner=math.cos(math.radians(inner)),
        shadow=shadow_settings(light),
    )


def shadow_settings(light: Light) -> ShadowSettings | None:
    """A scene light's shadow map settings, None where it casts no shadow."""
    if not light.shadow:
        return None
    slope, normal_offset = light.shadow_bias
    size = (
        math.tan(math.radians(light.shadow_light_angle))
        if light.type == "directional"
        else float(light.shadow_light_radius)
    )
    return ShadowSettings(
        light.shadow_resolution, slope, normal_offset, light.shadow_filter, size,
        light.shadow_cascades,
    )  # fmt: skip


def fibonacci_sphere(count: int) -> np.ndarray:
    """``count`` unit vectors spread evenly over the sphere (a spherical Fibonacci lattice,
    Gonzalez 2010): equal-area cells, so each stands for 4 pi / count steradians."""
    i = np.arange(count) + 0.5
    z = 1.0 - 2.0 * i / count
    r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    phi = i * math.pi * (3.0 - math.sqrt(5.0))  # the golden angle
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)


def cell_integrals(env_map: np.ndarray, directions: np.ndarray, rotation: float) -> np.ndarray:
    """The integral of the map's radiance over each direction's Voronoi cell on the sphere,
    sum over the cell's texels of L dOmega (N, 3): every texel (turned ``rotation`` degrees
    about +Y into the world) goes to its nearest direction, so the cells partition the
    sphere and the integrals sum to the whole map's integral."""
    from app.reference.ibl import map_texels  # environment scenes only (start-up)

    d, weighted = map_texels(env_map, math.radians(rotation))
    out = np.zeros((len(directions), 3))
    for start in range(0, len(d), 65536):  # chunks bound the (texels x N) dot products
        nearest = np.argmax(d[start : start + 65536] @ directions.T, axis=1)
        np.add.at(out, nearest, weighted[start : start + 65536])
    return out


def environment_texels(env: Environment) -> np.ndarray:
    """The equirect map (float32, read-only, cached) of an image, sky or studio environment,
    before rotation and intensity."""
    from app.textures.environment import environment_map  # environment scenes only

    sun = None if env.sun_direction is None else tuple(env.sun_direction)
    return environment_map(env.source, env.file, sun, env.turbidity)


def map_lights(env: Environment) -> list[PunctualLight]:
    """An image, sky or studio environment as ``env.samples`` directional lights on the
    Fibonacci lattice, each carrying its cell's radiance (docs/ibl.md): how the float64
    ray-caster integrates it (the renderer uses the split sum, app/render/ibl.py).

    L_o = integral f L (n.l)+ dl ~ sum_i f(l_i) (n.l_i)+ integral_cell_i L dl, and the
    illumination sum gives pi sum_i f c_light (n.l_i)+, so c_light_i = (1/pi) integral over
    cell i, times ``intensity``. A uniform map would give c = 4 L / N on every light (to the
    cells' discretisation), but a uniform environment never comes here: the renderer and
    the ray-caster integrate it per point by its own quadrature (``uniform_environment``;
    app/reference/environment_uniform.py). Exact for the diffuse term's low frequencies;
    glossy surfaces see the N dots of the lattice unless N grows.
    """
    env_map = environment_texels(env)
    directions = fibonacci_sphere(env.samples)
    colors = cell_integrals(env_map, directions, env.rotation) * (env.intensity / math.pi)
    return [
        # light travels from direction d towards the surface
        PunctualLight(LightType.DIRECTIONAL, np.zeros(3), -d, c)
        for d, c in zip(directions, colors, strict=True)
    ]


def frame_lights(lights: list[Light]) -> list[PunctualLight]:
    """The scene's lights in the order every pass sums them (``order_lights``). An
    environment is not among them: the lighting pass adds it per pixel (docs/ibl.md)."""
    return order_lights([light_record(x) for x in lights])


def uniform_environment(env: Environment | None) -> tuple[np.ndarray, int] | None:
    """(radiance L, quadrature directions) of a uniform environment, the twin's and the
    lighting pass's input (app/reference/environment_uniform.py); None for none or
    another source."""
    if env is None or env.source != "uniform":
        return None
    return np.asarray(env.radiance, np.float64), env.samples
