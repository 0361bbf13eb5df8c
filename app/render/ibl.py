"""Image-based lighting on the GPU (docs/ibl.md): the environment's prefiltered cube
maps, its SH9 irradiance and the split-sum DFG table, handed to the lighting pass, which
adds ``ibl_radiance`` (glsl/lights/ibl.glsl) per pixel where ENVIRONMENT_IBL.

The prefilter (glsl/passes/env_prefilter.frag: GGX importance sampling with filtered
importance sampling, Krivanek & Colbert 2008) runs once per (map, face size, samples)
in a process: the faces are read back and kept as float32 arrays, so a second renderer
of the same environment only uploads them. moderngl writes only level 0 of a cube map,
so each roughness level is its own cube texture (ENV_LEVELS of them)."""

from __future__ import annotations

import hashlib
import math
from collections.abc import Iterator
from contextlib import contextmanager

import moderngl
import numpy as np

from app.common.tables import read_dfg_table
from app.gl.context import release_objects
from app.gl.fullscreen import FullscreenDraw
from app.gl.shaders import ShaderCache
from app.render.background import EnvironmentSource, equirect_texture
from app.render.inputs import ENVIRONMENT, ShaderInput
from app.textures.cache import prepared_cache
from app.textures.versions import version

ENV_LEVELS = 6  # roughness r_k = k / 5; glsl/lights/ibl.glsl samples exactly these
FACE_SIZE = 128  # level 0's face; level k has max(FACE_SIZE >> k, MIN_FACE) texels
MIN_FACE = 16
SAMPLES = 256  # GGX samples per texel of the rough levels
GL_TEXTURE_CUBE_MAP_SEAMLESS = 0x884F  # filter across face edges (core since GL 3.2)
_CACHE: dict[tuple, list[np.ndarray]] = {}
_CACHE_LIMIT = 8
# (face size, samples) the next EnvironmentLighting prefilters with: the renderer's
# FACE_SIZE and SAMPLES unless a caller measuring the choice sets others (prefilter_settings).
_SETTINGS = [FACE_SIZE, SAMPLES]


@contextmanager
def prefilter_settings(base: int, samples: int) -> Iterator[None]:
    """Renderers made inside prefilter their environment with level 0's face size ``base``
    and ``samples`` GGX samples per texel (the IBL bench's sweep); restored on exit."""
    old = list(_SETTINGS)
    _SETTINGS[:] = [base, samples]
    try:
        yield
    finally:
        _SETTINGS[:] = old


# Where the prefiltered map is read: along the dominant direction (the renderer's), or
# along the mirror direction R alone where a caller measuring the correction asks
# (``reflection_direction``; scripts/ibl_errors.py --spheres).
_DIRECTION = ["dominant"]
DIRECTION_DEFINES = {
    "dominant": {},
    "mirror": {"IBL_MIRROR_DIRECTION": 1},
    "view-dependent": {"IBL_VIEW_DEPENDENT_DIRECTION": 1},
}


@contextmanager
def reflection_direction(name: str) -> Iterator[None]:
    """Renderers made inside read the prefiltered map along ``name``: "dominant" (the
    default, Lagarde & de Rousiers 2014), "mirror" (R itself) or "view-dependent" (the
    lobe-centroid fit, ``specular_centroid_direction``); restored on exit."""
    if name not in DIRECTION_DEFINES:
        raise ValueError(f"reflection direction {name!r}: one of {sorted(DIRECTION_DEFINES)}")
    old = list(_DIRECTION)
    _DIRECTION[:] = [name]
    try:
        yield
    finally:
        _DIRECTION[:] = old


def clear_cache() -> None:
    """Forget every prefiltered map (the bench times the prefilter itself)."""
    _CACHE.clear()


def levels_bytes(base: int) -> int:
    """GPU memory of the ENV_LEVELS RGBA32F cube maps for level 0's face size ``base``."""
    return sum(6 * face_size(k, base) ** 2 * 16 for k in range(ENV_LEVELS))


def level_roughness(k: int) -> float:
    """The perceptual roughness level k is prefiltered for."""
    return k / (ENV_LEVELS - 1)


