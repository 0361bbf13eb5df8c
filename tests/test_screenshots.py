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
# A mean over the whole image misses a change confined to one sphere of a row (swapping
# one sphere's G2 or diffuse model gave a mean of 0.009-0.011 but 2.5-3% of pixels above
# FLIP 0.1); an unchanged scene has at most 2.5e-5 of its pixels there.
LOCAL_FLIP = 0.1
MAX_LOCAL_FRACTION = 0.005


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
    flip_map, mean_flip, _ = flip.evaluate(reference, test, "LDR")
    assert mean_flip <= MAX_MEAN_FLIP, f"mean FLIP {mean_flip:.4f}"
    local = float(np.mean(flip_map > LOCAL_FLIP))
    assert local <= MAX_LOCAL_FRACTION, f"{local:.2%} of pixels differ by FLIP > {LOCAL_FLIP}"


def test_flip_sees_a_changed_image(gl_egl):
    """The comparison can fail: a darkened render is far from its screenshot."""
    path = scene_files()[0]
    shot = np.asarray(Image.open(SHOTS / f"{path.stem}.png").convert("RGB"))
    darker = (render_scene(gl_egl, path).astype(np.float32) * 0.6) / 255.0
    _, mean_flip, _ = flip.evaluate(shot.astype(np.float32) / 255.0, darker, "LDR")
    assert mean_flip > MAX_MEAN_FLIP


def test_flip_sees_one_changed_sphere(gl_egl, tmp_path):
    """The local criterion catches what the mean misses: one sphere's diffuse model swapped."""
    source = (SHOTS.parent / "scenes" / "sec9_diffuse_retro.toml").read_text()
    changed = source.replace('"oren_nayar"', '"lambert"', 1)
    assert changed != source
    path = tmp_path / "sec9_diffuse_retro.toml"
    path.write_text(changed)
    shot = np.asarray(Image.open(SHOTS / f"{path.stem}.png").convert("RGB"))
    image = render_scene(gl_egl, path)
    flip_map, mean_flip, _ = flip.evaluate(
        shot.astype(np.float32) / 255.0, image.astype(np.float32) / 255.0, "LDR"
    )
    assert mean_flip <= MAX_MEAN_FLIP  # the mean alone would pass it
    assert np.mean(flip_map > LOCAL_FLIP) > MAX_LOCAL_FRACTION
