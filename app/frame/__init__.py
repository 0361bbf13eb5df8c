"""Frame data: what one scene hands the passes, prepared once on the CPU.

``prepare_frame(loaded)`` turns a validated scene into ``FrameData``: the mesh parts with
their material layers and maps, the material table that the lighting pass reads (and each
part's rows of it), and the lights in the order every pass sums them. The deferred
renderer (app/render/renderer.py) and the bench's forward renderer both start from it.
The camera is not part of it: it changes every frame in the viewer (app/frame/camera.py).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from app.common.lights import PunctualLight
from app.frame.lights import frame_lights
from app.frame.materials import MaterialTable, material_table
from app.scene.geometry import MeshPart, build_parts, take_built
from app.scene.layers import LayerBuilder
from app.scene.loader import LoadedScene
from app.scene.model import TEXTURE_KEYS, Scene
from app.untrusted.budget import Budget


@dataclass
class FrameData:
    """The parts to draw, their material table, and the lights."""

    parts: list[MeshPart]
    materials: MaterialTable
    material_ids: list[list[int]]  # part i's rows of ``materials``, one per layer
    lights: list[PunctualLight]  # directional first, then local (order_lights)
    decoded: int = 0  # bytes of decoded input the parts keep (app/untrusted/budget.py)

    @property
    def has_local_lights(self) -> bool:
        return any(light.is_local for light in self.lights)


def prepare_frame(loaded: LoadedScene) -> FrameData:
    """Load the scene's geometry and maps and build its material table and lights."""
    kept = take_built(loaded)  # a model file's parts, built to frame its camera
    if kept is None:
        budget = Budget(loaded.policy.limits)
        kept = build_parts(loaded, budget), budget.spent
    parts, spent = kept
    table, ids = material_table(parts)
    scene = loaded.scene
    return FrameData(parts, table, ids, frame_lights(scene.lights), spent)


def restyle(frame: FrameData, loaded: LoadedScene, changed: set[str]) -> FrameData | None:
    """``frame`` with new constants for the scene materials named in ``changed`` (their
    definitions in ``loaded`` differ from those ``frame`` was built with), keeping every
    part's geometry: what a slider in the viewer needs, without loading meshes again.

    The parts' layers are replaced in place. None where a changed material has texture
    maps or a blend, had maps before the edit, or another material blends it in: their
    maps and bakes depend on the constants, so the caller prepares the whole frame again.
    """
    scene = loaded.scene
    for name in changed:
        m = scene.materials.get(name)
        if m is None or m.blend is not None or any(getattr(m, k) for k in TEXTURE_KEYS):
            return None
        if any(other.blend and other.blend.material == name for other in scene.materials.values()):
            return None
    named = [
        (part, scene.objects[part.object_index].material)
        for part in frame.parts
        if part.object_index >= 0
    ]
    # A part whose layer was built with maps (the material had them before this edit)
    # needs its layer and G-buffer program built again, as any part with maps does.
    if any(name in changed and (len(p.layers) != 1 or p.layers[0].maps) for p, name in named):
        return None
    builder = LayerBuilder(loaded)
    layers = {name: builder.layer(name) for name in changed}
    for part, name in named:
        if name in layers:
            part.layers = [layers[name]]
    table, ids = material_table(frame.parts)
    return dataclasses.replace(frame, materials=table, material_ids=ids)


def restyle_file_materials(frame: FrameData, loaded: LoadedScene, old: Scene) -> FrameData | None:
    """``frame`` with new constants for the model files' own materials whose factors
    (``objects[i].file_materials``) differ between ``old``, the scene ``frame`` was built
    from, and ``loaded``'s, keeping every part and map: a viewer slider on a model file's
    material, as ``restyle`` is one on a scene material.

    The parts' layers are replaced in place. None where anything of an object but its
    ``file_materials`` differs, or where only new parts give the glTF reader's layer
    (``app.scene.file_materials.restyled_layers`` says when)."""
    from app.scene.file_materials import restyled_layers

    new = loaded.scene
    if len(new.objects) != len(old.objects):
        return None
    replaced: dict[int, dict] = {}
    for index, (was, now) in enumerate(zip(old.objects, new.objects, strict=True)):
        if was == now:
            continue
        if was.model_copy(update={"file_materials": None}) != now.model_copy(
            update={"file_materials": None}
        ):
            return None
        drawn = {
            part.file_material: part.layers[0]
            for part in frame.parts
            if part.object_index == index and part.file_material is not None
        }
        layers = restyled_layers(loaded, index, was.file_materials or {}, drawn)
        if layers is None:
            return None
        replaced[index] = layers
    for part in frame.parts:
        layers = replaced.get(part.object_index, {})
        if part.file_material in layers:
            part.layers = [layers[part.file_material]]
    table, ids = material_table(frame.parts)
    return dataclasses.replace(frame, materials=table, material_ids=ids)
