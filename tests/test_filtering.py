"""RTR4 §9.13: filtering normal and roughness mips, measured against a supersampled
reference (app/bench/filtering.py), and the mip chains as the GL samples them."""

from __future__ import annotations

import moderngl
import numpy as np
import pygltflib
from PIL import Image

from app.bench.filtering import measure, with_settings
from app.gl.context import GLContext
from app.gl.kernel import run_kernel
from app.reference.encoding import oct_decode
from app.reference.filtering import (
    GGX_LEAN_SPREAD,
    SPECULAR_AA_KAPPA,
    SPECULAR_AA_SIGMA2,
    alpha2_from_slope_variance,
    convolved_interval_alpha,
    ggx_lean_lobe_errors,
    lean_anisotropic_roughness,
)
from app.render.renderer import Renderer
from app.render.texture_upload import read_level, upload_texture
from app.scene.loader import LoadedScene, load_scene, parse_scene
from app.scene.model import RenderSettings
from app.textures.maps import lean_normal_maps, normal_roughness_texture
from app.textures.mips import decode_normal_map
from tests.conftest import REPO
from tests.gltf_builder import GltfBuilder

SCENE = REPO / "scenes" / "sec13_filtering.toml"


def test_variance_filtering_beats_naive_mips(gl_egl: GLContext) -> None:
    """On the bumpy receding floor (160x90; reference 8x8 samples per pixel from level 0),
    variance-filtered roughness mips cut the relative RMSE of the HDR image against the
    reference at least 3-fold over naive mips (measured 1.657 -> 0.296, 5.6x) and the mean
    FLIP of the displayed image at least 2-fold (0.142 -> 0.048, 3.0x): the spread of
    the bumps' normals widens the highlight into the reference's glitter path instead of
    vanishing into a flat mirror. Toksvig lands within 10% of it (0.302)."""
    options = [(m, {"normal_filter": m}) for m in ("naive", "toksvig", "variance")]
    results, _ = measure(
        gl_egl, load_scene(SCENE), (160, 90), supersample=8, sweep=1, options=options,
        repeats=1,
    )  # fmt: skip
    err = {r.variant: r.rel_rmse for r in results}
    flip = {r.variant: r.flip_mean for r in results}
    assert err["variance"] * 3.0 <= err["naive"], err
    assert flip["variance"] * 2.0 <= flip["naive"], flip
    assert abs(err["toksvig"] - err["variance"]) <= 0.1 * err["variance"], err


def _levels(gl_tex: moderngl.Texture, count: int) -> list[np.ndarray]:
    out = []
    w, h = gl_tex.size
    for k in range(count):
        lw, lh = max(1, w >> k), max(1, h >> k)
        data = read_level(gl_tex, k)
        assert data.shape[:2] == (lh, lw)
        out.append(data[::-1].astype(np.float32))
    return out


def test_gl_level_zero_is_the_source_and_levels_are_ours(gl_egl: GLContext) -> None:
    """Uploaded chains read back from the GL: level 0 is the source (to float16, the
    storage format), and every level is the project's, not the GL's own mipmaps."""
    rng = np.random.default_rng(7)
    n = rng.normal(size=(32, 16, 3)) * [0.4, 0.4, 1.0]
    n[..., 2] = np.abs(n[..., 2]) + 0.2
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    r = rng.uniform(0.1, 0.9, (32, 16))
    tex = normal_roughness_texture(n, r, (32, 16), "variance")
    gl_tex = upload_texture(gl_egl.ctx, tex)
    try:
        got = _levels(gl_tex, len(tex.levels))
    finally:
        gl_tex.release()
    source = np.concatenate([n, r[..., None]], axis=-1)
    np.testing.assert_array_equal(got[0], source.astype(np.float16).astype(np.float32))
    for k, level in enumerate(tex.levels):
        np.testing.assert_array_equal(got[k], level.astype(np.float16).astype(np.float32))
    # A plain box average of level 0's roughness is what the GL would have built; ours
    # (variance) is rougher, since the normals under each texel differ.
    assert got[1][..., 3].mean() > source[..., 3].reshape(16, 2, 8, 2).mean(axis=(1, 3)).mean()


