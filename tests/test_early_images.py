"""A still render starts decoding a glTF file's whole-decoded images (normal,
metallic-roughness, occlusion) while it imports its modules (app/scene/early_images.py,
app/textures/early.py): which images, and the reader taking the decoded image instead of
decoding the same bytes again, a broken or a known image left to the reader."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pygltflib
from PIL import Image

from app.scene.early_images import whole_image_uris
from app.textures import early, maps
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
    early.decode_early(data, Budget())
    assert early.take(digest) is None


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
    assert tried == [len(broken) // 2]  # the normal map's file alone, not the base colour


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
