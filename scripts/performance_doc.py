"""Write docs/performance.md's generated section from a ``pbs bench`` run.

    python scripts/performance_doc.py BENCH_DIR_OR_JSON [--doc docs/performance.md] [--check]

Reads BENCH_DIR/bench.json (or the JSON named), builds the section with
``app.bench.report.performance_section`` (the run, the targets' verdicts, a compact table
per suite that ran) and puts it between the doc's two generated-section markers; the
hand-written text around them is left as it is. ``--check`` writes nothing and exits 1
when the doc's section differs from what the JSON gives (e.g. after a hand edit).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from app.bench.report import DOC_BEGIN, DOC_END, performance_section, update_generated

DOC = Path(__file__).resolve().parents[1] / "docs" / "performance.md"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("bench", type=Path, help="a pbs bench output folder, or its bench.json")
    parser.add_argument("--doc", type=Path, default=DOC, help="the page (docs/performance.md)")
    parser.add_argument("--check", action="store_true", help="compare only; exit 1 if stale")
    args = parser.parse_args(argv)
    source = args.bench / "bench.json" if args.bench.is_dir() else args.bench
    payload = json.loads(source.read_text(encoding="utf-8"))
    section = performance_section(payload)
    return update_generated(
        "performance_doc", args.doc, section, source, args.check, (DOC_BEGIN, DOC_END)
    )


if __name__ == "__main__":
    sys.exit(main())
