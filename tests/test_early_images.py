"""A still render starts decoding a glTF file's whole-decoded images (normal,
metallic-roughness, occlusion, and the colour maps that are no JPEG) while it imports its
modules (app/scene/early_images.py, app/textures/early.py): which images, the reader
taking the decoded image instead of decoding the same bytes again, a broken or a known
image left to the reader, and a PNG's image data joined into one chunk."""

from __future__ import annotations

import io
import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pygltflib
import pytest
from PIL import Image

from app.scene.early_images import whole_image_uris
from app.textures import decoded, early, maps
from app.untrusted.budget import Budget
from app.untrusted.policy import Limits
from tests.gltf_builder import GltfBuilder, png_rgb


def _texture(b: GltfBuilder, folder: Path, colour: tuple[int, int, int], how: str = "file") -> int:
    source = b.image(png_rgb(colour, 8), how, folder)
    b.doc.textures.append(pygltflib.Texture(source=source))
    return len(b.doc.textures) - 1


def test_whole_image_uris(tmp_path: Path) -> None:
    """The metallic-roughness, normal and occlusion images, in the material's order, each
    once; not the colour maps (decoded reduced for a still frame), nor a data: URI."""
    b = GltfBuilder()
    base, mr, normal, occlusion, emissive = (
        _texture(b, tmp_path, (10 * k, 20, 30)) for k in range(5)
    )
    inline = _texture(b, tmp_path, (1, 2, 3), how="data")
    info = pygltflib.TextureInfo
    first = pygltflib.Material(
        pbrMetallicRoughness=pygltflib.PbrMetallicRoughness(
            baseColorTexture=info(index=base), metallicRoughnessTexture=info(index=mr)
        ),
        normalTexture=pygltflib.NormalMaterialTexture(index=normal),
        occlusionTexture=pygltflib.OcclusionTextureInfo(index=occlusion),
        emissiveTexture=info(index=emissive),
    )
    second = pygltflib.Material(
        normalTexture=pygltflib.NormalMaterialTexture(index=inline),
        occlusionTexture=pygltflib.OcclusionTextureInfo(index=mr),
    )
    b.quad(material=b.material(first))
    b.material(second)
    path = b.save(tmp_path / "model.gltf")
    assert whole_image_uris(path) == ["image1.png", "image2.png", "image3.png"]


def _png(seed: int) -> bytes:
    texels = np.random.default_rng(seed).integers(0, 256, (16, 16, 3), np.uint8)
    data = io.BytesIO()
    Image.fromarray(texels).save(data, format="PNG")
    return data.getvalue()


def test_reader_takes_the_early_image() -> None:
    """``open_image`` of bytes decoded early returns that very image, its texels those of
    a decode of its own; once taken, the next image of other bytes decodes as always."""
    import hashlib

    data = _png(1)
    early.decode_early(data, Budget())
    decoded = early._EARLY[hashlib.sha256(data).hexdigest()].result()
    image = maps.open_image(data, Budget(), None, decode_later=True)
    maps.wait_decoded(image)
    assert image is decoded
    own = Image.open(io.BytesIO(data))
    np.testing.assert_array_equal(np.asarray(image), np.asarray(own))
    assert early.take(image.info[maps.SOURCE_DIGEST]) is None  # taken once


