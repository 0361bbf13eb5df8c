"""render.antialiasing = "msaa" (app/render/msaa.py, docs/antialiasing.md): a pixel whose
multisampled G-buffer samples differ is the mean of its samples' shading, each sample
shaded by the lighting pass itself (every target's sample s copied into the one-sample
G-buffer, then the ordinary lighting pass); every other pixel keeps the aliased frame's
HDR value bit for bit; the silhouettes come closer to the 4x4 supersampled frame; a scene
with blended parts falls back to "fxaa" with one note."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from app.bench.antialiasing import aa_scene_data, with_aa
from app.gl.context import GLContext
from app.gl.fullscreen import FullscreenDraw
from app.gl.shaders import GLSL_VERSION
from app.reference import msaa as twin
from app.render.msaa import MSAA_SAMPLES
from app.render.renderer import Renderer
from app.scene.sources import scene_from
from tests.conftest import REPO

pytestmark = pytest.mark.gl

SIZE = (96, 54)


def _sample_copy_source(r: Renderer) -> str:
    """A fragment shader that writes sample ``u_sample`` of every multisampled target of
    ``r``'s msaa pass into the one-sample G-buffer's target at the same location, and
    window depth 0 where that sample holds a surface (1 elsewhere), so that the lighting
    pass's z-test passes exactly there."""
    lines = ["uniform int u_sample;"]
    body = []
    for location, (target, channels) in enumerate(r.msaa.samples.layout.targets()):
        lines.append(f"uniform sampler2DMS s_{target.name};")
        lines.append(f"layout(location = {location}) out vec{channels} o_{target.name};")
        swizzle = "xyzw"[:channels]
        body.append(f"o_{target.name} = texelFetch(s_{target.name}, px, u_sample).{swizzle};")
    body.append("float z = texelFetch(s_depth, px, u_sample).x;")
    body.append("gl_FragDepth = z > 0.0 ? 0.0 : 1.0;")
    return "\n".join([*lines, "void main() {", "ivec2 px = ivec2(gl_FragCoord.xy);", *body, "}"])


def _texels(texture) -> np.ndarray:
    """A float32 texture's texels, float64 (H, W, components), rows bottom-up."""
    w, h = texture.size
    data = np.frombuffer(texture.read(), np.float32)
    return data.reshape(h, w, texture.components).astype(np.float64)


_hdr = _texels


def per_sample_shading(r: Renderer) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(S, H, W, 4): the HDR image of each multisampled G-buffer sample of ``r``'s last
    frame, shaded by ``r``'s own lighting pass (its G-buffer overwritten, sample by sample;
    the background's clear where the sample holds no surface); and each sample's RT2
    (S, H, W, 2) and octahedral normal (S, H, W, 2), read back from those copies."""
    ctx, (w, h) = r.gl.ctx, SIZE
    program = ctx.program(
        vertex_shader=f"{GLSL_VERSION}\n" + (REPO / "glsl/passes/fullscreen.vert").read_text(),
        fragment_shader=f"{GLSL_VERSION}\n{_sample_copy_source(r)}",
    )
    textures = {f"s_{t.name}": getattr(r.msaa.samples, t.name)
                for t, _ in r.msaa.samples.layout.targets()}  # fmt: skip
    out, surfaces, normals = [], [], []
    try:
        for s in range(MSAA_SAMPLES):
            r.gbuffer.fbo.depth_mask = True
            FullscreenDraw(ctx, program).draw(
                r.gbuffer.fbo, {"u_sample": s}, textures, viewport=(0, 0, w, h), depth_func="1"
            )
            r.lighting.run(r.gbuffer, r.camera, r._drawn.background)
            out.append(_hdr(r.lighting.hdr))
            surfaces.append(_texels(r.gbuffer.depth))
            normals.append(_texels(r.gbuffer.normal)[..., :2])
    finally:
        program.release()
    return np.stack(out), np.stack(surfaces), np.stack(normals)


# Two spheres of two materials that intersect (only the material id tells their seam
# apart), and one of the first material further back.
SEAM_OBJECTS = [
    {"shape": "sphere", "radius": 0.6, "position": [-0.35, 0.0, 0.0], "material": "white"},
    {"shape": "sphere", "radius": 0.6, "position": [0.45, 0.0, 0.0], "material": "red"},
    {"shape": "sphere", "radius": 0.6, "position": [-1.3, 0.4, -1.5], "material": "white"},
]


def _plane(position: list[float], material: str) -> dict:
    """A 1.2 m square facing the camera."""
    return {"shape": "plane", "size": [1.2, 1.2], "position": position,
            "rotation": [90.0, 0.0, 0.0], "material": material}  # fmt: skip


# Squares facing the camera, so that one test alone tells each pair apart: one material
# 3 % deeper (the depth tolerance alone), and another material 0.3 % deeper (the id alone).
PLANE_OBJECTS = [
    _plane([-1.3, 0.0, 0.0], "white"),
    _plane([-0.9, 0.3, -0.2], "white"),
    _plane([0.9, 0.0, 0.0], "white"),
    _plane([1.3, 0.3, -0.02], "red"),
]
OBJECTS = {"seam": SEAM_OBJECTS, "planes": PLANE_OBJECTS}


@pytest.mark.parametrize("objects", ["bench", "seam", "planes"])
def test_edge_pixels_are_the_mean_of_their_samples_shading(gl_egl: GLContext, objects: str) -> None:
    """The marked pixels: those the twin marks from the samples read back
    (app/reference/msaa.py ``msaa_edges``), each the mean of the lighting pass's radiance
    of its samples (``msaa_resolve``; float32 rounding of a sum of four); every other pixel:
    the aliased frame's HDR, bit for bit."""
    data = aa_scene_data(SIZE)
    if objects in OBJECTS:
        data["objects"] = OBJECTS[objects]
    r = Renderer(gl_egl, with_aa(scene_from(data), "msaa", 8))
    try:
        r.want_hdr()
        r.render()
        msaa = _hdr(r.msaa.target)
        aliased = _hdr(r.lighting.hdr)
        depth = np.frombuffer(r.msaa.fbo.read(components=1, attachment=-1, dtype="f4"), np.float32)
        edges = depth.reshape(SIZE[1], SIZE[0]) == 0.0
        centre = _texels(r.gbuffer.depth)  # before per_sample_shading overwrites it
        radiance, surfaces, normals = per_sample_shading(r)
    finally:
        r.release()
    assert 50 < edges.sum() < 0.3 * edges.size
    assert np.array_equal(edges, twin.msaa_edges(centre, surfaces, normals))
    expected = twin.msaa_resolve(aliased, edges, radiance)
    assert np.allclose(msaa[edges], expected[edges], rtol=1e-5, atol=1e-6)
    # the samples differ there: not the aliased centre's value (at most of them)
    differs = np.abs(msaa[edges] - aliased[edges]).max(axis=-1) > 1e-4
    assert differs.mean() > 0.5
    assert np.array_equal(msaa[~edges], aliased[~edges])


