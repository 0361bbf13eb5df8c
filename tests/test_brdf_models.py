"""Every BRDF model of the renderer, through the BRDF probe: the lighting pass's own GLSL
(app.brdf.evaluate, float32 on llvmpipe) against its float64 twin, reciprocity, and energy.

The terms are tested one by one in test_fresnel.py, test_microfacet.py, test_diffuse.py and
test_multiscatter.py; here each complete f(l, v), as a scene selects it, is run through the
same preprocessor branches the lighting pass compiles.
"""

from __future__ import annotations

import numpy as np
import pytest

from app.brdf import evaluate
from app.reference.quadrature import N, directional_albedo, reflected_rule
from tests.agreement import relative_error

# One material table per model choice (what a scene file's [materials.NAME] holds).
MODELS: dict[str, dict] = {
    "standard": {"base_color": [0.8, 0.3, 0.1]},
    "standard metal": {"preset": "gold"},
    "schlick generalised": {
        "fresnel": "schlick_generalized", "f90": [0.9, 0.7, 1.0], "fresnel_p": 0.3,
    },
    "exact dielectric": {"fresnel": "dielectric", "ior": 1.5},
    "exact dielectric in water": {"preset": "skin-in-water", "fresnel": "dielectric"},
    "exact internal reflection": {"fresnel": "dielectric", "ior": 1.0, "medium_ior": 1.5},
    "schlick internal reflection": {"ior": 1.0, "medium_ior": 1.5},
    "index matched (vanishes)": {"fresnel": "dielectric", "ior": 1.33, "medium_ior": 1.33},
    "exact conductor": {"preset": "gold", "fresnel": "conductor"},
    "conductor in water": {"preset": "silver", "fresnel": "conductor", "medium_ior": 1.33},
    "beckmann": {"ndf": "beckmann"},
    "beckmann rational lambda": {"ndf": "beckmann", "lambda_form": "rational"},
    "blinn-phong": {"ndf": "blinn_phong"},
    "gtr gamma 1": {"ndf": "gtr", "gtr_gamma": 1.0},
    "gtr gamma 1.5": {"ndf": "gtr", "gtr_gamma": 1.5},
    "gtr gamma 3": {"ndf": "gtr", "gtr_gamma": 3.0},
    "anisotropic ggx": {"anisotropy": 0.8, "preset": "aluminum"},
    "anisotropic beckmann": {"ndf": "beckmann", "anisotropy": -0.6},
    "ggx lambda path": {"g2": "separable"},
    "height-correlated beckmann": {"ndf": "beckmann", "g2": "height_correlated"},
    "direction-correlated exp": {"g2": "direction_correlated"},
    "direction-correlated rational": {"g2": "direction_correlated", "correlation": "rational"},
    "height-direction-correlated exp": {"g2": "height_direction_correlated"},
    "height-direction-correlated rational": {
        "g2": "height_direction_correlated", "correlation": "rational",
    },
    "hammon visibility": {"g2": "hammon"},
    "shirley diffuse": {"diffuse": "shirley"},
    "ashikhmin-shirley diffuse": {"diffuse": "ashikhmin_shirley"},
    "burley diffuse": {"diffuse": "burley"},
    "renormalised burley diffuse": {"diffuse": "burley_renormalized"},
    "oren-nayar diffuse": {"diffuse": "oren_nayar"},
    "hammon diffuse": {"diffuse": "hammon"},
    "no diffuse": {"diffuse": "none"},
    "multiscatter": {"multiscatter": True, "preset": "copper"},
    # Thin film (RTR4 §9.11): over the default dielectric, a conductor, a metalness metal.
    "thin film soap": {"thin_film": True, "film_thickness": 380.0},
    "thin film over gold": {
        "thin_film": True, "preset": "gold", "fresnel": "conductor", "film_ior": 1.5,
        "film_thickness": 250.0,
    },
    "thin film over metalness metal": {
        "thin_film": True, "metallic": 1.0, "base_color": [0.9, 0.6, 0.3], "film_ior": 2.0,
        "film_thickness": 900.0,
    },
    # sheen (RTR4 §9.10): a cloth layer over a base, each NDF at its smooth and rough ends
    "charlie sheen": {"sheen_color": [0.9, 0.6, 0.3], "sheen_roughness": 0.5},
    "charlie sheen smooth": {"sheen_color": [1.0, 1.0, 1.0], "sheen_roughness": 0.0},
    "charlie sheen over metal": {
        "preset": "gold", "sheen_color": [0.3, 0.5, 1.0], "sheen_roughness": 1.0,
    },
    "ashikhmin sheen": {"sheen": "ashikhmin", "sheen_color": [0.9, 0.6, 0.3]},
    "ashikhmin sheen smooth": {
        "sheen": "ashikhmin", "sheen_color": [1.0, 1.0, 1.0], "sheen_roughness": 0.0,
    },
    "ashikhmin sheen rough": {
        "sheen": "ashikhmin", "sheen_color": [0.5, 0.5, 0.5], "sheen_roughness": 1.0,
        "diffuse": "oren_nayar",
    },
    # Charlie with Estevez & Kulla's Smith Lambda: the fit's exp(L) up to 7.7e8 at grazing
    "charlie smith sheen": {
        "sheen": "charlie_smith", "sheen_color": [0.9, 0.6, 0.3], "sheen_roughness": 0.5,
    },
    "charlie smith sheen smooth": {
        "sheen": "charlie_smith", "sheen_color": [1.0, 1.0, 1.0], "sheen_roughness": 0.0,
    },
    "charlie smith sheen over metal": {
        "sheen": "charlie_smith", "preset": "gold", "sheen_color": [0.3, 0.5, 1.0],
        "sheen_roughness": 1.0,
    },
    # --- clear coat (RTR4 §9.12) ---
    "clear coat over plastic": {"base_color": [0.8, 0.3, 0.1], "clearcoat": 1.0},
    "tinted rough half coat over gold": {
        "preset": "gold", "clearcoat": 0.5, "clearcoat_roughness": 0.4,
        "clearcoat_color": [0.9, 0.6, 0.3], "clearcoat_ior": 1.6,
    },
    "clear coat over exact conductor": {
        "preset": "copper", "fresnel": "conductor", "clearcoat": 1.0, "clearcoat_roughness": 0.1,
    },
    "clear coat over exact dielectric": {
        "fresnel": "dielectric", "ior": 1.33, "clearcoat": 1.0, "clearcoat_roughness": 0.05,
    },
    # --- diffraction grating (RTR4 §9.11): a CD over silver, a fine deep one over plastic ---
    "cd grating over silver": {"diffraction": "grating", "preset": "silver", "roughness": 0.2},
    "fine deep grating over plastic": {
        "diffraction": "grating", "base_color": [0.1, 0.1, 0.1], "grating_period": 700.0,
        "grating_depth": 300.0,
    },
    # Weidlich & Wilkie 2007: the base with the directions refracted into the coat
    "weidlich-wilkie coat over plastic": {
        "base_color": [0.8, 0.3, 0.1], "clearcoat": 1.0, "clearcoat_model": "weidlich_wilkie",
    },
    "weidlich-wilkie tinted rough half coat over gold": {
        "preset": "gold", "clearcoat": 0.5, "clearcoat_roughness": 0.4,
        "clearcoat_color": [0.9, 0.6, 0.3], "clearcoat_ior": 1.6,
        "clearcoat_model": "weidlich_wilkie",
    },
    "weidlich-wilkie coat over exact conductor": {
        "preset": "copper", "fresnel": "conductor", "clearcoat": 1.0, "clearcoat_ior": 2.0,
        "clearcoat_roughness": 0.1, "clearcoat_model": "weidlich_wilkie",
    },
    # the same with the coat-base inter-reflection series (docs/layered.md)
    "weidlich-wilkie series coat over plastic": {
        "base_color": [0.8, 0.3, 0.1], "clearcoat": 1.0,
        "clearcoat_model": "weidlich_wilkie_series",
    },
    "weidlich-wilkie series tinted rough half coat over gold": {
        "preset": "gold", "clearcoat": 0.5, "clearcoat_roughness": 0.4,
        "clearcoat_color": [0.9, 0.6, 0.3], "clearcoat_ior": 1.6,
        "clearcoat_model": "weidlich_wilkie_series",
    },
    # --- multiple scattering with another G2: each reads its own table (RTR4 §9.8) ---
    "multiscatter separable gold": {"preset": "gold", "multiscatter": True, "g2": "separable"},
    "multiscatter direction-correlated rational copper": {
        "preset": "copper", "multiscatter": True, "g2": "direction_correlated",
        "correlation": "rational",
    },
    # --- empirical cloth (RTR4 §9.10): not reciprocal (NOT_RECIPROCAL; tests/test_cloth.py) ---
    "empirical cloth defaults (lambert)": {"diffuse": "cloth_empirical"},
    "empirical cloth velvet": {
        "diffuse": "cloth_empirical", "base_color": [0.35, 0.02, 0.05], "cloth_rim": [0.6, 4.0],
        "cloth_inner": [0.4, 2.0], "cloth_diffuse": 0.5, "cloth_scatter": [0.6, 0.2, 0.1],
        "cloth_wrap": 0.5, "cloth_sheen": 0.8, "cloth_sheen_color": [1.0, 0.8, 0.6],
    },
    "empirical cloth sheen, no wrap": {
        "diffuse": "cloth_empirical", "cloth_diffuse": 0.8, "cloth_sheen": 1.0,
    },
    # --- micro-cylinder fibres (RTR4 §9.10): not reciprocal (tests/test_fiber.py, which
    # also runs curved threads) ---
    "kajiya-kay fibre": {"fiber": "kajiya_kay", "base_color": [0.6, 0.3, 0.1]},
    "kajiya-kay fibre turned": {"fiber": "kajiya_kay", "fiber_rotation": 30.0},
    "sadeghi fibre": {"fiber": "sadeghi", "base_color": [0.6, 0.3, 0.1]},
    "sadeghi fibre turned, isotropic volume": {
        "fiber": "sadeghi", "fiber_rotation": -45.0, "fiber_kd": 1.0, "fiber_gamma_v": 40.0,
    },
}  # fmt: skip

