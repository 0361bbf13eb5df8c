"""render.antialiasing (docs/antialiasing.md): "none" is the aliased frame, bit for bit;
"fxaa", "jitter", "sraa" and "gbaa" come closer to the renderer's own 4x4 supersampled
frame at the silhouettes; "sraa"'s geometry samples see an analytic sphere's edge per
sample; "gbaa"'s edge distances give the coverage of analytic spheres and meshes;
jittered accumulation converges as its samples grow; a bad value is one error line
naming the key, exit 2."""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from app.bench.antialiasing import aa_scene_data, with_aa
from app.gl.context import GLContext
from app.gl.fullscreen import FullscreenDraw
from app.gl.shaders import DERIVATIVE_CONTROL, GLSL_VERSION, ShaderCache
from app.reference.antialiasing import halton, jitter_offsets
from app.render import antialias
from app.render.adjacency import adjacency_indices
from app.render.antialias import SRAA_SAMPLES, sphere_window_rects
from app.render.renderer import Renderer
from app.scene.edits import replace_parts
from app.scene.loader import LoadedScene
from app.scene.sources import scene_from
from tests.conftest import REPO

SIZE = (96, 54)


@pytest.fixture(scope="module")
def loaded() -> LoadedScene:
    """The bench's antialiasing scene (app/bench/antialiasing.py) at ``SIZE``."""
    return scene_from(aa_scene_data(SIZE))


def _display(
    gl: GLContext, loaded: LoadedScene, mode: str, n: int = 8
) -> tuple[np.ndarray, set[str]]:
    """The display image (0..1) of ``mode`` with ``n`` samples, and the objects built."""
    r = Renderer(gl, with_aa(loaded, mode, n))
    try:
        r.render()
        built = {name for name, key in r.keys.items() if key is not None}
        return r.read_ldr().astype(np.float64) / 255.0, built
    finally:
        r.release()


@pytest.fixture(scope="module")
def truth(gl_egl: GLContext, loaded: LoadedScene) -> tuple[np.ndarray, np.ndarray]:
    """The 4x4 supersampled display image and its silhouette pixels (the 4x4 block of
    G-buffer samples holds more than one material, or surface and background)."""
    r = Renderer(gl_egl, with_aa(loaded, "none", 8, 4))
    try:
        r.render()
        image = r.read_ldr().astype(np.float64) / 255.0
        g = r.read_gbuffer()
    finally:
        r.release()
    w, h = SIZE
    ids = np.where(g.covered, g.material_id.astype(np.int64), -1).reshape(h, 4, w, 4)
    return image, ids.min(axis=(1, 3)) != ids.max(axis=(1, 3))


def _silhouette_error(image: np.ndarray, truth: tuple[np.ndarray, np.ndarray]) -> float:
    ref, edges = truth
    return float(np.abs(image - ref).mean(axis=2)[edges].mean())


def test_halton_points_cover_the_pixel() -> None:
    """Halton (2, 3): the radical inverses; the offsets are centred on the pixel."""
    assert [halton(k, 2) for k in (1, 2, 3, 4)] == [0.5, 0.25, 0.75, 0.125]
    assert halton(1, 3) == pytest.approx(1 / 3) and halton(4, 3) == pytest.approx(4 / 9)
    offsets = jitter_offsets(8)
    assert np.allclose(offsets.mean(axis=0), 0.0)
    assert np.abs(offsets).max() < 0.75
    assert len({tuple(o) for o in offsets}) == 8


def test_one_centred_sample_is_the_aliased_frame(gl_egl: GLContext, loaded: LoadedScene) -> None:
    """ "jitter" with one sample (offset 0 after centring) draws the frame through the
    jittered matrices, the HDR path and the accumulation, and gives "none"'s display
    image to the bit: the machinery adds nothing where the jitter is zero."""
    plain, built = _display(gl_egl, loaded, "none")
    one, built_one = _display(gl_egl, loaded, "jitter", 1)
    assert not built & {"fxaa", "accumulate"} and "accumulate" in built_one
    assert np.array_equal(plain, one)