def test_flat_normal_map_keeps_roughness_at_every_gl_level(gl_egl: GLContext) -> None:
    """A flat normal map: every level the GL holds has the source roughness (to float16)
    and the +z normal, for every filter."""
    n = np.zeros((16, 16, 3))
    n[..., 2] = 1.0
    for method in ("naive", "toksvig", "variance"):
        tex = normal_roughness_texture(n, 0.37, (16, 16), method)
        gl_tex = upload_texture(gl_egl.ctx, tex)
        try:
            levels = _levels(gl_tex, len(tex.levels))
        finally:
            gl_tex.release()
        assert len(levels) == 5
        for level in levels:
            np.testing.assert_array_equal(level[..., 3], np.float32(np.float16(0.37)))
            np.testing.assert_array_equal(
                level[..., :3], np.broadcast_to([0.0, 0.0, 1.0], level[..., :3].shape)
            )


def test_specular_aa_defaults_are_the_twins_and_reach_the_gbuffer_pass(gl_egl: GLContext):
    """The scene format's default sigma^2 and kappa are the twin's (Tokuyoshi & Kaplanyan
    2019: 0.25 and 0.18), and a scene that turns specular AA on hands exactly those values
    (to float32) to the G-buffer pass's program, the only place the GLSL reads them."""
    settings = RenderSettings()
    assert settings.specular_aa_variance == SPECULAR_AA_SIGMA2 == 0.25
    assert settings.specular_aa_threshold == SPECULAR_AA_KAPPA == 0.18
    data = {
        "render": {"width": 16, "height": 16, "specular_aa": True},
        "materials": {"m": {"roughness": 0.3}},
        "objects": [{"shape": "sphere", "radius": 1.0, "material": "m"}],
        "lights": [{"type": "directional", "direction": [0.0, -1.0, -1.0]}],
    }
    r = Renderer(gl_egl, parse_scene(data, REPO / "scenes" / "specular_aa.toml"))
    try:
        r.render()
        (drawable,) = r.gbuffer_pass.drawables
        sigma2, kappa = drawable.program["u_specular_aa"].value
    finally:
        r.release()
    assert (sigma2, kappa) == (np.float32(SPECULAR_AA_SIGMA2), np.float32(SPECULAR_AA_KAPPA))


# -- LEAN: the slopes' covariance as anisotropic roughness (Olano & Baker 2010) -------------

GROOVES = REPO / "scenes" / "sec13_grooves.toml"


def test_lean_twin_keeps_the_material_and_adds_the_covariance() -> None:
    """Sigma = 0 gives the material back (r, |a|, its axis); an isotropic Sigma = s I is
    the variance mips' alpha'^2 = alpha^2 + 2 s with no anisotropy; a rank-1 Sigma along
    theta widens the lobe along theta alone: alpha_x'^2 = alpha^2 + 2 s, alpha_y' = alpha."""
    r = np.array([0.2, 0.5, 0.7])
    a = np.array([0.0, 0.6, -0.4])
    phi = np.array([0.3, 1.0, -2.0])
    d = np.stack([np.cos(phi), np.sin(phi)], axis=-1)
    r1, a1, d1 = lean_anisotropic_roughness(r, a, d, np.zeros((3, 3)))
    np.testing.assert_allclose(r1, r, rtol=1e-12)
    np.testing.assert_allclose(a1, np.abs(a), atol=1e-12)
    major = np.where(a[:, None] < 0.0, np.stack([-d[:, 1], d[:, 0]], axis=-1), d)
    np.testing.assert_allclose(np.abs(np.sum(d1 * major, axis=-1))[1:], 1.0, atol=1e-12)
    s = 0.03
    r2, a2, _ = lean_anisotropic_roughness(0.3, 0.0, np.array([1.0, 0.0]), np.array([s, s, 0]))
    np.testing.assert_allclose(r2**4, alpha2_from_slope_variance(0.3**4, s), rtol=1e-12)
    assert a2 == 0.0
    theta = 0.7
    c, n = np.cos(theta), np.sin(theta)
    sigma = s * np.array([c * c, n * n, c * n])
    r3, a3, d3 = lean_anisotropic_roughness(0.3, 0.0, np.array([1.0, 0.0]), sigma)
    alpha = r3**2
    np.testing.assert_allclose((alpha * (1 + a3)) ** 2, 0.3**4 + 2 * s, rtol=1e-12)
    np.testing.assert_allclose(alpha * (1 - a3), 0.3**2, rtol=1e-12)
    np.testing.assert_allclose(abs(d3 @ [c, n]), 1.0, rtol=1e-12)


