"""Constant surfaces (docs/gbuffer.md): where every part the G-buffer draws has its
material's constants at every pixel, the G-buffer keeps only the normal, depth and row,
and the decode reads base colour, metallic, roughness and F0 from the material table.

* The layout is chosen only where it is exact: float32 targets, no screen-space specular
  antialiasing, no map or blend or COLOR_0 that varies a surface number per pixel.
* The images (HDR and display bytes), the G-buffer read back and the debug views equal
  those of the stored-surface layout bit for bit, with every optional target present
  (tangent, coat normal, emission: their locations move down by one).
* Viewer edits that switch the layout (specular antialiasing, a material gaining a map)
  give a fresh renderer's image.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from app.common.models import MATERIAL_TEXELS, SURFACE_TEXELS
from app.frame import prepare_frame
from app.gl.context import GLContext
from app.render.debug_views import DebugPass
from app.render.renderer import Renderer, RenderOptions
from app.scene.loader import LoadedScene, parse_scene
from app.scene.model import Material

SIZE = (96, 64)
SUN = {"type": "directional", "direction": [-0.3, -1.0, -0.4], "intensity": 2.0}
LAMP = {"type": "point", "position": [0.8, 1.6, 1.2], "intensity": 6.0, "range": 8.0}


def scene(materials: dict, render: dict | None = None) -> dict:
    """A floor under three analytic spheres and a box, each with its own material; the
    first two spheres share every model number and differ only in base colour."""
    names = list(materials)
    objects = [{"shape": "plane", "size": [8.0, 8.0], "material": names[0]}]
    for k, name in enumerate(names[1:]):
        x = -1.5 + 1.0 * k
        shape = {"shape": "box", "size": [0.6, 0.6, 0.6]} if k == 3 else {
            "shape": "sphere", "radius": 0.45}  # fmt: skip
        objects.append({**shape, "material": name, "position": [x, 0.5, 0.0]})
    return {
        "background": [0.05, 0.06, 0.08],
        "camera": {"position": [0.0, 2.2, 4.0], "target": [0.0, 0.4, 0.0], "fov_y": 40.0},
        "render": {"width": SIZE[0], "height": SIZE[1], **(render or {})},
        "materials": materials,
        "lights": [SUN, LAMP],
        "objects": objects,
    }


PLAIN = {
    "floor": {"base_color": [0.7, 0.7, 0.7], "roughness": 0.6},
    "red": {"base_color": [0.8, 0.3, 0.2], "roughness": 0.3},
    "blue": {"base_color": [0.2, 0.3, 0.8], "roughness": 0.3},
    "gold": {"preset": "gold", "roughness": 0.35},
    "box": {"base_color": [0.5, 0.6, 0.4], "roughness": 0.8, "metallic": 0.25, "f0": 0.06},
}


def every_target(tmp_path: Path) -> dict:
    """PLAIN with an anisotropic metal (RT3), an emitter (RT5) and a coat with its own
    normal map (RT4): none of them varies a surface number per pixel."""
    texel = np.array([200, 90, 230], np.uint8)
    Image.fromarray(np.tile(texel, (8, 8, 1))).save(tmp_path / "coat.png")
    materials = dict(PLAIN)
    materials["gold"] = {"preset": "gold", "roughness": 0.35, "anisotropy": 0.7}
    materials["blue"] = {**PLAIN["blue"], "emissive": [0.4, 0.2, 0.1]}
    materials["box"] = {**PLAIN["box"], "clearcoat": 1.0, "clearcoat_normal_map": "coat.png"}
    return materials


def load(data: dict, tmp_path: Path) -> LoadedScene:
    return parse_scene(data, tmp_path / "scene.toml")


def frame(gl: GLContext, loaded: LoadedScene, constant: bool) -> dict:
    """Everything a frame gives the caller, from a renderer that may use constant surfaces
    (``constant``) or keeps the surface numbers in the G-buffer."""
    r = Renderer(gl, loaded, options=RenderOptions(constant_surfaces=constant))
    try:
        r.render()
        out = {"layout": r.gbuffer.constant_surfaces, "ldr": r.read_ldr()}
        r.render()
        out["hdr"] = r.read_hdr()
        out["gbuffer"] = r.read_gbuffer()
        debug = DebugPass(r)
        for view in ("base_color", "roughness", "metallic", "f0", "material_id", "light"):
            debug.run(view)
            out[view] = debug.read_values()
        debug.release()
    finally:
        r.release()
    return out


def assert_same_frames(a: dict, b: dict) -> None:
    for key in ("ldr", "hdr", "base_color", "roughness", "metallic", "f0", "material_id",
                "light"):  # fmt: skip
        assert np.array_equal(a[key], b[key], equal_nan=True), key
    ga, gb = a["gbuffer"], b["gbuffer"]
    for field in ("base_color", "normal", "depth", "tangent", "material_id", "coat_normal",
                  "emission"):  # fmt: skip
        x, y = getattr(ga, field), getattr(gb, field)
        assert (x is None) == (y is None), field
        assert x is None or np.array_equal(x, y), field


@pytest.mark.parametrize("materials", ["plain", "every target"])
def test_same_frame_as_the_stored_surfaces(gl_egl, tmp_path, materials):
    """Bit for bit the stored-surface G-buffer's frame, with and without the optional
    targets (whose locations move when RT0 is gone)."""
    chosen = PLAIN if materials == "plain" else every_target(tmp_path)
    loaded = load(scene(chosen), tmp_path)
    table = prepare_frame(loaded).materials
    assert table.constant_surfaces
    # red and blue share every model number: only their surfaces tell their rows apart
    assert len(table.rows) == len(chosen)
    assert table.packed().shape[1] == MATERIAL_TEXELS + SURFACE_TEXELS
    fast, stored = frame(gl_egl, loaded, True), frame(gl_egl, loaded, False)
    assert fast["layout"] and not stored["layout"]
    covered = fast["gbuffer"].covered
    assert covered.mean() > 0.5
    assert len(np.unique(fast["gbuffer"].material_id[covered])) == len(chosen)
    if materials == "every target":
        assert fast["gbuffer"].coat_normal is not None and fast["gbuffer"].emission is not None
        assert np.abs(fast["gbuffer"].tangent[covered]).max() > 0.0
    assert_same_frames(fast, stored)


def test_the_targets_shrink(gl_egl, tmp_path):
    """No RT0, and RT1 holds two float32 channels: 16 bytes per pixel for RT1 and RT2
    instead of 40."""
    r = Renderer(gl_egl, load(scene(PLAIN), tmp_path))
    try:
        g = r.gbuffer
        assert g.base_color is None and g.normal.components == 2 and g.normal.dtype == "f4"
        # (and g_edge, the default antialiasing's edge distances: not a surface target)
        assert [name for name, _ in g.samplers() if name != "g_edge"] == ["g_normal", "g_depth"]
        assert g.defines()["GBUFFER_CONSTANT_SURFACES"] == 1
    finally:
        r.release()


UNSAFE = {
    "f16 targets": ({"gbuffer": "f16"}, None),
    "unorm16 base colour": ({"gbuffer": "unorm16_base"}, None),
    "specular antialiasing": ({"specular_aa": True}, None),
    "a base colour map": ({}, ("red", "base_color_map")),
    "a roughness map": ({}, ("red", "roughness_map")),
    "a metallic map": ({}, ("gold", "metallic_map")),
}


@pytest.mark.parametrize("case", list(UNSAFE))
def test_stored_surfaces_where_a_number_varies_or_rounds(gl_egl, tmp_path, case):
    """Where a surface number varies per pixel, or the targets would round the table's
    float32 numbers, the G-buffer keeps them."""
    render, mapped = UNSAFE[case]
    materials = {k: dict(v) for k, v in PLAIN.items()}
    if mapped is not None:
        name, key = mapped
        Image.fromarray(np.full((4, 4, 3), 180, np.uint8)).save(tmp_path / "map.png")
        materials[name][key] = "map.png"
    r = Renderer(gl_egl, load(scene(materials, render), tmp_path))
    try:
        assert not r.gbuffer.constant_surfaces
        assert r.gbuffer.base_color is not None
        assert "GBUFFER_CONSTANT_SURFACES" not in r.gbuffer.defines()
    finally:
        r.release()


def test_edits_that_switch_the_layout(gl_egl, tmp_path):
    """Specular antialiasing on and off (alone and with a new width), and a material gaining
    a map and losing it: each edit switches the layout and gives the image a fresh
    renderer gives."""
    Image.fromarray(np.full((4, 4, 3), 180, np.uint8)).save(tmp_path / "map.png")
    loaded = load(scene(PLAIN), tmp_path)
    r = Renderer(gl_egl, loaded)

    def fresh() -> np.ndarray:
        other = Renderer(gl_egl, r.loaded)
        try:
            other.render()
            return other.read_ldr()
        finally:
            other.release()

    try:
        assert r.gbuffer.constant_surfaces
        settings = r.scene.render
        steps = [
            ("settings", settings.model_copy(update={"specular_aa": True}), False),
            ("settings", settings, True),
            # with a new size in the same edit (a resize alone keeps the G-buffer pass)
            ("settings", settings.model_copy(update={"specular_aa": True, "width": 80}), False),
            ("settings", settings, True),
        ]
        mapped = {**r.scene.materials}
        mapped["red"] = Material.model_validate({**PLAIN["red"], "base_color_map": "map.png"})
        steps += [("materials", mapped, False), ("materials", dict(r.scene.materials), True)]
        for kind, value, constant in steps:
            if kind == "settings":
                r.set_settings(value)
            else:
                r.set_materials(value)
            assert r.gbuffer.constant_surfaces is constant, (kind, constant)
            r.render()
            assert np.array_equal(r.read_ldr(), fresh()), (kind, constant)
    finally:
        r.release()


def test_a_roughness_edit_keeps_the_layout(gl_egl, tmp_path):
    """A slider edit changes only the table: the rows (and with them the G-buffer's ids)
    follow, and the image is a fresh renderer's."""
    r = Renderer(gl_egl, load(scene(PLAIN), tmp_path))
    try:
        gbuffer = r.gbuffer
        materials = dict(r.scene.materials)
        # blue takes red's roughness and colour: their rows merge
        materials["blue"] = materials["red"]
        materials["floor"] = materials["floor"].model_copy(update={"roughness": 0.25})
        r.set_materials(materials)
        assert r.gbuffer is gbuffer and len(r.materials.rows) == len(PLAIN) - 1
        r.render()
        edited = r.read_ldr()
        other = Renderer(gl_egl, r.loaded)
        try:
            other.render()
            assert np.array_equal(edited, other.read_ldr())
        finally:
            other.release()
    finally:
        r.release()
