"""A validated scene -> the float64 ray-caster's inputs and its reference image
(app/reference/raycast.py).

The primitives are built from ``scene.objects`` directly (their model matrices by
app.scene.geometry.model_matrix), not from the tessellated mesh parts, and the materials
from the scene's definitions (``Material.resolve``, as the layers take them), so the
reference shares no geometry with the renderer. What it cannot reproduce exactly it
refuses with a ValueError naming the object, material or key: mesh files and the shapes
it does not intersect, texture maps, blends, a camera with an aperture.
"""

from __future__ import annotations

import math

import numpy as np

from app.common.primitives import Primitive
from app.frame.camera import camera_frame
from app.frame.lights import environment_texels, frame_lights, map_lights, uniform_environment
from app.reference.environment import equirect_uv, sample_bilinear
from app.reference.material import Surface
from app.reference.raycast import (
    Background,
    PrimitiveMaterial,
    RaycastImage,
    area_reference,
    camera_rays,
    ndc_rays,
    render_reference,
)
from app.scene.loader import LoadedScene
from app.scene.model import TEXTURE_KEYS, Material, SceneObject
from app.scene.placement import model_matrix


def _label(index: int, obj: SceneObject) -> str:
    return f"objects[{index}]" + (f" ({obj.name!r})" if obj.name else "")


def primitive(index: int, obj: SceneObject) -> Primitive:
    """Scene object ``index`` as an analytic primitive; ValueError for what has none."""
    model = model_matrix(obj)
    if obj.shape == "sphere":
        return Primitive("sphere", model, radius=float(obj.radius or 0.5))  # geometry.py's default
    if obj.shape == "plane":
        size = obj.size or [10.0, 10.0]  # the mesh plane's default (app/scene/geometry.py)
        return Primitive("plane", model, size=(float(size[0]), float(size[1])))
    raise ValueError(
        f"{_label(index, obj)}: the ray-caster intersects spheres and planes, not "
        f"shape {obj.shape!r}"
    )


def primitive_material(name: str, m: Material) -> PrimitiveMaterial:
    """Scene material ``name`` as the twins take it; ValueError for maps and blends (the
    ray-caster shades material constants only)."""
    maps = [key for key in TEXTURE_KEYS if getattr(m, key) is not None]
    if maps:
        raise ValueError(f"materials.{name}: the ray-caster takes no texture maps ({maps[0]})")
    if m.blend is not None:
        raise ValueError(f"materials.{name}: the ray-caster takes no blends (blend)")
    if any(m.emission) or m.alpha_mode != "opaque":  # glTF 2.0 core material
        key = "emissive" if any(m.emission) else "alpha_mode"
        raise ValueError(
            f"materials.{name}: the ray-caster takes no emission, alpha mask or blend ({key})"
        )
    p = m.resolve()
    surface = Surface(
        np.asarray(p.base_color, np.float64), p.metallic, p.roughness, p.f0, p.anisotropy
    )
    return PrimitiveMaterial(surface, p.params, p.model, math.radians(m.anisotropy_rotation))


def _scene_inputs(
    loaded: LoadedScene, size: tuple[int, int] | None
) -> tuple[tuple[int, int], list, list, list]:
    """What both references cast from ``loaded``: the image size (default the scene's
    render size), the primitives and their materials in object order, and the lights,
    an image, sky or studio environment's cell lights included (the reference integrates
    those by brute force, the renderer by the split sum: the two converge as the cells
    grow; a uniform environment is the renderer's own quadrature, through the twin)."""
    scene = loaded.scene
    if scene.camera.aperture > 0.0:
        raise ValueError("camera.aperture: the ray-caster is a pinhole camera (no depth of field)")
    if size is None:
        size = (scene.render.width, scene.render.height)
    prims, materials = [], []
    for i, obj in enumerate(scene.objects):
        prims.append(primitive(i, obj))
        assert obj.material is not None  # the scene model requires one for every shape
        materials.append(primitive_material(obj.material, scene.materials[obj.material]))
    lights = frame_lights(scene.lights)
    if scene.environment is not None and scene.environment.source != "uniform":
        lights = lights + map_lights(scene.environment)
    return size, prims, materials, lights


def reference_scene(loaded: LoadedScene, size: tuple[int, int] | None = None) -> RaycastImage:
    """The ray-cast reference image of ``loaded`` at ``size`` (width, height; default the
    scene's render size), supersampled as ``render.supersample`` says, with the same camera
    frame the renderer gives its lighting pass (app/render/renderer.py)."""
    scene = loaded.scene
    size, prims, materials, lights = _scene_inputs(loaded, size)
    factor = scene.render.supersample
    drawn = scene.render.drawn_size(size)
    camera = camera_frame(scene.camera, *drawn)
    # A uniform environment: the renderer's own quadrature, through the twin (docs/ibl.md)
    uniform = uniform_environment(scene.environment)
    background = np.asarray(scene.background, np.float64)
    env = scene.environment
    if env is not None and env.background:  # as app/render/background.py draws it
        rays = camera_rays(camera, *drawn)
        uv = equirect_uv(rays, math.radians(env.rotation))
        background = env.intensity * sample_bilinear(environment_texels(env), uv)
    return render_reference(
        prims, materials, camera, size, lights, background, scene.render.terms, factor, uniform
    )


def area_reference_scene(
    loaded: LoadedScene,
    size: tuple[int, int] | None = None,
    samples: int = 8,
    edge_samples: int = 32,
) -> RaycastImage:
    """The pixel-area-integrated truth of ``loaded`` at ``size`` (default the scene's
    render size): ``area_reference``'s ``samples`` x ``samples`` rays per pixel
    (``edge_samples`` x ``edge_samples`` where a silhouette crosses it), box-averaged in
    linear radiance with the background, an environment drawn behind the scene included,
    whatever ``render.supersample`` says: what the renderer's pixels converge to
    (docs/accuracy.md, "Every pixel")."""
    scene = loaded.scene
    size, prims, materials, lights = _scene_inputs(loaded, size)
    camera = camera_frame(scene.camera, size[0], size[1])
    env = scene.environment
    background: np.ndarray | Background = np.asarray(scene.background, np.float64)
    if env is not None and env.background:  # as app/render/background.py draws it
        texels, rotation, intensity = (
            environment_texels(env),
            math.radians(env.rotation),
            env.intensity,
        )

        def drawn(ndc: np.ndarray) -> np.ndarray:
            return intensity * sample_bilinear(texels, equirect_uv(ndc_rays(camera, ndc), rotation))

        background = drawn

    return area_reference(
        prims, materials, camera, size, lights, background, scene.render.terms, samples,
        edge_samples, uniform_environment(env),
    )  # fmt: skip
