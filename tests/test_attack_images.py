"""Hostile images and environments, in every place a scene, glTF or MTL names one.

Textures: PNG headers that lie about their size (a 100000 x 100000 IHDR over 60 bytes),
sides past the limit, zero sizes, truncated data, 16-bit, palette and grey images, a
zTXt decompression bomb, JPEG, BMP, TIFF and GIF headers that lie, formats pbs does not
read (PostScript, PSD, ICO), text and empty files named .png, FIFOs and folders, each as
a scene's base colour, normal, roughness and metallic map and blend mask, a glTF image
(bufferView and file), and an MTL ``map_Kd``. Environments: Radiance .hdr files whose
resolution line declares 10^12 texels or 16384 x 8192, wrong aspect ratios, broken run
lengths, exponent-255 texels (3e38), OpenEXR files holding NaN, infinities, negative and
huge values, lying data windows and no colour channels. Each is held to the contract of
tests/attacks.py under a 1 GiB budget.
"""

from __future__ import annotations

import io
import os
import struct
import zlib
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from tests.attacks import Case, escapes, run_cases, scene_head
from tests.gltf_builder import GltfBuilder

pytestmark = pytest.mark.gl  # the images that load are rendered

MAX_MEMORY = "1G"


def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def _png_header(
    width: int, height: int, depth: int = 8, colour: int = 2, rows: bytes = b""
) -> bytes:
    ihdr = struct.pack(">IIBBBBB", width, height, depth, colour, 0, 0, 0)
    body = _chunk(b"IHDR", ihdr)
    if rows:
        body += _chunk(b"IDAT", zlib.compress(rows))
    return b"\x89PNG\r\n\x1a\n" + body + _chunk(b"IEND", b"")


def _pil(image: Image.Image, fmt: str, **kw) -> bytes:
    out = io.BytesIO()
    image.save(out, format=fmt, **kw)
    return out.getvalue()


def _png_ztxt_bomb() -> bytes:
    """A valid 4 x 4 PNG carrying a zTXt chunk that inflates to 200 MB."""
    base = _pil(Image.new("RGB", (4, 4), (9, 9, 9)), "PNG")
    text = b"comment\x00\x00" + zlib.compress(b"\x00" * 200_000_000, 9)
    return base[:-12] + _chunk(b"zTXt", text) + base[-12:]


def _patch_jpeg_size(data: bytes, width: int, height: int) -> bytes:
    at = data.index(b"\xff\xc0") + 5
    return data[:at] + struct.pack(">HH", height, width) + data[at + 4 :]


