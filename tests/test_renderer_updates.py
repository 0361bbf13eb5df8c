"""A renderer changes without being rebuilt: after each ``set_*`` / ``resize`` / ``update`` it
renders, bit for bit, the image of a renderer built fresh from the edited scene, and it
compiles only model combinations it has not seen (the viewer moves the camera every frame
and edits materials, lights and settings live)."""

from __future__ import annotations

import copy
from collections.abc import Callable

import numpy as np
import pytest

from app.render.renderer import Renderer
from app.resources import scenes_dir
from app.scene.loader import LoadedScene, load_scene, parse_scene
from app.scene.model import Camera, Light, Material, RenderSettings

SIZE = (96, 40)


@pytest.fixture(scope="module")
def base() -> LoadedScene:
    """Punctual lights of every type over a floor and two spheres (RTR4 §9.4)."""
    return load_scene(scenes_dir() / "sec4_lights.toml")


def edited(base: LoadedScene, edit: Callable[[dict], None]) -> LoadedScene:
    """The base scene with ``edit`` applied to its data, validated as a file would be."""
    data = copy.deepcopy(base.scene.model_dump(exclude_none=True))
    edit(data)
    return parse_scene(data, base.path)


def images(r: Renderer) -> tuple[np.ndarray, np.ndarray]:
    r.render()
    return r.read_hdr(), r.read_ldr()


def updated_images(gl, start: LoadedScene, target: LoadedScene):
    """The images of a renderer of ``start`` before and after ``update(target.scene)``."""
    r = Renderer(gl, start, SIZE)
    try:
        before = images(r)
        r.update(target.scene)
        return before, images(r)
    finally:
        r.release()


def fresh_images(gl, loaded: LoadedScene, size: tuple[int, int] | None = SIZE):
    r = Renderer(gl, loaded, size)
    try:
        return images(r)
    finally:
        r.release()


def assert_same(got: tuple[np.ndarray, np.ndarray], want: tuple[np.ndarray, np.ndarray]) -> None:
    assert got[0].shape == want[0].shape
    np.testing.assert_array_equal(got[0], want[0])  # linear HDR, bit for bit
    np.testing.assert_array_equal(got[1], want[1])


def _camera(d: dict) -> None:
    d["camera"].update(position=[1.5, 3.0, 6.0], fov_y=50.0, aperture=0.08, focus_distance=6.0)


def _lights_spots_only(d: dict) -> None:
    d["lights"] = [x for x in d["lights"] if x["type"] == "spot"]


def _lights_directional_only(d: dict) -> None:
    d["lights"] = [x for x in d["lights"] if x["type"] == "directional"]


def _lights_moved(d: dict) -> None:
    for x in d["lights"]:
        if x["type"] == "point":
            x["position"][0] += 0.3
            x["intensity"] = x.get("intensity", 1.0) * 2.0


def _materials_models(d: dict) -> None:
    d["materials"]["ball"].update(ndf="beckmann", g2="separable", diffuse="burley")
    d["materials"]["floor"].update(anisotropy=0.6, roughness=0.4)  # the G-buffer gains RT3


def _materials_values(d: dict) -> None:
    d["materials"]["ball"].update(base_color=[0.9, 0.2, 0.1], metallic=1.0)


def _settings(d: dict) -> None:
    d["render"].update(tonemap="aces", terms="specular", gbuffer="f32", light_culling="none")


def _tonemap(d: dict) -> None:
    d["render"]["tonemap"] = "reinhard"


def _terms(d: dict) -> None:
    d["render"]["terms"] = "diffuse"


def _encoding(d: dict) -> None:
    d["render"]["gbuffer"] = "f16"  # new targets, and no constant surfaces


def _specular_aa(d: dict) -> None:
    d["render"].update(specular_aa=True, specular_aa_variance=2.0)


def _lens(d: dict) -> None:
    d["camera"].update(aperture=0.2, focus_distance=3.0)  # the lens alone


def _material_blended(d: dict) -> None:
    d["materials"]["ball"].update(alpha=0.4, alpha_mode="blend")  # the blend pass comes


