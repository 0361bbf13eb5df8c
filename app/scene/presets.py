"""Named materials from RTR4's F0 tables (RTR4 §9.5; RTR4 tables 9.2-9.4).

Each preset is RTR4's linear F0 and the workflow it implies: dielectrics keep a
scalar F0 (``metallic = 0``); metals, and silicon, whose reflectance is coloured and
which have no diffuse term, use ``metallic = 1`` with ``base_color = F0``. Where
RTR4 gives a range (e.g. water-y to dry tissue 0.02-0.04) the preset takes the midpoint
and records the range.

Each preset also carries its index of refraction, so that its F0 can be computed rather
than looked up: a real ``ior`` for dielectrics, a complex ``eta + i k`` per RGB channel
for metals and silicon (measured optical constants, sources below, at ``WAVELENGTHS_NM``).
The "in water" rows (n1 = 1.33) follow from those indices: RTR4's own in-water rows
keep RTR4's F0 (``preset_table`` compares them with the computed value), and every
other material gets a ``<name>-in-water`` row whose F0 is computed from its index.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from app.common.ior import f0_conductor, f0_from_ior, ior_from_f0

MEDIUM_IOR = {"air": 1.0, "water": 1.33}

# The representative wavelengths of the R, G and B channels. Any single wavelength per
# channel approximates RTR4's F0, which are spectral reflectances integrated against
# colour-matching functions; 650/550/450 nm is the common rendering choice.
WAVELENGTHS_NM = (650.0, 550.0, 450.0)

_JC72 = "Johnson & Christy 1972, Phys. Rev. B 6, 4370"
_JC74 = "Johnson & Christy 1974, Phys. Rev. B 9, 5056"
_WERNER = "Werner, Glantschnig & Ambrosch-Draxl 2009, J. Phys. Chem. Ref. Data 38, 1013 (REELS)"

# Measured optical constants as tabulated in the refractiveindex.info database (public
# domain, CC0): (source, rows of (wavelength um, n, k)). Only the source rows that bracket
# 450, 550 and 650 nm are kept, verbatim; n and k are interpolated linearly in wavelength.
_OPTICAL_CONSTANTS: dict[str, tuple[str, tuple[tuple[float, float, float], ...]]] = {
    "titanium": (_JC74, (
        (0.431, 2.21, 3.01), (0.451, 2.27, 3.04), (0.549, 2.54, 3.43),
        (0.582, 2.60, 3.58), (0.617, 2.67, 3.72), (0.659, 2.76, 3.84),
    )),
    "chromium": (_JC74, (
        (0.431, 2.19, 3.04), (0.451, 2.33, 3.14), (0.549, 3.18, 3.33),
        (0.582, 3.22, 3.30), (0.617, 3.17, 3.30), (0.659, 3.09, 3.34),
    )),
    "iron": (_JC74, (
        (0.431, 2.48, 2.71), (0.451, 2.59, 2.77), (0.549, 2.95, 2.93),
        (0.582, 2.94, 2.99), (0.617, 2.88, 3.05), (0.659, 2.92, 3.10),
    )),
    "nickel": (_JC74, (
        (0.431, 1.71, 2.82), (0.451, 1.73, 2.95), (0.549, 1.92, 3.61),
        (0.582, 1.96, 3.80), (0.617, 1.99, 4.02), (0.659, 1.99, 4.26),
    )),
    "platinum": ("Rakic et al. 1998, Appl. Opt. 37, 5271 (Brendel-Bormann fit to measurements)", (
        (0.44722, 1.8390, 3.1204), (0.45610, 1.8591, 3.1717), (0.54437, 2.0699, 3.6830),
        (0.55518, 2.0984, 3.7451), (0.64973, 2.3748, 4.2641), (0.66263, 2.4155, 4.3305),
    )),
    "copper": (_JC72, (
        (0.4305, 1.25, 2.305), (0.4509, 1.24, 2.397), (0.5486, 1.02, 2.577),
        (0.5821, 0.70, 2.704), (0.6168, 0.30, 3.205), (0.6595, 0.22, 3.747),
    )),
    "palladium": (_JC74, (
        (0.431, 1.37, 3.14), (0.451, 1.41, 3.26), (0.549, 1.64, 3.84),
        (0.582, 1.68, 4.02), (0.617, 1.75, 4.21), (0.659, 1.80, 4.42),
    )),
    "mercury": ("Inagaki, Arakawa & Williams 1981, Phys. Rev. B 23, 5246 (liquid Hg)", (
        (0.44280, 1.02698, 3.80193), (0.47686, 1.18600, 4.08981),
        (0.51660, 1.38332, 4.40608), (0.56356, 1.62088, 4.75050),
        (0.61992, 1.90988, 5.14953), (0.68880, 2.28417, 5.58189),
    )),
    "brass": ("Querry 1985, CRDC-CR-85034 (70% Cu, 30% Zn: C260 cartridge brass)", (
        (0.4400, 1.191, 1.797), (0.4500, 1.094, 1.829), (0.4600, 0.994, 1.883),
        (0.5400, 0.549, 2.668), (0.5500, 0.527, 2.765), (0.5600, 0.505, 2.860),
        (0.6400, 0.444, 3.609), (0.6500, 0.444, 3.695), (0.6600, 0.445, 3.778),
    )),
    "zinc": (_WERNER, (
        (0.413281, 0.6029, 3.6376), (0.450852, 0.6794, 4.0209),
        (0.495937, 0.7858, 4.4636), (0.551041, 0.9322, 4.9850),
        (0.619921, 1.1356, 5.6116), (0.708481, 1.4247, 6.3811),
    )),
    "gold": (_JC72, (
        (0.4305, 1.45, 1.948), (0.4509, 1.38, 1.914), (0.5486, 0.43, 2.455),
        (0.5821, 0.29, 2.863), (0.6168, 0.21, 3.272), (0.6595, 0.14, 3.697),
    )),
    "aluminum": ("Rakic 1995, Appl. Opt. 34, 4755", (
        (0.44280, 0.60790, 5.3676), (0.47687, 0.72780, 5.7781),
        (0.51660, 0.87340, 6.2418), (0.56357, 1.0728, 6.7839),
        (0.61993, 1.3660, 7.4052), (0.65225, 1.5724, 7.7354),
    )),
    "silver": (_JC72, (
        (0.4305, 0.04, 2.462), (0.4509, 0.04, 2.657), (0.5486, 0.06, 3.586),
        (0.5821, 0.05, 3.858), (0.6168, 0.06, 4.152), (0.6595, 0.05, 4.483),
    )),
    "silicon": ("Aspnes & Studna 1983, Phys. Rev. B 27, 985", (
        (0.4428, 4.753, 0.163), (0.4592, 4.583, 0.130), (0.5391, 4.123, 0.048),
        (0.5636, 4.042, 0.032), (0.6199, 3.906, 0.022), (0.6525, 3.847, 0.016),
    )),
}  # fmt: skip

# Dielectrics with a measured dispersion formula (refractiveindex.info database):
# (source, formula, coefficients). Formula 1: n^2 - 1 = C0 + sum B lambda^2/(lambda^2 - C^2);
# formula 2: the same with C in place of C^2 (lambda in um). Evaluated at the helium d line,
# the reference wavelength of glass catalogues.
WAVELENGTH_D_NM = 587.5618
_DISPERSION: dict[str, tuple[str, int, tuple[float, ...]]] = {
    "water": ("Daimon & Masumura 2007, Appl. Opt. 46, 3811 (20.0 C)", 2, (
        0.0, 5.684027565e-1, 5.101829712e-3, 1.726177391e-1, 1.821153936e-2,
        2.086189578e-2, 2.620722293e-2, 1.130748688e-1, 1.069792721e1,
    )),
    "schott-k7-glass": ("SCHOTT Zemax catalogue 2017-01-20b (K7, n_d = 1.51112)", 2, (
        0.0, 1.1273555, 0.00720341707, 0.124412303, 0.0269835916, 0.827100531, 100.384588,
    )),
    "diamond": ("Peter 1923, Z. Phys. 15, 358", 1, (0.0, 0.3306, 0.1750, 4.3356, 0.1060)),
}  # fmt: skip


def sellmeier(formula: int, coefficients: tuple[float, ...], wavelength_um: float) -> float:
    """n from a refractiveindex.info formula 1 or 2 (Sellmeier) dispersion formula."""
    l2 = wavelength_um * wavelength_um
    s = coefficients[0]
    for b, c in zip(coefficients[1::2], coefficients[2::2], strict=True):
        s += b * l2 / (l2 - (c * c if formula == 1 else c))
    return float(np.sqrt(1.0 + s))


def optical_constants(name: str) -> tuple[tuple[float, ...], tuple[float, ...], str]:
    """(n, k, source) of a metal at ``WAVELENGTHS_NM``, interpolated linearly in wavelength."""
    source, rows = _OPTICAL_CONSTANTS[name]
    table = np.array(rows, np.float64)
    wl = np.array(WAVELENGTHS_NM) / 1000.0
    n = np.interp(wl, table[:, 0], table[:, 1])
    k = np.interp(wl, table[:, 0], table[:, 2])
    return tuple(map(float, n)), tuple(map(float, k)), source


@dataclass(frozen=True)
class Preset:
    """One material: a row of RTR4's tables, or one derived from its index."""

    name: str
    kind: str  # "dielectric", "metal" or "semiconductor"
    f0: tuple[float, float, float]  # RTR4's linear F0 (computed for derived rows)
    medium: str = "air"
    note: str = ""
    ior: float | None = None  # real index of a dielectric (absolute)
    eta: tuple[float, float, float] | None = None  # absolute complex index n + ik, R, G, B
    k: tuple[float, float, float] | None = None
    index_source: str = ""
    derived: bool = False  # f0 computed from the index: RTR4 has no such row

    @property
    def metallic(self) -> float:
        """1 for anything whose F0 is coloured (metals, silicon), else 0."""
        return 0.0 if self.kind == "dielectric" else 1.0

    @property
    def f0_scalar(self) -> float:
        """Mean of the RGB F0, the value a dielectric preset carries."""
        return sum(self.f0) / 3.0

    @property
    def medium_ior(self) -> float:
        """Index of the surrounding medium: 1.0 for air, 1.33 for water."""
        return MEDIUM_IOR[self.medium]

    def f0_from_index(self) -> tuple[float, float, float] | None:
        """F0 of the index relative to the medium (None where the preset has no index)."""
        m = self.medium_ior
        if self.ior is not None:
            v = float(f0_from_ior(self.ior, m))
            return (v, v, v)
        if self.eta is not None and self.k is not None:
            f = f0_conductor(np.array(self.eta) / m, np.array(self.k) / m)
            return (float(f[0]), float(f[1]), float(f[2]))
        return None


