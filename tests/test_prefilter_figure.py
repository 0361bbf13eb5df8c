"""The walkthrough's figure of the environment prefilter (step 4, plot kind "prefilter"):
the exact integral it is measured against, the renderer's Monte Carlo converging to it,
the figure built through the handout's plot path, and the viewer's label and command of
every plot kind (app/viewer/lesson.py ``plot_command``)."""

from __future__ import annotations

import math
import shlex
import tomllib
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from app.brdf import figures
from app.gl.context import GLContext
from app.reference.environment import texel_directions
from app.reference.ibl import prefiltered_radiance
from app.walkthrough.build import render_plot
from app.walkthrough.model import Plot

STEPS = Path(__file__).resolve().parents[1] / "walkthrough"
METAL = "{{ base_color = [0.9, 0.9, 0.9], metallic = 1.0, roughness = {r} }}"


def _lobe_mean_of_cosine(r: float) -> float:
    """L_pre(R) for the environment L(l) = (R.l)+, by a 1D quadrature over the half
    vector's angle: with n = v = R, l = 2(R.h)h - R, R.l = 2c^2 - 1 (c = cos theta_h) and
    dl = 4 (R.h) dh, so L_pre = int D (2c^2-1)^2 c sin / int D (2c^2-1) c sin over
    theta_h in [0, pi/4] (the lobe's weights D(h) (R.l)+, each texel's solid angle)."""
    a2 = r**4
    theta = (np.arange(200_000) + 0.5) * (math.pi / 4) / 200_000
    c = np.cos(theta)
    d = a2 / (math.pi * (c * c * (a2 - 1.0) + 1.0) ** 2)
    w = d * (2.0 * c * c - 1.0) * c * np.sin(theta)
    return float(np.sum(w * (2.0 * c * c - 1.0)) / np.sum(w))


@pytest.mark.parametrize("r", [0.3, 0.6, 0.9])
def test_exact_prefilter_of_a_cosine_environment(r: float) -> None:
    """The texel sum of an environment that is the cosine about a tilted R equals the 1D
    integral of the lobe: the GGX weight, the (R.l)+ weight and each texel's solid angle
    all count (any one dropped moves the sum by more than the tolerance)."""
    R = np.array([0.6, 0.48, 0.64])
    R /= np.linalg.norm(R)
    d, _ = texel_directions(256, 512)
    env = np.repeat(np.maximum(d @ R, 0.0)[..., None], 3, -1)
    got = prefiltered_radiance(env, 0.0, R, r)
    want = _lobe_mean_of_cosine(r)
    assert np.allclose(got, want, rtol=2e-3), (got, want)


def test_exact_prefilter_of_a_constant_is_the_constant() -> None:
    env = np.full((32, 64, 3), 1.7)
    d = figures.strip_directions(8, 2).reshape(-1, 3)
    assert np.allclose(prefiltered_radiance(env, 0.0, d, 0.5), 1.7, rtol=1e-12)


def test_renderer_monte_carlo_converges_to_the_exact_integral(gl_egl: GLContext) -> None:
    """The GLSL prefilter along the figure's strip: far from the texel sum with one
    sample, within 1.5 % RMS with 1,024 (the filtered importance sampling's bias and the
    bilinear source stay), the error falling with N (measured: docs/ibl.md)."""
    strip = figures.prefilter_strip(gl_egl, [0.5], (1, 64, 1024))
    err = strip.errors[0]
    assert err[0] > 0.05 and err[2] < 0.015 and err[2] < err[1] < err[0], err
    assert strip.exact.shape == strip.estimates.shape[::2] == (1, 4 * figures.PREFILTER_FACE)
    assert np.all(np.diff(strip.azimuth) > 0.0)


def test_prefilter_figure_builds(gl_egl: GLContext, tmp_path: Path) -> None:
    """The handout's plot path draws the figure (one panel per roughness, the error plot)."""
    plot = Plot(kind="prefilter", materials=[METAL.format(r=0.3), METAL.format(r=0.7)])
    path = tmp_path / "prefilter.png"
    render_plot(gl_egl, plot, (480, 270), path)
    image = np.asarray(Image.open(path).convert("L"))
    assert image.shape[0] > 200 and image.shape[1] > 200
    assert (image < 128).mean() > 0.01  # ink: curves, axes, words


def test_every_plot_names_its_kind_and_a_command_that_parses() -> None:
    """The viewer's line under each plot of the 13 steps: ``pbs brdf`` (which parses, -o
    included) only for the lobes; a figure of app/brdf/figures.py names itself and the
    ``pbs walkthrough`` of its step, in both languages."""
    from app.cli import _parser
    from app.viewer.lesson import PLOT_KINDS, plot_command

    kinds = set()
    for path in sorted(STEPS.glob("*.toml")):
        step = tomllib.loads(path.read_text(encoding="utf-8"))
        for plot in (Plot.model_validate(p) for p in step.get("plots", [])):
            kinds.add(plot.kind)
            for lang in ("en", "ko"):
                what, command = plot_command(plot, step["section"], lang)
                assert what.startswith(PLOT_KINDS[plot.kind][lang])
                args = _parser().parse_args(shlex.split(command)[1:])
                if plot.kind == "lobes":
                    assert args.command == "brdf" and args.materials == plot.materials
                else:
                    assert args.command == "walkthrough" and args.steps == {step["section"]}
    assert kinds == {"lobes", "vndf", "layered_furnace", "prefilter"}
