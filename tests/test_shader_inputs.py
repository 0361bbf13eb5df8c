"""The shader-input contract (app/render/inputs.py) and the full-screen base
(app/gl/fullscreen.py): a context's defines are the union of its inputs'; the renderer's
frame context holds the G-buffer, lights, material table, lookup tables, culler,
environment light and shadow maps, each an input of its own role; a new input added to
a context is compiled into the lighting programs and bound at every draw without moving
a pixel; a pass given a context without an input it needs refuses by name; and every
full-screen draw of the passes goes through ``FullscreenDraw``.
"""

from __future__ import annotations

import numpy as np
import pytest

from app.gl.fullscreen import FullscreenDraw
from app.render.blend import BlendPass
from app.render.culling import LightCuller
from app.render.ibl import EnvironmentLighting, UniformEnvironment
from app.render.inputs import (
    ENVIRONMENT,
    GBUFFER,
    LIGHTS,
    MATERIALS,
    SHADOWS,
    TILES,
    MissingInputError,
    ShaderInput,
    ShadingContext,
)
from app.render.lighting import LightingPass
from app.render.renderer import Renderer
from app.render.shadows import ShadowPass
from app.scene.loader import parse_scene
from tests.conftest import REPO

SIZE = (64, 48)


class Probe(ShaderInput):
    """A stand-in input: its own define and uniform-free binding, recorded."""

    def __init__(self, role: str, defines: dict[str, int]) -> None:
        self.role = role
        self._defines = defines
        self.bound: list[object] = []

    def defines(self) -> dict[str, int]:
        return dict(self._defines)

    def uniforms(self, program) -> None:
        self.bound.append(program)


def test_context_defines_are_the_union_of_its_inputs():
    a, b = Probe("a", {"A": 1, "SHARED": 2}), Probe("b", {"B": 3, "SHARED": 2})
    context = ShadingContext([a, b])
    assert context.defines() == {"A": 1, "B": 3, "SHARED": 2}
    assert context.only("b").defines() == {"B": 3, "SHARED": 2}
    c = Probe("c", {"C": 4})
    assert context.with_inputs(c).defines() == {"A": 1, "B": 3, "SHARED": 2, "C": 4}
    assert context.with_inputs(Probe("a", {})).defines() == {"B": 3, "SHARED": 2}  # replaced
    with pytest.raises(ValueError, match="SHARED"):  # one name, two values
        ShadingContext([a, Probe("c", {"SHARED": 5})]).defines()
    with pytest.raises(ValueError, match="role 'a'"):
        ShadingContext([a, Probe("a", {})])


def scene(environment: str) -> dict:
    """Tiled local lights, a shadowed spot light and an environment: every kind of input."""
    lights = [
        {"type": "point", "position": [x, 1.5, z], "color": [1.0, 0.9, 0.8],
         "intensity": 4.0, "range": 4.0}
        for x in (-1.0, 0.0, 1.0) for z in (-1.0, 0.0, 1.0)
    ]  # fmt: skip
    lights.append({"type": "spot", "position": [0.0, 3.0, 1.0], "direction": [0.0, -1.0, -0.3],
                   "color": [1.0, 1.0, 1.0], "intensity": 30.0, "range": 10.0,
                   "shadow": True})  # fmt: skip
    env = {"source": environment}
    if environment == "uniform":
        env["radiance"] = [0.2, 0.3, 0.4]
    return {
        "camera": {"position": [0.0, 2.0, 4.0], "target": [0.0, 0.0, 0.0], "fov_y": 50.0},
        "render": {"width": SIZE[0], "height": SIZE[1], "light_culling": "tiled"},
        "environment": env,
        "materials": {"m": {"base_color": [0.8, 0.5, 0.3], "roughness": 0.4}},
        "objects": [
            {"shape": "sphere", "radius": 0.6, "material": "m", "position": [0.0, 0.6, 0.0]},
            {"shape": "plane", "size": [6.0, 6.0], "material": "m"},
        ],
        "lights": lights,
    }


@pytest.fixture(scope="module")
def renderer(gl_egl):
    r = Renderer(gl_egl, parse_scene(scene("sky"), "inputs.toml"))
    r.render()
    yield r
    r.release()


