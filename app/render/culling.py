"""Tiled light culling on the OpenGL 3.3 path: lights reach only the pixels in their range.

Three small fragment passes per frame, after the G-buffer pass and before lighting:

1. ``tile_depth.frag``: the min and max view depth of each 8x8 tile's surfaces, and
   a 32-bit depth mask of the slices of that slab that hold a surface (Harada et al.
   2012's 2.5D culling), into two targets of one framebuffer;
2. ``group_cull.frag``: for each group of 4x4 tiles, the local lights whose range sphere
   reaches the view-space box and the side planes of the group's frustum over its
   surfaces' depth slab: a superset of its tiles' lists, so that
3. ``light_cull.frag`` tests only those for each tile: a light is in the tile's mask when
   its range sphere covers an occupied slice and reaches the view-space box of the
   tile's frustum over those slices and its four side planes, and, for a spot light,
   its cone reaches that box's bounding sphere (glsl/lights/tiles.glsl, twin
   app/reference/tiles.py). One RGBA32UI texel holds 128 lights (four 32-bit words), a
   tile (or group) has ``quads`` texels side by side.

The box test is what makes the lists short: the side planes alone, tested one by one,
accept any centre within r of each plane, so around a tile frustum much thinner than the
lights' ranges they pass every centre in the r x r squares beyond its corners, where the
box (an exact distance) passes only those within r. docs/performance.md measures how much
shorter the lists are on the bench's scene.

The lighting pass then loops the directional lights (which reach everything) and the set
bits of its tile's masks, in ascending light order: the same lights in the same order
as the unculled loop minus lights that would add exactly 0, so culled and unculled
images agree to the last bit. The CPU's per-frame work is one vectorised transform of
the light centres into view space, made only when the view has moved.
"""

from __future__ import annotations

import math

import moderngl
import numpy as np

from app.common.camera import CameraFrame
from app.common.lights import POINT_COS_OUTER, LightType, PunctualLight
from app.errors import InputError
from app.gl.context import release_objects, wait_before_read
from app.gl.fullscreen import FullscreenDraw
from app.gl.shaders import ShaderCache
from app.render.gbuffer import GBuffer
from app.render.inputs import TILES, ShaderInput
from app.render.limits import max_dimension

# 8 x 8 tiles: shorter lists than 16 x 16 ones, and with the group pass the finer cull
# costs less than that saves (measured in docs/performance.md).
TILE_SIZE = 8
GROUP_TILES = 4  # the coarse pass culls for groups of 4 x 4 tiles (32 x 32 pixels)
LIGHTS_PER_ROW = 1024  # texels per row of the local-light texture
RANGE_MARGIN = 1.001  # ranges grow by 0.1% so float32 rounding can never cull a light
#                      whose window is still (barely) above zero at a tile's edge
# render.light_culling = "auto" (the default) culls only from this many local lights on.
# Below it the three passes cost more than the lights they save (measured with 1-16
# lights in docs/performance.md, "Tiled culling"; tiles paid at 16 lights in
# the bench's full run).
TILED_MIN_LOCAL_LIGHTS = 9
CONE_MARGIN = 1e-3  # radians: spot cones widen so float32 rounding never culls a lit pixel
NO_CONE = POINT_COS_OUTER  # the cone cosine of a point light: below -1, no cone test


def tiles_used(setting: str, lights: list[PunctualLight]) -> bool:
    """Whether a frame with ``lights`` culls them by tiles under ``render.light_culling``
    ``setting``: "tiled" whenever there is a local light, "none" never, "auto" from
    ``TILED_MIN_LOCAL_LIGHTS`` local lights on. The image is the same either way (the
    module docstring says why); only the time differs."""
    local = sum(light.is_local for light in lights)
    if setting == "auto":
        return local >= TILED_MIN_LOCAL_LIGHTS
    return setting == "tiled" and local > 0


