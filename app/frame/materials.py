"""The material table: the per-material numbers of the optional BRDF models, one row per
distinct (model, parameters), and the model groups that decide the lighting permutations.

The G-buffer carries each pixel's row (its material id); the lighting pass compiles one
program per distinct ``Model`` (a group) and each program shades only its group's pixels.
Each row also carries its model's codes (app.common.models.model_codes), which only the
bench's uber lighting shader reads.

Where every part the G-buffer draws has the same surface numbers (base colour, metallic,
perceptual roughness, F0) at all its pixels (``constant_surface``), the rows are keyed by
those numbers too and carry them (``SURFACE_TEXEL``): the G-buffer can then store only
each pixel's normal, depth and row, and the lighting pass read the rest from the row
(docs/gbuffer.md, "Constant surfaces").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.common.extension_maps import FACTOR_TARGETS, targets_of
from app.common.gbuffer import optional_defines
from app.common.material_fields import MATERIAL_FIELDS
from app.common.models import (
    SURFACE_TEXELS,
    MaterialParams,
    Model,
    ModelParams,
    pack_model_params,
)
from app.scene.geometry import MeshPart


def _spread(x: np.ndarray | float, n: int) -> tuple:
    """``x`` (n numbers, or one for all n) as a tuple of n numbers: a hashable part of a
    key. ``tolist`` where it already has n (the usual case): np.broadcast_to took most of
    a viewer slider step's material table (docs/viewer.md)."""
    a = np.asarray(x)
    return tuple(a.tolist()) if a.shape == (n,) else tuple(np.broadcast_to(a, n).tolist())


def _params_key(p: ModelParams) -> tuple:
    """Every number of ``p`` (app/common/material_fields.py MATERIAL_FIELDS), hashable:
    rows are shared by materials whose model and numbers are equal."""
    return tuple(
        _spread(getattr(p, f.name), f.size) if f.size > 1 else getattr(p, f.name)
        for f in MATERIAL_FIELDS
    )


def _surface_key(m: MaterialParams) -> tuple:
    """The surface numbers the G-buffer's RT0 and RT1 would store for a layer without maps."""
    return (_spread(m.base_color, 3), m.metallic, m.roughness, m.f0)


# Maps that change the surface numbers of RT0/RT1 (or the row) from pixel to pixel; the
# others (anisotropy, its direction, the coat normal, emission, occlusion) feed other
# targets. Keys of SurfaceLayer.maps.
SURFACE_MAPS = frozenset({"base_color", "metallic", "normal_roughness", "f0", "select"})


def constant_surface(part: MeshPart) -> bool:
    """Whether the G-buffer pass writes one set of surface numbers (its layer 0's constants)
    at every pixel of ``part``: no map of SURFACE_MAPS, no mask blend of two layers, no
    glTF COLOR_0 (it multiplies the base colour; an analytic part has none). Screen-space
    specular antialiasing, a render setting, widens the roughness per pixel too: the
    renderer checks it (Renderer._constant_surfaces)."""
    layer = part.layers[0]
    return (
        part.blend is None
        and not SURFACE_MAPS & layer.maps.keys()
        and (part.colors is None or part.analytic is not None)
    )