def _d(
    name: str, lo: float, hi: float | None = None, note: str = "", medium: str = "air"
) -> Preset:
    value = lo if hi is None else 0.5 * (lo + hi)
    if hi is not None:
        note = f"RTR4 range {lo}-{hi}; midpoint used" + (f"; {note}" if note else "")
    return Preset(name, "dielectric", (value, value, value), medium, note)


def _m(name: str, r: float, g: float, b: float, kind: str = "metal", medium: str = "air") -> Preset:
    return Preset(name, kind, (r, g, b), medium)


_TABLE: tuple[Preset, ...] = (
    # Dielectrics (RTR4 §9.5, the table of dielectric F0 values).
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
    # Semiconductors (RTR4's table lists titanium here too; it is the metal above).
    # Diamond is a transparent insulator: kept as a dielectric with the table's mean F0.
    Preset("diamond", "dielectric", (0.171, 0.172, 0.176), note="RTR4's semiconductor table"),
    _m("silicon", 0.345, 0.369, 0.426, kind="semiconductor"),
    # The same materials in water (RTR4 §9.5, F0 values in water).
    _d("skin-in-water", 0.0007, medium="water"),
    _d("schott-k7-glass", 0.042),
    _d("schott-k7-glass-in-water", 0.004, medium="water"),
    _d("diamond-in-water", 0.084, medium="water"),
    _m("iron-in-water", 0.470, 0.475, 0.492, medium="water"),
    _m("gold-in-water", 1.000, 0.747, 0.261, medium="water"),
    _m("silver-in-water", 0.964, 0.950, 0.899, medium="water"),
)


