"""The empirical cloth terms of RTR4 §9.10 (diffuse = "cloth_empirical";
glsl/brdf/cloth.glsl, twin app/reference/cloth.py): what reciprocity holds, the wrap
form's energy conservation, the white-furnace albedo, the scene keys.

GLSL against the twin: tests/test_brdf_models.py (its "empirical cloth" rows). The
numbers printed by ``python -m tests.test_cloth`` are those of docs/cloth.md, "Empirical".
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from app.brdf import evaluate
from app.errors import InputError
from app.reference import cloth
from app.reference.cloth import CLOTH_WRAP_MIN_N_DOT_L
from app.reference.constants import MIN_N_DOT_V
from app.reference.quadrature import cosine_rule, gauss_legendre
from app.scene.model import CLOTH_KEYS
from tests.agreement import hdr_and_twin
from tests.conftest import REPO
from tests.test_brdf_models import direction_pairs

N = np.array([0.0, 0.0, 1.0])
WRAPS = (0.0, 0.1, 0.25, 0.5, 0.75, 1.0)
ALL_KEYS = {
    "diffuse": "cloth_empirical", "cloth_rim": [0.6, 4.0], "cloth_inner": [0.4, 2.0],
    "cloth_diffuse": 0.5, "cloth_scatter": [0.6, 0.2, 0.1], "cloth_wrap": 0.5,
    "cloth_sheen": 0.8, "cloth_sheen_color": [1.0, 0.8, 0.6],
}  # fmt: skip

EVERY_WEIGHT_1 = {"cloth_rim": [1.0, 1.0], "cloth_inner": [1.0, 1.0], "cloth_sheen": 1.0}

# White furnace (rho_ss = 1, c_sheen = 1), twin, largest directional albedo over n.v:
# (name, keys, pinned maximum). The model is not normalised: lobes k_rim + k_inner + k_diff
# above 1, or any sheen over a full diffuse lobe, reflect more than arrives.
FURNACE: tuple[tuple[str, dict, float], ...] = (
    ("defaults (Lambert)", {}, 1.0),
    ("wrap 0.5, white scatter", {"cloth_wrap": 0.5}, 0.999982),
    ("wrap 1, white scatter", {"cloth_wrap": 1.0}, 0.999978),
    ("wrap 0.5, the book's form", {"cloth_wrap": 0.5, "cloth_wrap_form": "rtr4"}, 1.333304),
    ("wrap 0.5, black scatter", {"cloth_wrap": 0.5, "cloth_scatter": [0.0, 0.0, 0.0]}, 0.518519),
    ("rim [1, 4] + diffuse 0", {"cloth_rim": [1.0, 4.0], "cloth_diffuse": 0.0}, 1.0),
    ("inner [1, 2] + diffuse 0", {"cloth_inner": [1.0, 2.0], "cloth_diffuse": 0.0}, 0.9998),
    ("sheen 1 alone", {"cloth_sheen": 1.0, "cloth_diffuse": 0.0}, 0.088428),
    ("every weight 1, no wrap", EVERY_WEIGHT_1, 2.088428),
    ("all keys (the test's)", ALL_KEYS, 1.001766),
)


def _params(keys: dict):
    from app.scene.model import Material

    return Material(**{"diffuse": "cloth_empirical", **keys}).resolve().params


def f_twin(p, rho: np.ndarray, l: np.ndarray, v: np.ndarray, rtr4: bool = False) -> np.ndarray:
    """The cloth term of the twin at unit l, v over n = +Z (the caller's clamps applied)."""
    NoL = np.clip(l @ N, 1e-20, 1.0)
    NoV = np.clip(v @ N, MIN_N_DOT_V, 1.0)
    h = l + v
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    LoH = np.clip(np.sum(l * h, axis=-1), 0.0, 1.0)
    return cloth.f_cloth_empirical(
        rtr4, rho, p.cloth_rim_inner, p.cloth_diffuse, p.cloth_scatter, p.cloth_wrap,
        p.cloth_sheen, NoL, NoV, LoH,
    )  # fmt: skip


def furnace_albedo(keys: dict, mu_v: float) -> float:
    """int f(l, v) (n.l) dl with rho_ss = 1 (the largest channel) as the illumination sum
    takes it: f (n.l) above n.l = 1e-4, the wrapped lobes' f (n.l) at and below (past the
    terminator, RTR4 §9.10); Gauss-Legendre 256 in |n.l| x 256 in azimuth per hemisphere."""
    p = _params(keys)
    rtr4 = keys.get("cloth_wrap_form") == "rtr4"
    d, w = cosine_rule(256, 256)
    v = np.array([np.sqrt(1.0 - mu_v * mu_v), 0.0, mu_v])
    f = f_twin(p, np.ones(3), d, np.broadcast_to(v, d.shape), rtr4)
    upper = np.sum(f * (d[:, 2] * w)[:, None], axis=0)
    lower = np.sum(
        cloth.f_cloth_empirical_past_terminator(
            rtr4, np.ones(3), p.cloth_rim_inner, p.cloth_diffuse, p.cloth_scatter,
            p.cloth_wrap, -d[:, 2], np.full(len(d), max(mu_v, MIN_N_DOT_V)),
        ) * w[:, None], axis=0,
    )  # fmt: skip
    return float(np.max(upper + lower))


MU_V = (MIN_N_DOT_V, 0.01, 0.05, 0.1, 0.2, 0.5, 0.8, 1.0)


def furnace_max(keys: dict) -> tuple[float, float]:
    return max((furnace_albedo(keys, mu), mu) for mu in MU_V)


# --- the defaults are Lambert ---


def test_defaults_are_lambert_bit_for_bit(gl_egl) -> None:
    """diffuse = "cloth_empirical" without keys: k_diff 1, no lobes, white scatter, wrap 0,
    no sheen, i.e. Lambert, bit for bit in the twin and on the GPU (1 + 0/n.l is 1)."""
    l, v = direction_pairs()
    for backend in ("reference", "glsl"):
        gl = gl_egl if backend == "glsl" else None
        lam = evaluate({"roughness": 0.4}, l, v, backend=backend, gl=gl)
        cl = evaluate({"diffuse": "cloth_empirical", "roughness": 0.4}, l, v, backend=backend,
                      gl=gl)  # fmt: skip
        assert np.array_equal(lam, cl), backend


# --- reciprocity: what holds ---


def test_reciprocity_what_holds() -> None:
    """The rim and inner lobes depend on v only, the wrap on l only: f(l, v) != f(v, l).
    What holds: (1) the sheen term and the k_diff lobe without wrap are reciprocal;
    (2) the asymmetry is exactly rho/pi [g(v) W(l) - g(l) W(v)], g = the lobes' sum."""
    l, v = direction_pairs()
    keep = (l @ N > 1e-3) & (v @ N > 1e-3)
    l, v = l[keep], v[keep]
    l = l / np.linalg.norm(l, axis=-1, keepdims=True)
    v = v / np.linalg.norm(v, axis=-1, keepdims=True)
    rho = np.array([0.8, 0.5, 0.2])
    sym = _params({"cloth_diffuse": 0.7, "cloth_sheen": 0.9})
    np.testing.assert_allclose(f_twin(sym, rho, l, v), f_twin(sym, rho, v, l), rtol=1e-12)
    p = _params(ALL_KEYS)
    asym = f_twin(p, rho, l, v) - f_twin(p, rho, v, l)
    assert np.abs(asym).max() > 0.1  # not reciprocal, and by a visible amount

    def g(x: np.ndarray) -> np.ndarray:
        return cloth.Fd_cloth_empirical(rho, p.cloth_rim_inner, p.cloth_diffuse, x @ N)

    def W(x: np.ndarray) -> np.ndarray:
        return cloth.wrap_cloth_empirical(False, p.cloth_scatter, p.cloth_wrap, x @ N)

    np.testing.assert_allclose(asym, g(v) * W(l) - g(l) * W(v), rtol=1e-9, atol=1e-12)


# --- the wrap forms: energy, and light past the terminator ---


@pytest.mark.parametrize("w", WRAPS)
def test_wrap_integrates_to_lambert_over_the_sphere(w: float) -> None:
    """Filament's wrapped cosine (n.l + w)+ / (1 + w)^2 integrates to pi = int (n.l)+ dl
    over the whole sphere (exact: 2 pi / (1 + w)^2 int_{-w}^{1} (mu + w) dmu), the book's
    clamp(n.l + w, 0, 1) / (1 + w) to pi (1 + 2w)/(1 + w); and the illumination sum's two
    sides (the lit side's W (n.l), the wrapped lobes past the terminator) add up to it."""
    lo = -w if w > 0 else 0.0
    for rtr4, expected in ((False, np.pi), (True, np.pi * (1.0 + 2.0 * w) / (1.0 + w))):
        # the book's form has a kink at n.l = 1 - w: split the rule there
        knots = sorted({lo, max(lo, 1.0 - w), 1.0})
        sphere = sum(
            2.0 * np.pi * np.sum(wt * cloth.wrapped_cosine_cloth_empirical(rtr4, w, mu))
            for a, b in itertools.pairwise(knots) if b > a
            for mu, wt in [gauss_legendre(a, b, 8)]
        )  # fmt: skip
        assert abs(sphere - expected) <= 1e-13, (rtr4, sphere)
        mu, wt = gauss_legendre(CLOTH_WRAP_MIN_N_DOT_L, 1.0, 256)
        upper = (
            2.0
            * np.pi
            * np.sum(wt * cloth.wrap_cloth_empirical(rtr4, np.ones(3), w, mu)[:, 0] * mu)
        )
        mu, wt = gauss_legendre(-1.0, CLOTH_WRAP_MIN_N_DOT_L, 256)
        past = cloth.f_cloth_empirical_past_terminator(
            rtr4, np.full(3, np.pi), np.zeros(4), 1.0, np.ones(3), w, mu, np.ones_like(mu)
        )[:, 0]  # rho_ss = pi: the lobes are 1
        assert abs(upper + 2.0 * np.pi * np.sum(wt * past) - expected) <= 2e-3 * np.pi, rtr4


def test_the_probe_brdf_is_zero_behind_the_surface(gl_egl) -> None:
    """The BRDF probe's f (brdf_eval) is 0 for n.l <= 0 on both backends: the wrapped light
    past the terminator is the illumination sum's (test_wrap_lights_past_the_terminator)."""
    l = np.array([[0.6, 0.0, -0.2], [0.8, 0.0, 0.0]])
    l = l / np.linalg.norm(l, axis=-1, keepdims=True)
    v = np.array([[0.0, 0.0, 1.0]] * 2)
    for backend in ("reference", "glsl"):
        f = evaluate(ALL_KEYS, l, v, backend=backend, gl=gl_egl if backend == "glsl" else None)
        assert np.all(f == 0.0)


def _wrapped_sphere(gl_egl, form: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A white-scatter cloth sphere with wrap 0.5 lit from +x, seen from +z (48 x 48, f32
    G-buffer, no antialiasing): the GPU's HDR, the twin's, and n.l per covered pixel."""
    from app.reference.illumination import decode_gbuffer
    from app.render.renderer import Renderer
    from app.scene.loader import parse_scene

    data = {
        "camera": {"position": [0, 0, 4], "target": [0, 0, 0], "fov_y": 35.0},
        "render": {"gbuffer": "f32", "antialiasing": "none"},
        "materials": {"cotton": {
            "base_color": [0.8, 0.8, 0.8], "diffuse": "cloth_empirical", "f0": 0.0,
            "cloth_wrap": 0.5, "cloth_wrap_form": form,
        }},
        "objects": [{"shape": "sphere", "radius": 1.0, "material": "cotton"}],
        "lights": [{"type": "directional", "direction": [-1, 0, 0], "intensity": 2.0}],
    }  # fmt: skip
    loaded = parse_scene(data, REPO / "inline.toml")
    r = Renderer(gl_egl, loaded, (48, 48))
    try:
        hdr, ref, g = hdr_and_twin(r, loaded.scene.background)
        dec = decode_gbuffer(g, r.camera)
    finally:
        r.release()
    NoL = np.full(g.depth.shape, np.nan)
    NoL[dec.covered] = dec.n[:, 0]  # l = +x
    return hdr, ref, NoL


@pytest.mark.parametrize("form", ["filament", "rtr4"])
def test_wrap_lights_past_the_terminator(gl_egl, form: str) -> None:
    """RTR4 §9.10: wrap lighting lights the surface past the terminator, down to n.l = -w,
    so the terminator is a gradient, not a step: every pixel with -0.4 < n.l < -0.02 is lit,
    the radiance falls smoothly through n.l = 0, and the GPU agrees with the twin."""
    hdr, ref, NoL = _wrapped_sphere(gl_egl, form)
    sel = np.isfinite(NoL)
    np.testing.assert_allclose(hdr[sel], ref[sel], rtol=1e-4, atol=1e-6)
    past = sel & (NoL < -0.02) & (NoL > -0.4)
    assert past.sum() > 20 and np.all(hdr[past][:, 0] > 0.0), "nothing lit past the terminator"
    assert np.all(hdr[sel & (NoL < -0.52)] == 0.0), "lit beyond n.l = -w"
    # no step at the terminator: the row through the centre falls in small steps
    row = hdr[24, :, 0][np.isfinite(NoL[24])]
    assert np.abs(np.diff(row)).max() < 0.2 * row.max()


def test_wrap_refused_under_a_coat_or_a_sheen_layer() -> None:
    """The wrapped lobes past the terminator carry no coat or sheen-layer weights: refused."""
    for extra in ({"clearcoat": 0.5}, {"sheen_color": [0.5, 0.5, 0.5]}):
        with pytest.raises(InputError, match="cloth_wrap: the light wrapped past the terminator"):
            evaluate({"diffuse": "cloth_empirical", "cloth_wrap": 0.5, **extra},
                     [[0.0, 0.0, 1.0]], [[0.0, 0.0, 1.0]], backend="reference")  # fmt: skip


# --- white furnace ---


@pytest.mark.parametrize(("name", "keys", "pinned"), FURNACE, ids=[f[0] for f in FURNACE])
def test_white_furnace_albedo(name: str, keys: dict, pinned: float) -> None:
    """Largest directional albedo over n.v, pinned to 1e-4 (docs/cloth.md, "Empirical")."""
    albedo, _ = furnace_max(keys)
    assert abs(albedo - pinned) <= 1e-4, f"{name}: {albedo:.6f}"


# --- scene keys ---


@pytest.mark.parametrize("key", CLOTH_KEYS)
def test_cloth_keys_need_the_model(key: str) -> None:
    value = {"cloth_rim": [0.5, 2.0], "cloth_inner": [0.5, 2.0], "cloth_scatter": [0.5] * 3,
             "cloth_sheen_color": [0.5] * 3, "cloth_wrap_form": "rtr4"}.get(key, 0.5)  # fmt: skip
    with pytest.raises(InputError, match=f"{key}: applies only with diffuse = 'cloth_empirical'"):
        evaluate({key: value}, [[0.0, 0.0, 1.0]], [[0.0, 0.0, 1.0]], backend="reference")
    evaluate({key: value, "diffuse": "cloth_empirical"}, [[0.0, 0.0, 1.0]], [[0.0, 0.0, 1.0]],
             backend="reference")  # fmt: skip


def print_tables() -> None:
    print("| parameters | largest albedo | at n.v |\n|---|---|---|")
    for name, keys, _ in FURNACE:
        albedo, mu = furnace_max(keys)
        print(f"| {name} | {albedo:.6f} | {mu:g} |")


if __name__ == "__main__":
    print_tables()
