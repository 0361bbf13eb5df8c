"""The semantic checks on a resolved material, shared by its three front-ends.

A material reaches the renderer from a scene file's ``[materials.x]`` table (the schema's
``Material``, app/scene/model.py), from a glTF file with its KHR_materials_* extensions
(app/scene/gltf.py, app/scene/gltf_extensions.py) or from an OBJ's MTL file
(app/scene/geometry.py). Each front-end checks its own keys as written (ranges, which
keys go together, spellings: those stay with it), builds a ``MaterialParams`` and the set
of maps it samples, and then hands both to ``material_problems``: the checks here are
about whether that result is consistent, whatever file it came from: the BRDF terms that
combine (RTR4 §9.5–9.12), a map whose factor is missing, a coat that cannot lie on its
base, an emission the HDR image cannot hold.

They are not range checks: a glTF ``ior`` of 0 (eta 1e6) or a normal map scale past the
scene file's bound is consistent and passes. Each problem names the scene file's key it
is about (docs/scene-format.md); each front-end turns it into its own one-line error
naming its file and its own key (a TOML key, a glTF JSON path, an MTL statement).
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass

from app.common.models import MaterialParams

# Radiometric values (light colours and intensities, background, environment radiance,
# emission) stop at 1e15 so that the HDR image stays finite in float32 (max 3.4e38): near
# a light the 1 cm distance floor and the largest f (n.l) multiply c_light by up to
# ~2.4e14, and a frame sums at most a few thousand lights. Values above ~3.4e38
# overflowed to +Inf in the HDR image (found by tests/test_fuzz_scenes.py;
# docs/stability.md, "The renderer").
MAX_RADIANCE = 1e15

# The scene file's key of each map a SurfaceLayer samples that a check here is about
# (app/textures/maps.py names the maps by role; the problems name scene-file keys).
MAP_KEYS = {
    "anisotropy": "anisotropy_map",
    "anisotropy_direction": "anisotropy_direction_map",
    "coat_normal": "clearcoat_normal_map",
    "emissive": "emissive_map",
}

# A fibre replaces the specular and diffuse terms: every term keeps its standard model.
_FIBER_STANDARD = {
    "fresnel": "schlick", "ndf": "ggx", "lambda_form": "exact", "g2": "height_correlated",
    "correlation": "exp", "diffuse": "lambert", "multiscatter": False, "thin_film": False,
    "diffraction": "none",
}  # fmt: skip


@dataclass(frozen=True)
class MaterialProblem:
    """One inconsistency of a resolved material: the scene file's ``key`` it is about
    and the ``message`` (without the key)."""

    key: str
    message: str


def material_problems(
    params: MaterialParams,
    maps: Collection[str],
    emissive: Sequence[float] = (0.0, 0.0, 0.0),
    emissive_strength: float = 1.0,
) -> list[MaterialProblem]:
    """Every inconsistency of the material ``params`` sampling the SurfaceLayer maps
    ``maps`` (their names: ``MAP_KEYS``) and emitting ``emissive`` x
    ``emissive_strength`` (the factor and its strength apart: a map multiplies the factor,
    whatever the strength), in the order a scene file's keys are checked; empty where
    the material is consistent."""
    problems: list[MaterialProblem] = []

    def problem(key: str, message: str) -> None:
        problems.append(MaterialProblem(key, message))

    model, extra = params.model, params.params
    anisotropic = params.anisotropy != 0.0
    if "anisotropy" in maps and not anisotropic:
        problem("anisotropy_map", "multiplies 'anisotropy', which must be non-zero")
    if "anisotropy_direction" in maps and not anisotropic:
        problem("anisotropy_direction_map", "turns the anisotropy, which must be non-zero")
    if model.lambda_form == "rational" and model.ndf != "beckmann":
        problem("lambda_form", "'rational' is Beckmann's approximation (ndf = 'beckmann')")
    if model.g2 == "hammon" and (model.ndf != "ggx" or anisotropic):
        problem("g2", "'hammon' approximates the isotropic GGX G2 (ndf = 'ggx')")
    if anisotropic and model.ndf not in ("ggx", "beckmann"):
        problem("anisotropy", "only the 'ggx' and 'beckmann' NDFs are anisotropic")
    if model.multiscatter and (model.ndf != "ggx" or anisotropic):
        # one table per G2 form of the isotropic GGX (app/common/tables.py MS_FORMS)
        problem("multiscatter", "the compensation tables are for the isotropic GGX (ndf = 'ggx')")
    if model.diffraction != "none" and (
        model.ndf != "ggx" or model.g2 != "height_correlated" or anisotropic
    ):
        problem(
            "diffraction",
            "the grating's orders move the isotropic GGX lobe with the height-correlated G2 "
            "(ndf = 'ggx', g2 = 'height_correlated', no anisotropy)",
        )
    _clearcoat(params, maps, problem)
    if model.diffuse == "cloth_empirical" and extra.cloth_wrap > 0.0:
        # the light wrapped past the terminator (RTR4 §9.10) is the lobes' alone, unweighted
        layers = (["a clear coat"] if extra.clearcoat != 0.0 else []) + (
            ["a sheen layer"] if model.sheen != "none" else []
        )
        if layers:
            problem(
                "cloth_wrap",
                f"the light wrapped past the terminator does not pass through {layers[0]}: "
                "use cloth_sheen for the empirical sheen, or no wrap",
            )
    if "emissive" in maps and not any(emissive):
        problem("emissive_map", "multiplies 'emissive', which must be non-zero")
    if max(emissive, default=0.0) * emissive_strength > MAX_RADIANCE:
        problem(
            "emissive_strength",
            f"emissive x emissive_strength must not exceed {MAX_RADIANCE:g}",
        )
    if model.fiber != "none":
        given = [key for key, value in _FIBER_STANDARD.items() if getattr(model, key) != value]
        given += ["clearcoat"] if extra.clearcoat != 0.0 else []
        given += ["anisotropy"] if anisotropic else []
        given += ["anisotropy_map"] if "anisotropy" in maps else []
        given += ["sheen_color"] if model.sheen != "none" else []
        for key in given:
            problem(
                key,
                f"does not apply with fiber = '{model.fiber}' (the fibre replaces the "
                "specular and diffuse terms; no other layer composes over it)",
            )
        if params.metallic > 0.0:
            problem("metallic", f"a fibre (fiber = '{model.fiber}') is a dielectric")
    return problems


def _clearcoat(
    params: MaterialParams, maps: Collection[str], problem: Callable[[str, str], None]
) -> None:
    """A coat's normal map needs a coat, and a coat needs a base it can lie on (RTR4
    §9.12): an index at least the medium's, over a base that is not below it."""
    extra = params.params
    if extra.clearcoat == 0.0:
        if "coat_normal" in maps:
            problem("clearcoat_normal_map", "applies only with clearcoat > 0")
        return
    if extra.clearcoat_eta < 1.0:
        problem(
            "clearcoat_ior",
            "must be at least the medium's index (light would be totally reflected going "
            "into the coat)",
        )
    if params.model.internal:
        problem(
            "clearcoat",
            "a coat over a base whose index is below the medium's is not supported",
        )
