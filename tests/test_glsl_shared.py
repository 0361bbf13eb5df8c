"""The constants GLSL shares with Python are written once (app/common) and reach every
program with the Python values: a program reads back each generated name, and no GLSL
file defines one of them itself."""

from __future__ import annotations

import re

import numpy as np

from app.common.glsl import shared_defines
from app.common.lights import LightType
from app.common.models import BRDF_TERMS, DIFFUSE_MODELS, G2_MODELS, NDF_MODELS, Model
from app.common.tonemaps import TONEMAPS
from app.gl.kernel import run_kernel
from app.resources import glsl_dir


def test_every_shared_constant_reads_back_with_its_python_value(gl_egl) -> None:
    """Each generated name, read in GLSL four at a time, has the value Python gives it."""
    names = list(shared_defines())
    values = []
    for start in range(0, len(names), 4):
        chunk = names[start : start + 4]
        chunk += [chunk[0]] * (4 - len(chunk))
        body = f"result = vec4({', '.join(chunk)});"
        out = run_kernel(gl_egl.ctx, [], body, {"unused": np.zeros(1)})
        values += list(out[0, : len(names) - start])
    assert values == [float(shared_defines()[n]) for n in names]


def test_the_names_follow_the_python_definitions() -> None:
    d = shared_defines()
    assert d["NDF_BECKMANN"] == NDF_MODELS.index("beckmann")
    assert d["G2_HAMMON"] == G2_MODELS.index("hammon")
    assert d["DIFFUSE_BURLEY_RENORMALIZED"] == DIFFUSE_MODELS.index("burley_renormalized")
    assert d["LIGHT_SPOT"] == LightType.SPOT
    assert d["TONEMAP_REINHARD"] == TONEMAPS.index("reinhard")
    assert d["TERM_SPECULAR"] | d["TERM_DIFFUSE"] == BRDF_TERMS["all"]
    # A model's defines select by these very names (glsl/brdf/model.glsl).
    assert Model(ndf="gtr").defines()["NDF_MODEL"] == d["NDF_GTR"]


def test_no_glsl_file_writes_a_shared_constant() -> None:
    """A ``#define`` or ``const`` of a shared name in glsl/ would be a second definition."""
    names = "|".join(shared_defines())
    pattern = re.compile(rf"^\s*(?:#define|const\s+\w+)\s+({names})\b", re.M)
    found = [
        f"{path.relative_to(glsl_dir())}: {m.group(1)}"
        for path in sorted(glsl_dir().rglob("*"))
        if path.is_file()
        for m in pattern.finditer(path.read_text(encoding="utf-8"))
    ]
    assert not found, found
