"""The content-keyed cache of prepared textures (app/textures/cache.py): a second load of
the same images reads the chains instead of building them and gets the same arrays, a
corrupt entry is detected by its checksum and rebuilt, the cache can be turned off and
stays within its size, and a glTF material's maps go through it."""

from __future__ import annotations

import mmap
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from app.textures import cache as cache_module
from app.textures import cache_keys
from app.textures.cache import PreparedCache, entry_key, prepared_cache
from app.textures.maps import Texture, channel_texture, normal_roughness_map


def images(seed: int = 7) -> tuple[Image.Image, Image.Image]:
    """A random normal map and metallic-roughness image (odd sizes: blocks of three)."""
    rng = np.random.default_rng(seed)
    normal = rng.integers(0, 256, (37, 29, 3), dtype=np.uint8)
    normal[..., 2] = rng.integers(128, 256, (37, 29), dtype=np.uint8)
    mr = rng.integers(0, 256, (37, 29, 3), dtype=np.uint8)
    return Image.fromarray(normal, "RGB"), Image.fromarray(mr, "RGB")


def chain(cache_dir: Path, monkeypatch: pytest.MonkeyPatch, seed: int = 7) -> list[np.ndarray]:
    monkeypatch.setenv("PBS_CACHE_DIR", str(cache_dir))
    normal, mr = images(seed)
    return list(normal_roughness_map(normal, 0.8, 0.9, mr, "variance").levels)  # looked up


