"""The bench's scenes, as scene-file dictionaries (docs/scene-format.md).

* ``many_lights_scene``: the culling and resolution suites' scene (tests/test_culling.py's
  generator, generalised): a 40 m floor with twelve spheres under ``count`` coloured point
  and spot lights (alternating, so a 4 + 4 light case fits pyrender's limits) scattered
  over a 28 x 28 m field, every light with the same range. ``calibrate_range`` picks that
  range so that about ``target`` lights reach an average surface pixel.
* ``accuracy_scene``: two rows of spheres sweeping roughness over a floor, 16 point lights
  and one low directional light that all reach everything, with every material set to the
  model a comparison of the accuracy suite asks for.
* ``specialization_scene``: the culling scene's floor, spheres and lights, with every
  material on the standard model (``lambert``: one model group) or each sphere on one of
  ``MIXED_MODELS`` (``mixed``: seven groups).
"""

from __future__ import annotations

import copy
import math

import numpy as np

from app.bench.pairs import in_cone_mask
from app.common.gbuffer import DEFAULT_ENCODING
from app.common.lights import LightType
from app.frame.lights import light_record
from app.gl.context import GLContext
from app.reference.illumination import surface_positions
from app.render.renderer import Renderer
from app.scene.loader import parse_scene

FIELD_HALF = 14.0  # lights lie over [-14, 14]^2 m
BASE_RANGE = 3.0  # range at which a light's intensity is BASE_INTENSITY
BASE_INTENSITY = 4.0


def _light_field(count: int, seed: int = 3) -> list[tuple[list[float], list[float]]]:
    """(position, colour) of ``count`` lights, deterministic."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        x, z = rng.uniform(-FIELD_HALF, FIELD_HALF, 2)
        y = float(rng.uniform(0.3, 3.0))
        colour = [float(c) for c in rng.uniform(0.2, 1.0, 3)]
        out.append(([float(x), y, float(z)], colour))
    return out


def many_lights_scene(
    count: int,
    light_range: float,
    size: tuple[int, int],
    culling: str = "tiled",
    gbuffer: str = DEFAULT_ENCODING,
) -> dict:
    """The culling suite's scene with ``count`` lights (no directional light: the count is
    exactly the number of lights a pixel could be lit by).

    Intensity grows as range^2 (``BASE_INTENSITY`` at ``BASE_RANGE``), so that the light
    reaching an average pixel stays about the same as the ranges change with the count.
    """
    intensity = BASE_INTENSITY * (light_range / BASE_RANGE) ** 2
    lights = []
    for i, (position, colour) in enumerate(_light_field(count)):
        light = {
            "type": "spot" if i % 2 else "point",
            "position": position,
            "color": colour,
            "intensity": intensity,
            "range": light_range,
        }
        if light["type"] == "spot":
            light["direction"] = [0.0, -1.0, 0.1]
            light["outer_angle"] = 60.0
            light["inner_angle"] = 45.0
        lights.append(light)
    rng = np.random.default_rng(5)
    ball_materials = ("plastic", "gold", "rubber")
    spheres = [
        {
            "shape": "sphere",
            "radius": 1.0,
            "material": ball_materials[k % 3],
            "position": [float(x), 1.0, float(z)],
        }
        for k, (x, z) in enumerate(rng.uniform(-8.0, 8.0, (12, 2)))
    ]
    return {
        "camera": {"position": [0.0, 9.0, 16.0], "exposure": -1.0},
        "render": {
            "width": size[0],
            "height": size[1],
            "light_culling": culling,
            "gbuffer": gbuffer,
        },
        "materials": {
            "floor": {"base_color": [0.7, 0.7, 0.7], "roughness": 0.6},
            "plastic": {"base_color": [0.8, 0.3, 0.2], "roughness": 0.3},
            "gold": {"base_color": [1.0, 0.78, 0.34], "metallic": 1.0, "roughness": 0.35},
            "rubber": {"base_color": [0.2, 0.3, 0.8], "roughness": 0.7},
        },
        "lights": lights,
        "objects": [{"shape": "plane", "size": [40.0, 40.0], "material": "floor"}, *spheres],
    }


def load(data: dict, name: str = "bench.toml"):
    """A scene dictionary as the renderer's LoadedScene (validated like a file)."""
    return parse_scene(copy.deepcopy(data), name)