def check_tile_masks(
    ctx: moderngl.Context, size: tuple[int, int], lights: list[PunctualLight], file: str
) -> None:
    """``InputError`` where the tile masks of ``lights``' local lights at ``size`` need a
    texture wider than this GL's largest (one RGBA32UI texel per 128 lights per tile)."""
    local = sum(x.is_local for x in lights)
    width = -(-size[0] // TILE_SIZE) * max(1, -(-local // 128))
    if width > (limit := max_dimension(ctx)):
        raise InputError(
            file,
            "lights",
            f"{local} local lights culled in {size[0]}-pixel-wide tiles need mask rows "
            f"{width} texels wide, past this GL's largest texture ({limit})",
        )


class LightCuller(ShaderInput):
    """Owns the tile targets and the local-light texture of one image size; to the
    lighting pass (and the debug view ``tiles``) a shader input (app/render/inputs.py):
    the tile masks ``u_tile_masks``, their layout's defines and ``u_first_local``."""

    role = TILES

    def __init__(
        self,
        ctx: moderngl.Context,
        shaders: ShaderCache,
        size: tuple[int, int],
        lights: list[PunctualLight],
    ) -> None:
        """``lights`` in the frame's order: directional ones first (order_lights)."""
        self.ctx = ctx
        self.size = size
        local = [x for x in lights if x.is_local]
        self.first_local = len(lights) - len(local)
        self.local_count = len(local)
        self.centres = np.array([x.position for x in local], np.float64).reshape(-1, 3)
        self.ranges = np.array([x.range for x in local], np.float64) * RANGE_MARGIN
        # Spot lights' axes (the way the light travels) and widened outer-cone cosines.
        spot = [x.type == LightType.SPOT for x in local]
        self.axes = np.array(
            [
                x.direction if is_spot else (0.0, 0.0, 0.0)
                for x, is_spot in zip(local, spot, strict=True)
            ],
            np.float64,
        ).reshape(-1, 3)
        self.cone_cos = np.array(
            [
                math.cos(min(math.acos(x.cos_outer) + CONE_MARGIN, math.pi)) if is_spot else NO_CONE
                for x, is_spot in zip(local, spot, strict=True)
            ],
            np.float64,
        )
        self.tiles = (-(-size[0] // TILE_SIZE), -(-size[1] // TILE_SIZE))
        self.quads = max(1, -(-self.local_count // 128))  # mask texels per tile
        self.groups = (-(-self.tiles[0] // GROUP_TILES), -(-self.tiles[1] // GROUP_TILES))
        defines = {"TILE_SIZE": TILE_SIZE, "GROUP_TILES": GROUP_TILES}
        self.depth_pass = FullscreenDraw.of(ctx, shaders, "passes/tile_depth.frag", defines)
        self.group_pass = FullscreenDraw.of(ctx, shaders, "passes/group_cull.frag", defines)
        self.cull_pass = FullscreenDraw.of(ctx, shaders, "passes/light_cull.frag", defines)
        self.tile_depth = ctx.texture(self.tiles, 2, dtype="f4")
        self.tile_bins = ctx.texture(self.tiles, 1, dtype="u4")
        self.masks = ctx.texture((self.tiles[0] * self.quads, self.tiles[1]), 4, dtype="u4")
        self.group_masks = ctx.texture((self.groups[0] * self.quads, self.groups[1]), 4, dtype="u4")
        rows = max(1, -(-self.local_count // LIGHTS_PER_ROW))
        width = LIGHTS_PER_ROW if self.local_count > LIGHTS_PER_ROW else max(1, self.local_count)
        self.lights = ctx.texture((width, rows), 4, dtype="f4")
        self.spots = ctx.texture((width, rows), 4, dtype="f4")
        # Which lights are spots, as mask bits (one texel per quad): the cone stage's
        # candidates are a tile's mask & these, without a read of each light's cone.
        spot_bits = np.zeros(self.quads * 128, np.uint64)
        spot_bits[: self.local_count] = np.array(spot, bool)
        words = (spot_bits.reshape(-1, 32) << np.arange(32, dtype=np.uint64)).sum(axis=1)
        words = words.astype(np.uint32).tobytes()
        self.spot_bits = ctx.texture((self.quads, 1), 4, words, dtype="u4")
        self._view: bytes | None = None  # the view matrix the light textures were made for
        textures = (
            self.tile_depth, self.tile_bins, self.group_masks, self.masks, self.lights,
            self.spots, self.spot_bits,
        )  # fmt: skip
        for tex in textures:
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.depth_fbo = ctx.framebuffer([self.tile_depth, self.tile_bins])
        self.group_fbo = ctx.framebuffer([self.group_masks])
        self.mask_fbo = ctx.framebuffer([self.masks])

    def _upload(self, view: np.ndarray) -> None:
        """Light centres in view space with their (padded) ranges, one texel per light,
        and spot axes; kept while the view stays (a culler's lights never change: new
        lights build a new culler)."""
        key = np.asarray(view, np.float64).tobytes()
        if key == self._view:
            return
        self._view = key
        texels = np.zeros((self.lights.width * self.lights.height, 4), np.float32)
        centres = self.centres @ view[:3, :3].T + view[:3, 3]
        texels[: self.local_count, :3] = centres
        texels[: self.local_count, 3] = self.ranges
        self.lights.write(texels.tobytes())
        spots = np.zeros_like(texels)
        spots[: self.local_count, :3] = self.axes @ view[:3, :3].T
        spots[: self.local_count, 3] = self.cone_cos
        self.spots.write(spots.tobytes())

    def run(self, gbuffer: GBuffer, view: np.ndarray, camera: CameraFrame) -> None:
        """Build this frame's tile masks from the G-buffer's depth (both culling passes)."""
        self.ctx.disable(moderngl.CULL_FACE)  # the draws turn depth test and blending off
        self._upload(view)
        self.depth_pass.draw(
            self.depth_fbo, textures={"g_depth": gbuffer.depth}, viewport=(0, 0, *self.tiles)
        )
        common = {
            "u_quads": self.quads,
            "u_image_size": self.size,
            "u_tan_half_fov": camera.tan_half_fov,
        }
        self.group_pass.draw(
            self.group_fbo,
            {**common, "u_local_count": self.local_count, "u_tiles": self.tiles},
            {"u_tile_depth": self.tile_depth, "u_local_lights": self.lights},
            viewport=(0, 0, self.groups[0] * self.quads, self.groups[1]),
        )
        textures = {
            "u_tile_depth": self.tile_depth,
            "u_tile_bins": self.tile_bins,
            "u_local_lights": self.lights,
            "u_local_spots": self.spots,
            "u_group_masks": self.group_masks,
            "u_spot_bits": self.spot_bits,
        }
        self.cull_pass.draw(
            self.mask_fbo,
            common,
            textures,
            viewport=(0, 0, self.tiles[0] * self.quads, self.tiles[1]),
        )

    def defines(self) -> dict[str, int]:
        return {
            "TILED_LIGHTS": 1,
            "TILE_SIZE": TILE_SIZE,  # the culler's tiles
            "TILE_QUADS": self.quads,  # mask texels per tile
            "DIRECTIONAL_LIGHTS": int(self.first_local > 0),
        }

    def samplers(self) -> list[tuple[str, moderngl.Texture]]:
        return [("u_tile_masks", self.masks)]

    def uniforms(self, program: moderngl.Program) -> None:
        if "u_first_local" in program:  # lights [0, u_first_local) are directional
            program["u_first_local"].value = self.first_local

    def read_tiles(self) -> tuple[np.ndarray, np.ndarray]:
        """The tile-depth pass's output: (tiles_y, tiles_x, 2) float32 depth bounds and
        (tiles_y, tiles_x) uint32 depth masks, tile rows bottom-up."""
        tx, ty = self.tiles
        wait_before_read(self.tile_depth.ctx)
        bounds = np.frombuffer(self.tile_depth.read(), np.float32).reshape(ty, tx, 2)
        bins = np.frombuffer(self.tile_bins.read(), np.uint32).reshape(ty, tx)
        return bounds.copy(), bins.copy()

    def read_masks(self) -> np.ndarray:
        """(tiles_y, tiles_x, local_count) bool: which local lights reach each tile."""
        return self._unpack(self.masks, self.tiles)

    def read_group_masks(self) -> np.ndarray:
        """(groups_y, groups_x, local_count) bool: the coarse pass's candidates for each
        group of GROUP_TILES x GROUP_TILES tiles."""
        return self._unpack(self.group_masks, self.groups)

    def _unpack(self, texture: moderngl.Texture, cells: tuple[int, int]) -> np.ndarray:
        nx, ny = cells
        wait_before_read(texture.ctx)
        words = np.frombuffer(texture.read(), np.uint32).reshape(ny, nx, self.quads * 4)
        bits = (words[..., :, None] >> np.arange(32, dtype=np.uint32)) & 1
        return bits.reshape(ny, nx, self.quads * 128)[..., : self.local_count].astype(bool)

    def release(self) -> None:
        release_objects(
            self.depth_pass,
            self.group_pass,
            self.cull_pass,
            self.depth_fbo,
            self.group_fbo,
            self.mask_fbo,
            self.tile_depth,
            self.tile_bins,
            self.group_masks,
            self.masks,
            self.lights,
            self.spots,
            self.spot_bits,
        )
