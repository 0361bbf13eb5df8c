"""Which maps a layer samples and with which UVs: the map bits of its LAYER<i>_MAPS define
(``MAP_BITS``, declared with the extension maps in app/common/extension_maps.py),
KHR_texture_transform's matrices in this project's UV space, and the UV defines of a part
(glsl/material/layers.glsl reads them). Pure numbers: no GL here.
"""

from __future__ import annotations

import numpy as np

from app.common.extension_maps import MAP_BITS, MAP_INDEX
from app.scene.geometry import MeshPart
from app.textures.maps import SurfaceLayer, UvTransform


def layer_maps_define(layer: SurfaceLayer) -> int:
    """The LAYER<i>_MAPS bitmask of a layer's maps."""
    return sum(MAP_BITS[name] for name in layer.maps)


def uv_matrix(t: UvTransform) -> np.ndarray:
    """KHR_texture_transform's uv' = T(offset) R(rotation) S(scale) uv as a 3x3 matrix in
    this project's UV space. The extension defines it in glTF's, whose v runs down the
    image (origin top left); ours runs up (textures are uploaded bottom row first), so the
    matrix is conjugated by the flip F: v -> 1 - v (F = F^-1): M = F T R S F. The rotation
    is R = [[cos, sin], [-sin, cos]] by rows in glTF's UV space: the one the extension's
    worked example needs (offset [0, 1], rotation pi/2, scale 0.5 reads "only the lower
    left quadrant of the source image, rotated clockwise 90 degrees"; glTF
    KHR_texture_transform, Khronos 2018) and Blender, Babylon.js and the sample model
    TextureTransformTest use. The README's GLSL listing, mat3(cos, sin, 0, -sin, cos, 0,
    0, 0, 1), read column-major is its transpose, which no viewer follows; this
    function used it before, and rotated every texture the wrong way."""
    c, s = np.cos(t.rotation), np.sin(t.rotation)
    translate = np.array([[1.0, 0.0, t.offset[0]], [0.0, 1.0, t.offset[1]], [0.0, 0.0, 1.0]])
    rotate = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    scale = np.diag([t.scale[0], t.scale[1], 1.0])
    flip = np.array([[1.0, 0.0, 0.0], [0.0, -1.0, 1.0], [0.0, 0.0, 1.0]])
    return flip @ translate @ rotate @ scale @ flip


def uv_defines(part: MeshPart) -> dict[str, int]:
    """UV_TRANSFORM_MAPS0 (layer 0's maps with a UV set or transform of their own) and
    UV_SET1_MAPS0 (those reading TEXCOORD_1), VERTEX_UV1 where one does and the part has
    TEXCOORD_1, VERTEX_COLOR where it has COLOR_0; nothing for a part without either
    whose maps all read TEXCOORD_0 untransformed."""
    layer = part.layers[0]
    moved = {k: t for k, t in layer.uv_transforms.items() if k in layer.maps and not t.identity}
    set1 = {k for k, t in moved.items() if t.uv_set == 1 and part.uv1 is not None}
    defines: dict[str, int] = {}
    if moved:
        defines["UV_TRANSFORM_MAPS0"] = sum(MAP_BITS[k] for k in moved)
    if set1:
        defines["UV_SET1_MAPS0"] = sum(MAP_BITS[k] for k in set1)
        defines["VERTEX_UV1"] = 1
    if part.colors is not None and part.analytic is None:
        defines["VERTEX_COLOR"] = 1
    return defines


def uv_transform_bytes(layer: SurfaceLayer) -> bytes:
    """u_uv_transform0[len(MAP_INDEX)]: each map index's matrix (identity where the map has
    none), as the GL's column-major float32 mat3s."""
    out = np.tile(np.eye(3), (len(MAP_INDEX), 1, 1))
    for key, t in layer.uv_transforms.items():
        if key in MAP_INDEX:
            out[MAP_INDEX[key]] = uv_matrix(t)
    return np.ascontiguousarray(out.transpose(0, 2, 1), np.float32).tobytes()
