"""Writing images without leaving partial files: temp file in the same folder, then rename.

An image with a fourth channel carries alpha (a transparent background, docs/architecture.md
"Alpha"): a PNG's is straight (PNG stores colour not premultiplied), an HDR file's is
premultiplied radiance plus coverage (OpenEXR's convention, kept for .npy)."""

from __future__ import annotations

import contextlib
import errno
import os
import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
from PIL import Image

HDR_SUFFIXES = (".exr", ".npy")


def atomic_write(path: Path, write: Callable[[Path], None]) -> None:
    """Call ``write(tmp)`` on a temporary sibling of ``path`` and rename it into place."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        write(tmp)
        # mkstemp makes the file 0600; give it the mode a plain open() would have.
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


# zlib's level for PNGs: 3 deflates a 480x480 render in 13 ms of CPU where Pillow's
# default 6 takes 29, for a file 4% larger (docs/performance.md); the pixels are the same.
PNG_COMPRESS_LEVEL = 3


def write_png(path: Path, image: np.ndarray) -> None:
    """(H, W, 3) uint8 -> RGB PNG; (H, W, 4) uint8 (sRGB colour, straight alpha) -> RGBA PNG."""
    mode = _png_mode(image)
    atomic_write(
        path,
        lambda tmp: Image.fromarray(image, mode).save(
            tmp, format="PNG", compress_level=PNG_COMPRESS_LEVEL
        ),
    )


def _png_mode(image: np.ndarray) -> str:
    """PIL's mode of an (H, W, 3) or (H, W, 4) uint8 image; ValueError for another shape."""
    if image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] not in (3, 4):
        raise ValueError(f"expected (H, W, 3) or (H, W, 4) uint8, got {image.shape} {image.dtype}")
    return "RGB" if image.shape[2] == 3 else "RGBA"


def _write_exr(tmp: Path, hdr: np.ndarray) -> None:
    import OpenEXR

    name = "RGBA" if hdr.shape[-1] == 4 else "RGB"  # A: coverage, RGB premultiplied by it
    channels = {name: np.ascontiguousarray(hdr[..., : len(name)], dtype=np.float32)}
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    try:
        with OpenEXR.File(header, channels) as f:
            f.write(str(tmp))
    except RuntimeError as exc:  # OpenEXR's C++ errors (a full disk, a write refused)
        raise OSError(errno.EIO, f"OpenEXR could not write the file ({exc})") from None


def write_hdr(path: Path, hdr: np.ndarray) -> None:
    """(H, W, 3) float32 linear radiance, or (H, W, 4) radiance premultiplied by the
    coverage in the fourth channel -> OpenEXR (.exr; channels R, G, B[, A]) or numpy (.npy)."""
    path = Path(path)
    if path.suffix == ".npy":
        atomic_write(path, lambda tmp: np.save(tmp, np.asarray(hdr, np.float32)))
    elif path.suffix == ".exr":
        atomic_write(path, lambda tmp: _write_exr(tmp, hdr))
    else:
        raise ValueError(f"unsupported HDR suffix {path.suffix}")
