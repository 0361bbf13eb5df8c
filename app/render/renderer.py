"""The frame: scene -> frame data -> G-buffer pass -> culling -> lighting pass -> blend pass
(alpha-blended parts only, app/render/blend.py) -> post.

``Renderer`` owns the GPU objects of one scene at one size; ``render()`` runs the passes,
and the ``read_*`` methods bring each stage's result back for output and tests.

A renderer changes without being rebuilt, as a scheduler: every object it builds (the
G-buffer's targets, the G-buffer pass, the culler, the environment's light, the shadow
maps, the lighting and blend passes, the environment background, depth of field, the
resolve, post and the camera's matrices) is declared once in ``SCHEDULE`` with a key, a
hashable value computed from exactly the inputs it is built from (scene, frame data,
render settings, ``RenderOptions``, size), a build function, and the built objects it uses
(``needs``). ``set_camera``, ``set_lights``, ``set_materials``, ``set_settings``,
``set_options``, ``resize`` and ``update`` (an edited scene) change the inputs, then
``_change`` recomputes every key and builds again exactly the objects whose key changed
and those that need a rebuilt one, in the order of ``SCHEDULE``, releasing the old ones;
``builds`` counts the builds per object (tests/test_renderer_schedule.py).

Programs come from one ``ShaderCache`` that lives as long as the renderer, so a change
compiles only a model combination it has never seen; renderers of the same context may
share one cache (a comparison's two sides, app/render/compare.py), whose owner releases it.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from collections import Counter
from collections.abc import Callable, Hashable
from dataclasses import dataclass
from functools import cached_property

import moderngl
import numpy as np

from app.common.camera import CameraFrame
from app.common.gbuffer import MAX_COLOR_TARGETS, GBufferData, GBufferLayout
from app.common.lights import PunctualLight
from app.common.tonemaps import TONEMAP_CODE
from app.frame import FrameData, prepare_frame, restyle, restyle_file_materials
from app.frame.camera import camera_frame, projection_matrix, view_matrix
from app.frame.lights import environment_texels, frame_lights, uniform_environment
from app.frame.materials import MaterialTable
from app.gl.context import GLContext
from app.gl.shaders import ShaderCache
from app.reference.antialiasing import jitter_offsets
from app.render.antialias import (
    SRAA_SAMPLES,
    AccumulatePass,
    FxaaPass,
    GbaaPass,
    PartRects,
    SraaPass,
    jittered_frame,
)
from app.render.background import EnvironmentBackground, EnvironmentSource
from app.render.blend import BlendPass, blend_defines, blended, forward_drawables
from app.render.culling import LightCuller, check_tile_masks, tiles_used
from app.render.fullscreen import read_rgba
from app.render.gbuffer import FLUSH_TRIANGLES, GBuffer, GBufferPass
from app.render.ibl import EnvironmentLighting, UniformEnvironment
from app.render.inputs import ShadingContext, shading_context
from app.render.lighting import LightingPass
from app.render.limits import (
    check_memory,
    check_multisampling,
    check_render_size,
    target_bytes_per_pixel,
)
from app.render.mesh_drawable import masked, rotated
from app.render.msaa import MSAA_SAMPLES, MsaaPass
from app.render.post import DofPass, DownsamplePass, PostPass
from app.render.sample_geometry import SampleInputs
from app.render.shadows import ShadowPass, check_shadow_resolutions, shadow_atlas_bytes
from app.render.texture_upload import TextureUploads
from app.render.transmission import TransmissionPass, transmission_defines, transmissive
from app.scene.edits import replace_parts
from app.scene.geometry import MeshPart
from app.scene.loader import LoadedScene
from app.scene.model import (
    DEFAULT_ANTIALIASING,
    Camera,
    Environment,
    Light,
    Material,
    RenderSettings,
    Scene,
)

# Layouts whose shed targets were noted (once a process each; Renderer._layout).
_SHED_NOTED: set[GBufferLayout] = set()
# Scenes whose "msaa" fell back to "fxaa" (noted once a process each; Renderer.antialiasing).
_MSAA_NOTED: set[str] = set()


@dataclass(frozen=True)
class RenderOptions:
    """The pipeline's variants that are not scene keys: the bench's "before" and its
    alternatives, and the tests' references. The renderer reads them only through the
    keys of ``SCHEDULE`` (and the frame's plan, ``fused_display``), so changing one
    (``Renderer.set_options``) builds again only what it changes.

    ``uber``: one lighting program with run-time model selection instead of one per model
    group (the ``specialization`` suite). ``ms_table``: the float32 (forms, n, n, 2) Kulla-Conty
    tables of every G2 form at a size other than the shipped 64 x 64
    (``app.reference.multiscatter.load_tables(n)``); a key
    holds the array itself, so a new array is a new table.
    ``light_form``: where the lighting pass reads its lights (app/render/lighting.py
    ``LIGHT_FORMS``); None lets the pass choose from the light count.
    ``constant_surfaces``: False keeps RT0 and RT1's surface numbers in the G-buffer even
    where the material table could give them (the bench's "before", and the tests'
    reference for the same image; docs/gbuffer.md, "Constant surfaces").
    ``fuse_post``: a plain frame's lighting pass writes the display image (``fused_display``);
    False: every frame draws the HDR image and runs the post pass on it.
    ``flush_triangles``: the G-buffer pass flushes once this many triangles were drawn since
    the last flush (app/render/gbuffer.py FLUSH_TRIANGLES); 0: one flush at the end.
    ``interactive``: the viewer's frames, which leave out ``render.gbaa_interior`` (gbaa's
    interior correction, over the viewer's cost bound; app/render/antialias.py
    ``GbaaPass``; docs/antialiasing.md): a still (False) draws it where the scene asks.
    """

    uber: bool = False
    ms_table: np.ndarray | None = dataclasses.field(default=None, compare=False)
    light_form: str | None = None
    constant_surfaces: bool = True
    fuse_post: bool = True
    flush_triangles: int = FLUSH_TRIANGLES
    interactive: bool = False


def environment_source(env: Environment) -> EnvironmentSource:
    """An image, sky or studio environment's map (cached), rotation and intensity."""
    return EnvironmentSource(environment_texels(env), env.rotation, env.intensity)


class Same:
    """A part of a key that compares by identity: equal only to a ``Same`` of the very same
    object. It holds the object, so that while a key is kept its object cannot be freed
    and its id given to a new one. For inputs that are replaced, never edited in place
    (the frame's parts and lights lists, a surface layer, an ``ms_table`` array)."""

    __slots__ = ("obj",)

    def __init__(self, obj: object) -> None:
        self.obj = obj

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Same) and other.obj is self.obj

    def __hash__(self) -> int:
        return id(self.obj)

    def __repr__(self) -> str:
        return f"Same({type(self.obj).__name__} at {id(self.obj):#x})"


