"""``app.brdf.evaluate`` on its default context keeps working after other contexts come
and go in the process (a test module's fixture, a renderer's): it makes its context
current for the call. Without that, CI's test_diffraction probe failed with "cannot
create program" in a worker where another context had been created and released."""

from __future__ import annotations

import numpy as np
import pytest

from app.brdf import evaluate
from app.gl.context import create_context

L = np.array([[0.0, 0.6, 0.8]])
V = np.array([[0.0, -0.6, 0.8]])


@pytest.mark.parametrize("backend", ["egl", "osmesa"])
def test_default_context_survives_another_context_released(backend):
    material = {"preset": "gold", "roughness": 0.3}
    before = evaluate(material, L, V, backend="glsl")
    other = create_context(backend)
    other.release()
    after = evaluate(material, L, V, backend="glsl")
    assert np.array_equal(before, after) and before.max() > 0.0
