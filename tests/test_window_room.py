"""The bundled HDR environment (app/assets/window_room.py) is what the generator makes,
and reads back through the scene's image path."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from app.assets.window_room import OUT, window_room, write
from app.textures.environment import read_environment_image


def test_bundled_exr_is_a_fresh_build(tmp_path: Path) -> None:
    fresh = read_environment_image(write(tmp_path / "room.exr"), "t", "environment.file")
    shipped = read_environment_image(OUT, "t", "environment.file")
    np.testing.assert_array_equal(shipped, fresh)
    # half floats: the room to 3 significant digits, the window 500 times the walls
    np.testing.assert_allclose(shipped, window_room(), rtol=1e-3)
    assert shipped.max() / np.median(shipped) > 400.0
