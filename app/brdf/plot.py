"""BRDF Explorer-style plots of one or more materials: ``pbs brdf`` (docs/brdf-explorer.md).

In the spirit of Disney's BRDF Explorer (Burley 2012), each material gets one column of
two panels, both computed from ``app.brdf.evaluate``, by default on the GLSL the lighting
pass runs, so the curves are the renderer's own numbers:

* the lobe: f(l, v) cos(theta_v) (or f itself) in the plane of incidence, as a polar plot
  over the outgoing angle theta_v in [-90, 90] degrees, for several incident angles
  theta_i (the light in the plane phi = 180 degrees, the view sweeping through it);
* the directional albedo R(theta) = integral of f(l, v) (n.v)+ dv over the hemisphere
  (RTR4 §9.3), the fraction of light from direction l that is reflected, against
  theta in [0, 90] degrees, with the line R = 1 (energy conservation) for reference.

The albedo uses a deterministic quadrature (``albedo_curve``) at two resolutions; their
difference is reported as the accuracy of the curve.
"""

from __future__ import annotations

import math
import re
import warnings
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Literal

import numpy as np

from app.brdf import Backend, evaluate
from app.common.models import MaterialParams
from app.errors import InputError
from app.gl.context import GLContext
from app.output import atomic_write
from app.reference.constants import MIN_PERCEPTUAL_ROUGHNESS
from app.reference.quadrature import direction, directional_albedo, reflected_rule
from app.scene.presets import PRESETS
from app.untrusted import RefusedError
from app.untrusted.policy import Limits
from app.untrusted.structured import parse_toml

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from matplotlib.projections.polar import PolarAxes

Quantity = Literal["fcos", "f"]


@dataclass(frozen=True)
class FigureWords:
    """Every word the figure writes, so that a caller can set it in another language
    (the walkthrough's Korean handout); ``font``: the font families to draw them with
    (None: matplotlib's default), each family registered from ``font_files`` first.
    The defaults are ``pbs brdf``'s English."""

    evaluated_by: str = "f(l, v) as evaluated by {where} (app.brdf.evaluate)"
    glsl: str = "the renderer's GLSL"
    reference: str = "the float64 reference twin"
    subtitle: str = "{model}, roughness {roughness:g}, metallic {metallic:g}"
    angle: str = "angle: θv (+ = mirror side; dotted: the light at −θi)"
    radius: str = "radius: {what} [1/sr], {how}{scale}"
    luminance: str = "luminance"
    log_radius: str = ", log radius"
    light_theta: str = "θ of the light (deg)"
    albedo: str = "directional albedo R(θ) = ∫ f (n·v) dv"
    quadrature: str = "quadrature error ~ {error:.0e} (|R_8192 − R_2048|)"
    font: tuple[str, ...] | None = None
    font_files: tuple[str, ...] = ()


ENGLISH = FigureWords()

# Rec. 709 / sRGB primaries: the luminance Y of linear RGB (ITU-R BT.709-6, item 3.2).
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])

DEFAULT_THETAS = (0.0, 30.0, 60.0, 80.0)
# Every 2 degrees to 60, every degree to 84, every half degree to grazing (90 included):
# the curves of smooth materials bend most within the last few degrees.
ALBEDO_THETAS = np.concatenate(
    [np.arange(0.0, 60.0, 2.0), np.arange(60.0, 84.0, 1.0), np.arange(84.0, 90.25, 0.5)]
)
# Quadrature resolution (n_psi = n_phi) of the albedo: the curve uses FINE, the error
# estimate compares it with COARSE. Per angle: 8 panels x n_psi x 4 quarter turns x n_phi.
ALBEDO_COARSE = 8  # 2048 directions per angle
ALBEDO_FINE = 16  # 8192 directions per angle
COLUMN_INCHES = (4.6, 7.4)  # default figure size per material column
DEFAULT_DPI = 100


class ModelUnavailableError(RuntimeError):
    """A material's model cannot be evaluated: its GLSL does not compile, its float64 twin
    does not exist yet, or its f(l, v) is not finite. Not bad input: exit code 1."""


@dataclass(frozen=True)
class NamedMaterial:
    """A resolved material with the label it is plotted under."""

    name: str  # preset name, scene material name, or the inline table's keys
    source: str  # the command-line argument it came from
    params: MaterialParams


# -- arguments -> materials --------------------------------------------------------------


def _known_presets() -> str:
    return ", ".join(sorted(PRESETS))