def test_early_image_left_to_the_reader() -> None:
    """Nothing is kept of bytes that decoded before (the cache's record: a warm render
    decodes no whole image), of an image past the budget's side, nor of one that fails to
    decode (the reader decodes it and names it)."""
    import hashlib

    data = _png(2)
    digest = hashlib.sha256(data).hexdigest()
    early.decode_early(data, Budget(Limits(max_texture_side=8)))  # 16 texels a side
    assert early.take(digest) is None
    broken = data[: len(data) // 2]
    early.decode_early(broken, Budget())
    assert early.take(hashlib.sha256(broken).hexdigest()) is None
    maps.wait_decoded(maps.open_image(data, Budget(), None, decode_later=True))  # recorded
    early._TAKEN.discard(digest)  # asked for above: its own reason to decode none
    early.decode_early(data, Budget())
    assert early.take(digest) is None


def test_no_early_decode_after_the_reader_asked() -> None:
    """Bytes the reader asked for before the early threads reached them (it decoded them
    itself) are not decoded early afterwards, nor kept."""
    import hashlib

    data = _png(6)
    digest = hashlib.sha256(data).hexdigest()
    assert early.take(digest) is None  # the reader came first
    early.decode_early(data, Budget())
    assert digest not in early._EARLY


def test_broken_gltf_image_named(tmp_path: Path, capsys, monkeypatch) -> None:
    """A .gltf whose normal map file is cut short: the early start tries it (and keeps
    nothing), and the render still refuses it by its key, exit 2, no output."""
    import threading

    from tests.test_bad_input import _check, _run_inproc

    tried: list[int] = []
    decode = early.decode_early
    monkeypatch.setattr(
        early, "decode_early", lambda data, b: tried.append(len(data)) or decode(data, b)
    )
    b = GltfBuilder()
    colour = _texture(b, tmp_path, (200, 120, 40))
    broken = _png(3)
    (tmp_path / "broken.png").write_bytes(broken[: len(broken) // 2])
    b.doc.images.append(pygltflib.Image(uri="broken.png"))
    b.doc.textures.append(pygltflib.Texture(source=len(b.doc.images) - 1))
    material = pygltflib.Material(
        pbrMetallicRoughness=pygltflib.PbrMetallicRoughness(
            baseColorTexture=pygltflib.TextureInfo(index=colour)
        ),
        normalTexture=pygltflib.NormalMaterialTexture(index=len(b.doc.textures) - 1),
    )
    b.quad(material=b.material(material))
    path = b.save(tmp_path / "model.gltf")
    out = tmp_path / "out"
    out.mkdir()
    rc, err = _run_inproc(capsys, str(path), "-o", str(out / "x.png"), "--size", "32x24")
    for thread in threading.enumerate():
        if thread.name == "pbs-early-images":
            thread.join(10.0)
    _check(rc, err, out, f"pbs: error: {path}: images[1]:", "is not an image pbs reads")
    # the normal map's file and the base colour (a PNG: decoded whole, so early), on two
    # threads in either order
    assert len(tried) == 2 and len(broken) // 2 in tried


def test_decoders_take_the_whole_bytes() -> None:
    """``open_image`` (and the early decode) hand Pillow's decoder the whole encoded image
    in one call (``early.whole_reads``: the GIL let go for the whole decode), the texels
    those of Pillow's own 64 KiB reads."""
    data = io.BytesIO()
    noise = np.random.default_rng(5).integers(0, 256, (256, 256, 3), np.uint8)
    Image.fromarray(noise).save(data, format="JPEG", quality=95)
    encoded = data.getvalue()
    assert len(encoded) > 65536  # more than one of Pillow's reads
    image = maps.open_image(encoded, Budget(), None)
    assert image.decodermaxblock >= len(encoded)
    own = Image.open(io.BytesIO(encoded))
    np.testing.assert_array_equal(np.asarray(image), np.asarray(own))


def test_colour_maps_decoded_early_unless_jpeg(tmp_path: Path) -> None:
    """The base colour and emissive images are the colour maps a still render decodes
    early, after the filtered maps' images; a JPEG among them is left to the reader, which
    may decode it reduced (libjpeg's DCT scaling)."""
    from app.scene import early_images

    b = GltfBuilder()
    base, emissive, normal = (_texture(b, tmp_path, (10 * k, 20, 30)) for k in range(3))
    info = pygltflib.TextureInfo
    material = pygltflib.Material(
        pbrMetallicRoughness=pygltflib.PbrMetallicRoughness(baseColorTexture=info(index=base)),
        normalTexture=pygltflib.NormalMaterialTexture(index=normal),
        emissiveTexture=info(index=emissive),
    )
    b.quad(material=b.material(material))
    path = b.save(tmp_path / "model.gltf")
    assert whole_image_uris(path) == ["image2.png"]
    assert whole_image_uris(path, early_images._COLOUR_MAPS) == ["image0.png", "image1.png"]
    jpeg = io.BytesIO()
    Image.new("RGB", (8, 8), (200, 10, 10)).save(jpeg, format="JPEG")
    (tmp_path / "image0.png").write_bytes(jpeg.getvalue())  # a JPEG whatever its name says
    (tmp_path / "image1.png").write_bytes(_png(4))
    tried: list[int] = []
    decode = early.decode_early
    try:
        early.decode_early = lambda data, budget: tried.append(len(data))  # type: ignore[assignment]
        for name in ("image0.png", "image1.png"):
            early_images._open(name, path, Budget(), skip_jpeg=True)
    finally:
        early.decode_early = decode  # type: ignore[assignment]
    assert tried == [len(_png(4))]


def _png_chunks(data: bytes) -> list[tuple[bytes, int]]:
    import struct

    chunks, at = [], 8
    while at < len(data):
        length, kind = struct.unpack_from(">I4s", data, at)
        chunks.append((kind, length))
        at += 12 + length
    return chunks


def test_single_idat_same_texels() -> None:
    """``single_idat``: a PNG whose image data spans many IDAT chunks (as libpng writes
    them, 8 KiB each) becomes one IDAT chunk with a valid CRC, and decodes to the same
    texels; bytes that are no PNG, hold one IDAT, or are cut short come back as they
    are."""
    noise = np.random.default_rng(9).integers(0, 256, (96, 80, 3), np.uint8)
    one, split, _ = _split_png(noise)
    joined = early.single_idat(split)
    assert [k for k, _ in _png_chunks(joined)] == [b"IHDR", b"IDAT", b"IEND"]
    for data in (split, joined):
        image = Image.open(io.BytesIO(data))
        image.load()  # Pillow checks each chunk's CRC
        np.testing.assert_array_equal(np.asarray(image), noise)
    assert early.single_idat(one) is one  # one IDAT already
    cut = split[:-30]
    assert early.single_idat(cut) is cut  # cut short: left to the decoder
    assert early.single_idat(b"GIF89a....") == b"GIF89a...."


def test_single_idat_checks_the_joined_stream_once(monkeypatch: pytest.MonkeyPatch) -> None:
    """``single_idat`` computes the joined chunk's CRC in one call over the whole stream,
    not one per chunk: CPython's ``zlib.crc32`` lets go of the GIL for each buffer past
    5 KiB, and a decode thread that checked a 2048² map chunk by chunk waited for the GIL
    hundreds of times beside the main thread's Python."""
    import struct
    import zlib

    noise = np.random.default_rng(12).integers(0, 256, (96, 80, 3), np.uint8)
    _, split, pieces = _split_png(noise)
    sizes: list[int] = []

    def crc32(data, value=0):
        sizes.append(len(data))
        return zlib.crc32(data, value)

    monkeypatch.setattr(early, "zlib", SimpleNamespace(crc32=crc32))
    joined = early.single_idat(split)
    assert len(sizes) <= 2 and max(sizes) > 1000 * (pieces - 1)  # the stream, at once
    at = joined.index(b"IDAT") - 4
    (length,) = struct.unpack_from(">I", joined, at)
    (stored,) = struct.unpack_from(">I", joined, at + 8 + length)
    assert stored == zlib.crc32(joined[at + 4 : at + 8 + length])
    image = Image.open(io.BytesIO(joined))
    image.load()
    np.testing.assert_array_equal(np.asarray(image), noise)


def _split_png(texels: np.ndarray) -> tuple[bytes, bytes, int]:
    """A PNG of ``texels`` as Pillow writes it (one IDAT chunk), the same image with its
    zlib stream split into 1000-byte IDAT chunks, and how many those are (> 20)."""
    import struct
    import zlib

    out = io.BytesIO()
    Image.fromarray(texels).save(out, format="PNG", compress_level=0)
    one = out.getvalue()
    stream = b"".join(
        one[at + 8 : at + 8 + n] for at, (kind, n) in _chunk_offsets(one) if kind == b"IDAT"
    )
    head = b"".join(
        one[at : at + 12 + n] for at, (kind, n) in _chunk_offsets(one) if kind == b"IHDR"
    )
    end = b"\x00\x00\x00\x00IEND\xaeB`\x82"
    pieces = [stream[i : i + 1000] for i in range(0, len(stream), 1000)]
    split = (
        early.PNG_SIGNATURE
        + head
        + b"".join(
            struct.pack(">I", len(p))
            + b"IDAT"
            + p
            + struct.pack(">I", zlib.crc32(p, zlib.crc32(b"IDAT")))
            for p in pieces
        )
        + end
    )
    assert [k for k, _ in _png_chunks(split)].count(b"IDAT") == len(pieces) > 20
    return one, split, len(pieces)


def test_open_image_joins_the_image_data_only_to_decode(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``maps.open_image`` joins a PNG's IDAT chunks (``single_idat``) for the decode it
    makes; where the prepared-texture cache records that these bytes decoded before, the
    image is returned undecoded and nothing is joined (a copy and a checksum of every
    byte, on a warm render's main thread), and its texels, read later, are the same."""
    from app.textures.cache import prepared_cache

    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("PBS_CACHE", raising=False)
    noise = np.random.default_rng(11).integers(0, 256, (96, 88, 3), np.uint8)
    _, split, _ = _split_png(noise)
    joins: list[int] = []

    def counted(data: bytes) -> bytes:
        joins.append(len(data))
        return early.single_idat(data)

    monkeypatch.setattr(maps, "single_idat", counted)
    keeping = decoded.keep_decoded_images(False)  # no process memo: the cache's record alone
    try:
        first = maps.open_image(split, Budget())
        np.testing.assert_array_equal(np.asarray(first), noise)
        assert joins == [len(split)]
        prepared_cache().flush()
        again = maps.open_image(split, Budget())
        assert joins == [len(split)]  # recorded as decoded: not joined
        np.testing.assert_array_equal(np.asarray(again.convert("RGB")), noise)
    finally:
        decoded.keep_decoded_images(keeping)


def _chunk_offsets(data: bytes) -> list[tuple[int, tuple[bytes, int]]]:
    import struct

    out, at = [], 8
    while at < len(data):
        length, kind = struct.unpack_from(">I4s", data, at)
        out.append((at, (kind, length)))
        at += 12 + length
    return out


def test_single_idat_keeps_what_follows_iend_and_bounds_its_work(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Bytes after IEND come back as they are, after the joined chunk; a file of more IDAT
    chunks than ``MAX_IDAT_CHUNKS`` is left as it is (a hostile file's millions of empty
    chunks cost no loop of that length), and so is one of more image data than
    ``MAX_JOINED_BYTES`` (the join's copies are bounded)."""
    import struct
    import zlib

    noise = np.random.default_rng(10).integers(0, 256, (32, 32, 3), np.uint8)
    out = io.BytesIO()
    Image.fromarray(noise).save(out, format="PNG", compress_level=0)
    one = out.getvalue()
    offsets = _chunk_offsets(one)
    stream = b"".join(one[at + 8 : at + 8 + n] for at, (kind, n) in offsets if kind == b"IDAT")
    head = b"".join(one[at : at + 12 + n] for at, (kind, n) in offsets if kind == b"IHDR")

    def chunk(kind: bytes, data: bytes) -> bytes:
        crc = zlib.crc32(data, zlib.crc32(kind))
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", crc)

    pieces = [stream[i : i + 500] for i in range(0, len(stream), 500)]
    trailer = b"trailing bytes that are no chunk"
    split = (
        early.PNG_SIGNATURE + head + b"".join(chunk(b"IDAT", p) for p in pieces)
        + chunk(b"IEND", b"") + trailer
    )  # fmt: skip
    joined = early.single_idat(split)
    assert joined.endswith(chunk(b"IEND", b"") + trailer)
    assert joined.count(b"IDAT") == 1
    image = Image.open(io.BytesIO(joined))
    image.load()
    np.testing.assert_array_equal(np.asarray(image), noise)
    monkeypatch.setattr(early, "MAX_JOINED_BYTES", len(stream) - 1)
    assert early.single_idat(split) is split
    monkeypatch.setattr(early, "MAX_JOINED_BYTES", len(stream))
    assert early.single_idat(split) == joined
    monkeypatch.setattr(early, "MAX_IDAT_CHUNKS", 3)
    assert early.single_idat(split) is split


def test_normal_spread_made_early(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A normal map decoded early also gets the sampled spread that ``auto`` chooses by,
    under the key the reader's ``auto_normal_filter`` looks up (its scale included), so the
    reader finds it kept; a scale the reader would refuse makes none."""
    import hashlib

    from app.scene import early_images
    from app.textures.cache import prepared_cache
    from app.textures.maps import _image_part, _prepared_version, auto_normal_filter

    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("PBS_CACHE", raising=False)
    b = GltfBuilder()
    normal = _texture(b, tmp_path, (120, 130, 250))
    (tmp_path / "image0.png").write_bytes(_png(8))
    material = pygltflib.Material(
        normalTexture=pygltflib.NormalMaterialTexture(index=normal, scale=0.5)
    )
    b.quad(material=b.material(material))
    path = b.save(tmp_path / "model.gltf")
    assert early_images.normal_map_scales(path) == {"image0.png": [0.5]}
    data = (tmp_path / "image0.png").read_bytes()
    digest = hashlib.sha256(data).hexdigest()
    early_images._start(path)
    image = maps.open_image(data, Budget(), "normal", decode_later=True)
    maps.wait_decoded(image)
    parts = (_prepared_version(), _image_part(image), 0.5)
    assert prepared_cache().holds("normal spread", parts)
    events = len(prepared_cache().events)
    assert auto_normal_filter(image, 0.5) == "variance"
    assert prepared_cache().events[events:] == ["memory"]  # found, not made again
    assert early.take(digest) is None  # the reader took the image
    doc = json.loads(path.read_text())
    doc["materials"][0]["normalTexture"]["scale"] = 5e3  # past the reader's bound
    path.write_text(json.dumps(doc))
    assert early_images.normal_map_scales(path) == {}


def test_normal_spread_made_early_after_the_reader_took_the_image(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The reader takes a normal map while its early decode runs; the early thread still
    makes its spread (the reader's call then finds it, or waits for it: the prepared
    cache builds an entry once), under the reader's key."""
    import hashlib

    from app.scene import early_images
    from app.textures.cache import prepared_cache
    from app.textures.maps import auto_normal_filter

    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("PBS_CACHE", raising=False)
    data = _png(9)
    digest = hashlib.sha256(data).hexdigest()
    early.decode_early(data, Budget())
    image = maps.open_image(data, Budget(), "normal", decode_later=True)
    maps.wait_decoded(image)
    assert early.peek(digest) is None and early.decoded(digest) is image  # taken
    events = len(prepared_cache().events)
    early_images._normal_spread(digest, 1.0)
    assert prepared_cache().events[events:] == ["built"]
    assert auto_normal_filter(image, 1.0) in ("lean", "variance")
    assert prepared_cache().events[events + 1 :] == ["memory"]  # found, not made again


def test_colour_levels_made_early(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A colour map decoded early gets its levels from level 1 on made on the early
    thread (``maps.start_colour_levels``); the reader's ``colour_texture`` takes them
    (made once, not again) and they are the bits it makes itself. A map that is no square
    power of two, or a still that samples level 0, leaves them unused."""
    import hashlib

    from app.scene import early_images
    from app.textures import mips

    monkeypatch.setenv("PBS_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.delenv("PBS_CACHE", raising=False)
    texels = np.random.default_rng(12).integers(0, 256, (32, 32, 3), np.uint8)
    encoded = io.BytesIO()
    Image.fromarray(texels).save(encoded, format="PNG")
    data = encoded.getvalue()
    (tmp_path / "image0.png").write_bytes(data)
    b = GltfBuilder()
    b.doc.images.append(pygltflib.Image(uri="image0.png"))
    b.doc.textures.append(pygltflib.Texture(source=len(b.doc.images) - 1))
    info = pygltflib.TextureInfo(index=len(b.doc.textures) - 1)
    material = pygltflib.Material(
        pbrMetallicRoughness=pygltflib.PbrMetallicRoughness(baseColorTexture=info)
    )
    b.quad(material=b.material(material))
    path = b.save(tmp_path / "model.gltf")
    digest = hashlib.sha256(data).hexdigest()
    made: list[tuple[int, ...]] = []
    box = mips.srgb_box_levels

    def counted(level0: np.ndarray) -> list[np.ndarray]:
        made.append(level0.shape)
        return box(level0)

    monkeypatch.setattr(maps, "srgb_box_levels", counted)
    early_images._start(path)
    assert made == [(32, 32, 4)] and digest in maps._EARLY_LEVELS
    image = maps.open_image(data, Budget(), "colour", decode_later=True)
    levels = list(maps.colour_texture(image, 2).levels)
    assert made == [(32, 32, 4)]  # taken, not made again
    assert digest not in maps._EARLY_LEVELS
    rgba = np.dstack([texels, np.full((32, 32), 255, np.uint8)])
    expected = box(rgba[::-1].copy())[2:]
    assert [lv.shape for lv in levels] == [(8, 8, 4), (4, 4, 4), (2, 2, 4), (1, 1, 4)]
    for level, want in zip(levels, expected, strict=True):
        np.testing.assert_array_equal(level, want[::-1])
    odd = Image.fromarray(texels[:, :24])
    odd.info[maps.SOURCE_DIGEST] = "not square"
    maps.start_colour_levels(odd)
    assert "not square" not in maps._EARLY_LEVELS
