"""The G-buffer encodings' error, channel by channel (docs/gbuffer.md, "Encodings").

Every error here is the encoding's own: HDR(candidate) against HDR(f32) of the same scene,
camera and geometry, both shaded by the GLSL lighting pass, so only the stored values
differ. ``channel_errors`` isolates one channel: it draws the f32 G-buffer, rounds that
channel alone on the CPU as a candidate storage would (``quantize``), writes the targets
back and lights them again. The rounding is the GL's conversion as the spec states it
(float16: round to nearest even; unorm16: round(clamp(x) * 65535), OpenGL 4.6 sec. 2.3.5.2),
so these rows estimate each channel's share; the whole encoding is measured by rendering it.
"""

from __future__ import annotations

import numpy as np

from app.bench.metrics import RELATIVE_FLOOR
from app.bench.scenes import load
from app.common.gbuffer import GBufferData
from app.gl.context import GLContext
from app.reference.encoding import snorm_to_unorm, unorm_to_snorm
from app.render.renderer import Renderer, RenderOptions

STORAGES = ("f16", "unorm16", "f32")
# channel -> (G-buffer field, components, signed: stored through snorm_to_unorm in unorm16)
CHANNELS: dict[str, tuple[str, tuple[int, ...], bool]] = {
    "normal": ("normal", (0, 1), True),
    "base_color": ("base_color", (0, 1, 2), False),
    "metallic": ("base_color", (3,), False),
    "roughness": ("normal", (2,), False),
    "f0": ("normal", (3,), False),
    "tangent": ("tangent", (0, 1), True),
    "anisotropy": ("tangent", (2,), True),
}
ERODE_PX = 2  # interior pixels: this far from a silhouette or the background


def quantize(x: np.ndarray, storage: str, signed: bool) -> np.ndarray:
    """``x`` (float32) as a ``storage`` texel gives it back, as float32. ``signed``: a value
    in [-1, 1] that unorm16 stores mapped to [0, 1] (snorm_to_unorm)."""
    x = np.asarray(x, np.float32)
    if storage == "f32":
        return x.copy()
    if storage == "f16":
        return x.astype(np.float16).astype(np.float32)
    u = snorm_to_unorm(x.astype(np.float64)) if signed else x.astype(np.float64)
    q = np.round(np.clip(u, 0.0, 1.0) * 65535.0) / 65535.0
    return (unorm_to_snorm(q) if signed else q).astype(np.float32)


def interior_pixels(g: GBufferData, erode: int = ERODE_PX) -> np.ndarray:
    """Covered pixels at least ``erode`` pixels (chessboard distance) from the background
    and from a change of material (silhouettes of one sphere over another)."""
    keep = g.covered.copy()
    h, w = keep.shape
    ids = np.where(g.covered, g.material_id, -1.0)
    pad_ids = np.pad(ids, erode, constant_values=-1.0)
    for dy in range(2 * erode + 1):
        for dx in range(2 * erode + 1):
            keep &= pad_ids[dy : dy + h, dx : dx + w] == ids
    return keep


def relative_errors(hdr: np.ndarray, ref: np.ndarray, sel: np.ndarray) -> dict[str, float]:
    """Median, 99th percentile and max over ``sel``'s pixels and channels of
    |hdr - ref| / max(|ref|, RELATIVE_FLOOR * peak) (app/bench/metrics.py's measure)."""
    a = np.asarray(hdr, np.float64)[sel]
    b = np.asarray(ref, np.float64)[sel]
    floor = RELATIVE_FLOOR * float(np.abs(b).max())
    rel = np.abs(a - b) / np.maximum(np.abs(b), floor)
    return {
        "rel_median": float(np.median(rel)),
        "rel_p99": float(np.percentile(rel, 99.0)),
        "rel_max": float(rel.max()),
    }


def _write(tex: object, array: np.ndarray) -> None:
    """An (H, W, C) float32 array, rows top to bottom, into an f32 target."""
    tex.write(np.ascontiguousarray(array[::-1], np.float32).tobytes())  # type: ignore[attr-defined]


def channel_errors(gl: GLContext, data: dict) -> list[dict]:
    """One row per (channel, storage): the error of the f32 frame of scene ``data`` with
    that channel alone rounded as the storage would (written into the stored-surface
    layout's targets: constant surfaces would keep the base colour, roughness and F0 in
    the material table, out of reach)."""
    r = Renderer(
        gl, load({**data, "render": {**data["render"], "gbuffer": "f32"}}),
        options=RenderOptions(constant_surfaces=False),
    )  # fmt: skip
    rows = []
    try:
        r.render()
        ref = r.read_hdr().astype(np.float64)
        g = r.read_gbuffer()
        sel = interior_pixels(g)
        background = np.asarray(r.scene.background, np.float64)
        for channel, (field, comps, signed) in CHANNELS.items():
            if field == "tangent" and r.gbuffer.tangent is None:
                continue
            for storage in STORAGES[:2]:
                array = getattr(g, field).copy()
                array[..., comps] = quantize(array[..., comps], storage, signed)
                _write(getattr(r.gbuffer, field), array)
                r.lighting.run(r.gbuffer, r.camera, background)
                hdr = r.lighting.read().astype(np.float64)
                _write(getattr(r.gbuffer, field), getattr(g, field))
                rows.append(
                    {"channel": channel, "storage": storage, **relative_errors(hdr, ref, sel)}
                )
    finally:
        r.release()
    return rows
