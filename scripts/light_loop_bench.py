"""The light-loop steps, timed interleaved against each other and the limit pass.

    .venv/bin/python scripts/light_loop_bench.py [LIGHTS] [WxH] [ROUNDS] [VARIANTS]

LIGHTS (default 256) lights in the culling suite's scene (app/bench/scenes.py, range
calibrated to ~16 lights per surface pixel), WxH (default 1280x720), ROUNDS (default 7)
rounds of ``time_interleaved`` (app/bench/timing.py), one frame of each variant per round.
VARIANTS (default ``texture,uniform``) are comma-separated lighting-pass forms
(``RenderOptions.light_form``), each optionally followed by ``:NAME`` or ``:NAME=VALUE``
defines added to the lighting programs only, to time a shader step before it is made the
default. Prints each variant's lighting and cull medians, its per-round ratio (median and
range) against the limit pass (app/bench/limit.py) and against the variant before it,
and whether its HDR image equals the first variant's bit for bit.

LIGHTS ``peers:N`` times the peers suite's scene instead (app/bench/peers.py
``peers_scene``: 35 mesh spheres and a floor, every light reaching every pixel) at 1 and N
lights for each variant, all interleaved, and prints each variant's lighting pass per
light, (t_N - t_1) / (N - 1) per round, against the first variant's: what a change to
the loop saves per light where no tile culls any.
"""

from __future__ import annotations

import copy
import statistics
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import app.render.lighting as lighting_module
from app.bench.context import deferred_passes
from app.bench.limit import LimitPass
from app.bench.pairs import light_pairs
from app.bench.scenes import calibrate_range, load, many_lights_scene
from app.bench.timing import Budget, Pass, round_ratios, time_interleaved
from app.gl.context import GLContext, create_context
from app.render.renderer import Renderer, RenderOptions
from app.scene.loader import LoadedScene


def variant_renderer(
    gl: GLContext, loaded: LoadedScene, size: tuple[int, int], variant: str
) -> Renderer:
    """A renderer whose lighting pass reads its lights in ``variant``'s form, with its
    extra defines (``form:NAME=VALUE:...``) added to the lighting programs."""
    form, *flags = variant.split(":")
    extra: dict[str, int] = {}
    for flag in flags:
        name, _, value = flag.partition("=")
        extra[name] = int(value or 1)
    plain = lighting_module._draws

    def draws(ctx, shaders, variants, lights):  # the extra defines win over the lights' own
        view = copy.copy(lights)
        view.defines = lambda: {**lights.defines(), **extra}
        return plain(ctx, shaders, variants, view)

    lighting_module._draws = draws
    try:
        return Renderer(gl, loaded, size, options=RenderOptions(light_form=form))
    finally:
        lighting_module._draws = plain


def ratio_text(r: dict[str, float] | None) -> str:
    """A per-round ratio as "median (min-max)"."""
    if r is None:
        return "no rounds"
    return f"{r['median']:.3f} ({r['min']:.3f}-{r['max']:.3f})"


