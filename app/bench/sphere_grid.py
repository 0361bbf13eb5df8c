"""The 35 spheres the speed comparisons draw (app/bench/spheres.py against pyrender,
app/bench/peers.py against pygfx, PyVista and pyrender): a 7 x 5 grid of icospheres,
rows alternating a red dielectric and a gold metal, roughness 0.1-0.9 along a row. One
declaration, so that both comparisons draw the same materials and tessellation."""

from __future__ import annotations

GRID = (7, 5)  # columns, rows
SPACING = 1.2  # m between sphere centres
RADIUS = 0.5  # m
SUBDIVISIONS = 4  # icospheres of 20 * 4^4 = 5,120 triangles, in every renderer


def sphere_grid(on_floor: bool) -> tuple[dict, list[dict]]:
    """The grid's materials (by name) and sphere objects: standing in the z = 0 plane,
    rows along y (``on_floor`` False), or lying on the y = 0 floor, rows along z."""
    cols, rows = GRID
    materials: dict = {}
    objects: list[dict] = []
    for j in range(rows):
        for i in range(cols):
            name = f"s{j}_{i}"
            metal = j % 2 == 1
            materials[name] = {
                "base_color": [1.0, 0.78, 0.34] if metal else [0.8, 0.25, 0.2],
                "metallic": 1.0 if metal else 0.0,
                "roughness": round(0.1 + 0.8 * i / (cols - 1), 4),
            }
            x = SPACING * (i - (cols - 1) / 2)
            row = SPACING * (j - (rows - 1) / 2)
            position = [x, RADIUS, row] if on_floor else [x, row, 0.0]
            objects.append({"shape": "sphere", "radius": RADIUS, "subdivisions": SUBDIVISIONS,
                            "material": name, "position": position})  # fmt: skip
    return materials, objects
