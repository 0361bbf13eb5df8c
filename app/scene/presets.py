"""Named materials from the seed's Fresnel tables (seed section 5; RTR4 tables 9.2-9.4).

Each preset is the seed's linear F0 and the workflow it implies: dielectrics keep a
scalar F0 (``metallic = 0``); metals, and silicon, whose reflectance is coloured and
which have no diffuse term, use ``metallic = 1`` with ``base_color = F0``. Where the
seed gives a range (e.g. water-y to dry tissue 0.02-0.04) the preset takes the midpoint
and records the range. The "in water" rows are the seed's values for the same
materials immersed in water (n1 = 1.33).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Preset:
    """One row of the seed's tables."""

    name: str
    kind: str  # "dielectric", "metal" or "semiconductor"
    f0: tuple[float, float, float]
    medium: str = "air"
    note: str = ""

    @property
    def metallic(self) -> float:
        """1 for anything whose F0 is coloured (metals, silicon), else 0."""
        return 0.0 if self.kind == "dielectric" else 1.0

    @property
    def f0_scalar(self) -> float:
        """Mean of the RGB F0, the value a dielectric preset carries."""
        return sum(self.f0) / 3.0


def _d(
    name: str, lo: float, hi: float | None = None, note: str = "", medium: str = "air"
) -> Preset:
    value = lo if hi is None else 0.5 * (lo + hi)
    if hi is not None:
        note = f"seed range {lo}-{hi}; midpoint used" + (f"; {note}" if note else "")
    return Preset(name, "dielectric", (value, value, value), medium, note)


def _m(name: str, r: float, g: float, b: float, kind: str = "metal", medium: str = "air") -> Preset:
    return Preset(name, kind, (r, g, b), medium)


_TABLE: tuple[Preset, ...] = (
    # Dielectrics (seed: "Typical Fresnel Reflectance Values", dielectric table).
    _d("water", 0.02),
    _d("living-tissue", 0.02, 0.04, "watery tissues toward the lower bound, dry ones higher"),
    _d("skin", 0.028),
    _d("eyes", 0.025, note="dry cornea; tears are close to water"),
    _d("hair", 0.046),
    _d("teeth", 0.058),
    _d("fabric", 0.04, 0.056, "polyester highest, most others under 0.05"),
    _d("stone", 0.035, 0.056, "the minerals most often found in stone"),
    _d("plastic-glass", 0.04, 0.05, "plastics and glass, not crystal glass"),
    _d("crystal-glass", 0.05, 0.07),
    _d("gems", 0.05, 0.08, "not diamonds or diamond simulants"),
    _d("diamond-like", 0.13, 0.2, "diamonds and simulants (cubic zirconia, moissanite)"),
    # Metals.
    _m("titanium", 0.542, 0.497, 0.449),
    _m("chromium", 0.549, 0.556, 0.554),
    _m("iron", 0.562, 0.565, 0.578),
    _m("nickel", 0.660, 0.609, 0.526),
    _m("platinum", 0.673, 0.637, 0.585),
    _m("copper", 0.955, 0.638, 0.538),
    _m("palladium", 0.733, 0.697, 0.652),
    _m("mercury", 0.781, 0.780, 0.778),
    _m("brass", 0.910, 0.778, 0.423),
    _m("zinc", 0.664, 0.824, 0.850),
    _m("gold", 1.000, 0.782, 0.344),
    _m("aluminum", 0.913, 0.922, 0.924),
    _m("silver", 0.972, 0.960, 0.915),
    # Semiconductors (the seed's table lists titanium here too; it is the metal above).
    # Diamond is a transparent insulator: kept as a dielectric with the table's mean F0.
    Preset("diamond", "dielectric", (0.171, 0.172, 0.176), note="seed's semiconductor table"),
    _m("silicon", 0.345, 0.369, 0.426, kind="semiconductor"),
    # The same materials in water (seed: "Fresnel Reflectance Values in Water").
    _d("skin-in-water", 0.0007, medium="water"),
    _d("schott-k7-glass", 0.042),
    _d("schott-k7-glass-in-water", 0.004, medium="water"),
    _d("diamond-in-water", 0.084, medium="water"),
    _m("iron-in-water", 0.470, 0.475, 0.492, medium="water"),
    _m("gold-in-water", 1.000, 0.747, 0.261, medium="water"),
    _m("silver-in-water", 0.964, 0.950, 0.899, medium="water"),
)

PRESETS: dict[str, Preset] = {p.name: p for p in _TABLE}
