"""The public Python API: render scenes into numpy arrays, change them between frames.

In the spirit of pyrender's ``OffscreenRenderer``, with one difference that matters for a
turntable or a data set: an ``OffscreenRenderer`` keeps its compiled programs and uploaded
meshes for its whole life. A change of camera, lights, a material's parameters, render
settings or image size goes through the updatable ``Renderer``'s ``set_*`` / ``resize``
(app/render/renderer.py, docs/architecture.md "A renderer that changes"), which rebuild only
the passes the change touches; the next frame costs a frame, not a rebuild (docs/api.md
has the measured numbers).

Scenes come from a file (a path, or the name of a bundled scene such as ``"showcase"``) or
from a Python dict with the scene file's keys; both are validated by
``app.scene.loader.parse_scene``, so bad input raises the same one-line
``app.errors.InputError`` a scene file would. Every change is validated the same way before
the renderer sees it: a failed change leaves the renderer as it was.

The API lives in the ``app`` package the ``pbs-lab`` distribution installs (``from app.api
import OffscreenRenderer``): a second top-level name (``pbs``) would be one more package to
ship and keep in step for a module of a few hundred lines.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np
from pydantic import BaseModel, ValidationError

from app.common.gbuffer import GBufferData
from app.errors import InputError
from app.gl.context import Backend, GLContext, create_context
from app.reference.encoding import oct_decode
from app.render.renderer import Renderer
from app.scene.edits import KeyPath, edited
from app.scene.loader import LoadedScene, describe_error
from app.scene.model import FILE_CAMERA_KEYS, Camera, RenderSettings, Scene
from app.scene.sources import PYTHON_SCENE, Look, SceneSource, scene_from

# ``scene_from`` (app/scene/sources.py, which the CLI shares) and ``PYTHON_SCENE`` are part
# of the API.
__all__ = ["CHANNELS", "PYTHON_SCENE", "Look", "OffscreenRenderer", "SceneSource", "scene_from"]

# The G-buffer channels ``OffscreenRenderer.channel`` reads, with their shapes (H, W[, C]):
# what each means is in docs/api.md and app/common/gbuffer.py.
CHANNELS: dict[str, str] = {
    "base_color": "(H, W, 3) float32, linear base colour (F0 for metals)",
    "metallic": "(H, W) float32",
    "normal": "(H, W, 3) float32, world-space unit normal; 0 where nothing was drawn",
    "roughness": "(H, W) float32, perceptual (alpha = roughness^2)",
    "f0": "(H, W) float32, the dielectric's reflectance at normal incidence",
    "depth": "(H, W) float32, view depth in metres; 0 where nothing was drawn",
    "material_id": "(H, W) int32, the row of the material table; -1 where nothing was drawn",
    "covered": "(H, W) bool, the pixels a surface was drawn into",
    "tangent": "(H, W, 3) float32, world-space unit tangent; 0 without anisotropic materials",
    "anisotropy": "(H, W) float32; 0 without anisotropic materials",
    "emission": "(H, W, 3) float32, emitted radiance (linear); 0 where nothing emits",
    "occlusion": "(H, W) float32, the factor on environment light; 1 without occlusion maps",
}


def _validated(model: type[BaseModel], data: dict, where: str, file: str) -> Any:
    """``data`` validated as ``model``, or the scene file's one-line error with the key
    path under ``where`` (``camera.fov_y``)."""
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        key, msg = describe_error(exc.errors()[0])
        raise InputError(file, f"{where}.{key}" if key else where, msg) from None


class OffscreenRenderer:
    """One scene rendered headless into numpy arrays, changed between frames in place.

    ``scene``: anything ``scene_from`` takes. ``size``: (width, height) of the output,
    overriding the scene's render.width/height. ``backend``: the headless context to
    create (``"auto"`` tries EGL, then OSMesa; app/gl/context.py), unless ``gl`` is an
    existing context to render with (it is then left to its owner); ``device``: the EGL
    device to make it on (its index in ``pbs devices``; default ``PBS_EGL_DEVICE``, else
    EGL's first; one out of range is an ``InputError``). Use it as a context
    manager, or call ``close()``: both release every GL object (and the context it made).

    ``render()`` runs every pass and returns the display image; the other reads
    (``hdr``, ``depth``, ``channel``, ``gbuffer``) read the same frame. Rows are top to
    bottom (row 0 is the top of the image) everywhere. ``allow_paths`` and ``max_memory``:
    what the scene's files may reach and cost (``scene_from``). A model file
    (``OffscreenRenderer("model.glb")``) is framed for ``size`` and lit by the defaults;
    ``look`` (``Look(view="front", env="sky")``) changes the view, camera or environment.
    """

    def __init__(
        self,
        scene: SceneSource,
        size: tuple[int, int] | None = None,
        backend: Backend = "auto",
        gl: GLContext | None = None,
        base_dir: str | Path | None = None,
        allow_paths: tuple[str | Path, ...] | list[str | Path] = (),
        max_memory: int | None = None,
        look: Look | None = None,
        device: int | None = None,
    ) -> None:
        loaded = scene_from(scene, base_dir, allow_paths, max_memory, look=look, size=size)
        if size is not None:
            size = self._checked_size(loaded, size)
        self._owns_gl = gl is None
        self.gl = create_context(backend, device) if gl is None else gl
        try:
            self.renderer: Renderer | None = Renderer(self.gl, loaded, size)
        except BaseException:
            if self._owns_gl:
                self.gl.release()
            raise
        self._frame = False  # a frame of the current state is on the GPU

    # --- life --------------------------------------------------------------------------------

    def __enter__(self) -> OffscreenRenderer:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()

    def close(self) -> None:
        """Release the renderer's GL objects, and the context where this object made it.
        Closing twice does nothing."""
        if self.renderer is None:
            return
        self.renderer.release()
        self.renderer = None
        if self._owns_gl:
            self.gl.release()

    def _live(self) -> Renderer:
        if self.renderer is None:
            raise RuntimeError("this OffscreenRenderer is closed")
        return self.renderer

    # --- what it shows -------------------------------------------------------------------------

    @property
    def scene(self) -> Scene:
        """The scene as rendered now (a validated ``app.scene.model.Scene``)."""
        return self._live().scene

    @property
    def file(self) -> str:
        """The scene's file (or ``<python scene>``), as error messages name it."""
        return str(self._live().loaded.path)

    @property
    def size(self) -> tuple[int, int]:
        """The output image's (width, height)."""
        return self._live().size

    @property
    def render_size(self) -> tuple[int, int]:
        """The G-buffer's (width, height): ``size`` times render.supersample."""
        return self._live().render_size

    # --- changes between frames ----------------------------------------------------------------

    def set_camera(self, camera: Camera | Mapping[str, Any] | None = None, **changes: Any) -> None:
        """A new camera: a ``Camera``, a dict of the scene file's ``[camera]`` keys, or
        keyword changes to the current one (``set_camera(position=[0, 1, 5])``); with
        ``from_file`` a glTF object's camera (docs/gltf-lights-cameras.md). New matrices
        only: nothing is compiled or uploaded."""
        r = self._live()
        data = r.scene.camera.model_dump(exclude_none=True) if camera is None else _as_dict(camera)
        if camera is None and "from_file" in changes:  # the file's camera replaces the view
            data = {k: v for k, v in data.items() if k not in FILE_CAMERA_KEYS}
        data.update(changes)
        # The camera table alone is validated; a glTF file's camera with the whole scene.
        r.set_camera(edited(r.loaded, [(("camera",), data)], "set_camera").scene.camera)
        self._frame = False

    def set_lights(
        self,
        lights: list[Any] | None = None,
        environment: Mapping[str, Any] | BaseModel | bool | None = False,
    ) -> None:
        """New lights (a list of ``[[lights]]`` tables or ``Light`` models; None keeps
        them) and, where given, a new environment (a table, or None for none; left out it
        stays). Validated with the whole scene, as a file's lights are."""
        r = self._live()
        edits: list[tuple[KeyPath, object]] = []
        if lights is not None:
            edits.append((("lights",), [_as_dict(x) for x in lights]))
        if environment is not False:
            edits.append((("environment",), None if environment is None else _as_dict(environment)))
        loaded = edited(r.loaded, edits, "set_lights")
        r.set_lights(loaded.scene.lights, loaded.scene.environment)
        self._frame = False

    def set_material(self, name: str, **changes: Any) -> None:
        """Change parameters of material ``name`` (``set_material("gold", roughness=0.2)``;
        a value of None removes the key, back to its default). Validated with the whole
        scene, as a file's materials are; a material without maps keeps every mesh's
        vertex buffer, and programs are compiled only for a model combination not seen."""
        r = self._live()
        if name not in r.scene.materials:
            known = ", ".join(sorted(r.scene.materials)) or "none defined"
            raise InputError(self.file, f"materials.{name}", f"unknown material (known: {known})")
        edits = [
            (("materials", name, key), _as_dict(value) if isinstance(value, BaseModel) else value)
            for key, value in changes.items()
        ]
        r.set_materials(edited(r.loaded, edits, "set_material").scene.materials)
        self._frame = False

    def set_settings(self, **changes: Any) -> None:
        """Change ``[render]`` keys (``set_settings(tonemap="aces", supersample=2)``);
        only the passes that depend on the changed keys are rebuilt."""
        r = self._live()
        data = r.scene.render.model_dump(exclude_none=True)
        data.update(changes)
        r.set_settings(edited(r.loaded, [(("render",), data)], "set_settings").scene.render)
        self._frame = False

    def resize(self, size: tuple[int, int]) -> None:
        """A new output size (width, height), within the limits of render.width/height:
        new targets for every pass; programs and meshes are kept."""
        r = self._live()
        r.resize(self._checked_size(r.loaded, size))
        self._frame = False

    def update(self, scene: SceneSource) -> None:
        """Show an edited scene (any ``scene_from`` source) with the same objects' files:
        each part that differs goes through its own change, the rest is kept."""
        r = self._live()
        loaded = scene_from(scene, r.loaded.path.parent)
        r.update(loaded.scene)
        self._frame = False

    @staticmethod
    def _checked_size(loaded: LoadedScene, size: tuple[int, int]) -> tuple[int, int]:
        """``size`` as (width, height) ints, checked against render.width/height's limits."""
        if not (isinstance(size, tuple | list) and len(size) == 2):
            raise InputError(str(loaded.path), "size", f"expected (width, height) (got {size!r})")
        data = loaded.scene.render.model_dump(exclude_none=True)
        data.update(width=size[0], height=size[1])
        settings = _validated(RenderSettings, data, "size", str(loaded.path))
        return (settings.width, settings.height)

    # --- the frame and its read-backs ----------------------------------------------------------

    def render(self) -> np.ndarray:
        """Run every pass; returns the display image, (H, W, 3) uint8 sRGB, or with
        ``render.background = "transparent"`` (H, W, 4): straight alpha, the antialiased
        coverage (``ldr``)."""
        r = self._live()
        r.render()
        self._frame = True
        return r.read_image()

    def _rendered(self) -> Renderer:
        r = self._live()
        if not self._frame:
            raise RuntimeError("no frame of the current scene: call render() first")
        return r

    def ldr(self) -> np.ndarray:
        """The display image (tone mapped, sRGB-encoded), (H, W, 3) uint8; with
        ``render.background = "transparent"`` (``set_settings(background="transparent")``)
        (H, W, 4), the fourth channel straight (not premultiplied) alpha: the coverage,
        fractional at edges under supersampling, as a PNG stores it."""
        return self._rendered().read_image()

    def want_hdr(self, wanted: bool = True) -> None:
        """Ask that every following ``render()`` also draw the HDR image, for a caller
        that reads ``hdr()`` after each frame: one lighting pass per frame then serves both
        images. Without it a frame writes the display image directly and ``hdr()`` runs
        the lighting pass a second time (the cheaper choice when HDR is read rarely)."""
        self._live().want_hdr(wanted)

    def hdr(self) -> np.ndarray:
        """Linear HDR radiance before exposure and tone mapping, (H, W, 3) float32
        (``want_hdr`` when it is read every frame); with a transparent background (H, W, 4),
        the radiance premultiplied by the coverage in the fourth channel."""
        return self._rendered().read_hdr_image()

    def gbuffer(self) -> GBufferData:
        """Every G-buffer target as stored (octahedral directions), at ``render_size``."""
        return self._rendered().read_gbuffer()

    def depth(self) -> np.ndarray:
        """View depth in metres (along the camera's axis), (H, W) float32 at
        ``render_size``; 0 where nothing was drawn."""
        return self.channel("depth")

    def channel(self, name: str) -> np.ndarray:
        """One G-buffer channel of ``CHANNELS`` at ``render_size``, decoded: directions as
        world-space unit vectors (0 where nothing was drawn)."""
        _check_channels((name,))
        return channels_of(self.gbuffer(), (name,))[name]

    def channels(self, names: tuple[str, ...] | None = None) -> dict[str, np.ndarray]:
        """Several channels (all of ``CHANNELS`` by default) from one G-buffer read."""
        names = tuple(CHANNELS) if names is None else tuple(names)
        _check_channels(names)
        return channels_of(self.gbuffer(), names)


def channels_of(g: GBufferData, names: tuple[str, ...]) -> dict[str, np.ndarray]:
    """``names`` of ``CHANNELS`` decoded from a G-buffer read."""
    covered = g.covered
    out: dict[str, np.ndarray] = {}
    for name in names:
        if name == "base_color":
            value = g.base_color[..., :3]
        elif name == "metallic":
            value = g.base_color[..., 3]
        elif name == "normal":
            value = _direction(g.normal[..., :2], covered)
        elif name == "roughness":
            value = g.normal[..., 2]
        elif name == "f0":
            value = g.normal[..., 3]
        elif name == "depth":
            value = np.where(covered, g.depth, 0.0)
        elif name == "material_id":
            value = np.where(covered, np.rint(g.material_id), -1).astype(np.int32)
        elif name == "covered":
            value = covered
        elif name == "tangent":
            has = covered & np.any(g.tangent[..., :2] != 0.0, axis=-1)
            value = _direction(g.tangent[..., :2], has)
        elif name == "anisotropy":
            value = g.tangent[..., 2]
        elif name == "emission":  # RT5 (glTF 2.0 core material); absent: nothing emits
            rgb = np.zeros((*covered.shape, 3)) if g.emission is None else g.emission[..., :3]
            value = np.where(covered[..., None], rgb, 0.0)
        else:  # occlusion: RT5's A; absent: no occlusion map in the frame
            a = np.ones(covered.shape) if g.emission is None else g.emission[..., 3]
            value = np.where(covered, a, 1.0)
        out[name] = np.ascontiguousarray(value, np.bool_ if name == "covered" else value.dtype)
    floats = ("base_color", "metallic", "roughness", "f0", "depth", "anisotropy")
    for name in (*floats, "emission", "occlusion"):
        if name in out:
            out[name] = out[name].astype(np.float32)
    return out


def _check_channels(names: tuple[str, ...]) -> None:
    for name in names:
        if name not in CHANNELS:
            known = ", ".join(CHANNELS)
            raise InputError("channel", "", f"unknown channel '{name}' (known: {known})")


def _direction(octahedral: np.ndarray, where: np.ndarray) -> np.ndarray:
    """Octahedral (x, y) -> unit vectors (float64 decode, then float32), 0 outside
    ``where`` (Cigolle et al. 2014, as the lighting pass decodes them)."""
    safe = np.where(where[..., None], octahedral, 0.0)
    return np.where(where[..., None], oct_decode(safe), 0.0).astype(np.float32)


def _as_dict(value: Any) -> dict:
    """A model or mapping as a plain dict of scene-file keys."""
    if isinstance(value, BaseModel):
        return value.model_dump(exclude_none=True)
    if isinstance(value, Mapping):
        return copy.deepcopy(dict(value))
    raise InputError("value", "", f"expected a table (dict) (got {value!r})")
