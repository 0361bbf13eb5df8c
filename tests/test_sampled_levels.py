"""A still frame decodes a model's textures from the finest mip level its camera samples
(app/scene/sampled_levels.py, app/scene/gltf.py ``uv_lods``): the bound itself on a quad
whose level of detail is known, a close camera that decodes the whole map, a far one that
decodes it reduced, and the far frame against the frame built from every level."""

from __future__ import annotations

import io
import math
from pathlib import Path

import numpy as np
import pygltflib
import pytest
from PIL import Image

from app.gl.context import GLContext
from app.scene.geometry import take_built
from app.scene.sampled_levels import (
    LOD_MARGIN,
    MAX_REDUCTION,
    MAX_SKIPPED_WEIGHT,
    SKIPPED_SHARE,
    ViewTriangles,
    reduced_levels,
    sampled_uv_lods,
)
from app.scene.sources import scene_from
from tests.gltf_builder import QUAD_INDICES, QUAD_POSITIONS, QUAD_UV, GltfBuilder

TEXELS = 256  # the maps' side


def _quad(z: float = 0.0, uv: bool = True) -> ViewTriangles:
    return ViewTriangles(
        QUAD_POSITIONS.astype(np.float64) + np.array([0.0, 0.0, z]),
        QUAD_UV.astype(np.float64) if uv else None,
        QUAD_INDICES.reshape(-1, 3).astype(np.int64),
        two_sided=False,
    )


def _camera(distance: float) -> dict:
    return {"position": [0.0, 0.0, distance], "target": [0.0, 0.0, 0.0], "up": [0.0, 1.0, 0.0],
            "fov_y": 90.0, "near": 0.1}  # fmt: skip


def test_bound_of_a_facing_quad() -> None:
    """A 2 m quad facing a 90-degree camera from 4 m spans a quarter of a 256-pixel image:
    1 UV unit over 64 pixels, LOD -6 in UV units (a 256-texel map's level 2)."""
    lods = sampled_uv_lods([_quad()], _camera(4.0), (256, 256))
    assert len(lods) == 64 * 64 + 64  # its pixel centres, the diagonal's for both triangles
    assert lods == pytest.approx(-6.0, abs=1e-9)
    assert reduced_levels(lods, TEXELS, TEXELS) == 2
    assert reduced_levels(lods, 200, 200) == 1  # 200 / 4 is no whole level: one only


def test_a_level_a_few_pixels_blend_a_little_is_skipped() -> None:
    """Level 0 of a 1024-texel map is skipped where the pixels that blend it take at most
    MAX_SKIPPED_WEIGHT of it each (less LOD_MARGIN) and SKIPPED_SHARE of the frame's
    pixels' worth together; one pixel more than either keeps it."""
    side = 1024
    at_level = lambda lod: lod - math.log2(side)  # noqa: E731 (a pixel's uv lod)
    frame = np.full(100_000, at_level(1.5))
    light = at_level(0.8)  # blends level 0 by 0.2
    share = round(SKIPPED_SHARE * len(frame) / 0.2)  # 500 such pixels
    few = frame.copy()
    few[:share] = light
    assert reduced_levels(few, side, side) == 1
    many = frame.copy()
    many[: share + 1] = light
    assert reduced_levels(many, side, side) == 0
    heavy = frame.copy()
    heavy[0] = at_level(1.0 - MAX_SKIPPED_WEIGHT + LOD_MARGIN / 2)  # one pixel, margin over
    assert reduced_levels(heavy, side, side) == 0
    heavy[0] = at_level(1.0 - MAX_SKIPPED_WEIGHT + 2 * LOD_MARGIN)
    assert reduced_levels(heavy, side, side) == 1
    assert reduced_levels(np.zeros(0), side, side) == MAX_REDUCTION  # nothing seen
    assert reduced_levels(np.zeros(0), 12, 12) == 2  # 12 divides by 4, not 8
    assert reduced_levels(np.array([-math.inf]), side, side) == 0  # no bound taken


def _jpeg(rgb: np.ndarray) -> bytes:
    data = io.BytesIO()
    Image.fromarray(rgb).save(data, format="JPEG", quality=95)
    return data.getvalue()