def test_second_load_hits_and_is_identical(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("PBS_CACHE", raising=False)
    first = chain(tmp_path, monkeypatch)
    cache = prepared_cache()
    assert cache.events[-1] == "built"
    cache.flush()  # written on the cache's writer thread
    assert len(list((tmp_path / "textures").glob("*.npy"))) == 1
    again = chain(tmp_path, monkeypatch)  # the same process: from memory
    assert cache.events[-1] == "memory"
    cache.clear_memory()  # another process: from disk
    third = chain(tmp_path, monkeypatch)
    assert cache.events[-1] == "disk"
    for a, b, c in zip(first, again, third, strict=True):
        assert a.dtype == b.dtype == c.dtype == np.float32
        assert np.array_equal(a, b) and np.array_equal(a, c)
        assert not c.flags.writeable  # shared: nobody may change them in place
    # Another image, another filter, another scale: other keys, built.
    chain(tmp_path, monkeypatch, seed=8)
    assert cache.events[-1] == "built"
    normal, mr = images()
    normal_roughness_map(normal, 0.8, 0.9, mr, "toksvig").levels[0]
    normal_roughness_map(normal, 0.7, 0.9, mr, "variance").levels[0]
    assert cache.events[-2:] == ["built", "built"]


def test_cached_chain_is_what_the_builder_makes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """With the cache off, the same call builds every time; the cached arrays equal it."""
    cached = chain(tmp_path, monkeypatch)
    monkeypatch.setenv("PBS_CACHE", "off")
    cache = prepared_cache()
    built = chain(tmp_path, monkeypatch)
    built_again = chain(tmp_path, monkeypatch)
    assert not cache.enabled and cache.events == ["built", "built"]
    for a, b, c in zip(cached, built, built_again, strict=True):
        assert np.array_equal(a, b) and np.array_equal(a, c)
    # Off means off: nothing written (a fresh folder stays empty).
    chain(tmp_path / "off", monkeypatch)
    assert not (tmp_path / "off").exists()


def test_corrupt_entry_is_rebuilt(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("PBS_CACHE", raising=False)
    first = chain(tmp_path, monkeypatch)
    cache = prepared_cache()
    cache.flush()
    (entry,) = (tmp_path / "textures").glob("*.npy")
    # Flip bytes inside the data (the file still loads: only the checksum can tell).
    data = bytearray(entry.read_bytes())
    middle = len(data) // 2
    data[middle : middle + 8] = bytes(b ^ 0xFF for b in data[middle : middle + 8])
    entry.write_bytes(bytes(data))
    cache.clear_memory()
    again = chain(tmp_path, monkeypatch)
    assert cache.events[-2:] == ["rebuilt", "built"]
    for a, b in zip(first, again, strict=True):
        assert np.array_equal(a, b)
    # Rewritten whole: the next process reads it.
    cache.clear_memory()
    chain(tmp_path, monkeypatch)
    assert cache.events[-1] == "disk"
    # A well-formed .npy whose header names another checksum: rebuilt.
    packed = np.load(entry, allow_pickle=False).copy()
    packed[-1] ^= 1
    np.save(entry, packed)
    cache.clear_memory()
    chain(tmp_path, monkeypatch)
    assert cache.events[-2:] == ["rebuilt", "built"]
    # Not an entry at all: rebuilt too.
    cache.flush()
    entry.write_bytes(b"not an npy")
    cache.clear_memory()
    chain(tmp_path, monkeypatch)
    assert cache.events[-2:] == ["rebuilt", "built"]


def test_entries_are_data_not_pickles(tmp_path: Path) -> None:
    """An entry holding an object array (what a pickle would smuggle in) is refused and
    rebuilt, never unpickled."""
    cache = PreparedCache(tmp_path)
    key = entry_key("test", ("x",))
    np.save(tmp_path / f"{key}.npy", np.array([{"x": 1}], dtype=object), allow_pickle=True)
    arrays = cache.arrays("test", ("x",), lambda: [np.arange(3.0)])
    assert cache.events == ["rebuilt", "built"]
    assert np.array_equal(arrays[0], np.arange(3.0))


def test_disk_size_is_bounded(tmp_path: Path) -> None:
    """Past ``disk_bytes`` the least recently used entries go; in memory likewise."""
    cache = PreparedCache(tmp_path, disk_bytes=3 * 8200, memory_bytes=2 * 8000)
    for k in range(5):
        cache.arrays("test", (k,), lambda k=k: [np.full(1000, float(k))])
    cache.flush()
    on_disk = sorted(tmp_path.glob("*.npy"))
    assert 1 <= len(on_disk) <= 3
    assert sum(p.stat().st_size for p in on_disk) <= 3 * 8200
    assert len(cache._memory) == 2
    cache.clear_memory()
    cache.arrays("test", (4,), lambda: [np.full(1000, 4.0)])  # the newest survived
    assert cache.events[-1] == "disk"


def test_key_separates_inputs() -> None:
    assert entry_key("k", (b"ab", b"c")) != entry_key("k", (b"a", b"bc"))
    assert entry_key("k", (np.zeros(2, np.float32),)) != entry_key("k", (np.zeros(1),))
    assert entry_key("k", (1,)) != entry_key("k", (1.0,))
    assert entry_key("a", ()) != entry_key("b", ())


def test_default_directory(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.delenv("PBS_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert cache_keys.cache_directory() == tmp_path / "pbs"
    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path / "mine"))
    assert cache_keys.cache_directory() == tmp_path / "mine"


def test_channel_texture_cached(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("PBS_CACHE", raising=False)
    _, mr = images()
    a = list(channel_texture(mr, 2).levels)
    cache = prepared_cache()
    cache.clear_memory()
    b = list(channel_texture(mr, 2).levels)
    assert cache.events[-2:] == ["built", "disk"]
    expected = np.asarray(mr, np.float64)[..., 2] / 255.0
    assert np.array_equal(a[0][..., 0], expected.astype(np.float32))
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))


def test_prefiltered_environment_from_disk(
    gl_egl, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The IBL prefilter's levels (app/render/ibl.py ``prepared_prefilter``): a second
    process (memory cleared, the prefilter's own cache too) reads them from disk, equal."""
    from app.gl.shaders import ShaderCache
    from app.render.ibl import clear_cache, prepared_prefilter
    from app.textures.environment import studio

    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("PBS_CACHE", raising=False)
    env = studio(64)
    shaders = ShaderCache(gl_egl.ctx)
    try:
        first = prepared_prefilter(gl_egl.ctx, shaders, env, base=16, samples=8)
        cache = prepared_cache()
        cache.clear_memory()
        clear_cache()
        again = prepared_prefilter(gl_egl.ctx, shaders, env, base=16, samples=8)
        other = prepared_prefilter(gl_egl.ctx, shaders, env, base=16, samples=16)
    finally:
        shaders.release()
    assert cache.events == ["built", "disk", "built"]
    assert all(np.array_equal(a, b) for a, b in zip(first, again, strict=True))
    assert not all(np.array_equal(a, b) for a, b in zip(first, other, strict=True))


def test_open_image_keys_by_file_bytes(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """An image open_image decoded is keyed by its file's digest: the same bytes hit, one
    changed pixel (another file) misses."""
    import io

    from app.textures.maps import SOURCE_DIGEST, open_image

    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("PBS_CACHE", raising=False)
    _, mr = images()

    def png(image: Image.Image) -> bytes:
        out = io.BytesIO()
        image.save(out, "PNG")
        return out.getvalue()

    data = png(mr)
    first = open_image(data)
    assert isinstance(first.info[SOURCE_DIGEST], str)
    # Decoded once per process: a second open is the same decoded image (callers only read).
    second = open_image(data)
    assert second is first and second.tobytes() == mr.tobytes()
    assert second.info[SOURCE_DIGEST] == first.info[SOURCE_DIGEST]
    cache = prepared_cache()
    channel_texture(first, 1).levels[0]
    assert cache.events[-1] == "built"
    channel_texture(open_image(data), 1).levels[0]
    assert cache.events[-1] == "memory"
    changed = np.asarray(mr).copy()
    changed[0, 0, 1] ^= 1
    channel_texture(open_image(png(Image.fromarray(changed, "RGB"))), 1).levels[0]
    assert cache.events[-1] == "built"


def test_colour_mips_kept(gl_egl, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A colour map's mips: drawn the first time (app/render/srgb_mips.py) and kept; a
    second process defines them from the kept bytes, every level the same bytes, each
    texel its footprint's mean in linear light (the float64 twin) to llvmpipe's sRGB
    rounding, which each level made from the rounded one above adds to."""
    import io

    from app.reference.footprint import srgb_footprint_levels
    from app.render.texture_upload import read_level, upload_texture
    from app.textures.maps import colour_texture, open_image

    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("PBS_CACHE", raising=False)
    normal, _ = images()
    out = io.BytesIO()
    normal.save(out, "PNG")
    tex = colour_texture(open_image(out.getvalue()))
    assert tex.source_key is not None
    made = [upload_texture(gl_egl.ctx, tex)]
    cache = prepared_cache()
    cache.clear_memory()
    made.append(upload_texture(gl_egl.ctx, tex))
    # The first lookups: open_image's record that these bytes decode, the RGBA texels.
    assert cache.events[2:] == ["built", "disk"]
    try:
        # the GL's rows are bottom first; the footprints are the image's (top first)
        twin = [t[::-1] for t in srgb_footprint_levels(read_level(made[0], 0)[::-1])]
        for k in range(max(tex.levels[0].shape[:2]).bit_length()):
            drawn = read_level(made[0], k)
            assert np.array_equal(read_level(made[1], k), drawn), k
            difference = np.abs(drawn - twin[k])
            assert difference.max() <= 0.5 + k, k  # 37 x 29: an odd side at most levels
            assert difference.mean() <= 0.5, k
    finally:
        for t in made:
            t.release()


def test_eviction_spares_writes_in_progress(tmp_path: Path) -> None:
    """Another process's temporary file is not evicted while fresh; a stale one (a killed
    writer's) is removed."""
    import os

    fresh, stale = tmp_path / ".tmp-fresh.npy", tmp_path / ".tmp-stale.npy"
    for path in (fresh, stale):
        path.write_bytes(b"x" * 50_000)
    os.utime(stale, (1.0, 1.0))
    cache = PreparedCache(tmp_path, disk_bytes=10)
    cache.arrays("test", (1,), lambda: [np.zeros(4)])
    cache.flush()
    assert fresh.exists() and not stale.exists()


def _jpeg(seed: int = 3) -> bytes:
    import io

    rng = np.random.default_rng(seed)
    out = io.BytesIO()
    Image.fromarray(rng.integers(0, 256, (24, 40, 3), dtype=np.uint8), "RGB").save(out, "JPEG")
    return out.getvalue()


def _undecoded(image: Image.Image) -> bool:
    """Whether Pillow has yet to decode ``image`` (its tile list, emptied by ``load``; a
    copy of a decoded image has none)."""
    return bool(getattr(image, "tile", None))


def test_image_known_to_decode_is_decoded_when_read(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """open_image decodes an image the first time (and records that its bytes decode);
    a later process gets it undecoded, the same texels once read; a broken image is
    refused every time, never recorded."""
    from app.textures import decoded, maps
    from app.untrusted import RefusedError

    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("PBS_CACHE", raising=False)
    monkeypatch.setattr(decoded, "_IMAGES", type(decoded._IMAGES)())
    data = _jpeg()
    first = maps.open_image(data)
    assert not _undecoded(first)
    expected = first.tobytes()
    cache = prepared_cache()
    cache.clear_memory()
    decoded.forget()  # the next process
    later = maps.open_image(data)
    assert _undecoded(later)  # nothing has read its texels yet
    assert later.info[maps.SOURCE_DIGEST] == first.info[maps.SOURCE_DIGEST]
    assert later.size == first.size and later.mode == first.mode
    assert later.tobytes() == expected  # decoded on first read, the same texels
    broken = data[: len(data) // 2]  # a whole header, half the scan
    for _ in range(2):
        with pytest.raises(RefusedError):
            maps.open_image(broken)
        cache.clear_memory()
    monkeypatch.setenv("PBS_CACHE", "off")  # no record: always decoded here
    assert not _undecoded(maps.open_image(data))


def test_upload_levels_are_their_own_entry(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A prepared chain's float16 upload levels (rows bottom first) are exactly
    np.float16 of its float32 levels, and a later process reads them without looking up
    the float32 levels."""
    from app.textures.maps import PreparedLevels, upload_bytes, upload_levels

    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("PBS_CACHE", raising=False)
    normal, mr = images()
    tex = normal_roughness_map(normal, 0.8, 0.9, mr, "variance")
    assert isinstance(tex.levels, PreparedLevels)
    cache = prepared_cache()
    assert cache.events == []  # nothing looked up until a level is wanted
    assert upload_bytes(tex) == 4 * 2 * sum(  # declared: known before a level is built
        max(1, 37 >> k) * max(1, 29 >> k) for k in range(6)
    )
    assert cache.events == []
    half = upload_levels(tex)
    assert cache.events == ["built"]  # the float16 rows alone: the float32 chain not kept
    assert upload_bytes(tex) == sum(h.nbytes for h in half)
    cache.clear_memory()
    again = normal_roughness_map(normal, 0.8, 0.9, mr, "variance")
    half_again = upload_levels(again)
    assert cache.events[1:] == ["disk"]  # the float16 entry alone
    assert len(list((tmp_path / "textures").glob("*.npy"))) == 1
    assert all(a.tobytes() == b.tobytes() for a, b in zip(half, half_again, strict=True))
    # made directly (mips.chain_levels' rows_up_float16), the cast of the float32 levels
    for level, h in zip(tex.levels, half, strict=True):
        assert h.dtype == np.float16 and h.flags.c_contiguous
        assert h.tobytes() == np.ascontiguousarray(level[::-1], np.float16).tobytes()
    plain = Texture([np.asarray(level) for level in tex.levels])  # not prepared: converted
    assert all(a.tobytes() == b.tobytes() for a, b in zip(half, upload_levels(plain), strict=True))


def test_colour_texels_kept_and_file_not_decoded_again(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A colour map's RGBA texels are kept by its file's content: a later process gets the
    same texels with the image left undecoded."""
    from app.textures import decoded, maps

    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("PBS_CACHE", raising=False)
    monkeypatch.setattr(decoded, "_IMAGES", type(decoded._IMAGES)())
    data = _jpeg(5)
    first = maps.colour_texture(maps.open_image(data))
    cache = prepared_cache()
    assert cache.events[-1] == "built"
    cache.clear_memory()
    decoded.forget()  # the next process
    image = maps.open_image(data)
    again = maps.colour_texture(image)
    assert cache.events[-1] == "disk"
    assert _undecoded(image)  # the texels came from the cache, not the decoder
    assert again.source_key == first.source_key is not None
    assert again.levels[0].dtype == np.uint8 and again.levels[0].shape == (24, 40, 4)
    assert np.array_equal(again.levels[0], first.levels[0])
    assert np.array_equal(first.levels[0], np.asarray(image.convert("RGBA")))


def test_prepare_looks_up_an_entry_in_the_background(tmp_path: Path) -> None:
    """``prepare`` does ``arrays``'s lookup on the background thread: a kept entry read
    from disk, a missing one built there (and kept: the lookup after it is a memory hit),
    a build's exception raised by the future."""
    cache = PreparedCache(tmp_path)
    cache.arrays("test", ("kept",), lambda: [np.arange(5.0)])
    cache.clear_memory()
    kept = cache.prepare("test", ("kept",), lambda: [])
    assert np.array_equal(kept.result(), [np.arange(5.0)])
    assert cache.events == ["built", "disk"]
    built = cache.prepare("test", ("missing",), lambda: [np.zeros(2)])
    assert np.array_equal(built.result(), [np.zeros(2)])
    assert cache.events[-1] == "built"
    cache.arrays("test", ("missing",), lambda: [])
    assert cache.events[-1] == "memory"

    def broken() -> list[np.ndarray]:
        raise ValueError("not an image")

    with pytest.raises(ValueError, match="not an image"):
        cache.prepare("test", ("broken",), broken).result()


def test_kept_reads_and_never_builds(tmp_path: Path) -> None:
    """``kept`` answers an entry kept in memory, on disk or in a seed (read-only, as
    ``arrays`` answers it) and None where there is none, without building or storing
    anything; ``prepare_kept`` does it on the background thread; a cache that is off keeps
    nothing."""
    seed = PreparedCache(tmp_path / "seed")
    seed.arrays("test", ("seeded",), lambda: [np.ones(3)])
    seed.flush()
    cache = PreparedCache(tmp_path / "own", seeds=[tmp_path / "seed"])
    cache.arrays("test", ("kept",), lambda: [np.arange(4.0)])
    cache.flush()
    assert cache.kept("test", ("missing",)) is None
    assert cache.events == ["built"] and not cache.holds("test", ("missing",))
    (held,) = cache.kept("test", ("kept",))
    assert np.array_equal(held, np.arange(4.0)) and not held.flags.writeable
    assert cache.events[-1] == "memory"
    cache.clear_memory()
    assert np.array_equal(cache.prepare_kept("test", ("kept",)).result()[0], np.arange(4.0))
    assert cache.events[-1] == "disk"
    assert cache.prepare_kept("test", ("missing",)).result() is None
    assert np.array_equal(cache.kept("test", ("seeded",))[0], np.ones(3))
    assert cache.events[-1] == "seed"
    off = PreparedCache(tmp_path / "own", enabled=False)
    assert off.kept("test", ("kept",)) is None


@pytest.mark.parametrize("fails", [False, True])
def test_an_entry_being_built_is_waited_for_not_built_again(tmp_path: Path, fails: bool) -> None:
    """Two threads ask for one entry at once: the second waits for the first one's build
    and gets its arrays (or its exception), and nothing is built twice; once the build is
    over, a new miss builds again (an exception is not kept)."""
    import threading

    cache = PreparedCache(tmp_path)
    started, release = threading.Event(), threading.Event()
    builds: list[str] = []

    def build() -> list[np.ndarray]:
        builds.append(threading.current_thread().name)
        started.set()
        release.wait(10)
        if fails:
            raise ValueError("the build failed")
        return [np.arange(5.0)]

    got: dict[str, object] = {}

    def ask(name: str) -> None:
        try:
            got[name] = cache.arrays("test", ("shared",), build)[0]
        except ValueError as exc:
            got[name] = exc

    first = threading.Thread(target=ask, args=("first",), name="first")
    first.start()
    assert started.wait(10)
    second = threading.Thread(target=ask, args=("second",), name="second")
    second.start()
    second.join(0.2)
    assert second.is_alive()  # waiting for the first build, not building its own
    release.set()
    first.join(10)
    second.join(10)
    assert builds == ["first"]
    if fails:
        assert all(isinstance(got[n], ValueError) for n in ("first", "second"))
        cache.arrays("test", ("shared",), lambda: [np.zeros(2)])  # built anew
        assert cache.events[-1] == "built"
    else:
        assert got["first"] is got["second"] and np.array_equal(got["first"], np.arange(5.0))
        assert cache.events == ["built"]


@pytest.mark.parametrize("method", ["none", "variance"])
def test_declared_upload_bytes_are_the_built_levels(
    method: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A prepared map's GL bytes (what the memory check counts before anything is built)
    are those of the levels it builds: a chain with and without mips, a channel's mips,
    a chain from the roughness image alone."""
    from app.textures.maps import upload_bytes, upload_levels

    monkeypatch.setenv("PBS_CACHE", "off")
    normal, mr = images()
    for tex in (
        normal_roughness_map(normal, 1.0, 0.5, mr, method),
        normal_roughness_map(None, 1.0, 0.5, mr.resize((5, 3)), method),
        channel_texture(mr, 2),
    ):
        assert upload_bytes(tex) == sum(level.nbytes for level in upload_levels(tex))


def test_seed_entry_is_read_never_written(tmp_path: Path) -> None:
    """A read-only seed folder (an installation's entries) answers a lookup the disk level
    misses; nothing is written to the cache or the seed, and an unreadable seed entry is
    skipped (built, the seed file left as it was)."""
    made = PreparedCache(tmp_path / "made")
    built = made.arrays("k", ("x",), lambda: [np.arange(6.0)])
    made.flush()
    seed = tmp_path / "made"
    cache = PreparedCache(tmp_path / "user", seeds=[tmp_path / "none", seed])
    got = cache.arrays("k", ("x",), lambda: [np.zeros(6)])
    cache.flush()
    assert cache.events == ["seed"]
    assert np.array_equal(got[0], built[0])
    assert not (tmp_path / "user").exists()
    (entry,) = seed.glob("*.npy")
    entry.write_bytes(entry.read_bytes()[:-8] + b"corrupt!")
    again = PreparedCache(tmp_path / "user2", seeds=[seed])
    assert np.array_equal(again.arrays("k", ("x",), lambda: [np.ones(6)])[0], np.ones(6))
    assert again.events == ["built"] and entry.is_file()


def test_seed_directories(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    import os
    import sys

    monkeypatch.setenv("PBS_CACHE_SEED", f"{tmp_path / 'a'}{os.pathsep}{tmp_path / 'b'}")
    assert cache_keys.seed_directories() == [tmp_path / "a", tmp_path / "b"]
    monkeypatch.setenv("PBS_CACHE_SEED", "")
    assert cache_keys.seed_directories() == []
    monkeypatch.delenv("PBS_CACHE_SEED")
    assert cache_keys.seed_directories() == [Path(sys.prefix) / "share/pbs/prepared"]


def test_seeded_environment_is_not_prefiltered_again(
    gl_egl, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """app/render/prepared_seed.py writes the bundled environments' levels; a process with
    an empty cache reads them from the seed, the same arrays the prefilter makes."""
    from app.gl.shaders import ShaderCache
    from app.render import ibl, prepared_seed
    from app.textures.environment import environment_map

    monkeypatch.setattr(ibl, "_SETTINGS", [16, 8])  # a small prefilter: the same path
    written = prepared_seed.seed(tmp_path / "seed")
    assert len(written) == len(prepared_seed.BUNDLED)
    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path / "empty"))
    monkeypatch.setenv("PBS_CACHE_SEED", str(tmp_path / "seed"))
    monkeypatch.delenv("PBS_CACHE", raising=False)
    ibl.clear_cache()
    shaders = ShaderCache(gl_egl.ctx)
    try:
        seeded = ibl.prepared_prefilter(gl_egl.ctx, shaders, environment_map("studio"), 16, 8)
        assert prepared_cache().events == ["seed"]
        ibl.clear_cache()
        made = ibl.prefilter(gl_egl.ctx, shaders, environment_map("studio"), 16, 8)
    finally:
        shaders.release()
    assert all(np.array_equal(a, b) for a, b in zip(seeded, made, strict=True))


def test_float16_levels_converted_in_bands_are_the_cast() -> None:
    """``float16_rows_up`` (two threads, bands of rows) gives the bits of the one-call cast
    of the rows flipped: rounding, subnormals and overflow alike."""
    import warnings

    from app.textures.mips import float16_rows_up

    rng = np.random.default_rng(3)
    for shape in [(1030, 300, 4), (5, 3, 1), (1, 1, 4)]:
        scale = rng.choice([1e-7, 1e-5, 1.0, 7e4], shape)
        level = (rng.standard_normal(shape) * scale).astype(np.float32)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # overflow to inf, as the cast
            got = float16_rows_up(level)
            want = np.ascontiguousarray(level[::-1], np.float16)
        assert (
            got.flags.c_contiguous
            and got.view(np.uint16).tobytes() == want.view(np.uint16).tobytes()
        )


def test_kept_maps_upload_without_moderngl_data_calls(
    gl_egl, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A glTF map's texels and a colour map's GL mips go through ctypes (which lets go of
    the GIL while llvmpipe copies and filters, so the cache's background thread goes on),
    never through moderngl's ``build_mipmaps``, ``read`` or a texture made with data
    (which hold it); the colour map's levels are those of the path that draws them on an
    upload of the texels alone, the variance chain the CPU's to float16's rounding."""
    import io

    import moderngl

    from app.render.texture_upload import read_level, upload_texture
    from app.textures.maps import colour_texture, open_image

    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("PBS_CACHE", raising=False)
    normal, mr = images(11)
    out = io.BytesIO()
    normal.save(out, "PNG")
    tex = colour_texture(open_image(out.getvalue()))
    chain = normal_roughness_map(normal, 1.0, 1.0, mr, "variance")
    reference = upload_texture(gl_egl.ctx, Texture([tex.levels[0]], srgb=True))
    made_with_data = gl_egl.ctx.texture

    def no_data(*args, **kwargs):
        data = args[2] if len(args) > 2 else kwargs.get("data")
        assert data is None, "a texture made with its data holds the GIL"
        return made_with_data(*args, **kwargs)

    def refused(*args, **kwargs):
        raise AssertionError("holds the GIL")

    monkeypatch.setattr(gl_egl.ctx, "texture", no_data)
    monkeypatch.setattr(moderngl.Texture, "build_mipmaps", refused)
    monkeypatch.setattr(moderngl.Texture, "read", refused)
    made = [upload_texture(gl_egl.ctx, t) for t in (tex, chain)]
    monkeypatch.undo()
    try:
        for k in range(max(tex.levels[0].shape[:2]).bit_length()):
            assert np.array_equal(read_level(made[0], k), read_level(reference, k)), k
        want = chain.levels.upload_levels()  # the CPU's float64 chain: the GL's to float16
        for k, level in enumerate(want):
            drawn = read_level(made[1], k).astype(np.float64)
            assert np.all(np.abs(drawn - level) <= np.abs(level) * 2.0**-10 + 2.0**-24), k
    finally:
        for t in (*made, reference):
            t.release()


def test_colour_maps_uploaded_before_prepared_chains(
    gl_egl, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``TextureUploads.upload_ready_first``: the maps with nothing to wait for (colour)
    go to the GL before the prepared chains the background thread may still be making,
    each once; a drawable's later ``get`` finds them made."""
    from app.render import texture_upload

    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path))
    normal, mr = images(12)
    chain = normal_roughness_map(normal, 1.0, 1.0, mr, "variance")
    metallic = channel_texture(mr, 2)
    colour = Texture([np.zeros((4, 4, 4), np.uint8)], srgb=True)
    order: list[Texture] = []
    upload = texture_upload.upload_texture

    def recorded(ctx, tex, shaders=None):
        order.append(tex)
        return upload(ctx, tex, shaders)

    monkeypatch.setattr(texture_upload, "upload_texture", recorded)
    uploads = texture_upload.TextureUploads(gl_egl.ctx)
    try:
        uploads.upload_ready_first([chain, metallic, colour, chain])
        assert order == [colour, chain, metallic]
        assert uploads.get(chain) is uploads.get(chain) and len(order) == 3
    finally:
        uploads.release()


def test_gltf_material_maps_prepared_from_when_read(tmp_path: Path) -> None:
    """A glTF material's prepared maps start on the cache's background thread as the
    material is read, before any part is built: the metallic mips; not the variance
    normal/roughness chain, which the GL draws at its upload (app/render/normal_chain.py)
    where the cache does not hold its levels, and which is read there where it does."""
    import pygltflib

    from app.scene.geometry import _DEFAULT_MATERIAL
    from app.scene.gltf import GltfFile
    from tests.gltf_builder import GltfBuilder

    normal, mr = images(13)
    b = GltfBuilder()
    pbr = pygltflib.PbrMetallicRoughness(
        metallicRoughnessTexture=pygltflib.TextureInfo(index=b.texture(mr))
    )
    material = pygltflib.Material(
        pbrMetallicRoughness=pbr,
        normalTexture=pygltflib.NormalMaterialTexture(index=b.texture(normal)),
    )
    b.quad(material=b.material(material))
    layer = GltfFile(b.save(tmp_path / "maps.glb")).layer(0, _DEFAULT_MATERIAL, "variance")
    assert layer.maps["metallic"].levels.prefetched()
    chain = layer.maps["normal_roughness"].levels
    assert chain.gl_source is not None and not chain.prefetched()


def test_colour_texels_kept_rows_up_are_convert_rgba(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A colour map's kept RGBA8 texels (rows bottom first, read back to front) are
    ``convert("RGBA")``'s, from the cache and from disk: a decoded RGB image's raw bytes
    where their 4th byte is 255, and also for an RGB image whose 4th byte is not (made in
    the process, not decoded) and an RGBA one."""
    from app.textures.maps import SOURCE_DIGEST, colour_texture

    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("PBS_CACHE", raising=False)
    rng = np.random.default_rng(5)
    decoded = Image.fromarray(rng.integers(0, 256, (7, 5, 3), dtype=np.uint8), "RGB")
    made = Image.new("RGB", (5, 7))  # black: Pillow leaves its 4th bytes 0
    rgba = Image.fromarray(rng.integers(0, 256, (7, 5, 4), dtype=np.uint8), "RGBA")
    for k, image in enumerate((decoded, made, rgba)):
        image.info[SOURCE_DIGEST] = f"digest {k}"
        want = np.asarray(image.convert("RGBA"))
        assert np.array_equal(colour_texture(image).levels[0], want), image.mode
        prepared_cache().clear_memory()
        assert np.array_equal(colour_texture(image).levels[0], want), image.mode


def test_entry_read_where_it_cannot_be_mapped(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Entries are mapped (no copy); where the file system refuses the mapping, the entry
    is read instead, not taken for a corrupt one and rebuilt."""
    monkeypatch.delenv("PBS_CACHE", raising=False)
    first = chain(tmp_path, monkeypatch)
    cache = prepared_cache()
    cache.clear_memory()
    load = np.load

    def unmappable(path: Path, mmap_mode: str | None = None, **kwargs: object) -> np.ndarray:
        if mmap_mode is not None:
            raise OSError("mmap refused")
        return load(path, **kwargs)

    monkeypatch.setattr(np, "load", unmappable)
    again = chain(tmp_path, monkeypatch)
    assert cache.events[-1] == "disk"
    assert all(np.array_equal(a, b) for a, b in zip(first, again, strict=True))


def test_chain_written_at_the_first_draw(gl_egl, tmp_path: Path, monkeypatch) -> None:
    """A pass's prepared map still being made gets its texture (its storage) at once and
    its levels at the first draw that binds it (``TextureUploads.finish``): the pass is
    built without waiting for the chain, and the texture holds every level after."""
    import threading

    from app.render.texture_upload import TextureUploads, read_level
    from app.textures.maps import PreparedLevels

    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("PBS_CACHE", raising=False)
    go = threading.Event()
    rng = np.random.default_rng(7)
    levels = [rng.uniform(0.0, 1.0, (16 >> k, 8 >> k if k < 4 else 1, 4)) for k in range(5)]
    levels = [np.ascontiguousarray(lv.astype(np.float32)) for lv in levels]

    built: list[bool] = []

    def build() -> list[np.ndarray]:
        go.wait(2.0)
        built.append(True)
        return levels

    tex = Texture(PreparedLevels("test chain", ("test", tmp_path.name), build, (16, 8, 4, False)))
    tex.levels.prefetch()
    uploads = TextureUploads(gl_egl.ctx)
    try:
        uploads.upload_ready_first([tex], later=True)
        assert not built  # returned while the chain is still being made
        go.set()
        uploads.finish()
        gl_tex = uploads.get(tex)
        for k, level in enumerate(levels):
            want = np.ascontiguousarray(level[::-1], np.float16)
            assert np.array_equal(read_level(gl_tex, k), want), k
    finally:
        go.set()
        uploads.release()


def _layout() -> list[tuple[tuple[int, ...], type]]:
    return [((5, 3, 4), np.float16), ((7,), np.uint8), ((2, 2, 4), np.float16)]


def _fill(into: tuple[np.ndarray, ...]) -> None:
    for k, a in enumerate(into):
        a[...] = (np.arange(a.size) * (k + 3)).reshape(a.shape) % 250


def test_entry_filled_in_place_is_what_pack_entry_holds(tmp_path: Path) -> None:
    """An entry whose layout is known before its data is made in its file (``filled``):
    the arrays handed out are the file's pages, and the finished file reads back as an
    entry written whole would (checksum, dtypes, shapes, values) from disk and in
    another process's view; a second lookup reads it instead of filling again."""
    cache = PreparedCache(tmp_path)
    calls: list[int] = []

    def fill(into: tuple[np.ndarray, ...]) -> None:
        calls.append(1)
        assert all(a.flags.writeable and a.flags.c_contiguous for a in into)
        _fill(into)

    made = cache.filled("test", ("in place",), _layout(), fill)
    assert calls == [1] and cache.events == ["built"]
    assert all(not a.flags.writeable for a in made)
    assert all(isinstance(_root(a), mmap.mmap) for a in made)  # the file's pages
    cache.flush()
    (path,) = tmp_path.glob("*.npy")  # renamed into place: no temporary left
    expected = [np.empty(shape, dtype) for shape, dtype in _layout()]
    _fill(tuple(expected))
    read = cache_module.unpack_entry(np.load(path, allow_pickle=False))
    for a, b, c in zip(made, read, expected, strict=True):
        assert a.dtype == b.dtype == c.dtype and a.shape == b.shape == c.shape
        assert np.array_equal(a, c) and np.array_equal(b, c)
    assert cache.filled("test", ("in place",), _layout(), fill) is made  # from memory
    cache.clear_memory()
    again = cache.filled("test", ("in place",), _layout(), fill)
    assert calls == [1] and cache.events[-1] == "disk"
    assert all(np.array_equal(a, c) for a, c in zip(again, expected, strict=True))
    # A flipped byte in its data is caught by the checksum the writer added.
    data = bytearray(path.read_bytes())
    data[-3] ^= 0xFF
    path.write_bytes(bytes(data))
    cache.clear_memory()
    cache.filled("test", ("in place",), _layout(), fill)
    assert cache.events[-2:] == ["rebuilt", "built"] and calls == [1, 1]


def test_entry_filled_in_memory_without_a_directory_or_a_mapping(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``filled`` without a directory fills arrays of its own; where the file cannot be
    mapped it fills them in memory and the writer writes them, read back the same."""
    for cache in (PreparedCache(None), PreparedCache(tmp_path, enabled=False)):
        made = cache.filled("test", ("x",), _layout(), _fill)
        assert [a.shape for a in made] == [shape for shape, _ in _layout()]
    monkeypatch.setattr(cache_module.mmap, "mmap", _refuse_mapping)
    cache = PreparedCache(tmp_path)
    made = cache.filled("test", ("y",), _layout(), _fill)
    cache.flush()
    (path,) = tmp_path.glob("*.npy")
    assert not list(tmp_path.glob(f"{cache_module._TEMPORARY}*"))  # none left behind
    read = cache_module.unpack_entry(np.load(path, allow_pickle=False))
    assert all(np.array_equal(a, b) for a, b in zip(made, read, strict=True))


def _root(a: np.ndarray) -> object:
    """The object that owns an array's memory (the end of its chain of bases)."""
    base: object = a
    while isinstance(base, np.ndarray) and base.base is not None:
        base = base.base
    return base.obj if isinstance(base, memoryview) else base


def _refuse_mapping(*args: object, **kwargs: object) -> object:
    raise OSError("mapping refused")


def test_entry_whose_fill_fails_leaves_no_file(tmp_path: Path) -> None:
    """A fill that raises: the error reaches the caller, no entry or temporary is left,
    and the next lookup fills again."""
    cache = PreparedCache(tmp_path)

    def broken(into: tuple[np.ndarray, ...]) -> None:
        into[0][...] = 1
        raise RuntimeError("the GL refused")

    with pytest.raises(RuntimeError, match="refused"):
        cache.filled("test", ("z",), _layout(), broken)
    cache.flush()
    assert not list(tmp_path.iterdir())
    made = cache.filled("test", ("z",), _layout(), _fill)
    assert cache.events == ["built"] and made[1][4] == (4 * 4) % 250


def test_one_frame_keeps_no_decoded_image(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``keep_decoded_images(False)`` (a one-frame ``pbs render``): an image is not kept
    for a later load, so a colour map's image is freed once its texels are in their
    entry; kept again (the default), a second open of the same bytes is the same image."""
    import gc
    import weakref

    from app.textures import decoded, maps

    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path))
    monkeypatch.delenv("PBS_CACHE", raising=False)
    monkeypatch.setattr(decoded, "_IMAGES", type(decoded._IMAGES)())
    data = _jpeg(6)
    before = decoded.keep_decoded_images(False)
    try:
        image = maps.open_image(data)
        texture = maps.colour_texture(image)
        assert not decoded.holding()
        freed = weakref.ref(image)
        del image
        gc.collect()
        assert freed() is None  # nothing but the caller held it: its texels are gone
        assert texture.levels[0].shape == (24, 40, 4)  # the entry's texels stay
    finally:
        assert decoded.keep_decoded_images(before) is False
    other = _jpeg(7)  # bytes this process has not decoded (those above it has)
    first = maps.open_image(other)
    maps.colour_texture(first)
    assert maps.open_image(other) is first  # kept: a later load reuses it


def test_a_still_render_keeps_no_decoded_image_and_restores_the_setting(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``pbs render`` of one frame turns the keeping off while it renders and back to what
    it was when it returns (a test or the API may load again in the same process)."""
    from app import cli
    from app.resources import scenes_dir
    from app.textures import decoded

    seen: list[bool] = []
    keep = decoded.keep_decoded_images

    def recorded(value: bool) -> bool:
        seen.append(value)
        return keep(value)

    monkeypatch.setattr(decoded, "keep_decoded_images", recorded)
    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path / "cache"))
    model = scenes_dir() / "meshes" / "material_sampler.glb"
    out = tmp_path / "still.png"
    assert cli.main(["render", str(model), "-o", str(out), "--size", "48x32", "-q"]) == 0
    assert out.is_file()
    assert seen == [False, True] and decoded._KEEPING[0] is True


@pytest.mark.parametrize("way", ["written", "in place"])
def test_a_failed_write_leaves_no_file_and_keeps_the_arrays(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture, way: str
) -> None:
    """A disk that fills while an entry is written (``arrays``: written by the writer;
    ``filled``: finished in place): one warning, no entry and no temporary file left, and
    the caller keeps the arrays it was handed (the cache is an optimisation)."""
    import errno
    import logging

    def full(*args: object) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")

    if way == "written":
        monkeypatch.setattr(cache_module, "write_entry", full)
    else:
        monkeypatch.setattr(cache_module._InPlace, "finish", full)
    cache = PreparedCache(tmp_path)
    expected = [np.empty(shape, dtype) for shape, dtype in _layout()]
    _fill(tuple(expected))
    with caplog.at_level(logging.WARNING, logger=cache_module.__name__):
        if way == "written":
            made = cache.arrays("test", ("full", way), lambda: [a.copy() for a in expected])
        else:
            made = cache.filled("test", ("full", way), _layout(), _fill)
        cache.flush()
    assert all(np.array_equal(a, b) for a, b in zip(made, expected, strict=True))
    assert [r.message for r in caplog.records if "cannot write" in r.message]
    assert not list(tmp_path.iterdir())  # neither the entry nor a temporary


def test_entry_made_in_memory_where_its_blocks_cannot_be_reserved(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A full disk when an entry would be made in place: its blocks are reserved before
    the file is mapped (a write into a mapped sparse file on a full disk is a SIGBUS), so
    the refusal is an OSError, and the arrays are filled in memory; no temporary is left."""
    import errno

    def full(*args: object) -> None:
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(cache_module.os, "posix_fallocate", full)
    cache = PreparedCache(tmp_path)
    made = cache.filled("test", ("full",), _layout(), _fill)
    assert all(isinstance(_root(a), np.ndarray) for a in made)  # not the file's pages
    cache.flush()
    assert not list(tmp_path.glob(f"{cache_module._TEMPORARY}*"))
    expected = [np.empty(shape, dtype) for shape, dtype in _layout()]
    _fill(tuple(expected))
    assert all(np.array_equal(a, b) for a, b in zip(made, expected, strict=True))


def test_held_writes_wait_for_their_release_and_never_block_a_wait(tmp_path: Path) -> None:
    """Within ``writes_held`` the writer leaves the entries handed to it queued: nothing is
    on disk until ``release_writes``; a wait for a held entry (its key read again from
    disk, ``flush``) lets them go first instead of waiting on itself; the block's end lets
    go what is still held."""
    from concurrent.futures import TimeoutError as FutureTimeout

    from app.textures import background

    cache = PreparedCache(tmp_path / "a")
    with background.writes_held():
        cache.arrays("test", ("one",), lambda: [np.arange(3.0)])
        cache.arrays("test", ("two",), lambda: [np.ones(2)])
        with pytest.raises(FutureTimeout):  # unheld, a 24-byte entry is written at once
            cache._writing[entry_key("test", ("one",))].result(timeout=0.5)
        assert list(cache.directory.glob("*.npy")) == []
        background.release_writes()
        cache.flush()
        assert len(list(cache.directory.glob("*.npy"))) == 2
    # a lookup of a held entry's key from disk releases it rather than wait on itself
    other = PreparedCache(tmp_path / "b")
    with background.writes_held():
        other.arrays("test", ("three",), lambda: [np.zeros(4)])
        other._memory.clear()  # as another lookup meets it: only on disk, being written
        (again,) = other.arrays("test", ("three",), lambda: [np.full(4, 9.0)])
        assert np.array_equal(again, np.zeros(4)) and other.events[-1] == "disk"
    # the block's end lets go what is still held
    last = PreparedCache(tmp_path / "c")
    with background.writes_held():
        last.arrays("test", ("four",), lambda: [np.zeros(1)])
        held = last._writing[entry_key("test", ("four",))]
    held.result(timeout=10.0)
    assert len(list(last.directory.glob("*.npy"))) == 1


def test_a_still_render_holds_the_cache_writes_while_its_scene_is_read(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``pbs render`` of one frame holds the prepared-texture cache's writes while the
    scene is read (its entries queued, none on disk) and lets them go when the renderer
    is set up: every entry is on disk when the command returns, and writes are free after
    it, as before it."""
    from app import cli
    from app.render import renderer as renderer_module
    from app.resources import scenes_dir
    from app.scene import sources
    from app.textures import background

    seen: dict[str, object] = {}
    read, init = sources.scene_from, renderer_module.Renderer.__init__
    folder = tmp_path / "cache" / "textures"

    def entries() -> list[Path]:  # written ones, not the files being filled in place
        return [p for p in folder.glob("*.npy") if not p.name.startswith(cache_module._TEMPORARY)]

    def reading(*args, **kwargs):
        loaded = read(*args, **kwargs)
        seen["free after the read"] = background._WRITES_FREE.is_set()
        seen["on disk after the read"] = len(entries())
        return loaded

    def setting_up(self, *args, **kwargs):
        seen["free at the set-up"] = background._WRITES_FREE.is_set()
        return init(self, *args, **kwargs)

    monkeypatch.setattr(sources, "scene_from", reading)
    monkeypatch.setattr(renderer_module.Renderer, "__init__", setting_up)
    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path / "cache"))
    model = scenes_dir() / "meshes" / "material_sampler.glb"
    out = tmp_path / "still.png"
    assert cli.main(["render", str(model), "-o", str(out), "--size", "48x32", "-q"]) == 0
    assert seen == {
        "free after the read": False,
        "on disk after the read": 0,
        "free at the set-up": True,
    }
    prepared_cache().flush()
    assert len(entries()) >= 4 and background._WRITES_FREE.is_set()
