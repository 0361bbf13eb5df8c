"""pareto.png and scaling.png (matplotlib's Agg backend: no window, no display needed).

* pareto.png: one panel per accuracy comparison, frame time (median, with the min-max
  range as a bar) against rel_rmse, log scale; the Pareto front joined by a line, front
  points filled, the renderer's default ringed.
* scaling.png: (left) frame time against light count for each culling variant, log-log;
  (right) frame time against pixel count for the resolution suite, with each pass's
  time, so it shows which pass grows with the image.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

from app.bench.report import SPHERES_CASE, pareto_by_comparison
from app.output import atomic_write

VARIANT_STYLE = {
    "culled": ("tab:blue", "o"),
    "unculled": ("tab:red", "s"),
    "forward": ("tab:orange", "^"),
    "floor": ("tab:green", "v"),
    "limit": ("tab:olive", "<"),
    "pyrender": ("tab:purple", "D"),
    "culled_readback": ("tab:cyan", "x"),
}


def _figure(width: float, height: float):
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    return Figure(figsize=(width, height), dpi=110, layout="constrained")


def _save(fig, path: Path) -> None:
    atomic_write(Path(path), lambda tmp: fig.savefig(tmp, format="png", dpi=fig.dpi))


def _label_clusters(ax, members: list[dict], floor: float) -> list[tuple[float, float, str]]:
    """One label per group of points that nearly coincide on the drawn panel (within a
    label's height and a few characters' width of each other, in display pixels), its
    variants one per line, so that labels of overlapping points do not print over each
    other. Call after the axes' limits and scales are final."""
    ax.autoscale_view()
    pts = [(r["ms_median"], max(r["rel_rmse"], floor)) for r in members]
    px = ax.transData.transform(pts)
    clusters: list[list[int]] = []
    for i in range(len(members)):
        for c in clusters:
            dx, dy = abs(px[i] - px[c[0]])
            if dx <= 60.0 and dy <= 28.0:
                c.append(i)
                break
        else:
            clusters.append([i])
    out = []
    for c in clusters:
        text = "\n".join(
            members[i]["variant"] + (" (default)" if members[i].get("default") else "") for i in c
        )
        out.append((*pts[c[0]], text))
    return out


def plot_pareto(rows: list[dict], path: Path) -> None:
    ibl = {f"ibl {case}": front for case, front in pareto_by_comparison(rows, "ibl").items()}
    fronts = {**pareto_by_comparison(rows), **ibl}
    n = max(len(fronts), 1)
    cols = min(n, 3)
    nrows = -(-n // cols)
    fig = _figure(4.2 * cols, 3.6 * nrows)
    axes = fig.subplots(nrows, cols, squeeze=False).ravel()
    for ax, (comp, front) in zip(axes, fronts.items(), strict=False):
        members = front["rows"]
        floor = 1e-12  # exact variants can reach 0 on a log axis
        for r in members:
            err = max(r["rel_rmse"], floor)
            on = r["variant"] in front["front"]
            ax.errorbar(
                r["ms_median"], err,
                xerr=[[r["ms_median"] - r["ms_min"]], [r["ms_max"] - r["ms_median"]]],
                fmt="o", color="tab:blue" if on else "tab:gray",
                markerfacecolor="tab:blue" if on else "white", capsize=3,
            )  # fmt: skip
            if r.get("default"):
                ax.plot(r["ms_median"], err, "o", markersize=14, markerfacecolor="none",
                        markeredgecolor="tab:red")  # fmt: skip
        pts = sorted(
            (r["ms_median"], max(r["rel_rmse"], floor))
            for r in members
            if r["variant"] in front["front"]
        )
        if len(pts) > 1:
            ax.plot(*zip(*pts, strict=True), "-", color="tab:blue", alpha=0.6, label="Pareto front")
            ax.legend(fontsize=7, loc="best")
        ax.set_yscale("log")
        ax.margins(x=0.15, y=0.2)
        for x, y, text in _label_clusters(ax, members, floor):
            ax.annotate(
                text,
                (x, y),
                textcoords="offset points",
                xytext=(9, 0),
                fontsize=8,
                va="center",
                bbox={"boxstyle": "round,pad=0.15", "fc": "white", "ec": "none", "alpha": 0.85},
            )  # fmt: skip  (a white box: the label sits on its own error bar)
        ax.set_title(textwrap.fill(members[0].get("comparison", comp), 48), fontsize=9)
        ax.set_xlabel("frame time, ms (median, min-max)")
        ax.set_ylabel("rel. RMSE vs its reference")
        ax.grid(True, which="both", alpha=0.3)
    for ax in axes[len(fronts) :]:
        ax.set_visible(False)
    if not fronts:
        axes[0].set_visible(True)
        axes[0].text(0.5, 0.5, "no accuracy rows", ha="center", va="center")
    _save(fig, path)


def plot_scaling(rows: list[dict], path: Path) -> None:
    fig = _figure(11.0, 4.2)
    left, right = fig.subplots(1, 2)
    culling = [  # the 35-sphere pyrender comparison is another scene: not on these axes
        r
        for r in rows
        if r["suite"] == "culling" and r.get("ms_median") and r["case"] != SPHERES_CASE
    ]
    for variant, (colour, marker) in VARIANT_STYLE.items():
        pts = sorted((r["lights"], r) for r in culling if r["variant"] == variant)
        if not pts:
            continue
        xs = [n for n, _ in pts]
        ys = [r["ms_median"] for _, r in pts]
        lo = [r["ms_median"] - r["ms_min"] for _, r in pts]
        hi = [r["ms_max"] - r["ms_median"] for _, r in pts]
        left.errorbar(xs, ys, yerr=[lo, hi], color=colour, marker=marker, label=variant, capsize=2)
    if culling:
        size = f"{culling[0]['width']}x{culling[0]['height']}"
        left.set_xscale("log")
        left.set_yscale("log")
        left.legend(fontsize=8)
        left.set_title(f"culling suite, {size}, ~16 lights per pixel", fontsize=9)
    else:
        left.text(0.5, 0.5, "no culling rows", ha="center", va="center")
    left.set_xlabel("lights in the scene")
    left.set_ylabel("frame time to HDR, ms (median, min-max)")
    left.grid(True, which="both", alpha=0.3)

    res = sorted(
        (r["width"] * r["height"], r)
        for r in rows
        if r["suite"] == "resolution" and r.get("ms_median")
    )
    if res:
        px = [p / 1e6 for p, _ in res]
        right.errorbar(
            px, [r["ms_median"] for _, r in res],
            yerr=[[r["ms_median"] - r["ms_min"] for _, r in res],
                  [r["ms_max"] - r["ms_median"] for _, r in res]],
            color="black", marker="o", label="frame (wall)", capsize=2,
        )  # fmt: skip
        names = []
        for _, r in res:
            names += [n for n in r.get("passes_ms", {}) if n not in names]
        for name in names:
            right.plot(px, [r["passes_ms"].get(name, float("nan")) for _, r in res],
                       marker=".", linestyle="--", label=f"{name} pass")  # fmt: skip
        right.set_xscale("log")
        right.set_yscale("log")
        right.legend(fontsize=8)
        right.set_title(f"resolution suite, culled, {res[0][1]['lights']} lights", fontsize=9)
        right.set_xticks(px, [r["case"] for _, r in res], fontsize=8)
        right.minorticks_off()
    else:
        right.text(0.5, 0.5, "no resolution rows", ha="center", va="center")
    right.set_xlabel("image size (megapixels, log)")
    right.set_ylabel("ms")
    right.grid(True, which="both", alpha=0.3)
    _save(fig, path)
