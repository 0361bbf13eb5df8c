"""The frame: scene -> frame data -> G-buffer pass -> culling -> lighting pass -> blend pass
(alpha-blended parts only, app/render/blend.py) -> post.

``Renderer`` owns the GPU objects of one scene at one size; ``render()`` runs the passes,
and the ``read_*`` methods bring each stage's result back for output and tests. A renderer
can change without being rebuilt: ``set_camera``, ``set_lights``, ``set_materials``,
``set_settings``, ``resize`` (and ``update``, which takes a whole edited scene and calls
whichever of them the edit needs) rebuild only the passes that depend on what changed.
Programs come from one ``ShaderCache`` that lives as long as the renderer, so a change
compiles only a model combination it has never seen; renderers of the same context may
share one cache (a comparison's two sides, app/render/compare.py), whose owner releases it.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import moderngl
import numpy as np

from app.common.gbuffer import GBufferData
from app.common.lights import PunctualLight
from app.errors import InputError
from app.frame import FrameData, prepare_frame, restyle
from app.frame.camera import camera_frame, projection_matrix, view_matrix
from app.frame.lights import environment_texels, frame_lights, uniform_environment
from app.frame.materials import MaterialTable
from app.gl.context import GLContext
from app.gl.shaders import ShaderCache
from app.render.background import EnvironmentBackground, EnvironmentSource
from app.render.blend import BlendPass, blend_defines, blended, forward_drawables
from app.render.culling import LightCuller, check_tile_masks, tiles_used
from app.render.gbuffer import GBuffer, GBufferPass, masked, rotated
from app.render.ibl import EnvironmentLighting, UniformEnvironment
from app.render.lighting import LightingPass
from app.render.limits import check_memory, check_render_size, target_bytes_per_pixel
from app.render.post import DofPass, DownsamplePass, PostPass
from app.render.shadows import ShadowPass, check_shadow_resolutions, shadow_atlas_bytes
from app.scene.loader import LoadedScene
from app.scene.model import Camera, Environment, Light, Material, RenderSettings, Scene


@dataclass(frozen=True)
class RenderOptions:
    """Pipeline variants that are not scene keys, for the bench and its tests.

    ``uber``: one lighting program with run-time model selection instead of one per model
    group (the ``specialization`` suite). ``ms_table``: a float32 (n, n, 2) Kulla-Conty table
    other than the shipped 64 x 64 one (``app.reference.multiscatter.load_table(n)``).
    ``light_form``: where the lighting pass reads its lights (app/render/lighting.py
    ``LIGHT_FORMS``); None lets the pass choose from the light count.
    ``constant_surfaces``: False keeps RT0 and RT1's surface numbers in the G-buffer even
    where the material table could give them (the bench's "before", and the tests'
    reference for the same image; docs/gbuffer.md, "Constant surfaces").
    """

    uber: bool = False
    ms_table: np.ndarray | None = None
    light_form: str | None = None
    constant_surfaces: bool = True


def environment_source(env: Environment) -> EnvironmentSource:
    """An image, sky or studio environment's map (cached), rotation and intensity."""
    return EnvironmentSource(environment_texels(env), env.rotation, env.intensity)


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


# Render settings whose change needs new mesh parts (their maps' mips and baked blends).
_PART_SETTINGS = ("normal_filter", "blend")


