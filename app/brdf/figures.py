"""The walkthrough's figures beyond ``pbs brdf``'s lobes (app/brdf/plot.py), as matplotlib
``Figure`` objects (no pyplot, no window), from the float64 twins:

* ``vndf_figure``: Heitz 2018's sampling of the visible normals (RTR4 §9.6-9.8;
  app/reference/vndf.py): for each roughness and view angle, a cloud of the reflected
  directions it draws over the hemisphere, and the per-sample variance of the three
  estimators of the directional albedo (visible normals, cosine-weighted, uniform), with
  the quadrature's albedo they all estimate;
* ``layered_furnace_figure``: the white furnace of coated materials (RTR4 §9.12): the
  directional albedo of each composition against the angle of incidence, beside the
  Monte-Carlo random walk through the coat (app/reference/layered.py).

The numbers are seeded: the same figure every build. Every figure writes its words from
``WORDS`` in the language it is given (English or Korean, docs/walkthrough.md's
glossary) and draws them in the font it is given (app/brdf/plot.py ``figure_font``: the
walkthrough's Hangul font for Korean).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from app.common.models import MaterialParams
from app.reference import vndf
from app.reference.multiscatter import single_scatter_albedo

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from app.gl.context import GLContext


WORDS: dict[str, dict[str, dict[str, str]]] = {  # language -> figure kind -> its words
    "en": {
        "vndf": {
            "cloud": "r = {r:g}, θv = {t:g}°\nbelow horizon {below:.0f} %",
            "quadrature": "E (quadrature)",
            "var": "var {method}",
            "vndf": "VNDF",
            "cosine": "cosine",
            "uniform": "uniform",
            "title": "Visible-normal sampling (Heitz 2018): directions l seen from above\n"
            "★ mirror of v; × below the horizon (weight 0)\n"
            "table: per-sample variance of the albedo estimate, F = 1",
        },
        "layered_furnace": {
            "model": "clearcoat_model = {model}",
            "walk": "random walk through the coat (reference, ±2 s.e.)",
            "light": "θ of the light (deg)",
            "albedo": "directional albedo (mean of RGB)",
            "title": "White furnace of a coated white Lambertian base",
        },
        "prefilter": {
            "title": "The environment prefilter (GGX lobe, weights n·l): the renderer's GLSL "
            "Monte Carlo against the exact float64 integral\nthe studio along a strip 14-19° "
            "above the horizon",
            "mc": "Monte Carlo, N = {n}",
            "exact": "exact (sum over every texel)",
            "azimuth": "azimuth of R (deg)",
            "radiance": "prefiltered radiance L_pre(R)",
            "roughness": "roughness {r:g}",
            "samples": "samples per texel N",
            "error": "relative RMS error over the strip (%)",
        },
    },
    "ko": {
        "vndf": {
            "cloud": "r = {r:g}, θv = {t:g}°\n수평선 아래 {below:.0f} %",
            "quadrature": "E (수치 적분)",
            "var": "{method} 분산",
            "vndf": "VNDF",
            "cosine": "코사인",
            "uniform": "균등",
            "title": "가시 법선 샘플링 (Heitz 2018): 위에서 내려다본 방향 l\n"
            "★ v의 정반사 방향, × 수평선 아래 (가중치 0)\n"
            "표: 알베도 추정값의 샘플당 분산, F = 1",
        },
        "layered_furnace": {
            "model": "클리어 코트 모델: {model}",
            "walk": "코팅 속 랜덤 워크 (기준값, ±2 표준 오차)",
            "light": "빛의 입사각 θ (도)",
            "albedo": "방향 알베도 (RGB 평균)",
            "title": "흰 램버트 기판에 코팅한 재질의 화이트 퍼니스",
        },
        "prefilter": {
            "title": "환경 사전 필터링 (GGX 로브, 가중치 n·l): 렌더러의 GLSL 몬테카를로 대 "
            "정확한 float64 적분\n수평선 위 14-19°의 띠를 따라 본 스튜디오",
            "mc": "몬테카를로, N = {n}",
            "exact": "정확한 값 (모든 텍셀의 합)",
            "azimuth": "R의 방위각 (도)",
            "radiance": "사전 필터링된 복사휘도 L_pre(R)",
            "roughness": "거칠기 {r:g}",
            "samples": "텍셀당 샘플 수 N",
            "error": "띠 위의 상대 RMS 오차 (%)",
        },
    },
}

VNDF_CLOUD = 300  # directions drawn per cloud
VNDF_VARIANCE_SAMPLES = 20_000  # per variance estimate


@dataclass(frozen=True)
class VarianceRow:
    """The albedo at one roughness and view angle: its quadrature value and each method's
    per-sample mean and variance (the variance of an N-sample estimate is this / N)."""

    roughness: float
    theta: float
    albedo: float
    means: dict[str, float]
    variances: dict[str, float]


def vndf_variances(roughnesses: Sequence[float], thetas: Sequence[float]) -> list[VarianceRow]:
    """The variance table of ``vndf_figure`` (seeded)."""
    rows = []
    for r in roughnesses:
        for t in thetas:
            v = vndf.view_at(t)
            x = {
                m: vndf.albedo_samples(m, v, r, VNDF_VARIANCE_SAMPLES, seed=7)
                for m in vndf.VNDF_METHODS
            }
            means = {m: float(x[m].mean()) for m in vndf.VNDF_METHODS}
            variances = {m: float(x[m].var()) for m in vndf.VNDF_METHODS}
            albedo = single_scatter_albedo(float(v[2]), r)
            rows.append(VarianceRow(r, t, albedo, means, variances))
    return rows


def vndf_figure(
    roughnesses: Sequence[float],
    thetas: Sequence[float],
    dpi: int = 100,
    lang: str = "en",
    font: tuple[str, ...] | None = None,
    font_files: tuple[str, ...] = (),
) -> Figure:
    """Sample clouds (rows: roughness, columns: view angle) of the directions l reflected
    about visible normals, seen from above (the disc is the hemisphere, x = l.x, y = l.y),
    with the view's mirror direction; under them the variance table. Its words in
    ``lang`` (WORDS), in ``font`` (``figure_font``)."""
    from app.brdf.plot import figure_font

    with figure_font(font, font_files):
        return _vndf_figure(roughnesses, thetas, dpi, WORDS[lang]["vndf"])


def _vndf_figure(
    roughnesses: Sequence[float], thetas: Sequence[float], dpi: int, words: dict[str, str]
) -> Figure:
    from matplotlib.figure import Figure

    rows, cols = len(roughnesses), len(thetas)
    fig = Figure(figsize=(2.1 * cols + 0.4, 2.1 * rows + 2.2), dpi=dpi, layout="constrained")
    grid = fig.add_gridspec(rows + 1, cols, height_ratios=(*([1.0] * rows), 0.9))
    circle = np.linspace(0.0, 2.0 * np.pi, 181)
    rng = np.random.default_rng(2018)
    for i, r in enumerate(roughnesses):
        alpha = max(r, 0.045) ** 2
        for j, t in enumerate(thetas):
            ax = fig.add_subplot(grid[i, j])
            v = vndf.view_at(t)
            m = vndf.sample_vndf(v, alpha, alpha, rng.random(VNDF_CLOUD), rng.random(VNDF_CLOUD))
            l = vndf.reflect(v, m)
            up = l[:, 2] > 0.0
            ax.plot(np.cos(circle), np.sin(circle), color="0.6", lw=0.8)
            ax.scatter(l[up, 0], l[up, 1], s=2, color="tab:blue", alpha=0.5, lw=0)
            ax.scatter(l[~up, 0] / np.linalg.norm(l[~up, :2], axis=-1).clip(1e-9),
                       l[~up, 1] / np.linalg.norm(l[~up, :2], axis=-1).clip(1e-9),
                       s=4, color="tab:red", marker="x", lw=0.6)  # fmt: skip
            ax.plot([-v[0]], [0.0], marker="*", color="tab:orange", ms=8)
            ax.set_xlim(-1.1, 1.1)
            ax.set_ylim(-1.1, 1.1)
            ax.set_aspect("equal")
            ax.set_xticks([])
            ax.set_yticks([])
            below = 100.0 * float(np.mean(~up))
            ax.set_title(words["cloud"].format(r=r, t=t, below=below), fontsize=8)
    table = vndf_variances(roughnesses, thetas)
    ax = fig.add_subplot(grid[rows, :])
    ax.axis("off")
    cells = [
        [f"{row.roughness:g}", f"{row.theta:g}°", f"{row.albedo:.3f}",
         *(f"{row.variances[m]:.3g}" for m in vndf.VNDF_METHODS)]
        for row in table
    ]  # fmt: skip
    variances = [words["var"].format(method=words[m]) for m in vndf.VNDF_METHODS]
    tab = ax.table(
        cellText=cells, colLabels=["r", "θv", words["quadrature"], *variances], loc="center"
    )
    tab.auto_set_font_size(False)
    tab.set_fontsize(7)
    tab.scale(1.0, 0.95)
    fig.suptitle(words["title"], fontsize=9)
    return fig


# --- the layered white furnace ---------------------------------------------------------------

FURNACE_THETAS = (0.0, 30.0, 60.0, 75.0, 85.0)
FURNACE_WALK_PATHS = 6000


def walk_albedo(params: MaterialParams, thetas: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
    """The random walk's total albedo (coat + substrate, mean over RGB) of the coated
    ``params`` at each angle, and its standard error: its base resolved inside the coat
    (medium_ior = the coat's index), a flat coat of ``clearcoat_ior``, T0 =
    ``clearcoat_color``. Seeded."""
    import dataclasses

    from app.reference.layered import random_walk
    from app.reference.material import Surface
    from app.reference.quadrature import direction
    from app.scene.model import Material

    eta = float(params.params.clearcoat_eta)
    base = Material.model_validate(
        {"base_color": list(params.base_color), "metallic": params.metallic,
         "roughness": params.roughness, "fresnel": params.model.fresnel,
         "ior": float(params.params.eta_dielectric), "medium_ior": eta}
    ).resolve()  # fmt: skip

    s = Surface(
        np.asarray(base.base_color, np.float64), base.metallic, base.roughness, base.f0, 0.0
    )
    model = dataclasses.replace(base.model, clearcoat="none")
    out, err = [], []
    for k, t in enumerate(thetas):
        w = random_walk(
            s, base.params, model, eta, tuple(params.params.clearcoat_color), direction(t),
            paths=FURNACE_WALK_PATHS, bounces=24, seed=11 + k,
        )  # fmt: skip
        out.append(float(np.mean(w.total)))
        err.append(float(np.mean(w.stderr)))
    return np.array(out), np.array(err)


def layered_furnace_figure(
    materials: Sequence[MaterialParams],
    dpi: int = 100,
    lang: str = "en",
    font: tuple[str, ...] | None = None,
    font_files: tuple[str, ...] = (),
) -> Figure:
    """The directional albedo (mean over RGB) of each coated material (labelled by its
    clear-coat model) against the angle of incidence, by quadrature on its twin, and the
    random walk through the coat of the first one's base (points with twice their
    standard error); the line 1 is the white furnace. Its words in ``lang`` (WORDS), in
    ``font`` (``figure_font``)."""
    from app.brdf.plot import figure_font

    with figure_font(font, font_files):
        return _layered_furnace_figure(materials, dpi, WORDS[lang]["layered_furnace"])


def _layered_furnace_figure(
    materials: Sequence[MaterialParams], dpi: int, words: dict[str, str]
) -> Figure:
    from matplotlib.figure import Figure

    from app.reference.layered import coated_albedo
    from app.reference.material import Surface

    thetas = np.array(FURNACE_THETAS)
    fig = Figure(figsize=(6.4, 3.6), dpi=dpi, layout="constrained")
    ax = fig.add_subplot()
    ax.axhline(1.0, color="0.6", lw=0.8, ls="--")
    for p in materials:
        s = Surface(np.asarray(p.base_color, np.float64), p.metallic, p.roughness, p.f0, 0.0)
        total = [
            (lambda cs: cs[0] + float(np.mean(cs[1])))(coated_albedo(s, p.params, p.model, t))
            for t in thetas
        ]
        label = words["model"].format(model=p.model.clearcoat)
        ax.plot(thetas, total, marker="o", ms=3, label=label)
    walk, err = walk_albedo(materials[0], thetas)
    ax.errorbar(thetas, walk, yerr=2.0 * err, fmt="k*", ms=8, capsize=3,
                label=words["walk"])  # fmt: skip
    ax.set_xlabel(words["light"])
    ax.set_ylabel(words["albedo"])
    ax.set_ylim(0.0, 1.1)
    ax.set_xlim(0.0, 90.0)
    ax.legend(fontsize=7, loc="lower left")
    ax.set_title(words["title"], fontsize=9)
    return fig


# --- the environment prefilter's Monte Carlo against its exact integral -----------------------

PREFILTER_SAMPLE_COUNTS = (1, 4, 16, 64, 256, 1024)  # the GPU estimator's samples per texel
PREFILTER_SHOWN = (4, 16, 256)  # the counts whose strips the figure draws
PREFILTER_FACE = 32  # face size of the prefiltered cube the strip is read from
PREFILTER_ROW = 10  # the side faces' texel row of the strip: about 14-19 degrees up,
# through four of the studio's five soft boxes (app/textures/environment.py STUDIO_BOXES)
_STRIPS: dict[tuple, PrefilterStrip] = {}  # the last studio strip, per GL renderer


@dataclass(frozen=True)
class PrefilterStrip:
    """The prefiltered studio along a strip of directions (M, 3) round the horizon (the
    texel centres of row PREFILTER_ROW of the four side faces), sorted by azimuth (M,)
    in degrees: the exact texel sum (R, M) per roughness and the renderer's Monte Carlo
    (R, S, M) per roughness and sample count, each the mean of RGB; ``errors`` (R, S)
    the relative RMS error of each estimate over the strip."""

    roughnesses: tuple[float, ...]
    sample_counts: tuple[int, ...]
    directions: np.ndarray
    azimuth: np.ndarray
    exact: np.ndarray
    estimates: np.ndarray

    @property
    def errors(self) -> np.ndarray:
        rel = (self.estimates - self.exact[:, None, :]) / self.exact[:, None, :]
        return np.sqrt(np.mean(rel * rel, axis=-1))


def strip_directions(size: int = PREFILTER_FACE, row: int = PREFILTER_ROW) -> np.ndarray:
    """Unit directions (4, size, 3) of the texel centres of ``row`` of the side faces
    +X, -X, +Z, -Z of a cube face of ``size`` texels (cube faces 0, 1, 4, 5)."""
    from app.reference.environment import cube_direction

    st = np.stack([(np.arange(size) + 0.5) / size, np.full(size, (row + 0.5) / size)], -1)
    d = np.stack([cube_direction(face, st) for face in (0, 1, 4, 5)])
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def prefilter_strip(
    gl: GLContext,
    roughnesses: Sequence[float],
    sample_counts: Sequence[int] = PREFILTER_SAMPLE_COUNTS,
    env: np.ndarray | None = None,
) -> PrefilterStrip:
    """The prefiltered ``env`` (default: the studio) along the strip: by the renderer's
    GLSL prefilter (glsl/passes/env_prefilter.frag, app/render/ibl.py) on the context
    ``gl`` at each sample count, and by the float64 texel sum (app/reference/ibl.py
    ``prefiltered_radiance``) at each roughness."""
    from app.gl.shaders import ShaderCache
    from app.reference.ibl import prefiltered_radiance
    from app.render.ibl import prefilter_estimates
    from app.textures.environment import studio

    key = (tuple(roughnesses), tuple(sample_counts), gl.renderer)
    if env is None and key in _STRIPS:  # the handout draws it once per language
        return _STRIPS[key]
    studio_strip = env is None
    env = studio() if env is None else env
    size, row = PREFILTER_FACE, PREFILTER_ROW
    shaders = ShaderCache(gl.ctx)
    try:
        counts = list(sample_counts)
        faces = prefilter_estimates(gl.ctx, shaders, env, list(roughnesses), size, counts)
    finally:
        shaders.release()
    # faces (R, S, 6, size, size, 3): row ``row`` of faces +X, -X, +Z, -Z
    mc = faces[:, :, (0, 1, 4, 5), row].mean(-1).reshape(len(roughnesses), len(sample_counts), -1)
    d = strip_directions(size, row).reshape(-1, 3)
    azimuth = np.degrees(np.arctan2(d[:, 0], d[:, 2]))
    order = np.argsort(azimuth)
    exact = np.stack([prefiltered_radiance(env, 0.0, d, r).mean(-1) for r in roughnesses])
    strip = PrefilterStrip(
        tuple(float(r) for r in roughnesses),
        tuple(int(n) for n in sample_counts),
        d[order],
        azimuth[order],
        exact[:, order],
        mc[:, :, order].astype(np.float64),
    )
    if studio_strip:
        _STRIPS.clear()
        _STRIPS[key] = strip
    return strip


def prefilter_figure(
    strip: PrefilterStrip,
    dpi: int = 100,
    lang: str = "en",
    font: tuple[str, ...] | None = None,
    font_files: tuple[str, ...] = (),
) -> Figure:
    """One panel per roughness: the prefiltered radiance along the strip by the renderer's
    Monte Carlo at PREFILTER_SHOWN sample counts and by the exact texel sum; under them
    the relative RMS error over the strip against the sample count (log-log). Its words
    in ``lang`` (WORDS), in ``font`` (``figure_font``)."""
    from app.brdf.plot import figure_font

    with figure_font(font, font_files):
        return _prefilter_figure(strip, dpi, WORDS[lang]["prefilter"])


def _prefilter_figure(strip: PrefilterStrip, dpi: int, words: dict[str, str]) -> Figure:
    from matplotlib.figure import Figure

    cols = len(strip.roughnesses)
    fig = Figure(figsize=(3.0 * cols + 0.4, 5.6), dpi=dpi, layout="constrained")
    grid = fig.add_gridspec(2, cols, height_ratios=(1.0, 0.9))
    colours = ("tab:red", "tab:orange", "tab:blue")
    for i, r in enumerate(strip.roughnesses):
        ax = fig.add_subplot(grid[0, i])
        for colour, n in zip(colours, PREFILTER_SHOWN, strict=False):
            if n in strip.sample_counts:
                k = strip.sample_counts.index(n)
                ax.plot(strip.azimuth, strip.estimates[i, k], color=colour, lw=0.9,
                        label=words["mc"].format(n=n))  # fmt: skip
        ax.plot(strip.azimuth, strip.exact[i], color="k", lw=1.6, ls="--",
                label=words["exact"])  # fmt: skip
        ax.set_xlim(-180.0, 180.0)
        ax.set_xticks((-180, -90, 0, 90, 180))
        ax.set_xlabel(words["azimuth"], fontsize=8)
        if i == 0:
            ax.set_ylabel(words["radiance"], fontsize=8)
        ax.tick_params(labelsize=7)
        ax.set_title(words["roughness"].format(r=r), fontsize=9)
    handles, labels = fig.axes[0].get_legend_handles_labels()
    ax = fig.add_subplot(grid[1, :])
    n = np.array(strip.sample_counts, np.float64)
    for i, r in enumerate(strip.roughnesses):
        label = words["roughness"].format(r=r)
        ax.loglog(n, 100.0 * strip.errors[i], marker="o", ms=4, label=label)
    guide = 100.0 * strip.errors[:, 0].max() / np.sqrt(n)
    ax.loglog(n, guide, color="0.6", ls=":", label="1/√N")
    ax.set_xlabel(words["samples"], fontsize=8)
    ax.set_ylabel(words["error"], fontsize=8)
    ax.tick_params(labelsize=7)
    ax.legend(handles + ax.get_legend_handles_labels()[0],
              labels + ax.get_legend_handles_labels()[1], fontsize=7, ncols=2)  # fmt: skip
    fig.suptitle(words["title"], fontsize=9)
    return fig