def _images() -> dict[str, bytes | Callable[[Path], None]]:
    """Every hostile texture: its name -> its bytes (or a function making the file)."""
    ok = Image.new("RGB", (8, 8), (120, 130, 140))
    jpeg = _pil(ok, "JPEG")
    bmp = bytearray(_pil(ok, "BMP"))
    struct.pack_into("<ii", bmp, 18, 100_000, -100_000)
    tiff = bytearray(_pil(ok, "TIFF"))
    gif = bytearray(_pil(ok, "GIF"))
    struct.pack_into("<HH", gif, 6, 65535, 65535)
    psd = b"8BPS\x00\x01" + b"\x00" * 6 + struct.pack(">HIIHH", 3, 30000, 30000, 8, 3)
    return {
        "ok.png": _pil(ok, "PNG"),
        "ok.jpg": jpeg,
        "ok-16bit.png": _png_header(8, 8, 16, 2, (b"\x00" + b"\x80" * 48) * 8),
        "ok-grey16.png": _png_header(8, 8, 16, 0, (b"\x00" + b"\x10" * 16) * 8),
        "ok-palette.png": _pil(ok.convert("P"), "PNG"),
        "ok-grey-alpha.png": _pil(ok.convert("LA"), "PNG"),
        "ok-1bit.png": _pil(ok.convert("1"), "PNG"),
        "ok.bmp": _pil(ok, "BMP"),
        "ok.tga": _pil(ok, "TGA"),
        "lying-huge.png": _png_header(100_000, 100_000),
        "side-past-limit.png": _png_header(9000, 16, rows=b"\x00" * 10),
        "tall-past-limit.png": _png_header(1, 70_000),
        "zero-width.png": _png_header(0, 16),
        "big-truncated.png": _png_header(8192, 8192, rows=b"\x00" * 100),
        "rgba16-8192.png": _png_header(8192, 8192, 16, 6),
        "truncated.png": _pil(ok, "PNG")[:40],
        "ztxt-bomb.png": _png_ztxt_bomb(),
        "jpeg-lying-size.jpg": _patch_jpeg_size(jpeg, 65500, 65500),
        "jpeg-truncated.jpg": jpeg[: len(jpeg) // 2],
        "bmp-lying-size.bmp": bytes(bmp),
        "tiff-truncated.tif": bytes(tiff[:60]),
        "gif-lying-size.gif": bytes(gif),
        "postscript.png": b"%!PS-Adobe-3.0 EPSF-3.0\n%%BoundingBox: 0 0 10 10\nshowpage\n",
        "psd-lying.png": psd,
        "ico.png": _pil(ok, "ICO"),
        "text.png": b"this is not an image at all\n",
        "empty.png": b"",
        "fifo.png": lambda p: os.mkfifo(p),
        "folder.png": lambda p: p.mkdir(),
    }  # fmt: skip


def _hdr(width: int, height: int, body: bytes | None = None, head: bytes | None = None) -> bytes:
    h = head or f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {height} +X {width}\n".encode()
    return h + (body if body is not None else bytes([100, 110, 120, 128]) * (width * height))


def _exr(pixels: np.ndarray) -> bytes:
    import tempfile

    import OpenEXR

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "e.exr"
        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
        channels = {"RGB": np.ascontiguousarray(pixels, np.float32)}
        with OpenEXR.File(header, channels) as f:
            f.write(str(path))
        return path.read_bytes()


def _exr_lying_window(width: int, height: int) -> bytes:
    """A valid small EXR whose dataWindow attribute is rewritten to declare another size."""
    data = bytearray(_exr(np.ones((4, 8, 3), np.float32)))
    at = data.index(b"dataWindow\x00box2i\x00") + len(b"dataWindow\x00box2i\x00") + 4
    struct.pack_into("<iiii", data, at, 0, 0, width - 1, height - 1)
    return bytes(data)


def _environments() -> dict[str, bytes]:
    one = np.ones((8, 16, 3), np.float32)
    rle_row = bytes([2, 2, 0, 16]) + b"".join(bytes([128 + 16, v]) for v in (100, 110, 120, 128))
    return {
        "ok.hdr": _hdr(16, 8),
        "ok-rle.hdr": _hdr(16, 8, rle_row * 8),
        "ok.exr": _exr(one),
        "declares-1e12.hdr": _hdr(2_000_000, 1_000_000, b""),
        "declares-16384.hdr": _hdr(16384, 8192, b"\x00" * 64),
        "declares-digits.hdr": _hdr(10**30, 10**30, b""),
        "wrong-aspect.hdr": _hdr(16, 16),
        "zero-size.hdr": _hdr(0, 0, b""),
        "no-resolution.hdr": b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\nnonsense\n",
        "no-blank-line.hdr": b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n-Y 8 +X 16\n",
        "other-format.hdr": b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 8 +X 16\n" + b"\x80" * 512,
        "bad-run.hdr": _hdr(16, 8, bytes([2, 2, 0, 16, 200, 1]) * 8),
        "zero-run.hdr": _hdr(16, 8, bytes([2, 2, 0, 16, 0, 0]) * 8),
        "truncated.hdr": _hdr(16, 8)[:-100],
        "exponent-255.hdr": _hdr(16, 8, bytes([255, 255, 255, 255]) * 128),
        "not-radiance.hdr": b"P6\n16 8\n255\n" + b"\x00" * 384,
        "nan.exr": _exr(np.where(np.arange(384).reshape(8, 16, 3) == 5, np.nan, one)),
        "inf.exr": _exr(np.where(np.arange(384).reshape(8, 16, 3) == 5, np.inf, one)),
        "negative.exr": _exr(-one),
        "float-max.exr": _exr(one * 3e38),
        "past-radiance.exr": _exr(one * 1e16),
        "wrong-aspect.exr": _exr(np.ones((8, 8, 3), np.float32)),
        "lying-window.exr": _exr_lying_window(100_000, 50_000),
        "lying-window-16384.exr": _exr_lying_window(16384, 8192),
        "lying-window-small.exr": _exr_lying_window(64, 32),
        "truncated.exr": _exr(one)[:200],
        "text.exr": b"not an exr\n",
        "empty.hdr": b"",
    }  # fmt: skip


HEAD = scene_head(24, 16)
SITES = {
    "base_color_map": '[materials.m]\nbase_color_map = "{f}"\n',
    "normal_map": '[materials.m]\nnormal_map = "{f}"\n',
    "roughness_map": '[materials.m]\nroughness_map = "{f}"\n',
    "metallic_map": '[materials.m]\nmetallic_map = "{f}"\n',
    "blend_mask": '[materials.top]\nmetallic = 1.0\n[materials.m]\n'
                  'blend = {{ material = "top", mask = "{f}" }}\n',
}  # fmt: skip


def _gltf_with_image(folder: Path, stem: str, data: bytes, how: str) -> str:
    import pygltflib

    b = GltfBuilder()
    if how == "view":
        b.doc.images.append(pygltflib.Image(bufferView=b.view(data), mimeType="image/png"))
    else:
        (folder / f"{stem}.img").write_bytes(data)
        b.doc.images.append(pygltflib.Image(uri=f"{stem}.img"))
    b.doc.textures.append(pygltflib.Texture(source=0))
    material = b.material(
        pygltflib.Material(
            pbrMetallicRoughness=pygltflib.PbrMetallicRoughness(
                baseColorTexture=pygltflib.TextureInfo(index=0)
            ),
            normalTexture=pygltflib.NormalMaterialTexture(index=0),
        )
    )
    b.quad(material)
    name = f"{stem}.glb"
    b.save(folder / name)
    return name


def cases(folder: Path) -> list[Case]:
    folder.mkdir(parents=True, exist_ok=True)
    out: list[Case] = []

    def add(case_id: str, body: str, hdr: bool = False) -> None:
        scene = folder / f"{case_id}.toml"
        scene.write_text(HEAD + body, encoding="utf-8")
        png, npy = folder / f"{case_id}.png", folder / f"{case_id}.npy"
        argv = ["render", str(scene), "-o", str(png), "--hdr", str(npy), "--backend", "egl",
                "-q", "--max-memory", MAX_MEMORY]  # fmt: skip
        out.append(Case(case_id, argv, str(folder), [str(png), str(npy)], None, None, str(npy)))

    for name, data in _images().items():
        path = folder / name
        if callable(data):
            data(path)
        else:
            path.write_bytes(data)
        stem = name.replace(".", "-")
        for site, text in SITES.items():
            add(f"{site}-{stem}", text.format(f=name)
                + '[[objects]]\nshape = "sphere"\nmaterial = "m"\n')  # fmt: skip
        if isinstance(data, bytes):
            for how in ("view", "file"):
                glb = _gltf_with_image(folder, f"gltf-{how}-{stem}", data, how)
                add(f"gltf-{how}-{stem}", f'[[objects]]\nshape = "mesh"\nfile = "{glb}"\n')
        mtl = folder / f"mtl-{stem}.mtl"
        mtl.write_text(f"newmtl m\nKd 1 1 1\nmap_Kd {name}\n", encoding="utf-8")
        obj = folder / f"mtl-{stem}.obj"
        obj.write_text(
            f"mtllib {mtl.name}\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\n"
            "usemtl m\nf 1/1 2/2 3/3\n",
            encoding="utf-8",
        )
        add(f"mtl-{stem}", f'[[objects]]\nshape = "mesh"\nfile = "{obj.name}"\n')
    for name, data in _environments().items():
        (folder / name).write_bytes(data)
        stem = name.replace(".", "-")
        for intensity in (1.0, 1e14):
            add(f"env-{stem}-{intensity:g}", '[materials.m]\nroughness = 0.3\n'
                f'[environment]\nsource = "image"\nfile = "{name}"\nintensity = {intensity}\n'
                '[[objects]]\nshape = "sphere"\nmaterial = "m"\n')  # fmt: skip
    return out


def test_hostile_images_and_environments(tmp_path: Path) -> None:
    found_cases = cases(tmp_path / "asset")
    assert len(found_cases) >= 150, len(found_cases)
    outcomes = run_cases(found_cases, tmp_path)
    found = escapes(found_cases, outcomes)
    rendered = {c for c, o in outcomes.items() if o.code == 0}
    # The controls render (a broken harness would refuse everything).
    for control in ("base_color_map-ok-png", "normal_map-ok-jpg", "gltf-view-ok-png",
                    "mtl-ok-bmp", "env-ok-hdr-1", "env-ok-exr-1", "env-ok-rle-hdr-1"):  # fmt: skip
        assert control in rendered, (control, outcomes[control].stderr)
    assert not found, f"{len(found)} of {len(found_cases)} escaped:\n" + "\n".join(found[:60])
