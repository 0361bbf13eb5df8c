"""The generated part of docs/fresnel.md: every preset's F0 against the F0 of its index, and
Schlick's largest error against the exact Fresnel equations (RTR4 §9.5).

    .venv/bin/python scripts/fresnel_tables.py

prints the markdown that belongs between the GENERATED markers of docs/fresnel.md;
tests/test_fresnel.py checks that the document carries the current output.
"""

from __future__ import annotations

import numpy as np

from app.reference.fresnel import fresnel_schlick_max_error
from app.scene.presets import PRESETS, WAVELENGTHS_NM, preset_table


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
    """The preset table: RTR4 F0, index, F0 from the index, difference (markdown)."""
    lines = [
        "| preset | medium | kind | RTR4 F0 | index (n, or n + ik for R, G, B) "
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
            f"| {row['name']} | {row['medium']} | {row['kind']} | {_fmt3(row['rtr4_f0'], '.4g')} "
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
    nm = ", ".join(f"{w:g}" for w in WAVELENGTHS_NM)
    return "\n".join(
        [
            "### Presets: RTR4 F0 against the F0 of the index",
            "",
            f"Metals and silicon: n + ik interpolated linearly at {nm} nm (R, G, B). "
            'Dielectrics: one real index. "in water" rows use the relative index '
            "n / 1.33 (and k / 1.33); rows without an RTR4 F0 are derived from the index.",
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