# RTR4 §9.10's empirical cloth lobes depend on v alone and its wrap on l alone: what holds
# of reciprocity for them is tested in tests/test_cloth.py.
NOT_RECIPROCAL = (
    "empirical cloth velvet",
    # the fibre patches weight the thread by cos(theta_i) over n.l (tests/test_fiber.py)
    "kajiya-kay fibre",
    "kajiya-kay fibre turned",
    "sadeghi fibre",
    "sadeghi fibre turned, isotropic volume",
)

ROUGHNESSES = (0.0, 0.3, 1.0)  # 0 is floored to 0.045 by the material


def _unit(d: np.ndarray) -> np.ndarray:
    d = np.asarray(d, np.float64)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def _dir(theta_deg: np.ndarray, phi_deg: np.ndarray) -> np.ndarray:
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1)


def direction_pairs(seed: int = 7, count: int = 3000) -> tuple[np.ndarray, np.ndarray]:
    """Random pairs over the upper hemisphere plus the edge cases, rounded to float32 so
    both backends see the same inputs."""
    rng = np.random.default_rng(seed)
    l = _unit(rng.normal(size=(count, 3)))
    v = _unit(rng.normal(size=(count, 3)))
    l[:, 2], v[:, 2] = np.abs(l[:, 2]), np.abs(v[:, 2])
    theta = np.array([0.0, 30.0, 60.0, 80.0, 89.0, 89.9])
    mirror_l = _dir(theta, 0.0 * theta)
    mirror_v = _dir(theta, 0.0 * theta + 180.0)  # the specular peak of each theta
    edges_l = [
        [0.0, 0.0, 1.0],  # l = v = n
        _dir(89.9, 0.0),  # l = v at grazing
        _dir(45.0, 0.0),  # n.v tiny
        _dir(89.94, 0.0),  # n.l ~ 1e-3
        [1.0, 0.0, 0.0],  # l in the tangent plane: f = 0
        _dir(40.0, 10.0),  # v just below the horizon (clamped n.v)
        _dir(30.0, 0.0),  # v = -l reflected through n: no half vector
        _dir(60.0, 90.0),  # l along the bitangent, v along the tangent
    ]
    edges_v = [
        [0.0, 0.0, 1.0],
        _dir(89.9, 0.0),
        _dir(89.94, 180.0),
        _dir(20.0, 250.0),
        _dir(30.0, 0.0),
        [0.3, 0.0, -0.01],
        -_dir(30.0, 0.0),
        _dir(60.0, 0.0),
    ]
    l = np.vstack([l, mirror_l, edges_l])
    v = np.vstack([v, mirror_v, edges_v])
    l, v = _unit(l), _unit(v)
    return l.astype(np.float32).astype(np.float64), v.astype(np.float32).astype(np.float64)


