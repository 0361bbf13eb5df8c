"""The antialiasing passes against their float64 twins (app/reference/antialiasing.py;
docs/antialiasing.md, "Twins"): a small frame of the bench's antialiasing scene is drawn
on real GL in each mode, the pass's inputs are read back from its targets, and the
twin's output from those inputs is compared with the pass's."""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest

from app.bench.antialiasing import aa_scene_data, with_aa
from app.gl.context import GLContext
from app.reference import antialiasing as twin
from app.render.renderer import Renderer, RenderOptions
from app.scene.edits import replace_parts
from app.scene.loader import LoadedScene
from app.scene.sources import scene_from

pytestmark = pytest.mark.gl

# gbaa at the size test_antialiasing.py draws it (the icosphere's triangles are under 2
# pixels at 96x54); FXAA and the accumulation at the smaller one
GBAA_SIZE = (192, 108)
SIZE = (96, 54)


def texels(texture) -> np.ndarray:
    """A texture's texels as float64 (H, W, components), rows bottom-up (GL's order)."""
    dtype = {"f1": np.uint8, "f2": np.float16, "f4": np.float32}[texture.dtype]
    w, h = texture.size
    data = np.frombuffer(texture.read(alignment=1), dtype)
    return data.reshape(h, w, texture.components).astype(np.float64)


def bytes_off(twin_image: np.ndarray, gl_bytes: np.ndarray) -> np.ndarray:
    """How far the GL's 8-bit values lie from the twin's unrounded ones, in 8-bit steps,
    beyond the half step that rounding to 8 bits may take."""
    return np.maximum(np.abs(twin_image * 255.0 - gl_bytes) - 0.5, 0.0)


# A pixel the twin and the GL agree on lies within this many 8-bit steps beyond the half
# step of rounding: the float32 shader and the float64 twin differ by a few float32
# rounding errors of the radiance, the tone map and pow (about 1e-6 relative, 3e-4 of a
# step at 255), far below it; a changed term moves a pixel by a tenth of a step and more.
STEP_TOLERANCE = 0.02


# GbaaPass's resolves, (exact, interior): the areas along the nearest axis alone (the
# baseline), exact at the corners with the edge pixels' own part along the edge (the
# renderer's), and with every interior pixel moved to its area mean (render.gbaa_interior)
GBAA_VARIANTS = {"lean": (False, False), "exact": (True, False), "interior": (True, True)}
# The renderer's, (RenderOptions.interactive, render.gbaa_interior): a still, a still with
# the interior correction, and the viewer's frame of a scene asking for it (left out)
SCENE_VARIANTS = {"still": (False, False), "interior": (False, True), "viewer": (True, True)}