def _shown(arg: str) -> str:
    """An argument as an error message shows it: on one line."""
    return arg.replace("\n", "\\n")


def _inline(arg: str) -> list[NamedMaterial]:
    """``{ ndf = "beckmann", roughness = 0.3 }``: one material from an inline TOML table."""
    from app.scene.loader import parse_scene

    try:
        data = parse_toml(f"m = {arg}", Limits().max_nesting)
    except RefusedError as exc:
        raise InputError(_shown(arg), "", f"malformed inline TOML table: {exc}") from None
    table = data.get("m")
    if set(data) != {"m"} or not isinstance(table, dict):  # '{ ... }\nkey = 1' and the like
        raise InputError(_shown(arg), "", "expected one inline TOML table like { roughness = 0.3 }")
    # Validate through the scene loader, which names the offending key as a scene file
    # would (materials.m.KEY); report it relative to this table.
    try:
        loaded = parse_scene({"materials": {"m": table}}, Path("inline"))
    except InputError as exc:
        key = exc.key.removeprefix("materials.m.")
        raise InputError(_shown(arg), key, exc.message) from None
    name = ", ".join(f"{k}={_short(v)}" for k, v in table.items()) or "defaults"
    return [NamedMaterial(name, arg, loaded.scene.materials["m"].resolve())]


def _short(value: object) -> str:
    if isinstance(value, list):
        return "[" + ",".join(_short(x) for x in value) + "]"
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


def _split_scene(arg: str) -> tuple[str, str | None]:
    """'scene.toml:NAME' -> ('scene.toml', 'NAME'); anything else -> (arg, None)."""
    match = re.fullmatch(r"(.+):([^:/\\]+)", arg)
    if match and not Path(arg).exists():
        return match.group(1), match.group(2)
    return arg, None


def _scene_path(path_text: str) -> Path | None:
    """The scene file an argument names: a path, or a bundled scene's bare name."""
    from app.resources import scenes_dir

    path = Path(path_text)
    if path.suffix.lower() == ".toml" or path.exists():  # load_scene explains a folder
        return path
    bundled = scenes_dir() / f"{path_text}.toml"
    return bundled if "/" not in path_text and bundled.is_file() else None


def _scene(arg: str, path: Path, only: str | None) -> list[NamedMaterial]:
    from app.scene.loader import load_scene

    materials = load_scene(path).scene.materials
    if only is not None:
        if only not in materials:
            known = ", ".join(sorted(materials)) or "none defined"
            raise InputError(str(path), f"materials.{only}", f"no such material (known: {known})")
        return [NamedMaterial(only, arg, materials[only].resolve())]
    if not materials:
        raise InputError(str(path), "materials", "the scene defines no materials to plot")
    return [NamedMaterial(name, arg, m.resolve()) for name, m in materials.items()]


def parse_material_arg(arg: str) -> list[NamedMaterial]:
    """The materials one command-line argument names, in this order of interpretation:

    * ``{ key = value, ... }``: an inline TOML table with the keys of [materials.NAME];
    * a preset name (``gold``; app/scene/presets.py), plotted with the preset's defaults;
    * a scene file (``path/scene.toml``, or a bundled scene's name like ``showcase``):
      every material it defines, or only NAME with ``scene.toml:NAME``.

    Raises ``InputError`` naming the argument (or the scene file) and the key.
    """
    text = arg.strip()
    if text.startswith("{"):
        return _inline(text)
    if text in PRESETS:
        from app.scene.model import Material

        return [NamedMaterial(text, arg, Material(preset=text).resolve())]
    path_text, only = _split_scene(text)
    path = _scene_path(path_text)
    if path is not None:
        return _scene(arg, path, only)
    raise InputError(
        _shown(arg),
        "preset",
        f"not a preset, a scene file or an inline {{ ... }} table (presets: {_known_presets()})",
    )


def parse_material_args(args: Sequence[str]) -> list[NamedMaterial]:
    """All arguments' materials, validated before anything is evaluated or written."""
    out: list[NamedMaterial] = []
    for arg in args:
        out.extend(parse_material_arg(arg))
    return out


# -- evaluation ----------------------------------------------------------------------------


