"""Frame data: what one scene hands the passes, prepared once on the CPU.

``prepare_frame(loaded)`` turns a validated scene into ``FrameData``: the mesh parts with
their material layers and maps, the material table that the lighting pass reads (and each
part's rows of it), and the lights in the order every pass sums them. The deferred
renderer (app/render/renderer.py) and the bench's forward renderer both start from it.
The camera is not part of it: it changes every frame in the viewer (app/frame/camera.py).
"""

from __future__ import annotations

from dataclasses import dataclass

from app.common.lights import PunctualLight
from app.frame.lights import frame_lights
from app.frame.materials import MaterialTable, material_table
from app.scene.geometry import MeshPart, build_parts
from app.scene.loader import LoadedScene


@dataclass
class FrameData:
    """The parts to draw, their material table, and the lights."""

    parts: list[MeshPart]
    materials: MaterialTable
    material_ids: list[list[int]]  # part i's rows of ``materials``, one per layer
    lights: list[PunctualLight]  # directional first, then local (order_lights)

    @property
    def has_local_lights(self) -> bool:
        return any(light.is_local for light in self.lights)


def prepare_frame(loaded: LoadedScene) -> FrameData:
    """Load the scene's geometry and maps and build its material table and lights."""
    parts = build_parts(loaded)
    table, ids = material_table(parts)
    scene = loaded.scene
    return FrameData(parts, table, ids, frame_lights(scene.lights, scene.environment))
