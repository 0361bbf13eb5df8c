"""The BRDF probe: f(l, v) of a material for arrays of direction pairs, from the real GLSL
or from its float64 twin.

``evaluate(material, l, v)`` answers with the very code the lighting pass runs: the same
GLSL files (glsl/brdf/*.glsl), assembled with the same model defines and fed the same
material table, executed on a full-screen pass into a 32-bit float texture. With
``backend="reference"`` it runs app/reference instead, so the two can be compared on any
directions one likes (tests/test_brdf_models.py, docs/brdf-models.md).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from app.common.models import (
    MaterialParams,
    ModelParams,
    pack_model_params,
    unpack_model_params,
)
from app.errors import InputError
from app.gl.context import GLContext, create_context, osmesa_changes
from app.gl.kernel import run_kernel
from app.reference.material import ShadingPoint, Surface, brdf_eval
from app.scene.model import Material

Backend = Literal["glsl", "reference"]

# The passes' own include: the model selection, every term and brdf_eval.
INCLUDES = ("brdf/brdf.glsl",)

_BODY = """
Surface s = Surface(surface_a.rgb, surface_a.a, surface_b.x, surface_b.y, surface_b.z);
ModelParams p = fetch_model_params(u_materials, 0);
ShadingPoint sp = ShadingPoint(s, p, dir_n.xyz, dir_nc.xyz, dir_t.xyz, dir_v.xyz, vec3(0.0));
result = vec4(brdf_eval(sp, dir_l.xyz), 0.0);
"""

_context: GLContext | None = None
_context_osmesa = 0  # osmesa_changes() when _context was made


def _default_context() -> GLContext:
    """One headless context per process, created on first use (EGL, else OSMesa), and
    made again after an OSMesa context came or went (app/gl/context.py says why)."""
    global _context, _context_osmesa
    if _context is not None and _context_osmesa != osmesa_changes():
        _context.release()
        _context = None
    if _context is None:
        _context = create_context("auto")
        _context_osmesa = osmesa_changes()
    return _context


def resolve_material(material: Mapping[str, Any] | Material | MaterialParams) -> MaterialParams:
    """A scene-file material table (or its validated forms) as resolved parameters."""
    if isinstance(material, MaterialParams):
        return material
    if isinstance(material, Material):
        return material.resolve()
    try:
        return Material.model_validate(dict(material)).resolve()
    except ValueError as exc:  # pydantic's ValidationError is a ValueError
        raise InputError("<material>", "", str(exc).splitlines()[-2].strip()) from None


def _frame(count: int, n: ArrayLike | None, t: ArrayLike | None) -> tuple[np.ndarray, np.ndarray]:
    """Normal and tangent per pair: +Z and +X by default; a given tangent is used as is
    (brdf_eval orthonormalises it against n), else +X for every normal."""
    n_arr = np.broadcast_to(np.asarray([0.0, 0.0, 1.0] if n is None else n, np.float64), (count, 3))
    t_arr = np.broadcast_to(np.asarray([1.0, 0.0, 0.0] if t is None else t, np.float64), (count, 3))
    return n_arr, t_arr


def surface_texels(params: MaterialParams) -> tuple[np.ndarray, np.ndarray]:
    """The material's Surface values as the two float32 vec4 inputs ``_BODY`` reads:
    (base_color, metallic) and (roughness, f0, anisotropy, 0)."""
    f32 = np.float32
    return (
        np.array([*params.base_color, params.metallic], f32),
        np.array([params.roughness, params.f0, params.anisotropy, 0.0], f32),
    )


def reference_inputs(params: MaterialParams) -> tuple[Surface, ModelParams]:
    """The material as the float64 twins take it, from the very float32 values the GLSL
    receives (``surface_texels`` and the packed material table)."""
    a, b = surface_texels(params)
    s = Surface(a[:3].astype(np.float64), float(a[3]), float(b[0]), float(b[1]), float(b[2]))
    return s, unpack_model_params(pack_model_params([params.params], [0], [params.model])[0])


def run_material_kernel(
    ctx: Any,
    params: MaterialParams,
    body: str,
    inputs: dict[str, np.ndarray],
    extra_includes: tuple[str, ...] = (),
) -> np.ndarray:
    """``run_kernel`` with everything a material's BRDF needs: the BRDF includes, the
    model's defines, its one-row material table bound to ``u_materials`` and, with
    multiple scattering, the table bound to ``u_ms_table``, with sheen its albedo table
    bound to ``u_sheen_table``. Returns (N, 4) float64."""
    table = pack_model_params([params.params], [0], [params.model])
    textures: list[Any] = []

    def bind(program: Any, unit: int) -> None:
        tex = ctx.texture((table.shape[1], 1), 4, table.tobytes(), dtype="f4")
        textures.append(tex)
        tex.use(unit)
        if "u_materials" in program:  # the standard model reads no table entries
            program["u_materials"].value = unit
        if params.model.multiscatter:
            from app.render.tables import ms_texture

            ms = ms_texture(ctx)
            textures.append(ms)
            ms.use(unit + 1)
            program["u_ms_table"].value = unit + 1
        if params.model.sheen != "none":  # sheen (RTR4 §9.10): its albedo table
            from app.render.tables import sheen_texture

            sh = sheen_texture(ctx)
            textures.append(sh)
            sh.use(unit + 2)
            program["u_sheen_table"].value = unit + 2

    try:
        return run_kernel(
            ctx,
            (*INCLUDES, *extra_includes),
            body,
            inputs,
            defines=params.model.defines(),
            bind=bind,
            declarations="uniform sampler2D u_materials;",
        )
    finally:
        for tex in textures:
            tex.release()


def evaluate(
    material: Mapping[str, Any] | Material | MaterialParams,
    l: ArrayLike,
    v: ArrayLike,
    n: ArrayLike | None = None,
    backend: Backend = "glsl",
    *,
    t: ArrayLike | None = None,
    nc: ArrayLike | None = None,
    gl: GLContext | None = None,
) -> np.ndarray:
    """f(l, v) for N pairs of unit directions, as an (N, 3) float64 array.

    ``material`` is what a scene file's [materials.NAME] table holds (a dict), or a
    validated ``Material``/``MaterialParams``. ``n`` defaults to +Z with the tangent ``t``
    along +X; ``nc``, a clear coat's own unit normal (RTR4 §9.12), defaults to ``n``. The
    material's numbers are rounded to float32 for both backends (the GPU's precision), so
    the backends differ only by the arithmetic.
    """
    params = resolve_material(material)
    l_arr = np.atleast_2d(np.asarray(l, np.float64))
    v_arr = np.atleast_2d(np.asarray(v, np.float64))
    count = max(len(l_arr), len(v_arr))
    l_arr = np.broadcast_to(l_arr, (count, 3))
    v_arr = np.broadcast_to(v_arr, (count, 3))
    n_arr, t_arr = _frame(count, n, t)
    nc_arr = n_arr if nc is None else np.broadcast_to(np.asarray(nc, np.float64), (count, 3))
    surface_a, surface_b = surface_texels(params)

    if backend == "reference":
        s, p = reference_inputs(params)
        return brdf_eval(ShadingPoint(s, p, n_arr, nc_arr, t_arr, v_arr), params.model, l_arr)
    if backend != "glsl":
        raise ValueError(f"backend must be 'glsl' or 'reference', not {backend!r}")

    context = gl or _default_context()
    inputs = {
        "surface_a": np.broadcast_to(surface_a, (count, 4)),
        "surface_b": np.broadcast_to(surface_b, (count, 4)),
        "dir_n": n_arr,
        "dir_nc": nc_arr,
        "dir_t": t_arr,
        "dir_l": l_arr,
        "dir_v": v_arr,
    }
    out = run_material_kernel(context.ctx, params, _BODY, inputs)
    return out[:, :3]