def _evaluate(
    material: NamedMaterial,
    l: np.ndarray,
    v: np.ndarray,
    backend: Backend,
    gl: GLContext | None,
) -> np.ndarray:
    """``evaluate`` with model failures turned into one ``ModelUnavailableError``."""
    import moderngl

    model = material.params.model.describe()
    try:
        f = evaluate(material.params, l, v, backend=backend, gl=gl)
    except moderngl.Error as exc:
        first = next(
            (line.strip() for line in str(exc).splitlines() if "error" in line.lower()), ""
        )
        raise ModelUnavailableError(
            f"{material.source}: model '{model}' does not compile in GLSL ({first}); "
            "try --backend reference"
        ) from None
    except (AttributeError, ImportError) as exc:  # a twin not written yet
        if backend != "reference":
            raise
        raise ModelUnavailableError(
            f"{material.source}: model '{model}' has no float64 twin ({exc})"
        ) from None
    if not np.all(np.isfinite(f)):
        raise ModelUnavailableError(
            f"{material.source}: f(l, v) of model '{model}' "
            f"is not finite at {np.count_nonzero(~np.isfinite(f).all(axis=-1))} of {len(f)} "
            "direction pairs"
        )
    return f


def alpha_of(params: MaterialParams) -> float:
    """The narrowest GGX width of a material: alpha = r^2 with r floored as the GLSL does,
    times (1 - |anisotropy|) along the narrow axis of an anisotropic one (floored likewise)."""
    alpha = max(params.roughness, MIN_PERCEPTUAL_ROUGHNESS) ** 2
    if params.anisotropy:
        alpha = max(alpha * (1.0 - abs(params.anisotropy)), MIN_PERCEPTUAL_ROUGHNESS**2)
    return alpha


def incident(theta_deg: float) -> np.ndarray:
    """The light direction at polar angle theta in the plane phi = 180 degrees."""
    return direction(theta_deg, 180.0)


def outgoing(theta_v_deg: np.ndarray) -> np.ndarray:
    """View directions in the plane of incidence: theta_v > 0 on the mirror side (phi = 0),
    theta_v < 0 on the light's side (phi = 180), as (N, 3)."""
    t = np.radians(np.asarray(theta_v_deg, np.float64))
    return np.stack([np.sin(t), np.zeros_like(t), np.cos(t)], axis=-1)


def lobe_angles(theta_i_deg: float, alpha: float, n_uniform: int = 721) -> np.ndarray:
    """Outgoing angles theta_v (degrees, sorted, in [-90, 90]) for one lobe curve: every
    0.25 degrees, plus nodes packed into the specular peak at theta_v = theta_i.

    In the plane of incidence the half vector sits at (theta_v - theta_i)/2 from n, and GGX
    falls to half its peak at tan(theta_h) ~ 0.64 alpha: for alpha = 0.002 the peak is
    ~0.3 degrees wide at half maximum, and the uniform grid alone can miss its top by 40%
    (0.125 degrees off). The extra nodes are
    theta_v = theta_i + 2 atan(alpha tan u) for u uniform in (-pi/2, pi/2), which crowd
    into the peak however narrow it is (the substitution of quadrature.tan_rule).
    """
    uniform = np.linspace(-90.0, 90.0, n_uniform)
    u = np.linspace(-1.55, 1.55, 241)
    peak = theta_i_deg + 2.0 * np.degrees(np.arctan(alpha * np.tan(u)))
    angles = np.concatenate([uniform, peak[(peak > -90.0) & (peak < 90.0)]])
    return np.unique(angles)


@dataclass(frozen=True)
class Lobe:
    """One curve of the polar panel: f(l, v) (cos theta_v) for the light at theta_i."""

    theta_i: float  # degrees
    theta_v: np.ndarray  # (N,) degrees
    value: np.ndarray  # (N, 3) f cos(theta_v) or f, per RGB channel


def lobes(
    material: NamedMaterial,
    thetas_i: Sequence[float],
    quantity: Quantity = "fcos",
    backend: Backend = "glsl",
    *,
    gl: GLContext | None = None,
) -> list[Lobe]:
    """The lobe curves of one material for each incident angle, in one evaluation."""
    alpha = alpha_of(material.params)
    angles = [lobe_angles(t, alpha) for t in thetas_i]
    l = np.concatenate(
        [np.broadcast_to(incident(t), (len(a), 3)) for t, a in zip(thetas_i, angles, strict=True)]
    )
    v = np.concatenate([outgoing(a) for a in angles])
    f = _evaluate(material, l, v, backend, gl)
    if quantity == "fcos":
        f = f * np.maximum(v[:, 2], 0.0)[:, None]
    out, start = [], 0
    for t, a in zip(thetas_i, angles, strict=True):
        out.append(Lobe(float(t), a, f[start : start + len(a)]))
        start += len(a)
    return out