def _material(name: str) -> str:
    """The material a preset name denotes ('gold-in-water' -> 'gold')."""
    return name.removesuffix("-in-water")


def _with_index(p: Preset, air_f0: dict[str, float]) -> Preset:
    """``p`` with its index filled in: measured constants, a dispersion formula, or the
    index implied by the material's RTR4 F0 in air (ior_from_f0)."""
    material = _material(p.name)
    if material in _OPTICAL_CONSTANTS:
        eta, k, source = optical_constants(material)
        return replace(p, eta=eta, k=k, index_source=source)
    if material in _DISPERSION:
        source, formula, coefficients = _DISPERSION[material]
        n = sellmeier(formula, coefficients, WAVELENGTH_D_NM / 1000.0)
        return replace(p, ior=n, index_source=f"{source}, at 587.6 nm")
    n = float(ior_from_f0(air_f0[material]))
    return replace(p, ior=n, index_source="ior_from_f0(RTR4 F0 in air)")


def _in_water(p: Preset) -> Preset:
    """The derived ``<name>-in-water`` counterpart of an air preset, F0 from its index."""
    w = Preset(
        f"{p.name}-in-water", p.kind, p.f0, "water", "derived from the index (no RTR4 row)",
        p.ior, p.eta, p.k, p.index_source, derived=True,
    )  # fmt: skip
    f0 = w.f0_from_index()
    assert f0 is not None
    return replace(w, f0=f0)