class Renderer:
    """One scene, one image size, headless.

    With ``render.supersample = n`` every pass before post runs at n x n times the pixels
    (``render_size``) and a resolve box-filters the HDR image down to ``size``. ``size``
    overrides the scene's render.width and render.height. ``shaders``: a cache of the same
    context to take programs from (every pass sets its uniforms on each run, so passes of
    two renderers can use one program); the renderer then leaves its release to the
    caller, who releases it after every renderer that uses it.
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
        # A plain frame's lighting pass writes the display image (run_lighting); off, every
        # frame draws the HDR image and runs the post pass on it.
        self.fuse_post = True
        # The HDR image was asked for since the last frame / before this frame began: a
        # caller that reads it every frame gets it drawn with the frame (fused_display).
        self._hdr_read = self._hdr_wanted = False
        self._size = size
        self.frame: FrameData = prepare_frame(loaded)
        self.gbuffer: GBuffer | None = None
        self.gbuffer_pass: GBufferPass | None = None
        self.blend: BlendPass | None = None  # only where a part is alpha-blended
        self.culler: LightCuller | None = None
        self.lighting: LightingPass | None = None
        self.background: EnvironmentBackground | None = None  # [environment] background
        # the environment's light: the split sum (image, sky, studio) or the uniform
        # environment's quadrature (docs/ibl.md)
        self.ibl: EnvironmentLighting | UniformEnvironment | None = None
        self.shadows: ShadowPass | None = None  # only where a light casts shadows
        self.dof: DofPass | None = None
        self.resolve: DownsamplePass | None = None
        self.post: PostPass | None = None
        self._build_targets()

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
        factor = self.scene.render.supersample
        return (self.size[0] * factor, self.size[1] * factor)

    # --- building the passes -----------------------------------------------------------------

    def _build_targets(self, resized: bool = False) -> None:
        """Everything whose size is the image's: the G-buffer and every pass after it.
        ``resized``: only the image's size changed (``resize``; a width, height or
        supersample edit), so the G-buffer pass's geometry, the shadow maps and the
        environment's light and background, which do not depend on it, are kept (the
        viewer switches between its preview and full size after every input)."""
        settings = self.scene.render
        table = self.materials
        # RefusedError before anything is allocated or released (app/render/limits.py): a
        # renderer that refuses a resize keeps its old targets.
        constant = self._constant_surfaces()
        per_pixel = target_bytes_per_pixel(
            settings.gbuffer, table.needs_tangents, table.needs_coat_normals,
            self.scene.camera.aperture > 0.0, table.needs_emission, constant,
        )  # fmt: skip
        check_render_size(
            self.gl.ctx, self.size, settings.supersample, per_pixel, str(self.loaded.path),
            "size" if self._size is not None else "render.width, render.height",
        )  # fmt: skip
        w, h = self.render_size
        check_shadow_resolutions(self.gl.ctx, self.scene.lights, str(self.loaded.path))
        check_memory(
            self.frame.parts, self.frame.decoded, w * h * per_pixel,
            shadow_atlas_bytes(self.scene.lights), self.loaded.policy.limits.max_memory,
            str(self.loaded.path),
        )  # fmt: skip
        self._release(("gbuffer",))
        self.gbuffer = GBuffer(
            self.gl.ctx, self.render_size, settings.gbuffer, table.needs_tangents,
            table.needs_coat_normals, table.needs_emission, constant,
        )  # fmt: skip
        if resized:
            self._build_culler()  # its tiles are the image's
            self._build_shading()
        else:
            self._build_gbuffer_pass()
            self._build_lighting()
        self._build_post()
        self._build_camera()

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

    def _layout(self) -> dict[str, int]:
        """What decides the G-buffer's targets: their optional ones and constant surfaces.
        A change of it allocates new targets (``_build_targets``)."""
        return self.materials.gbuffer_defines() | {"constant": int(self._constant_surfaces())}

    def _specular_aa(self) -> tuple[float, float] | None:
        settings = self.scene.render
        if not settings.specular_aa:
            return None
        return (settings.specular_aa_variance, settings.specular_aa_threshold)

    def _opaque(self) -> list[int]:
        """Indices of the parts the G-buffer pass draws: all but the blended ones."""
        return [i for i, part in enumerate(self.frame.parts) if not blended(part)]

    def _build_gbuffer_pass(self) -> None:
        self._release(("gbuffer_pass",))
        opaque = self._opaque()
        self.gbuffer_pass = GBufferPass(
            self.gl.ctx, self.shaders, [self.frame.parts[i] for i in opaque],
            [self.frame.material_ids[i] for i in opaque], self._specular_aa(),
            self.gbuffer.defines(),
        )  # fmt: skip

    def _build_blend(self) -> None:
        """The blend pass, only where a part is alpha-blended (every other scene compiles
        and renders as before it existed)."""
        self._release(("blend",))
        parts, ids = self.frame.parts, self.frame.material_ids
        chosen = [i for i, part in enumerate(parts) if blended(part)]
        if chosen:
            drawables = forward_drawables(
                self.gl.ctx, self.shaders, [parts[i] for i in chosen], [ids[i] for i in chosen],
                self.materials, self.scene.render.terms, self._specular_aa(),
                blend_defines(self.lighting),
            )  # fmt: skip
            self.blend = BlendPass(self.gl.ctx, drawables)

    def _build_lighting(self) -> None:
        """The culler (where local lights and tiled culling), the environment's light, the
        shadow maps, the lighting and blend passes and the environment background."""
        ctx = self.gl.ctx
        check_shadow_resolutions(ctx, self.scene.lights, str(self.loaded.path))
        self._release(("lighting", "ibl"))
        env = self.scene.environment
        if env is not None and env.source != "uniform":  # docs/ibl.md
            self.ibl = EnvironmentLighting(ctx, self.shaders, environment_source(env))
        elif (uniform := uniform_environment(env)) is not None:
            self.ibl = UniformEnvironment(*uniform)
        self._build_culler()
        self._build_shadows()
        self._build_shading()
        self._build_background()

    def _build_shadows(self) -> None:
        """The shadow maps, where a light casts shadows (docs/shadows.md): the opaque parts
        cast (``_shadow_casters``), the blended ones only receive."""
        self._release(("lighting", "shadows"))  # the lighting pass binds the old maps
        self._shadow_casters = self._opaque()
        if any(light.shadow is not None for light in self.lights):
            opaque = self._shadow_casters
            parts = [self.frame.parts[i] for i in opaque]
            blends = [p for i, p in enumerate(self.frame.parts) if i not in set(opaque)]
            self.shadows = ShadowPass(self.gl.ctx, self.shaders, self.lights, parts, blends)

    def _build_culler(self) -> None:
        """The tile culler, where the frame culls by tiles (``tiles_used``)."""
        self._release(("culler",))
        if tiles_used(self.scene.render.light_culling, self.lights):
            check_tile_masks(
                self.gl.ctx, self.render_size, self.lights, str(self.loaded.path)
            )  # before any of its textures exists
            self.culler = LightCuller(self.gl.ctx, self.shaders, self.render_size, self.lights)

    def _build_shading(self) -> None:
        """The lighting pass and the blend pass, on the culler, environment light and
        shadow maps as they are: what a material edit needs again (``set_materials``)."""
        self._display_done = self._hdr_missing = False  # run_lighting: set by each frame
        self._release(("lighting",))
        settings = self.scene.render
        self.lighting = LightingPass(
            self.gl.ctx, self.shaders, self.render_size, self.lights, self.materials,
            self.culler, settings.terms, self.options.uber, self.options.ms_table,
            gbuffer=self.gbuffer.defines(), ibl=self.ibl, shadows=self.shadows,
            form=self.options.light_form,
        )  # fmt: skip
        self._build_blend()  # it shades with the lights, material table and terms

    def _build_background(self) -> None:
        """The environment behind the objects, only where ``[environment] background``."""
        self._release(("background",))
        env = self.scene.environment
        if env is not None and env.background:
            self.background = EnvironmentBackground(
                self.gl.ctx, self.shaders, environment_source(env)
            )

    def _build_post(self) -> None:
        """Depth of field (a camera with an aperture), the supersampling resolve, post."""
        self._release(("dof", "resolve", "post"))
        ctx, cam, settings = self.gl.ctx, self.scene.camera, self.scene.render
        if cam.aperture > 0.0:
            self.dof = DofPass(
                ctx, self.shaders, self.render_size, cam.aperture, cam.focus, cam.fov_y
            )
        factor = settings.supersample
        if factor > 1:
            self.resolve = DownsamplePass(ctx, self.shaders, self.size, factor)
        self.post = PostPass(ctx, self.shaders, self.size, settings.tonemap)

    def _build_camera(self) -> None:
        cam = self.scene.camera
        w, h = self.size
        self.view = view_matrix(cam)
        self.proj = projection_matrix(cam, w / h)
        self.camera = camera_frame(cam, *self.render_size)

    def _release(self, names: tuple[str, ...]) -> None:
        for name in names:
            obj = getattr(self, name)
            if obj is not None:
                obj.release()
                setattr(self, name, None)

    def _edit(self, **changes: object) -> Scene:
        """The scene with ``changes``, which becomes the renderer's scene; returns the old
        one. A camera or settings table is already validated on its own and is swapped in
        as it is (every orbit step); other changes are validated with the whole scene, as
        a scene file's would be (materials named by objects, blends, lights)."""
        old = self.scene
        if set(changes) <= {"camera", "render", "background"} and all(
            isinstance(v, Camera | RenderSettings) for k, v in changes.items() if k != "background"
        ):
            scene = old.model_copy(update=changes)
        else:
            scene = Scene.model_validate({**old.model_dump(), **changes})
        self.loaded = dataclasses.replace(self.loaded, scene=scene)
        return old

    # --- changing what is rendered --------------------------------------------------------------

    def set_camera(self, camera: Camera) -> None:
        """A new camera: new matrices, and a new depth-of-field pass where the lens changed."""
        old = self._edit(camera=camera)
        lens = ("aperture", "focus", "fov_y")
        thin_lens = old.camera.aperture > 0.0 or camera.aperture > 0.0  # a pinhole has no pass
        if thin_lens and any(getattr(old.camera, k) != getattr(camera, k) for k in lens):
            self._build_post()
        self._build_camera()

    def set_lights(self, lights: list[Light], environment: Environment | None = None) -> None:
        """New lights (and environment): new light textures, culler and lighting programs
        (compiled only for a combination of light kinds not seen before)."""
        self._edit(lights=lights, environment=environment)
        self.frame = dataclasses.replace(self.frame, lights=frame_lights(self.scene.lights))
        self._build_lighting()

    def set_materials(self, materials: dict[str, Material]) -> None:
        """New material definitions for the scene's objects: new constants, material table
        and lighting programs; the geometry is kept, and maps are built again only for
        materials that have them (``app.frame.restyle``)."""
        old = self._edit(materials=materials).materials
        new = self.scene.materials
        changed = {name for name in new if old.get(name) != new[name]}
        frame = None if set(old) - set(new) else restyle(self.frame, self.loaded, changed)
        if frame is None:
            self._rebuild_frame()
            return
        targets = self._layout()
        self.frame = frame
        if self._layout() != targets:  # the G-buffer gains or loses a target
            self._build_targets()
            return
        opaque = self._opaque()
        drawables = self.gbuffer_pass.drawables  # restyle edits the parts' layers in place
        if len(drawables) != len(opaque) or any(blended(d.part) for d in drawables):
            self._build_gbuffer_pass()  # a part became blended or stopped being blended
        for drawable, i in zip(self.gbuffer_pass.drawables, opaque, strict=True):
            drawable.material_ids = frame.material_ids[i]
        if any(
            d.alpha_mask != masked(d.part) or d.rotated != rotated(d.part)
            for d in self.gbuffer_pass.drawables
        ):  # an alpha_mode or anisotropy_rotation edit compiles its code in or out
            self._build_gbuffer_pass()
        casters = self._opaque()
        masks = self.shadows is not None and (
            self.shadows.masked or any(masked(self.frame.parts[i]) for i in casters)
        )  # an alpha mask's coverage shapes its shadow (docs/shadows.md)
        if casters != self._shadow_casters or masks:
            self._build_shadows()  # the casters or their coverage change
        # the culler and the environment's light and background stay
        self._build_shading()

    def set_settings(self, settings: RenderSettings) -> None:
        """New render settings; rebuilds only what depends on the keys that changed."""
        old = self._edit(render=settings).render
        changed = {
            k for k in RenderSettings.model_fields if getattr(old, k) != getattr(settings, k)
        }
        if changed & set(_PART_SETTINGS):
            self._rebuild_frame()
        specular_aa = changed & {"specular_aa", "specular_aa_variance", "specular_aa_threshold"}
        layout = self.gbuffer.constant_surfaces != self._constant_surfaces()  # RT0 comes or goes
        if changed & {"width", "height", "supersample", "gbuffer"} or layout:
            try:
                # a new encoding, layout or specular antialiasing compiles the G-buffer pass
                # again; a new size alone keeps it
                self._build_targets(resized=not ("gbuffer" in changed or specular_aa or layout))
            except InputError:  # past the GL's limits: the old settings and targets stay
                self._edit(render=old)
                raise
            return
        if specular_aa:
            self._build_gbuffer_pass()
            self._build_blend()
        if changed & {"light_culling", "terms"}:
            self._build_lighting()
        if "tonemap" in changed:
            self._build_post()

    def resize(self, size: tuple[int, int]) -> None:
        """A new output size (width, height): new targets for every pass."""
        old, self._size = self._size, (int(size[0]), int(size[1]))
        try:
            self._build_targets(resized=True)
        except InputError:  # past the GL's limits: the old size and targets stay
            self._size = old
            raise

    def update(self, scene: Scene) -> None:
        """Show ``scene``, an edit of the current one (same objects' files): each part of
        it that differs goes through its own ``set_*``."""
        old = self.scene
        if scene.objects != old.objects:
            self._edit(objects=scene.objects, materials=scene.materials)
            self._rebuild_frame()
        elif scene.materials != old.materials:
            self.set_materials(scene.materials)
        if scene.render != old.render:
            self.set_settings(scene.render)
        if scene.lights != old.lights or scene.environment != old.environment:
            self.set_lights(scene.lights, scene.environment)
        if scene.camera != old.camera:
            self.set_camera(scene.camera)
        if scene.background != old.background:
            self._edit(background=scene.background)

    def _rebuild_frame(self) -> None:
        """New parts and material table (the lights stay), and the passes that use them."""
        targets = self._layout()
        self._release(("gbuffer_pass",))
        self.frame = prepare_frame(self.loaded)
        if self._layout() != targets:  # the G-buffer gains or loses a target
            self._build_targets()
            return
        self._build_gbuffer_pass()
        self._build_lighting()

    # --- the frame ---------------------------------------------------------------------------

    def render(self, timings: dict[str, float] | None = None) -> None:
        """Run all passes; results stay on the GPU until read. With ``timings`` each pass
        is waited for and its wall time in milliseconds recorded by name (the viewer's
        frame-time plot; the waits cost some throughput, so only when asked)."""
        clock = _PassClock(self.gl.ctx, timings)
        self._hdr_wanted, self._hdr_read = self._hdr_read, False
        self.gbuffer_pass.run(self.gbuffer, self.view, self.proj, self.camera)
        clock.done("gbuffer")
        if self.culler is not None:
            self.culler.run(self.gbuffer, self.view, self.camera)
            clock.done("culling")
        if self.shadows is not None:  # each map once, when its light is first culled in
            self.shadows.run(self.proj @ self.view)
            clock.done("shadows")
        self.run_lighting()
        clock.done("lighting")
        if self.blend is not None:  # composited before depth of field, resolve and post
            self.blend.run(self.gbuffer, self.lighting, self.view, self.proj, self.camera)
            clock.done("blend")
        hdr = self.lighting.hdr
        if self.dof is not None:
            self.dof.run(hdr, self.gbuffer.depth)
            hdr = self.dof.target
            clock.done("depth of field")
        if self.resolve is not None:
            self.resolve.run(hdr)
            hdr = self.resolve.target
            clock.done("resolve")
        if not self._display_done:  # else the lighting pass wrote the display image
            self.run_post(hdr)
            clock.done("post")

    def _plain(self) -> bool:
        """No pass between lighting and post reads or draws the HDR image: no depth of
        field, resolve, blended parts or environment background."""
        extra = (self.dof, self.resolve, self.blend, self.background)
        return all(x is None for x in extra)

    @property
    def fused_display(self) -> bool:
        """Whether a frame's lighting pass writes the display image (``run_lighting``): a
        plain frame, unless the last frame's HDR image was read (a caller reading both
        images of every frame would otherwise pay for two lighting passes)."""
        return self.fuse_post and self._plain() and not self._hdr_wanted

    def run_lighting(self) -> None:
        """The lighting pass, then the environment background over it where there is one.
        A plain frame (``_plain``) with ``fuse_post`` writes the display image directly
        (LightingPass.run_display: the post pass fused in, the same bytes) and no HDR
        image; ``read_hdr`` and ``hdr_texture`` run the HDR lighting pass on the same
        G-buffer when asked (docs/performance.md, "The fused display image")."""
        background = np.asarray(self.scene.background, np.float64)
        if self.fused_display:
            exposure = self.scene.camera.exposure
            bg = tuple(float(x) for x in background)
            target = self.post.display_target(self.gbuffer.zbuffer, bg, exposure)
            self.lighting.run_display(
                self.gbuffer, self.camera, target, self.scene.render.tonemap, 2.0**exposure
            )
            self._display_done = self._hdr_missing = True
            self._frame_view = (self.camera, background)  # what _complete_hdr draws with
            return
        self.lighting.run(self.gbuffer, self.camera, background)
        self._display_done = self._hdr_missing = False
        if self.background is not None:
            self.background.run(self.gbuffer, self.lighting.fbo, self.camera)

    def _complete_hdr(self) -> None:
        """The HDR image of a frame whose lighting pass wrote the display image only, with
        that frame's camera and background (an edit since has not been rendered)."""
        if self._hdr_missing:
            camera, background = self._frame_view
            self.lighting.run(self.gbuffer, camera, background)
            self._hdr_missing = False

    def run_post(self, hdr: moderngl.Texture) -> None:
        """The post pass on the frame's HDR image ``hdr``, unless the lighting pass wrote
        the display image itself (``run_lighting``); in a plain frame only on the
        surfaces' pixels (``PostPass.run_on_surfaces``)."""
        if self._display_done and hdr is self.lighting.hdr:
            return
        self._complete_hdr()
        exposure = self.scene.camera.exposure
        if self._plain() and hdr is self.lighting.hdr:  # the background is the clear's
            background = tuple(float(x) for x in self.scene.background)
            self.post.run_on_surfaces(hdr, exposure, self.gbuffer.zbuffer, background)
        else:
            self.post.run(hdr, exposure)

    @property
    def hdr_texture(self) -> moderngl.Texture:
        """The last frame's linear HDR radiance on the GPU (RGBA32F, ``size``): what
        ``read_hdr`` reads, for passes that combine frames (app/render/compare.py)."""
        self._hdr_read = True
        self._complete_hdr()
        if self.resolve is not None:
            return self.resolve.target
        return self.dof.target if self.dof is not None else self.lighting.hdr

    @property
    def display_texture(self) -> moderngl.Texture:
        """The last frame's display image on the GPU (RGBA8 sRGB): what ``read_ldr`` reads."""
        return self.post.target

    def read_hdr(self) -> np.ndarray:
        """Linear HDR radiance before exposure, (H, W, 3) float32, after depth of field
        where the camera has an aperture (resolved to ``size``)."""
        self._hdr_read = True
        self._complete_hdr()
        if self.resolve is not None:
            return self.resolve.read()
        return self.dof.read() if self.dof is not None else self.lighting.read()

    def read_ldr(self) -> np.ndarray:
        """The display image, (H, W, 3) uint8 sRGB."""
        return self.post.read()

    def read_gbuffer(self) -> GBufferData:
        """The G-buffer's targets (with constant surfaces, the surface numbers from the
        material table's rows, as the decode reads them)."""
        return self.gbuffer.read(self.materials.surface_texels())

    def release(self) -> None:
        self._release(
            ("culler", "resolve", "dof", "blend", "gbuffer_pass", "gbuffer", "lighting", "post")
        )
        self._release(("background", "ibl", "shadows"))
        if self._owns_shaders:
            self.shaders.release()
