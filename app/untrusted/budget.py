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

# Peak bytes the loaders allocate per unit of what an input declares (measured with
# tracemalloc on the loaders: docs/stability.md, "Limits"; rounded up).
COSTS = {
    "vertex": 600,  # a mesh vertex: float64 attributes, normals, tangents, the float32 array
    "triangle": 120,  # a triangle: int64 faces and their uint32 copy, face normals
    "colour texel": 12,  # an sRGB map: the decoded image and its RGBA8 copy
    "scalar texel": 40,  # a linear one-channel map with its float64 mips
    "normal texel": 260,  # a normal map's float64 normals, roughness and mip chain
    "direction texel": 60,  # an anisotropy direction map's decoded RG and mips
    "environment texel": 120,  # an HDR image decoded and turned into the float32 map
    "byte": 1,  # a file's bytes, held while its contents are decoded
    "mesh file byte": 40,  # an OBJ, PLY or STL file parsed by trimesh, per byte of the file
}


def describe(n: float) -> str:
    """Bytes for a message: '3.2 GiB', '412 MiB'."""
    return f"{n / GIB:.1f} GiB" if n >= GIB / 10 else f"{n / (1 << 20):.0f} MiB"


@dataclass
class Budget:
    """The running total of one scene's decoded input, refused past ``limits.max_memory``."""

    limits: Limits = field(default_factory=Limits)
    spent: int = 0
    triangles: int = 0
    parts: int = 0

    def charge(self, units: int, kind: str, what: str) -> None:
        """Add ``units`` of ``kind`` (a key of ``COSTS``) for ``what``; ``RefusedError`` where
        the total would pass the limit, naming ``what`` and the limit."""
        cost = int(units) * COSTS[kind]
        if self.spent + cost > self.limits.max_memory:
            raise RefusedError(
                f"{what} would take about {describe(cost)}, bringing this input to "
                f"{describe(self.spent + cost)}, past the limit of "
                f"{describe(self.limits.max_memory)} (--max-memory)"
            )
        self.spent += cost

    def mesh(self, vertices: int, triangles: int, what: str) -> None:
        """A part of ``vertices`` and ``triangles`` about to be built."""
        self.parts += 1
        if self.parts > self.limits.max_parts:
            raise RefusedError(f"{what}: more than {self.limits.max_parts} drawn parts")
        self.triangles += int(triangles)
        if self.triangles > self.limits.max_triangles:
            raise RefusedError(
                f"{what}: more than {self.limits.max_triangles} triangles in all "
                "(instances counted each time they are drawn)"
            )
        self.charge(vertices, "vertex", what)
        self.charge(triangles, "triangle", what)

    def texture(self, width: int, height: int, kind: str | None, what: str) -> None:
        """A texture of ``width`` x ``height`` texels about to be decoded, and (``kind``:
        colour, scalar, normal or direction; None: decoded only) turned into a map."""
        side = self.limits.max_texture_side
        if max(width, height) > side:
            raise RefusedError(f"{what} is {width}x{height}, more than {side} texels a side")
        if kind is not None:
            self.charge(width * height, f"{kind} texel", what)
