"""The pyrender comparison: the 35-sphere scene, render plus read-back per frame.

``sphere_grid_scene``: a 7 x 5 grid of spheres of radius 0.5 m, 1.2 m apart, in the plane
z = 0, seen from 9 m along +z with a 45 degree vertical field of view; roughness sweeps
0.1-0.9 along a row and the rows alternate dielectric and metal (mixed metallic and
roughness); ``lights`` point lights of range 100 m in front of the grid, no floor. The
spheres are icospheres of subdivision 4 (5,120 triangles) in both renderers: pbs draws the
same triangles pyrender is given (app/bench/pyrender_child.py builds them with
app.scene.geometry.build_parts). pyrender shades at most 4 lights of each type, so the
comparison stops at 4.

``run_pyrender_spheres`` (part of the culling suite): for each light count, pbs frames
(``Renderer.render`` then ``read_ldr``, split into its passes: the G-buffer, the tile
culling, lighting, post and the 8-bit read-back, each ended by glFinish) alternate with
pyrender's, rendered by a served child process (app/bench/peer_child.py, the peers'
protocol; each ``render()`` returns colour and depth in numpy), one frame of each per
round with the order rotated (timing.time_interleaved), so a change of the machine's
load falls on both; the ratio pyrender/pbs is taken per round. (Timing the two in blocks of frames,
the first version, gave 1.3-3.0x at 1 light within one run on the loaded machine.)
"""

from __future__ import annotations

import tempfile
from pathlib import Path

from app.bench.context import Context, Settings, deferred_passes, make_row
from app.bench.peer_child import PeerChild
from app.bench.report import SPHERES_CASE, SPHERES_PYRENDER
from app.bench.scenes import load
from app.bench.sphere_grid import SUBDIVISIONS, sphere_grid
from app.bench.timing import Pass, round_ratios
from app.render.renderer import Renderer

CASE = SPHERES_CASE
PBS = "pbs render+read-back"
PYRENDER = SPHERES_PYRENDER


def sphere_grid_scene(lights: int, size: tuple[int, int]) -> dict:
    """The 35-sphere scene with ``lights`` (1-4) white point lights in front."""
    materials, objects = sphere_grid(on_floor=False)
    spots = ([-3.0, 2.5, 5.0], [3.0, 2.5, 5.0], [-3.0, -2.5, 5.0], [3.0, -2.5, 5.0])
    return {
        "camera": {"position": [0.0, 0.0, 9.0], "target": [0.0, 0.0, 0.0], "fov_y": 45.0},
        "render": {"width": size[0], "height": size[1]},
        "materials": materials,
        "lights": [
            {"type": "point", "position": list(p), "intensity": 12.0, "range": 100.0}
            for p in spots[:lights]
        ],
        "objects": objects,
    }


def pbs_frame_passes(r: Renderer) -> list[Pass]:
    """A whole frame to the caller's 8-bit image, pass by pass: G-buffer, tile culling,
    lighting, post (exposure, tone map, sRGB; fused into lighting in a plain frame), the
    display image's FXAA where ``render.antialiasing = "fxaa"``, its geometric edge
    resolve where ``"gbaa"`` (the default) and the read-back. The scene must have no
    depth of field, supersampling, jittered accumulation, blended parts, shadows or an
    environment background (what ``Renderer.render`` adds for those is not here)."""
    extra = (r.dof, r.resolve, r.accumulate, r.blend, r.shadows, r.background)
    if any(x is not None for x in extra):
        raise ValueError("pbs_frame_passes: a scene with depth of field, supersampling, "
                         "accumulation, blended parts, shadows or an environment")  # fmt: skip
    *passes, _ = deferred_passes(r)
    # as Renderer.render runs them: the lighting pass writes the display image itself
    # where the frame is plain (Renderer.fused_display), else the post pass follows
    lit = r.post.fbo if r.fused_display else r.lighting.fbo
    passes.append(Pass("lighting", r.run_lighting, lit))
    if not r.fused_display:
        passes.append(Pass("post", lambda: r.run_post(r.lighting.hdr), r.post.fbo))
    fxaa = r.fxaa
    if fxaa is not None:
        passes.append(Pass("fxaa", lambda: fxaa.run(r.post.target), r.post.fbo))
    if r.gbaa is not None:  # the HDR image the lighting pass wrote (not read where fused)
        passes.append(Pass("gbaa", lambda: r.resolve_edges(r.lighting.hdr), r.post.fbo))
    return [*passes, Pass("read-back", r.read_ldr)]


def run_pyrender_spheres(ctx: Context) -> None:
    """The comparison's rows: per light count, ``pbs`` and ``pyrender``, one frame of each
    in turn (timing.time_interleaved, pyrender's frame a request to its served child),
    with the ratio pyrender/pbs per round."""
    s = ctx.settings
    size = s.culling_size
    for count in s.pyrender_sphere_lights:
        data = sphere_grid_scene(count, size)
        ctx.progress.start(f"culling {CASE}, {count} light(s): pbs and pyrender, interleaved")
        r = Renderer(ctx.gl, load(data), size)
        child = None
        try:
            with tempfile.TemporaryDirectory(prefix="pbs-spheres-") as tmp:
                child = PeerChild("pyrender", data, size, Path(tmp) / "pyrender.npy")
                times = ctx.time_interleaved(
                    {PBS: pbs_frame_passes(r), PYRENDER: [Pass("render()", child.frame)]}
                )
                result = child.finish()
        except (OSError, RuntimeError) as exc:
            ctx.notes.append(f"pyrender ({CASE}, {count} lights): {exc}")
            continue
        finally:
            if child is not None:
                child.close()
            r.release()
            ctx.progress.done()
        common = {
            "pyrender_over_pbs": round_ratios(times[PYRENDER], times[PBS]),
            "triangles_per_sphere": 20 * 4**SUBDIVISIONS,
        }
        ctx.rows.append(make_row("culling", CASE, PBS, size, count, times[PBS], **common))
        ctx.rows.append(
            make_row("culling", CASE, PYRENDER, size, count, times[PYRENDER], pyrender=result,
                     timer="wall clock around a frame request to the served child: render()"
                     " with colour+depth read-back, and the pipe's round trip", **common)
        )  # fmt: skip


def sphere_tasks(settings: Settings, pyrender: bool) -> int:
    """Progress tasks: one per light count, with pyrender only."""
    return len(settings.pyrender_sphere_lights) if pyrender else 0
