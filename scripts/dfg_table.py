"""(Re)compute the split-sum DFG table (Karis 2013) with the float64 twin, for the
project's own G2 (height-correlated Smith), GGX and Schlick F (app/reference/ibl.py).

    .venv/bin/python scripts/dfg_table.py [SIZE]

Writes app/common/data/dfg_table_SIZE.npy (default 64: the Kulla-Conty table's size and
grids, so both are read with the same look-up); 64 x 64 takes ~30 s.
"""

from __future__ import annotations

import argparse

import numpy as np

from app.common.tables import DFG_TABLE_SIZE, dfg_table_path
from app.reference.ibl import compute_dfg_table


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("size", nargs="?", type=int, default=DFG_TABLE_SIZE)
    size = parser.parse_args(argv).size
    table = compute_dfg_table(size)
    path = dfg_table_path(size)
    np.save(path, table)
    print(
        f"{path}: {size}x{size}, A in [{table[..., 0].min():.6f}, {table[..., 0].max():.6f}]"
        f", B in [{table[..., 1].min():.6f}, {table[..., 1].max():.6f}]"
    )


if __name__ == "__main__":
    main()
