"""An HDR environment image made by the project: a room with one bright window and a warm
lamp, as an equirectangular OpenEXR file, for scenes/ibl_image.toml (docs/ibl.md).

Why generate it: the image path (``[environment] source = "image"``) needs a file to show
without a download, and one whose every texel is known. The room, in the map's convention
(app/reference/environment.py; -Z is what the default camera sees behind the objects):

- walls of radiance 0.08 (warm grey), a darker floor (0.04) and a lighter ceiling (0.12);
- a window ahead and to the left (azimuth -35 degrees from -Z, 10-45 degrees up, 40 degrees
  wide) of radiance 40 (a cool daylight white): 500 times the walls;
- a small warm lamp behind the camera's right, 25 degrees up, radiance 150.

Half floats (OpenEXR HALF, ZIP): a few hundred kilobytes. Run ``python -m
app.assets.window_room`` to rewrite ``scenes/textures/window_room.exr``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from app.reference.environment import texel_directions

WIDTH = 512
OUT = Path(__file__).resolve().parents[2] / "scenes" / "textures" / "window_room.exr"


def window_room(width: int = WIDTH) -> np.ndarray:
    """The room's radiance, float32 (width / 2, width, 3)."""
    d, _ = texel_directions(width // 2, width)
    elevation = np.degrees(np.arcsin(np.clip(d[..., 1], -1.0, 1.0)))
    azimuth = np.degrees(np.arctan2(d[..., 0], -d[..., 2]))  # 0 towards -Z, +90 towards +X
    out = np.empty((*d.shape[:2], 3))
    out[:] = (0.085, 0.08, 0.07)
    out[elevation < -20.0] = (0.045, 0.04, 0.035)
    out[elevation > 60.0] = (0.12, 0.12, 0.115)
    window = (np.abs(azimuth + 35.0) < 20.0) & (elevation > 10.0) & (elevation < 45.0)
    out[window] = (38.0, 40.0, 44.0)
    lamp = np.degrees(np.arccos(np.clip(d @ _unit(150.0, 25.0), -1.0, 1.0))) < 3.0
    out[lamp] = (160.0, 140.0, 110.0)
    return out.astype(np.float32)


def _unit(azimuth: float, elevation: float) -> np.ndarray:
    """The direction at ``azimuth`` degrees from -Z towards +X and ``elevation`` up."""
    a, e = math.radians(azimuth), math.radians(elevation)
    return np.array([math.cos(e) * math.sin(a), math.sin(e), -math.cos(e) * math.cos(a)])


def write(path: Path = OUT) -> Path:
    """Write the room as a half-float ZIP-compressed OpenEXR file."""
    import OpenEXR

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {"RGB": window_room().astype(np.float16)}) as f:
        f.write(str(path))
    return path


if __name__ == "__main__":
    print(write())