@pytest.fixture(scope="module")
def pairs() -> tuple[np.ndarray, np.ndarray]:
    return direction_pairs()


@pytest.mark.parametrize("roughness", ROUGHNESSES)
@pytest.mark.parametrize("name", list(MODELS))
def test_glsl_matches_float64_twin(gl_egl, pairs, name: str, roughness: float) -> None:
    l, v = pairs
    material = {**MODELS[name], "roughness": roughness}
    gpu = evaluate(material, l, v, gl=gl_egl)
    ref = evaluate(material, l, v, backend="reference")
    assert np.all(np.isfinite(gpu)) and np.all(gpu >= 0.0)
    assert np.all(np.isfinite(ref)) and np.all(ref >= 0.0)
    below = (l @ N) <= 0.0
    assert np.all(gpu[below] == 0.0) and np.all(ref[below] == 0.0)
    # Relative error, with values under 1e-6 of the set's peak compared absolutely
    # (that far below the peak float32's absolute rounding of the sums dominates).
    err = relative_error(gpu, ref, 1e-6 * ref.max())
    assert err.max() <= 1e-4, f"{name} r={roughness}: max relative error {err.max():.2e}"


@pytest.mark.parametrize("name", [name for name in MODELS if name not in NOT_RECIPROCAL])
def test_reciprocity(gl_egl, pairs, name: str) -> None:
    """f(l, v) = f(v, l) (RTR4 §9.3) for every model, twin and GLSL, where both
    cosines exceed the n.v clamp (which is the one deliberate asymmetry)."""
    l, v = pairs
    keep = (l @ N > 1e-3) & (v @ N > 1e-3)
    l, v = _unit(l[keep]), _unit(v[keep])  # exactly unit in float64: f is reciprocal for those
    material = {**MODELS[name], "roughness": 0.4}
    ref_lv = evaluate(material, l, v, backend="reference")
    ref_vl = evaluate(material, v, l, backend="reference")
    np.testing.assert_allclose(ref_lv, ref_vl, rtol=1e-12, atol=1e-300)
    gpu_lv = evaluate(material, l, v, gl=gl_egl)
    gpu_vl = evaluate(material, v, l, gl=gl_egl)
    assert relative_error(gpu_lv, gpu_vl, 1e-6 * gpu_lv.max()).max() <= 1e-4