@dataclass(frozen=True)
class AlbedoCurve:
    """R(theta) per RGB channel and the estimated quadrature error of each value."""

    theta: np.ndarray  # (T,) degrees
    albedo: np.ndarray  # (T, 3), from the fine rule
    error: np.ndarray  # (T,) max over channels of |fine - coarse|

    @property
    def luminance(self) -> np.ndarray:
        """Rec. 709 luminance of the albedo, (T,)."""
        return self.albedo @ LUMINANCE


def _albedo(
    material: NamedMaterial,
    theta: np.ndarray,
    n: int,
    backend: Backend,
    gl: GLContext | None,
) -> np.ndarray:
    """R(theta) with ``reflected_rule(l, alpha, n, n)`` at each angle, in one evaluation."""
    alpha = alpha_of(material.params)
    rules = [reflected_rule(incident(t), alpha, n, n) for t in theta]
    v = np.concatenate([v for v, _ in rules])
    l = np.repeat(np.stack([incident(t) for t in theta]), [len(w) for _, w in rules], axis=0)
    f = _evaluate(material, l, v, backend, gl).reshape(len(theta), -1, 3)
    return np.array([directional_albedo(f[i], *rules[i]) for i in range(len(theta))])


def albedo_curve(
    material: NamedMaterial,
    theta: np.ndarray = ALBEDO_THETAS,
    backend: Backend = "glsl",
    *,
    gl: GLContext | None = None,
    fine: int = ALBEDO_FINE,
    coarse: int = ALBEDO_COARSE,
) -> AlbedoCurve:
    """The directional albedo R(theta) = integral of f(l, v) (n.v)+ dv, l at theta.

    One rule serves every material, broad or peaked: ``reflected_rule`` with
    scale = alpha (``alpha_of``) maps half vectors, crowded into the GGX peak by
    tan(theta_h) = alpha tan(psi), to outgoing directions, and cuts the domain exactly at
    the horizon; its psi panels are graded toward that cut, so the wide-angle rest of the
    hemisphere (where a diffuse lobe lives) is covered as well: on f = 1/pi the 2048-node
    rule is exact to 2e-7 for every alpha in [0.002, 1] and theta in [0, 89.9] degrees, the
    8192-node rule to 2e-14 (docs/brdf-explorer.md). The value is that of the ``fine``
    rule; ``error`` = |fine - coarse| estimates its error (measured against a 4x finer rule
    it is an upper bound, except at exactly 90 degrees for r = 0: 3.4e-6 vs 3.2e-6).
    """
    theta = np.asarray(theta, np.float64)
    r_fine = _albedo(material, theta, fine, backend, gl)
    r_coarse = _albedo(material, theta, coarse, backend, gl)
    return AlbedoCurve(theta, r_fine, np.abs(r_fine - r_coarse).max(axis=-1))


# -- the figure ----------------------------------------------------------------------------


TITLE_POINTS = 9  # a column's title
# A character's mean advance in ems, a little above a sans-serif's, Latin and Hangul mixed
# (a Hangul syllable is about 1 em: a title of Korean words wraps early, never late).
CHAR_EMS = 0.62


def _wrapped(text: str, inches: float, points: float) -> str:
    """``text`` broken at its spaces into lines that fit a column ``inches`` wide at
    ``points`` (a long inline material, all its keys in its name, ran past the figure's
    edge): each line at most as many characters as the width holds at ``CHAR_EMS``."""
    import textwrap

    chars = max(int(0.92 * inches * 72.0 / (CHAR_EMS * points)), 12)
    return "\n".join(textwrap.wrap(text, chars, break_long_words=False)) or text


def _subtitle(params: MaterialParams, words: FigureWords = ENGLISH) -> str:
    return words.subtitle.format(
        model=params.model.describe(), roughness=params.roughness, metallic=params.metallic
    )


def _log_radius(values: list[np.ndarray], decades: float) -> tuple[list[np.ndarray], float]:
    """log10(y / y_min) clipped at 0, y_min = max(y) 10^-decades; returns the curves and
    log10(y_min) (for the tick labels)."""
    peak = max(float(np.max(v)) for v in values)
    floor = math.log10(peak) - decades if peak > 0.0 else 0.0
    with np.errstate(divide="ignore"):
        return [np.maximum(np.log10(v) - floor, 0.0) for v in values], floor


