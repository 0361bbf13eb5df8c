"""Offline baking of a mask blend into one textured material (RTR4 §9.13: "mostly
offline, some at run time").

The bake evaluates the same parameter blend as the G-buffer pass (app/reference/blend.py,
twin of glsl/material/blend.glsl) once per texel of the mask, and stores the result as the
maps of a single layer: base colour (linear), metallic, F0, anisotropy, normals with
roughness (then filtered like any normal map), and a ``select`` map, the blend weight,
from which the G-buffer pass picks the material-table row (the models' numbers) of the
layer that dominates. tests/test_blend.py renders both and compares them.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from app.reference.blend import Layer, blend_layers, blend_weight
from app.reference.tonemap import srgb_decode
from app.textures.maps import (
    SurfaceLayer,
    Texture,
    normal_roughness_texture,
    sample_bilinear_wrap,
    scalar_texture,
)
from app.textures.mips import box_mips


def _sample(texture: Texture, x: np.ndarray, y: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Level 0 of ``texture`` at bake texel coordinates (x, y) in [0, 1), scaled by the
    layer's UV scale relative to the mask's, bilinear with wrap-around."""
    level = np.asarray(texture.levels[0], np.float64)
    if texture.srgb:
        level = srgb_decode(level[..., :3] / 255.0)
    h, w = level.shape[:2]
    return sample_bilinear_wrap(level, x * scale[0] * w - 0.5, y * scale[1] * h - 0.5)


def _layer_at(layer: SurfaceLayer, x: np.ndarray, y: np.ndarray, scale: np.ndarray) -> Layer:
    """The layer's parameters at every bake texel (constants times maps)."""
    p = layer.params
    shape = x.shape
    base = np.broadcast_to(np.asarray(p.base_color, np.float64), (*shape, 3)).copy()
    metallic = np.full(shape, p.metallic)
    roughness = np.full(shape, p.roughness)
    anisotropy = np.full(shape, p.anisotropy)
    normal = np.zeros((*shape, 3))
    normal[..., 2] = 1.0
    maps = layer.maps
    if "base_color" in maps:
        base *= _sample(maps["base_color"], x, y, scale)[..., :3]
    if "metallic" in maps:
        metallic *= _sample(maps["metallic"], x, y, scale)[..., 0]
    if "anisotropy" in maps:
        anisotropy *= _sample(maps["anisotropy"], x, y, scale)[..., 0]
    if "normal_roughness" in maps:
        nr = _sample(maps["normal_roughness"], x, y, scale)
        normal = nr[..., :3] / np.linalg.norm(nr[..., :3], axis=-1, keepdims=True)
        roughness = nr[..., 3]
    return Layer(base, metallic, roughness, np.full(shape, p.f0), anisotropy, normal)


def bake_blend(
    base: SurfaceLayer,
    top: SurfaceLayer,
    mask: np.ndarray,
    threshold: float,
    softness: float,
    normal_filter: str,
) -> SurfaceLayer:
    """``top`` painted over ``base`` by ``mask`` (float (H, W) in [0, 1], sampled with the
    base layer's UV scale), baked into one layer at the mask's resolution. (Baking at the
    finest resolution of any input, 2048^2 for scenes/sec13_rust_blend.toml, took 11 s and
    changed the runtime-vs-baked difference by under 1%: the difference lies on the mask's
    edges, where filtering before or after the smoothstep differs.)"""
    one = np.ones(2)
    relative = np.asarray(top.uv_scale) / np.asarray(base.uv_scale)
    h, w = mask.shape
    y, x = np.meshgrid((np.arange(h) + 0.5) / h, (np.arange(w) + 0.5) / w, indexing="ij")
    weight = blend_weight(mask, threshold, softness)
    mixed = blend_layers(_layer_at(base, x, y, one), _layer_at(top, x, y, relative), weight)
    anisotropic = bool(base.params.anisotropy or top.params.anisotropy)
    params = replace(
        base.params,
        base_color=(1.0, 1.0, 1.0),
        metallic=1.0,
        f0=1.0,
        anisotropy=1.0 if anisotropic else 0.0,
        roughness=1.0,
    )
    maps = {
        "base_color": Texture(box_mips(mixed.base_color)),
        "metallic": scalar_texture(mixed.metallic),
        "f0": scalar_texture(mixed.f0),
        "normal_roughness": normal_roughness_texture(
            mixed.normal, mixed.perceptual_roughness, (h, w), normal_filter
        ),
        "select": scalar_texture(weight),
    }
    if anisotropic:
        maps["anisotropy"] = scalar_texture(mixed.anisotropy)
    # The direction of anisotropy is the base's (one tangent per pixel; a runtime blend
    # also turns it by layer 0's alone): its map is read with the same UV scale.
    if "anisotropy_direction" in base.maps:
        maps["anisotropy_direction"] = base.maps["anisotropy_direction"]
    return SurfaceLayer(
        params, maps, base.uv_scale, base.normal_mapped or top.normal_mapped,
        anisotropy_rotation=base.anisotropy_rotation,
    )  # fmt: skip
