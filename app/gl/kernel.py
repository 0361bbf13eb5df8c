"""Run a GLSL snippet once per element of some arrays: the project's real shader code as a
vectorised function, for the BRDF probe and for term-by-term tests against the twins.

Each element becomes one fragment of a full-screen pass; each input array travels in an
RGBA32F texture and each result is read back from an RGBA32F target, so nothing but
float32 arithmetic in the shader stands between the GLSL and its float64 twin.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import moderngl
import numpy as np

from app.gl.context import release_objects
from app.gl.fullscreen import FullscreenDraw, bind_textures
from app.gl.shaders import assemble, assemble_text

MAX_WIDTH = 1024  # texels per row of the input and output textures

_TEMPLATE = """{includes}
{declarations}
{uniforms}
out vec4 kernel_result;

void main() {{
    ivec2 kernel_px = ivec2(gl_FragCoord.xy);
{fetches}
    vec4 result = vec4(0.0);
{body}
    kernel_result = result;
}}
"""


def kernel_source(
    includes: Sequence[str], body: str, inputs: Sequence[str], declarations: str = ""
) -> str:
    """The fragment shader: ``body`` reads each input as a ``vec4`` of its name and
    assigns the ``vec4 result``; ``declarations`` (uniforms, helper functions) precede it."""
    return _TEMPLATE.format(
        includes="\n".join(f'#include "{name}"' for name in includes),
        declarations=declarations,
        uniforms="\n".join(f"uniform sampler2D kernel_in_{name};" for name in inputs),
        fetches="\n".join(
            f"    vec4 {name} = texelFetch(kernel_in_{name}, kernel_px, 0);" for name in inputs
        ),
        body="\n".join("    " + line for line in body.strip().splitlines()),
    )


def run_kernel(
    ctx: moderngl.Context,
    includes: Sequence[str],
    body: str,
    inputs: Mapping[str, np.ndarray],
    defines: Mapping[str, object] | None = None,
    bind: Callable[[moderngl.Program, int], None] | None = None,
    declarations: str = "",
    target_dtype: str = "f4",
) -> np.ndarray:
    """Evaluate ``body`` for each of the N rows of the ``inputs`` arrays.

    ``inputs`` maps a GLSL name to an (N,) or (N, k <= 4) array (padded with zeros to a
    vec4). ``bind(program, first_free_unit)`` may set further uniforms and textures.
    ``target_dtype``: the result target's moderngl dtype, "f4" (RGBA32F), or "f2" / "nu2"
    (RGBA16F / 16-bit unorm) to see what a G-buffer target of that storage keeps.
    Returns the ``result`` vectors as an (N, 4) float64 array (a unorm code k as k/65535).
    """
    arrays = {k: np.asarray(a, np.float32).reshape(len(a), -1) for k, a in inputs.items()}
    if not arrays:
        raise ValueError("run_kernel needs at least one input array")
    count = {len(a) for a in arrays.values()}
    if len(count) != 1:
        raise ValueError(f"inputs differ in length: {sorted(count)}")
    n = count.pop()
    width = max(1, min(n, MAX_WIDTH))
    height = max(1, -(-n // width))
    program = ctx.program(
        vertex_shader=assemble("passes/fullscreen.vert", defines),
        fragment_shader=assemble_text(
            kernel_source(includes, body, list(arrays), declarations), defines
        ),
    )
    textures: list[moderngl.Texture] = []
    target = ctx.texture((width, height), 4, dtype=target_dtype)
    fbo = ctx.framebuffer([target])
    fullscreen = FullscreenDraw(ctx, program, owns_program=True)
    try:
        named = []
        for name, a in arrays.items():
            texels = np.zeros((width * height, 4), np.float32)
            texels[:n, : a.shape[1]] = a
            tex = ctx.texture((width, height), 4, texels.tobytes(), dtype="f4")
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
            textures.append(tex)
            named.append((f"kernel_in_{name}", tex))  # an unused input is optimised away
        bind_textures(program, named)
        if bind is not None:
            bind(program, len(arrays))
        fullscreen.draw(fbo, viewport=(0, 0, width, height))
        stored = np.dtype({"nu2": "u2"}.get(target_dtype, target_dtype))
        out = np.frombuffer(target.read(), stored).reshape(-1, 4)[:n].astype(np.float64)
        return out / 65535.0 if target_dtype == "nu2" else out
    finally:
        release_objects(fullscreen, fbo, target, *textures)