def _plot_lobes(
    ax: PolarAxes,
    curves: list[Lobe],
    quantity: Quantity,
    rgb: bool,
    log: bool,
    words: FigureWords = ENGLISH,
) -> None:
    from matplotlib import colormaps
    from matplotlib.ticker import MaxNLocator
    from matplotlib.transforms import ScaledTranslation

    colours = colormaps["viridis"](np.linspace(0.0, 0.85, max(len(curves), 1)))
    styles = ["-", "--", ":", "-."]
    if rgb:
        radii = [c.value[:, k] for c in curves for k in range(3)]
    else:
        radii = [c.value @ LUMINANCE for c in curves]
    floor = 0.0
    if log:
        radii, floor = _log_radius(radii, 4.0)
    rmax = max(float(np.max(r)) for r in radii) or 1.0
    for i, c in enumerate(curves):
        t = np.radians(c.theta_v)
        label = f"θi = {c.theta_i:g}°"
        if rgb:
            for k, colour in enumerate("rgb"):
                ax.plot(t, radii[3 * i + k], colour, ls=styles[i % 4], lw=1.1,
                        label=label if k == 0 else None)  # fmt: skip
        else:
            ax.plot(t, radii[i], color=colours[i], lw=1.4, label=label)
        # The light's direction, dotted, on the left (phi = 180 degrees).
        ax.plot([-np.radians(c.theta_i)] * 2, [0.0, rmax], color=colours[i], lw=0.8, ls=":")
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)  # theta_v > 0 (the mirror side) to the right
    ax.set_thetamin(-90.0)
    ax.set_thetamax(90.0)
    ax.set_thetagrids(range(-90, 91, 30))
    ax.set_rlim(0.0, rmax * 1.05)
    if log:  # a label every other decade: the baseline is short
        ticks = np.arange(math.floor(rmax), -0.5, -2.0)[::-1]
        ax.set_rticks(ticks)
        ax.set_yticklabels([f"1e{round(t + floor)}" for t in ticks], fontsize=7)
    else:
        ax.yaxis.set_major_locator(MaxNLocator(4))
        ax.tick_params(axis="y", labelsize=7)
    what = "f(l,v)·cos θv" if quantity == "fcos" else "f(l,v)"
    how = "RGB" if rgb else words.luminance
    scale = words.log_radius if log else ""
    # The polar axes keep a square box and draw the half disc in its middle half, so the
    # quarters above and below would stay empty: the title goes into the upper one (see
    # render_figure), the legend and the axis description into the lower one.
    below = ax.transAxes + ScaledTranslation(0.0, -16.0 / 72.0, ax.figure.dpi_scale_trans)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, 0.25), bbox_transform=below,
              ncol=4, fontsize=7, frameon=False, handlelength=1.5, columnspacing=1.0)  # fmt: skip
    ax.annotate(
        f"{words.angle}\n{words.radius.format(what=what, how=how, scale=scale)}",
        xy=(0.5, 0.25), xycoords="axes fraction", xytext=(0.0, -30.0),
        textcoords="offset points", ha="center", va="top", fontsize=8,
    )  # fmt: skip


def _plot_albedo(ax: Axes, curve: AlbedoCurve, words: FigureWords = ENGLISH) -> None:
    for k, colour in enumerate(("tab:red", "tab:green", "tab:blue")):
        ax.plot(curve.theta, curve.albedo[:, k], color=colour, lw=1.0, label="RGB"[k])
    ax.plot(curve.theta, curve.luminance, color="black", lw=1.8, label=words.luminance)
    ax.axhline(1.0, color="grey", ls="--", lw=1.0, label="R = 1")
    ax.set_xlim(0.0, 90.0)
    ax.set_xticks(range(0, 91, 15))
    ax.set_xlabel(words.light_theta, fontsize=8)
    ax.set_ylabel(words.albedo, fontsize=8)
    ax.tick_params(labelsize=7)
    ax.grid(alpha=0.3)
    # The quadrature's error note above the plot, where no curve runs: inside it, at a
    # fixed corner, a curve along the axis there crossed it (a dielectric's albedo of
    # 0.04 from 0 to 45 degrees), and the legend's free spot is no place for a line as
    # long (the steep rise at the critical angle ran through it there).
    note = words.quadrature.format(error=curve.error.max())
    ax.set_title(note, loc="left", fontsize=7, color="dimgrey")
    ax.legend(fontsize=7, loc="best", ncol=2, frameon=False)


