"""The clear coat's own normal (RTR4 §9.12: "layers may have different normals"; glTF
KHR_materials_clearcoat's clearcoatNormalTexture; docs/layered.md).

* GLSL against the float64 twin with a coat normal tilted away from the base's, for both
  compositions (1e-4 relative where the reference is not tiny), and reciprocity.
* A coat normal equal to the base's is the single-normal BRDF as it stood before the coat
  normal existed, bit for bit (the composition written out as it was, GLSL and twin).
* The G-buffer's RT4: allocated only where a coat's normal differs from its base's, read
  back and decoded as written (within the encoding's error), and the lighting pass with it
  against the twin's illumination sum.
Bad input (the keys without a coat, missing files, a coat normal map in a blend) is in
tests/test_bad_textures.py.
"""

from __future__ import annotations

import dataclasses
import tomllib
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from app.brdf import evaluate, resolve_material, run_material_kernel, surface_texels
from app.common.models import MaterialParams, pack_model_params, unpack_model_params
from app.frame import prepare_frame
from app.reference import clearcoat
from app.reference.constants import MIN_PERCEPTUAL_ROUGHNESS
from app.reference.encoding import oct_decode
from app.reference.illumination import decode_gbuffer
from app.reference.material import (
    ShadingPoint,
    Surface,
    base_brdf_factors,
    brdf_eval,
    brdf_eval_layered_cos,
    brdf_factors,
    clearcoat_base_params,
    clearcoat_base_surface,
    shading_cosines,
)
from app.reference.normal_mapping import perturb_normal, tangent_space_normal
from app.render.renderer import Renderer
from app.scene.loader import LoadedScene, parse_scene
from tests.agreement import hdr_and_twin, relative_error
from tests.test_brdf_models import direction_pairs

N = np.array([0.0, 0.0, 1.0])
MATERIALS = {
    "filament over gold": {"preset": "gold", "roughness": 0.3, "clearcoat": 1.0,
                           "clearcoat_roughness": 0.1},
    "tinted half coat over plastic": {
        "base_color": [0.8, 0.3, 0.1], "roughness": 0.5, "clearcoat": 0.5,
        "clearcoat_roughness": 0.3, "clearcoat_color": [0.9, 0.6, 0.3],
    },
    "weidlich-wilkie over copper": {
        "preset": "copper", "fresnel": "conductor", "roughness": 0.2, "clearcoat": 1.0,
        "clearcoat_ior": 1.6, "clearcoat_roughness": 0.15, "clearcoat_model": "weidlich_wilkie",
    },
    "weidlich-wilkie over plastic": {
        "base_color": [0.2, 0.5, 0.8], "roughness": 0.6, "clearcoat": 1.0,
        "clearcoat_model": "weidlich_wilkie", "clearcoat_color": [0.95, 0.8, 0.55],
    },
}  # fmt: skip
# Coat normals tilted 20 and 45 degrees from the base's +Z, in different azimuths.
TILTS = {
    "20 deg": np.array([np.sin(np.radians(20.0)), 0.0, np.cos(np.radians(20.0))]),
    "45 deg": np.array([-0.5, 0.5, np.sqrt(0.5)]),
}


@pytest.fixture(scope="module")
def pairs() -> tuple[np.ndarray, np.ndarray]:
    return direction_pairs()


@pytest.mark.parametrize("tilt", list(TILTS))
@pytest.mark.parametrize("name", list(MATERIALS))
def test_glsl_matches_twin_with_a_tilted_coat_normal(gl_egl, pairs, name: str, tilt: str) -> None:
    """The coat normal reaches the lobe, the crossings, the absorption and (Weidlich-Wilkie)
    the refraction the same way in both; the tilt moves f (so the comparison sees it)."""
    l, v = pairs
    nc = TILTS[tilt].astype(np.float32).astype(np.float64)
    material = MATERIALS[name]
    gpu = evaluate(material, l, v, nc=nc, gl=gl_egl)
    ref = evaluate(material, l, v, nc=nc, backend="reference")
    assert np.all(np.isfinite(gpu)) and np.all(gpu >= 0.0)
    assert np.all(np.isfinite(ref)) and np.all(ref >= 0.0)
    below = (l @ N) <= 0.0  # brdf_eval tests the base's normal
    assert np.all(gpu[below] == 0.0) and np.all(ref[below] == 0.0)
    err = relative_error(gpu, ref, 1e-6 * ref.max())
    assert err.max() <= 1e-4, f"{name}, {tilt}: max relative error {err.max():.2e}"
    untilted = evaluate(material, l, v, backend="reference")
    assert relative_error(ref, untilted, 1e-6 * ref.max()).max() > 0.1


