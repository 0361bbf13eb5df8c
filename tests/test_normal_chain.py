"""The normal/roughness chain the GL draws (app/render/normal_chain.py, glsl/passes/
normal_chain.frag) against the CPU's float64 chain (app/textures/mips.py, the twin): every
level within float16's rounding of it, on maps of odd and one-texel sides, steep normals
(the n.z floor), a normal scale, no roughness map, and levels from ``first`` on."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from app.gl.context import GLContext
from app.render import normal_chain
from app.textures.maps import ChainSource, _map_chain_levels

pytestmark = pytest.mark.gl


def _maps(
    shape: tuple[int, int], seed: int, steep: bool = False
) -> tuple[Image.Image, Image.Image]:
    rng = np.random.default_rng(seed)
    normal = rng.integers(0, 256, (*shape, 3), dtype=np.uint8)
    if not steep:  # the upper hemisphere, as a height field's normals lie
        normal[..., 2] = rng.integers(128, 256, shape, dtype=np.uint8)
    rough = rng.integers(0, 256, (*shape, 3), dtype=np.uint8)
    return Image.fromarray(normal, "RGB"), Image.fromarray(rough, "RGB")


def _drawn(gl: GLContext, source: ChainSource) -> list[np.ndarray]:
    chain = normal_chain.build_chain(gl.ctx, source)
    try:
        return normal_chain.read_chain_levels(chain)
    finally:
        chain.release()


CASES = [
    ((37, 29), 1.0, 0.9, True, 0, False),
    ((37, 29), 1.7, 0.4, False, 0, False),  # a normal scale, no roughness map
    ((64, 64), 0.6, 1.0, True, 2, False),  # levels from 2 on
    ((1, 9), 1.0, 1.0, True, 0, False),
    ((33, 1), 1.0, 0.5, True, 1, False),
    ((24, 40), 1.0, 0.3, True, 0, True),  # normals down to the surface and below it
]


@pytest.mark.parametrize(("shape", "scale", "factor", "rough", "first", "steep"), CASES)
def test_drawn_chain_is_the_cpus(
    gl_egl: GLContext,
    shape: tuple[int, int],
    scale: float,
    factor: float,
    rough: bool,
    first: int,
    steep: bool,
) -> None:
    normal, roughness = _maps(shape, sum(shape) + first, steep)
    roughness = roughness if rough else None
    drawn = _drawn(gl_egl, ChainSource(normal, roughness, scale, factor, first))
    cpu = _map_chain_levels(normal, scale, factor, roughness, "variance", True, first)
    assert len(drawn) == len(cpu)
    worst = 0.0
    for k, (ours, theirs) in enumerate(zip(drawn, cpu, strict=True)):
        assert ours.shape == theirs.shape and ours.dtype == np.float16, k
        error = np.abs(ours.astype(np.float64) - theirs.astype(np.float64))
        ulp = np.abs(theirs.astype(np.float64)) * 2.0**-10 + 2.0**-24  # float16's step
        assert np.all(error <= ulp), (k, float(error.max()))
        worst = max(worst, float(error.max()))
    print(f"{shape} scale {scale} first {first} steep {steep}: largest difference {worst:.2e}")


def test_flat_map_is_its_roughness(gl_egl: GLContext) -> None:
    """A flat normal map (128, 128, 255) and one roughness: every level the decoded flat
    normal (1/255 off +z in x and y, as the GL samples rgb * 2 - 1) and the roughness,
    no variance added."""
    normal = Image.new("RGB", (16, 8), (128, 128, 255))
    rough = Image.new("RGB", (16, 8), (0, 102, 0))  # 0.4
    levels = _drawn(gl_egl, ChainSource(normal, rough, 1.0, 1.0, 0))
    n = np.array([1.0 / 255.0, 1.0 / 255.0, 1.0])
    n /= np.linalg.norm(n)
    for level in levels:
        texels = level.reshape(-1, 4).astype(np.float64)
        np.testing.assert_allclose(texels[:, :3], np.broadcast_to(n, (len(texels), 3)), atol=1e-3)
        np.testing.assert_allclose(texels[:, 3], 0.4, atol=1e-3)


def test_framebuffer_state_kept(gl_egl: GLContext) -> None:
    """A chain drawn while a framebuffer of moderngl's is bound leaves it bound with its
    own viewport: the levels' viewports are set on the GL, not on moderngl's framebuffer."""
    ctx = gl_egl.ctx
    target = ctx.texture((64, 32), 4)
    fbo = ctx.framebuffer([target])
    fbo.use()
    normal, rough = _maps((37, 29), 3)
    chain = normal_chain.build_chain(ctx, ChainSource(normal, rough, 1.0, 1.0, 0))
    try:
        assert ctx.fbo is fbo
        assert fbo.viewport == (0, 0, 64, 32)
        assert tuple(ctx.viewport) == (0, 0, 64, 32)
    finally:
        chain.release()
        fbo.release()
        target.release()


def test_refused_chain_built_on_the_cpu(
    gl_egl: GLContext, tmp_path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Where the GL refuses to draw a chain (an incomplete level framebuffer, an error),
    the upload builds it on the CPU: the CPU's float16 levels, nothing kept under the
    GL-built key."""
    from app.gl.texture_storage import LevelFramebufferError, read_level
    from app.render import texture_upload
    from app.textures.cache import prepared_cache
    from app.textures.maps import normal_roughness_map

    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("PBS_CACHE", raising=False)
    normal, rough = _maps((21, 17), 4)
    tex = normal_roughness_map(normal, 1.0, 0.7, rough, "variance")

    def refused(*args, **kwargs):
        raise LevelFramebufferError("refused for the test")

    monkeypatch.setattr(normal_chain, "build_chain", refused)
    made = texture_upload.upload_texture(gl_egl.ctx, tex)
    try:
        want = tex.levels.upload_levels()
        for k, level in enumerate(want):
            assert np.array_equal(read_level(made, k), level), k
        assert not prepared_cache().holds(tex.levels.gl_kind, tex.levels.gl_parts)
    finally:
        made.release()


