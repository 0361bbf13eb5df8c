"""The renderer as a scheduler (app/render/renderer.py ``SCHEDULE``): each kind of edit
builds again exactly the objects whose key reads what it changed, and those that need a
rebuilt one, and no other; every other object is the very object it was. Counted with
``Renderer.builds``, and each edited renderer's images are checked, bit for bit, against
a renderer built fresh from the edited scene (a key too narrow would keep a stale object
there; one too broad shows in the counts)."""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Callable

import numpy as np
import pytest

from app.errors import InputError
from app.render.renderer import SCHEDULE, Renderer, RenderOptions
from app.resources import scenes_dir
from app.scene.loader import LoadedScene, parse_scene
from app.scene.model import Environment, Light, Material, RenderSettings

SIZE = (64, 40)
NAMES = tuple(b.name for b in SCHEDULE)


def scene_data() -> dict:
    """A floor and a ball under a shadowing sun and a point light (tiled culling, so the
    culler exists), lit by a sky that is also drawn behind them: every object of the
    schedule but depth of field, the resolve and the blend pass, which edits add."""
    return {
        "background": [0.02, 0.02, 0.03],
        "render": {"width": SIZE[0], "height": SIZE[1], "light_culling": "tiled"},
        "camera": {"position": [0.0, 2.0, 5.0], "target": [0.0, 0.4, 0.0], "fov_y": 45.0},
        "materials": {
            "floor": {"base_color": [0.5, 0.5, 0.5], "roughness": 0.7},
            "ball": {"base_color": [0.8, 0.3, 0.2], "roughness": 0.35},
        },
        "objects": [
            {"shape": "plane", "size": [20.0, 20.0], "material": "floor"},
            {"shape": "sphere", "radius": 0.6, "position": [0.0, 0.6, 0.0], "material": "ball"},
        ],
        "lights": [
            {"type": "directional", "direction": [0.3, -1.0, -0.4], "intensity": 2.0,
             "shadow": True, "shadow_resolution": 256},
            {"type": "point", "position": [1.0, 1.0, 1.5], "intensity": 3.0, "range": 4.0},
        ],
        "environment": {"source": "sky", "sun_direction": [0.5, 0.6, -0.6], "intensity": 0.1,
                        "background": True},
    }  # fmt: skip


def load(data: dict) -> LoadedScene:
    return parse_scene(copy.deepcopy(data), scenes_dir() / "inline.toml")


def images(r: Renderer) -> tuple[np.ndarray, np.ndarray]:
    r.render()
    return r.read_hdr(), r.read_ldr()


def assert_same_images(got: tuple[np.ndarray, np.ndarray], want: tuple[np.ndarray, np.ndarray]):
    """HDR and display images equal bit for bit."""
    np.testing.assert_array_equal(got[0], want[0])
    np.testing.assert_array_equal(got[1], want[1])


def _set_camera(**changes) -> Callable[[Renderer], None]:
    return lambda r: r.set_camera(r.scene.camera.model_copy(update=changes))


def _set_render(**changes) -> Callable[[Renderer], None]:
    return lambda r: r.set_settings(
        RenderSettings.model_validate({**r.scene.render.model_dump(), **changes})
    )


def _set_material(name: str, **changes) -> Callable[[Renderer], None]:
    def apply(r: Renderer) -> None:
        materials = {k: m.model_dump(exclude_none=True) for k, m in r.scene.materials.items()}
        materials[name].update(changes)
        r.set_materials({k: Material.model_validate(v) for k, v in materials.items()})

    return apply


def _set_light(index: int, **changes) -> Callable[[Renderer], None]:
    def apply(r: Renderer) -> None:
        lights = [x.model_dump(exclude_none=True) for x in r.scene.lights]
        lights[index].update(changes)
        if changes.get("shadow", True) is None:  # no shadow, and none of its settings
            lights[index] = {k: v for k, v in lights[index].items() if "shadow" not in k}
        r.set_lights([Light.model_validate(x) for x in lights], r.scene.environment)

    return apply


def _set_environment(**changes) -> Callable[[Renderer], None]:
    def apply(r: Renderer) -> None:
        env = r.scene.environment.model_dump(exclude_none=True) | changes
        r.set_lights(list(r.scene.lights), Environment.model_validate(env))

    return apply


def _set_options(**changes) -> Callable[[Renderer], None]:
    return lambda r: r.set_options(dataclasses.replace(r.options, **changes))


