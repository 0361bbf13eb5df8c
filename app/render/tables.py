"""Look-up tables the shaders read, uploaded to GL.

The Kulla-Conty multiple-scattering table (app.reference.multiscatter) becomes the RG32F
texture ``u_ms_table`` of glsl/brdf/multiscatter.glsl:

* width n_mu, height n_r; texel (x = j, y = i) holds (1 - E(mu_j, r_i), 1 - E_avg(r_i)),
  the energy lost by single scattering, with mu_j = (j/(n_mu - 1))^4 and
  r_i = 0.045 + 0.955 (i/(n_r - 1))^2 (app.reference.multiscatter.mu_grid, roughness_grid);
* NEAREST filtering and texelFetch only: the GLSL interpolates by hand in float32 exactly
  as the float64 twin does. Hardware bilinear filtering weighs texels with fixed-point
  fractions on GPUs (8 fractional bits on NVIDIA), up to 2e-3 of a cell's difference, and
  differs between drivers (llvmpipe's R32F filtering measured exact here).
"""

from __future__ import annotations

import moderngl

from app.reference.multiscatter import DEFAULT_SIZE, load_table


def ms_texture(ctx: moderngl.Context, size: int | None = DEFAULT_SIZE) -> moderngl.Texture:
    """A new RG32F texture of the size x size table (None: the default, 64 x 64; sizes not
    shipped are computed on first use and cached). The caller releases it."""
    # float32 (n_r, n_mu, 2): rows are texture rows (y = r)
    table = load_table(DEFAULT_SIZE if size is None else size)
    n_r, n_mu = table.shape[:2]
    tex = ctx.texture((n_mu, n_r), 2, table.tobytes(), dtype="f4")
    tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
    tex.repeat_x = False
    tex.repeat_y = False
    return tex
