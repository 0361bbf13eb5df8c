"""Twin of glsl/brdf/fresnel.glsl: Fresnel reflectance terms.

Besides the twins of the GLSL functions this module holds the index <-> F0 helpers the
presets use and the comparison of Schlick's approximation with the exact Fresnel
equations that docs/fresnel.md reports. ``python -m app.reference.fresnel`` prints the
generated part of that document (the preset and the Schlick-error tables) as markdown.
"""

from __future__ import annotations

import numpy as np


def pow5_one_minus(x: np.ndarray) -> np.ndarray:
    """(1 - x)^5."""
    return (1.0 - np.asarray(x, np.float64)) ** 5


def F_schlick(F0: np.ndarray, cos_theta: np.ndarray) -> np.ndarray:
    """Schlick 1994; seed section 5: F = F0 + (1 - F0)(1 - (n.l)+)^5.

    ``F0`` (..., 3) or scalar, ``cos_theta`` (...); returns (..., 3).
    """
    F0 = np.asarray(F0, np.float64)
    c = np.clip(np.asarray(cos_theta, np.float64), 0.0, 1.0)[..., None]
    return F0 + (1.0 - F0) * pow5_one_minus(c)


def F_schlick_generalized(
    F0: np.ndarray, F90: np.ndarray, exponent: np.ndarray, cos_theta: np.ndarray
) -> np.ndarray:
    """Seed section 5 (RTR4 sec. 9.5): F = F0 + (F90 - F0)(1 - (n.l)+)^(1/p).

    ``exponent`` = 1/p > 0 (5 gives Schlick); 0^exponent is 0, as the GLSL writes it out.
    ``F0``, ``F90`` (..., 3); ``exponent``, ``cos_theta`` (...); returns (..., 3).
    """
    F0 = np.asarray(F0, np.float64)
    F90 = np.asarray(F90, np.float64)
    m = 1.0 - np.clip(np.asarray(cos_theta, np.float64), 0.0, 1.0)
    e = np.asarray(exponent, np.float64)
    with np.errstate(divide="ignore"):
        w = np.where(m > 0.0, np.power(np.where(m > 0.0, m, 1.0), e), 0.0)
    return F0 + (F90 - F0) * w[..., None]


def F_dielectric(eta: np.ndarray, cos_theta_i: np.ndarray) -> np.ndarray:
    """Fresnel 1823; Born & Wolf sec. 1.5.2: unpolarised reflectance of a dielectric interface.

    ``eta`` = n2/n1 (far side over incident side; < 1 is internal reflection, exactly 1
    past the critical angle). Evaluated as the GLSL does: with d = (eta - 1)(eta + 1) and
    g = sqrt(d + c^2), r_s = -d/(g + c)^2 and r_p = d((eta^2 + 1)c^2 - 1)/(eta^2 c + g)^2,
    free of the cancellation in c - g; eta = 1 gives exactly 0. Returns (...).
    """
    eta = np.asarray(eta, np.float64)
    c = np.clip(np.asarray(cos_theta_i, np.float64), 0.0, 1.0)
    d = (eta - 1.0) * (eta + 1.0)
    g2 = d + c * c
    g = np.sqrt(np.maximum(g2, 0.0))
    e2 = eta * eta
    gc = g + c
    q = e2 * c + g
    with np.errstate(divide="ignore", invalid="ignore"):
        rs = d / (gc * gc)
        rp = d * ((e2 + 1.0) * c * c - 1.0) / (q * q)
    F = 0.5 * (rs * rs + rp * rp)
    return np.where(d == 0.0, 0.0, np.where(g2 <= 0.0, 1.0, F))