class _FrameFacts:
    """What the keys read from one ``FrameData``, computed once per frame object (a camera
    move recomputes every key; the frame's parts are not walked again for it). A frame is
    replaced, never edited in place, by every change the renderer makes (``restyle``
    replaces layers of the same parts and returns a new ``FrameData``)."""

    def __init__(self, frame: FrameData) -> None:
        self.frame = frame
        parts = frame.parts
        # the parts the G-buffer pass draws and the shadow maps' casters: all but blended
        # and transmissive ones (a transmissive part is drawn by the transmission pass)
        glass = [transmissive(part) for part in parts]
        self.transmissive = tuple(i for i, part in enumerate(parts) if glass[i])
        self.opaque = tuple(i for i, part in enumerate(parts) if not blended(part) and not glass[i])
        self.blended = tuple(i for i, part in enumerate(parts) if blended(part) and not glass[i])
        self.transmissive_ids = tuple(tuple(frame.material_ids[i]) for i in self.transmissive)
        # the G-buffer pass compiles a part's alpha test and tangent rotation in or out
        self.compiled = tuple((masked(parts[i]), rotated(parts[i])) for i in self.opaque)
        # an alpha-masked caster's coverage shapes its shadow (docs/shadows.md): its layer,
        # which a material edit replaces (``restyle``)
        self.masks = tuple((i, Same(parts[i].layers[0])) for i in self.opaque if masked(parts[i]))
        # the maps the G-buffer pass uploads, which a model file's roughness edit replaces
        # on the same parts (``restyle_file_materials``: a new normal/roughness chain)
        self.maps = tuple(
            Same(texture)
            for i in self.opaque
            for layer in parts[i].layers
            for texture in layer.maps.values()
        )
        self.blended_ids = tuple(tuple(frame.material_ids[i]) for i in self.blended)
        # the opaque mesh triangles, which choose the default antialiasing
        # (``Renderer.antialiasing``)
        self.mesh_triangles = sum(
            len(parts[i].indices) // 3 for i in self.opaque if parts[i].analytic is None
        )
        # an opaque surface samples a texture map, which leaves gbaa's interior correction
        # out where the scene does not name it (``Renderer.gbaa_interior``)
        self.textured = any(layer.maps for i in self.opaque for layer in parts[i].layers)

    @cached_property
    def table(self) -> Hashable:
        """The material table's content: what the lighting and blend passes upload and
        compile from (a material edit that leaves it as it was keeps them)."""
        t = self.frame.materials
        return (
            tuple(t.models), tuple(t.groups), t.packed().tobytes(), t.needs_tangents,
            t.needs_coat_normals, t.needs_emission, t.constant_surfaces,
        )  # fmt: skip


@dataclass(frozen=True)
class CameraMatrices:
    """The camera's view and projection matrices (``size``'s aspect) and the lighting
    pass's camera frame at ``render_size``."""

    view: np.ndarray
    proj: np.ndarray
    frame: CameraFrame


@dataclass(frozen=True)
class Built:
    """One object the renderer builds: the attribute that holds it (None where the frame
    has none), its key (``key(renderer)``, a hashable value of exactly the inputs it is
    built from; None: the frame has no such object), its build function, the built
    objects it uses (rebuilt with them: ``needs``, all earlier in ``SCHEDULE``), a check
    that refuses its inputs before anything is released (InputError, app/render/limits.py),
    and ``refresh``: for a kept object, a key and an in-place update for it (the G-buffer
    pass's material ids)."""

    name: str
    key: Callable[[Renderer], Hashable]
    build: Callable[[Renderer], object]
    needs: tuple[str, ...] = ()
    check: Callable[[Renderer], None] | None = None
    refresh: tuple[Callable[[Renderer], Hashable], Callable[[Renderer], None]] | None = None


class _PassClock:
    """Wall time per pass, waiting for the GPU after each one; does nothing without a dict."""

    def __init__(self, ctx: moderngl.Context, timings: dict[str, float] | None) -> None:
        self.ctx, self.timings = ctx, timings
        if timings is not None:
            ctx.finish()
            self.last = time.perf_counter()

    def done(self, name: str) -> None:
        if self.timings is not None:
            self.ctx.finish()
            now = time.perf_counter()
            self.timings[name] = (now - self.last) * 1e3
            self.last = now


@dataclass
class _Drawn:
    """What the last frame drew with the passes as they are: its camera and background
    (an HDR image completed later uses them, not an edit made since), whether the HDR
    image exists and whether the lighting pass wrote the display image (fused)."""

    camera: CameraFrame
    background: np.ndarray
    hdr: bool
    display: bool


# Render settings whose change needs new mesh parts (their maps' mips and baked blends).
_PART_SETTINGS = ("normal_filter", "blend")

# Past this many opaque mesh triangles a scene that leaves render.antialiasing unset
# draws "fxaa" instead of "gbaa" (``Renderer.antialiasing``; docs/antialiasing.md
# measures both sides of it).
GBAA_DEFAULT_TRIANGLES = 20_000

_UNBUILT = object()  # the old key of an object never built

# Built objects whose rebuild drops what the last frame drew (its G-buffer, HDR or
# display image): reading the HDR image then needs a new frame.
_FRAME_OBJECTS = frozenset(
    {"gbuffer", "lighting", "transmission", "blend", "sraa", "dof", "resolve", "accumulate"}
    | {"post", "fxaa", "gbaa", "msaa"}
)


