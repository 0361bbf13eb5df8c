"""render.antialiasing = "msaa"'s parts against their float64 twins (app/reference/msaa.py;
docs/antialiasing.md, "Per-sample shading"): the background a sample without a surface
takes (glsl/passes/msaa_background.glsl, run as written on hand-made targets that reach
each of its picks), and the mark's test of the pixel centre against the samples
(glsl/passes/msaa.frag) on a frame whose samples agree with each other but not with the
centre. tests/test_aa_msaa.py holds the whole frame against the twin."""

from __future__ import annotations

import moderngl
import numpy as np
import pytest

from app.gl.context import GLContext
from app.gl.shaders import assemble, assemble_text
from app.reference import msaa as twin
from app.render.msaa import MSAA_SAMPLES
from app.render.renderer import Renderer
from app.scene.sources import scene_from

pytestmark = pytest.mark.gl

# The background pick as the lighting pass calls it, at every pixel.
PICK_SOURCE = """
#include "passes/msaa_background.glsl"
out vec4 frag_color;
void main() { frag_color = msaa_background(ivec2(gl_FragCoord.xy)); }
"""


def _first_pick(centre: np.ndarray) -> np.ndarray:
    """(H, W) int: which of ``MSAA_BACKGROUND_STEPS`` the pick takes at each pixel (its
    index, 5: none, the uniform background), for checking that a case reaches each."""
    h, w = centre.shape[:2]
    first = np.full((h, w), len(twin.MSAA_BACKGROUND_STEPS))
    for k, (dx, dy) in reversed(list(enumerate(twin.MSAA_BACKGROUND_STEPS))):
        ys = np.clip(np.arange(h) + dy, 0, h - 1)[:, None]
        xs = np.clip(np.arange(w) + dx, 0, w - 1)[None, :]
        z = centre[ys, xs, 0]
        first[~(np.isfinite(z) & (z > 0.0))] = k
    return first


def test_background_pick_matches_the_twin(gl_egl: GLContext) -> None:
    """msaa_background.glsl against ``msaa_background`` on a 13x9 frame of random
    centres, 30 % without a surface (view depth 0, and some NaN, infinite or negative,
    which the decode counts as none too), each pixel's HDR value its own: every pixel's
    pick, the pixel's own, each of the 4 neighbours' (clamped at the border) and the
    uniform background, is reached and returned bit for bit."""
    ctx = gl_egl.ctx
    w, h = 13, 9
    rng = np.random.default_rng(20261206)
    depth = rng.uniform(0.5, 8.0, (h, w))
    empty = rng.uniform(size=(h, w)) < 0.3
    depth[empty] = rng.choice([0.0, np.nan, np.inf, -1.0], size=int(empty.sum()))
    centre = np.stack([depth, rng.integers(0, 4, (h, w)).astype(np.float64)], axis=-1)
    centre = centre.astype(np.float32).astype(np.float64)
    hdr = rng.uniform(0.0, 4.0, (h, w, 4)).astype(np.float32).astype(np.float64)
    background = np.array([0.25, 0.5, 0.125, 1.0])
    picks = np.bincount(_first_pick(centre).ravel(), minlength=6)
    assert np.all(picks > 0), picks  # the case reaches every pick

    program = ctx.program(
        vertex_shader=assemble("passes/fullscreen.vert"),
        fragment_shader=assemble_text(PICK_SOURCE),
    )
    textures = [
        ctx.texture((w, h), 4, hdr.astype(np.float32).tobytes(), dtype="f4"),
        ctx.texture((w, h), 2, centre.astype(np.float32).tobytes(), dtype="f4"),
    ]
    out = ctx.texture((w, h), 4, dtype="f4")
    fbo = ctx.framebuffer([out])
    vao = ctx.vertex_array(program, [])
    try:
        for unit, name in enumerate(("u_msaa_hdr", "u_msaa_centre_depth")):
            textures[unit].use(unit)
            program[name].value = unit
        program["u_msaa_background"].value = tuple(background)
        fbo.use()
        ctx.viewport = (0, 0, w, h)
        ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
        vao.render(moderngl.TRIANGLES, vertices=3)
        glsl = np.frombuffer(out.read(), np.float32).reshape(h, w, 4).astype(np.float64)
    finally:
        for obj in (vao, fbo, out, *textures, program):
            obj.release()
    assert np.array_equal(glsl, twin.msaa_background(hdr, centre, background))


# The centre-only frame: tiny analytic spheres, each 0.15 pixel in radius at a pixel's
# centre: the centre sees a sphere, no sample does (the GL's 4 samples lie 0.39 pixel and
# more from the centre), so the samples agree with each other and the centre alone differs.
CENTRE_SIZE = (48, 32)
FOV_Y = 30.0
SPECK_PIXELS = [(10, 8), (24, 16), (37, 23)]  # (x, y) from the lower left
SPECK_DEPTH = 4.0  # metres in front of the camera


def _speck(px: int, py: int) -> dict:
    """A sphere 0.15 pixel in radius at pixel (px, py)'s centre, SPECK_DEPTH away from the
    camera at the origin looking down -z."""
    w, h = CENTRE_SIZE
    t = np.tan(np.radians(FOV_Y) / 2.0)
    ndc = np.array([(px + 0.5) / w, (py + 0.5) / h]) * 2.0 - 1.0
    x, y = ndc * t * np.array([w / h, 1.0]) * SPECK_DEPTH
    radius = 0.15 * 2.0 * t * SPECK_DEPTH / h
    return {"shape": "sphere", "radius": radius, "position": [x, y, -SPECK_DEPTH],
            "material": "red"}  # fmt: skip