@dataclass
class MaterialTable:
    """Rows of (model, params), the distinct models in first-use order, and each row's group."""

    models: list[Model]  # one per group
    rows: list[tuple[Model, ModelParams]]
    groups: list[int]  # group of each row
    # A clear coat of the frame shades with a normal other than its base's (a coat over a
    # normal-mapped base, or a coat normal map: SurfaceLayer.own_coat_normal; RTR4 §9.12).
    needs_coat_normals: bool = False
    # A layer of the frame emits or has an occlusion map (glTF 2.0 core material):
    # only then does the G-buffer carry RT5 (emitted radiance, occlusion).
    needs_emission: bool = False
    # The factor targets the extension maps of the frame's layers fill
    # (app/common/extension_maps.py targets_of): only a G-buffer target among them is
    # allocated (RT6 ``layer_maps``, RT8 ``coat_film_maps``), and the forward passes
    # compile in the sampling of each (``factor_defines``).
    factor_targets: frozenset[str] = frozenset()
    # Every part the G-buffer draws has constant surface numbers (``constant_surface``):
    # then ``surfaces`` holds each row's (base colour, metallic, roughness, F0), the rows
    # are distinct in them too, and ``packed`` appends them (SURFACE_TEXEL).
    surfaces: list[MaterialParams] | None = None

    @classmethod
    def build(
        cls, materials: list[MaterialParams], surfaces: bool = False
    ) -> tuple[MaterialTable, list[int]]:
        """The table for ``materials`` and each material's row (its material id); with
        ``surfaces``, rows also differ by the surface numbers and carry them."""
        models: list[Model] = []
        rows: list[tuple[Model, ModelParams]] = []
        groups: list[int] = []
        held: list[MaterialParams] = []
        index: dict[tuple, int] = {}
        ids = []
        for m in materials:
            key = (m.model, _params_key(m.params))
            if surfaces:
                key += _surface_key(m)
            if key not in index:
                if m.model not in models:
                    models.append(m.model)
                index[key] = len(rows)
                rows.append((m.model, m.params))
                groups.append(models.index(m.model))
                held.append(m)
            ids.append(index[key])
        return cls(models, rows, groups, surfaces=held if surfaces else None), ids

    @property
    def constant_surfaces(self) -> bool:
        """Whether the rows carry the surface numbers (see ``surfaces``)."""
        return self.surfaces is not None

    @property
    def needs_tangents(self) -> bool:
        """Whether a material is anisotropic, a diffraction grating (RTR4 §9.11: its grooves
        run along the tangent) or a fibre (RTR4 §9.10: its thread does): only then does
        shading read a tangent, and the G-buffer carry one (docs/gbuffer.md)."""
        return any(
            model.anisotropic or model.diffraction != "none" or model.fiber != "none"
            for model in self.models
        )

    def gbuffer_defines(self) -> dict[str, int]:
        """The G-buffer's optional targets as the defines of every pass that writes or
        decodes it (app/common/gbuffer.py GBUFFER_TARGETS): RT3 (tangent), RT4 (coat normal) and RT5
        (emission and occlusion; named only where present, so that every other scene's
        programs compile exactly as before it existed)."""
        return optional_defines(
            {
                "tangent": self.needs_tangents,
                "coat_normal": self.needs_coat_normals,
                "emission": self.needs_emission,
                "edge": False,  # the renderer's, by render.antialiasing (Renderer._layout)
                **{t.name: t.name in self.factor_targets for t in FACTOR_TARGETS if t.gbuffer},
            }
        )

    def factor_defines(self) -> dict[str, int]:
        """The define of each factor target the frame's maps fill, G-buffer or not: what
        a forward pass (app/render/blend.py forward_drawables) compiles in to sample them
        as the G-buffer pass does."""
        return {t.define: 1 for t in FACTOR_TARGETS if t.name in self.factor_targets}

    def packed(self) -> np.ndarray:
        """(M, MATERIAL_TEXELS, 4) float32 texels, see app.common.models.pack_model_params;
        with ``surfaces``, (M, MATERIAL_TEXELS + SURFACE_TEXELS, 4): each row's surface
        texels appended (``surface_texels``)."""
        table = pack_model_params([p for _, p in self.rows], self.groups,
                                  [m for m, _ in self.rows])  # fmt: skip
        if self.surfaces is None:
            return table
        return np.concatenate([table, self.surface_texels()], axis=1)

    def surface_texels(self) -> np.ndarray:
        """(M, SURFACE_TEXELS, 4) float32: (base colour RGB, metallic), (perceptual
        roughness, F0, 0, 0) per row, rounded to float32 as the G-buffer pass's uniforms
        are; zeros without ``surfaces``."""
        out = np.zeros((max(len(self.rows), 1), SURFACE_TEXELS, 4), np.float32)
        for row, m in enumerate(self.surfaces or ()):
            out[row, 0, :3] = m.base_color
            out[row, 0, 3] = m.metallic
            out[row, 1, :2] = (m.roughness, m.f0)
        return out


def material_table(parts: list[MeshPart]) -> tuple[MaterialTable, list[list[int]]]:
    """The lighting pass's material table over every layer of every part, and each part's
    rows (one per layer)."""
    layers = [layer for p in parts for layer in p.layers]
    # The G-buffer draws every part but the alpha-blended ones (app/render/blend.py).
    drawn = [p for p in parts if p.layers[0].alpha_mode != "blend"]
    surfaces = all(constant_surface(p) for p in drawn)
    table, flat = MaterialTable.build([layer.params for layer in layers], surfaces)
    table.needs_coat_normals = any(layer.own_coat_normal for layer in layers)
    table.needs_emission = any(
        any(layer.emissive) or "emissive" in layer.maps or "occlusion" in layer.maps
        for layer in layers
    )
    table.factor_targets = frozenset().union(*(targets_of(layer.maps) for layer in layers))
    ids, i = [], 0
    for p in parts:
        ids.append(flat[i : i + len(p.layers)])
        i += len(p.layers)
    return table, ids