def _build() -> tuple[Preset, ...]:
    air_f0 = {p.name: p.f0_scalar for p in _TABLE if p.medium == "air"}
    seeded = [_with_index(p, air_f0) for p in _TABLE]
    names = {p.name for p in seeded}
    # Water in water is no interface at all; every other material gets its in-water row.
    derived = [
        _in_water(p)
        for p in seeded
        if p.medium == "air" and p.name != "water" and f"{p.name}-in-water" not in names
    ]
    return (*seeded, *derived)


PRESETS: dict[str, Preset] = {p.name: p for p in _build()}


def preset_table() -> list[dict]:
    """Per preset: the RTR4 F0, the index, the F0 computed from the index and the difference.

    ``rtr4_f0`` and ``difference`` (computed - RTR4) are None for the derived rows, whose F0
    is the computed one. Used by docs/fresnel.md and tests/test_fresnel.py.
    """
    rows = []
    for p in PRESETS.values():
        computed = p.f0_from_index()
        book = None if p.derived else p.f0
        diff = None
        if book is not None and computed is not None:
            diff = tuple(c - s for c, s in zip(computed, book, strict=True))
        rows.append(
            {
                "name": p.name, "kind": p.kind, "medium": p.medium, "rtr4_f0": book,
                "ior": p.ior, "eta": p.eta, "k": p.k, "f0_index": computed,
                "difference": diff, "index_source": p.index_source, "derived": p.derived,
            }
        )  # fmt: skip
    return rows