def test_the_frame_context_holds_every_input_of_its_role(renderer):
    r = renderer
    context = r.shading
    assert set(context.roles) >= {GBUFFER, LIGHTS, MATERIALS, TILES, ENVIRONMENT, SHADOWS}
    assert isinstance(context[TILES], LightCuller) and context[TILES] is r.culler
    assert isinstance(context[ENVIRONMENT], EnvironmentLighting) and context[ENVIRONMENT] is r.ibl
    assert isinstance(context[SHADOWS], ShadowPass) and context[SHADOWS] is r.shadows
    assert context[GBUFFER].gbuffer is r.gbuffer
    union: dict[str, int] = {}
    for role in context.roles:
        union |= context[role].defines()
    assert context.defines() == union
    # Every lighting program is compiled with them (the lights in the pass's own form).
    for variant in r.lighting._variants:
        assert variant.items() >= union.items()


def test_uniform_environment_is_an_input_of_the_same_role(gl_egl):
    r = Renderer(gl_egl, parse_scene(scene("uniform"), "inputs.toml"))
    try:
        assert isinstance(r.shading[ENVIRONMENT], UniformEnvironment)
        assert r.shading.defines()["ENVIRONMENT_UNIFORM"] == 1
    finally:
        r.release()


def test_an_added_input_is_compiled_in_and_bound_without_moving_a_pixel(renderer):
    r = renderer
    expected = r.read_hdr()
    probe = Probe("probe", {"PROBE_INPUT": 1})  # read by no GLSL: the image is the same
    lighting = LightingPass(
        r.gl.ctx, r.shaders, r.render_size, r.shading.with_inputs(probe),
        r.scene.render.terms, form=r.lighting.form,
    )  # fmt: skip
    try:
        assert all(v["PROBE_INPUT"] == 1 for v in lighting._variants)
        assert not set(lighting.programs) & set(r.lighting.programs)  # programs of their own
        lighting.run(r.gbuffer, r.camera, np.asarray(r.scene.background))
        assert probe.bound == lighting.programs  # bound for each program, once a draw
        assert np.array_equal(lighting.read(), expected)
    finally:
        lighting.hdr.release()
        lighting.fbo.release()
        for draw in lighting.draws:
            draw.release()


@pytest.mark.parametrize("missing", [GBUFFER, LIGHTS, MATERIALS])
def test_a_lighting_pass_without_an_input_it_needs_refuses_by_name(renderer, missing):
    r = renderer
    context = r.shading.only(*(role for role in r.shading.roles if role != missing))
    with pytest.raises(MissingInputError, match=rf"lighting pass needs .*'{missing}'"):
        LightingPass(r.gl.ctx, r.shaders, r.render_size, context)


def test_a_blend_pass_without_the_lights_refuses_and_binding_needs_use(renderer):
    r = renderer
    with pytest.raises(MissingInputError, match=r"blend pass needs .*'lights'"):
        BlendPass(r.gl.ctx, [], r.shading.only(MATERIALS))
    with pytest.raises(RuntimeError, match="use"):
        ShadingContext([Probe("p", {})]).bind(r.lighting.programs[0])


def test_every_fullscreen_draw_of_the_passes_goes_through_the_base():
    """Only app/gl/fullscreen.py draws the 3-vertex triangle; the viewer's window blits its
    image through it too, with a program of its own (inline shaders, a sampler object)."""
    drawing = sorted(
        str(path.relative_to(REPO))
        for path in (REPO / "app").rglob("*.py")
        if "vertices=3" in path.read_text(encoding="utf-8")
    )
    assert drawing == ["app/gl/fullscreen.py"]


def test_a_fullscreen_draw_far_plane_triangle_runs_only_where_z_is_nearer(gl_egl):
    """FAR_PLANE with depth_func ">": pixels whose z-buffer holds 1 (nothing drawn) are
    skipped; the state after the draw has no depth test."""
    ctx = gl_egl.ctx
    from app.gl.shaders import ShaderCache

    shaders = ShaderCache(ctx)
    colour = ctx.texture((4, 1), 4, dtype="f4")
    depth = ctx.depth_renderbuffer((4, 1))
    fbo = ctx.framebuffer([colour], depth)
    hdr = ctx.texture((4, 1), 4, np.ones((1, 4, 4), np.float32).tobytes(), dtype="f4")
    draw = FullscreenDraw.of(ctx, shaders, "passes/post.frag", {"TONEMAP": 0, "FAR_PLANE": 1})
    try:
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        fbo.clear(depth=0.5, viewport=(0, 0, 2, 1))  # "surfaces" in the left two pixels
        fbo.depth_mask = False
        draw.draw(fbo, {"u_exposure": 1.0}, {"u_hdr": hdr}, depth_func=">")
        drawn = np.frombuffer(colour.read(), np.float32).reshape(4, 4)[:, 3]
        assert drawn.tolist() == [1.0, 1.0, 0.0, 0.0]
    finally:
        for obj in (draw, fbo, depth, colour, hdr):
            obj.release()
        shaders.release()
