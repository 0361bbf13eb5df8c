"""Scene materials -> ``SurfaceLayer``s: constants plus the texture chains the G-buffer
pass samples, cached so that a file two materials share is read and filtered once. Every
texture is read confined to the scene's allowed folders and charged to the scene's
``Budget`` before it is decoded (app/untrusted)."""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from PIL import Image

from app.errors import InputError
from app.scene.loader import LoadedScene
from app.scene.model import Material
from app.textures.lean import AUTO, LEAN, auto_filter, lean_params
from app.textures.maps import (
    SurfaceLayer,
    Texture,
    coat_normal_texture,
    colour_texture,
    decode_normals,
    direction_texture,
    lean_normal_maps,
    linear_channel,
    normal_roughness_chain,
    read_image,
    scalar_texture,
)
from app.untrusted import RefusedError
from app.untrusted.budget import Budget

# The map each texture key becomes, which decides what it costs (app/untrusted/budget.py).
TEXTURE_KINDS = {
    "base_color_map": "colour",
    "emissive_map": "colour",
    "normal_map": "normal",
    "clearcoat_normal_map": "normal",
    "roughness_map": "normal",  # it travels in the normal/roughness chain
    "anisotropy_direction_map": "direction",
}


class LayerBuilder:
    """Builds the layers of one scene, reading each texture file once."""

    def __init__(self, loaded: LoadedScene, budget: Budget | None = None) -> None:
        self.loaded = loaded
        self.normal_filter = loaded.scene.render.normal_filter
        self.budget = budget or Budget(loaded.policy.limits)
        self._images = lru_cache(maxsize=None)(self._read)

    def _read(self, relative: str, key: str, kind: str) -> Image.Image:
        path = self.loaded.resolve_file(relative, key)
        return read_image(path, str(self.loaded.path), key, self.budget, kind)

    def image(self, material: str, key: str) -> Image.Image:
        m = self.loaded.scene.materials[material]
        relative = getattr(m, key)
        kind = TEXTURE_KINDS.get(key, "scalar")
        if key == "roughness_map" and m.normal_map is not None:
            kind = "scalar"  # resampled into the normal map's chain, charged with it
        return self._images(relative, f"materials.{material}.{key}", kind)

    def _charge(self, material: str, key: str, shape: tuple[int, int], kind: str) -> None:
        """Charge a map of ``kind`` built from ``materials.<material>.<key>``'s texels to the
        scene's budget: an ``InputError`` naming that key where it does not fit."""
        try:
            self.budget.texture(shape[1], shape[0], kind, "its slope covariance map")
        except RefusedError as exc:
            key = f"materials.{material}.{key}"
            raise InputError(str(self.loaded.path), key, str(exc)) from None

    def mask(self, material: str) -> np.ndarray:
        """The blend mask of ``material`` as float64 (H, W) in [0, 1]."""
        blend = self.loaded.scene.materials[material].blend
        assert blend is not None
        key = f"materials.{material}.blend.mask"
        return linear_channel(self._images(blend.mask, key, "scalar"))

    def layer(self, name: str) -> SurfaceLayer:
        """The material ``name`` of the scene with its maps."""
        m: Material = self.loaded.scene.materials[name]
        params = m.resolve()
        maps: dict[str, Texture] = {}
        if m.base_color_map is not None:
            maps["base_color"] = colour_texture(self.image(name, "base_color_map"))
        if m.metallic_map is not None:
            maps["metallic"] = scalar_texture(linear_channel(self.image(name, "metallic_map")))
        if m.anisotropy_map is not None:
            maps["anisotropy"] = scalar_texture(linear_channel(self.image(name, "anisotropy_map")))
        if m.anisotropy_direction_map is not None:  # glTF anisotropyTexture's RG
            image = self.image(name, "anisotropy_direction_map")
            maps["anisotropy_direction"] = direction_texture(image)
        normals = None
        if m.normal_map is not None:
            normals = decode_normals(self.image(name, "normal_map"), m.normal_scale)
        if normals is not None or m.roughness_map is not None:
            r = None
            if m.roughness_map is not None:
                r = linear_channel(self.image(name, "roughness_map"))
            chosen = self.normal_filter
            if normals is not None and chosen == AUTO:  # lean where the spread is directional
                chosen = auto_filter(normals)
            if normals is not None and chosen == LEAN:
                # the normals' spread as a covariance: anisotropic roughness per pixel; its
                # map charged as one more normal map
                self._charge(name, "normal_map", normals.shape[:2], "normal")
                maps.update(lean_normal_maps(normals, params.roughness, r))
                params = lean_params(params)
            else:
                maps["normal_roughness"] = normal_roughness_chain(
                    normals, params.roughness, r, self.normal_filter
                )
        if m.clearcoat_normal_map is not None:  # RTR4 §9.12: the coat's own normals
            scale = 1.0 if m.clearcoat_normal_scale is None else m.clearcoat_normal_scale
            image = self.image(name, "clearcoat_normal_map")
            maps["coat_normal"] = coat_normal_texture(image, scale)
        if m.emissive_map is not None:  # glTF emissiveTexture: sRGB, multiplies emissive
            maps["emissive"] = colour_texture(self.image(name, "emissive_map"))
        if m.occlusion_map is not None:  # glTF occlusionTexture: linear R
            maps["occlusion"] = scalar_texture(linear_channel(self.image(name, "occlusion_map")))
        uv_scale = (m.uv_scale[0], m.uv_scale[1])
        return SurfaceLayer(
            params, maps, uv_scale, normal_mapped=m.normal_map is not None,
            emissive=m.emission,
            occlusion_strength=1.0 if m.occlusion_strength is None else m.occlusion_strength,
            alpha=m.alpha, alpha_mode=m.alpha_mode,
            alpha_cutoff=0.5 if m.alpha_cutoff is None else m.alpha_cutoff,
            anisotropy_rotation=math.radians(m.anisotropy_rotation),
        )  # fmt: skip
