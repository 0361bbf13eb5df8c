"""A glTF file's images decode on a pool while the file is read (app/textures/maps.py
``open_image(decode_later=True)``, app/scene/gltf.py): a broken image is still bad input
naming its key, and the first problem in reading order is the one reported."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pygltflib
import pytest
from PIL import Image

from tests.gltf_builder import GltfBuilder, png_rgb
from tests.test_bad_input import _check, _run_inproc, work  # noqa: F401

SIZE = "32x24"


def _truncated_png() -> bytes:
    """A PNG whose header is whole and whose pixel data stops half way: it opens, and
    fails only when it is decoded."""
    noise = np.random.default_rng(3).integers(0, 256, (64, 64, 3), np.uint8)
    data = io.BytesIO()
    Image.fromarray(noise).save(data, format="PNG")
    return data.getvalue()[: len(data.getvalue()) // 2]


def _model(root: Path, scale: float = 1.0) -> Path:
    """A quad whose base colour is a good PNG (images[0]) and whose normal map is a
    truncated one (images[1])."""
    b = GltfBuilder()
    colour = b.texture(png_rgb((200, 120, 40), 8))
    broken = b.view(_truncated_png())
    b.doc.images.append(pygltflib.Image(bufferView=broken, mimeType="image/png"))
    b.doc.textures.append(pygltflib.Texture(source=len(b.doc.images) - 1))
    normal = len(b.doc.textures) - 1
    pbr = pygltflib.PbrMetallicRoughness(baseColorTexture=pygltflib.TextureInfo(index=colour))
    material = pygltflib.Material(
        pbrMetallicRoughness=pbr,
        normalTexture=pygltflib.NormalMaterialTexture(index=normal, scale=scale),
    )
    b.quad(material=b.material(material))
    return b.save(root / "model.glb")


@pytest.mark.gl
@pytest.mark.parametrize("scale", [1.0, 1e9])
def test_broken_image_named(
    work: tuple[Path, Path],  # noqa: F811
    capsys: pytest.CaptureFixture[str],
    scale: float,
) -> None:
    """The truncated image is refused with its key, exit 2, no output; with a material
    problem read after it (a normalTexture.scale out of range), still the image: opening
    it comes first."""
    root, out = work
    path = _model(root, scale)
    rc, err = _run_inproc(capsys, str(path), "-o", str(out / "x.png"), "--size", SIZE)
    _check(rc, err, out, f"pbs: error: {path}: images[1]:", "is not an image pbs reads")


def test_images_open_before_colour_maps(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A material's colour map (its texels wait for their decode, its mips made on the
    reading thread) is made once every image of the material is open, so the images
    after it (a normal map, which the chain waits for) are decoding meanwhile."""
    import app.scene.gltf as gltf
    from app.common.models import MaterialParams

    b = GltfBuilder()
    colour = b.texture(png_rgb((200, 120, 40), 8))
    normal = b.texture(png_rgb((128, 128, 255), 8))
    pbr = pygltflib.PbrMetallicRoughness(baseColorTexture=pygltflib.TextureInfo(index=colour))
    material = pygltflib.Material(
        pbrMetallicRoughness=pbr, normalTexture=pygltflib.NormalMaterialTexture(index=normal)
    )
    b.quad(material=b.material(material))
    path = b.save(tmp_path / "model.glb")
    events: list[str] = []
    opened, made = gltf.open_image, gltf.colour_texture
    monkeypatch.setattr(
        gltf, "open_image", lambda *a, **k: events.append("open") or opened(*a, **k)
    )
    monkeypatch.setattr(
        gltf, "colour_texture", lambda im, *a: events.append("colour") or made(im, *a)
    )
    fallback = MaterialParams((1.0, 1.0, 1.0), 0.0, 0.5, 0.04)
    layer = gltf.GltfFile(path).layer(0, fallback, "variance")
    assert events == ["open", "open", "colour"]
    assert list(layer.maps) == ["base_color", "normal_roughness"]  # the material's order


@pytest.mark.parametrize(
    "raised, reason",
    [
        (
            Image.DecompressionBombError("too many"),
            "declares more texels than an image of 64 a side",
        ),
        (OSError("broken data stream"), "is not an image pbs reads (OSError: broken data stream)"),
        ("refused", "past its budget"),
    ],
)
def test_a_decode_on_the_pool_is_refused_as_open_image_refuses(
    monkeypatch: pytest.MonkeyPatch, raised: object, reason: str
) -> None:
    """What the decoder pool's decode raises reaches ``wait_decoded`` as ``open_image``
    itself would refuse it: Pillow's bomb check as the texture limit (the same sentence
    as a header's), its other errors by type and message, a ``RefusedError`` unchanged
    (not wrapped as an unreadable image)."""
    from app.textures import maps
    from app.untrusted import RefusedError
    from app.untrusted.budget import Budget
    from app.untrusted.policy import Limits

    if raised == "refused":
        raised = RefusedError("past its budget")

    def fail(image: Image.Image, digest: str) -> None:
        raise raised  # type: ignore[misc]

    monkeypatch.setattr(maps, "_decode", fail)
    texels = np.random.default_rng(len(reason)).integers(0, 256, (8, 8, 3), np.uint8)
    encoded = io.BytesIO()
    Image.fromarray(texels).save(encoded, "PNG")
    budget = Budget(Limits(max_texture_side=64))
    image = maps.open_image(encoded.getvalue(), budget, decode_later=True)
    with pytest.raises(RefusedError) as refused:
        maps.wait_decoded(image)
    assert str(refused.value) == reason
