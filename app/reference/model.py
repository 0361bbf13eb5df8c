"""Twin of glsl/brdf/model.glsl: which model each term of the BRDF uses, and its parameters.

A ``Model`` is the choice of Fresnel, NDF, Smith Lambda, G2, diffuse and multiple-scattering
terms; the renderer compiles one shader permutation per distinct ``Model`` (its
``defines()``), so a scene pays only for the models it uses. ``ModelParams`` holds the
numbers those models need beyond the G-buffer's metallic-roughness values; the lighting
pass reads them from a per-material table (``pack_model_params``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

# The names a scene file uses, in the order of the GLSL constants (index = value).
FRESNEL_MODELS = ("schlick", "schlick_generalized", "dielectric", "conductor")
NDF_MODELS = ("ggx", "beckmann", "blinn_phong", "gtr")
LAMBDA_FORMS = ("exact", "rational")
G2_MODELS = (
    "separable",
    "height_correlated",
    "direction_correlated",
    "height_direction_correlated",
    "hammon",
)
CORRELATIONS = ("exp", "rational")
DIFFUSE_MODELS = (
    "lambert",
    "shirley",
    "ashikhmin_shirley",
    "burley",
    "oren_nayar",
    "hammon",
    "none",
    "burley_renormalized",
)


@dataclass(frozen=True)
class Model:
    """One choice per BRDF term; the defaults are the renderer's standard model
    (Schlick F, GGX D, height-correlated Smith G2, Lambert diffuse)."""

    fresnel: str = "schlick"
    ndf: str = "ggx"
    lambda_form: str = "exact"
    g2: str = "height_correlated"
    correlation: str = "exp"
    diffuse: str = "lambert"
    multiscatter: bool = False
    anisotropic: bool = False
    internal: bool = False  # Schlick evaluated at the transmitted angle (n1 > n2)

    def defines(self) -> dict[str, int]:
        """The preprocessor defines that select this model in glsl/brdf/model.glsl."""
        return {
            "FRESNEL_MODEL": FRESNEL_MODELS.index(self.fresnel),
            "NDF_MODEL": NDF_MODELS.index(self.ndf),
            "LAMBDA_FORM": LAMBDA_FORMS.index(self.lambda_form),
            "G2_MODEL": G2_MODELS.index(self.g2),
            "CORRELATION": CORRELATIONS.index(self.correlation),
            "DIFFUSE_MODEL": DIFFUSE_MODELS.index(self.diffuse),
            "MULTISCATTER": int(self.multiscatter),
            "ANISOTROPIC": int(self.anisotropic),
            "FRESNEL_INTERNAL": int(self.internal),
        }

    def describe(self) -> str:
        """A short label naming every non-default choice, e.g. 'beckmann + separable'."""
        parts = [
            getattr(self, name)
            for name in ("fresnel", "ndf", "g2", "diffuse")
            if getattr(self, name) != getattr(DEFAULT_MODEL, name)
        ]
        if self.lambda_form != "exact":
            parts.append(f"{self.lambda_form} Lambda")
        if self.g2 in ("direction_correlated", "height_direction_correlated"):
            parts.append(f"{self.correlation} lambda(phi)")
        flags = ("multiscatter", "anisotropic", "internal")
        parts += [name for name in flags if getattr(self, name)]
        return " + ".join(parts) or "standard"


DEFAULT_MODEL = Model()


def _rgb(x: tuple[float, float, float] = (1.0, 1.0, 1.0)) -> np.ndarray:
    return np.asarray(x, np.float64)


@dataclass(frozen=True)
class ModelParams:
    """Per-material numbers of the optional models (each broadcasts like Surface's fields).

    Indices are relative: to the medium the light arrives from (``medium_ior``), so the
    seed's "in water" values follow from dividing by 1.33.
    """

    f90: np.ndarray = field(default_factory=_rgb)  # generalised Schlick: F at 90 degrees
    fresnel_exponent: float = 5.0  # generalised Schlick: 1/p
    eta: np.ndarray = field(default_factory=lambda: _rgb((1.5, 1.5, 1.5)))  # conductor n / n1
    eta_dielectric: float = 1.5  # dielectric n2 / n1
    k: np.ndarray = field(default_factory=lambda: _rgb((0.0, 0.0, 0.0)))  # conductor k / n1
    gtr_gamma: float = 2.0  # GTR tail exponent (2 = GGX)


def pack_model_params(params: list[ModelParams], groups: list[int]) -> np.ndarray:
    """The lighting pass's material table: (M, 4, 4) float32, one row of 4 RGBA texels per
    material id: (f90, 1/p), (eta, eta_dielectric), (k, gtr_gamma), (model group, 0, 0, 0)."""
    table = np.zeros((max(len(params), 1), 4, 4), np.float32)
    for row, (p, group) in enumerate(zip(params, groups, strict=True)):
        table[row, 0] = [*np.broadcast_to(p.f90, 3), p.fresnel_exponent]
        table[row, 1] = [*np.broadcast_to(p.eta, 3), p.eta_dielectric]
        table[row, 2] = [*np.broadcast_to(p.k, 3), p.gtr_gamma]
        table[row, 3, 0] = group
    return table


def unpack_model_params(texels: np.ndarray) -> ModelParams:
    """Inverse of one row of ``pack_model_params`` (float32 values widened to float64)."""
    t = np.asarray(texels, np.float64)
    return ModelParams(t[0, :3], float(t[0, 3]), t[1, :3], float(t[1, 3]), t[2, :3], float(t[2, 3]))
