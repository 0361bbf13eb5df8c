"""The subpixel reconstruction's resolve (glsl/passes/sraa.frag, ``SraaPass``) against its
float64 twin (``sraa_resolve``, app/reference/antialiasing.py; docs/antialiasing.md,
"Twins"), as tests/test_aa_twins.py compares the other antialiasing passes: a small frame
of the bench's antialiasing scene drawn on real GL, the pass's inputs read back from its
targets (the multisampled RT2 through a read-out draw, one sample at a time)."""

from __future__ import annotations

import numpy as np
import pytest

from app.bench.antialiasing import aa_scene_data, with_aa
from app.gl.context import GLContext
from app.gl.fullscreen import FullscreenDraw
from app.gl.shaders import GLSL_VERSION
from app.reference import antialiasing as twin
from app.render.antialias import SRAA_DEPTH_TOLERANCE, SRAA_SAMPLES
from app.render.renderer import Renderer
from app.scene.sources import scene_from
from tests.conftest import REPO
from tests.test_aa_twins import SIZE, texels

pytestmark = pytest.mark.gl

# Only one sample's RT2 copied out per draw: sampler2DMS cannot be read back directly.
SAMPLE_READ = """
uniform sampler2DMS u_samples;
uniform int u_sample;
out vec4 rt2;
void main() {
    rt2 = texelFetch(u_samples, ivec2(gl_FragCoord.xy), u_sample);
}
"""


def read_samples(r: Renderer) -> np.ndarray:
    """(H, W, SRAA_SAMPLES, 2) float64: the geometry samples' RT2 of ``r``'s last frame."""
    ctx, (w, h) = r.gl.ctx, SIZE
    program = ctx.program(
        vertex_shader=f"{GLSL_VERSION}\n" + (REPO / "glsl/passes/fullscreen.vert").read_text(),
        fragment_shader=f"{GLSL_VERSION}\n{SAMPLE_READ}",
    )
    out = ctx.texture(SIZE, 4, dtype="f4")
    fbo = ctx.framebuffer([out])
    samples = []
    try:
        for s in range(SRAA_SAMPLES):
            FullscreenDraw(ctx, program).draw(
                fbo, {"u_sample": s}, {"u_samples": r.sraa.samples.depth}, viewport=(0, 0, w, h)
            )
            samples.append(texels(out)[..., :2])
    finally:
        for obj in (fbo, out, program):
            obj.release()
    return np.stack(samples, axis=2)


# Where only the material id or only the depth tolerance tells two surfaces apart, which
# the bench's scene (each sphere its own material, far apart in depth) never asks: two
# spheres of two materials that intersect (the seam: equal depths), and one sphere of
# the first material further back (the same id, 25 % deeper).
SEAM_OBJECTS = [
    {"shape": "sphere", "radius": 0.6, "position": [-0.35, 0.0, 0.0], "material": "white"},
    {"shape": "sphere", "radius": 0.6, "position": [0.45, 0.0, 0.0], "material": "red"},
    {"shape": "sphere", "radius": 0.6, "position": [-1.3, 0.4, -1.5], "material": "white"},
]


@pytest.mark.parametrize("objects", ["bench", "seam"])
def test_sraa_resolve_is_its_twin(gl_egl: GLContext, objects: str) -> None:
    """``SraaPass``'s target against ``sraa_resolve`` of the HDR image, RT2 and geometry
    samples it read: the unmarked pixels copied bit for bit, the edge pixels the twin's
    mean within float32 rounding (1e-6 of the image's largest value; the mean of five
    float32 colours), the marked pixels the twin's ``sraa_edges``, and the reconstruction
    changing a good part of them (measured at 96x54: 163 edge pixels on the bench's scene,
    86 on ``SEAM_OBJECTS``, all changed, the largest difference 4.0e-8 and 3.2e-8 of the
    scale; a twin without its neighbour search, its material-id test or its depth
    tolerance fails)."""
    assert twin.SRAA_DEPTH_TOLERANCE == SRAA_DEPTH_TOLERANCE
    data = aa_scene_data(SIZE)
    if objects == "seam":
        data["objects"] = SEAM_OBJECTS
    r = Renderer(gl_egl, with_aa(scene_from(data), "sraa", 1))
    try:
        r.render()
        assert r.sraa is not None
        hdr, surface = texels(r.lighting.hdr), texels(r.gbuffer.depth)[..., :2]
        resolved = texels(r.sraa.target)
        samples = read_samples(r)
    finally:
        r.release()
    expected = twin.sraa_resolve(hdr, surface, samples)
    edges = twin.sraa_edges(surface, samples)
    scale = np.abs(expected).max()
    off = np.abs(resolved - expected).max(axis=-1)
    assert np.array_equal(resolved[~edges], hdr[~edges])
    assert off.max() <= 1e-6 * scale, (np.argwhere(off > 1e-6 * scale)[:8], off.max() / scale)
    changed = np.any(resolved != hdr, axis=-1)
    assert 50 < edges.sum() < edges.size // 4
    assert changed.sum() > 0.5 * edges.sum() and not np.any(changed & ~edges)