def test_each_mode_lowers_the_silhouette_error(
    gl_egl: GLContext, loaded: LoadedScene, truth: tuple[np.ndarray, np.ndarray]
) -> None:
    """Against the 4x4 supersampled frame at the silhouettes: FXAA at least 1.5x and
    8 jittered samples at least 3x below "none" (measured at 96x54: about 2x and 4.5x;
    docs/antialiasing.md)."""
    none = _silhouette_error(_display(gl_egl, loaded, "none")[0], truth)
    fxaa = _silhouette_error(_display(gl_egl, loaded, "fxaa")[0], truth)
    jitter = _silhouette_error(_display(gl_egl, loaded, "jitter", 8)[0], truth)
    assert none > 0.02  # the scene does alias
    assert fxaa <= none / 1.5
    assert jitter <= none / 3.0


def test_subpixel_reconstruction_beats_fxaa(
    gl_egl: GLContext, loaded: LoadedScene, truth: tuple[np.ndarray, np.ndarray]
) -> None:
    """ "sraa" against the 4x4 supersampled frame at the silhouettes: at least 2.8x below
    "none" and below FXAA (measured at 96x54: 3.2x below "none", FXAA 1.8x;
    docs/antialiasing.md); the mark and the reconstruction leave the interior's pixels
    as they were shaded."""
    none = _silhouette_error(_display(gl_egl, loaded, "none")[0], truth)
    fxaa = _silhouette_error(_display(gl_egl, loaded, "fxaa")[0], truth)
    sraa_image, built = _display(gl_egl, loaded, "sraa")
    sraa = _silhouette_error(sraa_image, truth)
    assert "sraa" in built and "fxaa" not in built
    assert sraa <= none / 2.8
    assert sraa < fxaa
    plain = _display(gl_egl, loaded, "none")[0]
    _, edges = truth
    interior = ~edges
    interior[1:] &= ~edges[:-1]
    interior[:-1] &= ~edges[1:]
    interior[:, 1:] &= ~edges[:, :-1]
    interior[:, :-1] &= ~edges[:, 1:]
    assert np.abs(sraa_image - plain)[interior].max() <= 1.0 / 255.0


def test_geometry_samples_see_the_analytic_edge(gl_egl: GLContext, loaded: LoadedScene) -> None:
    """The multisampled geometry pass ray-casts an analytic sphere per sample
    (gl_SampleMask): pixels whose samples are partly sphere, partly background, exist
    along the analytic spheres' edges, as many as along the polygonal one's per unit of
    its outline; a centre-only discard would give every sample the centre's answer."""
    r = Renderer(gl_egl, with_aa(loaded, "sraa", 8))
    ctx, w, h = gl_egl.ctx, *SIZE
    count = ctx.program(
        vertex_shader=f"{GLSL_VERSION}\n" + (REPO / "glsl/passes/fullscreen.vert").read_text(),
        fragment_shader=f"""{GLSL_VERSION}
        uniform sampler2DMS u_samples;
        out vec4 covered;
        void main() {{
            float n = 0.0;
            for (int s = 0; s < {SRAA_SAMPLES}; ++s)
                n += float(texelFetch(u_samples, ivec2(gl_FragCoord.xy), s).x > 0.0);
            covered = vec4(n);
        }}""",
    )
    out = ctx.texture(SIZE, 4, dtype="f4")
    fbo = ctx.framebuffer([out])
    try:
        r.render()
        FullscreenDraw(ctx, count).draw(
            fbo, {}, {"u_samples": r.sraa.samples.depth}, viewport=(0, 0, w, h)
        )
        covered = np.frombuffer(out.read(), np.float32).reshape(h, w, 4)[..., 0]
    finally:
        for obj in (fbo, out, count):
            obj.release()
        r.release()
    partial = (covered > 0) & (covered < SRAA_SAMPLES)
    # the analytic spheres lie left of the icosphere (x > 0.75 w)
    assert partial[:, : int(0.7 * w)].sum() >= 30
    assert partial[:, int(0.75 * w) :].sum() >= 10


def test_subpixel_reconstruction_follows_a_restyle(gl_egl: GLContext, loaded: LoadedScene) -> None:
    """A material edit that merges two table rows gives the kept parts new material ids
    (``refresh``): the geometry samples take them too, so the edited renderer's image is
    a fresh renderer's of the edited scene, to the bit."""
    r = Renderer(gl_egl, with_aa(loaded, "sraa", 8))
    try:
        r.render()
        materials = dict(r.scene.materials)
        materials["white"] = materials["red"]  # one row for both: the ids change
        r.set_materials(materials)
        assert "sraa" not in r.rebuilt
        r.render()
        edited = r.read_ldr()
        fresh = Renderer(gl_egl, dataclasses.replace(loaded, scene=r.scene))
        try:
            fresh.render()
            assert np.array_equal(edited, fresh.read_ldr())
        finally:
            fresh.release()
    finally:
        r.release()


