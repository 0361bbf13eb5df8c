"""The shadow lookup's normal offset follows the geometric normal, not the normal-mapped
one (glsl/gbuffer/decode.glsl face_normal, twin app/reference/shadows.py face_normals).

A normal map tilts the shading normal relative to the interpolated vertex normal, which
on a coarse fold (ToyCar's cloth) is itself tilted off the triangle the shadow map holds:
the two tilts together can carry the mapped normal below the triangle's plane while the
light still reaches it, and an offset along it then moves the lookup into the surface,
which shadows itself (the dotted lines along ToyCar's folds). A quad whose vertex normals
lean 30 degrees off its plane, its normal map leaning 75 degrees further (105 from the
plane, still facing a light 30 degrees above it), must stay unshadowed."""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from app.render.renderer import Renderer
from app.scene.loader import parse_scene

pytestmark = pytest.mark.gl

SIZE = (96, 64)
LEAN = np.radians(30.0)  # the vertex normals off the quad's plane, towards +x
TILT = np.radians(75.0)  # the normal map's tilt towards +u (+x), past the vertex normal


def _scene(folder: Path, shadow: bool) -> dict:
    """The quad (y = 0, |x|, |z| <= 1.5, u along +x), its normal map and a directional
    light from +x, 30 degrees above the quad."""
    vn = f"vn {np.sin(LEAN):.6f} {np.cos(LEAN):.6f} 0\n"
    (folder / "quad.obj").write_text(
        "v -1.5 0 1.5\nv 1.5 0 1.5\nv 1.5 0 -1.5\nv -1.5 0 -1.5\n"
        "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n" + vn + "f 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 4/4/1\n"
    )
    texel = np.round((np.array([np.sin(TILT), 0.0, np.cos(TILT)]) * 0.5 + 0.5) * 255)
    Image.fromarray(np.tile(texel.astype(np.uint8), (4, 4, 1))).save(folder / "tilt.png")
    light = {"type": "directional", "direction": [-0.866, -0.5, 0.0], "intensity": 3.0}
    if shadow:
        light["shadow"] = True
    return {
        "render": {"width": SIZE[0], "height": SIZE[1]},
        "camera": {"position": [0.0, 3.0, 3.0], "target": [0.0, 0.0, 0.0], "fov_y": 50.0},
        "materials": {
            "m": {"base_color": [0.8, 0.8, 0.8], "roughness": 0.6, "normal_map": "tilt.png"}
        },
        "objects": [{"shape": "mesh", "file": "quad.obj", "material": "m"}],
        "lights": [light],
    }


def _hdr(gl, folder: Path, data: dict) -> np.ndarray:
    renderer = Renderer(gl, parse_scene(copy.deepcopy(data), folder / "t.toml"))
    try:
        renderer.render()
        return renderer.read_hdr().astype(np.float64).sum(axis=-1)
    finally:
        renderer.release()


def test_a_mapped_normal_below_its_triangle_does_not_shadow_the_triangle(gl_egl, tmp_path):
    plain = _hdr(gl_egl, tmp_path, _scene(tmp_path, shadow=False))
    shadowed = _hdr(gl_egl, tmp_path, _scene(tmp_path, shadow=True))
    lit = plain > 1e-3 * plain.max()
    assert lit.sum() > 0.3 * lit.size  # the mapped normals face the light
    ratio = shadowed[lit] / plain[lit]
    unlit = ratio < 0.999
    assert unlit.sum() == 0, f"{unlit.sum()} of {lit.sum()} quad pixels in shadow"