def test_covariance_levels_are_the_footprints_slope_covariance() -> None:
    """Every level of the slope_covariance map is the population covariance of the slopes
    of the source texels under its footprint (odd sizes: blocks of 3 at the end), and its
    mean variance with the lean chain's alpha^2 is the variance chain's roughness: the two
    filters carry the same spread, one as a matrix, the other as its trace."""
    rng = np.random.default_rng(11)
    n = rng.normal(size=(12, 10, 3)) * [0.1, 0.25, 0.0]
    n[..., 2] = 1.0
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    r = rng.uniform(0.1, 0.6, (12, 10))
    maps = lean_normal_maps(n, 1.0, r)
    cov = maps["slope_covariance"].levels
    lean = maps["normal_roughness"].levels
    variance = normal_roughness_texture(n, r, (12, 10), "variance").levels
    s = -n[..., :2] / n[..., 2:]
    np.testing.assert_array_equal(cov[0], 0.0)
    # level 1 of 12 x 10 is 6 x 5: 2 x 2 blocks; level 2 is 3 x 2: rows in blocks 4, 4, 4
    # and columns in blocks of 4 and 6 (the odd last column of level 1 joins its pair)
    for (y0, y1, x0, x1), k, (i, j) in [((2, 4, 6, 8), 1, (1, 3)), ((8, 12, 4, 10), 2, (2, 1))]:
        block = s[y0:y1, x0:x1].reshape(-1, 2)
        want = np.cov(block.T, bias=True)
        got = cov[k][i, j]
        np.testing.assert_allclose(got, [want[0, 0], want[1, 1], want[0, 1]], atol=1e-5)
        alpha2 = lean[k][i, j, 3].astype(np.float64) ** 4 + got[0] + got[1]
        np.testing.assert_allclose(alpha2, variance[k][i, j, 3].astype(np.float64) ** 4,
                                   rtol=1e-4)  # fmt: skip
        np.testing.assert_allclose(lean[k][i, j, :3], variance[k][i, j, :3], atol=1e-6)