def calibrate_range(
    gl: GLContext, count: int, target: float, size: tuple[int, int] = (160, 90)
) -> float:
    """The common light range that makes ``target`` lights reach an average surface pixel of
    ``many_lights_scene(count, ...)``; with ``count <= target`` every light reaches every
    pixel of its cone (the range is 1% beyond the farthest such pixel).

    A light reaches a pixel closer than its range and, for a spot light, inside its outer
    cone (app/bench/pairs.py). The mean over pixels of #{lights reaching} is #{(pixel,
    light) pairs in cone and closer than r} / pixels, so r is the (target x pixels)-th
    smallest in-cone pixel-light distance, found on a small G-buffer (the lights do not
    change the G-buffer; ``size`` keeps the aspect).
    """
    data = many_lights_scene(count, 1.0, size)
    loaded = load(data)
    renderer = Renderer(gl, loaded, size)
    try:
        renderer.gbuffer_pass.run(renderer.gbuffer, renderer.view, renderer.proj, renderer.camera)
        _, p = surface_positions(renderer.read_gbuffer(), renderer.camera)
    finally:
        renderer.release()
    records = [light_record(light) for light in loaded.scene.lights]
    centres = np.array([r.position for r in records], np.float64)
    axes = np.array([r.direction for r in records], np.float64)
    cos_outer = np.array([r.cos_outer if r.type == LightType.SPOT else -2.0 for r in records])
    # |p - c|^2 by expansion (one matrix product): its rounding is irrelevant to a range.
    d2 = (p * p).sum(axis=1)[:, None] + (centres * centres).sum(axis=1)[None, :]
    d = np.sqrt(np.maximum(d2 - 2.0 * (p @ centres.T), 0.0))
    d = np.where(in_cone_mask(p, centres, axes, cos_outer), d, np.inf).ravel()
    if count <= target:
        return float(d[np.isfinite(d)].max() * 1.01)
    k = round(target * len(p))
    return float(np.partition(d, k)[k])


# --- the accuracy suite -------------------------------------------------------------------

ROUGHNESS_SWEEP = (0.05, 0.2, 0.35, 0.5, 0.7, 0.9)


def accuracy_scene(size: tuple[int, int], model: dict, gbuffer: str = DEFAULT_ENCODING) -> dict:
    """Spheres sweeping roughness (front row dielectric, back row metallic unless the
    comparison is about dielectric Fresnel) over a floor; every material gets ``model``'s
    keys (e.g. {"g2": "hammon"}). 16 point lights and a low directional light reach every
    pixel, so the BRDF is evaluated 17 times per pixel."""
    dielectric_only = model.get("fresnel") in ("dielectric", "schlick") and "ior" in model
    materials: dict[str, dict] = {}
    objects: list[dict] = []
    for row, (z, metallic) in enumerate(((1.0, 0.0), (-1.2, 1.0))):
        for k, r in enumerate(ROUGHNESS_SWEEP):
            name = f"m{row}{k}"
            colour = [0.75, 0.12, 0.08] if row == 0 else [0.95, 0.64, 0.54]
            mat = {"base_color": colour, "roughness": r}
            if not dielectric_only:
                mat["metallic"] = metallic
            mat.update(model)
            materials[name] = mat
            x = -3.75 + 1.5 * k
            objects.append(
                {"shape": "sphere", "radius": 0.6, "material": name, "position": [x, 0.6, z]}
            )
    floor = {"base_color": [0.4, 0.4, 0.4], "roughness": 0.8, **model}
    materials["floor"] = floor
    objects.insert(0, {"shape": "plane", "size": [20.0, 20.0], "material": "floor"})
    lights: list[dict] = [
        {"type": "directional", "direction": [-0.8, -0.12, -0.3], "intensity": 1.5},
    ]
    for i in range(16):
        angle = 2.0 * math.pi * i / 16
        radius = 3.0 + 2.0 * (i % 2)
        lights.append(
            {
                "type": "point",
                "position": [
                    radius * math.cos(angle),
                    1.2 + 0.8 * (i % 3),
                    radius * math.sin(angle),
                ],
                "color": [1.0, 0.9 - 0.03 * (i % 5), 0.8 + 0.04 * (i % 4)],
                "intensity": 2.0,
                "range": 40.0,
            }
        )
    return {
        "background": [0.02, 0.022, 0.03],
        "camera": {"position": [0.0, 3.2, 7.5], "target": [0.0, 0.5, 0.0], "fov_y": 40.0},
        "render": {"width": size[0], "height": size[1], "gbuffer": gbuffer},
        "materials": materials,
        "lights": lights,
        "objects": objects,
    }


# --- the specialization suite -------------------------------------------------------------