def _held_to_the_fxaa_twin(
    source: np.ndarray, filtered: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Assert that FXAA's GL output ``filtered`` of ``source`` is its twin's to within a
    step wherever the twin's tie margin is clear; (the twin's edge pixels, the clear mask)."""
    expected, margin = twin.fxaa_filter_with_ties(source)
    edge, _ = twin.fxaa_edge(twin.fxaa_luma(source / 255.0))
    off = bytes_off(expected, filtered).max(axis=-1)
    clear = margin > 1e-6
    assert off[clear].max() <= STEP_TOLERANCE, np.argwhere(clear & (off > STEP_TOLERANCE))[:8]
    return edge, clear


@pytest.mark.parametrize("variant", list(SCENE_VARIANTS))
@pytest.mark.parametrize("fused", [False, True], ids=["hdr", "fused"])
def test_gbaa_resolve_is_its_twin(gl_egl: GLContext, fused: bool, variant: str) -> None:
    """gbaa's resolve (glsl/passes/gbaa.frag) against ``gbaa_resolve`` on the RT2, edge
    and HDR texels it read: every pixel of the display image within ``STEP_TOLERANCE``
    of the twin's (beyond rounding), the marked pixels the twin's ``gbaa_marked``, and
    the resolve changing some of them (measured at 192x108, lean: 798 marked, 387
    changed, none off by more than rounding), and only them but with ``gbaa_interior``
    (which the viewer's frames leave out).
    ``fused``: the lighting pass wrote the display image and the surfaces' radiance
    alone, the background's a uniform."""
    interactive, asked = SCENE_VARIANTS[variant]
    interior = asked and not interactive
    loaded = with_aa(scene_from(aa_scene_data(GBAA_SIZE)), "gbaa", 1)
    render = loaded.scene.render.model_copy(update={"gbaa_interior": asked})
    loaded = dataclasses.replace(loaded, scene=replace_parts(loaded.scene, render=render))
    r = Renderer(gl_egl, loaded, options=RenderOptions(interactive=interactive))
    try:
        r.want_hdr(not fused)
        r.render()
        assert r.gbaa is not None and r.fused_display == fused
        assert (r.gbaa.exact, r.gbaa.interior) == (True, interior)
        resolved = texels(r.post.target)
        surface, edge = texels(r.gbuffer.depth), texels(r.gbuffer.edge)
        hdr = texels(r.lighting.hdr)
        background = None
        if fused:  # the display before the resolve is not kept: the marked pixels decide
            display = resolved
            background = np.r_[np.asarray(r.scene.background, np.float64), 1.0]
        else:
            r.run_post(r.lighting.hdr)
            display = texels(r.post.target)
        scene = r.scene
    finally:
        r.release()
    expected = twin.gbaa_resolve(
        surface, edge, hdr, display, scene.camera.exposure, scene.render.tonemap,
        background=background, exact=True, interior=interior,
    )  # fmt: skip
    marked = twin.gbaa_marked(surface)
    off = bytes_off(expected, resolved).max(axis=-1)
    assert off.max() <= STEP_TOLERANCE, (np.argwhere(off > STEP_TOLERANCE)[:8], off.max())
    assert 0 < marked.sum() < marked.size // 4
    if not fused:
        changed = np.any(resolved != display, axis=-1)
        inside = (surface[..., 0] > 0) & ~marked
        assert changed.sum() > 100 and not np.any(changed & ~marked & ~(inside & interior))
        assert np.any(changed & inside) == interior


def test_gbaa_interior_fused_frame_is_the_hdr_frames(gl_egl: GLContext) -> None:
    """With ``gbaa_interior`` a plain still's lighting pass writes the surfaces' radiance
    alone and gbaa's mark every surface pixel's display value (Renderer.run_lighting):
    its display image is, byte for byte, the one drawn through the complete HDR image and
    post (``want_hdr``), and its interior pixels are corrected (they differ from the
    uncorrected still's)."""
    loaded = with_aa(scene_from(aa_scene_data(GBAA_SIZE)), "gbaa", 1)
    images = {}
    for name, interior, hdr in (("fused", True, False), ("hdr", True, True),
                                ("uncorrected", False, False)):  # fmt: skip
        render = loaded.scene.render.model_copy(update={"gbaa_interior": interior})
        variant = dataclasses.replace(loaded, scene=replace_parts(loaded.scene, render=render))
        r = Renderer(gl_egl, variant)
        try:
            r.want_hdr(hdr)
            r.render()
            assert r.fused_display == (not hdr) and r.gbaa.interior == interior
            images[name] = r.read_ldr()
        finally:
            r.release()
    assert np.array_equal(images["fused"], images["hdr"])
    assert np.count_nonzero(np.any(images["fused"] != images["uncorrected"], axis=-1)) > 100


def test_gbaa_interior_default_leaves_textured_frames_alone(gl_egl: GLContext) -> None:
    """``render.gbaa_interior`` left unset corrects a still of untextured
    surfaces, not the viewer's frames, and not a frame where an opaque surface samples a
    texture map (its detail is filtered by the mip chain already: the frame keeps the
    plain resolve's bytes); a scene that names it true gets it there too."""
    size = (128, 72)

    def frame(loaded: LoadedScene, interior: bool | None = None, interactive: bool = False):
        scene = loaded.scene
        if interior is not None:
            render = scene.render.model_copy(update={"gbaa_interior": interior})
            scene = replace_parts(scene, render=render)
        options = RenderOptions(interactive=interactive)
        r = Renderer(gl_egl, dataclasses.replace(loaded, scene=scene), size, options=options)
        try:
            r.render()
            assert r.gbaa is not None and r.gbaa.interior == r.gbaa_interior
            return r.gbaa_interior, r.read_ldr().copy()
        finally:
            r.release()

    untextured = scene_from(aa_scene_data(size))
    assert frame(untextured)[0] and not frame(untextured, interactive=True)[0]
    textured = scene_from("gltf_material_sampler")
    drawn, default = frame(textured)
    assert not drawn
    assert np.array_equal(default, frame(textured, False)[1])
    named, corrected = frame(textured, True)
    assert named and np.count_nonzero(np.any(corrected != default, axis=-1)) > 100
    # an edit validates the whole render table again (the API's set_settings, a sweep):
    # the setting left unset stays unset, so the texture rule still holds
    from app.scene.edits import edited, parse_key

    tonemap = textured.scene.render.tonemap
    again = edited(textured, [(parse_key("render.tonemap", "test"), tonemap)], "test")
    assert again.scene.render.gbaa_interior is None and not frame(again)[0]


def test_fxaa_filter_is_its_twin(gl_egl: GLContext) -> None:
    """FXAA's filter (glsl/passes/fxaa.frag) against ``fxaa_filter`` on the copy of the
    display image it read: every pixel whose comparisons the twin finds clear of a tie
    (``fxaa_filter_with_ties``' margin over 1e-6: an exact tie, common in sums of 8-bit
    lumas, the float32 shader's rounding decides) within ``STEP_TOLERANCE`` of the twin's,
    beyond rounding (measured at 96x54: 620 edge pixels, 65 at a tie, 4 of them
    differing); the ties a small part of the edge pixels."""
    loaded = scene_from(aa_scene_data(SIZE))
    r = Renderer(gl_egl, with_aa(loaded, "fxaa", 1))
    try:
        r.render()
        assert r.fxaa is not None
        source, filtered = texels(r.fxaa.source), texels(r.post.target)
    finally:
        r.release()
    edge, clear = _held_to_the_fxaa_twin(source, filtered)
    assert edge.sum() > 300 and np.count_nonzero(~clear & edge) <= 0.15 * edge.sum()
    assert np.count_nonzero(np.any(filtered != source, axis=-1)) > 300


def test_accumulation_is_its_twin(gl_egl: GLContext) -> None:
    """The jittered accumulation (glsl/passes/accumulate.frag): after each of 4 samples
    the pass's running mean (RGBA32F) is ``accumulate``'s of the samples' HDR images
    within float32 rounding (1e-6 relative; measured 1.4e-7), and the frames were
    drawn at ``jitter_offsets``' points, the twin's Halton (2, 3) points centred."""
    n = 4
    assert np.allclose(twin.jitter_offsets(4)[0], [0.5 - 1.625 / 4, 1 / 3 - 14 / 36], atol=1e-15)
    loaded = scene_from(aa_scene_data(SIZE))
    r = Renderer(gl_egl, with_aa(loaded, "jitter", n))
    try:
        samples, means = [], []
        for k in range(n):
            r.render_sample(k)
            samples.append(texels(r.lighting.hdr))
            means.append(texels(r.accumulate.target))
    finally:
        r.release()
    samples, means = np.array(samples), np.array(means)
    expected = twin.accumulate(samples)
    scale = np.abs(expected).max()
    assert np.abs(samples[0] - samples[1]).max() > 0.01 * scale  # the jitter moved the frame
    assert np.abs(means - expected).max() <= 1e-6 * scale, np.abs(means - expected).max()


def synthetic_gbaa_inputs(size: tuple[int, int], seed: int) -> dict[str, np.ndarray]:
    """RT2, edge, HDR and display texels that take every branch of the resolve, which a
    scene of a few spheres leaves untaken: blocks of surfaces and single pixels, some
    sharing a material id at view depths within and past ``GBAA_DEPTH_TOLERANCE`` of
    each other, and the background; edge distances across (0, 1.2), 30 % of them on a
    grid of quarters (so that two axes' slivers and two edges tie exactly), 15 % at 15/16,
    16 (no edge) elsewhere; in the bottom 8 rows one-pixel gaps between two-pixel columns
    of a nearer surface, whose slivers and the gap's own part sum past the pixel; radiance
    rising and falling between pixels past the 1/2-2x clamp; random display bytes."""
    rng = np.random.default_rng(seed)
    w, h = size
    blocks = rng.integers(0, 7, (h // 4 + 1, w // 4 + 1))
    label = np.kron(blocks, np.ones((4, 4), np.int64))[:h, :w]
    label = np.where(rng.random((h, w)) < 0.5, rng.integers(0, 7, (h, w)), label)
    # the bottom rows: one-pixel gaps between two-pixel columns, over the background
    ys, xs = np.mgrid[0:h, 0:w]
    stripes = np.where(xs % 3 != 0, 5, np.where(ys % 2 == 0, 4, 0))
    label = np.where(ys < 8, stripes, label)
    ids = np.array([0, 1, 1, 1, 1, 2, 3])  # labels 1-4: one material at four depths
    depths = np.array([0.0, 5.0, 5.3, 5.55, 6.2, 4.0, 7.0])  # 1-2 within 10 %, 1-3 11 %
    depth = depths[label] * (1.0 + 0.002 * (xs - ys) / w)
    surface = np.stack([np.where(label > 0, depth, 0.0), ids[label]], axis=-1)
    edge = rng.uniform(0.0, 1.2, (h, w, 4))
    pick = rng.random((h, w, 4))
    edge = np.where(pick < 0.3, np.round(edge * 4) / 4, edge)
    edge = np.where((pick >= 0.3) & (pick < 0.45), 0.9375, edge)
    edge = np.where(pick >= 0.75, 16.0, edge)
    # the gaps' neighbours reach into them along x by 3/8 or 7/16 each (equal half the
    # time), the gaps' own edges lie under half a pixel along y, toward the background
    far = np.full((h, w, 2), 16.0)
    near = np.concatenate([rng.choice([0.875, 0.9375], (h, w, 2)), far], axis=-1)
    gap = np.concatenate([far, rng.uniform(0.0, 0.5, (h, w, 2))], axis=-1)
    striped = np.where((xs % 3 != 0)[..., None], near, gap)
    edge = np.where((ys < 8)[..., None], striped, edge).astype(np.float16)
    hdr = rng.uniform(0.0, 1.0, (h, w, 4)) ** 2 * 4.0 + 0.01
    hdr[..., 3] = 1.0
    display = rng.integers(0, 256, (h, w, 4)).astype(np.uint8)
    return {"surface": surface.astype(np.float32), "edge": edge, "hdr": hdr.astype(np.float32),
            "display": display}  # fmt: skip


def drawn_gbaa(
    gl_egl: GLContext, inputs: dict[str, np.ndarray], straight: bool, exact: bool, interior: bool
) -> np.ndarray:
    """``GbaaPass``' mark and resolve drawn over the whole of ``inputs``' texels (RT2
    ``surface``, ``edge``, ``hdr``, ``display``; exposure 0.5, the neutral tone map): the
    display texels after them, float64 bytes, rows bottom-up."""
    from app.common.tonemaps import TONEMAP_CODE
    from app.gl.shaders import ShaderCache
    from app.render import antialias

    ctx = gl_egl.ctx
    size = inputs["surface"].shape[1::-1]
    gbaa = antialias.GbaaPass(ctx, ShaderCache(ctx), size, TONEMAP_CODE["neutral"], straight,
                              exact=exact, interior=interior)  # fmt: skip
    textures = {
        "surface": ctx.texture(size, 2, inputs["surface"].tobytes(), dtype="f4"),
        "edge": ctx.texture(size, 4, inputs["edge"].tobytes(), dtype="f2"),
        "hdr": ctx.texture(size, 4, inputs["hdr"].tobytes(), dtype="f4"),
        "display": ctx.texture(size, 4, inputs["display"].tobytes(), dtype="f1"),
    }
    gbuffer = SimpleNamespace(depth=textures["surface"], edge=textures["edge"])
    try:
        gbaa.mark(gbuffer, textures["display"], [(0, 0, *size)], textures["hdr"], 0.5)
        gbaa.resolve(gbuffer, textures["hdr"], textures["display"], 0.5)
        return texels(textures["display"])
    finally:
        gbaa.release()
        for t in textures.values():
            t.release()


@pytest.mark.parametrize("resolve", list(GBAA_VARIANTS))
@pytest.mark.parametrize("variant", ["quad", "fetched", "straight"])
def test_gbaa_resolve_is_its_twin_on_every_branch(
    gl_egl: GLContext, variant: str, resolve: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``GbaaPass`` drawn on synthetic texels (``synthetic_gbaa_inputs``, 64x48) against
    ``gbaa_resolve``: every pixel within ``STEP_TOLERANCE`` of the twin's beyond rounding,
    with the quad's inner neighbours from the derivatives (``quad``), fetched, and with
    premultiplied alpha in (0, 1] written straight (a transparent background's); the
    depth tolerance, the 45-degree tie of the axes and the clamp all decide pixels here
    (a twin without any one of them fails); ``resolve``: ``GBAA_VARIANTS``', where the
    corners' exact areas, the correction along the edge and the interior's decide pixels
    too."""
    from app.render import antialias

    size = (64, 48)
    inputs = synthetic_gbaa_inputs(size, seed=3)
    straight = variant == "straight"
    if straight:
        alpha = np.random.default_rng(4).uniform(0.05, 1.0, size[::-1]).astype(np.float32)
        inputs["hdr"][..., :3] *= alpha[..., None]
        inputs["hdr"][..., 3] = alpha
    if variant == "fetched":
        monkeypatch.setattr(antialias, "quad_neighbour_defines", lambda ctx, shaders: {})
    exact, interior = GBAA_VARIANTS[resolve]
    resolved = drawn_gbaa(gl_egl, inputs, straight, exact, interior)
    expected = twin.gbaa_resolve(
        inputs["surface"], inputs["edge"], inputs["hdr"], inputs["display"], 0.5, "neutral",
        straight_alpha=straight, exact=exact, interior=interior,
    )  # fmt: skip
    off = bytes_off(expected, resolved).max(axis=-1)
    assert off.max() <= STEP_TOLERANCE, (np.argwhere(off > STEP_TOLERANCE)[:8], off.max())
    assert np.count_nonzero(np.any(resolved != inputs["display"], axis=-1)) > 0.3 * off.size


def test_gbaa_half_covered_pixel_past_its_neighbours_reach(gl_egl: GLContext) -> None:
    """A background pixel half covered by a slanted edge whose front neighbours' distances
    toward it lie just past one pixel (the bench's spheres at 320x180, the red sphere's
    upper right: 1.005 along y from the pixel below, 1.094 along x from the pixel to the
    left, the 4x4 samples' coverage 0.50): the exact resolve gives it half the front
    surface's radiance (the half-plane's area, capped at the half a half-plane missing the
    centre can cover), the twin and the GLSL alike, where a reach of one pixel left it
    empty."""
    h, w = 6, 8
    surface = np.zeros((h, w, 2), np.float32)
    edge = np.full((h, w, 4), 16.0, np.float16)
    hdr = np.zeros((h, w, 4), np.float32)
    hdr[..., 3] = 1.0
    x, y = 4, 3  # the pixel; rows bottom-up, +y up
    front = [(x - 1, y), (x, y - 1), (x - 1, y - 1), (x - 2, y), (x, y - 2), (x - 1, y - 2)]
    for fx, fy in front:
        surface[fy, fx] = (5.0, 1.0)
        hdr[fy, fx, :3] = 1.0
    # (+x, -x, +y, -y): the left neighbour's edge toward +x, the lower one's toward +y
    edge[y, x - 1] = (1.094, 16.0, 1.15, 16.0)
    edge[y - 1, x] = (1.06, 16.0, 1.005, 16.0)
    inputs = {"surface": surface, "edge": edge, "hdr": hdr,
              "display": np.zeros((h, w, 4), np.uint8)}  # fmt: skip
    weight, _ = twin.gbaa_coverage(surface, edge, exact=True)
    assert 0.45 <= weight[y, x].sum() <= 0.5, weight[y, x]
    resolved = drawn_gbaa(gl_egl, inputs, straight=False, exact=True, interior=False)
    expected = twin.gbaa_resolve(surface, edge, hdr, inputs["display"], 0.5, "neutral", exact=True)
    off = bytes_off(expected, resolved).max(axis=-1)
    assert off.max() <= STEP_TOLERANCE, (np.argwhere(off > STEP_TOLERANCE)[:8], off.max())
    dim = twin.gbaa_display_value(np.array([0.4, 0.4, 0.4, 1.0]), 0.5, "neutral")[0]
    assert resolved[y, x, 0] > 255.0 * dim, (resolved[y, x], dim)


def test_gbaa_interior_leaves_out_a_peak_whose_share_is_white(gl_egl: GLContext) -> None:
    """The interior correction on one surface (10x8, radiance 0.1) with two peaks one pixel
    wide: around the one past ``GBAA_SPILL`` times the display's white each neighbour
    keeps its own display value (the peak counts as ``c``), where without the guard the
    four brightened into a plus;
    around the one under it they rise as the correction has them. GL and twin alike."""
    h, w = 8, 10
    surface = np.zeros((h, w, 2), np.float32)
    surface[..., 0], surface[..., 1] = 5.0, 1.0
    hdr = np.full((h, w, 4), 0.1, np.float32)
    hdr[..., 3] = 1.0
    spill = twin.GBAA_SPILL * twin.gbaa_saturation("neutral") / 2.0**0.5
    hot, warm = (4, 2), (3, 7)  # (y, x), rows bottom-up
    hdr[hot][:3], hdr[warm][:3] = 30.0 * spill, 0.5 * spill  # its share alone white; under it
    inputs = {"surface": surface, "edge": np.full((h, w, 4), 16.0, np.float16), "hdr": hdr,
              "display": np.zeros((h, w, 4), np.uint8)}  # fmt: skip
    resolved = drawn_gbaa(gl_egl, inputs, straight=False, exact=True, interior=True)
    expected = twin.gbaa_resolve(surface, inputs["edge"], hdr, inputs["display"], 0.5, "neutral",
                                 exact=True, interior=True)  # fmt: skip
    off = bytes_off(expected, resolved).max(axis=-1)
    assert off.max() <= STEP_TOLERANCE, (np.argwhere(off > STEP_TOLERANCE)[:8], off.max())
    plain = 255.0 * twin.gbaa_display_value(hdr[0, 0], 0.5, "neutral")[0]
    unguarded = twin.gbaa_interior_radiance(hdr[0, 0], [hdr[hot]] + [hdr[0, 0]] * 3)
    assert twin.gbaa_display_value(unguarded, 0.5, "neutral")[0] > 254.5 / 255.0
    for (y, x), kept in ((hot, True), (warm, False)):
        around = [resolved[y + dy, x + dx, 0] for dx, dy in twin.STEPS]
        assert all((abs(v - plain) <= 0.5) == kept for v in around), (around, plain)


def test_fxaa_filter_is_its_twin_on_alpha_and_borders(gl_egl: GLContext) -> None:
    """``FxaaPass`` on a synthetic RGBA8 image (61x35, no multiple of the 4-pixel blocks:
    blocks of colour and single pixels, alpha in 1..255, edges at every border) against
    ``fxaa_filter``: the pixels clear of a tie within ``STEP_TOLERANCE`` of the twin's,
    colour and alpha (the mix premultiplied in linear light, divided again); measured:
    1861 edge pixels, 252 at a tie, 28 of them differing, none elsewhere (with the exact
    bilinear mix, not llvmpipe's 8-bit one, 8 pixels clear of a tie differ by up to 72
    steps)."""
    from app.gl.shaders import ShaderCache
    from app.render.antialias import FxaaPass

    size = (61, 35)
    rng = np.random.default_rng(5)
    w, h = size
    blocks = rng.integers(0, 256, (h // 3 + 1, w // 3 + 1, 4))
    image = np.kron(blocks, np.ones((3, 3, 1), np.int64))[:h, :w]
    image = np.where(rng.random((h, w, 1)) < 0.15, rng.integers(0, 256, (h, w, 4)), image)
    image[..., 3] = np.maximum(image[..., 3], 1)
    image = image.astype(np.uint8)
    ctx = gl_egl.ctx
    fxaa = FxaaPass(ctx, ShaderCache(ctx), size)
    display = ctx.texture(size, 4, image.tobytes(), dtype="f1")
    try:
        fxaa.run(display)
        filtered = texels(display)
    finally:
        fxaa.release()
        display.release()
    edge, clear = _held_to_the_fxaa_twin(image, filtered)
    assert edge.sum() > 0.5 * edge.size and np.count_nonzero(~clear & edge) <= 0.15 * edge.sum()
    assert np.count_nonzero(np.any(filtered != image, axis=-1)) > 0.4 * edge.size
