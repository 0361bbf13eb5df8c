"""glTF KHR_materials_* extensions on the project's models (app/scene/gltf_extensions.py).

Each extension's parameters reach MaterialParams; where the project's model and the
extension's definition agree, the project's BRDF for the mapped parameters (the float64
twin, and once the GLSL through the BRDF probe) equals the extension specification's own
formula, written out here from the Khronos READMEs (KHR_materials_ior, _specular,
_anisotropy, _sheen; glTF 2.0 Appendix B for the GGX lobe); bad values raise GltfError
with the JSON path.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from app.common.models import MaterialParams
from app.reference.material import ShadingPoint, Surface, brdf_eval
from app.reference.normal_mapping import rotate_tangent
from app.reference.sheen import load_table, sheen_E
from app.scene.gltf_document import GltfError
from app.scene.gltf_extensions import (
    IOR_ZERO_ETA,
    map_material_extensions,
    material_extensions,
)
from tests.agreement import relative_error

KEY = "materials[2]"
N = np.array([0.0, 0.0, 1.0])
X = np.array([1.0, 0.0, 0.0])


def core(base_color=(0.0, 0.0, 0.0), metallic: float = 0.0, roughness: float = 0.5):
    """What the reader builds from a core material (glTF's fixed ior 1.5: F0 = 0.04)."""
    return MaterialParams(tuple(base_color), metallic, roughness, 0.04)


def _dir(theta_deg: float, phi_deg: float) -> np.ndarray:
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


def pairs() -> tuple[np.ndarray, np.ndarray]:
    """Light and view directions at several angles (normal incidence to 80 degrees)."""
    ls, vs = [], []
    for tl in (0.0, 25.0, 50.0, 80.0):
        for tv, pv in ((0.0, 0.0), (35.0, 200.0), (60.0, 150.0), (75.0, 10.0), (40.0, 90.0)):
            ls.append(_dir(tl, 30.0))
            vs.append(_dir(tv, pv))
    return np.array(ls), np.array(vs)


def twin(p: MaterialParams, l, v, t=X, terms: str = "all") -> np.ndarray:
    """The project's f(l, v) for the mapped parameters: the float64 twin, n = +Z."""
    s = Surface(np.asarray(p.base_color, np.float64), p.metallic, p.roughness, p.f0,
                p.anisotropy)  # fmt: skip
    return brdf_eval(ShadingPoint(s, p.params, N, None, t, v), p.model, l, terms=terms)


# --- the specifications' formulas ---


def spec_schlick(f0, f90, VoH):
    """glTF 2.0 Appendix B / KHR_materials_specular: F = f0 + (f90 - f0)(1 - |v.h|)^5."""
    return f0 + (f90 - f0) * (1.0 - np.abs(VoH)) ** 5


def spec_ggx(NoH, NoL, NoV, alpha):
    """glTF 2.0 Appendix B: D_GGX and the height-correlated Smith V_GGX."""
    a2 = alpha * alpha
    D = a2 / (math.pi * (NoH * NoH * (a2 - 1.0) + 1.0) ** 2)
    V = 0.5 / (NoL * np.sqrt(NoV * NoV * (1 - a2) + a2) + NoV * np.sqrt(NoL * NoL * (1 - a2) + a2))
    return D * V


def spec_ggx_anisotropic(t, b, h, l, v, at, ab):
    """KHR_materials_anisotropy's D_GGX_anisotropic and V_GGX_anisotropic."""
    NoH, NoL, NoV = h[:, 2], l[:, 2], v[:, 2]
    a2 = at * ab
    f = np.stack([ab * (h @ t), at * (h @ b), a2 * NoH], axis=-1)
    w2 = a2 / np.sum(f * f, axis=-1)
    D = a2 * w2 * w2 / math.pi
    ggx_v = NoL * np.linalg.norm(np.stack([at * (v @ t), ab * (v @ b), NoV], -1), axis=-1)
    ggx_l = NoV * np.linalg.norm(np.stack([at * (l @ t), ab * (l @ b), NoL], -1), axis=-1)
    # The README's sample code clamps V to [0, 1]; that is the non-normative sample's (it
    # cuts the lobe near grazing, V = 5.3 at n.l = cos 80, n.v = cos 75, alpha = 0.25): the
    # normative text asks for the Smith G2 of this D, which the unclamped form is.
    return D * (0.5 / (ggx_v + ggx_l))


def half(l, v):
    h = l + v
    return h / np.linalg.norm(h, axis=-1, keepdims=True)


def spec_dielectric_f0(ior: float, color, weight: float) -> np.ndarray:
    """KHR_materials_specular with KHR_materials_ior:
    min(((ior - 1)/(ior + 1))^2 specularColor, 1) specular."""
    return np.minimum(((ior - 1.0) / (ior + 1.0)) ** 2 * np.asarray(color), 1.0) * weight


# --- parameters reach MaterialParams ---


def test_no_extensions_is_the_core_material():
    p = core()
    assert material_extensions({}, p, KEY) is p
    assert map_material_extensions(None, p, KEY).params is p


@pytest.mark.parametrize("ior", [1.0, 1.33, 1.5, 2.42, 4.0])
def test_ior_sets_f0_and_the_exact_fresnel_index(ior):
    p = material_extensions({"KHR_materials_ior": {"ior": ior}}, core(), KEY)
    assert p.f0 == pytest.approx(((ior - 1) / (ior + 1)) ** 2, rel=1e-15, abs=1e-300)
    assert p.params.eta_dielectric == ior
    assert p.model.fresnel == "schlick"  # F90 stays 1: nothing else changes


def test_ior_zero_is_a_fresnel_of_one():
    p = material_extensions({"KHR_materials_ior": {"ior": 0}}, core(), KEY)
    assert (p.f0, p.params.eta_dielectric) == (1.0, IOR_ZERO_ETA)
    l, v = pairs()
    # "the Fresnel term MUST evaluate to 1.0 independently of the view or light direction"
    f = twin(p, l, v, terms="specular")
    h = half(l, v)
    ref = spec_ggx(h[:, 2], l[:, 2], v[:, 2], 0.25)[:, None]
    np.testing.assert_allclose(f, np.broadcast_to(ref, f.shape), rtol=1e-12)


def test_specular_factor_reaches_f0_and_f90():
    ext = {"KHR_materials_ior": {"ior": 1.7},
           "KHR_materials_specular": {"specularFactor": 0.3}}  # fmt: skip
    p = material_extensions(ext, core(), KEY)
    assert p.f0 == pytest.approx(((1.7 - 1) / 2.7) ** 2 * 0.3, rel=1e-15)
    assert p.model.fresnel == "schlick_generalized"
    np.testing.assert_array_equal(p.params.f90, [0.3, 0.3, 0.3])
    assert p.params.fresnel_exponent == 5.0
    assert p.params.eta_dielectric == 1.7  # specular does not change the index


def test_white_specular_color_above_one_is_clamped_exactly():
    ext = {"KHR_materials_specular": {"specularColorFactor": [30.0, 30.0, 30.0]}}
    m = map_material_extensions(ext, core(), KEY)
    assert m.params.f0 == 1.0 and m.notes == ()  # min(0.04 x 30, 1) = 1


def test_coloured_specular_is_its_largest_channel_times_the_specular_color():
    ext = {"KHR_materials_specular": {"specularColorFactor": [2.0, 1.0, 0.5],
                                      "specularFactor": 0.7}}  # fmt: skip
    m = map_material_extensions(ext, core(), KEY)
    f0_rgb = spec_dielectric_f0(1.5, [2.0, 1.0, 0.5], 0.7)  # (0.056, 0.028, 0.014)
    assert m.params.f0 == pytest.approx(f0_rgb.max(), rel=1e-15) and m.notes == ()
    np.testing.assert_allclose(m.params.f0 * m.params.params.specular_color, f0_rgb, rtol=1e-15)
    # the twin's f(l, v): the specification's coloured dielectric Fresnel, exactly
    l, v = pairs()
    h = half(l, v)
    f = twin(m.params, l, v, terms="specular")
    F = spec_schlick(f0_rgb, 0.7, np.sum(v * h, axis=-1)[:, None])
    ref = F * spec_ggx(h[:, 2], l[:, 2], v[:, 2], 0.25)[:, None]
    np.testing.assert_allclose(f, ref, rtol=1e-12)


def test_specular_color_texture_is_a_map_of_the_specular_color():
    """specularColorTexture becomes maps["specular_color"] (RGB), turns SPECULAR_COLOR on
    even under a white factor and marks the row (specular_color_map 1: RT6's RGB scales
    the specular colour); a sheen colour texture beside it is left out with a note."""
    tex = {"index": 2, "texCoord": 1}
    ext = {"KHR_materials_specular": {"specularColorTexture": tex},
           "KHR_materials_sheen": {"sheenColorFactor": [1, 1, 1],
                                   "sheenColorTexture": {"index": 3}}}  # fmt: skip
    m = map_material_extensions(ext, core(), KEY)
    assert m.maps["specular_color"].info == tex and m.maps["specular_color"].channel == "rgb"
    assert m.params.model.specular_color and m.params.params.specular_color_map == 1.0
    np.testing.assert_array_equal(m.params.params.specular_color, [1.0, 1.0, 1.0])
    assert "sheen_color" not in m.maps
    assert [n for n in m.notes if "sheenColorTexture" in n and "specularColorTexture" in n]
    plain = map_material_extensions({"KHR_materials_specular": {}}, core(), KEY).params
    assert not plain.model.specular_color and plain.params.specular_color_map == 0.0


def test_sheen_roughness_texture_is_a_map_of_the_sheen_roughness():
    """sheenRoughnessTexture's A becomes maps["sheen_roughness"] and marks the row
    (sheen_roughness_map 1: RT6's A scales the sheen roughness); a clearcoatTexture
    beside it is left out with a note."""
    ext = {"KHR_materials_sheen": {"sheenColorFactor": [1, 1, 1],
                                   "sheenRoughnessTexture": {"index": 2}},
           "KHR_materials_clearcoat": {"clearcoatFactor": 1.0,
                                       "clearcoatTexture": {"index": 3}}}  # fmt: skip
    m = map_material_extensions(ext, core(), KEY)
    assert m.maps["sheen_roughness"].channel == "a"
    assert m.params.params.sheen_roughness_map == 1.0 and "clearcoat" not in m.maps
    assert [n for n in m.notes if "clearcoatTexture" in n and "sheenRoughnessTexture" in n]


def test_anisotropy_parameters():
    ext = {"KHR_materials_anisotropy": {"anisotropyStrength": 0.6}}
    p = material_extensions(ext, core(roughness=0.4), KEY)
    alpha = 0.16
    at = alpha + (1 - alpha) * 0.36
    assert p.model.anisotropic
    # alpha' (1 + a) = alpha_t and alpha' (1 - a) = alpha_b
    a2 = p.roughness**2
    assert a2 * (1 + p.anisotropy) == pytest.approx(at, rel=1e-14)
    assert a2 * (1 - p.anisotropy) == pytest.approx(alpha, rel=1e-14)
    plain = core()  # strength 0 (the default): isotropic, the parameters untouched
    assert material_extensions({"KHR_materials_anisotropy": {}}, plain, KEY) is plain


def test_sheen_parameters():
    ext = {"KHR_materials_sheen": {"sheenColorFactor": [0.9, 0.4, 0.1],
                                   "sheenRoughnessFactor": 0.3}}  # fmt: skip
    p = material_extensions(ext, core(), KEY)
    assert p.model.sheen == "charlie_smith"
    np.testing.assert_array_equal(p.params.sheen_color, [0.9, 0.4, 0.1])
    assert p.params.sheen_roughness == 0.3
    black = {"KHR_materials_sheen": {"sheenRoughnessFactor": 0.3}}  # colour 0: disabled
    plain = core()
    assert material_extensions(black, plain, KEY) is plain


def test_clearcoat_parameters_and_normal_map():
    info = {"index": 3, "texCoord": 1, "scale": 0.5}
    ext = {"KHR_materials_clearcoat": {"clearcoatFactor": 0.7,
                                       "clearcoatRoughnessFactor": 0.2,
                                       "clearcoatNormalTexture": info,
                                       "clearcoatTexture": {"index": 1}}}  # fmt: skip
    m = map_material_extensions(ext, core(), KEY)
    p = m.params
    assert p.model.clearcoat == "filament"
    assert (p.params.clearcoat, p.params.clearcoat_roughness) == (0.7, 0.2)
    assert p.params.clearcoat_eta == 1.5
    np.testing.assert_array_equal(p.params.clearcoat_color, [1.0, 1.0, 1.0])
    assert m.maps["coat_normal"].info == info
    assert m.maps["coat_normal"].key.endswith("KHR_materials_clearcoat.clearcoatNormalTexture")
    assert m.maps["clearcoat"].channel == "r" and m.maps["clearcoat"].info == {"index": 1}
    assert not m.notes  # the strength texture is sampled (G-buffer RT6)
    off = {"KHR_materials_clearcoat": {"clearcoatRoughnessFactor": 0.2}}
    plain = core()
    assert material_extensions(off, plain, KEY) is plain


def test_iridescence_parameters():
    ext = {"KHR_materials_iridescence": {"iridescenceFactor": 1.0, "iridescenceIor": 1.8,
                                         "iridescenceThicknessMinimum": 200.0,
                                         "iridescenceThicknessMaximum": 650.0}}  # fmt: skip
    m = map_material_extensions(ext, core(), KEY)
    p = m.params
    assert p.model.thin_film
    # Without iridescenceThicknessTexture the film is the maximum thick.
    assert (p.params.film_thickness, p.params.film_ior, p.params.film_eta) == (650.0, 1.8, 1.8)
    assert m.notes == ()
    partial = {
        "KHR_materials_iridescence": {
            "iridescenceFactor": 0.5,
            "iridescenceThicknessTexture": {"index": 0},
        }
    }
    m = map_material_extensions(partial, core(), KEY)
    film = m.params.params
    # the default maximum and minimum; the strength and the thickness texture are read
    assert (film.film_thickness, film.film_thickness_min, film.film_factor) == (400.0, 100.0, 0.5)
    assert m.notes == () and m.maps["film_thickness"].channel == "g"
    plain = core()
    assert material_extensions({"KHR_materials_iridescence": {}}, plain, KEY) is plain


def test_unknown_material_extension_is_noted():
    plain = core()
    m = map_material_extensions({"KHR_materials_diffuse_transmission": {}}, plain, KEY)
    assert m.params is plain and "KHR_materials_diffuse_transmission" in m.notes[0]


# --- the project's BRDF against the specifications' formulas ---


@pytest.mark.parametrize("metallic", [0.0, 0.5, 1.0])
@pytest.mark.parametrize(
    ("ior", "weight"), [(1.5, 1.0), (1.33, 1.0), (2.42, 0.4), (1.5, 0.0), (0.0, 0.6)]
)
def test_ior_and_specular_match_the_specification(ior, weight, metallic):
    """f_spec = mix(F_dielectric, F_metal, metallic) D V, with KHR_materials_specular's
    dielectric F0 = min(F0_ior specularColor, 1) specular and F90 = specular (ior = 0:
    F = 1 for the dielectric)."""
    base = np.array([0.9, 0.6, 0.2])
    ext = {"KHR_materials_ior": {"ior": ior},
           "KHR_materials_specular": {"specularFactor": weight}}  # fmt: skip
    p = material_extensions(ext, core(base, metallic, 0.5), KEY)
    l, v = pairs()
    h = half(l, v)
    VoH = np.sum(v * h, -1)[:, None]
    f0_ior = 1.0 if ior == 0.0 else ((ior - 1) / (ior + 1)) ** 2
    f0 = np.minimum(f0_ior, 1.0) * weight
    F = (1 - metallic) * spec_schlick(f0, weight, VoH) + metallic * spec_schlick(base, 1.0, VoH)
    ref = F * spec_ggx(h[:, 2], l[:, 2], v[:, 2], 0.25)[:, None]
    np.testing.assert_allclose(twin(p, l, v, terms="specular"), ref, rtol=1e-12)


@pytest.mark.parametrize("rotation", [0.0, math.pi / 2, math.pi, 0.3, -2.0, 7.0])
@pytest.mark.parametrize(("strength", "roughness"), [(0.6, 0.5), (1.0, 0.3), (0.2, 0.8)])
def test_anisotropy_matches_the_specification(strength, roughness, rotation):
    """KHR_materials_anisotropy's D and V with alpha_t = mix(alpha, 1, strength^2) along the
    tangent rotated by anisotropyRotation (any angle), alpha_b = alpha: the project's
    anisotropy along the tangent the G-buffer pass turns by the layer's rotation
    (rotate_tangent, the twin of glsl/material/normal_mapping.glsl's)."""
    ext = {"KHR_materials_anisotropy": {"anisotropyStrength": strength,
                                        "anisotropyRotation": rotation}}  # fmt: skip
    m = map_material_extensions(ext, core(roughness=roughness), KEY)
    assert m.notes == ()
    l, v = pairs()
    h = half(l, v)
    alpha = roughness * roughness
    at = alpha + (1 - alpha) * strength * strength
    t = np.array([math.cos(rotation), math.sin(rotation), 0.0])
    b = np.cross(N, t)
    F = spec_schlick(0.04, 1.0, np.sum(v * h, -1))
    ref = (F * spec_ggx_anisotropic(t, b, h, l, v, at, alpha))[:, None]
    a = m.anisotropy_rotation
    assert -math.pi <= a <= math.pi
    turned = rotate_tangent(N, X, 1.0, np.array([math.cos(a), math.sin(a)]))
    f = twin(m.params, l, v, t=turned, terms="specular")  # the tangent the G-buffer holds
    np.testing.assert_allclose(f, np.broadcast_to(ref, f.shape), rtol=1e-12)


def test_anisotropy_texture_fills_strength_and_direction():
    """anisotropyTexture: B (the strength) multiplies the anisotropy, RG (the direction)
    becomes the direction map; the rotation is kept exactly, and only the linear use of
    the strength is reported."""
    ext = {"KHR_materials_anisotropy": {"anisotropyStrength": 0.5, "anisotropyRotation": 0.3,
                                        "anisotropyTexture": {"index": 4}}}  # fmt: skip
    m = map_material_extensions(ext, core(), KEY)
    assert m.anisotropy_rotation == 0.3
    assert m.maps["anisotropy"].channel == "b"  # the strength channel
    assert m.maps["anisotropy_direction"].channel == "rg"
    assert len(m.notes) == 1 and "linearly" in m.notes[0]


def test_sheen_matches_the_specification():
    """KHR_materials_sheen: sheenColor D_charlie V_charlie + f_base (1 - max3(sheenColor)
    max(E(n.v), E(n.l))), with the spec's Charlie NDF and Estevez & Kulla visibility; E is
    the sheen lobe's albedo, which the specification leaves to a table (the project's)."""
    color, r = np.array([0.9, 0.4, 0.1]), 0.6
    ext = {"KHR_materials_sheen": {"sheenColorFactor": color.tolist(),
                                   "sheenRoughnessFactor": r}}  # fmt: skip
    base = core((0.5, 0.3, 0.2), 0.0, 0.4)
    p = material_extensions(ext, base, KEY)
    l, v = pairs()
    h = half(l, v)
    NoH, NoL, NoV = h[:, 2], l[:, 2], v[:, 2]
    alpha_g = r * r
    D = (2 + 1 / alpha_g) * (1 - NoH * NoH) ** (0.5 / alpha_g) / (2 * math.pi)

    def l_fit(x):
        t = (1 - alpha_g) ** 2
        a, b_, c, d, e = (p1 + t * (p0 - p1) for p1, p0 in (
            (21.5473, 25.3245), (3.82987, 3.32435), (0.19823, 0.16801),
            (-1.97760, -1.27393), (-4.32054, -4.85967)))  # fmt: skip
        return a / (1 + b_ * x**c) + d * x + e

    def lambda_sheen(cos_theta):
        return np.where(
            np.abs(cos_theta) < 0.5,
            np.exp(l_fit(cos_theta)),
            np.exp(2 * l_fit(0.5) - l_fit(1 - cos_theta)),
        )

    V = 1 / ((1 + lambda_sheen(NoV) + lambda_sheen(NoL)) * (4 * NoV * NoL))
    table = load_table()
    E_v = sheen_E(table, "charlie_smith", NoV, r)
    E_l = sheen_E(table, "charlie_smith", NoL, r)
    scaling = np.minimum(1 - color.max() * E_v, 1 - color.max() * E_l)
    ref = color * (D * V)[:, None] + twin(base, l, v) * scaling[:, None]
    np.testing.assert_allclose(twin(p, l, v), ref, rtol=1e-11)


@pytest.mark.gl
def test_glsl_matches_the_specification():
    """The lighting pass's GLSL (BRDF probe) for ior + specular + anisotropy against the
    specifications' formula, at float32 precision."""
    from app.brdf import evaluate

    ext = {"KHR_materials_ior": {"ior": 1.6},
           "KHR_materials_specular": {"specularFactor": 0.7},
           "KHR_materials_anisotropy": {"anisotropyStrength": 0.6}}  # fmt: skip
    p = material_extensions(ext, core(roughness=0.5), KEY)  # black base: no diffuse
    l, v = pairs()
    h = half(l, v)
    f0 = spec_dielectric_f0(1.6, [1.0, 1.0, 1.0], 0.7)
    alpha = 0.25
    at = alpha + (1 - alpha) * 0.36
    F = spec_schlick(f0[0], 0.7, np.sum(v * h, -1))
    ref = (F * spec_ggx_anisotropic(X, np.cross(N, X), h, l, v, at, alpha))[:, None]
    ref = np.broadcast_to(ref, (len(l), 3))
    gpu = evaluate(p, l, v)
    assert relative_error(gpu, ref, 1e-6 * ref.max()).max() <= 1e-4


# --- bad values ---

BAD = [
    ({"KHR_materials_ior": {"ior": float("nan")}}, "KHR_materials_ior.ior"),
    ({"KHR_materials_ior": {"ior": -1.5}}, "KHR_materials_ior.ior"),
    ({"KHR_materials_ior": {"ior": 0.5}}, "KHR_materials_ior.ior"),
    ({"KHR_materials_ior": {"ior": "1.5"}}, "KHR_materials_ior.ior"),
    ({"KHR_materials_ior": [1.5]}, "KHR_materials_ior"),
    ({"KHR_materials_ior": {"ior": 10**400}}, "KHR_materials_ior.ior"),  # JSON allows it
    ({"KHR_materials_specular": {"specularFactor": 1.5}}, "KHR_materials_specular.specularFactor"),
    ({"KHR_materials_specular": {"specularColorFactor": [1, -0.1, 1]}},
     "KHR_materials_specular.specularColorFactor"),
    ({"KHR_materials_specular": {"specularColorFactor": [1, 1]}},
     "KHR_materials_specular.specularColorFactor"),
    ({"KHR_materials_specular": {"specularTexture": {"index": -1}}},
     "KHR_materials_specular.specularTexture"),
    ({"KHR_materials_anisotropy": {"anisotropyStrength": 2.0}},
     "KHR_materials_anisotropy.anisotropyStrength"),
    ({"KHR_materials_anisotropy": {"anisotropyStrength": 0.5, "anisotropyRotation": float("inf")}},
     "KHR_materials_anisotropy.anisotropyRotation"),
    ({"KHR_materials_sheen": {"sheenColorFactor": [2.0, 0.0, 0.0]}},
     "KHR_materials_sheen.sheenColorFactor"),
    ({"KHR_materials_sheen": {"sheenRoughnessFactor": True}},
     "KHR_materials_sheen.sheenRoughnessFactor"),
    ({"KHR_materials_clearcoat": {"clearcoatFactor": -0.1}},
     "KHR_materials_clearcoat.clearcoatFactor"),
    ({"KHR_materials_clearcoat": {"clearcoatFactor": 1, "clearcoatNormalTexture": {"scale": 1}}},
     "KHR_materials_clearcoat.clearcoatNormalTexture"),
    ({"KHR_materials_clearcoat": {"clearcoatFactor": 1,
                                  "clearcoatNormalTexture": {"index": 0, "scale": float("nan")}}},
     "KHR_materials_clearcoat.clearcoatNormalTexture.scale"),
    ({"KHR_materials_iridescence": {"iridescenceIor": 0.9}},
     "KHR_materials_iridescence.iridescenceIor"),
    ({"KHR_materials_iridescence": {"iridescenceThicknessMaximum": -1.0}},
     "KHR_materials_iridescence.iridescenceThicknessMaximum"),
    ({"KHR_materials_iridescence": {"iridescenceThicknessMaximum": 6000.0}},
     "KHR_materials_iridescence.iridescenceThicknessMaximum"),
]  # fmt: skip


@pytest.mark.parametrize(("extensions", "where"), BAD)
def test_bad_values_name_the_key(extensions, where):
    with pytest.raises(GltfError) as info:
        material_extensions(extensions, core(), KEY)
    assert info.value.key == f"{KEY}.extensions.{where}"


def test_extensions_not_an_object():
    with pytest.raises(GltfError) as info:
        material_extensions([], core(), KEY)  # type: ignore[arg-type]
    assert info.value.key == f"{KEY}.extensions"


# --- what the approximated mappings differ by (docs/gltf.md: python -m tests.test_gltf_extensions)


def spec_clearcoat(base_f, c, alpha_c, l, v):
    """KHR_materials_clearcoat's layering: mix(material, D V, c F_c(n.v)), F_c Schlick at
    F0 0.04 with n.v (the coat's normal is n here)."""
    h = half(l, v)
    Fc = spec_schlick(0.04, 1.0, v[:, 2])
    return (1 - c * Fc)[:, None] * base_f + (c * Fc * spec_ggx(h[:, 2], l[:, 2], v[:, 2], alpha_c))[
        :, None
    ]


def spec_iridescent_fresnel(film_ior, base_f0, thickness, cos1):
    """KHR_materials_iridescence's iridescent_fresnel (its README's non-normative GLSL, the
    glTF approximation of Belcour & Barla 2017), outside ior 1, for (N,) cosines."""
    xyz_to_rec709 = np.array([[3.2404542, -1.5371385, -0.4985314],
                              [-0.9692660, 1.8760108, 0.0415560],
                              [0.0556434, -0.2040259, 1.0572252]])  # fmt: skip

    def sensitivity(opd, shift):
        phase = 2 * math.pi * opd * 1e-9
        val = np.array([5.4856e-13, 4.4201e-13, 5.2481e-13])
        pos = np.array([1.6810e06, 1.7953e06, 2.2084e06])
        var = np.array([4.3278e09, 9.3046e09, 6.6121e09])
        xyz = (
            val
            * np.sqrt(2 * math.pi * var)
            * np.cos(pos * phase[:, None] + shift)
            * np.exp(-(phase[:, None] ** 2) * var)
        )
        xyz[:, 0] += (
            9.7470e-14 * math.sqrt(2 * math.pi * 4.5282e09)
            * np.cos(2.2399e06 * phase + shift[:, 0]) * np.exp(-4.5282e09 * phase**2)
        )  # fmt: skip
        return (xyz / 1.0685e-7) @ xyz_to_rec709.T

    cos1 = np.asarray(cos1, np.float64)
    R0 = ((film_ior - 1) / (film_ior + 1)) ** 2
    R12 = spec_schlick(R0, 1.0, cos1)[:, None]
    T121 = 1 - R12
    cos2 = np.sqrt(1 - (1 / film_ior) ** 2 * (1 - cos1**2))
    sqrt_f0 = math.sqrt(base_f0 + 0.0001)
    base_ior = (1 + sqrt_f0) / (1 - sqrt_f0)
    R1 = ((base_ior - film_ior) / (base_ior + film_ior)) ** 2
    R23 = spec_schlick(R1, 1.0, cos2)[:, None]
    opd = 2 * film_ior * thickness * cos2
    phi = np.full((len(cos1), 3), math.pi + (math.pi if base_ior < film_ior else 0.0))
    R123 = np.clip(R12 * R23, 1e-5, 0.9999)
    Rs = T121**2 * R23 / (1 - R123)
    intensity = R12 + Rs
    Cm = Rs - T121
    for m in (1, 2):
        Cm = Cm * np.sqrt(R123)
        intensity = intensity + Cm * 2 * sensitivity(m * opd, m * phi)
    return np.maximum(intensity, 0.0)


def print_tables() -> None:
    """The measured differences of docs/gltf.md."""
    from app.reference import thin_film
    from app.reference.material import F_selected

    l, v = pairs()
    cos_l = np.maximum(l[:, 2], 0.0)
    print("| clear coat | base | max rel. diff. of f cos | median |\n|---|---|---|---|")
    bases = {
        "grey dielectric": core((0.5, 0.5, 0.5), 0.0, 0.5),
        "gold-coloured metal": core((1.0, 0.78, 0.34), 1.0, 0.3),
    }
    for base_name, base in bases.items():
        for c, rc in ((1.0, 0.1), (0.5, 0.3)):
            ext = {"KHR_materials_clearcoat": {"clearcoatFactor": c,
                                               "clearcoatRoughnessFactor": rc}}  # fmt: skip
            ours = twin(material_extensions(ext, base, KEY), l, v) * cos_l[:, None]
            theirs = spec_clearcoat(twin(base, l, v), c, rc * rc, l, v) * cos_l[:, None]
            err = relative_error(ours, theirs, 1e-6 * theirs.max())
            print(f"| c {c}, r {rc} | {base_name} | {err.max():.2f} | {np.median(err):.3f} |")
    mu = np.linspace(0.05, 1.0, 96)
    print("\n| thickness nm | project vs glTF | project vs Airy | glTF vs Airy |")
    print("|---|---|---|---|")
    for d in (100.0, 250.0, 400.0, 700.0, 1200.0):
        ext = {"KHR_materials_iridescence": {"iridescenceFactor": 1.0,
                                             "iridescenceThicknessMaximum": d}}  # fmt: skip
        p = material_extensions(ext, core(), KEY)
        s = Surface(np.zeros(3), 0.0, 0.5, p.f0, 0.0)
        ours = F_selected(ShadingPoint(s, p.params, N, None, X, N), p.model, mu)
        exact = thin_film.F_thin_film_spectral(1.3, 1.3, d, np.full(3, 1.5), np.zeros(3), mu)
        gltf = spec_iridescent_fresnel(1.3, 0.04, d, mu)
        diffs = [np.abs(a - b).max() for a, b in ((ours, gltf), (ours, exact), (gltf, exact))]
        print(f"| {d:g} | " + " | ".join(f"{x:.4f}" for x in diffs) + " |")


if __name__ == "__main__":
    print_tables()
