"""(Re)compute the sheen albedo table (RTR4 §9.10) with the float64 twin.

    .venv/bin/python scripts/sheen_tables.py

Writes app/common/data/sheen_table_64.npy: E(mu, r) of the Charlie and the Ashikhmin sheen
lobes with Neubelt's visibility and of the Charlie lobe with its Smith Lambda (Estevez & Kulla
2017's fit), by quadrature (app/reference/sheen.py; ~3 min).
"""

from __future__ import annotations

import numpy as np

from app.reference.sheen import TABLE_MODELS, generate


def main() -> None:
    path = generate()
    table = np.load(path)
    for k, model in enumerate(TABLE_MODELS):
        E = table[..., k]
        print(f"{path}: {model} E in [{E.min():.6g}, {E.max():.6g}]")


if __name__ == "__main__":
    main()
