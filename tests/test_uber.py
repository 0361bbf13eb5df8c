"""The uber lighting shader (``UBER_MODELS``, the bench's ``uber`` variant) is the same BRDF
as the specialized permutations, with the models chosen at run time.

The dispatch code of glsl/brdf (``F_selected``, ``D_selected``, ``G2_selected``, ...) is one
text for both builds: plain ``if`` on FRESNEL_MODEL, NDF_MODEL, ..., which are integer
constants in a specialized pass (folded away) and per-pixel globals under UBER_MODELS,
read from texel 3 of the material table (app/reference/model.py ``model_codes``). So the
taken branch runs the same float32 operations in the same order. Measured on llvmpipe
(EGL and OSMesa): bit-identical images for every scene below but sec13_rust_blend, whose
anisotropic, texture-mapped steel differs in 654 of the 320x160 pixels (6158 at its own
960x540) by at most 3.3e-7 relative (the compiler rounds some float32 operation of the
larger program differently; not traced to an instruction). The bound, 1e-5 relative, is
30x that, and 10^4 below what a wrong model code costs (the negative control below
measures 0.35 to 1100).
"""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pytest

from app.common.models import (
    CLEARCOAT_MODELS,
    CLOTH_WRAP_FORMS,
    CORRELATIONS,
    DIFFRACTION_MODELS,
    DIFFUSE_MODELS,
    FIBER_MODELS,
    FRESNEL_MODELS,
    G2_MODELS,
    LAMBDA_FORMS,
    MATERIAL_TEXELS,
    NDF_MODELS,
    SHEEN_MODELS,
    Model,
    ModelParams,
    model_codes,
    model_from_codes,
    pack_model_params,
    unpack_model,
    unpack_model_params,
)
from app.common.tables import MS_FORMS
from app.frame import prepare_frame
from app.gl.kernel import run_kernel
from app.reference.multiscatter import load_tables
from app.render.renderer import Renderer, RenderOptions
from app.resources import scenes_dir
from app.scene.loader import load_scene
from tests.agreement import relative_error

# Mixed-model scenes that together use every value of every model choice (checked below).
SCENES = (
    "sec5_metals",
    "sec5_internal",
    "sec7_g2_backlit",
    "sec8_anisotropy",
    "sec8_furnace",
    "sec8_ndf",
    "sec9_diffuse_grazing",
    "stress",
    "sec13_rust_blend",
    "sec11_thin_film",  # thin film (RTR4 §9.11): films and a bare lens
    "sec10_cloth",  # sheen (RTR4 §9.10): none, charlie, ashikhmin
    "sec10_cloth_smith",  # sheen: charlie_smith (Charlie's fitted Smith Lambda)
    "sec10_cloth_empirical",  # the empirical cloth terms (RTR4 §9.10)
    "sec12_layered",  # clear coat (RTR4 §9.12)
    "sec12_layered_variants",  # both clear-coat compositions
    "sec12_layered_furnace",  # and the inter-reflection series
    "sec11_diffraction",  # diffraction grating (RTR4 §9.11)
    "sec10_cloth_fibers",  # micro-cylinder fibres (RTR4 §9.10)
)
SIZE = (320, 160)
MAX_REL = 1e-5  # uber vs specialized, relative to max(|specialized|, 1e-3 peak)
CHOICES = {
    "fresnel": FRESNEL_MODELS,
    "ndf": NDF_MODELS,
    "lambda_form": LAMBDA_FORMS,
    "g2": G2_MODELS,
    "correlation": CORRELATIONS,
    "diffuse": DIFFUSE_MODELS,
    "multiscatter": (False, True),
    "anisotropic": (False, True),
    "internal": (False, True),
    "specular_color": (False, True),  # a coloured dielectric F0 (glTF KHR_materials_specular)
    "thin_film": (False, True),  # thin film (RTR4 §9.11)
    "sheen": SHEEN_MODELS,  # sheen (RTR4 §9.10)
    "clearcoat": CLEARCOAT_MODELS,  # clear coat (RTR4 §9.12)
    "diffraction": DIFFRACTION_MODELS,  # diffraction grating (RTR4 §9.11)
    "fiber": FIBER_MODELS,  # micro-cylinder fibres (RTR4 §9.10)
    "cloth_wrap_form": CLOTH_WRAP_FORMS,  # the empirical cloth's wrapped cosine (RTR4 §9.10)
}


def _models_of(name: str) -> list[Model]:
    """The scene's model groups, from the renderer's own material table."""
    return prepare_frame(load_scene(scenes_dir() / f"{name}.toml")).materials.models


def _render(gl, name: str, uber: bool, codes: bool = True) -> tuple[np.ndarray, np.ndarray, int]:
    """HDR image, covered mask and number of lighting programs; ``codes=False`` zeroes the
    uber shader's model codes in the uploaded table (every material then reads as the
    standard model)."""
    r = Renderer(gl, load_scene(scenes_dir() / f"{name}.toml"), SIZE, RenderOptions(uber=uber))
    try:
        if not codes:
            packed = r.materials.packed()
            packed[:, 3, 1:] = 0.0
            r.lighting.materials.write(packed.tobytes())
        r.render()
        return r.read_hdr(), r.read_gbuffer().depth > 0.0, len(r.lighting.programs)
    finally:
        r.release()