@pytest.mark.parametrize("name", list(MATERIALS))
def test_reciprocity_with_a_tilted_coat_normal(gl_egl, pairs, name: str) -> None:
    """f(l, v) = f(v, l) with the coat's normal apart from the base's: every factor of the
    composition is symmetric in l and v about its own normal. Where both directions are
    above both horizons by more than the n.v clamp."""
    l, v = pairs
    nc = TILTS["45 deg"]
    keep = (l @ N > 1e-3) & (v @ N > 1e-3) & (l @ nc > 1e-3) & (v @ nc > 1e-3)
    l, v = l[keep], v[keep]
    l, v = l / np.linalg.norm(l, axis=-1, keepdims=True), v / np.linalg.norm(v, axis=-1)[:, None]
    material = MATERIALS[name]
    ref_lv = evaluate(material, l, v, nc=nc, backend="reference")
    ref_vl = evaluate(material, v, l, nc=nc, backend="reference")
    np.testing.assert_allclose(ref_lv, ref_vl, rtol=1e-12, atol=1e-300)
    gpu_lv = evaluate(material, l, v, nc=nc, gl=gl_egl)
    gpu_vl = evaluate(material, v, l, nc=nc, gl=gl_egl)
    assert relative_error(gpu_lv, gpu_vl, 1e-6 * gpu_lv.max()).max() <= 1e-4


# --- nc = n: the single-normal BRDF, bit for bit ---------------------------------------------

# clearcoat_factors and brdf_eval as they were before the coat had a normal of its own
# (commit 68985db), written out with one normal.
_SINGLE_NORMAL_BODY = """
Surface s = Surface(surface_a.rgb, surface_a.a, surface_b.x, surface_b.y, surface_b.z);
ModelParams p = fetch_model_params(u_materials, 0);
vec3 n = dir_n.xyz, t = dir_t.xyz, l = dir_l.xyz, v = dir_v.xyz;
vec3 f = vec3(0.0);
if (dot(n, l) > 0.0) {
    float NoL, NoV;
    vec3 h;
    shading_cosines(n, l, v, NoL, NoV, h);
    float LoH = clamp(dot(l, h), 0.0, 1.0);
    float c = p.clearcoat;
    float F0c = clearcoat_F0(p.clearcoat_eta);
    float rc = max(p.clearcoat_roughness, MIN_PERCEPTUAL_ROUGHNESS);
    float alpha_c = rc * rc;
    vec3 l_base = l;
    vec3 v_base = v;
    float compression = 1.0;
    if (CLEARCOAT_MODEL == CLEARCOAT_WEIDLICH_WILKIE && c > 0.0) {
        float eta_c = mix(1.0, p.clearcoat_eta, c);
        l_base = clearcoat_refract_in(eta_c, n, l);
        v_base = clearcoat_refract_in(eta_c, n, v);
        compression = clearcoat_solid_angle_compression(eta_c);
    }
    ShadingPoint base = ShadingPoint(clearcoat_base_surface(s, p), clearcoat_base_params(p),
                                     n, n, t, v_base, vec3(0.0));
    BrdfFactors b = base_brdf_factors(base, l_base);
    float T = T_clearcoat_filament(c, F0c, NoL, NoV);
    vec3 A = mix(vec3(1.0), A_clearcoat_beer_lambert(p.clearcoat_color, p.clearcoat_eta, NoL,
                                                     NoV), c);
    vec3 w = (T * compression) * A;
    float f_coat = c * f_clearcoat_ggx(alpha_c, F0c, n, h, NoL, NoV, LoH);
    f = w * b.f_diffuse + (vec3(f_coat) + w * b.f_spec);
}
result = vec4(f, 0.0);
"""


def _surface(params: MaterialParams) -> Surface:
    """The material's Surface as the probe rounds it (float32 texels)."""
    a, b = surface_texels(params)
    return Surface(a[:3].astype(np.float64), float(a[3]), float(b[0]), float(b[1]), float(b[2]))