def _streak_width(hdr: np.ndarray) -> float:
    """The highlight's horizontal spread on the floor: the luminance-weighted standard
    deviation of the column, in pixels, over the floor's rows (the lower third)."""
    lum = hdr[2 * hdr.shape[0] // 3 :, :, :3] @ np.array([0.2126, 0.7152, 0.0722])
    x = np.arange(lum.shape[1])[None, :]
    w = lum / lum.sum()
    mean = float((w * x).sum())
    return float(np.sqrt((w * (x - mean) ** 2).sum()))


def test_lean_keeps_a_groove_map_a_brushed_highlight(gl_egl: GLContext) -> None:
    """scenes/sec13_grooves.toml at 160x90 against an 8x8 supersampled reference from
    level 0: far off, the grooves' normals spread only across the grooves, so the reference
    keeps a narrow streak (luminance-weighted width 2.45 px, mean radiance 3.98). Isotropic
    variance mips widen it (7.93 px, 5.04); mips without the spread (naive) keep it narrow
    but twice as bright (1.89 px, 7.84: a mirror's peak where the reference's is spread
    along the view); LEAN's anisotropic roughness gives 2.56 px and 3.63, and cuts the
    mean FLIP 7.7-fold from variance's (0.155 -> 0.020). Asserted: LEAN's width and mean
    radiance within 15% of the reference's, its width at most half of variance's and its
    FLIP at most a quarter of variance's."""
    options = [(m, {"normal_filter": m}) for m in ("variance", "lean")]
    results, ref = measure(
        gl_egl, load_scene(GROOVES), (160, 90), supersample=8, sweep=1, options=options,
        repeats=1,
    )  # fmt: skip
    width = {r.variant: _streak_width(r.hdr) for r in results}
    flip = {r.variant: r.flip_mean for r in results}
    reference = _streak_width(ref["hdr"])
    assert abs(width["lean"] / reference - 1.0) <= 0.15, (width, reference)
    lean = next(r.hdr for r in results if r.variant == "lean")
    radiance = float(lean[..., :3].mean() / ref["hdr"][..., :3].mean())
    assert abs(radiance - 1.0) <= 0.15, radiance
    assert width["lean"] <= 0.5 * width["variance"], width
    assert flip["lean"] * 4.0 <= flip["variance"], flip


def test_ggx_spread_is_the_one_sigma_interval_of_the_filtered_lobe(gl_egl: GLContext) -> None:
    """GGX's LEAN factor k (alpha'^2 = alpha^2 + 2 k sigma^2) from its float64 derivation:
    GGX(alpha) convolved with a Gaussian of standard deviation sigma on a grid, the GGX
    alpha' whose marginal holds erf(1/sqrt 2) of its slopes in the same interval. Without
    spread that is alpha itself (within 1e-3); as sigma/alpha grows, (alpha'^2 - alpha^2) /
    (2 sigma^2) falls (0.73 at sigma = alpha, 0.59 at 8 alpha) to GGX_LEAN_SPREAD = 0.5728
    (within 1e-3 at 64 alpha). The GLSL constant is the twin's (to float32). The lobe it
    gives for a groove-like footprint (alpha 0.04, sigma 0.3 across) sends 1.6x less light
    beyond 45 degrees than Beckmann's k = 1 (18x the filtered lobe's there, not 30x), for
    16% more misplaced within (L1 0.258 against 0.222)."""
    alpha = 0.04
    assert abs(convolved_interval_alpha(alpha, 0.0) / alpha - 1.0) <= 1e-3
    k = [(convolved_interval_alpha(alpha, rho * alpha) ** 2 - alpha**2) / (2 * (rho * alpha) ** 2)
         for rho in (1.0, 8.0, 64.0)]  # fmt: skip
    assert k[0] > k[1] > k[2], k
    assert abs(k[2] / GGX_LEAN_SPREAD - 1.0) <= 1e-3, k
    out = run_kernel(gl_egl.ctx, ["material/filtering.glsl"], "result = vec4(GGX_LEAN_SPREAD);",
                     {"p": np.zeros((1, 4))})  # fmt: skip
    assert out[0, 0] == np.float32(GGX_LEAN_SPREAD)
    l1_variance, tail_variance = ggx_lean_lobe_errors(alpha, 0.3, 1.0)
    l1, tail = ggx_lean_lobe_errors(alpha, 0.3, GGX_LEAN_SPREAD)
    assert tail * 1.5 <= tail_variance, (tail, tail_variance)
    assert l1 <= 1.2 * l1_variance, (l1, l1_variance)


def _ggx_grooves() -> LoadedScene:
    """scenes/sec13_grooves.toml with its materials' NDF switched to GGX."""
    loaded = load_scene(GROOVES)
    materials = {n: m.model_copy(update={"ndf": "ggx"}) for n, m in loaded.scene.materials.items()}
    return LoadedScene(loaded.scene.model_copy(update={"materials": materials}), loaded.path)


def test_lean_with_ggx_beats_variance_on_the_grooves(gl_egl: GLContext) -> None:
    """The groove floor with GGX, 160x90 against an 8x8 reference: LEAN with GGX's spread
    factor beats isotropic variance mips in both relative RMSE (0.489 against 0.719) and
    mean FLIP (0.261 against 0.295); with Beckmann's factor k = 1 its FLIP is worse than
    variance's (0.325, RMSE 0.568: GGX's tails along the wide axis light the floor where
    the grooves reflect nothing)."""
    options = [(m, {"normal_filter": m}) for m in ("variance", "lean")]
    results, _ = measure(
        gl_egl, _ggx_grooves(), (160, 90), supersample=8, sweep=1, options=options, repeats=1
    )
    got = {r.variant: r for r in results}
    assert got["lean"].rel_rmse < got["variance"].rel_rmse, results
    assert got["lean"].flip_mean < got["variance"].flip_mean, results


def test_lean_reaches_a_gltf_material_s_gbuffer(gl_egl: GLContext, tmp_path) -> None:
    """A glTF quad whose 256^2 normal map tilts its rows alternately towards +b and -b
    (grooves along u), seen whole at 16x16 pixels (mip level ~4, where every texel holds
    the same spread): under ``lean`` the G-buffer stores the twin's anisotropic roughness
    for that covariance with GGX's spread factor (a glTF material is GGX: perceptual
    roughness 0.533 and anisotropy 0.716 where Beckmann's k = 1 would give 0.598 and
    0.748; within 5e-4, measured 2e-5 and 7e-5: the float16 covariance) and a tangent
    along the quad's bitangent (world +y), the direction across the grooves; under
    ``variance`` the material stays isotropic (no tangent target)."""
    tilt = 0.4
    rows = np.where(np.arange(256) % 2 == 0, tilt, -tilt)
    n = np.zeros((256, 256, 3))
    n[..., 1] = rows[:, None]
    n[..., 2] = np.sqrt(1.0 - tilt * tilt)
    texels = np.round((n + 1.0) * 0.5 * 255.0).astype(np.uint8)
    b = GltfBuilder()
    mat = pygltflib.Material(
        pbrMetallicRoughness=pygltflib.PbrMetallicRoughness(
            baseColorFactor=[0.9, 0.9, 0.9, 1.0], metallicFactor=1.0, roughnessFactor=0.3
        ),
        normalTexture=pygltflib.NormalMaterialTexture(
            index=b.texture(Image.fromarray(texels, "RGB"))
        ),
    )
    b.quad(b.material(mat))
    b.save(tmp_path / "m.glb")
    scene = tmp_path / "scene.toml"
    gbuffers = {}
    for method in ("variance", "lean"):
        scene.write_text(
            f'[render]\nnormal_filter = "{method}"\n[camera]\nposition = [0.0, 0.0, 1.0]\n'
            'target = [0.0, 0.0, 0.0]\nfov_y = 90.0\n[[objects]]\nshape = "mesh"\n'
            'file = "m.glb"\n[[lights]]\ntype = "directional"\ndirection = [0.0, 0.0, -1.0]\n',
            encoding="utf-8",
        )
        r = Renderer(gl_egl, load_scene(scene), (16, 16))
        try:
            r.render()
            gbuffers[method] = r.read_gbuffer()
        finally:
            r.release()
    assert not gbuffers["variance"].tangent.any()
    g = gbuffers["lean"]
    centre = g.covered.copy()
    centre[[0, -1], :] = centre[:, [0, -1]] = False  # the quad's edges meet the background
    assert centre.sum() >= 100
    # the 8-bit texels decoded as the chain decodes them: slopes +-s, variance s^2 along y
    decoded = decode_normal_map(texels[:2, :1])[:, 0]
    s = decoded[:, 1] / decoded[:, 2]
    sigma = np.array([0.0, float(np.mean(s * s) - np.mean(s) ** 2), 0.0])
    r_want, a_want, d_want = lean_anisotropic_roughness(
        0.3, 0.0, np.array([1.0, 0.0]), sigma, GGX_LEAN_SPREAD
    )
    assert abs(d_want[1]) == 1.0
    r_beckmann, a_beckmann, _ = lean_anisotropic_roughness(0.3, 0.0, np.array([1.0, 0.0]), sigma)
    assert min(abs(r_beckmann - r_want), abs(a_beckmann - a_want)) > 0.02
    np.testing.assert_allclose(g.normal[centre, 2], r_want, atol=5e-4)
    np.testing.assert_allclose(g.tangent[centre, 2], a_want, atol=5e-4)
    t = oct_decode(g.tangent[centre, :2].astype(np.float64))
    np.testing.assert_allclose(np.abs(t[:, 1]), 1.0, atol=1e-3)


def test_switching_to_lean_and_back_renders_what_a_fresh_renderer_renders(gl_egl) -> None:
    """``update`` from variance to lean (new maps, an anisotropic model, the tangent target)
    and back gives the fresh renderer's image bit for bit (the viewer's normal-filter
    choice), and the two images differ."""
    scenes = {}
    for method in ("variance", "lean"):
        scenes[method] = with_settings(load_scene(GROOVES), (64, 36), normal_filter=method)

    def fresh(method: str) -> np.ndarray:
        r = Renderer(gl_egl, scenes[method])
        try:
            r.render()
            return r.read_hdr()
        finally:
            r.release()

    want = {m: fresh(m) for m in scenes}
    assert not np.array_equal(want["variance"], want["lean"])
    r = Renderer(gl_egl, scenes["variance"])
    try:
        for method in ("lean", "variance"):
            r.update(scenes[method].scene)
            r.render()
            np.testing.assert_array_equal(r.read_hdr(), want[method])
    finally:
        r.release()
