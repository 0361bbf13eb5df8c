"""Every GLSL library file includes what it uses: each ``glsl/**/*.glsl`` compiles when it is
the only file a shader includes (app/gl/shaders.py splices its own #include lines), so a
pass or a test kernel can include any file without knowing what to include before it.

Each file is compiled into a fragment shader of its own, with no defines (the default
feature set) and with defines that compile in the optional code: every model at run time
(UBER_MODELS), the masked light loop over several chunks (TILE_QUADS), and a material
with every map, a blend and specular antialiasing.
"""

from __future__ import annotations

import pytest

from app.gl.shaders import assemble, assemble_text
from app.resources import glsl_dir

LIBRARY = sorted(p.relative_to(glsl_dir()).as_posix() for p in glsl_dir().rglob("*.glsl"))

FEATURES = {
    "default": {},
    "optional code": {
        "UBER_MODELS": 1,
        "TILE_QUADS": 9,
        "LAYER0_MAPS": 63,
        "LAYER1_MAPS": 15,
        "BLEND": 1,
        "SPECULAR_AA": 1,
        "TONEMAP": 1,  # post/tonemap.glsl's tonemap_selected
        "SHADOWS": 2,  # lights/shadows.glsl: two shadow maps
        "SHADOW_PCSS": 1,  # and their PCSS filter
        "SHADOW_CASCADES": 1,  # and a directional light's cascades
        "SHADOW_LIGHTS": 2,  # two shadowed lights' lookup steps: a point light with PCSS
        "SHADOW_PROJ_0": 2,
        "SHADOW_FILTER_0": 2,
        "SHADOW_PROJ_1": 3,  # and a cascaded directional light with PCF
        "SHADOW_FILTER_1": 1,
    },
    # ENVIRONMENT_IBL and ENVIRONMENT_UNIFORM are alternatives (lights/shading.glsl):
    # one set each, with the lighting pass's tiled walk, light array and emission target.
    "uniform environment": {
        "ENVIRONMENT_UNIFORM": 1,
        "ENV_UNIFORM_SAMPLES": 64,
        "LIGHT_UNIFORMS": 16,  # lights/illumination.glsl: the lights in a uniform array
        "SHADOWS": 1,  # lights/shadows.glsl through sampler2DShadow: one PCF spot
        "SHADOW_COMPARE": 1,
        "SHADOW_LIGHTS": 1,
        "SHADOW_PROJ_0": 1,
        "SHADOW_FILTER_0": 1,
        "TILED_LIGHTS": 1,
        "TILE_SIZE": 16,
        "TILE_QUADS": 2,
        "DIRECTIONAL_LIGHTS": 1,
        "GBUFFER_EMISSION": 1,
        "FAR_PLANE": 1,
    },
    "image-based light": {
        "ENVIRONMENT_IBL": 1,
        "ENV_LEVELS": 6,
        "TILED_LIGHTS": 1,
        "TILE_SIZE": 16,
        "TILE_QUADS": 2,
        "GBUFFER_EMISSION": 1,
    },
}

SHADER = """#include "{path}"

out vec4 frag_color;

void main() {{
    frag_color = vec4(1.0);
}}
"""


def test_the_library_is_found():
    assert {"brdf/brdf.glsl", "gbuffer/decode.glsl", "lights/illumination.glsl"} <= set(LIBRARY)


@pytest.mark.parametrize("features", list(FEATURES))
@pytest.mark.parametrize("path", LIBRARY)
def test_library_file_compiles_alone(gl_egl, path, features):
    defines = FEATURES[features]
    program = gl_egl.ctx.program(
        vertex_shader=assemble("passes/fullscreen.vert", defines),
        fragment_shader=assemble_text(SHADER.format(path=path), defines),
    )
    program.release()


def test_fragment_only_extension_stays_out_of_the_vertex_stage():
    """The geometry samples' program (GBUFFER_SAMPLE_MASK) names GL_ARB_sample_shading
    for gl_SampleMask in its fragment stage only: the extension adds nothing to a vertex
    shader, where a strict compiler may refuse it."""
    defines = {"GBUFFER_SAMPLE_MASK": 4}
    extension = "#extension GL_ARB_sample_shading : require"
    assert extension in assemble("passes/gbuffer.frag", defines)
    assert extension not in assemble("passes/gbuffer.vert", defines)
    assert extension not in assemble("passes/gbuffer.frag", {})


def test_fine_derivatives_program_is_glsl_400_with_the_extension_in_its_fragment_stage():
    """gbaa's program with FINE_DERIVATIVES (dFdxFine, dFdyFine) is GLSL 4.00 in both
    stages, which GL_ARB_derivative_control needs, and names the extension in its
    fragment stage alone; without the define both stages stay 3.30 and name nothing."""
    from app.gl.shaders import DERIVATIVE_CONTROL, GLSL_VERSION, GLSL_VERSION_FINE_DERIVATIVES

    fine = {"FINE_DERIVATIVES": 1, "QUAD_NEIGHBOURS": 1}
    extension = f"#extension {DERIVATIVE_CONTROL} : require"
    fragment = assemble("passes/gbaa.frag", fine)
    vertex = assemble("passes/gbaa_rects.vert", fine)
    assert fragment.startswith(GLSL_VERSION_FINE_DERIVATIVES + "\n") and extension in fragment
    assert vertex.startswith(GLSL_VERSION_FINE_DERIVATIVES + "\n") and extension not in vertex
    plain = assemble("passes/gbaa.frag", {"QUAD_NEIGHBOURS": 1})
    assert plain.startswith(GLSL_VERSION + "\n") and extension not in plain


def test_expanded_text_is_the_traced_expansion(tmp_path) -> None:
    """``expand_includes`` (each file parsed once a process, no line origins) gives the
    text of the line-by-line expansion whose origins trace a compiler's errors, for every
    shader and library file and for a file whose includes repeat, sit in a comment or
    miss the pattern."""
    from app.gl.shaders import _expand_file, expand_includes

    stages = ("*.glsl", "*.vert", "*.frag", "*.geom")
    names = sorted(
        {p.relative_to(glsl_dir()).as_posix() for s in stages for p in glsl_dir().rglob(s)}
    )
    for name in names:
        assert expand_includes(name) == "\n".join(_expand_file(name)[0]), name
    (tmp_path / "a.glsl").write_text('float a;\n  #include "b.glsl"  \n', encoding="utf-8")
    (tmp_path / "b.glsl").write_text('#include "a.glsl"\nfloat b;', encoding="utf-8")
    text = (
        '#include "b.glsl"\n// #include "a.glsl"\n#include "a.glsl"\n#include "b.glsl"\n'
        '#include b.glsl\n#include "b.glsl" x\n'
    )
    (tmp_path / "main.frag").write_text(text, encoding="utf-8")
    expanded = expand_includes("main.frag", tmp_path)
    assert expanded == "\n".join(_expand_file("main.frag", tmp_path)[0])
    assert expanded.count("float a;") == expanded.count("float b;") == 1
