"""``app.brdf.evaluate`` on its default context keeps working after other contexts come
and go in the process (a test module's fixture, a renderer's): it makes its context
current for the call. Without that, CI's test_diffraction probe failed with "cannot
create program" in a worker where another context had been created and released.

The check runs in a child process: releasing a context here would leave this worker's
other contexts (module fixtures of interleaved test modules) not current, which is the
very failure it guards against, in tests it has nothing to do with. EGL only: after an
OSMesa context is destroyed, making the EGL context current again is not enough (not
fixed; the default context is EGL wherever EGL works)."""

from __future__ import annotations

import subprocess
import sys

from tests.conftest import REPO

CHILD = """
import numpy as np
from app.brdf import evaluate
from app.gl.context import create_context
material = {"preset": "gold", "roughness": 0.3}
l, v = np.array([[0.0, 0.6, 0.8]]), np.array([[0.0, -0.6, 0.8]])
before = evaluate(material, l, v, backend="glsl")
other = create_context("egl")
other.release()
after = evaluate(material, l, v, backend="glsl")
assert np.array_equal(before, after) and before.max() > 0.0
print("ok")
"""


def test_default_context_survives_another_context_released():
    done = subprocess.run([sys.executable, "-c", CHILD], cwd=REPO, capture_output=True,
                          text=True, timeout=120)  # fmt: skip
    assert done.returncode == 0 and done.stdout.strip() == "ok", done.stderr[-2000:]