def test_accumulation_converges(
    gl_egl: GLContext, loaded: LoadedScene, truth: tuple[np.ndarray, np.ndarray]
) -> None:
    """The silhouette error falls as the jittered samples grow (2, 4, 16)."""
    errors = [
        _silhouette_error(_display(gl_egl, loaded, "jitter", n)[0], truth) for n in (2, 4, 16)
    ]
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] <= errors[0] / 2.5


def test_samples_one_by_one_are_the_still(gl_egl: GLContext, loaded: LoadedScene) -> None:
    """A viewer's progressive accumulation (``render_sample`` 0..N-1) ends on the image
    ``render()`` makes; sample 0 alone is a jittered aliased frame."""
    still, _ = _display(gl_egl, loaded, "jitter", 4)
    r = Renderer(gl_egl, with_aa(loaded, "jitter", 4))
    try:
        r.render_sample(0)
        first = r.read_ldr()
        for k in range(1, 4):
            r.render_sample(k)
        assert r.accumulate.samples == 4
        assert np.array_equal(r.read_ldr().astype(np.float64) / 255.0, still)
        assert not np.array_equal(first, r.read_ldr())
    finally:
        r.release()


def test_switching_mode_builds_only_its_pass(gl_egl: GLContext, loaded: LoadedScene) -> None:
    """The mode is a key of the schedule: "none" -> "fxaa" builds the filter alone, and
    "fxaa" -> "jitter" drops it and builds the accumulation (post stays)."""
    r = Renderer(gl_egl, with_aa(loaded, "none", 8))
    try:
        settings = r.scene.render
        r.set_settings(settings.model_copy(update={"antialiasing": "fxaa"}))
        assert r.rebuilt == ("fxaa",)
        r.set_settings(settings.model_copy(update={"antialiasing": "jitter"}))
        assert set(r.rebuilt) == {"accumulate", "fxaa"} and r.fxaa is None
        r.render()
        assert r.read_hdr().shape == (SIZE[1], SIZE[0], 3)
    finally:
        r.release()


@pytest.mark.parametrize(
    ("line", "key"),
    [('antialiasing = "ssaa"', "render.antialiasing"),
     ("antialiasing_samples = 0", "render.antialiasing_samples")],
)  # fmt: skip
def test_bad_value_is_one_line_exit_2(tmp_path: Path, line: str, key: str) -> None:
    """A value outside the choices: one error line naming file and key, exit 2, no PNG."""
    text = (REPO / "scenes" / "sec4_lights.toml").read_text(encoding="utf-8")
    assert "[render]" in text
    scene = tmp_path / "bad.toml"
    scene.write_text(text.replace("[render]", f"[render]\n{line}", 1), encoding="utf-8")
    proc = subprocess.run(
        [sys.executable, "-m", "app", "render", str(scene), "-o", str(tmp_path / "x.png")],
        capture_output=True, text=True, timeout=120, check=False,
        env={**os.environ, "PYTHONPATH": str(REPO)},
    )  # fmt: skip
    assert proc.returncode == 2
    assert key in proc.stderr and "bad.toml" in proc.stderr
    assert proc.stderr.count("\n") == 1
    assert not (tmp_path / "x.png").exists()


def test_sraa_without_enough_samples_is_one_line(gl_egl: GLContext) -> None:
    """A GL that cannot draw sraa's geometry samples refuses the key with one line before
    anything is built (here: more samples than any GL offers), not a shader error."""
    from app.errors import InputError
    from app.render.limits import check_multisampling

    check_multisampling(gl_egl.ctx, SRAA_SAMPLES, "s.toml", "render.antialiasing")  # this GL
    with pytest.raises(InputError) as refused:
        check_multisampling(gl_egl.ctx, 1 << 20, "s.toml", "render.antialiasing")
    text = str(refused.value)
    assert "s.toml" in text and "render.antialiasing" in text and "\n" not in text, text


# --- "gbaa": the geometric edge resolve -------------------------------------------------

# The icosphere is dense for the edge distances at 96x54 (its triangles under 2 pixels):
# these tests take the scene at twice the size.
EDGE_SIZE = (192, 108)
ICOSPHERE = 3  # the scene's object index of the polygonal sphere