def test_vanished_gl_entry_is_not_rebuilt_under_its_key(
    tmp_path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A prefetch that found the GL-built levels kept, whose entry is gone by the time it
    reads it, makes no CPU chain under the GL's key: the upload then builds the CPU's
    levels under their own."""
    from app.textures import cache as cache_module
    from app.textures.maps import normal_roughness_map

    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("PBS_CACHE", raising=False)
    normal, rough = _maps((21, 17), 5)
    levels = normal_roughness_map(normal, 1.0, 0.7, rough, "variance").levels
    cache = cache_module.prepared_cache()
    monkeypatch.setattr(type(cache), "holds", lambda self, kind, parts: True)
    levels.prefetch()
    assert levels.prefetched()
    want = _map_chain_levels(normal, 1.0, 0.7, rough, "variance", True)
    got = levels.upload_levels()
    assert all(np.array_equal(a, b) for a, b in zip(got, want, strict=True))
    monkeypatch.undo()
    assert not cache_module.prepared_cache().holds(levels.gl_kind, levels.gl_parts)


@pytest.mark.parametrize("when", ["now", "later"])
def test_damaged_gl_entry_is_drawn_again(
    gl_egl: GLContext, tmp_path, monkeypatch: pytest.MonkeyPatch, when: str
) -> None:
    """A chain whose GL-drawn levels a prefetch finds kept but cannot read (a damaged
    file; or evicted meanwhile) is drawn by the GL again, uploaded at once or into storage
    made before it (``TextureUploads.finish``): the levels a cold render draws, not the
    CPU's, which differ from them in the last bits."""
    from app.gl.texture_storage import read_level
    from app.render import texture_upload
    from app.textures.cache import prepared_cache
    from app.textures.cache_keys import entry_file, entry_key, textures_directory
    from app.textures.maps import normal_roughness_map

    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("PBS_CACHE", raising=False)
    normal, rough = _maps((21, 17), 6)
    cold_tex = normal_roughness_map(normal, 1.0, 0.7, rough, "variance")
    cold = texture_upload.upload_texture(gl_egl.ctx, cold_tex)  # drawn and kept
    levels = cold_tex.levels
    want = [read_level(cold, k) for k in range(len(levels.upload_levels()))]
    cold.release()
    cpu = _map_chain_levels(normal, 1.0, 0.7, rough, "variance", True)
    assert any(not np.array_equal(a, b) for a, b in zip(want, cpu, strict=True))  # telling

    cache = prepared_cache()
    cache.clear_memory()  # the next process: the entry on disk alone
    path = entry_file(textures_directory(), [], entry_key(levels.gl_kind, levels.gl_parts))
    assert path is not None
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0xFF
    path.write_bytes(bytes(data))

    tex = normal_roughness_map(normal, 1.0, 0.7, rough, "variance")
    tex.levels.prefetch()  # finds the entry, fails to read it
    assert tex.levels.prefetched()
    uploads = texture_upload.TextureUploads(gl_egl.ctx)
    try:
        if when == "later":
            monkeypatch.setattr(type(tex.levels), "ready", lambda self: False)  # still read
            uploads.upload_ready_first([tex], later=True)
            uploads.finish()
        made = uploads.get(tex)
        for k, level in enumerate(want):
            assert np.array_equal(read_level(made, k), level), k
    finally:
        uploads.release()
    cache.clear_memory()
    assert cache.kept(levels.gl_kind, levels.gl_parts) is not None  # kept again, readable


@pytest.mark.parametrize("first", [0, 1])
def test_texels_read_in_place_give_the_same_levels(gl: GLContext, first: int) -> None:
    """The maps' texels read in place (app/gl/texel_buffer.py: the decoded images' own
    storage as buffer textures, GL_AMD_pinned_memory) and uploaded as textures give every
    level bit for bit, with and without a roughness map; the roughness read is the
    roughness image's (its green channel), not the normal map's."""
    from app.gl.texel_buffer import has_pinned_memory

    if not has_pinned_memory(gl.ctx):
        pytest.skip(f"{gl.described}: no GL_AMD_pinned_memory")
    normal, rough = _maps((37, 29), 5 + first)
    for roughness in (rough, None):
        source = ChainSource(normal, roughness, 1.3, 0.8, first)
        levels = []
        for in_place in (True, False):
            chain = normal_chain.build_chain(gl.ctx, source, texel_buffers=in_place)
            try:
                levels.append(normal_chain.read_chain_levels(chain))
            finally:
                chain.release()
        assert len(levels[0]) == len(levels[1])
        for ours, theirs in zip(*levels, strict=True):
            np.testing.assert_array_equal(ours, theirs)
    swapped = ChainSource(normal, normal, 1.3, 0.8, first)  # the normal map's green instead
    chain = normal_chain.build_chain(gl.ctx, swapped, texel_buffers=True)
    try:
        other = normal_chain.read_chain_levels(chain)
    finally:
        chain.release()
    source = ChainSource(normal, rough, 1.3, 0.8, first)
    chain = normal_chain.build_chain(gl.ctx, source, texel_buffers=True)
    try:
        assert not np.array_equal(normal_chain.read_chain_levels(chain)[0], other[0])
    finally:
        chain.release()


def test_texels_uploaded_where_they_cannot_be_read_in_place(gl_egl: GLContext) -> None:
    """A map whose decoded storage is not an RGB image's (an RGBA normal map) is uploaded
    as a texture: the chain is the same as the RGB map's, and asking for the texels in
    place is refused."""
    normal, rough = _maps((16, 12), 9)
    rgba = normal.convert("RGBA")
    assert ChainSource(rgba, rough, 1.0, 1.0, 0).texels_in_place() is None
    drawn = _drawn(gl_egl, ChainSource(rgba, rough, 1.0, 1.0, 0))
    for ours, theirs in zip(drawn, _drawn(gl_egl, ChainSource(normal, rough, 1.0, 1.0, 0)),
                            strict=True):  # fmt: skip
        np.testing.assert_array_equal(ours, theirs)
    with pytest.raises(ValueError, match="in place"):
        normal_chain.build_chain(gl_egl.ctx, ChainSource(rgba, rough, 1.0, 1.0, 0),
                                 texel_buffers=True)  # fmt: skip


def test_chain_drawn_ahead_is_the_one_uploaded(
    gl_egl: GLContext, tmp_path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A chain drawn ahead (``draw_chain_ahead``, as ``pbs render`` does where the scene's
    reader waits) is the texture the upload takes, with the levels a chain drawn by the
    upload has and its entry kept; drawn on another context, or with its GL memory past
    the limit, it is not drawn ahead (the upload draws it); one not taken is forgotten."""
    from app.gl.texture_storage import read_level
    from app.render import texture_upload
    from app.textures.cache import prepared_cache
    from app.textures.maps import normal_roughness_map

    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("PBS_CACHE", raising=False)
    normal, rough = _maps((48, 40), 6)
    tex = normal_roughness_map(normal, 1.0, 0.6, rough, "variance")
    want = _drawn(gl_egl, tex.levels.gl_source)
    drawn: list[int] = []
    build = normal_chain.build_chain
    monkeypatch.setattr(
        normal_chain, "build_chain", lambda *a, **k: drawn.append(1) or build(*a, **k)
    )
    small = normal_chain.gpu_bytes(tex.levels.gl_source)  # without the maps' texels
    texture_upload.draw_chain_ahead(gl_egl.ctx, tex.levels, small)
    assert drawn == [] and not prepared_cache().holds(tex.levels.gl_kind, tex.levels.gl_parts)
    texture_upload.draw_chain_ahead(gl_egl.ctx, tex.levels, 1 << 30)
    assert drawn == [1] and prepared_cache().holds(tex.levels.gl_kind, tex.levels.gl_parts)
    other = object()  # another context's upload does not take it
    assert texture_upload._drawn_ahead(other, tex.levels) is None  # type: ignore[arg-type]
    made = texture_upload.upload_texture(gl_egl.ctx, tex)
    try:
        assert drawn == [1]  # taken, not drawn again
        for k, level in enumerate(want):
            assert np.array_equal(read_level(made, k), level), k
    finally:
        made.release()
    second = normal_roughness_map(*_maps((16, 16), 7)[:1], 1.0, 0.5, None, "variance")
    texture_upload.draw_chain_ahead(gl_egl.ctx, second.levels, 1 << 30)
    texture_upload.forget_chains_ahead(gl_egl.ctx)
    assert texture_upload._drawn_ahead(gl_egl.ctx, second.levels) is None
