"""Which model each term of the BRDF uses, and its parameters (glsl/brdf/model.glsl reads
the same layout).

A ``Model`` is the choice of Fresnel, NDF, Smith Lambda, G2, diffuse and multiple-scattering
terms; the renderer compiles one shader permutation per distinct ``Model`` (its
``defines()``), so a scene pays only for the models it uses. ``ModelParams`` holds the
numbers those models need beyond the G-buffer's metallic-roughness values; the lighting
pass reads them from a per-material table (``pack_model_params``).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

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
    "cloth_empirical",  # RTR4 §9.10: the empirical cloth terms (app/reference/cloth.py)
)
# --- sheen (RTR4 §9.10): the cloth layer's NDF; "none" (code 0) compiles the layer out ---
# "charlie" and "ashikhmin" take Neubelt's visibility; "charlie_smith" is Charlie's NDF with
# Estevez & Kulla 2017's fitted Smith Lambda (appended: the older codes keep their values;
# code 3 is the last the specular code's two sheen bits hold).
SHEEN_MODELS = ("none", "charlie", "ashikhmin", "charlie_smith")
# --- clear coat (RTR4 §9.12) ---
# A transparent layer over any base model: none (compiled out), Filament's / glTF
# KHR_materials_clearcoat's cheap composition, Weidlich & Wilkie 2007's refracted one.
CLEARCOAT_MODELS = ("none", "filament", "weidlich_wilkie")
# --- diffraction (RTR4 §9.11): a periodic grating's orders over the specular lobe ---
DIFFRACTION_MODELS = ("none", "grating")
# --- micro-cylinder fibres (RTR4 §9.10): a thread along the tangent replaces the base's
# specular and diffuse terms; Kajiya & Kay 1989 or Sadeghi et al. 2013 (app/reference/fiber.py)
FIBER_MODELS = ("none", "kajiya_kay", "sadeghi")

# RTR4 §9.1: which reflections brdf_eval returns, a bitmask (``render.terms``).
TERM_SPECULAR = 1  # surface reflection: f_spec (and the multiple-scattering lobe)
TERM_DIFFUSE = 2  # subsurface reflection: f_diffuse
BRDF_TERMS = {"all": TERM_SPECULAR | TERM_DIFFUSE, "specular": TERM_SPECULAR,
              "diffuse": TERM_DIFFUSE}  # fmt: skip

# The GLSL name prefix of each term's model constants: FRESNEL_SCHLICK, NDF_GGX, ...
_GLSL_PREFIXES = (
    ("FRESNEL", FRESNEL_MODELS),
    ("NDF", NDF_MODELS),
    ("LAMBDA", LAMBDA_FORMS),
    ("G2", G2_MODELS),
    ("CORRELATION", CORRELATIONS),
    ("DIFFUSE", DIFFUSE_MODELS),
    ("SHEEN", SHEEN_MODELS),  # sheen (RTR4 §9.10)
    ("CLEARCOAT", CLEARCOAT_MODELS),  # clear coat (RTR4 §9.12)
    ("DIFFRACTION", DIFFRACTION_MODELS),  # diffraction grating (RTR4 §9.11)
    ("FIBER", FIBER_MODELS),  # micro-cylinder fibres (RTR4 §9.10)
)


def glsl_constants() -> dict[str, int]:
    """The model constants of glsl/brdf/model.glsl (``FRESNEL_SCHLICK 0``, ...) and the
    ``TERM_*`` bits, generated from the names above so that they are written once."""
    out = {
        f"{prefix}_{name.upper()}": code
        for prefix, names in _GLSL_PREFIXES
        for code, name in enumerate(names)
    }
    out.update(TERM_SPECULAR=TERM_SPECULAR, TERM_DIFFUSE=TERM_DIFFUSE)
    out["MATERIAL_TEXELS"] = MATERIAL_TEXELS
    out["SURFACE_TEXEL"] = SURFACE_TEXEL
    return out


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
    # --- thin film (RTR4 §9.11): F replaced by a film's interference reflectance ---
    thin_film: bool = False
    sheen: str = "none"  # sheen (RTR4 §9.10): the cloth layer's NDF, SHEEN_MODELS
    clearcoat: str = "none"  # clear coat (RTR4 §9.12): a CLEARCOAT_MODELS name
    diffraction: str = "none"  # diffraction (RTR4 §9.11): a DIFFRACTION_MODELS name
    fiber: str = "none"  # micro-cylinder fibres (RTR4 §9.10): a FIBER_MODELS name

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
            "THIN_FILM": int(self.thin_film),  # thin film (RTR4 §9.11)
            "SHEEN_MODEL": SHEEN_MODELS.index(self.sheen),  # sheen (RTR4 §9.10)
            "CLEARCOAT_MODEL": CLEARCOAT_MODELS.index(self.clearcoat),  # RTR4 §9.12
            "DIFFRACTION_MODEL": DIFFRACTION_MODELS.index(self.diffraction),  # RTR4 §9.11
            "FIBER_MODEL": FIBER_MODELS.index(self.fiber),  # micro-cylinder fibres, RTR4 §9.10
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
        flags = ("multiscatter", "anisotropic", "internal", "thin_film")
        parts += [name for name in flags if getattr(self, name)]
        if self.sheen != "none":  # sheen (RTR4 §9.10)
            parts.append(f"{self.sheen} sheen")
        if self.clearcoat != "none":  # clear coat (RTR4 §9.12)
            parts.append(f"{self.clearcoat} clear coat")
        if self.diffraction != "none":  # diffraction (RTR4 §9.11)
            parts.append(f"{self.diffraction} diffraction")
        if self.fiber != "none":  # micro-cylinder fibres (RTR4 §9.10)
            parts.append(f"{self.fiber} fibre")
        return " + ".join(parts) or "standard"


DEFAULT_MODEL = Model()


def _rgb(x: tuple[float, float, float] = (1.0, 1.0, 1.0)) -> np.ndarray:
    return np.asarray(x, np.float64)


@dataclass(frozen=True)
class ModelParams:
    """Per-material numbers of the optional models (each broadcasts like Surface's fields).

    Indices are relative: to the medium the light arrives from (``medium_ior``), so the
    RTR4's "in water" values follow from dividing by 1.33.
    """

    f90: np.ndarray = field(default_factory=_rgb)  # generalised Schlick: F at 90 degrees
    fresnel_exponent: float = 5.0  # generalised Schlick: 1/p
    eta: np.ndarray = field(default_factory=lambda: _rgb((1.5, 1.5, 1.5)))  # conductor n / n1
    eta_dielectric: float = 1.5  # dielectric n2 / n1
    k: np.ndarray = field(default_factory=lambda: _rgb((0.0, 0.0, 0.0)))  # conductor k / n1
    gtr_gamma: float = 2.0  # GTR tail exponent (2 = GGX)
    # --- thin film (RTR4 §9.11), material-table texel 7 ---
    film_thickness: float = 0.0  # nm; 0 = the base's Fresnel alone
    film_eta: float = 1.33  # film index / medium index (n2 / n1)
    film_ior: float = 1.33  # film index n2 itself (the optical path 2 n2 d cos(theta2))
    # sheen (RTR4 §9.10), texel 6: the layer's colour (linear RGB; black = no layer) and
    # its perceptual roughness (alpha = r^2)
    sheen_color: np.ndarray = field(default_factory=lambda: _rgb((0.0, 0.0, 0.0)))
    sheen_roughness: float = 0.0
    # --- clear coat (RTR4 §9.12; material-table texels 4 and 5) ---
    clearcoat: float = 0.0  # strength 0..1 (0: no coat, and Model.clearcoat is "none")
    clearcoat_roughness: float = 0.0  # perceptual; the coat's alpha = r^2 (floored)
    clearcoat_eta: float = 1.5  # the coat's index / the medium's (medium_ior)
    # The coat's transmittance at normal incidence through its thickness, once (linear RGB):
    # Beer-Lambert, T0 = exp(-sigma_a d); along a path at angle theta_t inside, T0^(1/cos).
    clearcoat_color: np.ndarray = field(default_factory=_rgb)
    # --- diffraction grating (RTR4 §9.11), material-table texel 8 ---
    grating_period: float = 0.0  # nm, the groove spacing d
    grating_depth: float = 0.0  # nm, the sinusoidal profile's peak-to-valley depth
    # --- empirical cloth (RTR4 §9.10, diffuse = "cloth_empirical"; texels 9-11) ---
    # (k_rim, a_rim, k_inner, a_inner); the defaults, with k_diff 1, white scatter, wrap 0
    # and no sheen, make the model Lambert exactly.
    cloth_rim_inner: np.ndarray = field(default_factory=lambda: np.array([0.0, 1.0, 0.0, 1.0]))
    cloth_diffuse: float = 1.0  # k_diff
    cloth_scatter: np.ndarray = field(default_factory=_rgb)  # c_scatter (linear RGB)
    cloth_wrap: float = 0.0  # w
    cloth_sheen: np.ndarray = field(default_factory=lambda: _rgb((0.0, 0.0, 0.0)))  # k c_sheen
    # --- micro-cylinder fibres (RTR4 §9.10; material-table texel 12), angles in radians ---
    fiber_rotation: float = 0.0  # the thread's direction: the tangent turned about n
    fiber_curvature: float = 0.0  # the thread's largest tilt out of the surface along its length
    fiber_gamma_v: float = 0.3490658503988659  # Sadeghi's volume-scattering width (20 degrees)
    fiber_kd: float = 0.3  # Sadeghi's isotropic share k_d of the volume scattering


# Texels per material row. 0-3 hold the models of RTR4 §9.5-9.9 (pack_model_params); the
# layered models of §9.10-9.12 have their own: 4-5 the clear coat (§9.12), 6 the sheen
# (§9.10), 7 the thin film (§9.11), 8 a diffraction grating (§9.11), 9-11 the empirical
# cloth terms (§9.10), 12 the micro-cylinder fibre (§9.10). The GLSL reads the width from
# the generated MATERIAL_TEXELS.
MATERIAL_TEXELS = 13
# Where a table keyed by surface constants too (app/frame/materials.py, constant surfaces)
# holds them, after the model texels: (base colour RGB, metallic), (perceptual roughness,
# F0, 0, 0). The G-buffer then stores only the normal, depth and row (docs/gbuffer.md).
SURFACE_TEXEL = MATERIAL_TEXELS
SURFACE_TEXELS = 2


def model_codes(model: Model) -> tuple[int, int, int]:
    """The (Fresnel, specular, diffuse) codes of ``model`` in texel 3 of its table row, read
    by the uber lighting shader (glsl/brdf/model.glsl fetch_model_codes):

    * Fresnel: fresnel | internal << 2
    * specular: ndf | lambda_form << 2 | g2 << 3 | correlation << 6 | anisotropic << 7
      | multiscatter << 8 | sheen << 9 | clearcoat << 11 | thin_film << 13
      | diffraction << 14 | fiber << 16
    * diffuse: diffuse

    Small integers, exact in float32."""
    d = model.defines()
    fresnel = d["FRESNEL_MODEL"] | d["FRESNEL_INTERNAL"] << 2
    specular = (
        d["NDF_MODEL"]
        | d["LAMBDA_FORM"] << 2
        | d["G2_MODEL"] << 3
        | d["CORRELATION"] << 6
        | d["ANISOTROPIC"] << 7
        | d["MULTISCATTER"] << 8
        | d["THIN_FILM"] << 13  # thin film (RTR4 §9.11)
        | d["SHEEN_MODEL"] << 9  # sheen (RTR4 §9.10): bits 9-10
        | d["CLEARCOAT_MODEL"] << 11  # clear coat (RTR4 §9.12): bits 11-12
        | d["DIFFRACTION_MODEL"] << 14  # diffraction (RTR4 §9.11): bits 14-15
        | d["FIBER_MODEL"] << 16  # micro-cylinder fibres (RTR4 §9.10): bits 16-17
    )
    return fresnel, specular, d["DIFFUSE_MODEL"]


def model_from_codes(fresnel: int, specular: int, diffuse: int) -> Model:
    """Inverse of ``model_codes``."""
    return Model(
        fresnel=FRESNEL_MODELS[fresnel & 3],
        ndf=NDF_MODELS[specular & 3],
        lambda_form=LAMBDA_FORMS[(specular >> 2) & 1],
        g2=G2_MODELS[(specular >> 3) & 7],
        correlation=CORRELATIONS[(specular >> 6) & 1],
        diffuse=DIFFUSE_MODELS[diffuse],
        multiscatter=bool((specular >> 8) & 1),
        anisotropic=bool((specular >> 7) & 1),
        internal=bool((fresnel >> 2) & 1),
        thin_film=bool((specular >> 13) & 1),  # thin film (RTR4 §9.11)
        sheen=SHEEN_MODELS[(specular >> 9) & 3],  # sheen (RTR4 §9.10)
        clearcoat=CLEARCOAT_MODELS[(specular >> 11) & 3],  # clear coat (RTR4 §9.12)
        diffraction=DIFFRACTION_MODELS[(specular >> 14) & 3],  # diffraction (RTR4 §9.11)
        fiber=FIBER_MODELS[(specular >> 16) & 3],  # micro-cylinder fibres (RTR4 §9.10)
    )


def pack_model_params(
    params: list[ModelParams], groups: list[int], models: list[Model] | None = None
) -> np.ndarray:
    """The lighting pass's material table: (M, MATERIAL_TEXELS, 4) float32, one row of RGBA
    texels per material id: (f90, 1/p), (eta, eta_dielectric), (k, gtr_gamma), (model
    group, Fresnel code, specular code, diffuse code), then the texels of the layered
    models (``MATERIAL_TEXELS``): 4-5 the clear coat's (color, strength), (roughness, eta,
    0, 0), its defaults where a material has none; the others zero. ``models`` gives
    each row's model for the codes (``model_codes``; only the uber lighting shader reads
    them); without it every row gets the standard model's codes."""
    table = np.zeros((max(len(params), 1), MATERIAL_TEXELS, 4), np.float32)
    models = models if models is not None else [DEFAULT_MODEL] * len(params)
    # Slices take a number or an RGB triple as they are (np.broadcast_to per texel cost a
    # viewer slider step more than the rest of the table).
    for row, (p, group, model) in enumerate(zip(params, groups, models, strict=True)):
        table[row, 0, :3] = p.f90
        table[row, 0, 3] = p.fresnel_exponent
        table[row, 1, :3] = p.eta
        table[row, 1, 3] = p.eta_dielectric
        table[row, 2, :3] = p.k
        table[row, 2, 3] = p.gtr_gamma
        table[row, 3] = [group, *model_codes(model)]
        if model.thin_film:  # thin film (RTR4 §9.11): (thickness nm, n2/n1, n2, 0)
            table[row, 7] = [p.film_thickness, p.film_eta, p.film_ior, 0.0]
        table[row, 6, :3] = p.sheen_color  # sheen
        table[row, 6, 3] = p.sheen_roughness
        if model.diffraction != "none":  # diffraction (RTR4 §9.11): (period, depth, 0, 0)
            table[row, 8] = [p.grating_period, p.grating_depth, 0.0, 0.0]
        # Clear coat (RTR4 §9.12), texels 4-5: (color, strength), (roughness, eta, 0, 0).
        # Without a coat they hold the defaults (strength 0, eta 1.5, white), so the coat's
        # formulas stay finite (and equal the base) even where a pass forces them on.
        table[row, 4, :3] = p.clearcoat_color
        table[row, 4, 3] = p.clearcoat
        table[row, 5] = [p.clearcoat_roughness, p.clearcoat_eta, 0.0, 0.0]
        # Empirical cloth (RTR4 §9.10), texels 9-11: (k_rim, a_rim, k_inner, a_inner),
        # (c_scatter, w), (k_sheen c_sheen, k_diff). Every row holds them (the defaults,
        # Lambert, where a material has none), like the clear coat's, so a table packed
        # without its models (the tests' kernels) still shades a cloth row as the twin.
        table[row, 9] = p.cloth_rim_inner  # numpy broadcasts one number to 4
        table[row, 10, :3] = p.cloth_scatter
        table[row, 10, 3] = p.cloth_wrap
        table[row, 11, :3] = p.cloth_sheen
        table[row, 11, 3] = p.cloth_diffuse
        # Micro-cylinder fibre (RTR4 §9.10), texel 12: (rotation, curvature, gamma_v, k_d),
        # on every row (the defaults where a material has none), as the cloth's.
        table[row, 12] = [p.fiber_rotation, p.fiber_curvature, p.fiber_gamma_v, p.fiber_kd]
    return table