def face_size(k: int, base: int = FACE_SIZE) -> int:
    return max(base >> k, MIN_FACE)


def prefilter(
    ctx: moderngl.Context,
    shaders: ShaderCache,
    env_map: np.ndarray,
    base: int = FACE_SIZE,
    samples: int = SAMPLES,
) -> list[np.ndarray]:
    """The prefiltered levels of ``env_map`` (in the map's own frame): ENV_LEVELS float32
    arrays (6, size, size, 3), face rows in texture t order; cached per map and settings."""
    digest = hashlib.sha1(np.ascontiguousarray(env_map, np.float32).tobytes()).hexdigest()
    key = (digest, env_map.shape, base, samples)
    if key in _CACHE:
        return _CACHE[key]
    source = equirect_texture(ctx, env_map, mipmaps=True)
    fullscreen = FullscreenDraw.of(ctx, shaders, "passes/env_prefilter.frag")
    try:
        levels = [
            _prefilter_faces(ctx, fullscreen, source, level_roughness(k), size, samples)
            for k, size in ((k, face_size(k, base)) for k in range(ENV_LEVELS))
        ]
    finally:
        fullscreen.release()
        source.release()
    if len(_CACHE) >= _CACHE_LIMIT:
        _CACHE.pop(next(iter(_CACHE)))
    _CACHE[key] = levels
    return levels


def _prefilter_faces(
    ctx: moderngl.Context,
    fullscreen: FullscreenDraw,
    source: moderngl.Texture,
    roughness: float,
    size: int,
    samples: int,
) -> np.ndarray:
    """The six faces (6, size, size, 3) of the map prefiltered for ``roughness`` by the
    prefilter's ``samples`` GGX samples per texel, from the equirect ``source``."""
    target = ctx.texture((size, size), 4, dtype="f4")
    fbo = ctx.framebuffer([target])
    faces = []
    try:
        for face in range(6):
            uniforms = {
                "u_samples": samples,
                "u_face_size": size,
                "u_roughness": roughness,
                "u_face": face,
            }
            fullscreen.draw(fbo, uniforms, {"u_source": source})
            data = np.frombuffer(fbo.read(components=4, dtype="f4"), np.float32)
            faces.append(data.reshape(size, size, 4)[..., :3].copy())
    finally:
        release_objects(fbo, target)
    return np.stack(faces)


def prefilter_estimates(
    ctx: moderngl.Context,
    shaders: ShaderCache,
    env_map: np.ndarray,
    roughnesses: list[float],
    size: int,
    sample_counts: list[int],
) -> np.ndarray:
    """The renderer's own Monte Carlo prefilter of ``env_map`` at each roughness and
    sample count, uncached: (len(roughnesses), len(sample_counts), 6, size, size, 3), the
    faces of ``size`` texels (the walkthrough's figure of the estimator against the exact
    texel sum, app/brdf/figures.py)."""
    source = equirect_texture(ctx, env_map, mipmaps=True)
    fullscreen = FullscreenDraw.of(ctx, shaders, "passes/env_prefilter.frag")
    try:
        return np.stack([
            np.stack([_prefilter_faces(ctx, fullscreen, source, r, size, n) for n in sample_counts])
            for r in roughnesses
        ])  # fmt: skip
    finally:
        fullscreen.release()
        source.release()


def prepared_prefilter(
    ctx: moderngl.Context,
    shaders: ShaderCache,
    env_map: np.ndarray,
    base: int = FACE_SIZE,
    samples: int = SAMPLES,
) -> list[np.ndarray]:
    """``prefilter`` through the prepared-texture cache (app/textures/cache.py), so that a
    second process with the same environment reads the levels from disk instead of running
    the prefilter: keyed by the map's bytes, the settings, the GL's renderer and version
    (the levels are its arithmetic) and a version of this file and the prefilter's GLSL.
    The bench's direct ``prefilter`` calls (timing it) never read the disk."""
    info = ctx.info
    parts = (
        prefilter_version(),
        np.ascontiguousarray(env_map, np.float32),
        int(base),
        int(samples),
        str(info.get("GL_RENDERER")),
        str(info.get("GL_VERSION")),
    )
    build = lambda: prefilter(ctx, shaders, env_map, base, samples)  # noqa: E731
    return list(prepared_cache().arrays("env_prefilter", parts, build))


