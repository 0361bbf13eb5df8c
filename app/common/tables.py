"""The shipped look-up tables (``data/``), read by the renderer and by the float64 twins.

The Kulla-Conty multiple-scattering table (RTR4 §9.8.2) is computed by the twin
(app/reference/multiscatter.py) and stored here as float32 (n_r, n_mu, 2) of
(1 - E(mu, r), 1 - E_avg(r)). The renderer only reads it; sizes that are not shipped are
computed by the twin on demand and cached outside the package.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from app.common.models import CORRELATIONS, G2_MODELS

# The renderer's table: 64 x 64 costs the lighting pass what 32 x 32 costs and is more
# accurate at worst (measured in docs/performance.md, ms_table).
DEFAULT_SIZE = 64
# Shipped: the default, the bench's other size and its reference (128 x 128 takes minutes
# to compute); other sizes are computed on first use and cached.
SHIPPED_SIZES = (32, 64, 128)
# The other G2 forms' tables (MS_FORMS) are shipped at these sizes only (each 64 x 64 one
# takes minutes to compute; 128 x 128 would take most of an hour for the five).
SHIPPED_FORM_SIZES = (32, 64)
DATA_DIR = Path(__file__).resolve().parent / "data"
CACHE_VERSION = 1  # bump when the grids, the quadrature or the layout change

# The joint masking-shadowing forms (RTR4 §9.7) that have a table of their own: E(mu, r)
# is the albedo of the single-scattering GGX specular WITH that G2, so its compensation is
# what that G2 loses. The direction-correlated forms depend on lambda(phi), one table per
# correlation (in app.common.models.CORRELATIONS order, consecutive). Hammon's fit of the
# height-correlated G2 has its own: with the height-correlated table its white furnace
# read 0.89 at roughness 0.6, n.l = 0.1 (the fit's V is not the exact one there). The
# texture stacks them along y in this order (app/render/tables.py), the GLSL finds a
# material's block with ``ms_form`` (glsl/brdf/multiscatter.glsl) from the generated
# MS_FORM_* constants.
MS_FORMS = (
    "height_correlated",
    "separable",
    "direction_correlated_exp",
    "direction_correlated_rational",
    "height_direction_correlated_exp",
    "height_direction_correlated_rational",
    "hammon",
)
# The G2 forms whose table depends on the correlation lambda(phi): block MS_FORM_<G2> +
# the CORRELATION code, so the correlations' tables follow in CORRELATIONS order.
_CORRELATED_G2 = ("direction_correlated", "height_direction_correlated")
assert all(
    MS_FORMS.index(f"{g2}_{c}") == MS_FORMS.index(f"{g2}_exp") + code
    for g2 in _CORRELATED_G2
    for code, c in enumerate(CORRELATIONS)
)


def ms_form(g2: str, correlation: str = "exp") -> str:
    """The name of the table (MS_FORMS) of a GGX material with this G2 and correlation."""
    return f"{g2}_{correlation}" if g2 in _CORRELATED_G2 else g2


def glsl_constants() -> dict[str, int]:
    """MS_FORMS (the number of stacked tables) and MS_FORM_<G2>, the block of each G2 (of
    its "exp" table where it depends on the correlation; the "rational" one follows)."""
    out = {"MS_FORMS": len(MS_FORMS)}
    out.update({f"MS_FORM_{g2.upper()}": MS_FORMS.index(ms_form(g2, "exp")) for g2 in G2_MODELS})
    return out


def cache_dir() -> Path:
    """$XDG_CACHE_HOME/pbs-lab (default ~/.cache/pbs-lab), where other sizes are kept."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "pbs-lab"


def table_path(size: int, form: str = "height_correlated") -> Path:
    """Where the size x size table of G2 ``form`` (MS_FORMS) lives: shipped in
    app/common/data, else the cache. The height-correlated one keeps its old name."""
    if form not in MS_FORMS:
        raise ValueError(f"no multiple-scattering table for the G2 form {form!r}")
    tail = "" if form == "height_correlated" else f"_{form}"
    if size in (SHIPPED_SIZES if form == "height_correlated" else SHIPPED_FORM_SIZES):
        return DATA_DIR / f"ms_table_{size}{tail}.npy"
    return cache_dir() / f"ms_table_{size}{tail}_v{CACHE_VERSION}.npy"


def read_ms_table(size: int = DEFAULT_SIZE, form: str = "height_correlated") -> np.ndarray:
    """The stored float32 (size, size, 2) table of G2 ``form``, read-only;
    FileNotFoundError where it was never computed (app.reference.multiscatter.load_table
    computes and stores it)."""
    return _read_square(table_path(size, form), size)


def read_ms_tables(size: int = DEFAULT_SIZE) -> np.ndarray:
    """Every form's table, float32 (len(MS_FORMS), size, size, 2) in MS_FORMS order:
    what the renderer's texture stacks."""
    return np.stack([read_ms_table(size, form) for form in MS_FORMS])


def _read_square(path: Path, size: int, channels: int = 2) -> np.ndarray:
    """A stored float32 (size, size, channels) table, read-only; ValueError for another
    shape."""
    table = np.load(path)
    shape = (size, size, channels)
    if table.shape != shape or table.dtype != np.float32:
        raise ValueError(f"{path}: expected float32 {shape}, got {table.dtype} {table.shape}")
    table.setflags(write=False)
    return table


# --- sheen (RTR4 §9.10) ---------------------------------------------------------------------
# The directional albedo E(mu, r) of the sheen lobes (app/reference/sheen.py), float32
# (n_r, n_mu, 3): channel 0 Charlie, channel 1 Ashikhmin, both with Neubelt's visibility,
# channel 2 Charlie with its Smith Lambda (Estevez & Kulla 2017's fit).
SHEEN_TABLE_SIZE = 64
SHEEN_TABLE_CHANNELS = 3


def sheen_table_path(size: int = SHEEN_TABLE_SIZE) -> Path:
    """Where the shipped sheen table lives (app/common/data/sheen_table_N.npy)."""
    return DATA_DIR / f"sheen_table_{size}.npy"


def read_sheen_table(size: int = SHEEN_TABLE_SIZE) -> np.ndarray:
    """The stored float32 (size, size, SHEEN_TABLE_CHANNELS) sheen albedo table, read-only."""
    return _read_square(sheen_table_path(size), size, SHEEN_TABLE_CHANNELS)


# --- image-based lighting (docs/ibl.md) -----------------------------------------------------
# The split-sum DFG table (app/reference/ibl.py): float32 (n_r, n_mu, 2) of (A, B) with
# integral f_spec (n.l) = F0 A + B for Schlick's F, on the Kulla-Conty table's grids.
DFG_TABLE_SIZE = 64


def dfg_table_path(size: int = DFG_TABLE_SIZE) -> Path:
    """Where the shipped DFG table lives (app/common/data/dfg_table_N.npy)."""
    return DATA_DIR / f"dfg_table_{size}.npy"


def read_dfg_table(size: int = DFG_TABLE_SIZE) -> np.ndarray:
    """The stored float32 (size, size, 2) DFG table, read-only."""
    return _read_square(dfg_table_path(size), size)
