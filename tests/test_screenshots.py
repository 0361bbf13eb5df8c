"""Every scene renders as its checked-in screenshot (perceptual comparison with FLIP).

A screenshot is regenerated with ``bash scripts/dev.sh shots`` and looked at before it
is committed; this test catches unintended changes to what the scenes look like.
"""

from __future__ import annotations

import flip_evaluator as flip
import numpy as np
import pytest
from PIL import Image

from app.screenshots import SHOTS, render_scene, scene_files

MAX_MEAN_FLIP = 0.02


def test_every_scene_has_a_screenshot():
    missing = [p.stem for p in scene_files() if not (SHOTS / f"{p.stem}.png").is_file()]
    assert not missing


@pytest.mark.parametrize("path", scene_files(), ids=lambda p: p.stem)
def test_scene_matches_its_screenshot(gl_egl, path):
    shot = np.asarray(Image.open(SHOTS / f"{path.stem}.png").convert("RGB"))
    assert shot.std() > 2.0, "the screenshot is flat"
    image = render_scene(gl_egl, path)
    assert image.shape == shot.shape
    reference = shot.astype(np.float32) / 255.0
    test = image.astype(np.float32) / 255.0
    _, mean_flip, _ = flip.evaluate(reference, test, "LDR")
    assert mean_flip <= MAX_MEAN_FLIP, f"mean FLIP {mean_flip:.4f}"


def test_flip_sees_a_changed_image(gl_egl):
    """The comparison can fail: a darkened render is far from its screenshot."""
    path = scene_files()[0]
    shot = np.asarray(Image.open(SHOTS / f"{path.stem}.png").convert("RGB"))
    darker = (render_scene(gl_egl, path).astype(np.float32) * 0.6) / 255.0
    _, mean_flip, _ = flip.evaluate(shot.astype(np.float32) / 255.0, darker, "LDR")
    assert mean_flip > MAX_MEAN_FLIP