def _covered_rel(a: np.ndarray, b: np.ndarray, covered: np.ndarray) -> float:
    peak = float(np.abs(b[covered]).max())
    return float(relative_error(a[covered], b[covered], 1e-3 * peak).max())


def test_the_scenes_use_every_model_choice():
    """The image test below exercises every run-time branch of the uber shader."""
    seen: dict[str, set] = {key: set() for key in CHOICES}
    for name in SCENES:
        for model in _models_of(name):
            for key, value in dataclasses.asdict(model).items():
                seen[key].add(value)
    for key, values in CHOICES.items():
        assert seen[key] == set(values), (key, set(values) - seen[key])


@pytest.mark.parametrize("name", SCENES)
def test_uber_image_equals_the_specialized_image(gl, name):
    """One uber program draws, to 1e-5 relative (measured: bit for bit, or 3.3e-7), what
    one specialized program per model group draws."""
    groups = len(_models_of(name))
    spec, covered, spec_programs = _render(gl, name, uber=False)
    uber, covered_uber, uber_programs = _render(gl, name, uber=True)
    assert spec_programs == groups and uber_programs == 1
    assert np.array_equal(covered, covered_uber) and covered.mean() > 0.05
    assert np.isfinite(uber).all()
    assert np.array_equal(uber[~covered], spec[~covered])  # the background, untouched
    rel = _covered_rel(uber, spec, covered)
    assert rel <= MAX_REL, f"{name}: uber vs specialized max relative difference {rel:.2e}"


@pytest.mark.parametrize("name", ["sec8_ndf", "sec9_diffuse_grazing", "stress"])
def test_uber_image_depends_on_the_model_codes(gl_egl, name):
    """Negative control: with the codes zeroed (every material read as the standard model)
    the uber image differs by far more than the bound above, so the bound can fail."""
    spec, covered, _ = _render(gl_egl, name, uber=False)
    wrong, _, _ = _render(gl_egl, name, uber=True, codes=False)
    assert _covered_rel(wrong, spec, covered) > 1e-2


def _all_models() -> list[Model]:
    """Every single-choice change from the standard model, plus a deterministic sample of
    combinations (the full product has 368,640 models)."""
    out = [Model()]
    for key, values in CHOICES.items():
        out += [dataclasses.replace(Model(), **{key: v}) for v in values]
    product = list(itertools.product(*CHOICES.values()))
    rng = np.random.default_rng(7)
    for i in rng.choice(len(product), 300, replace=False):
        out.append(Model(**dict(zip(CHOICES, product[i], strict=True))))
    return out


def test_model_codes_round_trip():
    """model_codes/model_from_codes are inverse, and unpack_model reads back pack's row."""
    models = _all_models()
    for m in models:
        assert model_from_codes(*model_codes(m)) == m
    table = pack_model_params([ModelParams()] * len(models), list(range(len(models))), models)
    assert table.shape == (len(models), MATERIAL_TEXELS, 4)
    for row, m in enumerate(models):
        assert unpack_model(table[row]) == (row, m)


def test_cloth_params_round_trip():
    """Empirical cloth (RTR4 §9.10): texels 9-11 carry a cloth row's numbers back exactly
    (float32-exact values); rows of other diffuse models hold the defaults (Lambert)."""
    cloth = Model(diffuse="cloth_empirical")
    p = ModelParams(
        cloth_rim_inner=np.array([0.5, 4.0, 0.25, 2.0]), cloth_diffuse=0.75,
        cloth_scatter=np.array([0.5, 0.25, 0.125]), cloth_wrap=0.5,
        cloth_sheen=np.array([1.0, 0.5, 0.375]),
    )  # fmt: skip
    table = pack_model_params([p, ModelParams()], [0, 1], [cloth, Model()])
    back = unpack_model_params(table[0])
    for name in ("cloth_rim_inner", "cloth_scatter", "cloth_sheen"):
        assert np.array_equal(getattr(back, name), getattr(p, name)), name
    assert (back.cloth_diffuse, back.cloth_wrap) == (0.75, 0.5)
    assert unpack_model(table[0]) == (0, cloth)
    assert table[1, 9:12].tolist() == [[0, 1, 0, 1], [1, 1, 1, 0], [0, 0, 0, 1]]
    old = table[1].copy()
    old[9:12] = 0.0  # a table from before the cloth texels: the defaults
    assert unpack_model_params(old).cloth_diffuse == ModelParams().cloth_diffuse