def prefilter_version() -> str:
    """The code version of the prefiltered levels (app/textures/versions.py)."""
    return version("env prefilter")


class EnvironmentLighting(ShaderInput):
    """The environment's image-based light as a shader input (app/render/inputs.py): the
    prefiltered levels and the DFG table, ``ENVIRONMENT_IBL``, and the SH9, rotation and
    intensity uniforms; the lighting and blend passes read it."""

    role = ENVIRONMENT

    def __init__(self, ctx: moderngl.Context, shaders: ShaderCache, env: EnvironmentSource) -> None:
        ctx.enable_direct(GL_TEXTURE_CUBE_MAP_SEAMLESS)
        self.levels = []
        for faces in prepared_prefilter(ctx, shaders, env.texels, *_SETTINGS):
            size = faces.shape[1]
            rgba = np.concatenate([faces, np.ones((*faces.shape[:3], 1), np.float32)], -1)
            cube = ctx.texture_cube((size, size), 4, dtype="f4")
            for face in range(6):
                cube.write(face, np.ascontiguousarray(rgba[face]).tobytes())
            cube.filter = (moderngl.LINEAR, moderngl.LINEAR)
            self.levels.append(cube)
        table = np.ascontiguousarray(read_dfg_table())
        self.dfg = ctx.texture(table.shape[1::-1], 2, table.tobytes(), dtype="f4")
        self.dfg.filter = (moderngl.LINEAR, moderngl.LINEAR)
        self.dfg.repeat_x = self.dfg.repeat_y = False
        self.rotation = math.radians(env.rotation)
        self.intensity = float(env.intensity)
        # SH9 of the turned map, in the world frame (float64 twin), times the intensity;
        # the twin imported by a frame with an environment (docs/performance.md, "Start-up")
        from app.reference.ibl import sh9_project

        self.sh = (sh9_project(env.texels, self.rotation) * env.intensity).astype(np.float32)

    def defines(self) -> dict[str, int]:
        return {"ENVIRONMENT_IBL": 1, "ENV_LEVELS": ENV_LEVELS, **DIRECTION_DEFINES[_DIRECTION[0]]}

    def samplers(self) -> list[tuple[str, moderngl.Texture | moderngl.TextureCube]]:
        """(uniform, texture) pairs: the ENV_LEVELS cube maps and the DFG table."""
        named = [(f"u_env_level{k}", cube) for k, cube in enumerate(self.levels)]
        return [*named, ("u_dfg_table", self.dfg)]

    def uniforms(self, prog: moderngl.Program) -> None:
        """The SH coefficients, rotation and intensity (those render.terms keeps)."""
        if "u_env_sh" in prog:
            prog["u_env_sh"].write(self.sh.tobytes())
        if "u_env_rotation" in prog:  # the specular term only
            prog["u_env_rotation"].value = self.rotation
            prog["u_env_intensity"].value = self.intensity

    def release(self) -> None:
        for tex in (*self.levels, self.dfg):
            tex.release()


class UniformEnvironment(ShaderInput):
    """The uniform environment as a shader input (docs/ibl.md, "The uniform
    environment"): ``uniform_environment_radiance`` (glsl/lights/environment_uniform.glsl)
    adds L R(v) per pixel, R(v) by a deterministic quadrature of ``samples`` directions;
    no textures. The same role as ``EnvironmentLighting``, so the lighting and blend
    passes take either."""

    role = ENVIRONMENT

    def __init__(self, radiance: list[float], samples: int) -> None:
        self.radiance = tuple(float(x) for x in radiance)
        self.samples = int(samples)

    def defines(self) -> dict[str, int]:
        return {"ENVIRONMENT_UNIFORM": 1, "ENV_UNIFORM_SAMPLES": self.samples}

    def uniforms(self, prog: moderngl.Program) -> None:
        """The radiance L (absent where render.terms leaves nothing of it)."""
        if "u_env_radiance" in prog:
            prog["u_env_radiance"].value = self.radiance
