"""Look-up tables the shaders read, uploaded to GL.

The Kulla-Conty multiple-scattering tables (app/common/tables.py; computed by the twin
app/reference/multiscatter.py), one per G2 form, become the RG32F
texture ``u_ms_table`` of glsl/brdf/multiscatter.glsl:

* width n_mu, height len(MS_FORMS) n_r: the forms' tables stacked along y in MS_FORMS
  order (the height-correlated one first); in block b, texel (x = j, y = b n_r + i) holds
  (1 - E(mu_j, r_i), 1 - E_avg(r_i)), the energy lost by single scattering, with
  mu_j = (j/(n_mu - 1))^4 and
  r_i = 0.045 + 0.955 (i/(n_r - 1))^2 (app.reference.multiscatter.mu_grid, roughness_grid);
* NEAREST filtering and texelFetch only: the GLSL interpolates by hand in float32 exactly
  as the float64 twin does. Hardware bilinear filtering weighs texels with fixed-point
  fractions on GPUs (8 fractional bits on NVIDIA), up to 2e-3 of a cell's difference, and
  differs between drivers (llvmpipe's R32F filtering measured exact here).
"""

from __future__ import annotations

import moderngl
import numpy as np

from app.common.tables import MS_FORMS, read_ms_tables, read_sheen_table
from app.frame.materials import MaterialTable


def ms_texture(ctx: moderngl.Context, tables: np.ndarray | None = None) -> moderngl.Texture:
    """A new RG32F texture of the float32 (len(MS_FORMS), n_r, n_mu, 2) stack of every G2
    form's table (app.reference.multiscatter.load_tables; None: the shipped default,
    64 x 64). The caller releases it."""
    tables = read_ms_tables() if tables is None else np.ascontiguousarray(tables, np.float32)
    if tables.ndim != 4 or tables.shape[0] != len(MS_FORMS):
        raise ValueError(f"expected one table per G2 form {MS_FORMS}, got {tables.shape}")
    forms, n_r, n_mu = tables.shape[:3]  # rows are texture rows (y = form block, r)
    tex = ctx.texture((n_mu, forms * n_r), 2, tables.tobytes(), dtype="f4")
    tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
    tex.repeat_x = False
    tex.repeat_y = False
    return tex


def material_texture(ctx: moderngl.Context, table: MaterialTable) -> moderngl.Texture:
    """A new RGBA32F texture of the material table (app/frame/materials.py): one material
    per row, MATERIAL_TEXELS wide, NEAREST (read by fetch_model_params, which is generated
    from app/common/material_fields.py). The caller releases it."""
    packed = table.packed()
    tex = ctx.texture((packed.shape[1], packed.shape[0]), 4, packed.tobytes(), dtype="f4")
    tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
    return tex


def sheen_texture(ctx: moderngl.Context) -> moderngl.Texture:
    """A new RGB32F texture of the shipped sheen albedo table (RTR4 §9.10; app/common/
    tables.py, computed by app/reference/sheen.py): width n_mu, height n_r, texel (j, i) =
    (E_charlie, E_ashikhmin, E_charlie_smith) on the multiple-scattering table's grids,
    NEAREST (read by hand in glsl/brdf/sheen.glsl sheen_E). The caller releases it."""
    table = read_sheen_table()
    n_r, n_mu, channels = table.shape
    tex = ctx.texture((n_mu, n_r), channels, np.ascontiguousarray(table).tobytes(), dtype="f4")
    tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
    tex.repeat_x = False
    tex.repeat_y = False
    return tex