def _maps() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Smooth base colour and metallic-roughness images (a few cycles across) and a
    normal map of bumps 16 texels apart (resolved at level 2, gone by level 4)."""
    y, x = np.mgrid[0:TEXELS, 0:TEXELS] / TEXELS * 2.0 * np.pi
    colour = np.stack([0.5 + 0.3 * np.sin(2 * x), 0.5 + 0.3 * np.cos(3 * y), 0.4 + 0 * x], -1)
    slope = 0.5 * np.stack([np.cos(16 * x), np.sin(16 * y)], -1)  # a period of 16 texels
    normal = np.concatenate([-slope, np.ones((TEXELS, TEXELS, 1))], -1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    mr = np.stack([0 * x, 0.4 + 0.2 * np.sin(x + y), 0.5 + 0.5 * np.sin(y)], -1)
    images = [
        (np.clip(v, 0, 1) * 255).round().astype(np.uint8) for v in (colour, normal * 0.5 + 0.5, mr)
    ]
    return images[0], images[1], images[2]


def _png(rgb: np.ndarray) -> bytes:
    data = io.BytesIO()
    Image.fromarray(rgb).save(data, format="PNG")
    return data.getvalue()


def _model(root: Path, colour: bool = True, change: str = "", png: bool = False) -> Path:
    """A quad with JPEG (``png``: PNG) base colour (unless not ``colour``: none), normal and
    metallic-roughness maps of 256 texels; ``change``: "transform" (the base colour's UVs
    scaled by KHR_texture_transform, not declared in extensionsUsed), "texcoord" (read
    through TEXCOORD_1), "no mips" (a sampler whose minFilter is LINEAR), "blend"
    (alphaMode BLEND), "transmission" (KHR_materials_transmission) or "no uv" (the
    primitive without TEXCOORD_0: its maps read at uv (0, 0), level 0)."""
    b = GltfBuilder()
    textures = []
    for rgb in _maps():
        encoded, mime = (_png(rgb), "image/png") if png else (_jpeg(rgb), "image/jpeg")
        b.doc.images.append(pygltflib.Image(bufferView=b.view(encoded), mimeType=mime))
        b.doc.textures.append(pygltflib.Texture(source=len(b.doc.images) - 1))
        textures.append(len(b.doc.textures) - 1)
    info = pygltflib.TextureInfo(index=textures[0])
    if change == "transform":
        info.extensions = {"KHR_texture_transform": {"scale": [4.0, 4.0]}}
    elif change == "texcoord":
        info.texCoord = 1
    elif change == "no mips":
        b.doc.samplers.append(pygltflib.Sampler(minFilter=9729))
        b.doc.textures[textures[0]].sampler = 0
    pbr = pygltflib.PbrMetallicRoughness(
        baseColorTexture=info if colour else None,
        metallicRoughnessTexture=pygltflib.TextureInfo(index=textures[2]),
    )
    material = pygltflib.Material(
        pbrMetallicRoughness=pbr, normalTexture=pygltflib.NormalMaterialTexture(index=textures[1])
    )
    if change == "blend":
        material.alphaMode = "BLEND"
    elif change == "transmission":
        material.extensions = {"KHR_materials_transmission": {"transmissionFactor": 1.0}}
        b.doc.extensionsUsed = ["KHR_materials_transmission"]
    if change == "texcoord":
        b.quad(material=b.material(material), uv1=QUAD_UV)
    else:
        b.quad(material=b.material(material))
    if change == "no uv":
        b.doc.meshes[-1].primitives[0].attributes.TEXCOORD_0 = None
    return b.save(root / "quad.glb")


def _sizes(path: Path, size: tuple[int, int], still: bool) -> dict[str, tuple[int, ...]]:
    """The level-0 shape of each map a still (or full) load of ``path`` builds."""
    loaded = scene_from(path, size=size, still=still)
    kept = take_built(loaded)
    assert kept is not None
    (part,) = kept[0]
    return {name: tuple(tex.levels[0].shape[:2]) for name, tex in part.layers[0].maps.items()}


def test_close_camera_decodes_whole(tmp_path: Path) -> None:
    """At 512 pixels the framed quad spans more pixels than its maps' texels: level 0 is
    sampled, every map starts there."""
    sizes = _sizes(_model(tmp_path), (512, 512), still=True)
    assert set(sizes.values()) == {(TEXELS, TEXELS)}


def test_far_camera_decodes_reduced(tmp_path: Path) -> None:
    """At 40 pixels a 256-texel map's finest sampled level is 2: the base colour decodes
    at 64 texels (DCT scaling), the chain and the metallic levels start at level 2; a load
    that is not a still frame (the viewer's, the API's) keeps every level."""
    path = _model(tmp_path)
    still = _sizes(path, (40, 40), still=True)
    assert set(still.values()) == {(TEXELS // 4, TEXELS // 4)}
    assert set(_sizes(path, (40, 40), still=False).values()) == {(TEXELS, TEXELS)}


def test_far_camera_keeps_a_png_colour_maps_sampled_levels(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A PNG decodes whole, but at 40 pixels its base colour keeps level 2 and the ones
    below alone: a linear-light 2x2 box of the whole map's texels (mips.srgb_box_levels),
    as a DCT-scaled JPEG's mips are made; a second load reads them from the
    prepared-texture cache, the same bytes, without decoding the image."""
    from app.textures import maps
    from app.textures.cache import prepared_cache
    from app.textures.mips import srgb_box_levels

    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("PBS_CACHE", raising=False)
    path = _model(tmp_path, png=True)
    whole = np.concatenate([_maps()[0], np.full((TEXELS, TEXELS, 1), 255, np.uint8)], -1)
    want = [level[::-1] for level in srgb_box_levels(np.ascontiguousarray(whole[::-1]))[2:]]
    decoded: list[object] = []
    texels_of = maps._decoded
    monkeypatch.setattr(maps, "_decoded", lambda image: decoded.append(image) or texels_of(image))
    for load in range(2):  # made, then read from the cache
        (part,) = take_built(scene_from(path, size=(40, 40), still=True))[0]
        levels = part.layers[0].maps["base_color"].levels
        assert len(levels) == len(want)
        for got, made in zip(levels, want, strict=True):
            np.testing.assert_array_equal(got, made)
        assert bool(decoded) == (load == 0)  # the texels read to make the levels, once
        decoded.clear()
        prepared_cache().flush()
    assert set(_sizes(path, (40, 40), still=True).values()) == {(TEXELS // 4, TEXELS // 4)}
    assert set(_sizes(path, (40, 40), still=False).values()) == {(TEXELS, TEXELS)}


def _frames(path: Path, size: tuple[int, int], gl: GLContext) -> np.ndarray:
    """|still frame - frame from every level| of ``path`` at ``size``, 8-bit RGB."""
    from app.render.renderer import Renderer

    images = []
    for still in (True, False):
        renderer = Renderer(gl, scene_from(path, size=size, still=still), size)
        renderer.render()
        images.append(renderer.read_image().astype(np.int64))
        renderer.release()
    return np.abs(images[0] - images[1])


@pytest.mark.parametrize(
    "change", ["transform", "texcoord", "no mips", "blend", "transmission", "no uv"]
)
def test_bound_not_taken(tmp_path: Path, change: str) -> None:
    """Where the bound on TEXCOORD_0 does not cover every read (a transformed or other UV
    set, a sampler without mips, maps read without UVs) or the frame draws the part in a
    pass the bound does not see (blended, transmissive), a still frame keeps every level."""
    sizes = _sizes(_model(tmp_path, change=change), (40, 40), still=True)
    assert set(sizes.values()) == {(TEXELS, TEXELS)}


def test_a_reframed_still_builds_its_own_parts(tmp_path: Path) -> None:
    """A still's parts hold textures from the level its camera samples: a scene derived
    from it with another camera (an API user's edit) must not take them."""
    from app.scene.edits import edited

    loaded = scene_from(_model(tmp_path), size=(40, 40), still=True)
    closer = edited(loaded, {"camera.position": [0.0, 0.0, 0.5]}, "test")
    assert take_built(closer) is None
    assert take_built(loaded) is not None  # the scene as framed takes them


MORE_SAMPLES = [
    {"render.antialiasing": "msaa"},
    {"render.antialiasing": "jitter"},
    {"render.supersample": 2},
]


@pytest.mark.parametrize("change", MORE_SAMPLES)
def test_a_still_edited_to_more_samples_builds_its_own_parts(tmp_path: Path, change: dict) -> None:
    """A model file's still samples once per pixel (its render table sets neither
    supersampling nor a multisampled mode), so its bound is always taken; a scene derived
    from it that samples between the pixel centres (an API user's edit) must not take the
    parts whose textures start at the bound's level."""
    from app.scene.edits import edited

    loaded = scene_from(_model(tmp_path), size=(40, 40), still=True)
    assert take_built(edited(loaded, change, "test")) is None
    assert take_built(loaded) is not None


@pytest.mark.gl
def test_far_frame_matches_every_level(tmp_path: Path, gl_egl: GLContext) -> None:
    """The far still frame against the same frame from every level. The normal/roughness
    chain and the metallic levels from level 2 on are the same bits as the whole chain's,
    so a quad without a base colour map differs only where a pixel blended a skipped
    level by at most 1/8 (none here). The base colour's DCT-scaled level 2 averages
    sRGB-encoded values where the GL's mips average linear ones, and the exposure meter
    reads it: a few 8-bit steps."""
    exact = _frames(_model(tmp_path, colour=False), (40, 40), gl_egl)
    print("far frame against every level, no base colour map:", exact.max(), exact.mean())
    assert exact.max() == 0
    coloured = _frames(_model(tmp_path), (40, 40), gl_egl)
    print("with the DCT-scaled base colour:", coloured.max(), coloured.mean())
    assert coloured.max() <= 4
    assert coloured.mean() <= 0.5


@pytest.mark.gl
def test_srgb_mips_match_the_gl(gl_egl: GLContext) -> None:
    """A DCT-scaled colour map's mips are made on the CPU (mips.srgb_box_levels): a 2x2 box
    in linear space, as the GL's sRGB mips are. llvmpipe encodes with an approximation of
    its own: level 1 within one 8-bit step, the deeper levels (each made from the one
    above) within a step more each."""
    from app.render.texture_upload import GL_SRGB8_ALPHA8, read_level
    from app.textures.mips import srgb_box_levels

    texels = np.random.default_rng(5).integers(0, 256, (64, 64, 4), np.uint8)
    gl_tex = gl_egl.ctx.texture((64, 64), 4, texels.tobytes(), internal_format=GL_SRGB8_ALPHA8)
    gl_tex.build_mipmaps()
    ours = srgb_box_levels(texels)
    assert len(ours) == 7 and ours[0] is texels
    for k in range(1, 7):
        difference = np.abs(ours[k].astype(int) - read_level(gl_tex, k).astype(int))
        assert difference.max() <= k, k
    gl_tex.release()


def test_the_bound_is_taken_for_the_camera_that_renders(tmp_path: Path) -> None:
    """The still's camera is the one its bound framed, and that is the camera a full load
    frames (the same float32 points): the levels skipped are the ones the frame sees."""
    path = _model(tmp_path)
    still = scene_from(path, size=(40, 30), still=True).scene.camera.model_dump()
    full = scene_from(path, size=(40, 30), still=False).scene.camera.model_dump()
    for key in ("position", "target", "up", "fov_y", "near", "far"):
        assert still[key] == full[key], key


def test_colour_levels_off_the_reading_thread(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A DCT-scaled colour map's levels are looked up (read, or their mips made) on a
    thread of their own (maps.PendingLevels), not on the thread that reads the material,
    and read when first indexed."""
    import threading

    import app.textures.maps as maps

    threads: list[str] = []
    cache = maps.prepared_cache()

    class Recorded:
        def arrays(self, kind, parts, build):
            if kind.startswith("colour"):
                threads.append(threading.current_thread().name)
            return cache.arrays(kind, parts, build)

        def __getattr__(self, name: str):
            return getattr(cache, name)

    monkeypatch.setattr(maps, "prepared_cache", Recorded)
    loaded = scene_from(_model(tmp_path), size=(40, 40), still=True)
    kept = take_built(loaded)
    assert kept is not None
    (part,) = kept[0]
    base = part.layers[0].maps["base_color"]
    assert isinstance(base.levels, maps.PendingLevels)
    assert base.levels[0].shape[:2] == (TEXELS // 4, TEXELS // 4)
    assert len(base.levels) == 7  # 64 texels a side down to 1
    assert threads and all(name.startswith("pbs-colour-levels") for name in threads)


def test_colour_level_zero_before_its_mips(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A DCT-scaled colour map's level 0 is handed over as soon as it is decoded: the
    exposure meter (which reads it while the scene is read) does not wait for the mips."""
    import threading

    import app.textures.maps as maps

    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path / "cache"))  # the mips made, not read
    read = threading.Event()  # set once the scene is read, its meter having read level 0
    waited: list[bool] = []
    made = maps.srgb_box_levels

    def held(level0: np.ndarray) -> list[np.ndarray]:
        waited.append(read.wait(timeout=5.0))  # False: the reader waited for the mips
        return made(level0)

    monkeypatch.setattr(maps, "srgb_box_levels", held)
    loaded = scene_from(_model(tmp_path), size=(40, 40), still=True)
    read.set()
    kept = take_built(loaded)
    assert kept is not None
    base = kept[0][0].layers[0].maps["base_color"]
    assert len(base.levels) == 7  # the mips, made once the scene was read
    assert waited == [True]
    assert base.levels[0].shape[:2] == (TEXELS // 4, TEXELS // 4)