def _supersample(d: dict) -> None:
    d["render"]["supersample"] = 2


def _transparent(d: dict) -> None:
    d["render"]["background"] = "transparent"  # straight-alpha post, no fused frame
    d["camera"]["target"] = [0.0, 6.0, -10.0]  # the floor fills the base view: show the sky


def _background(d: dict) -> None:
    d["background"] = [0.3, 0.1, 0.05]
    d["camera"]["target"] = [0.0, 6.0, -10.0]  # the floor fills the base view: show the sky


EDITS = {
    "camera": _camera,
    "spot lights only": _lights_spots_only,
    "directional light only": _lights_directional_only,
    "lights moved and brighter": _lights_moved,
    "material models": _materials_models,
    "material values": _materials_values,
    "settings": _settings,
    "tonemap": _tonemap,
    "terms": _terms,
    "gbuffer encoding": _encoding,
    "specular aa": _specular_aa,
    "lens": _lens,
    "material blended": _material_blended,
    "supersample": _supersample,
    "background": _background,
    "transparent background": _transparent,
}


@pytest.mark.parametrize("name", list(EDITS))
def test_update_renders_what_a_fresh_renderer_renders(gl_egl, base: LoadedScene, name: str):
    """``update(scene)`` after a first frame gives the fresh renderer's image exactly."""
    target = edited(base, EDITS[name])
    want = fresh_images(gl_egl, target)
    before, got = updated_images(gl_egl, base, target)
    assert_same(got, want)
    # The edit shows: the image differs from the base scene's (the test can fail).
    assert not np.array_equal(before[0], got[0]) or not np.array_equal(before[1], got[1])


# Edits the image does not show (the same image either way, by design), which must still
# leave every pass as a fresh renderer's: tiled culling on (a culler comes, the lighting
# pass binds it), normal-map filtering in a scene without normal maps (new parts).
UNSEEN = {
    "light culling": lambda d: d["render"].update(light_culling="tiled"),
    "normal filter": lambda d: d["render"].update(normal_filter="naive"),
}


@pytest.mark.parametrize("name", list(UNSEEN))
def test_an_edit_the_image_does_not_show(gl_egl, base: LoadedScene, name: str):
    """``update(scene)`` with an edit that changes passes but not the image: the fresh
    renderer's image, bit for bit."""
    target = edited(base, UNSEEN[name])
    _, got = updated_images(gl_egl, base, target)
    assert_same(got, fresh_images(gl_egl, target))


def test_each_setter_matches_a_fresh_renderer(gl_egl, base: LoadedScene):
    """The setters one after another, each checked against a fresh renderer of the scene
    edited so far."""
    steps: list[tuple[Callable[[dict], None], Callable[[Renderer, LoadedScene], None]]] = [
        (_camera, lambda r, s: r.set_camera(Camera.model_validate(s.scene.camera))),
        (
            _lights_spots_only,
            lambda r, s: r.set_lights(
                [Light.model_validate(x) for x in s.scene.lights], s.scene.environment
            ),
        ),
        (
            _materials_models,
            lambda r, s: r.set_materials(
                {k: Material.model_validate(v) for k, v in s.scene.materials.items()}
            ),
        ),
        (_settings, lambda r, s: r.set_settings(RenderSettings.model_validate(s.scene.render))),
    ]
    scene = base
    r = Renderer(gl_egl, base, SIZE)
    try:
        images(r)
        for edit, apply in steps:
            scene = edited(scene, edit)
            apply(r, scene)
            assert_same(images(r), fresh_images(gl_egl, scene))
    finally:
        r.release()


@pytest.mark.parametrize("scene", ["sec4_lights", "ibl_sky"])
def test_resize(gl_egl, scene: str):
    """``resize`` renders what a renderer built at the new size renders, and keeps what
    does not depend on the size: the G-buffer pass's geometry, the shadow maps, the
    environment's light and background (the viewer resizes at every preview/full switch)."""
    loaded = load_scene(scenes_dir() / f"{scene}.toml")
    r = Renderer(gl_egl, loaded, SIZE)
    try:
        images(r)
        kept = (r.gbuffer_pass, r.shadows, r.ibl, r.background)
        r.resize((64, 48))
        assert (r.gbuffer_pass, r.shadows, r.ibl, r.background) == kept
        got = images(r)
    finally:
        r.release()
    assert got[0].shape == (48, 64, 3)
    assert_same(got, fresh_images(gl_egl, loaded, (64, 48)))


