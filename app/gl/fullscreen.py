"""The full-screen triangle: the one draw every image-space pass makes.

glsl/passes/fullscreen.vert makes one triangle that covers the viewport from
``gl_VertexID`` alone, so a pass needs a program, an empty vertex array and a draw of 3
vertices; with ``FAR_PLANE`` defined the triangle lies on the far plane, for passes that
z-test it (">") against a G-buffer's z-buffer so that only pixels with a surface run the
fragment shader. ``FullscreenDraw`` is that much, and the only place in app/ that makes the
draw: post, downsample, depth of field, compare, the environment background and its
prefilter, tile culling, lighting, the debug views, the bench's floor and limit passes,
the GLSL kernels and the viewer's window (its image onto the screen) all draw through it.

The draw state is explicit: ``draw`` disables blending, and the depth test unless a
``depth_func`` asks for it, which it restores to off and "<" afterwards (the state every
other pass expects). The viewport is the framebuffer's own (moderngl keeps one per
framebuffer and sets it on ``use``) unless ``viewport`` sets another.
"""

from __future__ import annotations

import ctypes
from collections.abc import Iterable, Mapping, Sequence

import moderngl

from app.gl.context import gl_function
from app.gl.shaders import ShaderCache
from app.gl.texture_storage import LevelFramebuffer

FULLSCREEN_VERTEX = "passes/fullscreen.vert"

Texture = moderngl.Texture | moderngl.TextureCube
Textures = Mapping[str, Texture] | Iterable[tuple[str, Texture]]


def set_uniforms(program: moderngl.Program, uniforms: Mapping[str, object]) -> None:
    """Set each of ``uniforms`` the program has (the compiler drops what a permutation does
    not use): ``bytes`` are written whole (arrays, matrices), anything else assigned."""
    for name, value in uniforms.items():
        if name not in program:
            continue
        if isinstance(value, bytes):
            program[name].write(value)
        else:
            program[name].value = value


def bind_textures(program: moderngl.Program, textures: Textures, first_unit: int = 0) -> int:
    """Bind ``textures`` (sampler uniform -> texture) to units ``first_unit``, ... and point
    the program's samplers at them (those it has); returns the next free unit."""
    pairs = textures.items() if isinstance(textures, Mapping) else textures
    unit = first_unit
    for name, texture in pairs:
        texture.use(unit)
        if name in program:
            uniform = program[name]
            if uniform.gl_type == GL_SAMPLER_BUFFER:  # moderngl's setter drops these
                _sampler_unit(program, uniform.location, unit)
            else:
                uniform.value = unit
        unit += 1
    return unit


GL_SAMPLER_BUFFER = 0x8DC2  # a samplerBuffer uniform (app/gl/texel_buffer.py's textures)


def _sampler_unit(program: moderngl.Program, location: int, unit: int) -> None:
    """Point the sampler uniform at ``location`` of ``program`` at texture unit ``unit``
    through the GL (moderngl 5.13 takes a samplerBuffer's value and sets nothing)."""
    enum, int_ = ctypes.c_uint, ctypes.c_int
    gl_function(program.ctx, "glUseProgram", [enum])(program.glo)
    gl_function(program.ctx, "glUniform1i", [int_, int_])(location, unit)


