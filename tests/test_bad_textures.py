"""Bad texture and blend input (RTR4 §9.13 keys): exit code 2, one line naming the
file and the key, no output file, like every other bad input (tests/test_bad_input.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from app.cli import main
from tests.test_bad_input import BASE, SIZE, _check, _run_inproc, _scene, work  # noqa: F401

TEXTURED = BASE.replace("roughness = 0.5", 'roughness = 0.5\nnormal_map = "n.png"')
COATED = BASE.replace("roughness = 0.5", "roughness = 0.5\nclearcoat = 1.0")
COAT_MAPPED = COATED.replace("clearcoat = 1.0", 'clearcoat = 1.0\nclearcoat_normal_map = "n.png"')
# A blend whose top layer has a coat normal map (only layer 0 of a part samples one).
COAT_IN_BLEND = (
    BASE.replace("roughness = 0.5", 'roughness = 0.5\nblend = { material = "top", mask = "n.png" }')
    + '[materials.top]\nclearcoat = 1.0\nclearcoat_normal_map = "n.png"\n'
)


def _png(path: Path) -> None:
    rgb = np.full((8, 8, 3), (128, 128, 255), np.uint8)
    Image.fromarray(rgb).save(path)


CASES = [
    ("missing-normal-map", TEXTURED, "materials.m.normal_map", "no such file", None),
    (
        "text-as-image",
        BASE.replace("roughness = 0.5", 'base_color_map = "n.png"'),
        "materials.m.base_color_map",
        "is not an image pbs reads",
        b"this is not a PNG",
    ),
    (
        "truncated-png",
        TEXTURED,
        "materials.m.normal_map",
        "is not an image pbs reads (UnidentifiedImageError: cannot identify image file)",
        "truncate",
    ),
    (  # the header whole, the image data cut short: the reason says so
        "truncated-png-data",
        TEXTURED,
        "materials.m.normal_map",
        "is not an image pbs reads (OSError: image file is truncated)",
        "truncate-data",
    ),
    (
        "oversized-image",
        TEXTURED,
        "materials.m.normal_map",
        "more than 8192 texels a side",
        "huge",
    ),
    (
        "anisotropy-map-without-anisotropy",
        BASE.replace("roughness = 0.5", 'anisotropy_map = "n.png"'),
        "materials.m.anisotropy_map",
        "non-zero",
        "png",
    ),
    # the clear coat's own normal map (RTR4 §9.12, docs/layered.md)
    (
        "missing-coat-normal-map",
        COAT_MAPPED,
        "materials.m.clearcoat_normal_map",
        "no such file",
        None,
    ),
    (
        "coat-normal-map-without-coat",
        BASE.replace("roughness = 0.5", 'clearcoat_normal_map = "n.png"'),
        "materials.m.clearcoat_normal_map",
        "applies only with clearcoat > 0",
        "png",
    ),
    (
        "coat-normal-scale-without-coat",
        BASE.replace("roughness = 0.5", "clearcoat_normal_scale = 0.5"),
        "materials.m.clearcoat_normal_scale",
        "applies only with clearcoat > 0",
        None,
    ),
    (
        "coat-normal-scale-without-map",
        COATED.replace("clearcoat = 1.0", "clearcoat = 1.0\nclearcoat_normal_scale = 0.5"),
        "materials.m.clearcoat_normal_scale",
        "applies only with a 'clearcoat_normal_map'",
        None,
    ),
    (
        "coat-normal-scale-out-of-range",
        COAT_MAPPED.replace("clearcoat = 1.0", "clearcoat = 1.0\nclearcoat_normal_scale = -1.0"),
        "materials.m.clearcoat_normal_scale",
        "greater than or equal to 0",
        "png",
    ),
    (
        "coat-normal-map-text",
        COAT_MAPPED,
        "materials.m.clearcoat_normal_map",
        "is not an image pbs reads",
        b"not a PNG",
    ),
    (
        "coat-normal-map-in-blend",
        COAT_IN_BLEND,
        "materials.top.clearcoat_normal_map",
        "blend",
        "png",
    ),
    (
        "negative-uv-scale",
        BASE.replace("roughness = 0.5", "uv_scale = [1.0, -2.0]"),
        "materials.m.uv_scale[1]",
        "greater than 0",
        None,
    ),
    (
        "blend-unknown-material",
        BASE + '[materials.m.blend]\nmaterial = "rust"\nmask = "n.png"\n',
        "materials.m.blend.material",
        "unknown material 'rust'",
        "png",
    ),
    (
        "blend-onto-itself",
        BASE + '[materials.m.blend]\nmaterial = "m"\nmask = "n.png"\n',
        "materials.m.blend.material",
        "unknown material 'm'",
        "png",
    ),
    (
        "blend-missing-mask",
        BASE + '[materials.r]\n[materials.m.blend]\nmaterial = "r"\nmask = "gone.png"\n',
        "materials.m.blend.mask",
        "no such file",
        "png",
    ),
    (
        "blend-nested",
        BASE
        + '[materials.r]\n[materials.m.blend]\nmaterial = "r"\nmask = "n.png"\n'
        + '[materials.r.blend]\nmaterial = "m"\nmask = "n.png"\n',
        "materials.m.blend.material",
        "do not nest",
        "png",
    ),
    (
        "blend-softness-nan",
        BASE + '[materials.r]\n[materials.m.blend]\nmaterial = "r"\nmask = "n.png"\n'
        "softness = nan\n",
        "materials.m.blend.softness",
        "finite",
        "png",
    ),
    (
        "unknown-normal-filter",
        BASE + '[render]\nnormal_filter = "mipmap"\n',
        "render.normal_filter",
        "naive",
        None,
    ),
    (
        "supersample-too-large",
        BASE + "[render]\nwidth = 4096\nsupersample = 8\n",
        "render.supersample",
        "16384",
        None,
    ),
]


@pytest.mark.parametrize(
    ("scene", "key", "fragment", "texture"), [c[1:] for c in CASES], ids=[c[0] for c in CASES]
)
@pytest.mark.gl
def test_bad_texture_input(
    work: tuple[Path, Path],  # noqa: F811
    capsys: pytest.CaptureFixture[str],
    scene: str,
    key: str,
    fragment: str,
    texture: object,
) -> None:
    root, out = work
    if texture == "png":
        _png(root / "n.png")
    elif texture == "truncate":
        _png(root / "n.png")
        data = (root / "n.png").read_bytes()
        (root / "n.png").write_bytes(data[: len(data) // 2])
    elif texture == "truncate-data":  # noise does not compress: most of the file is data
        noise = np.random.default_rng(5).integers(0, 256, (64, 64, 3), np.uint8)
        Image.fromarray(noise).save(root / "n.png")
        data = (root / "n.png").read_bytes()
        (root / "n.png").write_bytes(data[: len(data) * 7 // 10])
    elif texture == "huge":  # 8200 x 1: a few bytes of PNG, over the size limit
        Image.fromarray(np.zeros((1, 8200, 3), np.uint8)).save(root / "n.png")
    elif isinstance(texture, bytes):
        (root / "n.png").write_bytes(texture)
    path = _scene(root, scene)
    rc, err = _run_inproc(capsys, str(path), "-o", str(out / "x.png"), "--size", SIZE)
    _check(rc, err, out, f"pbs: error: {path}: {key}:", fragment)


@pytest.mark.gl
def test_good_textured_scene_renders(
    work: tuple[Path, Path],  # noqa: F811
    capsys: pytest.CaptureFixture[str],
) -> None:
    """The same minimal scene with a valid normal map renders (the cases above fail for
    the reason they name, not for the normal map itself)."""
    root, out = work
    _png(root / "n.png")
    path = _scene(root, TEXTURED)
    capsys.readouterr()
    rc = main(["render", str(path), "-o", str(out / "x.png"), "--size", SIZE])
    assert rc == 0, capsys.readouterr().err
    assert (out / "x.png").is_file()
