"""An edit of a model file's own material factors in a running renderer (the viewer's
slider on ``objects[i].file_materials``): the factors reach the image without new parts
or maps (``app.frame.restyle_file_materials``), and the image is the one a renderer built
fresh from the edited scene draws, bit for bit."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from app.render.renderer import Renderer
from app.scene.loader import load_scene

HELMET = Path(__file__).parent / "assets" / "DamagedHelmet" / "DamagedHelmet.gltf"
SIZE = (48, 48)
SCENE = """\
[camera]
position = [0.0, 0.0, 3.2]
target = [0.0, 0.0, 0.0]
fov_y = 45.0

[[lights]]
type = "directional"
direction = [-0.4, -0.5, -1.0]
intensity = 3.0

[[objects]]
shape = "mesh"
file = "{file}"
{extra}
"""
# What a slider sets, one key at a time and all together; each a fast edit.
FAST = [
    {"base_color": "[0.9, 0.2, 0.1]"},
    {"metallic": "0.25"},
    {"emissive": "[0.5, 1.0, 0.25]", "emissive_strength": "3.0"},
    {"alpha": "0.5", "base_color": "[0.2, 0.4, 0.9]", "metallic": "0.0"},
]


def scene_file(folder: Path, name: str, factors: dict[str, str] | None) -> Path:
    """A scene of the small helmet (copied beside it) with ``factors`` on its material."""
    if not (folder / "helmet").exists():
        shutil.copytree(HELMET.parent, folder / "helmet")
    extra = ""
    if factors:
        inner = ", ".join(f"{k} = {v}" for k, v in factors.items())
        extra = f"file_materials = {{ Material_MR = {{ {inner} }} }}"
    path = folder / f"{name}.toml"
    path.write_text(SCENE.format(file=f"helmet/{HELMET.name}", extra=extra), encoding="utf-8")
    return path


def hdr(r: Renderer) -> np.ndarray:
    r.want_hdr(True)
    r.render()
    return r.read_hdr()


def fresh(gl, path: Path) -> np.ndarray:
    r = Renderer(gl, load_scene(path), SIZE)
    try:
        return hdr(r)
    finally:
        r.release()


@pytest.mark.gl
@pytest.mark.parametrize("factors", FAST, ids=lambda f: "+".join(f))
def test_a_factor_edit_keeps_the_parts_and_draws_the_fresh_image(gl_egl, tmp_path, factors):
    """The edit keeps the frame's parts, their maps and the G-buffer pass (no part built
    again), and its image equals a fresh renderer's of the edited scene bit for bit.
    Fails with the fast path removed (the parts are new) or with a factor left out of the
    new layer (the images differ)."""
    r = Renderer(gl_egl, load_scene(scene_file(tmp_path, "before", None)), SIZE)
    try:
        before = hdr(r)
        parts, maps = r.frame.parts, [dict(p.layers[0].maps) for p in r.frame.parts]
        gbuffer_builds = r.builds["gbuffer_pass"]
        edited = scene_file(tmp_path, "after", factors)
        r.update(load_scene(edited).scene)
        after = hdr(r)
        assert r.frame.parts is parts
        assert [p.layers[0].maps for p in r.frame.parts] == maps
        assert all(
            a is b
            for p, kept in zip(r.frame.parts, maps, strict=True)
            for a, b in zip(p.layers[0].maps.values(), kept.values(), strict=True)
        )
        assert r.builds["gbuffer_pass"] == gbuffer_builds
        assert "gbuffer_pass" not in r.rebuilt
    finally:
        r.release()
    assert np.abs(after - before).max() > 0.01  # the edit shows
    np.testing.assert_array_equal(after, fresh(gl_egl, edited))


@pytest.mark.gl
def test_a_roughness_edit_remakes_the_chain_alone(gl_egl, tmp_path):
    """The helmet's roughness factor is baked into its normal/roughness chain, which does
    not commute with the factor (docs/viewer.md): the edit makes a new chain from the
    images the old one keeps, on the same parts, the other maps the same objects, and the
    G-buffer pass built again to upload it; its image is the fresh renderer's bit for
    bit. Fails with the chain left as it was (the images differ: the pass is not built
    again, or the old chain drawn) or with the parts built again."""
    r = Renderer(gl_egl, load_scene(scene_file(tmp_path, "before", None)), SIZE)
    try:
        before = hdr(r)
        parts, maps = r.frame.parts, dict(r.frame.parts[0].layers[0].maps)
        edited = scene_file(tmp_path, "after", {"roughness": "0.3"})
        r.update(load_scene(edited).scene)
        after = hdr(r)
        assert r.frame.parts is parts
        now = r.frame.parts[0].layers[0].maps
        assert now["normal_roughness"] is not maps["normal_roughness"]
        assert all(now[k] is maps[k] for k in maps if k != "normal_roughness")
        assert "gbuffer_pass" in r.rebuilt
    finally:
        r.release()
    assert np.abs(after - before).max() > 0.01
    np.testing.assert_array_equal(after, fresh(gl_egl, edited))


@pytest.mark.gl
def test_the_files_values_back_keep_the_parts_and_draw_the_unedited_image(gl_egl, tmp_path):
    """After an edit, "the file's values" (the override removed): the factors come back
    from the file's JSON on the same parts, and the image is the unedited scene's bit for
    bit. Fails where the file's own factors are read wrong (the image differs) or the
    removal builds the parts again."""
    unedited = scene_file(tmp_path, "before", None)
    r = Renderer(gl_egl, load_scene(scene_file(tmp_path, "after", FAST[-1])), SIZE)
    try:
        edited = hdr(r)
        parts = r.frame.parts
        r.update(load_scene(unedited).scene)
        back = hdr(r)
        assert r.frame.parts is parts
    finally:
        r.release()
    assert np.abs(back - edited).max() > 0.01
    np.testing.assert_array_equal(back, fresh(gl_egl, unedited))
