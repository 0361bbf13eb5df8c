"""(Re)compute the Kulla-Conty multiple-scattering tables (RTR4 §9.8.2) with the float64 twin.

    .venv/bin/python scripts/ms_tables.py [SIZE ...] [--form FORM ...]

One table per G2 form (app.common.tables.MS_FORMS; default: every form), the same
generator with that form's G2. The shipped sizes (32, 64, 128: the default) go to
app/common/data; other sizes (16 for the benchmark) to the cache directory that
``app.reference.multiscatter.load_table`` reads.
"""

from __future__ import annotations

import argparse

import numpy as np

from app.common.tables import MS_FORMS, SHIPPED_SIZES
from app.reference.multiscatter import generate


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sizes", nargs="*", type=int, default=list(SHIPPED_SIZES))
    parser.add_argument("--form", action="append", choices=MS_FORMS, dest="forms")
    args = parser.parse_args(argv)
    for size in args.sizes:
        for form in args.forms or MS_FORMS:
            path = generate(size, form)
            table = np.load(path)
            print(
                f"{path}: {size}x{size}, E in [{1 - table[..., 0].max():.6f}, "
                f"{1 - table[..., 0].min():.6f}], E_avg in [{1 - table[:, 0, 1].max():.6f}, "
                f"{1 - table[:, 0, 1].min():.6f}]",
                flush=True,
            )


if __name__ == "__main__":
    main()
