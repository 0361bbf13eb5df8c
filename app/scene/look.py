"""How a model file is shown: its named views, the bundled environments and the ``Look``
that picks among them, and which files are model files.

Declared apart from app/scene/model_file.py (which frames and lights a model, and so
imports the geometry loader, trimesh and the texture decoders) in a module that imports
nothing else of ``app``: the CLI's parser takes its ``--view`` choices from here, and
``scene_from`` tells a model file from a scene file without loading either, and a scene
file that needs the model file's defaults (``needs_defaults``) from one that does not
(docs/performance.md, "Start-up").
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from app.scene.loader import LoadedScene

__all__ = ["ENVIRONMENTS", "MODEL_SUFFIXES", "VIEWS", "Look", "is_model_file", "needs_defaults"]

MODEL_SUFFIXES = (".glb", ".gltf", ".obj", ".stl", ".ply")
# (azimuth, elevation) in degrees of the camera about the model's centre.
VIEWS: dict[str, tuple[float, float]] = {
    "three-quarter": (40.0, 25.0),
    "front": (0.0, 0.0),
    "side": (90.0, 0.0),
    "top": (0.0, 90.0),
    "iso": (45.0, math.degrees(math.atan(1.0 / math.sqrt(2.0)))),
}
ENVIRONMENTS = ("studio", "sky")  # or an .hdr / .exr file


@dataclass(frozen=True)
class Look:
    """How a model is shown: a named view or an explicit azimuth/elevation (degrees),
    ``camera = "file"`` for the glTF file's own first camera, and the environment; and a
    glTF file's pose: an animation (name or index) at a time in seconds, a
    ``KHR_materials_variants`` variant (the model object's ``animation``, ``time`` and
    ``variant``; docs/gltf.md, "Animation")."""

    view: str = "three-quarter"
    azimuth: float | None = None
    elevation: float | None = None
    camera: str = "auto"  # "auto" or "file"
    env: str = "studio"  # "studio", "sky" or an .hdr/.exr path
    animation: str | None = None  # a name, or an index written as digits
    time: float | None = None  # seconds
    variant: str | None = None

    def pose(self) -> dict[str, str | float]:
        """The model object's pose keys this look sets (none: the rest pose)."""
        keys = {"animation": self.animation, "time": self.time, "variant": self.variant}
        return {key: value for key, value in keys.items() if value is not None}

    def angles(self) -> tuple[float, float]:
        """(azimuth, elevation) in degrees."""
        azimuth, elevation = VIEWS[self.view]
        if self.azimuth is not None:
            azimuth = self.azimuth
        if self.elevation is not None:
            elevation = self.elevation
        return azimuth, elevation


def is_model_file(path: str | Path) -> bool:
    """Whether ``path`` names a model file by its suffix."""
    return Path(path).suffix.lower() in MODEL_SUFFIXES


def needs_defaults(loaded: LoadedScene) -> tuple[bool, bool]:
    """(camera, lighting): which of the model file's defaults a scene file gets
    (app/scene/model_file.py ``with_defaults`` fills them in; docs/scene-format.md,
    "A scene file without a camera or lights").

    Lighting: the scene gives nothing that lights it: no light, no environment, no
    imported light, no ``lights = []`` written (an unlit scene on purpose) and no
    material of its own ``[materials]`` that an object wears and that emits (its emission
    is its light). Camera: no ``[camera]`` where the scene names a mesh file; a scene of
    primitives alone is framed only where it gets the lighting too, so a scene that
    lights its primitives keeps the default camera it was written for."""
    scene = loaded.scene
    lighting = (
        not scene.lights
        and scene.environment is None
        and "lights" not in scene.model_fields_set
        and not any(obj.import_lights for obj in scene.objects)
        and not _emits(loaded)
    )
    camera = "camera" not in scene.model_fields_set
    if not any(obj.file is not None for obj in scene.objects):
        camera = camera and lighting
    return camera, lighting


def _emits(loaded: LoadedScene) -> bool:
    """Whether an object wears a material of the scene's ``[materials]`` that emits light:
    an emissive colour above black at a strength above zero (an ``emissive_map`` only
    multiplies it, and a scene file refuses one without ``emissive``)."""
    materials = loaded.scene.materials
    for obj in loaded.scene.objects:
        material = materials.get(obj.material) if obj.material else None
        if material is None:
            continue
        if max(material.emission) > 0.0:
            return True
    return False