# Six sphere models of the mixed scene, beside the standard floor: every optional term a
# specialized pass compiles out (other NDFs and G2 forms, exact Fresnel, other diffuse
# lobes, multiple scattering, anisotropy) appears in at least one.
MIXED_MODELS: tuple[dict, ...] = (
    {"ndf": "beckmann", "g2": "separable", "diffuse": "burley"},
    {"ndf": "gtr", "gtr_gamma": 1.5, "g2": "height_direction_correlated"},
    {"fresnel": "conductor", "preset": "gold", "multiscatter": True},
    {"anisotropy": 0.7, "diffuse": "oren_nayar"},
    {"fresnel": "dielectric", "ior": 1.5, "g2": "hammon", "diffuse": "hammon"},
    {"ndf": "blinn_phong", "diffuse": "shirley"},
)
SPECIALIZATION_KINDS = ("lambert", "mixed")


def specialization_scene(kind: str, count: int, light_range: float, size: tuple[int, int]) -> dict:
    """``many_lights_scene`` with ``count`` lights, its materials set by ``kind``:

    * ``lambert``: as it is: floor and spheres all on the standard model (Schlick F, GGX D,
      height-correlated Smith G2, Lambert diffuse), so one lighting program shades all;
    * ``mixed``: the floor on the standard model and the twelve spheres cycling through
      ``MIXED_MODELS``: seven model groups, seven specialized lighting programs.
    """
    data = many_lights_scene(count, light_range, size)
    if kind == "lambert":
        return data
    if kind != "mixed":
        raise ValueError(f"unknown specialization scene {kind!r}")
    colours = ([0.8, 0.3, 0.2], [0.2, 0.3, 0.8], [1.0, 0.78, 0.34], [0.3, 0.7, 0.3])
    for k, keys in enumerate(MIXED_MODELS):
        material = {
            "base_color": colours[k % len(colours)],
            "roughness": 0.25 + 0.1 * k,
            **keys,
        }
        if "preset" in keys:
            material.pop("base_color")
        data["materials"][f"model{k}"] = material
    for k, obj in enumerate(data["objects"][1:]):
        obj["material"] = f"model{k % len(MIXED_MODELS)}"
    return data


# --- the G-buffer encodings ---------------------------------------------------------------

# The materials of the encodings' varied scene: dark and bright base colours, dielectrics
# and metals, roughness 0.05 to 1, and one anisotropic metal so that RT3 (the tangent) is
# written and read.
VARIED_MATERIALS: tuple[dict, ...] = (
    {"base_color": [0.02, 0.02, 0.025], "roughness": 0.05},
    {"base_color": [0.9, 0.88, 0.85], "roughness": 0.3},
    {"base_color": [0.95, 0.64, 0.54], "metallic": 1.0, "roughness": 0.12},
    {"base_color": [0.04, 0.3, 0.05], "roughness": 1.0},
    {"base_color": [0.91, 0.92, 0.92], "metallic": 1.0, "roughness": 0.4, "anisotropy": 0.8},
    {"base_color": [0.3, 0.05, 0.6], "roughness": 0.6, "f0": 0.02},
)


def encoding_scene(size: tuple[int, int], kind: str, gbuffer: str = "f32") -> dict:
    """The scenes the G-buffer encodings are measured on (docs/gbuffer.md): ``spheres``,
    five spheres of the default material (the default model) under two directional lights
    and a point light; ``varied``, six spheres of ``VARIED_MATERIALS`` under the same
    lights. No floor: every covered pixel is a sphere's."""
    materials = (
        [{}] * 5 if kind == "spheres" else list(VARIED_MATERIALS)
    )  # the default material: base colour, roughness and F0 as docs/scene-format.md gives
    count = len(materials)
    objects = [
        {
            "shape": "sphere",
            "radius": 0.7,
            "material": f"m{k}",
            "position": [-1.6 * (count - 1) / 2 + 1.6 * k, 0.0, 0.0],
        }
        for k in range(count)
    ]
    lights = [
        {"type": "directional", "direction": [-0.5, -0.6, -0.62], "intensity": 2.0},
        {"type": "directional", "direction": [0.7, -0.2, -0.7], "color": [0.6, 0.7, 1.0]},
        {"type": "point", "position": [1.0, 2.0, 3.0], "intensity": 6.0, "range": 30.0},
    ]
    return {
        "background": [0.0, 0.0, 0.0],
        "camera": {"position": [0.0, 0.6, 7.0], "target": [0.0, 0.0, 0.0], "fov_y": 40.0},
        "render": {"width": size[0], "height": size[1], "gbuffer": gbuffer},
        "materials": {f"m{k}": m for k, m in enumerate(materials)},
        "lights": lights,
        "objects": objects,
    }
