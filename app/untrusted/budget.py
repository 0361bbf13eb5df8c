"""The memory an input will take, added up before it is allocated.

Each loader asks its ``Budget`` before it builds anything whose size an input decides: the
bytes of a file it is about to read, a mesh of the declared vertex and triangle counts, a
texture of the width and height its header gives, an environment map. The cost of each is
the peak of the arrays the loader really builds for it, per vertex or per texel
(``COSTS``, measured on the loaders themselves: docs/stability.md, "Limits"), so a 2 KB
file that declares 16 million vertices is refused before one is made. The GPU side is
checked once more when the renderer adds geometry, textures and render targets up
(``gpu_bytes`` in app/render/renderer.py).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from app.untrusted import RefusedError
from app.untrusted.policy import GIB, Limits

# Bytes the loaders allocate per unit of what an input declares, as (peak while the unit
# is being built, what stays once it is built), measured on the loaders themselves
# (scripts/budget_costs.py; the table is in docs/stability.md, "Limits"), rounded up with a
# margin for the few per cent repeated runs differ by:
# a vertex with its share of the triangles' work, each kind of map per texel with its
# mips, an environment image per texel, a mesh file parsed by trimesh per byte, a file's
# bytes held while its contents are decoded.
COSTS = {
    "vertex": (600, 64),
    "triangle": (120, 16),
    "colour texel": (20, 6),
    "scalar texel": (56, 8),
    "normal texel": (128, 24),
    "direction texel": (72, 12),
    "environment texel": (120, 16),
    "byte": (1, 1),
    "mesh file byte": (12, 1),
}


def describe(n: float) -> str:
    """Bytes for a message: '3.2 GiB', '412 MiB'."""
    return f"{n / GIB:.1f} GiB" if n >= GIB / 10 else f"{n / (1 << 20):.0f} MiB"


@dataclass
class Budget:
    """The running total of what one scene's decoded input keeps, and the check that it
    plus what the next unit takes while it is built stays within ``limits.max_memory``."""

    limits: Limits = field(default_factory=Limits)
    spent: int = 0  # bytes kept by what was built so far
    peak: int = 0  # the largest spent + building seen
    triangles: int = 0
    parts: int = 0

    def charge(self, units: int, kind: str, what: str) -> None:
        """``units`` of ``kind`` (a key of ``COSTS``) about to be built for ``what``:
        ``RefusedError`` where building them would pass the limit (naming ``what`` and the
        limit), else their lasting share is added to the total."""
        building, kept = (int(units) * c for c in COSTS[kind])
        self._take(building, kept, what)

    def _take(self, building: int, kept: int, what: str) -> None:
        if self.spent + building > self.limits.max_memory:
            raise RefusedError(
                f"{what} would take about {describe(building)} while it is read, on top of "
                f"{describe(self.spent)} already held, past the limit of "
                f"{describe(self.limits.max_memory)} (--max-memory)"
            )
        self.peak = max(self.peak, self.spent + building)
        self.spent += kept

    def mesh(self, vertices: int, triangles: int, what: str) -> None:
        """A part of ``vertices`` and ``triangles`` about to be built."""
        self.parts += 1
        if self.parts > self.limits.max_parts:
            raise RefusedError(f"more than {self.limits.max_parts} drawn parts in all")
        self.triangles += int(triangles)
        if self.triangles > self.limits.max_triangles:
            raise RefusedError(
                f"more than {self.limits.max_triangles} triangles in all "
                "(instances counted each time they are drawn)"
            )
        v, t = COSTS["vertex"], COSTS["triangle"]  # built together: their peaks add up
        building = int(vertices) * v[0] + int(triangles) * t[0]
        self._take(building, int(vertices) * v[1] + int(triangles) * t[1], what)

    def texture(self, width: int, height: int, kind: str | None, what: str) -> None:
        """A texture of ``width`` x ``height`` texels about to be decoded, and (``kind``:
        colour, scalar, normal or direction; None: decoded only) turned into a map."""
        side = self.limits.max_texture_side
        if max(width, height) > side:
            raise RefusedError(f"{what} is {width}x{height}, more than {side} texels a side")
        if kind is not None:
            self.charge(width * height, f"{kind} texel", what)
