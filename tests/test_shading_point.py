"""The shading point is one contract in two languages: the GLSL struct ``ShadingPoint``
(glsl/brdf/material.glsl) and its twin, the frozen dataclass
``app.reference.material.ShadingPoint``, have the same fields in the same order, and the
composition layer takes it whole in both."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

from app.common.models import DEFAULT_MODEL, ModelParams
from app.reference.material import ShadingPoint, Surface, brdf_eval, brdf_standard
from app.resources import glsl_dir


def glsl_struct_fields(source: str, name: str) -> list[str]:
    """The field names of ``struct name { ... };`` in GLSL source, in order."""
    body = re.search(r"struct\s+" + name + r"\s*\{(.*?)\};", source, re.S)
    assert body is not None, f"no struct {name}"
    code = re.sub(r"//[^\n]*", "", body.group(1))
    return [re.split(r"\s+", decl.strip())[-1] for decl in code.split(";") if decl.strip()]


def test_the_twin_has_the_glsl_struct_fields_in_order() -> None:
    source = (glsl_dir() / "brdf" / "material.glsl").read_text()
    twin = [f.name for f in dataclasses.fields(ShadingPoint)]
    assert glsl_struct_fields(source, "ShadingPoint") == twin


def test_the_twin_is_a_value() -> None:
    """Frozen, as the GLSL struct is passed by value: a function that changes a field (the
    clear coat's base, clearcoat_base_point) makes a new point."""
    point = ShadingPoint(
        Surface(np.array([0.5, 0.5, 0.5]), 0.0, 0.5, 0.04), ModelParams(),
        np.array([0.0, 0.0, 1.0]), None, np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]),
    )  # fmt: skip
    with pytest.raises(dataclasses.FrozenInstanceError):
        point.v = np.array([1.0, 0.0, 0.0])  # type: ignore[misc]


def test_points_broadcast_over_arrays() -> None:
    """One ShadingPoint of k points gives the k values of k single points."""
    rng = np.random.default_rng(7)
    v = rng.normal(size=(5, 3))
    v[:, 2] = np.abs(v[:, 2]) + 0.2
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    l = np.array([0.3, -0.2, 0.9]) / np.linalg.norm([0.3, -0.2, 0.9])
    s = Surface(np.array([0.8, 0.4, 0.2]), 0.0, 0.4, 0.04)
    n = np.array([0.0, 0.0, 1.0])
    many = brdf_eval(ShadingPoint(s, ModelParams(), n, None, n, v), DEFAULT_MODEL, l)
    one = [brdf_standard(s, n, l, vi) for vi in v]
    np.testing.assert_array_equal(many, np.array(one))