class Renderer:
    """One scene, one image size, headless.

    With ``render.supersample = n`` every pass before post runs at n x n times the pixels
    (``render_size``) and a resolve box-filters the HDR image down to ``size``. ``size``
    overrides the scene's render.width and render.height. ``options``: the pipeline's
    variants (``RenderOptions``). ``shaders``: a cache of the same context to take
    programs from (every pass sets its uniforms on each run, so passes of two renderers
    can use one program); the renderer then leaves its release to the caller, who
    releases it after every renderer that uses it.
    """

    def __init__(
        self,
        gl: GLContext,
        loaded: LoadedScene,
        size: tuple[int, int] | None = None,
        options: RenderOptions | None = None,
        shaders: ShaderCache | None = None,
    ) -> None:
        self.gl = gl
        self.options = options or RenderOptions()
        self._owns_shaders = shaders is None
        self.shaders = ShaderCache(gl.ctx) if shaders is None else shaders
        self.loaded = loaded
        self._size = size
        self._hdr_wanted = False  # want_hdr: every frame draws the HDR image
        self._drawn: _Drawn | None = None  # the last frame, until its passes are rebuilt
        self.frame: FrameData = prepare_frame(loaded)
        self._facts: _FrameFacts | None = None
        # the key each built object was built with; absent: not built (or released)
        self._keys: dict[str, Hashable] = {}
        self.builds: Counter[str] = Counter()  # builds per object over the renderer's life
        self.rebuilt: tuple[str, ...] = ()  # the objects the last change built again
        self.matrices: CameraMatrices | None = None
        self.gbuffer: GBuffer | None = None  # the G-buffer's targets
        self.gbuffer_pass: GBufferPass | None = None
        self.blend: BlendPass | None = None  # only where a part is alpha-blended
        self.transmission: TransmissionPass | None = None  # only where a part transmits
        self.culler: LightCuller | None = None
        self.lighting: LightingPass | None = None
        self.shading: ShadingContext | None = None  # the frame's shader inputs (lighting's)
        self.background: EnvironmentBackground | None = None  # [environment] background
        # the environment's light: the split sum (image, sky, studio) or the uniform
        # environment's quadrature (docs/ibl.md)
        self.ibl: EnvironmentLighting | UniformEnvironment | None = None
        self.shadows: ShadowPass | None = None  # only where a light casts shadows
        # the transmissive parts' maps on the GL, which the transmission pass and the
        # shadow pass's textured-glass casters both draw with
        self.glass_maps: TextureUploads | None = None
        self.dof: DofPass | None = None
        self.resolve: DownsamplePass | None = None
        # render.antialiasing (docs/antialiasing.md): the jittered frames' running mean,
        # and the display image's FXAA-class filter
        self.accumulate: AccumulatePass | None = None
        # the subpixel reconstruction's geometry samples and resolved HDR image ("sraa")
        self.sraa: SraaPass | None = None
        # the multisampled G-buffer's per-sample shading of the edge pixels ("msaa")
        self.msaa: MsaaPass | None = None
        self.post: PostPass | None = None
        self.fxaa: FxaaPass | None = None
        # the geometric edge resolve of the display image's silhouettes ("gbaa")
        self.gbaa: GbaaPass | None = None
        self._refreshed: dict[str, Hashable] = {}  # Built.refresh's key per kept object
        self._restyled: list | None = None  # _change's rollback of a restyle
        self._change()

    # --- what the renderer shows -----------------------------------------------------------

    @property
    def scene(self) -> Scene:
        return self.loaded.scene

    @property
    def lights(self) -> list[PunctualLight]:
        """The frame's lights, in the order every pass sums them."""
        return self.frame.lights

    @property
    def uniform_environment(self) -> tuple[np.ndarray, int] | None:
        """The scene's uniform environment as the twins take it (radiance, directions:
        ``shade_gbuffer``'s ``environment``); None for none or another source."""
        return uniform_environment(self.scene.environment)

    @property
    def materials(self) -> MaterialTable:
        """The frame's material table (app/frame/materials.py)."""
        return self.frame.materials

    @property
    def size(self) -> tuple[int, int]:
        """The output image's (width, height)."""
        if self._size is not None:
            return self._size
        return (self.scene.render.width, self.scene.render.height)

    @property
    def render_size(self) -> tuple[int, int]:
        """The size every pass before the resolve runs at (``size`` x supersample)."""
        return self.scene.render.drawn_size(self.size)

    @property
    def view(self) -> np.ndarray:
        """World -> view matrix of the current camera."""
        return self.matrices.view

    @property
    def proj(self) -> np.ndarray:
        """View -> clip matrix of the current camera at ``size``'s aspect."""
        return self.matrices.proj

    @property
    def camera(self) -> CameraFrame:
        """The lighting pass's camera frame at ``render_size``."""
        return self.matrices.frame

    @property
    def transparent(self) -> bool:
        """``render.background = "transparent"``: pixels no surface covers hold nothing
        (alpha 0), the HDR image is RGBA premultiplied by coverage and the display image
        RGBA with straight alpha (``read_rgba``; docs/architecture.md, "Alpha")."""
        return self.scene.render.background == "transparent"

    @property
    def fuse_post(self) -> bool:
        """``options.fuse_post`` (read-only: change it with ``set_options``)."""
        return self.options.fuse_post

    @property
    def keys(self) -> dict[str, Hashable]:
        """The key each built object was built with (a copy; tests and debugging)."""
        return dict(self._keys)

    # --- the inputs the keys read ------------------------------------------------------------

    def _frame_facts(self) -> _FrameFacts:
        if self._facts is None or self._facts.frame is not self.frame:
            self._facts = _FrameFacts(self.frame)
        return self._facts

    def _constant_surfaces(self) -> bool:
        """Whether the G-buffer leaves the surface numbers to the material table
        (docs/gbuffer.md, "Constant surfaces"): every part drawn has its material's
        constants at every pixel (``MaterialTable.constant_surfaces``), no screen-space
        specular antialiasing widens the roughness per pixel, and the targets are float32,
        so that the table's float32 numbers are exactly those the targets would hold."""
        settings = self.scene.render
        return (
            self.options.constant_surfaces
            and self.materials.constant_surfaces
            and settings.gbuffer == "f32"
            and not settings.specular_aa
        )

    def _layout(self) -> GBufferLayout:
        """What decides the G-buffer targets' formats and attachments, and with them the
        defines of every pass that writes or decodes them (``GBuffer.defines``): the
        encoding, the optional targets and constant surfaces (frozen: a key)."""
        defines = self.materials.gbuffer_defines()
        if self._gbaa():  # the edge distances of the geometric resolve
            defines["GBUFFER_EDGE"] = 1
        layout = GBufferLayout.from_defines(
            self.scene.render.gbuffer, defines, self._constant_surfaces()
        )
        fitted = layout.fitted()
        if fitted != layout and layout not in _SHED_NOTED:  # more than a pass may write
            _SHED_NOTED.add(layout)
            logging.getLogger("pbs").info(
                "the G-buffer would need %d colour targets, past the %d a pass may write: "
                "%s left out (those materials use their factors alone)",
                len(layout.targets()), MAX_COLOR_TARGETS,
                ", ".join(sorted(layout.optional - fitted.optional)),
            )  # fmt: skip
        return fitted

    @property
    def antialiasing(self) -> str:
        """The antialiasing this renderer draws: ``render.antialiasing``, except that a
        scene which leaves it unset (``DEFAULT_ANTIALIASING``, "gbaa") and has more than
        ``GBAA_DEFAULT_TRIANGLES`` opaque mesh triangles gets "fxaa": gbaa's geometry
        stage runs once per triangle, on llvmpipe on one thread, and on a dense scene it
        cost more than the rest of the frame (docs/antialiasing.md, "The choice"). A
        scene that names "gbaa" gets it whatever its triangles."""
        settings = self.scene.render
        mode = settings.antialiasing
        if mode == "msaa":
            return self._msaa_fallback()
        if mode is not None:
            return mode
        dense = self._frame_facts().mesh_triangles > GBAA_DEFAULT_TRIANGLES
        return "fxaa" if dense else DEFAULT_ANTIALIASING

    def _msaa_fallback(self) -> str:
        """The mode "msaa", or "fxaa" (noted once a process per scene) where alpha-blended or
        transmissive parts are drawn over the opaque image: their colour at an edge pixel
        is the pixel centre's, which the per-sample shading would overwrite."""
        facts = self._frame_facts()
        if not (facts.blended or facts.transmissive):
            return "msaa"
        path = str(self.loaded.path)
        if path not in _MSAA_NOTED:
            _MSAA_NOTED.add(path)
            logging.getLogger("pbs").info(
                '%s: render.antialiasing = "msaa" does not resolve blended or transmissive '
                'parts yet; drawn with "fxaa"',
                path,
            )
        return "fxaa"

    def _gbaa(self) -> bool:
        """``antialiasing`` "gbaa" at one sample per pixel (with supersampling the resolve
        is the box filter's; the G-buffer then has no ``edge`` target)."""
        return self.antialiasing == "gbaa" and self.scene.render.supersample == 1

    def _specular_aa(self) -> tuple[float, float] | None:
        settings = self.scene.render
        if not settings.specular_aa:
            return None
        return (settings.specular_aa_variance, settings.specular_aa_threshold)

    def _opaque(self) -> list[int]:
        """Indices of the parts the G-buffer pass draws: all but the blended ones."""
        return list(self._frame_facts().opaque)

    def _opaque_parts(self) -> tuple[list[MeshPart], list[list[int]]]:
        """The parts the G-buffer pass draws and their material ids (``_opaque``), which
        the passes that draw them again take with the rest of ``_sample_inputs``."""
        opaque = self._opaque()
        return [self.frame.parts[i] for i in opaque], [self.frame.material_ids[i] for i in opaque]

    def _sample_inputs(self) -> SampleInputs:
        """What the passes that draw the opaque parts again into samples of their own
        (SRAA's and MSAA's ``SampleGeometry``) take, as one value: the G-buffer pass's
        parts, material ids and maps, the context, shader cache, render size and layout.
        A new such input is a field of ``SampleInputs`` and a value here."""
        parts, material_ids = self._opaque_parts()
        return SampleInputs(
            self.gl.ctx, self.shaders, self.render_size, self._layout(), parts, material_ids,
            self.gbuffer_pass.uploads,
        )  # fmt: skip

    def _environment_key(self) -> Hashable:
        """A map environment as its map and light are made from it (``environment_source``:
        the map's source settings, rotation, intensity), or a uniform one's radiance and
        directions (``uniform_environment``); not ``background``, which only says whether
        the map is drawn behind the objects."""
        env = self.scene.environment
        if env.source == "uniform":
            return ("uniform", tuple(env.radiance), env.samples)
        sun = None if env.sun_direction is None else tuple(env.sun_direction)
        return (env.source, env.file, sun, env.turbidity, env.rotation, env.intensity)

    # --- keys, checks and builds of each object (SCHEDULE, below the class) ----------------

    def _key_camera(self) -> Hashable:
        cam = self.scene.camera
        place = (tuple(cam.position), tuple(cam.target), tuple(cam.up))
        return (place, cam.fov_y, cam.near, cam.far, self.size, self.render_size)

    def _build_camera(self) -> CameraMatrices:
        cam = self.scene.camera
        w, h = self.size
        return CameraMatrices(
            view_matrix(cam), projection_matrix(cam, w / h), camera_frame(cam, *self.render_size)
        )

    def _key_gbuffer(self) -> Hashable:
        return (self.render_size, self._layout())

    def _check_gbuffer(self) -> None:
        """RefusedError before anything is allocated or released (app/render/limits.py):
        a renderer that refuses a size keeps its old targets."""
        settings = self.scene.render
        glass = bool(self._frame_facts().transmissive)  # the transmission pass's copy
        per_pixel = target_bytes_per_pixel(
            self._layout(), self.scene.camera.aperture > 0.0, transmission=glass
        )
        check_render_size(
            self.gl.ctx, self.size, settings.supersample, per_pixel, str(self.loaded.path),
            "size" if self._size is not None else "render.width, render.height",
        )  # fmt: skip
        w, h = self.render_size
        check_shadow_resolutions(self.gl.ctx, self.scene.lights, str(self.loaded.path))
        check_memory(
            self.frame.parts, self.frame.decoded, w * h * per_pixel,
            shadow_atlas_bytes(self.scene.lights, glass), self.loaded.policy.limits.max_memory,
            str(self.loaded.path),
        )  # fmt: skip

    def _build_gbuffer(self) -> GBuffer:
        return GBuffer(self.gl.ctx, self.render_size, self._layout())

    def _key_gbuffer_pass(self) -> Hashable:
        """The opaque parts' geometry and maps (a new frame's parts, a new map on the same
        parts), which of them draw (a part turned blended leaves), what each compiles in
        (alpha test, tangent rotation), specular antialiasing, the targets' layout and the
        flush variant; not the size (a resize keeps the pass) and not the material ids
        (``refresh``)."""
        facts = self._frame_facts()
        return (
            Same(self.frame.parts), facts.opaque, facts.compiled, facts.maps,
            self._specular_aa(), self._layout(), self.options.flush_triangles,
        )  # fmt: skip

    def _build_gbuffer_pass(self) -> GBufferPass:
        gbuffer_pass = GBufferPass(
            self.gl.ctx, self.shaders, *self._opaque_parts(), self._specular_aa(),
            self.gbuffer.defines(),
        )  # fmt: skip
        gbuffer_pass.flush_triangles = self.options.flush_triangles
        return gbuffer_pass

    def _refresh_key_gbuffer_pass(self) -> Hashable:
        return Same(self.frame.material_ids)

    def _refresh_gbuffer_pass(self) -> None:
        """A material edit that restyles the parts in place (``app.frame.restyle``) gives
        them new material ids: the kept pass draws with them."""
        for drawable, i in zip(self.gbuffer_pass.drawables, self._opaque(), strict=True):
            drawable.material_ids = self.frame.material_ids[i]

    def _key_ibl(self) -> Hashable:
        env = self.scene.environment
        if env is None:
            return None
        return self._environment_key()  # docs/ibl.md

    def _build_ibl(self) -> EnvironmentLighting | UniformEnvironment:
        env = self.scene.environment
        if env.source != "uniform":
            return EnvironmentLighting(self.gl.ctx, self.shaders, environment_source(env))
        return UniformEnvironment(*uniform_environment(env))

    def _key_shadows(self) -> Hashable:
        """Where a light casts shadows (docs/shadows.md): the lights, the parts (the opaque
        ones cast, the blended ones only receive) and each masked caster's layer."""
        if not any(light.shadow is not None for light in self.lights):
            return None
        facts = self._frame_facts()
        glass = tuple(Same(self.frame.parts[i].layers[0]) for i in facts.transmissive)
        return (Same(self.lights), Same(self.frame.parts), facts.opaque, facts.masks, glass)

    def _check_shadows(self) -> None:
        check_shadow_resolutions(self.gl.ctx, self.scene.lights, str(self.loaded.path))

    def _build_shadows(self) -> ShadowPass:
        opaque = set(self._opaque())
        parts = [p for i, p in enumerate(self.frame.parts) if i in opaque]
        blends = [p for i, p in enumerate(self.frame.parts) if i not in opaque]
        # transmissive parts tint the light through them (docs/shadows.md, "Glass")
        glass = [self.frame.parts[i] for i in self._frame_facts().transmissive]
        return ShadowPass(
            self.gl.ctx, self.shaders, self.lights, parts, blends, glass, self.glass_maps
        )

    def _key_glass_maps(self) -> Hashable:
        """Only where a part is transmissive: those parts and their layers (the maps)."""
        facts = self._frame_facts()
        if not facts.transmissive:
            return None
        layers = tuple(Same(self.frame.parts[i].layers[0]) for i in facts.transmissive)
        return (Same(self.frame.parts), facts.transmissive, layers)

    def _build_glass_maps(self) -> TextureUploads:
        """One GL texture per map of the transmissive parts, uploaded at the first draw
        that asks (the shadow casters' glass maps, the transmission pass's every map):
        the same textures in both passes, not a copy in each."""
        return TextureUploads(self.gl.ctx, self.shaders)

    def _key_culler(self) -> Hashable:
        """The tile culler, where the frame culls by tiles (``tiles_used``): its tiles are
        the image's."""
        if not tiles_used(self.scene.render.light_culling, self.lights):
            return None
        return (self.render_size, Same(self.lights))

    def _check_culler(self) -> None:
        check_tile_masks(self.gl.ctx, self.render_size, self.lights, str(self.loaded.path))

    def _build_culler(self) -> LightCuller:
        return LightCuller(self.gl.ctx, self.shaders, self.render_size, self.lights)

    def _key_lighting(self) -> Hashable:
        """The lights, the material table's content, the terms, the targets' layout, its
        HDR target's size and the variants; the culler, environment light and shadow maps
        it binds are ``needs``."""
        o = self.options
        return (
            self.render_size, Same(self.lights), self._frame_facts().table,
            self.scene.render.terms, self._layout(), o.uber, Same(o.ms_table), o.light_form,
        )  # fmt: skip

    def _build_lighting(self) -> LightingPass:
        options = self.options
        # the frame's shader inputs (app/render/inputs.py), released with the lighting pass
        self.shading = shading_context(
            self.gl.ctx, self.lights, self.materials, gbuffer=self.gbuffer,
            ms_table=options.ms_table, every_table=options.uber, environment=self.ibl,
            shadows=self.shadows, tiles=self.culler,
        )  # fmt: skip
        return LightingPass(
            self.gl.ctx, self.shaders, self.render_size, self.shading, self.scene.render.terms,
            options.uber, form=options.light_form,
        )  # fmt: skip

    def _key_transmission(self) -> Hashable:
        """Only where a part is transmissive (every other scene compiles and renders as
        before it existed): those parts, their rows, the table, terms and specular
        antialiasing; it shades with the lighting pass's inputs (``needs``)."""
        facts = self._frame_facts()
        if not facts.transmissive:
            return None
        return (
            Same(self.frame.parts), facts.transmissive, facts.transmissive_ids, facts.table,
            self.scene.render.terms, self._specular_aa(),
        )  # fmt: skip

    def _build_transmission(self) -> TransmissionPass:
        parts, ids = self.frame.parts, self.frame.material_ids
        chosen = self._frame_facts().transmissive
        drawables = forward_drawables(
            self.gl.ctx, self.shaders, [parts[i] for i in chosen], [ids[i] for i in chosen],
            self.materials, self.scene.render.terms, self._specular_aa(),
            transmission_defines(self.shading), self.glass_maps,
        )  # fmt: skip
        return TransmissionPass(self.gl.ctx, drawables, self.shading)

    def _key_blend(self) -> Hashable:
        """Only where a part is alpha-blended (every other scene compiles and renders as
        before it existed): those parts, their rows, the table, terms and specular
        antialiasing; it shades with the lighting pass's lights and defines (``needs``)."""
        facts = self._frame_facts()
        if not facts.blended:
            return None
        return (
            Same(self.frame.parts), facts.blended, facts.blended_ids, facts.table,
            self.scene.render.terms, self._specular_aa(),
        )  # fmt: skip

    def _build_blend(self) -> BlendPass:
        parts, ids = self.frame.parts, self.frame.material_ids
        chosen = self._frame_facts().blended
        drawables = forward_drawables(
            self.gl.ctx, self.shaders, [parts[i] for i in chosen], [ids[i] for i in chosen],
            self.materials, self.scene.render.terms, self._specular_aa(),
            blend_defines(self.shading),
        )  # fmt: skip
        return BlendPass(self.gl.ctx, drawables, self.shading)

    def _key_background(self) -> Hashable:
        """The environment behind the objects, only where ``[environment] background``
        and the background is not transparent (which leaves those pixels empty)."""
        env = self.scene.environment
        if env is None or not env.background or self.transparent:
            return None
        return self._environment_key()

    def _build_background(self) -> EnvironmentBackground:
        env = self.scene.environment
        return EnvironmentBackground(self.gl.ctx, self.shaders, environment_source(env))

    def _key_sraa(self) -> Hashable:
        """The subpixel reconstruction, only with ``render.antialiasing = "sraa"``: its
        geometry pass draws the G-buffer pass's parts into its own multisampled targets,
        with that pass's material maps (``needs``)."""
        if self.antialiasing != "sraa":
            return None
        return (self.render_size, self._key_gbuffer_pass())

    def _check_sraa(self) -> None:
        check_multisampling(self.gl.ctx, SRAA_SAMPLES, str(self.loaded.path), "render.antialiasing")

    def _build_sraa(self) -> SraaPass:
        return SraaPass(self._sample_inputs())

    def _refresh_sraa(self) -> None:
        """A restyle's new material ids, in the geometry samples too (their RT2 ids are
        matched against the frame's)."""
        self.sraa.geometry.refresh(self._opaque_parts()[1])

    def _key_msaa(self) -> Hashable:
        """The multisampled G-buffer and its per-sample shading, only with
        ``render.antialiasing = "msaa"``: the G-buffer pass's parts and maps
        (``needs``), the lighting pass's shader inputs and programs."""
        if self.antialiasing != "msaa":
            return None
        return (self.render_size, self._key_gbuffer_pass(), self._key_lighting())

    def _check_msaa(self) -> None:
        check_multisampling(self.gl.ctx, MSAA_SAMPLES, str(self.loaded.path), "render.antialiasing")

    def _build_msaa(self) -> MsaaPass:
        return MsaaPass(
            self._sample_inputs(), self.shading, self.scene.render.terms, self.lighting.form,
            PartRects(self.render_size, *self._opaque_extents()),
        )  # fmt: skip

    def _refresh_msaa(self) -> None:
        """A restyle's new material ids, in the multisampled G-buffer too."""
        self.msaa.geometry.refresh(self._opaque_parts()[1])

    def _key_dof(self) -> Hashable:
        """Depth of field, only for a camera with an aperture: its lens and the image."""
        cam = self.scene.camera
        if cam.aperture <= 0.0:
            return None
        return (self.render_size, cam.aperture, cam.focus, cam.fov_y)

    def _build_dof(self) -> DofPass:
        cam = self.scene.camera
        return DofPass(
            self.gl.ctx, self.shaders, self.render_size, cam.aperture, cam.focus, cam.fov_y
        )

    def _key_resolve(self) -> Hashable:
        """The supersampling resolve, only with ``render.supersample`` > 1."""
        factor = self.scene.render.supersample
        return None if factor <= 1 else (self.size, factor)

    def _build_resolve(self) -> DownsamplePass:
        factor = self.scene.render.supersample
        return DownsamplePass(self.gl.ctx, self.shaders, self.size, factor)

    def _key_accumulate(self) -> Hashable:
        """The jittered frames' running mean, only with ``render.antialiasing = "jitter"``."""
        return (self.size,) if self.antialiasing == "jitter" else None

    def _build_accumulate(self) -> AccumulatePass:
        return AccumulatePass(self.gl.ctx, self.shaders, self.size)

    def _key_fxaa(self) -> Hashable:
        """The display image's filter, only with ``render.antialiasing = "fxaa"``."""
        return (self.size,) if self.antialiasing == "fxaa" else None

    def _build_fxaa(self) -> FxaaPass:
        return FxaaPass(self.gl.ctx, self.shaders, self.size)

    def _key_gbaa(self) -> Hashable:
        """The geometric edge resolve, only with ``render.antialiasing = "gbaa"`` (and no
        supersampling): it writes the display image as post does."""
        if not self._gbaa():
            return None
        parts = (Same(self.frame.parts), self._frame_facts().opaque)
        return (self.size, self.scene.render.tonemap, self.transparent, parts, self.gbaa_interior)

    @property
    def gbaa_interior(self) -> bool:
        """Whether gbaa's interior correction is drawn (``render.gbaa_interior``): in a
        still, not in the viewer's frames (``RenderOptions.interactive``: its cost), and
        where the scene leaves the setting unset (None) only on a frame whose
        opaque surfaces sample no texture map: a map's detail is already filtered by its
        mip chain, and the correction's blur took a textured model further from its
        supersampled frame (docs/antialiasing.md, "The choice"). A scene that names it
        true gets it whatever its surfaces."""
        named = self.scene.render.gbaa_interior
        if named is False or self.options.interactive:
            return False
        return named is True or not self._frame_facts().textured

    def _opaque_extents(self) -> tuple[np.ndarray, np.ndarray]:
        """The opaque parts' extents, world space, for the window rectangles that gbaa's
        draws and msaa's mark cover (``PartRects``): (K, 8, 4) corners of the meshes'
        bounding boxes, (S, 4) the analytic spheres' centres and radii (a sphere's
        rectangle is its silhouette's)."""
        boxes, spheres = [], []
        for i in self._opaque():
            part = self.frame.parts[i]
            model = np.asarray(part.model, np.float64)
            if part.analytic is not None and part.analytic.kind == "sphere":
                scale = float(np.linalg.norm(model[:3, :3], axis=0).max())
                spheres.append([*model[:3, 3], part.analytic.radius * scale])
                continue
            lo, hi = part.vertices[:, :3].min(axis=0), part.vertices[:, :3].max(axis=0)
            box = np.array([[x, y, z, 1.0] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                            for z in (lo[2], hi[2])])  # fmt: skip
            boxes.append(box @ model.T)
        return np.array(boxes).reshape(-1, 8, 4), np.array(spheres).reshape(-1, 4)

    def _build_gbaa(self) -> GbaaPass:
        return GbaaPass(
            self.gl.ctx, self.shaders, self.size, TONEMAP_CODE[self.scene.render.tonemap],
            self.transparent, *self._opaque_extents(), interior=self.gbaa_interior,
        )  # fmt: skip

    def _key_post(self) -> Hashable:
        return (self.size, self.scene.render.tonemap, self.transparent)

    def _build_post(self) -> PostPass:
        return PostPass(
            self.gl.ctx, self.shaders, self.size, self.scene.render.tonemap, self.transparent
        )

    # --- the scheduler ------------------------------------------------------------------------

    def _plan(self, force: frozenset[str] = frozenset()) -> tuple[dict[str, Hashable], list]:
        """Every object's key now, and the objects to build again (or drop), in
        ``SCHEDULE``'s order: a changed key, a forced name, or a needed object built again;
        not an object absent before and after."""
        keys = {b.name: b.key(self) for b in SCHEDULE}
        rebuilt: set[str] = set()
        plan: list[Built] = []
        for b in SCHEDULE:
            key, old = keys[b.name], self._keys.get(b.name, _UNBUILT)
            changed = old != key or b.name in force or any(n in rebuilt for n in b.needs)
            if changed and not (key is None and (old is None or old is _UNBUILT)):
                plan.append(b)
                rebuilt.add(b.name)
        return keys, plan

    def _change(
        self, edit: Callable[[], object] | None = None, force: frozenset[str] = frozenset()
    ) -> tuple[str, ...]:
        """Apply ``edit`` (it changes the scene, size, options or frame data), then build
        again what the change needs (``_plan``). Every check runs first: where the edit or
        a check raises (InputError: past the GL's limits), every input goes back to what
        it was (the parts' layers too: ``restyle`` replaces them in place) and every object
        stays. Then the old objects are released and the new ones built in order, and the
        kept ones refreshed. Returns the names built again or dropped."""
        saved = (self.loaded, self._size, self.options, self.frame)
        self._restyled = None  # the parts' layers before a restyle (_stage_frame)
        try:
            if edit is not None:
                edit()
            keys, plan = self._plan(force)
            for b in plan:
                if b.check is not None and keys[b.name] is not None:
                    b.check(self)
        except BaseException:
            self.loaded, self._size, self.options, self.frame = saved
            if self._restyled is not None:
                for part, kept in zip(self.frame.parts, self._restyled, strict=True):
                    part.layers = kept
            raise
        for b in reversed(plan):
            obj = getattr(self, b.name)
            self._keys.pop(b.name, None)
            setattr(self, b.name, None)
            if obj is not None and hasattr(obj, "release"):
                obj.release()
        for b in plan:
            key = keys[b.name]
            if key is not None:
                setattr(self, b.name, b.build(self))
                self.builds[b.name] += 1
            self._keys[b.name] = key
        names = tuple(b.name for b in plan)
        for b in SCHEDULE:  # kept, or absent before and after
            self._keys.setdefault(b.name, keys[b.name])
        for b in SCHEDULE:
            if b.refresh is None or getattr(self, b.name) is None:
                continue
            stamp_of, refresh = b.refresh
            stamp = stamp_of(self)
            if b.name not in names and self._refreshed.get(b.name) != stamp:
                refresh(self)
            self._refreshed[b.name] = stamp
        if _FRAME_OBJECTS.intersection(names):
            self._drawn = None
        self.rebuilt = names
        return names

    def invalidate(self, *names: str) -> tuple[str, ...]:
        """Build the named objects of ``SCHEDULE`` again (and what needs them), with any
        other whose key changed: for a caller that edited frame data in place, which keys
        do not see (a map's sampler state, a part's vertex colours; tests)."""
        unknown = set(names) - {b.name for b in SCHEDULE}
        if unknown:
            raise ValueError(f"not objects of the schedule: {', '.join(sorted(unknown))}")
        return self._change(force=frozenset(names))

    def _stage_frame(self, old: Scene, fields: set[str]) -> None:
        """New frame data for the scene edit ``fields`` (top-level keys of the scene that
        may differ from ``old``): new parts for new objects or part settings (their maps'
        mips and bakes), restyled layers for new material constants where ``restyle`` can
        and for a model file's new material factors where ``restyle_file_materials`` can
        (else new parts), new lights only where they differ."""
        new = self.scene
        parts = False
        if "render" in fields:
            parts = any(getattr(old.render, k) != getattr(new.render, k) for k in _PART_SETTINGS)
        frame = self.frame
        if not parts and "objects" in fields and new.objects != old.objects:
            # a model file's material factors alone restyle its parts, else new parts
            self._restyled = [part.layers for part in frame.parts]  # _change's rollback
            restyled = restyle_file_materials(frame, self.loaded, old)
            parts = restyled is None
            frame = frame if restyled is None else restyled
        elif "objects" in fields:
            parts |= new.objects != old.objects
        if not parts and "materials" in fields and new.materials != old.materials:
            changed = {k for k in new.materials if old.materials.get(k) != new.materials[k]}
            restyled = None
            if not set(old.materials) - set(new.materials):
                if self._restyled is None:  # _change's rollback
                    self._restyled = [part.layers for part in frame.parts]
                restyled = restyle(frame, self.loaded, changed)
            if restyled is None:
                parts = True
            else:
                frame = restyled
        lights = frame.lights
        if "lights" in fields and new.lights != old.lights:
            lights = frame_lights(new.lights)
        if parts:
            frame = prepare_frame(self.loaded)
        if frame.lights is not lights:
            frame = dataclasses.replace(frame, lights=lights)
        self.frame = frame

    def _edit(self, **changes: object) -> Scene:
        """The scene with ``changes`` (``app.scene.edits.replace_parts``: a camera or
        settings table swapped in as it is, other tables validated with the whole scene),
        which becomes the renderer's scene; returns the old one."""
        old = self.scene
        self.loaded = dataclasses.replace(self.loaded, scene=replace_parts(old, **changes))
        return old

    def _edit_scene(self, **changes: object) -> tuple[str, ...]:
        """``_edit`` with ``changes``, the frame data staged for them, and the objects they
        need built again."""

        def edit() -> None:
            old = self._edit(**changes)
            self._stage_frame(old, set(changes))

        return self._change(edit)

    # --- changing what is rendered --------------------------------------------------------------

    def set_camera(self, camera: Camera) -> None:
        """A new camera: new matrices, and a new depth-of-field pass where the lens changed."""
        self._edit_scene(camera=camera)

    def set_lights(self, lights: list[Light], environment: Environment | None = None) -> None:
        """New lights (and environment): what reads them is built again (the culler, shadow
        maps, lighting and blend passes for new lights; the environment's light and
        background for a new environment); programs are compiled only for a combination
        of light kinds not seen before."""
        self._edit_scene(lights=lights, environment=environment)

    def set_materials(self, materials: dict[str, Material]) -> None:
        """New material definitions for the scene's objects: new constants, material table
        and lighting programs; the geometry is kept, and maps are built again only for
        materials that have them (``app.frame.restyle``)."""
        self._edit_scene(materials=materials)

    def set_settings(self, settings: RenderSettings) -> None:
        """New render settings; rebuilds only what depends on the keys that changed. A
        setting the GL cannot allocate (InputError) keeps the old settings and objects."""
        self._edit_scene(render=settings)

    def set_options(self, options: RenderOptions) -> None:
        """Another pipeline variant (``RenderOptions``): what its keys read is built again."""

        def edit() -> None:
            self.options = options

        self._change(edit)

    def resize(self, size: tuple[int, int]) -> None:
        """A new output size (width, height): new targets for every pass whose size is
        the image's; the G-buffer pass's geometry, the shadow maps, the environment's
        light and background are kept (the viewer switches between its preview and full
        size after every input). A size past the GL's limits (InputError) keeps the old."""
        new = (int(size[0]), int(size[1]))

        def edit() -> None:
            self._size = new

        self._change(edit)

    def update(self, scene: Scene) -> None:
        """Show ``scene``, an edit of the current one (same objects' files): its parts that
        differ from the current scene's, in one change."""
        old = self.scene
        fields = ("objects", "materials", "render", "lights", "environment", "camera", "background")
        changes = {k: getattr(scene, k) for k in fields if getattr(scene, k) != getattr(old, k)}
        if "lights" in changes or "environment" in changes:  # set together, as set_lights does
            changes.update(lights=scene.lights, environment=scene.environment)
        if "objects" in changes:  # the objects name their materials
            changes["materials"] = scene.materials
        if changes:
            self._edit_scene(**changes)

    # --- the frame ---------------------------------------------------------------------------

    def want_hdr(self, wanted: bool = True) -> None:
        """Ask that every following frame draw the HDR image (True), so that ``read_hdr``
        and ``hdr_texture`` read it without another lighting pass: a caller that reads the
        HDR image of every frame (an EXR and a PNG per frame, a comparison's difference)
        pays one lighting pass, not a fused one and the HDR one. False (the default): a
        plain frame fuses post into the lighting pass and draws no HDR image, which
        ``read_hdr`` then draws on demand (``complete_hdr``)."""
        self._hdr_wanted = bool(wanted)

    @property
    def hdr_wanted(self) -> bool:
        """Whether frames draw the HDR image (``want_hdr``)."""
        return self._hdr_wanted

    @property
    def hdr_drawn(self) -> bool:
        """Whether the last frame's HDR image exists: drawn with the frame or completed
        since (False without a frame of the current passes)."""
        return self._drawn is not None and self._drawn.hdr

    def render(self, timings: dict[str, float] | None = None) -> None:
        """Run all passes; results stay on the GPU until read. With ``timings`` each pass
        is waited for and its wall time in milliseconds recorded by name (the viewer's
        frame-time plot; the waits cost some throughput, so only when asked). With
        ``render.antialiasing = "jitter"`` the frame is the mean of
        ``render.antialiasing_samples`` jittered frames (``render_sample``), tone-mapped
        once."""
        clock = _PassClock(self.gl.ctx, timings)
        if self.accumulate is None:
            self._finish(self._draw(self.matrices, clock), clock)
            return
        for index in range(self.scene.render.antialiasing_samples):
            self._draw_sample(index, index == 0, clock)
        self._finish(self.accumulate.target, clock)

    def render_sample(
        self, index: int, restart: bool | None = None, timings: dict[str, float] | None = None
    ) -> None:
        """One jittered sample of ``render.antialiasing = "jitter"``: draw the frame with
        the projection moved by offset ``index`` of ``jitter_offsets(N)`` (N =
        ``render.antialiasing_samples``, index taken modulo N), add it to the running
        mean (``restart``, by default ``index == 0``: a new mean, after any change of the
        scene or camera) and show the mean so far (post and the read-backs read it). A
        viewer draws sample 0 while the view moves and 1, ..., N - 1 while it is idle,
        then stops: the image is then ``render()``'s."""
        if self.accumulate is None:
            raise ValueError('render_sample needs render.antialiasing = "jitter"')
        clock = _PassClock(self.gl.ctx, timings)
        self._draw_sample(index, index == 0 if restart is None else restart, clock)
        self._finish(self.accumulate.target, clock)

    def _draw_sample(self, index: int, restart: bool, clock: _PassClock) -> None:
        """Jittered sample ``index`` drawn and added to the running mean."""
        offsets = jitter_offsets(self.scene.render.antialiasing_samples)
        offset = offsets[index % len(offsets)]
        proj, camera = jittered_frame(self.proj, self.camera, tuple(offset), self.size)
        matrices = CameraMatrices(self.view, proj, camera)
        self.accumulate.add(self._draw(matrices, clock), restart)
        clock.done("accumulate")

    def _draw(self, m: CameraMatrices, clock: _PassClock) -> moderngl.Texture:
        """The passes up to the frame's HDR image (after blend, depth of field and resolve)
        with the camera's matrices ``m``; returns that image (a fused frame's lighting pass
        wrote the display image instead)."""
        self.gbuffer_pass.run(self.gbuffer, m.view, m.proj, m.frame)
        clock.done("gbuffer")
        if self.culler is not None:
            self.culler.run(self.gbuffer, m.view, m.frame)
            clock.done("culling")
        if self.shadows is not None:  # each map once, when its light is first culled in
            self.shadows.run(m.proj @ m.view)
            clock.done("shadows")
        self.run_lighting(m.frame)
        clock.done("lighting")
        if self.transmission is not None:  # refracts the opaque image, before the blend
            self.transmission.run(self.gbuffer, self.lighting, m.view, m.proj, m.frame)
            clock.done("transmission")
        if self.blend is not None:  # composited before depth of field, resolve and post
            self.blend.run(self.gbuffer, self.lighting, m.view, m.proj, m.frame)
            clock.done("blend")
        hdr = self.lighting.hdr
        if self.sraa is not None:  # the samples' colours from the shaded pixels
            self.sraa.run(self.gbuffer, hdr, m.view, m.proj, m.frame)
            hdr = self.sraa.target
            clock.done("sraa")
        if self.msaa is not None:  # the edge pixels shaded per sample
            self.msaa.run(self.gbuffer, hdr, m.view, m.proj, m.frame, self._drawn.background)
            hdr = self.msaa.target
            clock.done("msaa")
        if self.dof is not None:
            self.dof.run(hdr, self.gbuffer.depth)
            hdr = self.dof.target
            clock.done("depth of field")
        if self.resolve is not None:
            self.resolve.run(hdr)
            hdr = self.resolve.target
            clock.done("resolve")
        return hdr

    def _finish(self, hdr: moderngl.Texture, clock: _PassClock) -> None:
        """Post on ``hdr`` (unless the lighting pass wrote the display image), then the
        display image's FXAA-class filter, in place, where ``render.antialiasing =
        "fxaa"``."""
        if not self._drawn.display:  # else the lighting pass wrote the display image
            self.run_post(hdr)
            clock.done("post")
        if self.fxaa is not None:
            self.fxaa.run(self.post.target)
            clock.done("fxaa")
        if self.gbaa is not None:
            self.resolve_edges(hdr)
            clock.done("gbaa")

    def resolve_edges(self, hdr: moderngl.Texture) -> None:
        """``render.antialiasing = "gbaa"``: the display image's silhouette pixels
        resolved from the frame's HDR image ``hdr``; where the lighting pass wrote the
        display image (fused), it wrote the surface pixels' radiance too (``run_lighting``)
        and the background's is given as a uniform."""
        m = self.matrices  # the frame's (no jitter in this mode)
        background = None
        if not self._drawn.hdr:
            hdr, background = self.lighting.hdr, self._drawn.background
        exposure = self.scene.camera.exposure
        rects = self.gbaa.rects(m.view, m.proj)
        self.gbaa.mark(self.gbuffer, self.post.target, rects, hdr, exposure, background)
        self.gbaa.resolve(self.gbuffer, hdr, self.post.target, exposure, background)

    def _plain(self) -> bool:
        """No pass between lighting and post reads or draws the HDR image: no depth of
        field, resolve, accumulation, blended parts or environment background; and an
        opaque background, whose display value the fused and surface-only post passes clear
        to (a transparent one has the post pass write every pixel's alpha)."""
        extra = (
            self.dof, self.resolve, self.blend, self.transmission, self.background,
            self.accumulate, self.sraa, self.msaa,
        )  # fmt: skip
        return all(x is None for x in extra) and not self.transparent

    @property
    def fused_display(self) -> bool:
        """Whether a frame's lighting pass writes the display image (``run_lighting``): a
        plain frame, with ``options.fuse_post``, unless the HDR image is wanted with every
        frame (``want_hdr``)."""
        return self.options.fuse_post and self._plain() and not self._hdr_wanted

    def run_lighting(self, camera: CameraFrame | None = None) -> None:
        """The lighting pass, then the environment background over it where there is one,
        with ``camera`` (None: the scene's; a jittered sample's frame otherwise).
        A plain frame (``_plain``) with ``fuse_post`` writes the display image directly
        (LightingPass.run_display: the post pass fused in, the same bytes) and no HDR
        image; ``read_hdr`` and ``hdr_texture`` draw it on demand (``complete_hdr``;
        docs/performance.md, "The fused display image", measures the frame)."""
        background = np.asarray(self.scene.background, np.float64)
        if self.transparent:  # RGBA: no radiance, no coverage
            background = np.zeros(4, np.float64)
        camera = self.camera if camera is None else camera
        if self.fused_display:
            exposure = self.scene.camera.exposure
            bg = tuple(float(x) for x in background)
            # "gbaa" mixes the radiance at the silhouettes: the surfaces' is written too
            hdr = self.lighting.hdr if self.gbaa is not None else None
            if self.gbaa is not None and self.gbaa.interior:
                # every surface pixel's display value is gbaa's (the interior's its correction
                # draw's, the silhouettes' the resolve's): the lighting pass writes
                # their radiance alone, over the background's display value
                self.post.display_target(self.gbuffer.zbuffer, bg, exposure)
                self.lighting.run_surfaces(self.gbuffer, camera)
                self._drawn = _Drawn(camera, background, hdr=False, display=True)
                return
            target = self.post.display_target(self.gbuffer.zbuffer, bg, exposure, hdr)
            self.lighting.run_display(
                self.gbuffer, camera, target, self.scene.render.tonemap, 2.0**exposure,
                hdr is not None,
            )  # fmt: skip
            self._drawn = _Drawn(camera, background, hdr=False, display=True)
            return
        self.lighting.run(self.gbuffer, camera, background)
        self._drawn = _Drawn(camera, background, hdr=True, display=False)
        if self.background is not None:
            self.background.run(self.gbuffer, self.lighting.fbo, camera)

    def complete_hdr(self) -> None:
        """Draw the HDR image of a frame whose lighting pass wrote the display image only
        (``fused_display``), with that frame's camera and background (an edit made since
        without a render does not show): one more lighting pass on the same G-buffer,
        whose display image stays as it was. Nothing where the frame drew it, or where no
        frame was rendered since the passes were built again (the targets are read as
        they are: the bench runs passes one by one)."""
        drawn = self._drawn
        if drawn is not None and not drawn.hdr:
            self.lighting.run(self.gbuffer, drawn.camera, drawn.background)
            drawn.hdr = True

    def run_post(self, hdr: moderngl.Texture) -> None:
        """The post pass on the frame's HDR image ``hdr``, unless the lighting pass wrote
        the display image itself (``run_lighting``); in a plain frame only on the
        surfaces' pixels (``PostPass.run_on_surfaces``)."""
        if self._drawn is not None and self._drawn.display and hdr is self.lighting.hdr:
            return
        self.complete_hdr()
        exposure = self.scene.camera.exposure
        if self._plain() and hdr is self.lighting.hdr:  # the background is the clear's
            background = tuple(float(x) for x in self.scene.background)
            self.post.run_on_surfaces(hdr, exposure, self.gbuffer.zbuffer, background)
        else:
            self.post.run(hdr, exposure)

    @property
    def hdr_texture(self) -> moderngl.Texture:
        """The last frame's linear HDR radiance on the GPU (RGBA32F, ``size``): what
        ``read_hdr`` reads, for passes that combine frames (app/render/compare.py); drawn
        now where the frame fused it away (``complete_hdr``)."""
        self.complete_hdr()
        if self.accumulate is not None:
            return self.accumulate.target
        if self.resolve is not None:
            return self.resolve.target
        if self.dof is not None:
            return self.dof.target
        if self.msaa is not None:
            return self.msaa.target
        return self.sraa.target if self.sraa is not None else self.lighting.hdr

    @property
    def display_texture(self) -> moderngl.Texture:
        """The last frame's display image on the GPU (RGBA8 sRGB): what ``read_ldr`` reads."""
        return self.post.target

    def read_hdr(self) -> np.ndarray:
        """Linear HDR radiance before exposure, (H, W, 3) float32, after depth of field
        where the camera has an aperture (resolved to ``size``). Where the last frame
        fused post into the lighting pass, the HDR image is drawn now (``complete_hdr``:
        one more lighting pass; ``want_hdr`` draws it with every frame instead). Where
        ``transparent`` the radiance is premultiplied by the coverage (``read_hdr_rgba``)."""
        self.complete_hdr()
        if self.accumulate is not None:
            return self.accumulate.read()
        if self.resolve is not None:
            return self.resolve.read()
        if self.dof is not None:
            return self.dof.read()
        if self.msaa is not None:
            return self.msaa.read()
        return self.sraa.read() if self.sraa is not None else self.lighting.read()

    def read_ldr(self) -> np.ndarray:
        """The display image, (H, W, 3) uint8 sRGB."""
        return self.post.read()

    def read_rgba(self) -> np.ndarray:
        """The display image with its alpha, (H, W, 4) uint8: sRGB colour and straight
        (not premultiplied) linear alpha, the antialiased coverage where ``transparent``
        (alpha 255 everywhere otherwise)."""
        return read_rgba(self.post.fbo, self.size, "f1")

    def read_hdr_rgba(self) -> np.ndarray:
        """``read_hdr`` with the HDR image's alpha, (H, W, 4) float32: where
        ``transparent``, radiance premultiplied by coverage and the coverage (OpenEXR's
        convention); alpha 1 everywhere otherwise."""
        self.complete_hdr()
        source = (
            self.accumulate or self.resolve or self.dof or self.sraa or self.msaa or self.lighting
        )
        return read_rgba(source.fbo, self.size, "f4")

    def read_image(self) -> np.ndarray:
        """What a PNG of the frame holds: ``read_rgba`` where ``transparent``, else
        ``read_ldr``."""
        return self.read_rgba() if self.transparent else self.read_ldr()

    def read_hdr_image(self) -> np.ndarray:
        """What an HDR file of the frame holds: ``read_hdr_rgba`` where ``transparent``,
        else ``read_hdr``."""
        return self.read_hdr_rgba() if self.transparent else self.read_hdr()

    def read_gbuffer(self) -> GBufferData:
        """The G-buffer's targets (with constant surfaces, the surface numbers from the
        material table's rows, as the decode reads them)."""
        return self.gbuffer.read(self.materials.surface_texels())

    def release(self) -> None:
        """Release every GPU object (the camera's matrices stay readable)."""
        for b in reversed(SCHEDULE):
            obj = getattr(self, b.name)
            if hasattr(obj, "release"):
                obj.release()
                setattr(self, b.name, None)
                self._keys.pop(b.name, None)
        self._drawn = None
        if self._owns_shaders:
            self.shaders.release()