# (edit, the objects it builds again). The renderer's scene after the edit is rendered by a
# fresh renderer too (``test_an_edit_builds_exactly_its_objects``).
CASES: dict[str, tuple[Callable[[Renderer], None], set[str]]] = {
    "camera move": (_set_camera(position=[1.0, 2.5, 4.5]), {"matrices"}),
    "exposure": (_set_camera(exposure=0.7), set()),  # read by each frame
    # a thin lens: the depth-of-field pass comes; the matrices do not read the lens
    "lens": (_set_camera(aperture=0.05, focus_distance=4.0), {"dof"}),
    "field of view": (_set_camera(fov_y=30.0), {"matrices"}),
    # a light: what reads the lights (the culler, the shadow maps, the lighting pass)
    "light edit": (_set_light(1, intensity=5.0), {"culler", "shadows", "lighting"}),
    # an unshadowed, untiled edit would keep them: a light's shadow alone
    "light shadow off": (_set_light(0, shadow=None), {"culler", "shadows", "lighting"}),
    "environment": (_set_environment(rotation=40.0), {"ibl", "background", "lighting"}),
    "environment background off": (_set_environment(background=False), {"background"}),
    # a constant of a material: restyled in place, a new table row, the same geometry
    "material restyle": (_set_material("ball", roughness=0.6), {"lighting"}),
    # the ball takes the floor's constants: one row for both, the ball's id changes in the
    # kept G-buffer pass (updated in place)
    "material restyle merging rows": (
        _set_material("ball", base_color=[0.5, 0.5, 0.5], roughness=0.7),
        {"lighting"},
    ),
    # a constant no pass compiles or uploads for an opaque part (its coverage): nothing
    "material opaque alpha": (_set_material("ball", alpha=0.9), set()),
    # anisotropy: the G-buffer gains a tangent target (a new layout)
    "material layout": (
        _set_material("ball", anisotropy=0.6),
        {"gbuffer", "gbuffer_pass", "lighting"},
    ),
    # a part turned blended leaves the G-buffer pass and the casters; the blend pass comes
    "material blended": (
        _set_material("ball", alpha=0.5, alpha_mode="blend"),
        {"gbuffer_pass", "shadows", "lighting", "blend", "gbaa"},
    ),
    # the geometric edge resolve (the default "gbaa") writes display values as post does
    "tonemap": (_set_render(tonemap="aces"), {"post", "gbaa"}),
    # post un-premultiplies and writes alpha; the environment is no longer drawn behind
    "transparent background": (
        _set_render(background="transparent"),
        {"post", "background", "gbaa"},
    ),
    # the antialiasing mode (default "gbaa", docs/antialiasing.md): leaving it drops the
    # G-buffer's edge target (a new layout, the G-buffer pass without its edge outputs)
    "antialiasing none": (
        _set_render(antialiasing="none"),
        {"gbaa", "gbuffer", "gbuffer_pass", "lighting"},
    ),
    "antialiasing jitter": (
        _set_render(antialiasing="jitter"),
        {"gbaa", "gbuffer", "gbuffer_pass", "lighting", "accumulate"},
    ),
    "antialiasing msaa": (
        _set_render(antialiasing="msaa"),
        {"gbaa", "gbuffer", "gbuffer_pass", "lighting", "msaa"},
    ),
    "antialiasing fxaa": (
        _set_render(antialiasing="fxaa"),
        {"gbaa", "gbuffer", "gbuffer_pass", "lighting", "fxaa"},
    ),
    "terms": (_set_render(terms="specular"), {"lighting"}),
    "light culling": (_set_render(light_culling="none"), {"culler", "lighting"}),
    # the size: everything sized as the image; the geometry, maps and environment stay
    "size": (
        _set_render(width=48, height=32),
        {"matrices", "gbuffer", "culler", "lighting", "post", "gbaa"},
    ),
    "supersample": (
        _set_render(supersample=2),
        {"matrices", "gbuffer", "gbuffer_pass", "culler", "lighting", "resolve", "gbaa"},
    ),
    "gbuffer encoding": (_set_render(gbuffer="f16"), {"gbuffer", "gbuffer_pass", "lighting"}),
    # specular antialiasing widens roughness per pixel: no constant surfaces (a layout)
    "specular aa": (_set_render(specular_aa=True), {"gbuffer", "gbuffer_pass", "lighting"}),
    # new parts (their maps' mips): the G-buffer pass and the casters' maps, and the
    # lighting pass that binds the maps; the table is the same
    "normal filter": (
        _set_render(normal_filter="toksvig"),
        {"gbuffer_pass", "shadows", "lighting", "gbaa"},
    ),
    "background colour": (
        lambda r: r.update(r.scene.model_copy(update={"background": [0.3, 0.1, 0.0]})),
        set(),
    ),
    "no change": (lambda r: r.update(r.scene), set()),
    "variant fuse_post": (_set_options(fuse_post=False), set()),
    "variant flush_triangles": (_set_options(flush_triangles=0), {"gbuffer_pass"}),
    "variant uber": (_set_options(uber=True), {"lighting"}),
    "variant constant surfaces": (
        _set_options(constant_surfaces=False),
        {"gbuffer", "gbuffer_pass", "lighting"},
    ),
}