@pytest.fixture(scope="module")
def edge_truth(gl_egl: GLContext) -> tuple[LoadedScene, np.ndarray, np.ndarray, np.ndarray]:
    """The scene at ``EDGE_SIZE``, its 4x4 supersampled display image, the silhouette
    pixels (as ``truth``), each pixel's 4x4 coverage and whether its block holds the
    icosphere."""
    loaded = scene_from(aa_scene_data(EDGE_SIZE))
    r = Renderer(gl_egl, with_aa(loaded, "none", 8, 4))
    try:
        r.render()
        image = r.read_ldr().astype(np.float64) / 255.0
        g = r.read_gbuffer()
        mesh_id = r.frame.material_ids[ICOSPHERE][0]
    finally:
        r.release()
    w, h = EDGE_SIZE
    ids = np.where(g.covered, g.material_id.astype(np.int64), -1).reshape(h, 4, w, 4)
    edges = ids.min(axis=(1, 3)) != ids.max(axis=(1, 3))
    coverage = g.covered.reshape(h, 4, w, 4).mean(axis=(1, 3))
    return loaded, image, edges, (coverage, (ids == mesh_id).any(axis=(1, 3)))


def test_geometric_resolve_lowers_the_silhouette_error(gl_egl: GLContext, edge_truth) -> None:
    """ "gbaa" against the 4x4 supersampled frame at the silhouettes: at least 1.9x below
    "none" and below FXAA (measured at 192x108: 2.3x, FXAA 2.0x; 4.5x at the bench's
    640x360); the G-buffer has the edge target in this mode alone; without the interior
    correction (``render.gbaa_interior``, on by default in this untextured still) the
    pixels away from every silhouette keep the aliased frame's bytes (the resolve runs at
    marked pixels and mixes only across surfaces)."""
    loaded, ref, edges, _ = edge_truth
    truth = (ref, edges)
    none_image, _ = _display(gl_egl, loaded, "none")
    none = _silhouette_error(none_image, truth)
    fxaa = _silhouette_error(_display(gl_egl, loaded, "fxaa")[0], truth)
    r = Renderer(gl_egl, with_aa(loaded, "gbaa", 8))
    try:
        r.render()
        image = r.read_ldr().astype(np.float64) / 255.0
        assert r.gbuffer.edge is not None and r.fxaa is None
    finally:
        r.release()
    gbaa = _silhouette_error(image, truth)
    assert gbaa <= none / 1.9, (none, gbaa)
    assert gbaa < fxaa
    interior = ~edges
    interior[1:] &= ~edges[:-1]
    interior[:-1] &= ~edges[1:]
    interior[:, 1:] &= ~edges[:, :-1]
    interior[:, :-1] &= ~edges[:, 1:]
    assert np.abs(image - none_image)[interior].max() > 2.0 / 255.0  # the correction's
    scene = with_aa(loaded, "gbaa", 8).scene
    render = scene.render.model_copy(update={"gbaa_interior": False})
    r = Renderer(gl_egl, dataclasses.replace(loaded, scene=replace_parts(scene, render=render)))
    try:
        r.render()
        image = r.read_ldr().astype(np.float64) / 255.0
    finally:
        r.release()
    assert _silhouette_error(image, truth) <= none / 1.9
    assert np.abs(image - none_image)[interior].max() <= 1.0 / 255.0
    # with supersampling the box filter is the resolve: no edge target, no pass
    r = Renderer(gl_egl, with_aa(loaded, "gbaa", 8, 2))
    try:
        assert r.gbaa is None and r.gbuffer.edge is None
    finally:
        r.release()


def test_gbaa_quad_neighbours_are_the_fetched_ones(
    gl_egl: GLContext, edge_truth, monkeypatch: pytest.MonkeyPatch
) -> None:
    """gbaa's draws taking a 2x2 quad's inner neighbour from the derivatives give the
    display bytes of the five fetches they replace (the path of a GL whose derivatives
    are coarse): with dFdxFine/dFdyFine (GLSL 4.00 and GL_ARB_derivative_control,
    llvmpipe's path here) and with dFdx/dFdy, which the probe finds fine on llvmpipe."""
    loaded = edge_truth[0]
    ctx = gl_egl.ctx
    shaders = ShaderCache(ctx)
    assert ctx.version_code >= 400 and DERIVATIVE_CONTROL in ctx.extensions
    assert antialias.quad_neighbour_defines(ctx, shaders) == {
        "QUAD_NEIGHBOURS": 1,
        "FINE_DERIVATIVES": 1,
    }
    assert antialias.fine_derivatives(ctx, shaders)
    fine, _ = _display(gl_egl, loaded, "gbaa")
    paths = {
        "dFdx": {"QUAD_NEIGHBOURS": 1},  # a GL 3.3 context whose probe passed
        "fetched": {},  # a GL whose derivatives are coarse
    }
    for name, defines in paths.items():
        monkeypatch.setattr(antialias, "quad_neighbour_defines", lambda c, s, d=defines: d)
        other, _ = _display(gl_egl, loaded, "gbaa")
        assert np.array_equal(fine, other), name


