"""A model file's parts are built once a render: ``model_scene`` builds them to frame the
camera and keeps them, and the frame takes them (app/scene/geometry.py ``keep_built``,
``take_built``) instead of reading the file and its images again."""

from __future__ import annotations

from app.frame import prepare_frame
from app.resources import scenes_dir
from app.scene.edits import edited
from app.scene.sources import scene_from

MODEL = scenes_dir() / "meshes" / "material_sampler.glb"


def test_frame_takes_the_parts_the_framing_built() -> None:
    loaded = scene_from(MODEL, size=(64, 48))
    ((kept, spent),) = loaded.built.values()
    frame = prepare_frame(loaded)
    assert frame.parts is kept and frame.decoded == spent > 0
    assert not loaded.built  # taken once: a second frame builds its own
    again = prepare_frame(loaded)
    assert again.parts is not kept and len(again.parts) == len(kept)
    assert again.decoded == spent
    for a, b in zip(kept, again.parts, strict=True):
        assert (a.vertices == b.vertices).all() and (a.indices == b.indices).all()


def test_a_scene_with_other_objects_builds_its_own() -> None:
    loaded = scene_from(MODEL, size=(64, 48))
    ((kept, _),) = loaded.built.values()
    # A background is not what parts are built from: the edited scene takes them.
    clear = edited(loaded, {"render.background": "transparent"}, "--background")
    assert prepare_frame(clear).parts is kept
    loaded = scene_from(MODEL, size=(64, 48))
    ((kept, _),) = loaded.built.values()
    moved = edited(loaded, {"objects[0].position": [0.0, 1.0, 0.0]}, "test")
    assert prepare_frame(moved).parts is not kept
