"""The G-buffer's one layout list (app/common/gbuffer.py ``GBUFFER_TARGETS``) and what is
derived from it, for every combination of the optional targets, encodings and constant
surfaces:

* the bytes per pixel the GL allocates (``GBuffer``'s textures) equal the list's count
  (``GBufferLayout.bytes_per_pixel``), and app/render/limits.py charges exactly that plus
  the z-buffer, the HDR target and, with depth of field, its target;
* the targets sit at contiguous framebuffer locations in the list's order, which the
  ``GBUFFER_LOCATION_*`` defines and ``samplers()`` name;
* the GLSL declarations generated into the program header (``GBUFFER_OUTPUTS``) write each
  target at its own attachment, and ``GBUFFER_SAMPLERS`` declares the samplers
  ``samplers()`` binds;
* ``read()`` fills every ``GBufferData`` field from the list;
* the defines keep their values (pinned for a few layouts).
"""

from __future__ import annotations

import dataclasses
import itertools

import moderngl
import numpy as np
import pytest

from app.common.gbuffer import (
    ENCODING_NAMES,
    GBUFFER_TARGETS,
    MAX_COLOR_TARGETS,
    OPTIONAL_TARGETS,
    STORAGE_BYTES,
    GBufferData,
    GBufferLayout,
    glsl_declarations,
    optional_defines,
)
from app.gl.shaders import assemble, assemble_text
from app.render.gbuffer import GBuffer
from app.render.limits import target_bytes_per_pixel

SIZE = (4, 3)
SUBSETS = [
    frozenset(c) for k in range(len(OPTIONAL_TARGETS) + 1)
    for c in itertools.combinations(OPTIONAL_TARGETS, k)
]  # fmt: skip
LAYOUTS = [
    layout
    for encoding in ENCODING_NAMES for optional in SUBSETS for constant in (False, True)
    if (layout := GBufferLayout(encoding, optional, constant)).fits()
]  # fmt: skip
# Bytes of one texel channel by moderngl dtype, as the GL stores it.
DTYPE_BYTES = {"f2": 2, "nu2": 2, "f4": 4}


def layout_id(layout: GBufferLayout) -> str:
    extras = sorted(layout.optional) + (["constant"] if layout.constant_surfaces else [])
    return "-".join([layout.encoding, *extras])


@pytest.mark.parametrize("layout", LAYOUTS, ids=layout_id)
def test_allocated_bytes_are_the_lists_and_the_limits(gl_egl, layout: GBufferLayout) -> None:
    """What the GL allocates = the list's count = what limits.py charges for the G-buffer
    (its z-buffer, the HDR target and the depth-of-field target on top)."""
    g = GBuffer(gl_egl.ctx, SIZE, layout)
    try:
        textures = [tex for _, tex in g.samplers()]
        allocated = sum(tex.components * DTYPE_BYTES[tex.dtype] for tex in textures)
        assert len(textures) == len(g.fbo.color_attachments)
    finally:
        g.release()
    assert allocated == layout.bytes_per_pixel()
    z_buffer, hdr = 4, 16
    assert target_bytes_per_pixel(layout, False) == allocated + z_buffer + hdr
    assert target_bytes_per_pixel(layout, True) == allocated + z_buffer + 2 * hdr


@pytest.mark.parametrize("layout", LAYOUTS, ids=layout_id)
def test_locations_are_contiguous_and_named_by_the_defines(gl_egl, layout: GBufferLayout) -> None:
    """Every target present at the next location in the list's order; an optional one's
    GBUFFER_LOCATION_* is its attachment; samplers() names them in that order."""
    g = GBuffer(gl_egl.ctx, SIZE, layout)
    try:
        attachments = list(g.fbo.color_attachments)
        defines = g.defines()
        present = [t for t in GBUFFER_TARGETS if getattr(g, t.name) is not None]
        assert [getattr(g, t.name) for t in present] == attachments
        assert layout.locations() == {t.name: i for i, t in enumerate(present)}
        assert [name for name, _ in g.samplers()] == [t.glsl_name for t in present]
        for target in GBUFFER_TARGETS:
            tex = getattr(g, target.name)
            if target.define is None:
                continue
            if tex is not None or target.named_when_absent:
                assert defines[target.define] == int(tex is not None)
            else:
                assert target.define not in defines
            if tex is None:
                assert target.location_define not in defines
            else:
                assert defines[target.location_define] == attachments.index(tex)
        storage = {t.name: layout.storage(t) for t in present}
        for target in present:
            tex = getattr(g, target.name)
            assert tex.components == target.channels_in(layout.constant_surfaces)
            assert DTYPE_BYTES[tex.dtype] == STORAGE_BYTES[storage[target.name]]
    finally:
        g.release()


