"""Where the lighting pass reads its lights (app/render/lighting.py ``LIGHT_FORMS``): a
uniform array where the scene's lights fit the context's fragment uniform vectors, the
light texture beyond. Both forms hand the shader the same float32 texels, so the image
is the same bit for bit, culled or not, over one chunk of the tile masks and over two;
the form follows the queried limit; and programs shared by two scenes of one light count
(the shader cache) each shade with their own scene's lights. A frame without spot lights
compiles the cone out of the loop (SPOT_LIGHTS), one with a spot keeps it.
"""

from __future__ import annotations

import numpy as np
import pytest

from app.gl.shaders import ShaderCache
from app.render.lighting import light_form
from app.render.renderer import Renderer, RenderOptions
from app.scene.loader import parse_scene
from tests.test_culling import many_lights_scene

SIZE = (160, 90)


def render(gl, data: dict, form: str | None = None, shaders: ShaderCache | None = None):
    """The HDR image of ``data`` and its renderer (released by the caller)."""
    r = Renderer(gl, parse_scene(data, "forms.toml"), options=RenderOptions(light_form=form),
                 shaders=shaders)  # fmt: skip
    r.render()
    return r.read_hdr(), r


@pytest.mark.parametrize(("culling", "count"), [("tiled", 40), ("none", 40), ("tiled", 1100)])
def test_uniform_array_and_texture_give_identical_images(gl_egl, culling: str, count: int):
    data = many_lights_scene(count, culling, SIZE)  # 1100 lights: two chunks of the masks
    by_texture, r1 = render(gl_egl, data, "texture")
    by_uniforms, r2 = render(gl_egl, data, "uniform")
    try:
        assert (r1.lighting.form, r2.lighting.form) == ("texture", "uniform")
        assert np.isfinite(by_texture).all() and by_texture.max() > 0.5
        assert np.array_equal(by_uniforms, by_texture)
    finally:
        r1.release()
        r2.release()


def test_form_follows_the_context_uniform_limit(gl_egl):
    ctx = gl_egl.ctx
    vectors = int(ctx.info["GL_MAX_FRAGMENT_UNIFORM_VECTORS"])
    fits = [n for n in range(1, vectors) if light_form(ctx, n) == "uniform"]
    assert fits and fits == list(range(1, len(fits) + 1))  # every count up to a bound
    assert 3 * len(fits) <= vectors  # three vectors per light, within the queried limit
    assert len(fits) > vectors // 4  # and not a bound far below it
    # A shadow map's matrix and parameters take room from the lights.
    assert light_form(ctx, len(fits), shadow_maps=8) == "texture"
    # The renderer chooses by the scene's light count (one directional light besides).
    for count, form in ((40, "uniform"), (len(fits), "texture")):
        image, r = render(gl_egl, many_lights_scene(count, "tiled", SIZE))
        try:
            assert r.lighting.form == form
            assert np.isfinite(image).all()
        finally:
            r.release()


def test_shared_programs_shade_each_scene_with_its_own_lights(gl_egl):
    data = many_lights_scene(40, "tiled", SIZE)
    dimmer = {**data, "lights": [{**light, "intensity": 0.5 * light["intensity"]}
                                 for light in data["lights"]]}  # fmt: skip
    alone, r0 = render(gl_egl, dimmer, "uniform")
    r0.release()
    shaders = ShaderCache(gl_egl.ctx)
    bright, r1 = render(gl_egl, data, "uniform", shaders)
    dim, r2 = render(gl_egl, dimmer, "uniform", shaders)
    try:
        assert r1.lighting.programs[0] is r2.lighting.programs[0]  # one program, two scenes
        r1.render()  # after the dimmer scene's frame: its own lights again
        assert np.array_equal(r1.read_hdr(), bright)
        assert np.array_equal(dim, alone)
        assert not np.array_equal(dim, bright)
    finally:
        r1.release()
        r2.release()
        shaders.release()


def test_uniform_array_the_driver_refuses_falls_back_to_the_texture(gl_egl, monkeypatch):
    """Where the driver counts the pass's other uniforms differently, the array may not
    link though ``light_form`` chose it: the pass then builds the texture form."""
    vectors = int(gl_egl.ctx.info["GL_MAX_FRAGMENT_UNIFORM_VECTORS"])
    count = vectors // 3 + 1  # one directional light besides: 3 (count + 1) > the limit
    monkeypatch.setattr("app.render.lighting._OTHER_VECTORS", -3 * vectors)  # no reserve
    assert light_form(gl_egl.ctx, count + 1) == "uniform"
    data = many_lights_scene(count, "tiled", SIZE)
    image, r = render(gl_egl, data)
    try:
        assert r.lighting.form == "texture"
        with pytest.raises(Exception, match="uniform"):  # forced, the array is refused
            Renderer(gl_egl, parse_scene(data, "forms.toml"),
                     options=RenderOptions(light_form="uniform"))  # fmt: skip
        expected, r2 = render(gl_egl, data, "texture")
        r2.release()
        assert np.array_equal(image, expected)
    finally:
        r.release()


def test_spot_cone_compiled_in_only_where_the_frame_has_a_spot(gl_egl):
    """SPOT_LIGHTS (app/render/inputs.py LightInput, glsl/lights/punctual.glsl): a frame of
    point lights compiles the cone out of the light loop; one spot light brings it back,
    and its cone still darkens what lies outside it."""
    mixed = many_lights_scene(8, "none", SIZE)  # lights 0 and 4 are spots
    points = {**mixed, "lights": [
        {k: v for k, v in light.items() if k != "direction"} | {"type": "point"}
        if light["type"] == "spot" else light
        for light in mixed["lights"]
    ]}  # fmt: skip
    with_spots, r1 = render(gl_egl, mixed)
    without, r2 = render(gl_egl, points)
    try:
        assert r1.lighting.context.defines()["SPOT_LIGHTS"] == 1
        assert r2.lighting.context.defines()["SPOT_LIGHTS"] == 0
        assert np.isfinite(with_spots).all() and np.isfinite(without).all()
        # the spots' cones cut light that the same lights as points give
        assert (with_spots <= without + 1e-6).all() and (with_spots < without - 1e-3).any()
    finally:
        r1.release()
        r2.release()