def centre_only_data(background: bool) -> dict:
    """The centre-only frame's scene; ``background``: the specks before the sky (its
    radiance differs pixel to pixel), else before the uniform background."""
    data = {
        "background": [0.02, 0.02, 0.03],
        "render": {"width": CENTRE_SIZE[0], "height": CENTRE_SIZE[1], "antialiasing": "msaa"},
        "camera": {"position": [0.0, 0.0, 0.0], "target": [0.0, 0.0, -1.0], "fov_y": FOV_Y},
        "materials": {"red": {"base_color": [0.7, 0.08, 0.05], "roughness": 0.35}},
        "objects": [_speck(px, py) for px, py in SPECK_PIXELS],
        "lights": [{"type": "directional", "direction": [0.3, -0.5, -1.0], "intensity": 2.0}],
    }
    if background:
        data["environment"] = {"source": "sky", "sun_direction": [0.5, 0.6, -0.6],
                               "intensity": 0.1, "background": True}  # fmt: skip
    return data


# Sample u_sample of the multisampled RT2 (view depth, id) and RT1 (octahedral normal).
SAMPLE_READ_SOURCE = """
uniform sampler2DMS u_samples;
uniform sampler2DMS u_normals;
uniform int u_sample;
out vec4 frag_color;
void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    frag_color = vec4(texelFetch(u_samples, px, u_sample).xy,
                      texelFetch(u_normals, px, u_sample).xy);
}
"""


def _texels(texture: moderngl.Texture) -> np.ndarray:
    """A float32 texture's texels, float64 (H, W, components), rows bottom-up."""
    w, h = texture.size
    data = np.frombuffer(texture.read(), np.float32)
    return data.reshape(h, w, texture.components).astype(np.float64)


def _samples(r: Renderer) -> tuple[np.ndarray, np.ndarray]:
    """(S, H, W, 2) each: the msaa pass's multisampled RT2 and octahedral normals."""
    ctx, (w, h) = r.gl.ctx, CENTRE_SIZE
    program = ctx.program(
        vertex_shader=assemble("passes/fullscreen.vert"),
        fragment_shader=assemble_text(SAMPLE_READ_SOURCE),
    )
    out = ctx.texture((w, h), 4, dtype="f4")
    fbo = ctx.framebuffer([out])
    vao = ctx.vertex_array(program, [])
    read = []
    try:
        r.msaa.samples.depth.use(0)
        r.msaa.samples.normal.use(1)
        program["u_samples"].value, program["u_normals"].value = 0, 1
        fbo.use()
        ctx.viewport = (0, 0, w, h)
        ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
        for s in range(MSAA_SAMPLES):
            program["u_sample"].value = s
            vao.render(moderngl.TRIANGLES, vertices=3)
            read.append(_texels(out))
    finally:
        for obj in (vao, fbo, out, program):
            obj.release()
    stacked = np.stack(read)
    return stacked[..., :2], stacked[..., 2:]


@pytest.mark.parametrize("sky", [False, True], ids=["uniform", "sky"])
def test_the_centre_alone_marks_a_pixel(gl_egl: GLContext, sky: bool) -> None:
    """A pixel whose centre sees a speck that none of its samples sees: the mark's test of
    the centre against sample 0 (msaa.frag) marks it, as the twin's ``msaa_edges`` does,
    and the samples alone would not; its value is the mean of its 4 samples' backgrounds
    (``msaa_background``: its own centre saw a surface, so a neighbour's background, the
    sky's radiance there); every other pixel keeps the aliased frame's value."""
    r = Renderer(gl_egl, scene_from(centre_only_data(sky)))
    try:
        assert r.antialiasing == "msaa"
        r.want_hdr()
        r.render()
        msaa, aliased = _texels(r.msaa.target), _texels(r.lighting.hdr)
        depth = np.frombuffer(r.msaa.fbo.read(components=1, attachment=-1, dtype="f4"), np.float32)
        edges = depth.reshape(CENTRE_SIZE[1], CENTRE_SIZE[0]) == 0.0
        centre = _texels(r.gbuffer.depth)
        samples, normals = _samples(r)
        background = np.resize(np.asarray(r._drawn.background, np.float64), 4)
        if len(r._drawn.background) == 3:
            background[3] = 1.0
    finally:
        r.release()
    specks = np.zeros_like(edges)
    for px, py in SPECK_PIXELS:
        specks[py, px] = True
    assert np.array_equal(edges, specks)
    assert np.array_equal(edges, twin.msaa_edges(centre, samples, normals))
    assert not twin.msaa_edges(samples[0], samples, normals).any()  # the samples agree
    assert not twin._covered(samples[..., 0]).any()  # none of them sees a speck
    picked = twin.msaa_background(aliased, centre, background)
    expected = twin.msaa_resolve(aliased, edges, np.stack([picked] * MSAA_SAMPLES))
    assert np.allclose(msaa[edges], expected[edges], rtol=1e-6, atol=0.0)
    assert np.abs(msaa[edges] - aliased[edges]).max(axis=-1).min() > 1e-3  # not the speck
    if sky:  # a neighbour's sky, not the uniform background
        assert np.abs(msaa[edges] - background).max(axis=-1).min() > 1e-2
    assert np.array_equal(msaa[~edges], aliased[~edges])