WRITE_EACH = """
GBUFFER_OUTPUTS
void main() {{
{writes}
}}
"""
SAMPLE_EACH = """
GBUFFER_SAMPLERS
out vec4 f_out;
void main() {{
    f_out = vec4(0.0){reads};
}}
"""


@pytest.mark.parametrize("layout", [x for x in LAYOUTS if x.encoding == "f32"], ids=layout_id)
def test_generated_declarations_write_and_sample_each_target(gl_egl, layout: GBufferLayout) -> None:
    """A program whose only declarations are the header's GBUFFER_OUTPUTS writes k + 1 to
    the target at list position k (its GLSL name): each attachment then holds its own
    target's number. A program declaring GBUFFER_SAMPLERS has exactly the sampler
    uniforms samplers() binds."""
    ctx = gl_egl.ctx
    g = GBuffer(ctx, SIZE, layout)
    defines = g.defines()
    present = [(k, t) for k, t in enumerate(GBUFFER_TARGETS) if getattr(g, t.name) is not None]
    writes = "\n".join(
        f"    {t.glsl_name} = vec{getattr(g, t.name).components}({k + 1}.0);" for k, t in present
    )
    reads = "".join(f" + texelFetch({t.glsl_name}, ivec2(0), 0)" for _, t in present)
    vertex = assemble("passes/fullscreen.vert", defines)
    writer = ctx.program(
        vertex_shader=vertex,
        fragment_shader=assemble_text(WRITE_EACH.format(writes=writes), defines),
    )
    sampler = ctx.program(
        vertex_shader=vertex,
        fragment_shader=assemble_text(SAMPLE_EACH.format(reads=reads), defines),
    )
    vao = ctx.vertex_array(writer, [])
    try:
        g.fbo.use()
        ctx.viewport = (0, 0, *SIZE)
        ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
        vao.render(moderngl.TRIANGLES, vertices=3)
        for k, target in present:
            tex = getattr(g, target.name)
            texels = np.frombuffer(tex.read(), np.dtype(tex.dtype))  # f4, or f2 (RT7, edge)
            assert np.all(texels == k + 1), target.name
        uniforms = {name for name in sampler if isinstance(sampler[name], moderngl.Uniform)}
        assert uniforms == {name for name, _ in g.samplers()}
    finally:
        for obj in (vao, writer, sampler):
            obj.release()
        g.release()


@pytest.mark.parametrize("layout", [x for x in LAYOUTS if x.encoding == "unorm16"], ids=layout_id)
def test_read_fills_every_field(gl_egl, layout: GBufferLayout) -> None:
    """read() of a cleared G-buffer: every GBufferData field comes from one target of the
    list; present targets give (H, W, channels) arrays (a unorm target's signed channels
    as -1, unorm_to_snorm(0)); absent ones None or, for the tangent, zeros."""
    fields = [name for t in GBUFFER_TARGETS for name in t.fields]
    assert sorted(fields) == sorted(f.name for f in dataclasses.fields(GBufferData))
    g = GBuffer(gl_egl.ctx, SIZE, layout)
    try:
        g.clear()
        surfaces = np.zeros((1, 2, 4), np.float32)
        data = g.read(surfaces if layout.constant_surfaces else None)
    finally:
        g.release()
    w, h = SIZE
    assert data.depth.shape == data.material_id.shape == (h, w)
    assert data.base_color.shape == (h, w, 4)
    assert data.normal.shape == (h, w, 4)
    assert data.tangent.shape == (h, w, 4)
    if "tangent" in layout.optional:  # signed x, y, anisotropy; the fourth channel 0
        assert np.all(data.tangent[..., :3] == -1.0) and np.all(data.tangent[..., 3] == 0.0)
    else:
        assert np.all(data.tangent == 0.0)
    assert np.all(data.base_color == 0.0)
    assert np.all(data.normal[..., :2] == -1.0) and np.all(data.normal[..., 2:] == 0.0)
    assert (data.coat_normal is None) is ("coat_normal" not in layout.optional)
    assert (data.emission is None) is ("emission" not in layout.optional)
    if data.coat_normal is not None:
        assert data.coat_normal.shape == (h, w, 2)
        assert np.all(data.coat_normal == -1.0)