def test_edge_coverage_of_analytic_spheres_and_meshes(gl_egl: GLContext, edge_truth) -> None:
    """With a transparent background the resolve's coverage is the display image's
    alpha: against the 4x4 samples' coverage at the silhouettes, at least 4x closer than
    the aliased frame's at the analytic spheres' (measured 6x: r - |f| and its screen
    slope) and 1.6x at the icosphere's (measured 1.9x at this size: its silhouette edges
    from the triangles' adjacency, its rim's slivers crossed)."""
    loaded, _, edges, (coverage, mesh) = edge_truth
    scene = loaded.scene
    render = scene.render.model_copy(update={"background": "transparent"})
    clear = dataclasses.replace(loaded, scene=replace_parts(scene, render=render))
    errors = {}
    for mode in ("none", "gbaa"):
        r = Renderer(gl_egl, with_aa(clear, mode, 8))
        try:
            r.render()
            alpha = r.read_rgba()[..., 3].astype(np.float64) / 255.0
        finally:
            r.release()
        diff = np.abs(alpha - coverage)
        errors[mode] = (diff[edges & ~mesh].mean(), diff[edges & mesh].mean())
    assert errors["gbaa"][0] <= errors["none"][0] / 4.0, errors
    assert errors["gbaa"][1] <= errors["none"][1] / 1.6, errors


def test_adjacency_finds_each_edge_s_neighbour() -> None:
    """GL_TRIANGLES_ADJACENCY indices: each triangle's vertices at 0, 2, 4 and across
    each edge the neighbour's far vertex, matched by position (a split vertex of a seam
    is one vertex); an open edge takes its own first vertex (a degenerate neighbour,
    which the geometry stage takes for a silhouette)."""
    # two triangles sharing the edge 1-2, the second through a copy of vertex 2 (a seam)
    positions = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0, 1, 0]], np.float32)
    out = adjacency_indices(positions, np.array([0, 1, 2, 4, 1, 3], np.uint32)).reshape(-1, 6)
    assert out.tolist() == [[0, 0, 1, 3, 2, 2], [4, 0, 1, 1, 3, 3]]
    # a closed tetrahedron: every edge has its neighbour, never the triangle's own vertex
    tetra = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], np.float32)
    faces = np.array([0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3], np.uint32)
    adj = adjacency_indices(tetra, faces).reshape(-1, 6)
    for tri in adj:
        assert len(set(tri[0::2].tolist()) | set(tri[1::2].tolist())) == 4


def test_vertices_weld_by_position_as_unique_rows_do() -> None:
    """The adjacency's welding of split vertices (``adjacency._welded``): ids equal where
    positions compare equal, -0 and +0 welded, numbered as ``np.unique(axis=0)``'s inverse
    (the lexicographic order of the rows), on coincident and nearly coincident points."""
    from app.render.adjacency import _welded

    rng = np.random.default_rng(4)
    for case in range(20):
        p = (rng.integers(-2, 3, (300, 3)) * 0.5).astype(np.float32)
        p[rng.random(300) < 0.3] *= -1.0  # some +0 become -0
        if case % 2:
            p[::7] += np.float32(1e-6)  # near, not equal
        _, expected = np.unique(p, axis=0, return_inverse=True)
        assert np.array_equal(_welded(p), expected.reshape(-1)), case
    assert _welded(np.zeros((0, 3), np.float32)).shape == (0,)