def F_conductor(eta: np.ndarray, k: np.ndarray, cos_theta_i: np.ndarray) -> np.ndarray:
    """Born & Wolf ch. 14; Lagarde 2013: unpolarised reflectance for the index eta + i k.

    ``eta``, ``k`` (..., 3) relative to the incident medium, ``cos_theta_i`` (...); returns
    (..., 3). The same cancellation-free products as the GLSL (see the comment there):
    R_s = |eta_c^2 - 1|^2 / |c + w|^4 and R_p = R_s |eta_c^2 c^2 - s^2|^2 / |w c + s^2|^4,
    w = a + i b = sqrt(eta_c^2 - s^2) with a, b from the non-cancelling root and a b = eta k.
    """
    eta = np.asarray(eta, np.float64)
    k = np.asarray(k, np.float64)
    c = np.clip(np.asarray(cos_theta_i, np.float64), 0.0, 1.0)[..., None]
    c2 = c * c
    s2 = 1.0 - c2
    d = (eta - 1.0) * (eta + 1.0) - k * k
    p = 2.0 * eta * k
    t = d + c2
    m = np.sqrt(t * t + p * p)
    big = np.sqrt(0.5 * (m + np.abs(t)))
    small = 0.5 * p / np.maximum(big, 1e-30)
    a = np.where(t < 0.0, small, big)
    b = np.where(t < 0.0, big, small)
    ac = a + c
    D = ac * ac + b * b
    N = d * d + p * p
    Rs = N / np.maximum(D * D, 1e-30)
    acs = a * c + s2
    bc = b * c
    E = acs * acs + bc * bc
    re = (d + 1.0) * c2 - s2
    im = p * c2
    M = re * re + im * im
    Rp = Rs * M / np.maximum(E * E, 1e-30)
    return 0.5 * (Rs + Rp)


def cos_theta_schlick(eta: np.ndarray, cos_theta_i: np.ndarray) -> np.ndarray:
    """RTR4 sec. 9.5.2: the cosine for Schlick's approximation.

    cos_i for external reflection (eta >= 1); for internal reflection the transmitted
    cos_t = sqrt(1 - (1 - c^2)/eta^2) = sqrt((eta - 1)(eta + 1) + c^2)/eta, and 0 past the
    critical angle (F_schlick then gives exactly 1). Returns (...).
    """
    eta = np.asarray(eta, np.float64)
    c = np.clip(np.asarray(cos_theta_i, np.float64), 0.0, 1.0)
    g2 = (eta - 1.0) * (eta + 1.0) + c * c
    cos_t = np.minimum(np.sqrt(np.maximum(g2, 0.0)) / eta, 1.0)
    return np.where(eta >= 1.0, c, np.where(g2 > 0.0, cos_t, 0.0))


# --- Index <-> F0 (twin-only helpers) ---------------------------------------------------------


def f0_from_ior(n2: np.ndarray, n1: np.ndarray | float = 1.0) -> np.ndarray:
    """Seed section 5: F0 = ((n1 - n2)/(n1 + n2))^2 for an interface n1 -> n2."""
    n1 = np.asarray(n1, np.float64)
    n2 = np.asarray(n2, np.float64)
    return ((n1 - n2) / (n1 + n2)) ** 2


def ior_from_f0(f0: np.ndarray, n1: np.ndarray | float = 1.0) -> np.ndarray:
    """Inverse of ``f0_from_ior`` for a body in a medium n1: the root n2 > n1.

    n2 = n1 (1 + sqrt F0)/(1 - sqrt F0) (the other root, n1 (1 - sqrt F0)/(1 + sqrt F0),
    is the same F0 seen from inside: F0 does not tell the two sides apart).
    """
    s = np.sqrt(np.asarray(f0, np.float64))
    return np.asarray(n1, np.float64) * (1.0 + s) / (1.0 - s)