def unpack_model_params(texels: np.ndarray) -> ModelParams:
    """Inverse of one row of ``pack_model_params`` (float32 values widened to float64)."""
    t = np.asarray(texels, np.float64)
    p = ModelParams(
        t[0, :3], float(t[0, 3]), t[1, :3], float(t[1, 3]), t[2, :3], float(t[2, 3]),
        # Thin film (RTR4 §9.11), texel 7.
        film_thickness=float(t[7, 0]), film_eta=float(t[7, 1]), film_ior=float(t[7, 2]),
        sheen_color=t[6, :3], sheen_roughness=float(t[6, 3]),  # sheen (RTR4 §9.10)
        grating_period=float(t[8, 0]), grating_depth=float(t[8, 1]),  # grating (§9.11)
    )  # fmt: skip
    if t[5, 1] > 0.0:  # clear coat (RTR4 §9.12): texels 4-5 (a table from before: zero)
        p = replace(
            p,
            clearcoat=float(t[4, 3]),
            clearcoat_roughness=float(t[5, 0]),
            clearcoat_eta=float(t[5, 1]),
            clearcoat_color=t[4, :3],
        )
    if t[9, 1] > 0.0:  # empirical cloth (RTR4 §9.10): a_rim > 0 (a table from before: zero)
        p = replace(
            p,
            cloth_rim_inner=t[9].copy(),
            cloth_scatter=t[10, :3],
            cloth_wrap=float(t[10, 3]),
            cloth_sheen=t[11, :3],
            cloth_diffuse=float(t[11, 3]),
        )
    if t.shape[0] > 12 and t[12, 2] > 0.0:  # fibre (RTR4 §9.10): gamma_v > 0 (before: 0)
        p = replace(
            p,
            fiber_rotation=float(t[12, 0]),
            fiber_curvature=float(t[12, 1]),
            fiber_gamma_v=float(t[12, 2]),
            fiber_kd=float(t[12, 3]),
        )
    return p


def unpack_model(texels: np.ndarray) -> tuple[int, Model]:
    """The model group and the model of one row of ``pack_model_params`` (texel 3)."""
    group, fresnel, specular, diffuse = (int(x) for x in np.asarray(texels)[3])
    return group, model_from_codes(fresnel, specular, diffuse)


@dataclass(frozen=True)
class MaterialParams:
    """A material after presets and defaults: what the G-buffer and the material table store."""

    base_color: tuple[float, float, float]
    metallic: float
    roughness: float
    f0: float  # normal-incidence reflectance of the dielectric part
    anisotropy: float = 0.0
    model: Model = DEFAULT_MODEL
    params: ModelParams = field(default_factory=ModelParams)