def _single_normal_twin(params: MaterialParams, l: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The twin's coated brdf_eval as it was before the coat normal, for n = +Z."""
    s = _surface(params)
    p = unpack_model_params(pack_model_params([params.params], [0], [params.model])[0])
    n = np.broadcast_to(N, l.shape)
    t = np.broadcast_to([1.0, 0.0, 0.0], l.shape)
    lit, NoL, NoV, h = shading_cosines(n, l, v)
    LoH = np.clip(np.sum(l * h, -1), 0.0, 1.0)
    c = p.clearcoat
    F0c = clearcoat.clearcoat_F0(p.clearcoat_eta)
    rc = max(p.clearcoat_roughness, MIN_PERCEPTUAL_ROUGHNESS)
    alpha_c = rc * rc
    l_base, v_base, compression = l, v, 1.0
    if params.model.clearcoat == "weidlich_wilkie" and c > 0.0:
        eta_c = 1.0 - c + p.clearcoat_eta * c
        l_base = clearcoat.clearcoat_refract_in(eta_c, n, l)
        v_base = clearcoat.clearcoat_refract_in(eta_c, n, v)
        compression = clearcoat.clearcoat_solid_angle_compression(eta_c)
    base = dataclasses.replace(params.model, clearcoat="none")
    point = ShadingPoint(clearcoat_base_surface(s, p), clearcoat_base_params(p), n, None, t,
                         v_base)  # fmt: skip
    b = base_brdf_factors(point, base, l_base)
    T = clearcoat.T_clearcoat_filament(c, F0c, NoL, NoV)
    A = (
        1.0
        - c
        + clearcoat.A_clearcoat_beer_lambert(p.clearcoat_color, p.clearcoat_eta, NoL, NoV) * c
    )
    w = (T * compression)[..., None] * A
    f_coat = c * clearcoat.f_clearcoat_ggx(alpha_c, F0c, n, h, NoL, NoV, LoH)
    f = w * b.f_diffuse + (f_coat[..., None] + w * b.f_spec)
    return np.where(lit[..., None], f, 0.0)


@pytest.mark.parametrize("name", list(MATERIALS))
def test_coat_normal_equal_to_n_is_the_single_normal_brdf(gl_egl, pairs, name: str) -> None:
    """nc = n (every coat without RT4) gives the BRDF of the single-normal composition to
    the bit: the same operations in the same order, GLSL and twin."""
    l, v = pairs
    params = resolve_material(MATERIALS[name])
    a, b = surface_texels(params)
    count = len(l)
    inputs = {
        "surface_a": np.broadcast_to(a, (count, 4)), "surface_b": np.broadcast_to(b, (count, 4)),
        "dir_n": np.broadcast_to(N, (count, 3)), "dir_l": l, "dir_v": v,
        "dir_t": np.broadcast_to([1.0, 0.0, 0.0], (count, 3)),
    }  # fmt: skip
    before = run_material_kernel(gl_egl.ctx, params, _SINGLE_NORMAL_BODY, inputs)[:, :3]
    np.testing.assert_array_equal(evaluate(params, l, v, nc=N, gl=gl_egl), before)
    np.testing.assert_array_equal(
        evaluate(params, l, v, nc=N, backend="reference"), _single_normal_twin(params, l, v)
    )


# --- the G-buffer's RT4 ------------------------------------------------------------------------

# A plane seen from above; the coat's map (or none) and the base's map are the cases' keys.
_PLANE = """
[render]
width = 48
height = 32
gbuffer = "{gbuffer}"
[camera]
position = [0.0, 3.0, 0.5]
target = [0.0, 0.0, 0.0]
fov_y = 50.0
[materials.m]
base_color = [0.6, 0.2, 0.1]
roughness = 0.4
{keys}
[[lights]]
type = "directional"
direction = [0.3, -1.0, -0.4]
[[lights]]
type = "point"
position = [0.5, 1.0, 0.6]
intensity = 3.0
[[objects]]
shape = "plane"
size = [4.0, 4.0]
material = "m"
"""
# One tilted tangent-space normal everywhere: the coat's normal is known in closed form.
COAT_TEXEL = np.array([200, 90, 230], np.uint8)


def _loaded(tmp_path: Path, keys: str, gbuffer: str = "f32") -> LoadedScene:
    Image.fromarray(np.tile(COAT_TEXEL, (8, 8, 1))).save(tmp_path / "coat.png")
    bumps = np.random.default_rng(3).integers(60, 196, (16, 16, 3)).astype(np.uint8)
    bumps[..., 2] = 230
    Image.fromarray(bumps).save(tmp_path / "bumps.png")
    text = _PLANE.format(gbuffer=gbuffer, keys=keys)
    return parse_scene(tomllib.loads(text), tmp_path / "scene.toml")


CASES = {  # keys of the material -> whether RT4 exists
    "coat alone": ("clearcoat = 1.0", False),
    "normal map alone": ('normal_map = "bumps.png"', False),
    "coat over a normal-mapped base": ('clearcoat = 1.0\nnormal_map = "bumps.png"', True),
    "coat normal map": ('clearcoat = 1.0\nclearcoat_normal_map = "coat.png"', True),
}


@pytest.mark.parametrize("case", list(CASES))
def test_rt4_only_where_a_coat_normal_differs(tmp_path: Path, case: str) -> None:
    keys, wanted = CASES[case]
    table = prepare_frame(_loaded(tmp_path, keys)).materials
    assert table.needs_coat_normals is wanted
    assert table.gbuffer_defines()["GBUFFER_COAT_NORMAL"] == int(wanted)


@pytest.mark.parametrize("gbuffer", ["f16", "f32"])
@pytest.mark.parametrize("case", list(CASES))
def test_rt4_round_trip_and_lighting(gl_egl, tmp_path: Path, case: str, gbuffer: str) -> None:
    """RT4 holds the coat's normal as written: the vertex normal (+Y) under a coat over a
    normal-mapped base (glTF: no normal mapping applies to the coat), the coat map's normal
    on the plane's tangent frame with a coat map; absent where unused. The lighting pass
    shades it as the twin does (1e-4 relative)."""
    keys, wanted = CASES[case]
    loaded = _loaded(tmp_path, keys, gbuffer)
    r = Renderer(gl_egl, loaded)
    try:
        assert (r.gbuffer.coat_normal is not None) is wanted
        hdr, ref, g = hdr_and_twin(r, loaded.scene.background)
        vertex = r.frame.parts[0].vertices[0]
    finally:
        r.release()
    covered = g.covered
    assert covered.sum() > 0.5 * covered.size
    if not wanted:
        assert g.coat_normal is None and decode_gbuffer(g, r.camera).nc is None
    else:
        ng, t, w = vertex[3:6].astype(np.float64), vertex[8:11].astype(np.float64), vertex[11]
        written = ng  # the vertex normal
        if "coat_normal_map" in keys:
            texel = COAT_TEXEL.astype(np.float64) * (2.0 / 255.0) - 1.0
            written = perturb_normal(ng, t, w, tangent_space_normal(texel))
        decoded = oct_decode(g.coat_normal[covered].astype(np.float64))
        # f16 rounds the octahedral coordinates, and the coat map's texels always, to 2^-11.
        exact = gbuffer == "f32" and "coat_normal_map" not in keys
        tolerance = 1e-5 if exact else 3e-3
        err = np.linalg.norm(decoded - written, axis=-1)
        assert err.max() <= tolerance, f"{case}: coat normal off by {err.max():.2e}"
        base = oct_decode(g.normal[covered][:, :2].astype(np.float64))
        assert np.linalg.norm(base - written, axis=-1).max() > 0.05  # the layers differ
        np.testing.assert_allclose(decode_gbuffer(g, r.camera).nc, decoded / np.linalg.norm(
            decoded, axis=-1, keepdims=True), atol=1e-12)  # fmt: skip
    peak = ref[covered].max()
    lit = covered & (ref.max(axis=-1) > 1e-3 * peak)
    rel = np.abs(hdr - ref)[lit] / np.maximum(ref[lit], 1e-3 * peak)
    assert rel.max() <= 1e-4, f"{case}: lighting pass against the twin {rel.max():.2e}"


def test_layered_cosines_keep_a_smooth_coat_off_the_base_bumps() -> None:
    """With its own normal the coat's lobe takes its own cosine: the twin's illumination
    term of a coat over a tilted base normal equals f_coat (nc.l) + w f_base (n.l), not
    f (n.l) (RTR4 §9.12; Filament). The light is above the coat but below the base here,
    so the coat's reflection must survive."""
    params = resolve_material(MATERIALS["filament over gold"])
    s = _surface(params)
    n = np.array([[0.6, 0.0, 0.8]])  # the base's bump, tilted towards +x
    nc = np.array([[0.0, 0.0, 1.0]])  # the smooth coat
    v = np.array([[0.9, 0.0, np.sqrt(0.19)]])
    l = np.array([[-0.9, 0.0, np.sqrt(0.19)]])  # the coat's mirror direction; n.l < 0
    t = np.array([[1.0, 0.0, 0.0]])
    assert float(n[0] @ l[0]) < 0.0
    point = ShadingPoint(s, params.params, n, nc, t, v)
    got = brdf_eval_layered_cos(point, params.model, l)
    f = brdf_factors(point, params.model, l)
    coat_term = np.repeat(f.f_coat[:, None], 3, -1) * (nc[0] @ l[0])
    np.testing.assert_allclose(got, coat_term, rtol=1e-15)
    assert got.max() > 1.0  # the coat's mirror highlight, not zero
    assert np.all(brdf_eval(point, params.model, l) == 0.0)