def rebuilt_by(r: Renderer, edit: Callable[[Renderer], None]) -> set[str]:
    """The objects ``edit`` built again (counted), checking that every other is the very
    object it was and every rebuilt one a new object."""
    before = {name: getattr(r, name) for name in NAMES}
    counts = r.builds.copy()
    edit(r)
    built = set((r.builds - counts).elements())
    assert all(r.builds[n] - counts[n] <= 1 for n in NAMES)  # each built once at most
    for name in NAMES:
        now = getattr(r, name)
        if name in built:
            assert now is not None and now is not before[name], name
        elif before[name] is not None and now is None:
            built.add(name)  # dropped: the frame has none any more (an absent key)
        else:
            assert now is before[name], f"{name} replaced without a build"
    return built


@pytest.mark.parametrize("name", list(CASES))
def test_an_edit_builds_exactly_its_objects(gl_egl, name: str) -> None:
    edit, expected = CASES[name]
    r = Renderer(gl_egl, load(scene_data()))
    try:
        absent = ("glass_maps", "transmission", "blend", "sraa", "msaa", "dof", "resolve",
                  "accumulate", "fxaa")  # fmt: skip
        assert r.builds == {n: 1 for n in NAMES if n not in absent}
        images(r)
        built = rebuilt_by(r, edit)
        assert all((getattr(r, n) is None) == (r.keys[n] is None) for n in NAMES)
        got = images(r)
        scene = r.loaded
    finally:
        r.release()
    assert built == expected
    fresh = Renderer(gl_egl, scene)
    try:
        if name.startswith("variant"):
            edit(fresh)
        want = images(fresh)
    finally:
        fresh.release()
    assert_same_images(got, want)


def test_builds_follow_the_schedule_order(gl_egl) -> None:
    """A change builds its objects in ``SCHEDULE``'s order (each after what it needs) and
    reports them in ``rebuilt``."""
    r = Renderer(gl_egl, load(scene_data()))
    try:
        _set_render(width=48, height=32)(r)
        assert r.rebuilt == tuple(n for n in NAMES if n in r.rebuilt)
        assert set(r.rebuilt) == {"matrices", "gbuffer", "culler", "lighting", "post", "gbaa"}
        r.invalidate("ibl")  # the lighting pass binds the environment's light
        assert r.rebuilt == ("ibl", "lighting")
        with pytest.raises(ValueError, match="not objects"):
            r.invalidate("nothing")
    finally:
        r.release()


def test_a_refused_change_keeps_every_object(gl_egl, monkeypatch) -> None:
    """A size past the GL's limits is refused by the checks before anything is released:
    the inputs go back and every object is the one it was. So is a material edit refused
    after ``restyle`` replaced the parts' layers in place (here the memory check refuses
    the tangent target an anisotropic ball adds): the layers go back too."""
    import app.render.renderer as renderer_module

    r = Renderer(gl_egl, load(scene_data()))
    try:
        before = {name: getattr(r, name) for name in NAMES}
        first = images(r)
        counts, scene, frame = r.builds.copy(), r.scene, r.frame
        layers = [part.layers for part in r.frame.parts]
        with pytest.raises(InputError):
            r.resize((16384, 16384))
        with pytest.raises(InputError):
            _set_render(width=16384, height=16384, supersample=1, specular_aa=True)(r)

        def refuse(*args, **kwargs) -> None:
            raise InputError("inline.toml", "materials", "past the memory limit (test)")

        monkeypatch.setattr(renderer_module, "check_memory", refuse)
        with pytest.raises(InputError, match="test"):
            _set_material("ball", anisotropy=0.6)(r)
        assert r.scene is scene and r.frame is frame and r.size == SIZE
        assert all(part.layers is kept for part, kept in zip(r.frame.parts, layers, strict=True))
        assert r.builds == counts
        assert {name: getattr(r, name) for name in NAMES} == before
        again = images(r)
    finally:
        r.release()
    assert_same_images(again, first)


def test_hdr_is_read_from_the_frame_that_drew_it(gl_egl) -> None:
    """``read_hdr`` of a fused frame draws the HDR image with that frame's camera (a camera
    edit since does not show), once; an edit that builds the lighting pass again leaves no
    frame; ``want_hdr`` draws it with each frame."""
    data = scene_data()
    del data["environment"]  # a plain frame: fused
    r = Renderer(gl_egl, load(data))
    try:
        assert r.fused_display
        r.render()
        assert not r.hdr_drawn
        first = r.read_hdr()
        assert r.hdr_drawn
        r.render()
        _set_camera(position=[2.0, 2.0, 4.0])(r)
        np.testing.assert_array_equal(r.read_hdr(), first)
        _set_material("ball", roughness=0.6)(r)  # a new lighting pass: no frame of it
        assert not r.hdr_drawn
        r.want_hdr()
        assert not r.fused_display
        r.render()
        assert r.hdr_drawn
    finally:
        r.release()


def test_every_key_is_hashable(gl_egl) -> None:
    """Keys are hashable values (the scheduler compares them; tests and tools may keep
    them in sets)."""
    r = Renderer(gl_egl, load(scene_data()), options=RenderOptions(ms_table=None))
    try:
        keys = r.keys
        assert set(keys) == set(NAMES)
        for value in keys.values():
            hash(value)
    finally:
        r.release()