SPECULAR_ONLY = {  # specular terms alone with F = 1: white metal, no diffuse lobe
    name: {**MODELS[name], "base_color": [1.0, 1.0, 1.0], "metallic": 1.0, "diffuse": "none"}
    for name in MODELS
    if MODELS[name].get("fresnel", "schlick") == "schlick"
    and "preset" not in MODELS[name]
    and "diffuse" not in MODELS[name]
    and "medium_ior" not in MODELS[name]
    and "sheen_color" not in MODELS[name]  # the sheen layer's energy: tests/test_sheen.py
    # A coat's lobe (alpha 0.002) is narrower than this rule resolves on the base's
    # roughness: the coated white furnace is integrated lobe by lobe in test_layered.py.
    and "clearcoat" not in MODELS[name]
    # A grating's orders lie away from the mirror lobe this rule samples: its white
    # furnace is integrated over the whole disc of directions in test_diffraction.py.
    and "diffraction" not in MODELS[name]
    # A fibre's albedo is integrated in the thread's own coordinates in test_fiber.py.
    and "fiber" not in MODELS[name]
}


@pytest.mark.parametrize("name", list(SPECULAR_ONLY))
def test_specular_never_creates_energy(name: str) -> None:
    """Directional albedo of every NDF/Lambda/G2 combination with F = 1 is at most 1
    (RTR4 §9.3), over roughness and incidence; by quadrature on the twin."""
    worst, roughness, theta = specular_albedo_max(name)
    assert worst <= 1.0 + 2e-3, f"{name}: albedo {worst:.4f} at r={roughness}, {theta} deg"


def specular_albedo_max(name: str) -> tuple[float, float, float]:
    """The largest directional albedo of a specular-only model, and its roughness and theta."""
    best = (0.0, 0.0, 0.0)
    for roughness in (0.05, 0.2, 0.5, 0.8, 1.0):
        alpha = roughness * roughness
        for theta in (0.0, 30.0, 60.0, 80.0, 89.0):
            l = _dir(theta, 30.0)
            v, w = reflected_rule(l, max(alpha, 0.01), 32, 24)
            material = {**SPECULAR_ONLY[name], "roughness": roughness}
            f = evaluate(material, np.broadcast_to(l, v.shape), v, backend="reference")
            albedo = float(directional_albedo(f, v, w)[0])
            best = max(best, (albedo, roughness, theta))
    return best


def print_tables() -> None:
    """The tables of docs/brdf-models.md: ``python -m tests.test_brdf_models``."""
    from app.gl.context import create_context

    gl = create_context("auto")
    l, v = direction_pairs()
    print("| model | r = 0 | r = 0.3 | r = 1 |\n|---|---|---|---|")
    for name, material in MODELS.items():
        cells = []
        for roughness in ROUGHNESSES:
            m = {**material, "roughness": roughness}
            gpu = evaluate(m, l, v, gl=gl)
            ref = evaluate(m, l, v, backend="reference")
            cells.append(f"{relative_error(gpu, ref, 1e-6 * ref.max()).max():.1e}")
        print(f"| {name} | " + " | ".join(cells) + " |")
    print("\n| specular model (F = 1) | largest albedo | at roughness | at theta |")
    print("|---|---|---|---|")
    for name in SPECULAR_ONLY:
        albedo, roughness, theta = specular_albedo_max(name)
        print(f"| {name} | {albedo:.4f} | {roughness:g} | {theta:g} |")
    gl.release()


if __name__ == "__main__":
    print_tables()