def test_msaa_comes_closer_at_the_silhouettes(gl_egl: GLContext) -> None:
    """The silhouette error against the 4x4 supersampled frame falls at least 2x (its 4
    samples against the reference's 16; 2.6x measured at 96x54), and the display image is
    unchanged away from every silhouette."""
    loaded = scene_from(aa_scene_data(SIZE))
    images = {}
    for mode, factor in (("none", 1), ("msaa", 1), ("none", 4)):
        r = Renderer(gl_egl, with_aa(loaded, mode, 8, factor))
        try:
            r.render()
            images[(mode, factor)] = r.read_ldr().astype(np.float64) / 255.0
            if factor == 4:
                g = r.read_gbuffer()
        finally:
            r.release()
    w, h = SIZE
    ids = np.where(g.covered, g.material_id.astype(np.int64), -1).reshape(h, 4, w, 4)
    silhouettes = ids.min(axis=(1, 3)) != ids.max(axis=(1, 3))
    ref = images[("none", 4)]

    def error(image: np.ndarray) -> float:
        return float(np.abs(image - ref).mean(axis=2)[silhouettes].mean())

    assert error(images[("msaa", 1)]) * 2.0 < error(images[("none", 1)])
    near = silhouettes.copy()
    for axis in (0, 1):
        for step in (-1, 1):
            near |= np.roll(silhouettes, step, axis=axis)
    assert np.array_equal(images[("msaa", 1)][~near], images[("none", 1)][~near])


def test_blended_parts_fall_back_to_fxaa(
    gl_egl: GLContext, caplog: pytest.LogCaptureFixture
) -> None:
    """A frame with an alpha-blended part draws "fxaa" (the per-sample shading would
    overwrite the blend at the edges), noted once."""
    data = aa_scene_data(SIZE)
    data["materials"]["glass"] = {"base_color": [0.9, 0.9, 0.9], "alpha": 0.4,
                                  "alpha_mode": "blend"}  # fmt: skip
    data["objects"][0]["material"] = "glass"
    with caplog.at_level(logging.INFO, logger="pbs"):
        r = Renderer(gl_egl, with_aa(scene_from(data), "msaa", 8))
        try:
            assert r.antialiasing == "fxaa"
            assert r.msaa is None and r.fxaa is not None
        finally:
            r.release()
    assert sum('"msaa" does not resolve' in m for m in caplog.messages) == 1