def per_light(gl: GLContext, count: int, size: tuple[int, int], rounds: int,
              variants: list[str]) -> None:  # fmt: skip
    """The peers scene at 1 and ``count`` lights per variant, interleaved: each variant's
    lighting pass per light against the first variant's, per round."""
    from app.bench.peers import peers_scene

    renderers = {
        (v, n): variant_renderer(gl, load(peers_scene(n, size)), size, v)
        for v in variants
        for n in (1, count)
    }
    frames = {f"{v}@{n}": deferred_passes(r) for (v, n), r in renderers.items()}
    times = time_interleaved(gl, frames, Budget(1, rounds, rounds, 0.0), None)

    def light_ms(v: str) -> list[float]:
        one, many = times[f"{v}@1"].pass_ms["lighting"], times[f"{v}@{count}"].pass_ms["lighting"]
        return [(b - a) / (count - 1) for a, b in zip(one, many, strict=True)]

    first = variants[0]
    print(f"peers scene, 1 and {count} lights, {size[0]}x{size[1]}, {rounds} rounds")
    for v in variants:
        cost = light_ms(v)
        one = statistics.median(times[f"{v}@1"].pass_ms["lighting"])
        print(f"{v}: lighting at 1 light {one:.1f} ms, per light {statistics.median(cost):.2f} ms")
        if v != first:
            ratios = [a / b for a, b in zip(cost, light_ms(first), strict=True) if b > 0.0]
            spread = {"median": statistics.median(ratios), "min": min(ratios), "max": max(ratios)}
            print(f"  per light / {first}'s", ratio_text(spread))
            print("  lighting at 1 light / first's", ratio_text(round_ratios(
                times[f"{v}@1"], times[f"{first}@1"], ("lighting",), ("lighting",))))  # fmt: skip
            for n in (1, count):
                same = renderers[(v, n)].read_hdr(), renderers[(first, n)].read_hdr()
                print(f"  image at {n} equal to {first}'s", np.array_equal(*same))
    for r in renderers.values():
        r.release()


def main(argv: list[str]) -> None:
    """Build the variants and the limit pass, time them interleaved, print the ratios."""
    w, h = (int(x) for x in (argv[1] if len(argv) > 1 else "1280x720").split("x"))
    rounds = int(argv[2]) if len(argv) > 2 else 7
    variants = argv[3].split(",") if len(argv) > 3 else ["texture", "uniform"]
    gl = create_context()
    if argv and argv[0].startswith("peers:"):
        per_light(gl, int(argv[0].split(":")[1]), (w, h), rounds, variants)
        return
    count = int(argv[0]) if argv else 256
    loaded = load(many_lights_scene(count, calibrate_range(gl, count, 16.0), (w, h)))
    renderers = {v: variant_renderer(gl, loaded, (w, h), v) for v in variants}
    first = renderers[variants[0]]
    gb = first.gbuffer_pass
    gb.run(first.gbuffer, first.view, first.proj, first.camera)
    pairs = light_pairs(first.read_gbuffer(), first.camera, first.lights)
    limit = LimitPass(first, pairs)
    frames = {v: deferred_passes(r) for v, r in renderers.items()}
    frames["limit"] = [
        Pass("gbuffer", lambda: gb.run(first.gbuffer, first.view, first.proj, first.camera),
             first.gbuffer.fbo),
        Pass("limit", limit.run, limit.fbo),
    ]  # fmt: skip
    times = time_interleaved(gl, frames, Budget(1, rounds, rounds, 0.0), None)
    limit_ms = statistics.median(times["limit"].pass_ms["limit"])
    print(f"{count} lights, {w}x{h}, {pairs.mean_per_covered_pixel:.2f} per covered pixel, "
          f"{rounds} rounds; limit pass {limit_ms:.1f} ms")  # fmt: skip
    images = {v: r.read_hdr() for v, r in renderers.items()}
    for k, v in enumerate(variants):
        t = times[v]
        print(f"{v}: lighting {statistics.median(t.pass_ms['lighting']):.1f} ms, "
              f"cull {statistics.median(t.pass_ms['cull']):.1f} ms")  # fmt: skip
        print("  cull+lighting / limit", ratio_text(
            round_ratios(t, times["limit"], ("cull", "lighting"), ("limit",))))  # fmt: skip
        print("  lighting / limit", ratio_text(
            round_ratios(t, times["limit"], ("lighting",), ("limit",))))  # fmt: skip
        if k:
            before = variants[k - 1]
            print(f"  lighting / {before}'s", ratio_text(
                round_ratios(t, times[before], ("lighting",), ("lighting",))))  # fmt: skip
            print("  image equal to", variants[0], np.array_equal(images[v], images[variants[0]]))
    for obj in (limit, *renderers.values()):
        obj.release()


if __name__ == "__main__":
    main(sys.argv[1:])