# Every object a renderer builds, in the order they are built (each after what it needs).
# ``needs``: the objects it holds or compiles from, so it is built again with them: the
# lighting pass's shader inputs (``shading``, which it owns) bind the G-buffer's targets,
# the culler's tiles, the environment's light and the shadow maps; the blend pass shades
# with those inputs. The G-buffer pass reads the targets' layout, not the targets (a
# resize keeps it): the layout is in its key.
# The environment's light comes before the G-buffer pass: its prefilter runs on the GL
# while a model's maps are still being prepared on the texture cache's background thread
# (app/textures/cache.py ``prepare``), which the G-buffer pass's uploads wait for.
SCHEDULE: tuple[Built, ...] = (
    Built("matrices", Renderer._key_camera, Renderer._build_camera),
    Built("ibl", Renderer._key_ibl, Renderer._build_ibl),
    Built("gbuffer", Renderer._key_gbuffer, Renderer._build_gbuffer,
          check=Renderer._check_gbuffer),
    Built("gbuffer_pass", Renderer._key_gbuffer_pass, Renderer._build_gbuffer_pass,
          refresh=(Renderer._refresh_key_gbuffer_pass, Renderer._refresh_gbuffer_pass)),
    Built("glass_maps", Renderer._key_glass_maps, Renderer._build_glass_maps),
    Built("shadows", Renderer._key_shadows, Renderer._build_shadows,
          needs=("glass_maps",), check=Renderer._check_shadows),
    Built("culler", Renderer._key_culler, Renderer._build_culler,
          check=Renderer._check_culler),
    Built("lighting", Renderer._key_lighting, Renderer._build_lighting,
          needs=("gbuffer", "culler", "ibl", "shadows")),
    Built("transmission", Renderer._key_transmission, Renderer._build_transmission,
          needs=("lighting", "glass_maps")),
    Built("blend", Renderer._key_blend, Renderer._build_blend, needs=("lighting",)),
    Built("background", Renderer._key_background, Renderer._build_background),
    Built("sraa", Renderer._key_sraa, Renderer._build_sraa, needs=("gbuffer_pass",),
          check=Renderer._check_sraa,
          refresh=(Renderer._refresh_key_gbuffer_pass, Renderer._refresh_sraa)),
    Built("msaa", Renderer._key_msaa, Renderer._build_msaa,
          needs=("gbuffer_pass", "lighting"), check=Renderer._check_msaa,
          refresh=(Renderer._refresh_key_gbuffer_pass, Renderer._refresh_msaa)),
    Built("dof", Renderer._key_dof, Renderer._build_dof),
    Built("resolve", Renderer._key_resolve, Renderer._build_resolve),
    Built("accumulate", Renderer._key_accumulate, Renderer._build_accumulate),
    Built("post", Renderer._key_post, Renderer._build_post),
    Built("fxaa", Renderer._key_fxaa, Renderer._build_fxaa),
    Built("gbaa", Renderer._key_gbaa, Renderer._build_gbaa),
)  # fmt: skip
