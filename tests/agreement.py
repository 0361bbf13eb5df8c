"""How GLSL results are compared with their float64 twins."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from app.scene.loader import LoadedScene
from app.scene.model import Light

if TYPE_CHECKING:
    from app.common.models import Model, ModelParams
    from app.reference.illumination import DecodedGBuffer
    from app.render.gbuffer import GBufferData
    from app.render.renderer import Renderer


def relative_error(gpu: np.ndarray, ref: np.ndarray, floor: float) -> np.ndarray:
    """|gpu - ref| / max(|ref|, floor): relative where the reference is not tiny.

    ``floor`` is the magnitude below which a value counts as zero, so values that are
    exactly 0 in float64 are compared absolutely instead of dividing by 0.
    """
    gpu = np.asarray(gpu, np.float64)
    ref = np.asarray(ref, np.float64)
    return np.abs(gpu - ref) / np.maximum(np.abs(ref), floor)


def without_shadows(loaded: LoadedScene) -> LoadedScene:
    """``loaded`` with ``shadow = false`` (and the shadow keys' defaults) on every light:
    the twins shade without a light's visibility, so tests that compare the lighting with
    them compare the unshadowed scene; tests/test_shadows.py measures shadows against the
    ray-caster's shadow rays (docs/shadows.md)."""
    keys = {key for key in Light.model_fields if key.startswith("shadow")}
    lights = [
        type(light).model_validate(light.model_dump(exclude=keys)) for light in loaded.scene.lights
    ]
    return LoadedScene(loaded.scene.model_copy(update={"lights": lights}), loaded.path)


def hdr_and_twin(r: Renderer, background: np.ndarray) -> tuple[np.ndarray, np.ndarray, GBufferData]:
    """Render ``r``'s frame and shade its G-buffer with the float64 twins: (the GLSL HDR
    image as float64, the twin's image of the same G-buffer, the G-buffer read back)."""
    from app.reference.illumination import shade_gbuffer

    r.render()
    hdr = r.read_hdr().astype(np.float64)
    g = r.read_gbuffer()
    ref = shade_gbuffer(g, r.camera, r.lights, background, r.materials.models, r.materials.packed())
    return hdr, ref, g


def one_material_frame(r: Renderer) -> tuple[np.ndarray, DecodedGBuffer, Model, ModelParams]:
    """Render ``r``'s frame of a scene with one material and release ``r``: (the GLSL HDR
    image as float64, its decoded G-buffer, the material's model, its unpacked
    parameters), for comparing a sphere's pixels with a twin."""
    from app.common.models import unpack_model_params
    from app.reference.illumination import decode_gbuffer

    try:
        r.render()
        hdr = r.read_hdr().astype(np.float64)
        dec = decode_gbuffer(r.read_gbuffer(), r.camera)
        model = r.materials.models[0]
        params = unpack_model_params(r.materials.packed()[0])
    finally:
        r.release()
    return hdr, dec, model, params