class FullscreenDraw:
    """One program drawn as the full-screen triangle: the program and its empty vertex
    array. The program is the shader cache's (``of``) unless ``owns_program``."""

    def __init__(
        self, ctx: moderngl.Context, program: moderngl.Program, owns_program: bool = False
    ) -> None:
        self.ctx = ctx
        self.program = program
        self.vao = ctx.vertex_array(program, [])
        self._owns_program = owns_program

    @classmethod
    def of(
        cls,
        ctx: moderngl.Context,
        shaders: ShaderCache,
        fragment: str,
        defines: Mapping[str, object] | None = None,
    ) -> FullscreenDraw:
        """The draw of glsl/``fragment`` with ``defines`` behind passes/fullscreen.vert
        (compiled with the same defines: ``FAR_PLANE`` moves the triangle)."""
        return cls(ctx, shaders.program(FULLSCREEN_VERTEX, fragment, dict(defines or {})))

    def draw(
        self,
        fbo: moderngl.Framebuffer | None = None,
        uniforms: Mapping[str, object] | None = None,
        textures: Textures | None = None,
        *,
        viewport: tuple[int, int, int, int] | None = None,
        depth_func: str | None = None,
        first_unit: int = 0,
        add: bool = False,
    ) -> None:
        """Draw the triangle into ``fbo`` (None: the framebuffer bound now) with
        ``textures`` bound from ``first_unit`` on and ``uniforms`` set (every draw: a shader
        cache may hand the same program to passes of other parameters). ``depth_func``:
        the depth test against ``fbo``'s depth attachment (">" for a far-plane triangle);
        None draws without it. ``add``: the output added to what the target holds (one
        share of a sum drawn by several programs), else written over it."""
        ctx = self.ctx
        if fbo is not None:
            fbo.use()
        if viewport is not None:
            ctx.viewport = viewport
        if textures is not None:
            bind_textures(self.program, textures, first_unit)
        if uniforms:
            set_uniforms(self.program, uniforms)
        ctx.disable(moderngl.BLEND)
        if add:
            ctx.enable(moderngl.BLEND)
            ctx.blend_func = moderngl.ONE, moderngl.ONE
            ctx.blend_equation = moderngl.FUNC_ADD
        if depth_func is None:
            ctx.disable(moderngl.DEPTH_TEST)
            self.vao.render(moderngl.TRIANGLES, vertices=3)
        else:
            ctx.enable(moderngl.DEPTH_TEST)
            ctx.depth_func = depth_func
            self.vao.render(moderngl.TRIANGLES, vertices=3)
            ctx.disable(moderngl.DEPTH_TEST)
            ctx.depth_func = "<"
        if add:
            ctx.disable(moderngl.BLEND)
            ctx.blend_func = moderngl.DEFAULT_BLENDING

    def release(self) -> None:
        self.vao.release()
        if self._owns_program:
            self.program.release()


class LevelDraws:
    """Full-screen draws into levels of textures (mips the project draws itself: app/render/
    normal_chain.py, app/render/srgb_mips.py): one ``LevelFramebuffer``, a ``FullscreenDraw``
    per fragment file and defines, made at its first draw, with ``shaders``' programs (a
    cache of its own where none is given, released with it)."""

    def __init__(self, ctx: moderngl.Context, shaders: ShaderCache | None = None) -> None:
        self.ctx = ctx
        self._own = shaders is None
        self.shaders = ShaderCache(ctx) if shaders is None else shaders
        self._draws: dict[tuple, FullscreenDraw] = {}
        self.fbo = LevelFramebuffer(ctx)

    def draw(
        self,
        fragment: str,
        defines: Mapping[str, object],
        into: Sequence[tuple[moderngl.Texture, int]],
        uniforms: Mapping[str, object],
        textures: Textures,
    ) -> None:
        """Draw glsl/``fragment`` with ``defines`` into the levels ``into`` ((texture,
        level), colour attachments 0, 1, ...; the viewport the first one's)."""
        key = (fragment, tuple(sorted(defines.items())))
        if key not in self._draws:
            self._draws[key] = FullscreenDraw.of(self.ctx, self.shaders, fragment, defines)
        self.fbo.attach(into)
        self._draws[key].draw(None, uniforms, textures)

    def check(self) -> None:
        """``LevelFramebufferError`` where the GL reported an error since it was made."""
        self.fbo.check()

    def release(self) -> None:
        self.fbo.release()
        for draw in self._draws.values():
            draw.release()
        if self._own:
            self.shaders.release()