def test_gbaa_window_rectangle_of_a_sphere_holds_its_silhouette() -> None:
    """The window rectangle gbaa's draws cover for an analytic sphere (the planes through
    the eye that touch it) is its silhouette's: every projected point of the sphere lies
    inside, and each side lies within a hundredth of a pixel of the nearest one (a box's
    corners, as for a mesh, project pixels outside it)."""
    size, tan_y = (640, 360), np.tan(np.radians(16.0))
    near, far, aspect = 0.1, 100.0, size[0] / size[1]
    proj = np.zeros((4, 4))
    proj[0, 0], proj[1, 1] = 1.0 / (tan_y * aspect), 1.0 / tan_y
    proj[2, 2], proj[2, 3], proj[3, 2] = (
        (far + near) / (near - far),
        2 * far * near / (near - far),
        -1,
    )
    view = np.eye(4)
    view[:3, 3] = (0.3, -0.8, -0.2)  # the eye moved: the spheres' view positions differ
    rng = np.random.default_rng(7)
    directions = rng.normal(size=(200_000, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    for centre, radius in (
        ((-1.9, 0.0, -6.0), 0.6),
        ((2.5, 1.2, -4.0), 0.9),
        ((0.0, 0.0, -3.0), 0.2),
    ):
        rect = sphere_window_rects(np.array([[*centre, radius]]), view, proj, size)[0]
        points = np.c_[np.array(centre) + radius * directions, np.ones(len(directions))]
        clip = points @ (proj @ view).T
        window = (clip[:, :2] / clip[:, 3:] * 0.5 + 0.5) * size
        lo, hi = window.min(axis=0), window.max(axis=0)
        assert np.all(rect[:2] <= lo + 1e-6) and np.all(rect[2:] >= hi - 1e-6), (rect, lo, hi)
        assert np.all(rect[:2] >= lo - 0.01) and np.all(rect[2:] <= hi + 0.01), (rect, lo, hi)


def test_the_default_falls_back_to_fxaa_on_a_dense_mesh(gl_egl: GLContext) -> None:
    """A scene that leaves render.antialiasing at its default draws gbaa up to
    GBAA_DEFAULT_TRIANGLES opaque mesh triangles and FXAA past them (gbaa's geometry stage
    runs once per triangle); a scene that names "gbaa" keeps it at any count, and an edit
    of another render key leaves the default the default."""
    data = aa_scene_data(SIZE)
    light, dense = dict(data), dict(data)
    # subdivision 5: 20,480 triangles, past the 20,000 of GBAA_DEFAULT_TRIANGLES
    dense["objects"] = [*data["objects"][:3], {**data["objects"][3], "subdivisions": 5}]
    named = {**dense, "render": {**dense["render"], "antialiasing": "gbaa"}}
    # an edit validates the whole render table again (the API's set_settings, a sweep):
    # the key left unset stays unset
    from app.scene.edits import edited, parse_key

    loaded = scene_from(dense)
    tonemap = loaded.scene.render.tonemap
    edit = edited(loaded, [(parse_key("render.tonemap", "test"), tonemap)], "test")
    drawn = {}
    cases = (("light", scene_from(light)), ("dense", loaded), ("named", scene_from(named)),
             ("edited", edit))  # fmt: skip
    for name, scene in cases:
        r = Renderer(gl_egl, scene, SIZE)
        try:
            r.render()
            drawn[name] = (r.antialiasing, r.gbaa is not None, r.fxaa is not None)
        finally:
            r.release()
    assert drawn == {
        "light": ("gbaa", True, False),
        "dense": ("fxaa", False, True),
        "named": ("gbaa", True, False),
        "edited": ("fxaa", False, True),
    }


def test_fxaa_marked_blocks_hold_every_edge(gl_egl: GLContext, loaded: LoadedScene) -> None:
    """FXAA's mark names every block of pixels the filter would change: filtering only the
    marked blocks gives the bytes of filtering every block (the filter decides each pixel
    itself), on an image whose height is no multiple of the block (54 rows)."""
    r = Renderer(gl_egl, with_aa(loaded, "fxaa", 1))
    try:
        r.render()
        fx, display = r.fxaa, r.post.target
        assert fx is not None and SIZE[1] % antialias.FXAA_BLOCK
        marked = np.frombuffer(fx.marks.read(), np.uint8)
        assert 0 < np.count_nonzero(marked) < marked.size
        unfiltered, filtered = fx.source.read(), display.read()
        assert unfiltered != filtered
        display.write(unfiltered)
        fx.marks.write(np.full(marked.size, 255, np.uint8).tobytes())
        fx.filter_blocks(display)
        assert display.read() == filtered
    finally:
        r.release()
