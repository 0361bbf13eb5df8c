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

# The renderer's table: 64 x 64 costs the lighting pass what 32 x 32 costs and is more
# accurate at worst (measured in docs/performance.md, ms_table).
DEFAULT_SIZE = 64
# Shipped: the default, the bench's other size and its reference (128 x 128 takes minutes
# to compute); other sizes are computed on first use and cached.
SHIPPED_SIZES = (32, 64, 128)
DATA_DIR = Path(__file__).resolve().parent / "data"
CACHE_VERSION = 1  # bump when the grids, the quadrature or the layout change


def cache_dir() -> Path:
    """$XDG_CACHE_HOME/pbs-lab (default ~/.cache/pbs-lab), where other sizes are kept."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "pbs-lab"


def table_path(size: int) -> Path:
    """Where the size x size table lives: shipped in app/common/data, else the cache."""
    if size in SHIPPED_SIZES:
        return DATA_DIR / f"ms_table_{size}.npy"
    return cache_dir() / f"ms_table_{size}_v{CACHE_VERSION}.npy"


def read_ms_table(size: int = DEFAULT_SIZE) -> np.ndarray:
    """The stored float32 (size, size, 2) table, read-only; FileNotFoundError where it was
    never computed (app.reference.multiscatter.load_table computes and stores it)."""
    return _read_square(table_path(size), size)


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