def test_defines_keep_their_values() -> None:
    """The defines the hand-written GBuffer.defines gave, pinned: presence of RT3 and RT4
    always named, RT5 only where present, the optional targets' locations."""
    assert GBufferLayout("f32", frozenset({"tangent"})).defines() == {
        "GBUFFER_TANGENT": 1, "GBUFFER_COAT_NORMAL": 0, "GBUFFER_LOCATION_TANGENT": 3,
    }  # fmt: skip
    assert GBufferLayout("unorm16", frozenset({"coat_normal", "emission"}), True).defines() == {
        "GBUFFER_TANGENT": 0, "GBUFFER_COAT_NORMAL": 1, "GBUFFER_EMISSION": 1,
        "GBUFFER_UNORM_DIRECTIONS": 1, "GBUFFER_CONSTANT_SURFACES": 1,
        "GBUFFER_LOCATION_COAT_NORMAL": 2, "GBUFFER_LOCATION_EMISSION": 3,
    }  # fmt: skip
    assert GBufferLayout("f16", frozenset()).defines() == {
        "GBUFFER_TANGENT": 0, "GBUFFER_COAT_NORMAL": 0,
    }  # fmt: skip
    # the material table's choice round-trips through the layout
    for optional in SUBSETS:
        chosen = optional_defines({name: name in optional for name in OPTIONAL_TARGETS})
        assert GBufferLayout.from_defines("f32", chosen).optional == optional
    with pytest.raises(ValueError):
        optional_defines({"tangent": True})  # every optional target must be decided


def test_documented_costs() -> None:
    """docs/gbuffer.md's bytes per pixel: 40 with f32, 32 unorm16_base, 24 f16 and unorm16,
    16 with constant surfaces; 56 (f32) or 32 (f16) with the tangent target."""
    none = frozenset()
    assert GBufferLayout("f32", none).bytes_per_pixel() == 40
    assert GBufferLayout("unorm16_base", none).bytes_per_pixel() == 32
    assert GBufferLayout("f16", none).bytes_per_pixel() == 24
    assert GBufferLayout("unorm16", none).bytes_per_pixel() == 24
    assert GBufferLayout("f32", none, True).bytes_per_pixel() == 16
    assert GBufferLayout("f32", frozenset({"tangent"})).bytes_per_pixel() == 56
    assert GBufferLayout("f16", frozenset({"tangent"})).bytes_per_pixel() == 32


def test_a_program_without_gbuffer_defines_gets_the_defaults() -> None:
    """The header of a program that names no G-buffer define: RT0-RT3 (the tangent's
    default), float targets, and the declarations of those four."""
    lines = glsl_declarations({})
    assert "#define GBUFFER_TANGENT 1" in lines
    assert "#define GBUFFER_LOCATION_TANGENT 3" in lines
    outputs = next(x for x in lines if x.startswith("#define GBUFFER_OUTPUTS "))
    assert outputs.count(" out ") == 4 and "g_coat_normal" not in outputs


def test_a_layout_past_the_draw_buffers_sheds_the_coat_film_maps() -> None:
    """Every optional target at once is 9 colour targets, past GL 3.3's 8 draw buffers:
    the renderer's layout leaves RT8 out (its materials use their factors alone), and
    every other layout is kept whole."""
    every = GBufferLayout(optional=frozenset(OPTIONAL_TARGETS))
    assert len(every.targets()) == MAX_COLOR_TARGETS + 1 and not every.fits()
    fitted = every.fitted()
    assert fitted.fits() and fitted.optional == every.optional - {"coat_film_maps"}
    for layout in LAYOUTS:
        assert layout.fitted() == layout