def test_programs_are_compiled_once_per_combination(gl_egl, base: LoadedScene):
    """Going back to a model combination the renderer has shown compiles nothing, and a
    camera move compiles nothing at all."""
    other = edited(base, _materials_models)
    r = Renderer(gl_egl, base, SIZE)
    try:
        images(r)
        first = len(r.shaders)
        r.update(edited(base, _lights_moved).scene)
        r.update(base.scene)
        moved = base.scene.model_copy(
            update={"camera": base.scene.camera.model_copy(update={"position": [0.5, 5.0, 8.0]})}
        )
        r.update(moved)
        images(r)
        assert len(r.shaders) == first
        r.update(other.scene)
        images(r)
        grown = len(r.shaders)
        assert grown > first  # new model groups and a G-buffer with a tangent target
        r.update(moved)
        r.update(other.scene)
        images(r)
        assert len(r.shaders) == grown
    finally:
        r.release()


def test_a_material_value_keeps_the_geometry(gl_egl, base: LoadedScene):
    """A constant of a material without maps (what a viewer slider drags) reuses every
    mesh's vertex buffer and the shadow maps: no geometry is built or uploaded again, no
    map is drawn again, and the image is still the fresh renderer's."""
    target = edited(base, _materials_values)
    r = Renderer(gl_egl, base, SIZE)
    try:
        images(r)
        buffers = [d.vbo for d in r.gbuffer_pass.drawables]
        shadows = r.shadows
        r.update(target.scene)
        assert [d.vbo for d in r.gbuffer_pass.drawables] == buffers
        assert shadows is not None and r.shadows is shadows
        got = images(r)
    finally:
        r.release()
    assert_same(got, fresh_images(gl_egl, target))


def test_a_material_edit_keeps_the_environment(gl_egl):
    """An image-lit scene's material edit keeps the prefiltered environment and the
    background pass (nothing uploaded again); the image is the fresh renderer's."""
    sky = load_scene(scenes_dir() / "ibl_sky.toml")
    name = next(iter(sky.scene.materials))
    target = edited(sky, lambda d: d["materials"][name].update(roughness=0.77))
    r = Renderer(gl_egl, sky, SIZE)
    try:
        images(r)
        kept = (r.ibl, r.background)
        r.update(target.scene)
        assert None not in kept and (r.ibl, r.background) == kept
        got = images(r)
    finally:
        r.release()
    assert_same(got, fresh_images(gl_egl, target))


def test_a_part_turned_blended_draws_the_shadow_maps_again(gl_egl, base: LoadedScene):
    """A material edit that makes a part blended takes it out of the shadow maps' casters
    (blended parts cast none, docs/shadows.md): the maps are made again, and the image
    is the fresh renderer's."""
    target = edited(base, lambda d: d["materials"]["ball"].update(alpha=0.5, alpha_mode="blend"))
    r = Renderer(gl_egl, base, SIZE)
    try:
        images(r)
        shadows = r.shadows
        r.update(target.scene)
        assert r.shadows is not None and r.shadows is not shadows
        got = images(r)
    finally:
        r.release()
    assert_same(got, fresh_images(gl_egl, target))


def test_a_map_removed_by_an_edit_is_gone(gl_egl, base: LoadedScene):
    """A material that loses its base colour map by an edit is drawn without it: the
    part's layer, built with the map, is built again (before, the edit kept the mapped
    layer and the image showed the old map)."""
    mapped = edited(
        base, lambda d: d["materials"]["floor"].update(base_color_map="textures/noise.png")
    )
    with_map, got = updated_images(gl_egl, mapped, base)
    want = fresh_images(gl_egl, base)
    assert not np.array_equal(with_map[1], want[1])  # the map shows
    assert_same(got, want)