def figure_size(
    columns: int, size: tuple[int, int] | None, dpi: int | None
) -> tuple[float, float, int]:
    """(width, height) in inches and the dpi: ``size`` in pixels is met exactly."""
    dpi = dpi or DEFAULT_DPI
    if size is not None:
        return size[0] / dpi, size[1] / dpi, dpi
    return COLUMN_INCHES[0] * columns, COLUMN_INCHES[1], dpi


@dataclass(frozen=True)
class Column:
    """Everything plotted for one material."""

    material: NamedMaterial
    lobes: list[Lobe]
    albedo: AlbedoCurve


def compute_columns(
    materials: Sequence[NamedMaterial],
    thetas_i: Sequence[float] = DEFAULT_THETAS,
    quantity: Quantity = "fcos",
    backend: Backend = "glsl",
    *,
    gl: GLContext | None = None,
) -> list[Column]:
    """Evaluate every material's lobes and albedo curve (the slow part; no files)."""
    return [
        Column(
            m,
            lobes(m, thetas_i, quantity, backend, gl=gl),
            albedo_curve(m, backend=backend, gl=gl),
        )
        for m in materials
    ]


def render_figure(
    columns: Sequence[Column],
    quantity: Quantity = "fcos",
    *,
    rgb: bool = False,
    log: bool = False,
    size: tuple[int, int] | None = None,
    dpi: int | None = None,
    backend: Backend = "glsl",
    words: FigureWords = ENGLISH,
) -> Figure:
    """A matplotlib ``Figure`` (no pyplot, no window) with one column per material, its
    words ``words`` (English by default)."""
    with figure_font(words.font, words.font_files):
        return _render_figure(columns, quantity, rgb, log, size, dpi, backend, words)


@contextmanager
def figure_font(font: tuple[str, ...] | None, font_files: tuple[str, ...] = ()) -> Iterator[None]:
    """Inside it, matplotlib draws text in the ``font`` families, each registered from
    ``font_files`` first (the walkthrough's Hangul font for its Korean figures, with its
    Latin and Greek); ``font`` None leaves matplotlib's default. Every figure of
    ``pbs brdf`` and of app/brdf/figures.py is built inside it (the font is read when
    the text artists are made)."""
    if font is None:
        yield
        return
    from matplotlib import font_manager, rc_context

    for file in font_files:
        font_manager.fontManager.addfont(file)
    with rc_context({"font.family": list(font)}):
        yield


def _render_figure(
    columns: Sequence[Column],
    quantity: Quantity,
    rgb: bool,
    log: bool,
    size: tuple[int, int] | None,
    dpi: int | None,
    backend: Backend,
    words: FigureWords,
) -> Figure:
    from matplotlib.figure import Figure

    width, height, dpi = figure_size(len(columns), size, dpi)
    fig = Figure(figsize=(width, height), dpi=dpi, layout="constrained")
    grid = fig.add_gridspec(2, len(columns), height_ratios=(1.2, 1.0))
    share = None
    for j, col in enumerate(columns):
        polar = fig.add_subplot(grid[0, j], projection="polar")
        _plot_lobes(polar, col.lobes, quantity, rgb, log, words)
        # Above the 0 degree label, in the empty upper quarter of the square polar box.
        name = _wrapped(col.material.name, width / len(columns), TITLE_POINTS)
        polar.set_title(
            f"{name}\n{_subtitle(col.material.params, words)}",
            fontsize=TITLE_POINTS,
            y=0.75,
            pad=24,
        )
        ax = fig.add_subplot(grid[1, j], sharey=share)
        share = share or ax
        _plot_albedo(ax, col.albedo, words)
    top = max(1.1, *(float(c.albedo.albedo.max()) * 1.05 for c in columns))
    share.set_ylim(0.0, top)
    where = words.glsl if backend == "glsl" else words.reference
    fig.suptitle(words.evaluated_by.format(where=where), fontsize=10)
    return fig


def save_png(fig: Figure, path: Path) -> None:
    """Write the figure as PNG atomically (a temp file beside ``path``, then a rename)."""
    with warnings.catch_warnings():  # a tiny --size: the plot is cramped, not wrong
        warnings.filterwarnings("ignore", "constrained_layout not applied", UserWarning)
        atomic_write(Path(path), lambda tmp: fig.savefig(tmp, format="png", dpi=fig.dpi))