def test_fiber_params_round_trip():
    """Micro-cylinder fibre (RTR4 §9.10): texel 12 carries a fibre row's numbers back
    exactly; other rows hold the defaults; the model code's bits 16-17 round-trip."""
    model = Model(fiber="sadeghi")
    p = ModelParams(fiber_rotation=0.5, fiber_curvature=0.25, fiber_gamma_v=0.125, fiber_kd=0.75)
    table = pack_model_params([p, ModelParams()], [0, 1], [model, Model(fiber="kajiya_kay")])
    back = unpack_model_params(table[0])
    got = (back.fiber_rotation, back.fiber_curvature, back.fiber_gamma_v, back.fiber_kd)
    assert got == (0.5, 0.25, 0.125, 0.75)
    assert unpack_model(table[0]) == (0, model)
    assert unpack_model(table[1]) == (1, Model(fiber="kajiya_kay"))
    assert int(table[0, 3, 2]) >> 16 == 2 and int(table[1, 3, 2]) >> 16 == 1
    d = ModelParams()
    assert table[1, 12].tolist() == pytest.approx(
        [d.fiber_rotation, d.fiber_curvature, d.fiber_gamma_v, d.fiber_kd]
    )


def _specular_lambda_g2(m: Model) -> bool:
    """Which specular form brdf_eval takes (the condition the specialized build had as #if)."""
    fused = m.g2 == "hammon" or (
        m.g2 == "height_correlated" and m.ndf == "ggx" and not m.anisotropic
    )
    return not fused


def test_glsl_reads_the_model_codes_as_the_twin_writes_them(gl_egl):
    """fetch_model_codes (glsl/brdf/model.glsl) decodes every row of a packed table into the
    defines a specialized pass would get, and SPECULAR_LAMBDA_G2 follows."""
    models = _all_models()
    table = pack_model_params([ModelParams()] * len(models), [0] * len(models), models)
    ctx = gl_egl.ctx
    textures = []

    def bind(program, unit: int) -> None:
        tex = ctx.texture((table.shape[1], len(models)), 4, table.tobytes(), dtype="f4")
        textures.append(tex)
        tex.use(unit)
        program["u_materials"].value = unit

    rows = np.arange(len(models), dtype=np.float64)
    outputs = (
        "vec4(FRESNEL_MODEL, NDF_MODEL, LAMBDA_FORM, G2_MODEL)",
        "vec4(CORRELATION, DIFFUSE_MODEL, MULTISCATTER, ANISOTROPIC)",
        "vec4(FRESNEL_INTERNAL, SPECULAR_LAMBDA_G2 ? 1.0 : 0.0, SHEEN_MODEL, CLEARCOAT_MODEL)",
    )
    got = []
    try:
        for expr in outputs:
            got.append(
                run_kernel(
                    ctx,
                    ["brdf/model.glsl"],
                    f"fetch_model_codes(u_materials, int(x.x));\nresult = {expr};",
                    {"x": rows},
                    defines={"UBER_MODELS": 1},
                    bind=bind,
                    declarations="uniform sampler2D u_materials;",
                )
            )
    finally:
        for tex in textures:
            tex.release()
    got_all = np.concatenate([got[0], got[1], got[2]], axis=1)
    names = (
        "FRESNEL_MODEL", "NDF_MODEL", "LAMBDA_FORM", "G2_MODEL",
        "CORRELATION", "DIFFUSE_MODEL", "MULTISCATTER", "ANISOTROPIC", "FRESNEL_INTERNAL",
    )  # fmt: skip
    # (then SPECULAR_LAMBDA_G2 and the layers' codes: SHEEN_MODEL, CLEARCOAT_MODEL)
    for row, m in enumerate(models):
        d = m.defines()
        want = [d[n] for n in names] + [int(_specular_lambda_g2(m)), d["SHEEN_MODEL"]]
        want.append(d["CLEARCOAT_MODEL"])
        assert list(got_all[row].astype(int)) == want, m


def test_uber_pass_compiles_every_table(gl_egl):
    """The uber build pays for everything: on a scene without multiple scattering it still
    samples the Kulla-Conty table (its sampler is active), where the specialized one has
    no such sampler."""
    loaded = load_scene(scenes_dir() / "sec8_ndf.toml")
    for uber, expect in ((False, False), (True, True)):
        r = Renderer(gl_egl, loaded, (64, 32), RenderOptions(uber=uber))
        try:
            assert any("u_ms_table" in prog for prog in r.lighting.programs) is expect
            assert (r.lighting.ms_table is not None) is expect
        finally:
            r.release()


def test_ms_table_option(gl_egl):
    """RenderOptions(ms_table=load_tables(n)) binds the n x n Kulla-Conty tables, one block
    per G2 form (default: the shipped 64 x 64), and the image changes with it (the
    interpolation error differs)."""
    loaded = load_scene(scenes_dir() / "sec8_furnace.toml")
    images = {}
    for size in (None, 16):
        table = None if size is None else load_tables(size)
        r = Renderer(gl_egl, loaded, SIZE, RenderOptions(ms_table=table))
        try:
            n = 64 if size is None else 16
            assert r.lighting.ms_table.size == (n, n * len(MS_FORMS))
            r.render()
            images[size] = r.read_hdr()
        finally:
            r.release()
    assert np.abs(images[None] - images[16]).max() > 1e-5