def f0_conductor(eta: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Normal-incidence reflectance of the index eta + i k: ((eta-1)^2 + k^2)/((eta+1)^2 + k^2)."""
    eta = np.asarray(eta, np.float64)
    k = np.asarray(k, np.float64)
    return ((eta - 1.0) ** 2 + k * k) / ((eta + 1.0) ** 2 + k * k)


def critical_cos(eta: np.ndarray) -> np.ndarray:
    """cos(theta_c) = sqrt(1 - eta^2) for internal reflection (eta < 1); 0 for eta >= 1."""
    eta = np.asarray(eta, np.float64)
    return np.sqrt(np.maximum((1.0 - eta) * (1.0 + eta), 0.0))


# --- Schlick against the exact equations -------------------------------------------------------

# The angle grid for the largest-error search: 0.001 degree steps, plus the critical angle
# itself where there is one (where the exact internal reflectance has its kink).
ANGLES_DEG = np.linspace(0.0, 90.0, 90001)


def fresnel_schlick_max_error(
    eta: np.ndarray,
    k: np.ndarray | None = None,
    angles_deg: np.ndarray = ANGLES_DEG,
    *,
    transmitted_cos: bool = True,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The largest |Schlick - exact| over the angle of incidence, per channel.

    ``eta`` (and ``k`` for a conductor) is the relative index, shape (C,). Schlick is given
    the exact F0 of that index (so only the shape of the curve is compared, not the choice
    of F0) and, for a dielectric, the cosine of ``cos_theta_schlick`` (the transmitted one
    for internal reflection), or the incident cosine if ``transmitted_cos`` is False (the
    naive use, to show what the transmitted cosine buys). Returns (max error (C,), angle
    of the maximum in degrees (C,), signed error there (C,)).
    """
    eta = np.atleast_1d(np.asarray(eta, np.float64))
    theta = np.asarray(angles_deg, np.float64)
    extra = np.degrees(np.arcsin(eta[eta < 1.0]))
    theta = np.unique(np.concatenate([theta, extra]))
    cos_i = np.cos(np.radians(theta))
    if k is None:
        exact = F_dielectric(eta[None, :], cos_i[:, None])
        F0 = f0_from_ior(eta)
        cos_s = (
            cos_theta_schlick(eta[None, :], cos_i[:, None]) if transmitted_cos else cos_i[:, None]
        )
        approx = F0 + (1.0 - F0) * pow5_one_minus(cos_s)
    else:
        k = np.atleast_1d(np.asarray(k, np.float64))
        exact = F_conductor(eta, k, cos_i)
        approx = F_schlick(f0_conductor(eta, k), cos_i)
    err = approx - exact
    i = np.argmax(np.abs(err), axis=0)
    cols = np.arange(len(eta))
    return np.abs(err[i, cols]), theta[i], err[i, cols]


# --- Generated tables for docs/fresnel.md ---------------------------------------------------------


def _fmt3(v: tuple[float, ...] | None, spec: str = ".4f") -> str:
    """One number if all channels agree, else a comma-separated triple; no '-0.0000'."""
    if v is None:
        return "-"

    def one(x: float) -> str:
        text = f"{x:{spec}}"
        return text.lstrip("+-") if float(text) == 0.0 else text

    if max(v) - min(v) == 0.0:
        return one(v[0])
    return ", ".join(one(x) for x in v)


def preset_markdown() -> str:
    """The preset table: seed F0, index, F0 from the index, difference (markdown)."""
    from app.scene.presets import preset_table

    lines = [
        "| preset | medium | kind | seed F0 | index (n, or n + ik for R, G, B) "
        "| F0 from index | difference | index source |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for row in preset_table():
        if row["ior"] is not None:
            index = f"{row['ior']:.4f}"
        elif row["eta"] is not None:
            index = "; ".join(
                f"{n:.3f} + {k:.3f}i" for n, k in zip(row["eta"], row["k"], strict=True)
            )
        else:
            index = "-"
        lines.append(
            f"| {row['name']} | {row['medium']} | {row['kind']} | {_fmt3(row['seed_f0'], '.4g')} "
            f"| {index} | {_fmt3(row['f0_index'], '.4g')} | {_fmt3(row['difference'], '+.4f')} "
            f"| {row['index_source']} |"
        )
    return "\n".join(lines)


def schlick_error_rows() -> list[dict]:
    """Schlick's largest error over angle for every preset with an index.

    Dielectrics: external reflection (from the medium into the body) and internal
    reflection (from inside the body out into the medium, eta = n_medium/n), the latter
    with Schlick given the transmitted cosine ("internal") and the incident one
    ("internal, cos_i"). Conductors: external only, per RGB channel.
    """
    from app.scene.presets import PRESETS

    rows = []
    for p in PRESETS.values():
        if p.ior is not None:
            cases = (
                ("external", p.ior / p.medium_ior, True),
                ("internal", p.medium_ior / p.ior, True),
                ("internal, cos_i", p.medium_ior / p.ior, False),
            )
            for case, eta, transmitted in cases:
                err, at, signed = fresnel_schlick_max_error(
                    np.array([eta]), transmitted_cos=transmitted
                )
                rows.append(
                    {
                        "name": p.name, "medium": p.medium, "case": case, "eta": (eta,),
                        "max_error": (float(err[0]),), "angle_deg": (float(at[0]),),
                        "signed": (float(signed[0]),),
                    }
                )  # fmt: skip
        elif p.eta is not None:
            eta = np.array(p.eta) / p.medium_ior
            k = np.array(p.k) / p.medium_ior
            err, at, signed = fresnel_schlick_max_error(eta, k)
            rows.append(
                {
                    "name": p.name, "medium": p.medium, "case": "conductor",
                    "eta": tuple(eta), "max_error": tuple(map(float, err)),
                    "angle_deg": tuple(map(float, at)), "signed": tuple(map(float, signed)),
                }
            )  # fmt: skip
    return rows


def schlick_markdown() -> str:
    """The Schlick-vs-exact table and a generated summary (markdown)."""
    rows = schlick_error_rows()
    lines = [
        "| preset | medium | case | relative index | max \\|Schlick - exact\\| "
        "| at angle (deg) | signed error there |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['name']} | {r['medium']} | {r['case']} | {_fmt3(r['eta'])} "
            f"| {_fmt3(r['max_error'])} | {_fmt3(r['angle_deg'], '.1f')} "
            f"| {_fmt3(r['signed'], '+.4f')} |"
        )

    def extreme(case: str, medium: str | None = None, pick=max) -> tuple[float, str, float]:
        found = [
            (e, f"{r['name']} ({r['medium']})", a)
            for r in rows
            if r["case"] == case and medium in (None, r["medium"])
            for e, a in zip(r["max_error"], r["angle_deg"], strict=True)
        ]
        return pick(found)

    def say(x: tuple[float, str, float]) -> str:
        return f"{x[0]:.4f} ({x[1]}, at {x[2]:.1f} deg)"

    by = {(r["name"], r["case"]): r["max_error"][0] for r in rows}
    stokes = max(abs(v - by[(n, "external")]) for (n, c), v in by.items() if c == "internal")
    outer = [
        (sign, angle)
        for r in rows
        if r["case"] in ("external", "conductor")
        for sign, angle in zip(r["signed"], r["angle_deg"], strict=True)
    ]
    over = sum(sign > 0.0 for sign, _ in outer)
    angles = [a for _, a in outer]
    lines += [
        "",
        f"Largest error for external reflection from air: {say(extreme('external', 'air'))}; "
        f"from water: {say(extreme('external', 'water'))}; conductors: "
        f"{say(extreme('conductor'))}. At {over} of the {len(outer)} external and conductor "
        f"maxima Schlick overestimates, and all lie between {min(angles):.1f} and "
        f"{max(angles):.1f} degrees: near grazing the exact curve is still held down by the "
        "p-polarised reflectance (0 at Brewster's angle), which Schlick's single power "
        "does not model. For dielectrics the error is smallest near n = 1.6-1.7 and grows "
        "toward diamond and, steeply, as the relative index approaches 1 (dielectrics in "
        "water), where the exact reflectance stays near F0 until close to grazing.",
        "",
        "For internal reflection Schlick with the transmitted cosine has the same largest "
        f"error as for external reflection (largest difference {stokes:.1e}): the exact "
        "and the approximate curve are both reciprocal, F(eta, cos_i) = F(1/eta, cos_t). "
        "With the incident cosine instead, Schlick misses total internal reflection: "
        f"error at least {say(extreme('internal, cos_i', pick=min))}.",
    ]
    return "\n".join(lines)


def generated_markdown() -> str:
    """Everything between the GENERATED markers of docs/fresnel.md."""
    from app.scene.presets import WAVELENGTHS_NM

    nm = ", ".join(f"{w:g}" for w in WAVELENGTHS_NM)
    return "\n".join(
        [
            "### Presets: seed F0 against the F0 of the index",
            "",
            f"Metals and silicon: n + ik interpolated linearly at {nm} nm (R, G, B). "
            'Dielectrics: one real index. "in water" rows use the relative index '
            "n / 1.33 (and k / 1.33); rows without a seed F0 are derived from the index.",
            "",
            preset_markdown(),
            "",
            "### Schlick against the exact Fresnel equations",
            "",
            "Largest |F_schlick(F0, cos) - F_exact(cos)| over 0-90 degrees in 0.001 degree "
            "steps (plus the critical angle), with F0 = F_exact(1); internal reflection "
            "passes Schlick the transmitted cosine (`cos_theta_schlick`).",
            "",
            schlick_markdown(),
        ]
    )


if __name__ == "__main__":
    print(generated_markdown())
